//! The logger process: subscribes to every topic without loss and writes the run's MCAP log, with
//! the run configuration attached. In lockstep it writes each tick's records sorted once the
//! next tick shows the tick complete, so two runs with the same seed give identical bytes
//! (heartbeats, which carry pids, are left out there). On SIGINT/SIGTERM it drains what is
//! queued and finalises the file; killed outright, every record written so far stays readable.
//!
//! With `can.record_candump`, the software CAN bus's frames also go to `<log>.candump.log` as
//! `candump -L` lines (can-utils reads them: `canplayer`, `log2asc`), time-stamped with the run
//! clock and, in lockstep, ordered per tick by (time, sender, sender's sequence) so the file is
//! as reproducible as the log. Frames whose frame check fails (corrupted on the bus) are left
//! out, as `candump` never sees a frame that failed its CRC.
//!
//! A logger restarted by the launcher (paced runs) never truncates: it writes the segment
//! `<log stem>.segment-<n>.mcap` ([`segment_path`]), and `testbed run` summarises them all.
//!
//! With `can.link = "socketcan"` the recording is of the interface itself, as `candump -L`
//! makes it: a raw socket without filters, every frame in the kernel's order with its kernel
//! receive time stamp (the run's frames and anything else on the bus).

use anyhow::Context as _;
use ipc_types::ClockMode;
use ipc_types::*;
use std::collections::BTreeMap;
use std::io::BufWriter;
use testbed_bus::{AnySubscribers, Flow, LoopExit, SubscriberOptions, Wake};
use testbed_can::transport::{CandumpWriter, SocketCanTransport};
use testbed_can::{CanFrame, CanTransport};
use testbed_config::CanLink;
use testbed_log::{LogRecord, RunInfo, RunLogWriter, WriterOptions};
use testbed_runtime::{Context, Io, Node, WakeOn};

/// The longest a paced logger waits between two drains: while every topic is slow (the
/// simulation's fastest topics are 10 Hz, its heartbeats some 20 a second in all). Paced, it
/// wakes on an interval rather than on every sample: each wake-up costs a timer wake-up, a look
/// at all 22 subscribers and a `write` of the log whatever it carries, and one per sample (some
/// 150 per second, most alone) was the largest CPU cost of the paced pipeline; at
/// 250 ms its wake-ups were still half of its CPU (measured: `bench/README.md`, "The paced
/// logger drains once a second"). It is the runtime's
/// [`QUIET_PERIOD`](testbed_runtime::process::QUIET_PERIOD) (700 ms): the logger's heartbeat
/// goes out with every drain, where a 1-s drain woke it once more a second for the heartbeat
/// alone. A logger killed outright loses at most the records of the last period; a stopped one
/// loses nothing (it drains everything before it closes the log).
/// That is within what a crash of the machine loses anyway: the log is written, not synced, and
/// the kernel writes dirty pages back after 5–30 s.
pub const PACED_DRAIN_PERIOD: std::time::Duration = testbed_runtime::process::QUIET_PERIOD;

/// The shortest a paced logger waits between two drains, for a fast topic (a software CAN bus):
/// [`DRAIN_TARGET`] samples a period is 640 a second; a topic four times faster fills its
/// buffer.
pub const BUSY_DRAIN_PERIOD: std::time::Duration = std::time::Duration::from_millis(100);

/// How many samples of its fastest topic a paced drain should take: a quarter of a buffer, so a
/// topic fills its buffer between two drains only if its rate jumps fourfold at once.
const DRAIN_TARGET: usize = LOGGED_BUFFER / 4;

/// The paced drain period after a drain that took `most` samples of its fastest topic in
/// `elapsed` since the drain before: the period in which that rate brings [`DRAIN_TARGET`]
/// samples, from [`BUSY_DRAIN_PERIOD`] to [`PACED_DRAIN_PERIOD`].
pub fn paced_drain_period(most: usize, elapsed: std::time::Duration) -> std::time::Duration {
    if most == 0 {
        return PACED_DRAIN_PERIOD;
    }
    elapsed
        .mul_f64(DRAIN_TARGET as f64 / most as f64)
        .clamp(BUSY_DRAIN_PERIOD, PACED_DRAIN_PERIOD)
}

