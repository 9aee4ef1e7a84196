//! The `can-replay` process: puts a recorded `candump -L` file (`can.candump`) back on the
//! software bus. In lockstep it owns the clock as the plant does: after the frames up to and
//! including a tick's sync it waits for the estimator's estimate of that tick before the next
//! (so the gateways and the estimator see the frames in the recorded order and grouping);
//! paced, it follows the file's time stamps. It stops at the end of the file.

use crate::can_gateway::POLL_PERIOD;
use crate::can_link::BUS_BUFFER;
use crate::software_bus::SoftwareBusTransport;
use anyhow::Context as _;
use ipc_types::ClockMode;
use ipc_types::{AttitudeEstimate, SampleHeader, can_source};
use std::fs::File;
use std::io::BufReader;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use testbed_bus::{Flow, LoopExit, TopicSubscriber, Wake};
use testbed_can::transport::CandumpReader;
use testbed_can::{Decoder, Device, DeviceSet, Message, NodeClock, TimestampedFrame};
use testbed_config::RunConfig;
use testbed_flight::schedule::Schedule;
use testbed_gateways::can_board;
use testbed_gateways::gateway::run_time_ns;
use testbed_runtime::{Context, Io, Node, WakeOn};

/// The replay's ports: the software CAN bus and the estimates that release each tick.
pub struct CanReplayPorts {
    link: SoftwareBusTransport,
    estimates: TopicSubscriber<AttitudeEstimate>,
}

/// The replay of one candump file.
pub struct CanReplayProcess {
    path: PathBuf,
    reader: CandumpReader<BufReader<File>>,
    schedule: Schedule,
    sync_decoder: Decoder,
    clock: NodeClock,
    lockstep: bool,
    /// Whether the estimator answers every tick (lockstep with an estimator in the run).
    answered_by_estimator: bool,
    started: Instant,
    first_ns: Option<u64>,
    newest_estimate: Option<u64>,
    waiting_for: Option<u64>,
    pending: Option<TimestampedFrame>,
    ticks: u64,
    finished: bool,
}

impl CanReplayProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, CanReplayPorts)> {
        let config = cx.config;
        let path = config
            .can
            .candump
            .clone()
            .context("can-replay: can.candump names no file to replay")?;
        let file =
            File::open(&path).with_context(|| format!("can-replay: opening {}", path.display()))?;
        let protocol = can_board::protocol(config)?;
        let lockstep = config.run.mode == ClockMode::Lockstep;
        let answered_by_estimator = lockstep
            && Self::participants(config, cx.name)
                .iter()
                .any(|p| p == "estimator");
        let ports = CanReplayPorts {
            link: SoftwareBusTransport::open(
                cx.bus,
                can_source::REPLAY,
                SampleHeader::VALID | SampleHeader::REPLAYED,
                BUS_BUFFER,
            )?,
            estimates: cx.bus.subscriber()?,
        };
        let process = Self {
            path,
            reader: CandumpReader::new(BufReader::new(file)),
            schedule: config.schedule()?,
            sync_decoder: Decoder::with_devices(protocol, DeviceSet::of(&[Device::Node])),
            clock: NodeClock::new(),
            lockstep,
            answered_by_estimator,
            started: Instant::now(),
            first_ns: None,
            newest_estimate: None,
            waiting_for: None,
            pending: None,
            ticks: 0,
            finished: false,
        };
        Ok((process, ports))
    }

    fn participants(config: &RunConfig, name: &str) -> Vec<String> {
        config
            .run
            .participants
            .iter()
            .filter(|p| p.as_str() != name)
            .cloned()
            .collect()
    }

    /// Releases frames until the next tick must wait for its estimate (or for the pacing).
    fn step(&mut self, ports: &CanReplayPorts, io: &Io) -> anyhow::Result<Flow> {
        // Frames from others (gateways' commands) are not replayed; keep the buffer empty.
        while let Ok(Some(_)) = ports.link.poll() {}
        let newest = &mut self.newest_estimate;
        ports
            .estimates
            .drain(|e| *newest = (*newest).max(Some(e.header.time_ns)))?;
        if self
            .waiting_for
            .is_some_and(|t| self.newest_estimate.is_none_or(|n| n < t))
        {
            return Ok(Flow::Continue);
        }
        self.waiting_for = None;
        loop {
            let frame = match self.pending.take() {
                Some(f) => f,
                None => match self
                    .reader
                    .next_frame()
                    .with_context(|| format!("reading {}", self.path.display()))?
                {
                    Some(f) => f,
                    None => {
                        self.finished = true;
                        return Ok(Flow::Stop);
                    }
                },
            };
            if !self.lockstep {
                // Paced: release at the recorded spacing.
                let t0 = *self.first_ns.get_or_insert(frame.time_ns);
                let due = Duration::from_nanos(frame.time_ns.saturating_sub(t0));
                if self.started.elapsed() < due {
                    // Released by a later wake-up of the pacing interval.
                    self.pending = Some(frame);
                    return Ok(Flow::Continue);
                }
            }
            ports.link.set_time_ns(frame.time_ns);
            ports
                .link
                .send_frame(&frame.frame)
                .context("sending on the software CAN bus")?;
            io.heartbeat.add_samples_out(1);
            let sync = match self
                .sync_decoder
                .decode(&frame.frame)
                .message
                .map(|r| r.message)
            {
                Some(Message::NodeHeartbeat(hb)) => {
                    run_time_ns(&mut self.clock, &self.schedule, hb.node_time_us)
                }
                _ => None,
            };
            if let Some(t_ns) = sync {
                self.ticks += 1;
                io.heartbeat.set_time_ns(t_ns);
                if self.answered_by_estimator {
                    self.waiting_for = Some(t_ns);
                    if self.newest_estimate.is_none_or(|n| n < t_ns) {
                        return Ok(Flow::Continue);
                    }
                    self.waiting_for = None;
                }
            }
        }
    }
}

impl Node for CanReplayProcess {
    type Ports = CanReplayPorts;

    fn start_barrier(&self, config: &RunConfig) -> Option<Vec<String>> {
        // Its own name may be among the participants (the profile lists every process).
        Some(Self::participants(config, "can-replay"))
    }

    fn wake_on<'a>(
        &mut self,
        ports: &'a CanReplayPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        wake.data(&ports.estimates)?;
        wake.data(ports.link.subscriber())?;
        if !self.lockstep {
            wake.interval(POLL_PERIOD)?;
        }
        Ok(())
    }

    fn start(&mut self, ports: &CanReplayPorts, io: &Io) -> anyhow::Result<Flow> {
        // The first frames go out now; then every estimate (or pacing interval) releases more.
        self.started = Instant::now();
        self.step(ports, io)
    }

    fn on_wake(&mut self, ports: &CanReplayPorts, _wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        self.step(ports, io)
    }

    fn stop(&mut self, _ports: &CanReplayPorts, io: &Io, exit: LoopExit) -> anyhow::Result<()> {
        // The file ends after the frames that follow its last sync, which were read only once
        // that tick was answered: the estimate of every tick is out when the replay ends the run.
        tracing::info!(?exit, finished = self.finished, ticks = self.ticks, stats = %self.reader.stats(), "{} done", io.name);
        Ok(())
    }
}
