//! Logger process: subscribes to every topic without loss and writes the run's MCAP log, with
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

use anyhow::Context;
use ipc_types::*;
use std::collections::BTreeMap;
use std::io::BufWriter;
use testbed_can::transport::CandumpWriter;
use testbed_can::CanFrame;
use testbed_bus::{Bus, EventLoop, Flow, SourceId, SubscriberOptions, TopicSubscriber, Waiter};
use testbed_log::{LogEncode, LogRecord, RunInfo, RunLogWriter, WriterOptions};
use testbed_runtime::process::{self, FirstError, HEARTBEAT_PERIOD};
use testbed_runtime::ClockMode;

/// A subscriber whose samples go to the log, whatever their type.
trait LoggedTopic {
    fn attach<'a>(&'a self, events: &mut EventLoop<'_, 'a>) -> anyhow::Result<SourceId>;
    fn drain(&self, sink: &mut dyn FnMut(LogRecord)) -> anyhow::Result<usize>;
}

struct Logged<T: Topic>(TopicSubscriber<T>);

impl<T: Topic + LogEncode> LoggedTopic for Logged<T> {
    fn attach<'a>(&'a self, events: &mut EventLoop<'_, 'a>) -> anyhow::Result<SourceId> {
        Ok(events.on_data(&self.0)?)
    }
    fn drain(&self, sink: &mut dyn FnMut(LogRecord)) -> anyhow::Result<usize> {
        Ok(self.0.drain(|s| sink(s.into_record()))?)
    }
}

fn logged<T: Topic + LogEncode + 'static>(bus: &Bus) -> anyhow::Result<Box<dyn LoggedTopic>> {
    // Deep buffers absorb bursts; in lockstep, publishers wait rather than drop when full.
    Ok(Box::new(Logged(bus.subscriber_with::<T>(SubscriberOptions::buffer(256))?)))
}

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("logger")?;
    let lockstep = config.run.mode == ClockMode::Lockstep;
    let mut topics: Vec<Box<dyn LoggedTopic>> = vec![
        logged::<SimClockTick>(&bus)?,
        logged::<SimTruth>(&bus)?,
        logged::<GyroSample>(&bus)?,
        logged::<InclinometerSample>(&bus)?,
        logged::<MagnetometerSample>(&bus)?,
        logged::<WheelTelemetry>(&bus)?,
        logged::<CmgTelemetry>(&bus)?,
        logged::<AttitudeEstimate>(&bus)?,
        logged::<ControllerStatus>(&bus)?,
        logged::<WheelCommand>(&bus)?,
        logged::<CmgCommand>(&bus)?,
        logged::<CanBusFrame>(&bus)?,
        logged::<CanLinkStatus>(&bus)?,
        logged::<AppliedWheelCommand>(&bus)?,
        logged::<AppliedCmgCommand>(&bus)?,
    ];
    if !lockstep {
        topics.push(logged::<Heartbeat>(&bus)?);
    }
    let info = RunInfo {
        profile: config.run.profile.clone(),
        seed: config.run.seed,
        mode: if lockstep { "lockstep" } else { "paced" }.to_string(),
        config_toml: config.to_toml_string(),
        extra: Default::default(),
    };
    let path = &config.run.log;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let options = if lockstep { WriterOptions::lockstep() } else { WriterOptions::default() };
    let mut writer = RunLogWriter::create_with(path, &info, options).with_context(|| format!("creating the log {}", path.display()))?;
    let mut candump = match config.can.record_candump {
        true => Some(BusRecording::create(&path.with_extension("candump.log"), &config.can.interface)?),
        false => None,
    };
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;

    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    for topic in &topics {
        topic.attach(&mut events)?;
    }
    events.with_heartbeat(&heartbeat)?;
    heartbeat.set_state(ProcessState::Running);

    let mut error = FirstError::default();
    let write_pass = |writer: &mut RunLogWriter, candump: &mut Option<BusRecording>| -> anyhow::Result<Option<u64>> {
        let mut newest_tick = None;
        let mut failure = None;
        for topic in &topics {
            topic.drain(&mut |record| {
                if let LogRecord::SimClock(tick) = &record {
                    newest_tick = Some(tick.header.time_ns);
                }
                heartbeat.add_samples_in(1);
                if let (LogRecord::CanBus(frame), Some(candump)) = (&record, candump.as_mut()) {
                    candump.push(*frame);
                }
                if let Err(e) = writer.write_record(&record) {
                    failure.get_or_insert(e);
                }
            })?;
        }
        failure.map_or(Ok(newest_tick), |e| Err(e.into()))
    };
    events.run(|_| {
        let result = write_pass(&mut writer, &mut candump).and_then(|tick| match tick {
            // Everything published before tick k's clock sample is queued by now; one more pass
            // collects what landed in subscribers drained before the clock's.
            Some(t_ns) if lockstep && t_ns > 0 => {
                write_pass(&mut writer, &mut candump)?;
                writer.complete_until(t_ns - 1)?;
                candump.as_mut().map_or(Ok(()), |c| c.write_until(t_ns - 1))
            }
            _ => {
                if !lockstep {
                    candump.as_mut().map_or(Ok(()), |c| c.write_until(u64::MAX))?;
                }
                Ok(writer.flush()?)
            }
        });
        if error.failed(result) { Flow::Stop } else { Flow::Continue }
    })?;
    heartbeat.set_state(ProcessState::Stopping);
    let last = write_pass(&mut writer, &mut candump);
    let stats = writer.finish().with_context(|| format!("finalising the log {}", path.display()))?;
    tracing::info!(log = %path.display(), ?stats, "log finalised");
    if let Some(candump) = candump {
        candump.finish()?;
    }
    error.into_result().and(last.map(|_| ()))
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
        let file = std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
        let writer = CandumpWriter::new(BufWriter::new(file), iface).with_context(|| format!("can.interface for {}", path.display()))?;
        Ok(Self { path: path.to_path_buf(), writer, pending: BTreeMap::new(), written: 0, corrupted: 0 })
    }

    fn push(&mut self, frame: CanBusFrame) {
        let h = frame.header;
        self.pending.insert((h.time_ns, h.source_id, h.sequence), frame);
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
                    self.writer.write(sample.header.time_ns, &frame).with_context(|| format!("writing {}", self.path.display()))?;
                    self.written += 1;
                }
                Err(_) => self.corrupted += 1,
            }
        }
        Ok(())
    }

    fn finish(mut self) -> anyhow::Result<()> {
        self.write_until(u64::MAX)?;
        self.writer.flush().with_context(|| format!("writing {}", self.path.display()))?;
        tracing::info!(candump = %self.path.display(), frames = self.written, corrupted_left_out = self.corrupted, "bus recording finalised");
        Ok(())
    }
}