/// Samples each logged topic's subscriber holds.
const LOGGED_BUFFER: usize = 256;

/// How often a lockstep logger drains its subscribers (wall time). Lockstep runs as fast as the
/// machine allows, and a logger woken for every tick (or every sample) took a third of the
/// pipeline's CPU on two cores, on the cores the tick's own chain needs. Drained every
/// millisecond, it takes the records of several ticks per wake-up: at 1000× real time ten
/// ticks, some 15 samples a topic (a CAN bus topic some 150 frames), within the 256 of the
/// buffers, so a lossless publisher does not wait for it. The order of the file does not
/// depend on when it drains (see `on_wake`).
pub const LOCKSTEP_DRAIN_PERIOD: std::time::Duration = std::time::Duration::from_millis(1);

/// The logger's ports: one subscriber per logged topic.
pub struct LoggerPorts {
    topics: AnySubscribers<LogRecord>,
    /// The paced drain interval's period ([`paced_drain_period`]; [`BUSY_DRAIN_PERIOD`] until the
    /// first drain).
    drain_period: std::cell::Cell<std::time::Duration>,
}

/// The logger process: the log writer and the CAN recording.
pub struct LoggerProcess {
    lockstep: bool,
    path: std::path::PathBuf,
    writer: Option<RunLogWriter>,
    candump: Option<BusRecording>,
    /// The clock tick before the newest one seen (lockstep ordering).
    previous_tick_ns: Option<u64>,
    /// The SocketCAN recording (`can.link = "socketcan"` with `can.record_candump`).
    interface: Option<InterfaceRecording>,
    /// When the last paced drain was (the rate of the fastest topic since then sets the next).
    last_drain: Option<std::time::Instant>,
    /// The latest run-clock time of the samples logged (heartbeats aside): the time the
    /// logger's heartbeat reports.
    latest_ns: u64,
}

impl LoggerProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, LoggerPorts)> {
        let (config, bus) = (cx.config, cx.bus);
        let lockstep = config.run.mode == ClockMode::Lockstep;
        // Every topic of the table, but heartbeats in lockstep: they carry pids and wall
        // times, and a lockstep log is reproducible. Deep buffers absorb bursts (in lockstep,
        // publishers wait rather than drop when full); drained on `LOCKSTEP_DRAIN_PERIOD` or
        // `paced_drain_period` and never woken for, a subscriber rings no doorbell, so a
        // publish to the logger costs its publisher no system call.
        let topics = bus
            .subscribe_each(SubscriberOptions::buffer(LOGGED_BUFFER).polled(), |topic| {
                !(lockstep && topic == TopicId::Heartbeat)
            })?;
        let info = RunInfo {
            profile: config.run.profile.clone(),
            seed: config.run.seed,
            mode: if lockstep { "lockstep" } else { "paced" }.to_string(),
            config_toml: config.to_toml_string(),
            start_time_ns: config
                .run
                .start_time_ns
                .unwrap_or_else(testbed_log::unix_time_ns),
            extra: Default::default(),
        };
        let path = segment_path(&config.run.log, ipc_types::restart_count());
        if path != config.run.log {
            tracing::warn!(
                "restarted: logging to the new segment {} ({} keeps what was logged before)",
                path.display(),
                config.run.log.display()
            );
        }
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        let options = if lockstep {
            WriterOptions::lockstep()
        } else {
            WriterOptions::default()
        };
        let mut writer = RunLogWriter::create_with(&path, &info, options)
            .with_context(|| format!("creating the log {}", path.display()))?;
        writer.set_scene(crate::scene::platform_scene(&config.model, "body"));
        let candump_path = path.with_extension("candump.log");
        let (candump, interface) = match (config.can.record_candump, config.can.link) {
            (true, CanLink::Socketcan) => (
                None,
                Some(InterfaceRecording::open(
                    &candump_path,
                    &config.can.interface,
                )?),
            ),
            (true, _) => (
                Some(BusRecording::create(&candump_path, &config.can.interface)?),
                None,
            ),
            (false, _) => (None, None),
        };
        Ok((
            Self {
                lockstep,
                path,
                writer: Some(writer),
                candump,
                previous_tick_ns: None,
                interface,
                last_drain: None,
                latest_ns: 0,
            },
            LoggerPorts {
                topics,
                drain_period: std::cell::Cell::new(BUSY_DRAIN_PERIOD),
            },
        ))
    }

    /// Writes every queued sample; the time of the newest clock tick among them, if any, and
    /// the most samples taken from one topic.
    fn write_pass(&mut self, ports: &LoggerPorts, io: &Io) -> anyhow::Result<(Option<u64>, usize)> {
        let writer = self
            .writer
            .as_mut()
            .context("the log is already finalised")?;
        let candump = &mut self.candump;
        let mut newest_tick = None;
        let mut failure = None;
        let mut most = 0;
        let latest_ns = &mut self.latest_ns;
        for topic in &ports.topics {
            let taken = topic.drain_as(&mut |record| {
                if let LogRecord::SimClock(tick) = &record {
                    newest_tick = Some(tick.header.time_ns);
                }
                // Other processes' heartbeats carry their own times; the logger's own
                // heartbeat is stamped with the newest sample it logged, so it sits among the
                // records of its time in the log rather than at the run's start.
                if !matches!(record, LogRecord::Heartbeat(_)) {
                    *latest_ns = (*latest_ns).max(record.header().time_ns);
                }
                io.heartbeat.add_samples_in(1);
                if let (LogRecord::CanBus(frame), Some(candump)) = (&record, candump.as_mut()) {
                    candump.push(*frame);
                }
                if let Err(e) = writer.write_record(&record) {
                    failure.get_or_insert(e);
                }
            })?;
            most = most.max(taken);
        }
        io.heartbeat.set_time_ns(self.latest_ns);
        failure.map_or(Ok((newest_tick, most)), |e| Err(e.into()))
    }
}

