//! The CAN device gateways (`gyro-gateway`, …, `cmg-gateway`, `thruster-gateway`): the device's
//! link in, [`Gateway`] decoding, samples out; for the wheels, CMGs and thrusters, commands in,
//! limited (thrusters: checked by [`ThrusterGuard`]) and encoded onto the link. A gateway on a
//! candump file stops cleanly at its end.
//!
//! The thruster gateway completes the board's thruster status with what only it knows before
//! publishing it: the commands it refused, the propellant it estimates from the applied
//! on-times ([`PropellantEstimate`]) and whether the thrusters are disabled. A valve the board
//! senses open after its pulse ended, `stuck_open_confirm_periods` periods in a row, disables
//! them: reported once as the health event `ThrustersDisabled`, every later command refused
//! and sent with the latch flag, so the board shuts the latch valve.

use crate::can_link::HeartbeatCounters;
use crate::can_link::Link;
use crate::software_bus::SoftwareBusTransport;
use anyhow::{Context as _, bail};
use ipc_types::ClockMode;
use ipc_types::{
    CanLinkStatus, CmgCommand, CmgTelemetry, GyroSample, HealthEventKind, InclinometerSample,
    MagnetometerSample, ProcessState, SampleHeader, ThrusterCommand, ThrusterStatus, WheelCommand,
    WheelTelemetry,
};
use std::time::{Duration, Instant};
use testbed_bus::{Bus, BusError, Flow, LoopExit, SourceId, TopicPublisher, TopicSubscriber, Wake};
use testbed_can::{EncodeError, FrameBatch, Sample, TransportError};
use testbed_gateways::can_board;
use testbed_gateways::gateway::{Gateway, GatewayDevice, Served};
use testbed_gateways::status::StatusTracker;
use testbed_gateways::thrusters::{PropellantEstimate, ThrusterGuard};
use testbed_runtime::{Context, Io, Node, WakeOn};

/// How often a gateway polls a link that cannot wake its event loop (SocketCAN, serial,
/// candump file).
pub const POLL_PERIOD: Duration = Duration::from_millis(2);
/// How often a gateway on SocketCAN checks that its interface is up.
pub const LINK_CHECK_PERIOD: Duration = Duration::from_millis(100);
/// Without a board heartbeat for this long a free-running gateway reports itself `Degraded`
/// (PROTOCOL.md: the board is lost after 3 s).
pub const BOARD_LOST_AFTER: Duration = Duration::from_secs(3);

/// The publisher of a gateway's samples.
enum SamplePublisher {
    Gyro(TopicPublisher<GyroSample>),
    Inclinometer(TopicPublisher<InclinometerSample>),
    Magnetometer(TopicPublisher<MagnetometerSample>),
    Wheels(TopicPublisher<WheelTelemetry>),
    Cmg(TopicPublisher<CmgTelemetry>),
    Thrusters(TopicPublisher<ThrusterStatus>),
}

impl SamplePublisher {
    fn new(bus: &Bus, served: Served) -> Result<Self, BusError> {
        use ipc_types::Device;
        Ok(match served {
            Served::Device(Device::Gyro) => Self::Gyro(bus.publisher()?),
            Served::Device(Device::Inclinometer) => Self::Inclinometer(bus.publisher()?),
            Served::Device(Device::Magnetometer) => Self::Magnetometer(bus.publisher()?),
            Served::Device(Device::Wheels) => Self::Wheels(bus.publisher()?),
            Served::Device(Device::Cmg) => Self::Cmg(bus.publisher()?),
            Served::Thrusters => Self::Thrusters(bus.publisher()?),
        })
    }

    fn publish(&self, sample: &Sample) -> Result<(), BusError> {
        match (self, sample) {
            (Self::Gyro(p), Sample::Gyro(s)) => p.publish(s).map(drop),
            (Self::Inclinometer(p), Sample::Inclinometer(s)) => p.publish(s).map(drop),
            (Self::Magnetometer(p), Sample::Magnetometer(s)) => p.publish(s).map(drop),
            (Self::Wheels(p), Sample::WheelTelemetry(s)) => p.publish(s).map(drop),
            (Self::Cmg(p), Sample::CmgTelemetry(s)) => p.publish(s).map(drop),
            (Self::Thrusters(p), Sample::ThrusterStatus(s)) => p.publish(s).map(drop),
            _ => Ok(()),
        }
    }
}

/// A gateway's ports. The software CAN bus wakes the event loop (which borrows its subscriber)
/// and works through `&self`, so it is a port; the other links are polled through `&mut` and
/// belong to the board.
pub struct CanGatewayPorts {
    bus_link: Option<Box<SoftwareBusTransport>>,
    samples: SamplePublisher,
    status: TopicPublisher<CanLinkStatus>,
    wheel_commands: Option<TopicSubscriber<WheelCommand>>,
    cmg_commands: Option<TopicSubscriber<CmgCommand>>,
    thruster_commands: Option<TopicSubscriber<ThrusterCommand>>,
}

/// The thruster gateway's own state: its checks and its propellant estimate.
struct ThrusterSide {
    guard: ThrusterGuard,
    propellant: PropellantEstimate,
}

impl ThrusterSide {
    /// Completes the board's status (refusals, propellant, disabled) and senses the valves:
    /// returns the valve newly found stuck open.
    fn on_status(&mut self, status: &mut ThrusterStatus) -> Option<usize> {
        let stuck = if status.header.is_valid() && status.header.flags & SampleHeader::STALE == 0 {
            self.propellant.add(&status.applied_on_time);
            self.guard.on_valves_sensed(status.valves_open)
        } else {
            None
        };
        status.refused = self.guard.refused().total();
        status.propellant_used = self.propellant.used_kg();
        status.disabled = u32::from(status.disabled != 0 || self.guard.disabled().is_some());
        stuck
    }
}

/// The gateway of one device.
pub struct CanGateway {
    gateway: Gateway,
    /// A link that is not the software bus (polled).
    other_link: Option<Link>,
    describe: &'static str,
    tick_sync: bool,
    status_interval: Option<SourceId>,
    tracker: StatusTracker,
    counters: HeartbeatCounters,
    latest_ns: u64,
    ended: bool,
    /// The CAN board's heartbeats: how many, when they last grew, whether the board is lost.
    board_seen: (u64, Instant, bool),
    /// The control period: commands are expected once per period.
    period: Duration,
    /// The command stream's attachment (paced runs: its silence wakes the gateway).
    command_source: Option<SourceId>,
    /// No command came for two periods: the device has been commanded zero.
    zeroed: bool,
    /// The link's state: down since the last check found it down.
    link: LinkState,
    /// The thruster gateway's checks and estimate.
    thrusters: Option<ThrusterSide>,
    /// The encoded commands of one wake-up, a buffer kept for the run (a command allocates
    /// nothing).
    command_batches: Vec<(u64, Result<FrameBatch, EncodeError>)>,
}

/// A SocketCAN interface's up/down state as the gateway last saw it.
struct LinkState {
    down: bool,
    /// Times the link was found down after being up.
    losses: u64,
    /// Times it came back.
    recoveries: u64,
    last_check: Instant,
}