impl Node for LoggerProcess {
    type Ports = LoggerPorts;

    fn wake_on<'a>(
        &mut self,
        ports: &'a LoggerPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        if self.lockstep {
            wake.interval(LOCKSTEP_DRAIN_PERIOD)?;
        } else {
            wake.variable_interval(&ports.drain_period)?;
        }
        if self.interface.is_some() {
            wake.interval(crate::can_gateway::POLL_PERIOD)?;
        }
        Ok(())
    }

    fn on_wake(&mut self, ports: &LoggerPorts, _wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        if let Some(recording) = self.interface.as_mut() {
            recording.drain()?;
        }
        let (newest_tick, most) = self.write_pass(ports, io)?;
        if !self.lockstep {
            let now = std::time::Instant::now();
            let elapsed =
                now.saturating_duration_since(self.last_drain.replace(now).unwrap_or(now));
            // The first drain has no rate to go by: it keeps the busy period.
            if !elapsed.is_zero() {
                ports.drain_period.set(paced_drain_period(most, elapsed));
            }
        }
        match newest_tick {
            // Everything published before tick k's clock sample is queued by now; one more pass
            // collects what landed in subscribers drained before the clock's.
            Some(t_ns) if self.lockstep && t_ns > 0 => {
                self.write_pass(ports, io)?;
                // Tick k's clock completes tick k−2, not k−1: a process need not have finished
                // publishing tick k−1 when the plant starts tick k (a CAN gateway's status, a
                // frame no one waits for), but every process takes part in tick k, and each
                // handles its ticks in order, so nothing of tick k−2 can still come once tick
                // k has started. The order of the file does not depend on the load.
                if let Some(done) = self.previous_tick_ns.filter(|&p| p > 0) {
                    if let Some(writer) = self.writer.as_mut() {
                        writer.complete_until(done - 1)?;
                    }
                    if let Some(c) = self.candump.as_mut() {
                        c.write_until(done - 1)?;
                    }
                }
                self.previous_tick_ns = Some(t_ns);
            }
            _ => {
                if !self.lockstep
                    && let Some(c) = self.candump.as_mut()
                {
                    c.write_until(u64::MAX)?;
                }
                if let Some(writer) = self.writer.as_mut() {
                    writer.flush()?;
                }
            }
        }
        Ok(Flow::Continue)
    }

    fn stop(&mut self, ports: &LoggerPorts, io: &Io, _exit: LoopExit) -> anyhow::Result<()> {
        let last = self.write_pass(ports, io);
        let writer = self.writer.take().context("the log is already finalised")?;
        let stats = writer
            .finish()
            .with_context(|| format!("finalising the log {}", self.path.display()))?;
        tracing::info!(log = %self.path.display(), ?stats, "log finalised");
        if stats.late_records > 0 {
            tracing::warn!(
                late_records = stats.late_records,
                "records arrived after their tick was written: logged out of time order"
            );
        }
        if let Some(candump) = self.candump.take() {
            candump.finish()?;
        }
        if let Some(recording) = self.interface.take() {
            recording.finish()?;
        }
        last.map(|_| ())
    }
}