impl CanGateway {
    pub fn open(
        cx: &Context,
        device: impl Into<Served>,
    ) -> anyhow::Result<(Self, CanGatewayPorts)> {
        let device = device.into();
        let (config, bus, name) = (cx.config, cx.bus, cx.name);
        let schedule = config.schedule()?;
        let thrusters = match device {
            Served::Thrusters => {
                let valves = config.model.thrusters.as_ref().context(
                    "the thruster gateway needs [model.thrusters] (the valves' parameters)",
                )?;
                Some(ThrusterSide {
                    guard: ThrusterGuard::new(
                        valves,
                        schedule.period_s(),
                        valves.stuck_open_confirm_periods,
                    ),
                    propellant: PropellantEstimate::new(valves),
                })
            }
            Served::Device(_) => None,
        };
        let protocol =
            can_board::protocol(config).context("the CAN protocol of the model configuration")?;
        let tick_sync = config.run.mode == ClockMode::Lockstep;
        let link = Link::open(bus, config, device).context("opening its link")?;
        let describe = link.describe();
        // A bus (software or SocketCAN, e.g. vcan0 with the simulated CAN board on it) delivers the
        // board's tick syncs in order with the frames; a file or a serial line cannot wait for the
        // simulation clock.
        if tick_sync && !matches!(link, Link::Bus(_) | Link::SocketCan(_)) {
            bail!(
                "{name}: a lockstep run needs a CAN bus (can.link = \"software_bus\" or \"socketcan\"); a {describe} cannot \
                 wait for the simulation clock (run paced, or replay a candump file with can-replay)"
            );
        }
        let gateway = Gateway::new(device, protocol, schedule, tick_sync);
        let (bus_link, other_link) = match link {
            Link::Bus(t) => (Some(t), None),
            other => (None, Some(other)),
        };
        let ports = CanGatewayPorts {
            bus_link,
            samples: SamplePublisher::new(bus, device)?,
            status: bus.publisher()?,
            wheel_commands: (device == Served::Device(ipc_types::Device::Wheels))
                .then(|| bus.subscriber())
                .transpose()?,
            cmg_commands: (device == Served::Device(ipc_types::Device::Cmg))
                .then(|| bus.subscriber())
                .transpose()?,
            thruster_commands: (device == Served::Thrusters)
                .then(|| bus.subscriber())
                .transpose()?,
        };
        let gateway = Self {
            gateway,
            other_link,
            describe,
            tick_sync,
            status_interval: None,
            tracker: StatusTracker::new(device.source_id()),
            counters: HeartbeatCounters::default(),
            latest_ns: 0,
            ended: false,
            board_seen: (0, Instant::now(), false),
            period: Duration::from_nanos(schedule.period_ns),
            command_source: None,
            zeroed: false,
            command_batches: Vec::with_capacity(4),
            link: LinkState {
                down: false,
                losses: 0,
                recoveries: 0,
                last_check: Instant::now(),
            },
            thrusters,
        };
        Ok((gateway, ports))
    }

    fn publish_status(
        &mut self,
        ports: &CanGatewayPorts,
        io: &Io,
        t_ns: u64,
    ) -> anyhow::Result<()> {
        if let Some(mut s) = self.tracker.due(t_ns, self.gateway.status()) {
            if self.link.down {
                // While the link is down the status is not VALID: what a consumer (the
                // controller's safe mode) watches for "the devices are unreachable".
                s.header.flags &= !ipc_types::SampleHeader::VALID;
            }
            ports.status.publish(&s)?;
        }
        self.counters.update(io.heartbeat, &self.gateway.status());
        Ok(())
    }

    /// Checks (every [`LINK_CHECK_PERIOD`]) whether a SocketCAN interface is up; reports the
    /// loss and the return of the link, and counts them.
    fn check_link(&mut self, ports: &CanGatewayPorts, io: &Io) -> anyhow::Result<()> {
        let Some(link) = self.other_link.as_ref() else {
            return Ok(());
        };
        if self.link.last_check.elapsed() < LINK_CHECK_PERIOD {
            return Ok(());
        }
        self.link.last_check = Instant::now();
        let up = match link.is_up() {
            Ok(up) => up,
            Err(e) => {
                // The interface removed altogether: as good as down.
                tracing::warn!("{}: {e}", io.name);
                false
            }
        };
        let name = io.name;
        match (self.link.down, up) {
            (false, false) => {
                self.link.down = true;
                self.link.losses += 1;
                // A transport error, so that the status goes out now (a change of troubles).
                self.gateway.count_transport_error();
                tracing::warn!(
                    losses = self.link.losses,
                    "{name}: CAN interface {} is down: link lost",
                    link.name()
                );
                io.heartbeat.set_state(ProcessState::Degraded);
                self.publish_status(ports, io, self.latest_ns)?;
            }
            (true, true) => {
                self.link.down = false;
                self.link.recoveries += 1;
                tracing::info!(
                    recoveries = self.link.recoveries,
                    "{name}: CAN interface {} is up again: link back",
                    link.name()
                );
                io.heartbeat.set_state(ProcessState::Running);
                self.publish_status(ports, io, self.latest_ns)?;
            }
            _ => {}
        }
        Ok(())
    }

    /// Decodes every received frame and publishes the samples; false when the link has ended.
    fn receive(&mut self, ports: &CanGatewayPorts, io: &Io) -> anyhow::Result<bool> {
        loop {
            let received = match (&ports.bus_link, &mut self.other_link) {
                (Some(t), _) => t.poll(),
                (None, Some(link)) => link.poll(),
                (None, None) => Ok(None),
            };
            let frame = match received {
                Ok(Some(frame)) => frame,
                Ok(None) => return Ok(true),
                Err(TransportError::Closed) => return Ok(false),
                Err(e) => {
                    self.gateway.count_transport_error();
                    tracing::warn!("{}: receiving: {e}", io.name);
                    return Ok(true);
                }
            };
            io.heartbeat.add_samples_in(1);
            let outcome = self.gateway.on_frame(&frame.frame);
            let rejected = match (&ports.bus_link, &self.other_link) {
                (Some(t), _) => t.stats().check_errors + t.stats().invalid,
                (None, Some(link)) => link.rejected(),
                (None, None) => 0,
            };
            self.gateway.set_link_check_errors(rejected);
            if let Some(t_ns) = outcome.tick.filter(|_| outcome.sample.is_some()) {
                // The status goes out before the samples, which let the lockstep run go on; only
                // at ticks with a sample (where the run waits for this gateway), so the status
                // is always logged within its tick.
                self.publish_status(ports, io, t_ns)?;
            }
            if let Some(mut sample) = outcome.sample {
                self.latest_ns = testbed_gateways::gateway::sample_header(&sample).time_ns;
                io.heartbeat.set_time_ns(self.latest_ns);
                if let (Sample::ThrusterStatus(status), Some(side)) =
                    (&mut sample, self.thrusters.as_mut())
                    && let Some(stuck) = side.on_status(status)
                {
                    tracing::error!(
                        "{}: thruster {stuck}: valve stuck open; thrusters disabled, latch valve shut",
                        io.name
                    );
                    io.health.report(
                        self.latest_ns,
                        HealthEventKind::ThrustersDisabled,
                        "actuators/thrusters",
                        stuck as u32,
                        0.0,
                    );
                }
                ports.samples.publish(&sample)?;
                io.heartbeat.add_samples_out(1);
            }
        }
    }

    /// Limits, encodes and sends every pending command.
    fn send_commands(&mut self, ports: &CanGatewayPorts, io: &Io) -> anyhow::Result<()> {
        let gateway = &mut self.gateway;
        let mut batches = std::mem::take(&mut self.command_batches);
        let drained = match (
            &ports.wheel_commands,
            &ports.cmg_commands,
            &ports.thruster_commands,
            self.thrusters.as_mut(),
        ) {
            (Some(s), _, _, _) => {
                s.drain(|c| batches.push((c.header.time_ns, gateway.wheel_command(c))))?
            }
            (_, Some(s), _, _) => {
                s.drain(|c| batches.push((c.header.time_ns, gateway.cmg_command(c))))?
            }
            (_, _, Some(s), Some(side)) => s.drain(|c| {
                let (on_time, refusal) = side.guard.check(c);
                if let Some(refusal) = refusal {
                    gateway.count_refused_command();
                    tracing::warn!(
                        t_ns = c.header.time_ns,
                        "thruster command refused: {refusal}"
                    );
                }
                let latch = side.guard.disabled().is_some();
                batches.push((c.header.time_ns, gateway.thruster_command(on_time, latch)));
            })?,
            _ => 0,
        };
        io.heartbeat.add_samples_in(drained as u64);
        if drained > 0 && self.zeroed {
            self.zeroed = false;
            io.health.report(
                self.latest_ns,
                HealthEventKind::CommandsResumed,
                io.name,
                0,
                0.0,
            );
        }
        self.send_batches(ports, io, batches.drain(..));
        self.command_batches = batches;
        Ok(())
    }

    /// The last line of defence when the controller is dead or hung: no command for two
    /// periods, so the device is commanded zero (wheel torque, gimbal rate), again after every
    /// further two periods of silence, until commands come again.
    fn command_zero(&mut self, ports: &CanGatewayPorts, io: &Io) {
        let header = SampleHeader::new(self.latest_ns, 0, SampleHeader::VALID);
        let gateway = &mut self.gateway;
        let batch = match (&ports.wheel_commands, &ports.cmg_commands, &self.thrusters) {
            (Some(_), _, _) => gateway.wheel_command(&WheelCommand::new(header, [0.0; 3])),
            (_, Some(_), _) => gateway.cmg_command(&CmgCommand::new(header, [0.0; 4])),
            (_, _, Some(side)) => {
                gateway.thruster_command([0.0; 6], side.guard.disabled().is_some())
            }
            _ => return,
        };
        if !self.zeroed {
            self.zeroed = true;
            io.health.report(
                self.latest_ns,
                HealthEventKind::CommandsZeroed,
                io.name,
                0,
                (self.period * testbed_runtime::health::LOST_AFTER_PERIODS).as_secs_f64(),
            );
        }
        self.send_batches(ports, io, [(self.latest_ns, batch)]);
    }