/// Where the log goes: the run's log, or after the logger's `n`-th restart in the run its
/// `n`-th segment `<stem>.segment-<n>.mcap` beside it, so a restart never truncates what was
/// logged before.
pub fn segment_path(log: &std::path::Path, restarts: u32) -> std::path::PathBuf {
    if restarts == 0 {
        return log.to_path_buf();
    }
    let stem = log.file_stem().unwrap_or_default().to_string_lossy();
    let ext = log
        .extension()
        .map_or(String::new(), |e| format!(".{}", e.to_string_lossy()));
    log.with_file_name(format!("{stem}.segment-{restarts}{ext}"))
}

/// A new `candump -L` file at `path` of the frames of `iface`.
fn candump_file(
    path: &std::path::Path,
    iface: &str,
) -> anyhow::Result<CandumpWriter<BufWriter<std::fs::File>>> {
    let file =
        std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    CandumpWriter::new(BufWriter::new(file), iface)
        .with_context(|| format!("can.interface for {}", path.display()))
}

/// The software CAN bus written as a `candump -L` file.
struct BusRecording {
    path: std::path::PathBuf,
    writer: CandumpWriter<BufWriter<std::fs::File>>,
    /// Frames not yet written, by (time, sender, sender's sequence).
    pending: BTreeMap<(u64, u32, u64), CanBusFrame>,
    written: u64,
    corrupted: u64,
}

impl BusRecording {
    fn create(path: &std::path::Path, iface: &str) -> anyhow::Result<Self> {
        Ok(Self {
            path: path.to_path_buf(),
            writer: candump_file(path, iface)?,
            pending: BTreeMap::new(),
            written: 0,
            corrupted: 0,
        })
    }

    fn push(&mut self, frame: CanBusFrame) {
        let h = frame.header;
        self.pending
            .insert((h.time_ns, h.source_id, h.sequence), frame);
    }

    /// Writes the frames sent at or before `t_ns`, in key order.
    fn write_until(&mut self, t_ns: u64) -> anyhow::Result<()> {
        while let Some(entry) = self.pending.first_entry() {
            if entry.key().0 > t_ns {
                break;
            }
            let sample = entry.remove();
            match CanFrame::from_bus_frame(&sample) {
                Ok(frame) => {
                    self.writer
                        .write(sample.header.time_ns, &frame)
                        .with_context(|| format!("writing {}", self.path.display()))?;
                    self.written += 1;
                }
                Err(_) => self.corrupted += 1,
            }
        }
        Ok(())
    }

    fn finish(mut self) -> anyhow::Result<()> {
        self.write_until(u64::MAX)?;
        self.writer
            .flush()
            .with_context(|| format!("writing {}", self.path.display()))?;
        tracing::info!(candump = %self.path.display(), frames = self.written, corrupted_left_out = self.corrupted, "bus recording finalised");
        Ok(())
    }
}

/// Receive queue the interface recording asks for, bytes (capped by `net.core.rmem_max`).
const RECORDING_QUEUE_BYTES: usize = 8 << 20;

/// A SocketCAN interface written as a `candump -L` file, as `candump -L IFACE` writes it.
struct InterfaceRecording {
    path: std::path::PathBuf,
    socket: SocketCanTransport,
    writer: CandumpWriter<BufWriter<std::fs::File>>,
    written: u64,
    receive_errors: u64,
}

impl InterfaceRecording {
    fn open(path: &std::path::Path, iface: &str) -> anyhow::Result<Self> {
        // Opened before any other process of the run starts (the logger starts first), so the
        // recording holds every frame of the run.
        let mut socket = SocketCanTransport::open(iface)
            .with_context(|| format!("recording can.interface = {iface:?}"))?;
        // The logger reads the whole bus between its other work: a deep queue rides out a
        // burst (what does not fit is counted, see `finish`).
        let granted = socket
            .set_receive_buffer(RECORDING_QUEUE_BYTES)
            .with_context(|| format!("recording can.interface = {iface:?}"))?;
        tracing::debug!(granted, "receive queue of the {iface} recording");
        Ok(Self {
            path: path.to_path_buf(),
            socket,
            writer: candump_file(path, iface)?,
            written: 0,
            receive_errors: 0,
        })
    }

    /// Writes every frame the socket holds.
    fn drain(&mut self) -> anyhow::Result<()> {
        loop {
            match self.socket.recv(std::time::Duration::ZERO) {
                Ok(Some(frame)) => {
                    self.writer
                        .write(frame.time_ns, &frame.frame)
                        .with_context(|| format!("writing {}", self.path.display()))?;
                    self.written += 1;
                }
                Ok(None) => return Ok(()),
                Err(e) => {
                    // The interface going down reports ENETDOWN once; the recording goes on
                    // when it is back.
                    self.receive_errors += 1;
                    tracing::warn!("recording {}: {e}", self.socket.iface());
                    return Ok(());
                }
            }
        }
    }

    fn finish(mut self) -> anyhow::Result<()> {
        self.drain()?;
        self.writer
            .flush()
            .with_context(|| format!("writing {}", self.path.display()))?;
        let drops = self.socket.queue_drops();
        if drops > 0 {
            // The recording misses frames: say how many (a flood the logger could not keep up with).
            tracing::warn!(
                "recording {}: {drops} frames lost in the socket's receive queue; {} recorded",
                self.socket.iface(),
                self.written
            );
        }
        tracing::info!(candump = %self.path.display(), frames = self.written, queue_drops = drops, receive_errors = self.receive_errors, "interface recording finalised");
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;
    use std::time::Duration;

    #[test]
    fn the_paced_drain_period_takes_a_quarter_buffer_of_the_fastest_topic() {
        // The simulation: 10 Hz topics and ~20 heartbeats a second, drained after 1 s.
        assert_eq!(
            paced_drain_period(22, Duration::from_secs(1)),
            PACED_DRAIN_PERIOD
        );
        // Nothing came: the longest period.
        assert_eq!(
            paced_drain_period(0, Duration::from_millis(100)),
            PACED_DRAIN_PERIOD
        );
        // 128 samples a second: a quarter buffer (64) every half second.
        assert_eq!(
            paced_drain_period(128, Duration::from_secs(1)),
            Duration::from_millis(500)
        );
        // A software CAN bus, 2000 frames a second: the shortest period, 200 a drain, under the
        // 256 of the buffer.
        let busy = paced_drain_period(200, Duration::from_millis(100));
        assert_eq!(busy, BUSY_DRAIN_PERIOD);
        assert!(2000.0 * busy.as_secs_f64() < LOGGED_BUFFER as f64);
        // Slowing down, the period lengthens with the rate.
        assert_eq!(
            paced_drain_period(16, Duration::from_millis(100)),
            Duration::from_millis(400)
        );
    }

    #[test]
    fn a_restarted_logger_writes_a_new_segment_beside_the_log() {
        let log = Path::new("out/simulation.mcap");
        assert_eq!(segment_path(log, 0), log);
        assert_eq!(
            segment_path(log, 2),
            Path::new("out/simulation.segment-2.mcap")
        );
        assert_eq!(
            segment_path(Path::new("run"), 1),
            Path::new("run.segment-1")
        );
    }
}