    fn send_batches<E: std::fmt::Display>(
        &mut self,
        ports: &CanGatewayPorts,
        io: &Io,
        batches: impl IntoIterator<Item = (u64, Result<FrameBatch, E>)>,
    ) {
        let gateway = &mut self.gateway;
        for (t_ns, batch) in batches {
            let batch = match batch {
                Ok(batch) => batch,
                Err(e) => {
                    // Cannot happen after limiting; counted rather than sent.
                    tracing::warn!("{}: command not encoded: {e}", io.name);
                    gateway.count_transport_error();
                    continue;
                }
            };
            for frame in &batch {
                let sent = match (&ports.bus_link, &mut self.other_link) {
                    (Some(t), _) => {
                        t.set_time_ns(t_ns);
                        t.send_frame(frame)
                    }
                    (None, Some(link)) => link.send(frame, t_ns),
                    (None, None) => Ok(()),
                };
                match sent {
                    Ok(()) => gateway.count_sent(1),
                    Err(e) => {
                        gateway.count_transport_error();
                        tracing::warn!("{}: sending {frame}: {e}", io.name);
                    }
                }
            }
        }
    }
}

impl Node for CanGateway {
    type Ports = CanGatewayPorts;

    fn wake_on<'a>(
        &mut self,
        ports: &'a CanGatewayPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        match &ports.bus_link {
            Some(t) => wake.data(t.subscriber())?,
            None => wake.interval(POLL_PERIOD)?,
        };
        if let Some(s) = &ports.wheel_commands {
            self.command_source = Some(wake.input(s, self.period)?);
        }
        if let Some(s) = &ports.cmg_commands {
            self.command_source = Some(wake.input(s, self.period)?);
        }
        if let Some(s) = &ports.thruster_commands {
            self.command_source = Some(wake.input(s, self.period)?);
        }
        self.status_interval = (!self.tick_sync)
            .then(|| wake.interval(Duration::from_secs(1)))
            .transpose()?;
        Ok(())
    }

    fn start(&mut self, _ports: &CanGatewayPorts, io: &Io) -> anyhow::Result<Flow> {
        tracing::info!(
            link = self.describe,
            tick_sync = self.tick_sync,
            "{} running",
            io.name
        );
        Ok(Flow::Continue)
    }

    fn on_wake(&mut self, ports: &CanGatewayPorts, wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        if !self.receive(ports, io)? {
            self.ended = true;
            return Ok(Flow::Stop);
        }
        self.send_commands(ports, io)?;
        if let Wake::DeadlineMissed(source) = wake
            && Some(source) == self.command_source
        {
            self.command_zero(ports, io);
        }
        self.check_link(ports, io)?;
        let name = io.name;
        if self.gateway.node_heartbeats() != self.board_seen.0 {
            if self.board_seen.2 {
                tracing::info!("{name}: the CAN board is back");
                io.heartbeat.set_state(ProcessState::Running);
            }
            self.board_seen = (self.gateway.node_heartbeats(), Instant::now(), false);
        }
        if self.status_interval.is_some_and(|s| wake == Wake::Tick(s)) {
            if !self.board_seen.2 && self.board_seen.1.elapsed() > BOARD_LOST_AFTER {
                tracing::warn!(
                    "{name}: no CAN board heartbeat for {BOARD_LOST_AFTER:?}: board lost"
                );
                io.heartbeat.set_state(ProcessState::Degraded);
                self.board_seen.2 = true;
            }
            self.publish_status(ports, io, self.latest_ns)?;
        }
        if !self.tick_sync {
            self.counters.update(io.heartbeat, &self.gateway.status());
        }
        Ok(Flow::Continue)
    }

    fn stop(&mut self, _ports: &CanGatewayPorts, io: &Io, exit: LoopExit) -> anyhow::Result<()> {
        let s = self.gateway.status();
        let (late_messages, foreign) = self.gateway.dropped_messages();
        tracing::info!(
            ?exit,
            ended_with_input = self.ended,
            frames_ok = s.frames_ok,
            frames_bad = s.frames_bad,
            lost = s.lost_frames,
            crc = s.crc_errors,
            late = s.late_frames,
            stale = s.stale_samples,
            clamped = s.commands_clamped,
            refused = s.commands_refused,
            late_messages,
            foreign,
            transport_errors = s.transport_errors,
            link_losses = self.link.losses,
            queue_drops = self.other_link.as_ref().map_or(0, Link::queue_drops),
            link_recoveries = self.link.recoveries,
            "{} stopping",
            io.name
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_can::{Decoder, Message, Protocol};
    use testbed_flight::schedule::Schedule;
    use testbed_model::thruster_config::ThrusterConfig;

    fn side(config: &ThrusterConfig) -> ThrusterSide {
        ThrusterSide {
            guard: ThrusterGuard::new(config, 0.1, config.stuck_open_confirm_periods),
            propellant: PropellantEstimate::new(config),
        }
    }

    fn command(on_time: [f64; 6]) -> ThrusterCommand {
        ThrusterCommand {
            header: SampleHeader::new(0, 0, SampleHeader::VALID),
            on_time,
        }
    }

    fn status(applied: [f64; 6], valves_open: u32) -> ThrusterStatus {
        ThrusterStatus {
            header: SampleHeader::new(0, 0, SampleHeader::VALID),
            applied_on_time: applied,
            valves_open,
            ..Default::default()
        }
    }

    /// The gateway's side of a thruster run: bad commands refused and counted, what the board
    /// reports completed, a stuck valve disabling the thrusters and the latch flag sent.
    #[test]
    fn the_thruster_gateway_refuses_counts_and_disables() {
        let config = ThrusterConfig::default();
        let mut side = side(&config);
        let mut gateway = Gateway::new(
            Served::Thrusters,
            Protocol::default(),
            Schedule {
                period_ns: 100_000_000,
                tilt_every: 4,
                field_every: 4,
            },
            true,
        );
        for bad in [f64::NAN, 0.5, -0.01, config.min_on_time_s / 2.0] {
            let (on_time, refusal) = side.guard.check(&command([0.0, bad, 0.0, 0.0, 0.0, 0.0]));
            assert!(refusal.is_some(), "{bad} passed");
            assert_eq!(on_time, [0.0; 6], "a refused command shuts every valve");
        }
        let (on_time, refusal) = side.guard.check(&command([0.05, 0.0, 0.0, 0.0, 0.0, 0.0]));
        assert_eq!((on_time[0], refusal), (0.05, None));
        // The board reports the pulse; the gateway adds its propellant and its refusals.
        let mut s = status(on_time, 0);
        assert_eq!(side.on_status(&mut s), None);
        assert_eq!(s.refused, 4);
        assert!(s.propellant_used > 0.0 && s.disabled == 0);
        // A stale status (the board's frames did not all come) adds nothing.
        let used = s.propellant_used;
        let mut stale = status(on_time, 0);
        stale.header.flags |= SampleHeader::STALE;
        side.on_status(&mut stale);
        assert_eq!(stale.propellant_used, used);
        // Valve 4 reads open in periods it was not driven: stuck after the confirmation count.
        let mut stuck = None;
        for _ in 0..config.stuck_open_confirm_periods {
            side.guard.check(&command([0.0; 6]));
            stuck = side.on_status(&mut status([0.0; 6], 1 << 4));
        }
        assert_eq!(stuck, Some(4));
        // From now on every command is refused and goes out with the latch flag.
        let (on_time, refusal) = side.guard.check(&command([0.05, 0.0, 0.0, 0.0, 0.0, 0.0]));
        assert!(refusal.is_some() && on_time == [0.0; 6]);
        let frames = gateway
            .thruster_command(on_time, side.guard.disabled().is_some())
            .expect("zeros encode");
        let mut decoder = Decoder::new(Protocol::default());
        let decoded = frames
            .iter()
            .filter_map(|f| decoder.decode(f).message)
            .next_back()
            .expect("a complete command");
        let Message::ThrusterCommand(m) = decoded.message else {
            panic!("not a thruster command")
        };
        assert!(m.latch_shut && m.on_time_s == [0.0; 6]);
        let mut s = status([0.0; 6], 1 << 4);
        side.on_status(&mut s);
        assert_eq!((s.disabled, s.refused), (1, 5));
    }
}
