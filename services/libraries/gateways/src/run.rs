//! The processes: thin shells moving frames and samples between the library logic
//! ([`Gateway`], [`SimCanNode`]) and the bus.

use crate::bus_transport::SoftwareBusTransport;
use crate::gateway::{Gateway, GatewayDevice, run_time_ns};
use crate::node::{self, SimCanNode, TxFrame};
use crate::status::{HeartbeatCounters, StatusTracker};
use anyhow::{Context, bail};
use ipc_types::{
    AppliedCmgCommand, AppliedWheelCommand, AttitudeEstimate, CanLinkStatus, CmgCommand, CmgTelemetry, GyroSample,
    InclinometerSample, MagnetometerSample, ProcessState, SampleHeader, SimTruth, WheelCommand, WheelTelemetry,
    can_source,
};
use std::fs::File;
use std::io::BufReader;
use std::time::{Duration, Instant};
use testbed_bus::{Bus, BusError, EventLoop, Flow, LoopExit, TopicPublisher, Waiter, Wake};
use testbed_can::transport::{CandumpReader, CandumpReplay, Pacing, SerialConfig, SerialTransport, SocketCanTransport};
use testbed_can::{
    CanFrame, CanTransport, Decoder, Device, DeviceSet, Message, NodeClock, Sample, TimestampedFrame, TransportError,
};
use testbed_runtime::process::{self, FirstError, HEARTBEAT_PERIOD};
use testbed_runtime::run_config::{Actuation, CanLink, RunConfig};
use testbed_runtime::ClockMode;

/// How often a gateway polls a link that cannot wake its event loop (SocketCAN, serial,
/// candump file).
pub const POLL_PERIOD: Duration = Duration::from_millis(2);
/// Frames a software-bus receiver buffers (a tick holds about 20).
pub const BUS_BUFFER: usize = 128;
/// Without a node heartbeat for this long a free-running gateway reports itself `Degraded`
/// (PROTOCOL.md: the node is lost after 3 s).
pub const NODE_LOST_AFTER: Duration = Duration::from_secs(3);

/// A gateway's device link.
pub enum Link {
    /// The software CAN bus.
    Bus(Box<SoftwareBusTransport>),
    /// A SocketCAN interface, filtered to the device's and the node's identifiers.
    SocketCan(SocketCanTransport),
    /// A `candump -L` file.
    Candump(CandumpReplay<BufReader<File>>),
    /// A device wired directly by RS-232.
    Serial(SerialTransport),
}

impl Link {
    /// Opens the link the run configuration gives `device`.
    pub fn open(bus: &Bus, config: &RunConfig, device: GatewayDevice) -> anyhow::Result<Self> {
        let can = &config.can;
        if let Some(serial) = can.serial.get(device.config_name()) {
            let path = serial.path.to_string_lossy().into_owned();
            let transport = SerialTransport::open(&SerialConfig { path: path.clone(), baud: serial.baud })
                .with_context(|| format!("can.serial.{}: opening {path}", device.config_name()))?;
            return Ok(Link::Serial(transport));
        }
        Ok(match can.link {
            CanLink::SoftwareBus => {
                Link::Bus(Box::new(SoftwareBusTransport::open(bus, device.source_id(), SampleHeader::VALID, BUS_BUFFER)?))
            }
            CanLink::Socketcan => {
                let mut transport = SocketCanTransport::open(&can.interface)
                    .with_context(|| format!("can.interface = {:?}", can.interface))?;
                let protocol = node::protocol(config)?;
                transport
                    .set_device_filters(protocol.ids(), &[device.can_device(), Device::Node])
                    .with_context(|| format!("filters on {}", can.interface))?;
                Link::SocketCan(transport)
            }
            CanLink::Candump => {
                let path = can.candump.as_ref().context("can.link = \"candump\" needs can.candump (the file)")?;
                let pacing = match can.replay_speed {
                    0.0 => Pacing::AsFastAsPossible,
                    speed => Pacing::Timed { speed },
                };
                Link::Candump(CandumpReplay::open(path, pacing).with_context(|| format!("can.candump = {}", path.display()))?)
            }
        })
    }

    /// The next received frame, without waiting.
    pub fn poll(&mut self) -> Result<Option<TimestampedFrame>, TransportError> {
        match self {
            Link::Bus(t) => t.poll(),
            Link::SocketCan(t) => t.recv(Duration::ZERO),
            Link::Candump(t) => t.recv(Duration::ZERO),
            Link::Serial(t) => t.recv(Duration::ZERO),
        }
    }

    /// Sends `frame`, stamped `time_ns` where the link carries a time.
    pub fn send(&mut self, frame: &CanFrame, time_ns: u64) -> Result<(), TransportError> {
        match self {
            Link::Bus(t) => {
                t.set_time_ns(time_ns);
                t.send_frame(frame)
            }
            Link::SocketCan(t) => t.send(frame),
            Link::Candump(t) => t.send(frame),
            Link::Serial(t) => t.send(frame),
        }
    }

    /// Frames the link itself rejected so far: failed frame checks (software bus), error
    /// frames (SocketCAN), bad packets (serial), malformed lines (candump).
    pub fn rejected(&self) -> u64 {
        match self {
            Link::Bus(t) => t.stats().check_errors + t.stats().invalid,
            Link::SocketCan(t) => t.error_frames(),
            Link::Candump(t) => t.stats().malformed,
            Link::Serial(t) => t.stats().dropped(),
        }
    }

    fn describe(&self) -> &'static str {
        match self {
            Link::Bus(_) => "software CAN bus",
            Link::SocketCan(_) => "SocketCAN",
            Link::Candump(_) => "candump file",
            Link::Serial(_) => "serial line",
        }
    }
}

/// The publisher of a gateway's samples.
enum SamplePublisher {
    Gyro(TopicPublisher<GyroSample>),
    Inclinometer(TopicPublisher<InclinometerSample>),
    Magnetometer(TopicPublisher<MagnetometerSample>),
    Wheels(TopicPublisher<WheelTelemetry>),
    Cmg(TopicPublisher<CmgTelemetry>),
}

impl SamplePublisher {
    fn new(bus: &Bus, device: GatewayDevice) -> Result<Self, BusError> {
        Ok(match device {
            GatewayDevice::Gyro => Self::Gyro(bus.publisher()?),
            GatewayDevice::Inclinometer => Self::Inclinometer(bus.publisher()?),
            GatewayDevice::Magnetometer => Self::Magnetometer(bus.publisher()?),
            GatewayDevice::Wheels => Self::Wheels(bus.publisher()?),
            GatewayDevice::Cmg => Self::Cmg(bus.publisher()?),
        })
    }

    fn publish(&self, sample: &Sample) -> Result<(), BusError> {
        match (self, sample) {
            (Self::Gyro(p), Sample::Gyro(s)) => p.publish(s).map(drop),
            (Self::Inclinometer(p), Sample::Inclinometer(s)) => p.publish(s).map(drop),
            (Self::Magnetometer(p), Sample::Magnetometer(s)) => p.publish(s).map(drop),
            (Self::Wheels(p), Sample::WheelTelemetry(s)) => p.publish(s).map(drop),
            (Self::Cmg(p), Sample::CmgTelemetry(s)) => p.publish(s).map(drop),
            _ => Ok(()),
        }
    }
}

/// The process of the gateway of `device`: its link from the run configuration; decoded samples
/// out; for the wheels and CMGs, commands in, limited and encoded onto the link. Ends cleanly
/// at the end of a candump file.
pub fn run_gateway(device: GatewayDevice) -> anyhow::Result<()> {
    let name = device.process_name();
    let (config, bus) = process::start(name)?;
    let schedule = config.schedule()?;
    let protocol = node::protocol(&config).context("the CAN protocol of the model configuration")?;
    let tick_sync = config.run.mode == ClockMode::Lockstep;
    let link = Link::open(&bus, &config, device).with_context(|| format!("{name}: opening its link"))?;
    let describe = link.describe();
    if tick_sync && !matches!(link, Link::Bus(_)) {
        bail!(
            "{name}: a lockstep run needs the software CAN bus (can.link = \"software_bus\"); a {} cannot wait \
             for the simulation clock (run paced, or replay a candump file with can-replay)",
            describe
        );
    }
    let mut gateway = Gateway::new(device, protocol, schedule, tick_sync);
    let samples = SamplePublisher::new(&bus, device)?;
    let status = bus.publisher::<CanLinkStatus>()?;
    let wheel_commands = (device == GatewayDevice::Wheels).then(|| bus.subscriber::<WheelCommand>()).transpose()?;
    let cmg_commands = (device == GatewayDevice::Cmg).then(|| bus.subscriber::<CmgCommand>()).transpose()?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;

    // The software bus wakes the event loop (which borrows its subscriber) and works through
    // `&self`; the other links are polled, through `&mut`, on an interval.
    let (bus_link, mut other_link) = match link {
        Link::Bus(t) => (Some(t), None),
        other => (None, Some(other)),
    };
    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    match &bus_link {
        Some(t) => events.on_data(t.subscriber())?,
        None => events.on_interval(POLL_PERIOD)?,
    };
    if let Some(s) = &wheel_commands {
        events.on_data(s)?;
    }
    if let Some(s) = &cmg_commands {
        events.on_data(s)?;
    }
    let status_interval = (!tick_sync).then(|| events.on_interval(Duration::from_secs(1))).transpose()?;
    events.with_heartbeat(&heartbeat)?;
    heartbeat.set_state(ProcessState::Running);
    tracing::info!(link = describe, tick_sync, "{name} running");

    let mut tracker = StatusTracker::new(device.source_id());
    let mut counters = HeartbeatCounters::default();
    let mut latest_ns = 0u64;
    let mut error = FirstError::default();
    let mut ended = false;
    let mut node_seen = (0u64, Instant::now(), false); // (heartbeats, when they last grew, lost)
    let exit = events.run(|wake| {
        let mut publish_status = |gateway: &Gateway, t_ns: u64| -> anyhow::Result<()> {
            if let Some(s) = tracker.due(t_ns, gateway.status()) {
                status.publish(&s)?;
            }
            counters.update(&heartbeat, &gateway.status());
            Ok(())
        };
        // Frames.
        loop {
            let received = match (&bus_link, &mut other_link) {
                (Some(t), _) => t.poll(),
                (None, Some(link)) => link.poll(),
                (None, None) => Ok(None),
            };
            let frame = match received {
                Ok(Some(frame)) => frame,
                Ok(None) => break,
                Err(TransportError::Closed) => {
                    ended = true;
                    return Flow::Stop;
                }
                Err(e) => {
                    gateway.count_transport_error();
                    tracing::warn!("{name}: receiving: {e}");
                    break;
                }
            };
            heartbeat.add_samples_in(1);
            let outcome = gateway.on_frame(&frame.frame);
            let rejected = match (&bus_link, &other_link) {
                (Some(t), _) => t.stats().check_errors + t.stats().invalid,
                (None, Some(link)) => link.rejected(),
                (None, None) => 0,
            };
            gateway.set_link_check_errors(rejected);
            if let Some(t_ns) = outcome.tick.filter(|_| !outcome.samples.is_empty()) {
                // The status goes out before the samples, which let the lockstep run go on; only
                // at ticks with a sample (where the run waits for this gateway), so the status
                // is always logged within its tick.
                if error.failed(publish_status(&gateway, t_ns)) {
                    return Flow::Stop;
                }
            }
            for sample in &outcome.samples {
                latest_ns = crate::gateway::sample_header(sample).time_ns;
                heartbeat.set_time_ns(latest_ns);
                if error.failed(samples.publish(sample).map_err(anyhow::Error::from)) {
                    return Flow::Stop;
                }
                heartbeat.add_samples_out(1);
            }
        }
        // Commands.
        let mut batches = Vec::new();
        let drained = match (&wheel_commands, &cmg_commands) {
            (Some(s), _) => s.drain(|c| batches.push((c.header.time_ns, gateway.wheel_command(&c)))),
            (_, Some(s)) => s.drain(|c| batches.push((c.header.time_ns, gateway.cmg_command(&c)))),
            _ => Ok(0),
        };
        match drained {
            Ok(n) => heartbeat.add_samples_in(n as u64),
            Err(e) => {
                error.failed::<()>(Err(e.into()));
                return Flow::Stop;
            }
        }
        for (t_ns, batch) in batches {
            let batch = match batch {
                Ok(batch) => batch,
                Err(e) => {
                    // Cannot happen after limiting; counted rather than sent.
                    tracing::warn!("{name}: command not encoded: {e}");
                    gateway.count_transport_error();
                    continue;
                }
            };
            for frame in &batch {
                let sent = match (&bus_link, &mut other_link) {
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
                        tracing::warn!("{name}: sending {frame}: {e}");
                    }
                }
            }
        }
        if gateway.node_heartbeats() != node_seen.0 {
            if node_seen.2 {
                tracing::info!("{name}: the CAN node is back");
                heartbeat.set_state(ProcessState::Running);
            }
            node_seen = (gateway.node_heartbeats(), Instant::now(), false);
        }
        if status_interval.is_some_and(|s| wake == Wake::Tick(s)) {
            if !node_seen.2 && node_seen.1.elapsed() > NODE_LOST_AFTER {
                tracing::warn!("{name}: no CAN node heartbeat for {NODE_LOST_AFTER:?}: node lost");
                heartbeat.set_state(ProcessState::Degraded);
                node_seen.2 = true;
            }
            if error.failed(publish_status(&gateway, latest_ns)) {
                return Flow::Stop;
            }
        }
        if !tick_sync {
            counters.update(&heartbeat, &gateway.status());
        }
        Flow::Continue
    })?;
    let s = gateway.status();
    let (late_messages, foreign) = gateway.dropped_messages();
    tracing::info!(
        ?exit,
        ended_with_input = ended,
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
        "{name} stopping"
    );
    heartbeat.set_state(ProcessState::Stopping);
    error.into_result()
}

/// The simulated smart CAN node process: truth in, sensor frames and tick syncs out on the
/// software bus; command frames in, applied commands out to the plant.
pub fn run_node() -> anyhow::Result<()> {
    let name = "sim-can-node";
    let (config, bus) = process::start(name)?;
    if config.run.actuation != Actuation::CanNode {
        tracing::warn!("{name}: run.actuation is not \"can_node\": the plant ignores the commands the node applies");
    }
    let mut node = SimCanNode::new(&config).context("the simulated CAN node")?;
    let truth = bus.subscriber::<SimTruth>()?;
    let link = SoftwareBusTransport::open(&bus, can_source::NODE, SampleHeader::VALID | SampleHeader::SIMULATED, BUS_BUFFER)?;
    let wheel = bus.publisher::<AppliedWheelCommand>()?;
    let cmg = bus.publisher::<AppliedCmgCommand>()?;
    let status = bus.publisher::<CanLinkStatus>()?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;
    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    events.on_data(&truth)?;
    events.on_data(link.subscriber())?;
    events.with_heartbeat(&heartbeat)?;
    heartbeat.set_state(ProcessState::Running);

    let mut tracker = StatusTracker::new(can_source::NODE);
    let mut counters = HeartbeatCounters::default();
    let mut error = FirstError::default();
    let mut truths = Vec::new();
    let exit = events.run(|_| {
        truths.clear();
        if error.failed(truth.drain_into(&mut truths).map_err(anyhow::Error::from)) {
            return Flow::Stop;
        }
        for t in &truths {
            heartbeat.add_samples_in(1);
            heartbeat.set_time_ns(t.header.time_ns);
            link.set_time_ns(t.header.time_ns);
            for frame in node.on_truth(t) {
                let sent = match frame {
                    TxFrame::Send(f) => link.send_frame(&f),
                    TxFrame::Corrupt(f, bit) => link.send_corrupted(&f, bit),
                };
                if let Err(e) = sent {
                    node.count_transport_error();
                    tracing::warn!("{name}: sending: {e}");
                }
            }
        }
        loop {
            let frame = match link.poll() {
                Ok(Some(frame)) => frame,
                Ok(None) => break,
                Err(e) => {
                    error.failed::<()>(Err(anyhow::Error::from(e).context("receiving from the software CAN bus")));
                    return Flow::Stop;
                }
            };
            node.set_link_check_errors(link.stats().check_errors + link.stats().invalid);
            let Some(applied) = node.on_frame(&frame.frame) else { continue };
            let t_ns = applied.wheel.header.time_ns;
            let published = (|| -> anyhow::Result<()> {
                if let Some(s) = tracker.due(t_ns, node.status()) {
                    status.publish(&s)?;
                }
                wheel.publish(&applied.wheel)?;
                cmg.publish(&applied.cmg)?;
                Ok(())
            })();
            if error.failed(published) {
                return Flow::Stop;
            }
            heartbeat.add_samples_out(2);
            counters.update(&heartbeat, &node.status());
        }
        Flow::Continue
    })?;
    let s = node.status();
    tracing::info!(
        ?exit,
        sent = s.frames_sent,
        tx_drop = s.injected_tx_drop,
        tx_corrupt = s.injected_tx_corrupt,
        tx_delay = s.injected_tx_delay,
        tx_duplicate = s.injected_tx_duplicate,
        rx_drop = s.injected_rx_drop,
        rx_corrupt = s.injected_rx_corrupt,
        rx_delay = s.injected_rx_delay,
        rx_duplicate = s.injected_rx_duplicate,
        overdue_ticks = node.overdue_ticks(),
        "{name} stopping"
    );
    heartbeat.set_state(ProcessState::Stopping);
    error.into_result()
}

/// The `can-replay` process: puts a recorded `candump -L` file (`can.candump`) back on the
/// software bus. In lockstep it owns the clock as the plant does: after the frames up to and
/// including a tick's sync it waits for the estimator's estimate of that tick before the next
/// (so the gateways and the estimator see the frames in the recorded order and grouping);
/// paced, it follows the file's time stamps. It ends at the end of the file.
pub fn run_replay() -> anyhow::Result<()> {
    let name = "can-replay";
    let (config, bus) = process::start(name)?;
    let path = config.can.candump.clone().context("can-replay: can.candump names no file to replay")?;
    let file = File::open(&path).with_context(|| format!("can-replay: opening {}", path.display()))?;
    let mut reader = CandumpReader::new(BufReader::new(file));
    let schedule = config.schedule()?;
    let protocol = node::protocol(&config)?;
    let mut sync_decoder = Decoder::with_devices(protocol, DeviceSet::of(&[Device::Node]));
    let mut clock = NodeClock::new();
    let link = SoftwareBusTransport::open(&bus, can_source::REPLAY, SampleHeader::VALID | SampleHeader::REPLAYED, BUS_BUFFER)?;
    let estimates = bus.subscriber::<AttitudeEstimate>()?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;
    let lockstep = config.run.mode == ClockMode::Lockstep;
    let participants: Vec<String> = config.run.participants.iter().filter(|p| p.as_str() != name).cloned().collect();
    let answered_by_estimator = lockstep && participants.iter().any(|p| p == "estimator");
    if process::wait_for_participants(&bus, &participants)? == LoopExit::TerminationRequested {
        return Ok(());
    }
    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    events.on_data(&estimates)?;
    events.on_data(link.subscriber())?;
    let pace = (!lockstep).then(|| events.on_interval(POLL_PERIOD)).transpose()?;
    events.with_heartbeat(&heartbeat)?;
    heartbeat.set_state(ProcessState::Running);

    let started = Instant::now();
    let mut first_ns: Option<u64> = None;
    let mut newest_estimate: Option<u64> = None;
    let mut waiting_for: Option<u64> = None;
    let mut pending: Option<TimestampedFrame> = None;
    let mut ticks = 0u64;
    let mut error = FirstError::default();
    let mut finished = false;
    let _pace = pace;
    let mut step = || -> Flow {
        // Frames from others (gateways' commands) are not replayed; keep the buffer empty.
        while let Ok(Some(_)) = link.poll() {}
        if error.failed(estimates.drain(|e| newest_estimate = newest_estimate.max(Some(e.header.time_ns))).map_err(anyhow::Error::from)) {
            return Flow::Stop;
        }
        if waiting_for.is_some_and(|t| newest_estimate.is_none_or(|n| n < t)) {
            return Flow::Continue;
        }
        waiting_for = None;
        loop {
            let frame = match pending.take() {
                Some(f) => f,
                None => match reader.next_frame() {
                    Ok(Some(f)) => f,
                    Ok(None) => {
                        finished = true;
                        return Flow::Stop;
                    }
                    Err(e) => {
                        error.failed::<()>(Err(anyhow::Error::from(e).context(format!("reading {}", path.display()))));
                        return Flow::Stop;
                    }
                },
            };
            if !lockstep {
                // Paced: release at the recorded spacing.
                let t0 = *first_ns.get_or_insert(frame.time_ns);
                let due = Duration::from_nanos(frame.time_ns.saturating_sub(t0));
                if started.elapsed() < due {
                    // Released by a later wake-up of the pacing interval.
                    pending = Some(frame);
                    return Flow::Continue;
                }
            }
            link.set_time_ns(frame.time_ns);
            if let Err(e) = link.send_frame(&frame.frame) {
                error.failed::<()>(Err(anyhow::Error::from(e).context("sending on the software CAN bus")));
                return Flow::Stop;
            }
            heartbeat.add_samples_out(1);
            let sync = match sync_decoder.decode(&frame.frame).message.map(|r| r.message) {
                Some(Message::NodeHeartbeat(hb)) => run_time_ns(&mut clock, &schedule, hb.node_time_us),
                _ => None,
            };
            if let Some(t_ns) = sync {
                ticks += 1;
                heartbeat.set_time_ns(t_ns);
                if answered_by_estimator {
                    waiting_for = Some(t_ns);
                    if newest_estimate.is_none_or(|n| n < t_ns) {
                        return Flow::Continue;
                    }
                    waiting_for = None;
                }
            }
        }
    };
    // The first frames go out now; then every estimate (or pacing interval) releases more.
    let exit = match step() {
        Flow::Stop => LoopExit::Stopped,
        Flow::Continue => events.run(|_| step())?,
    };
    // The file ends after the frames that follow its last sync, which were read only once that
    // tick was answered: the estimate of every tick is out when the replay ends the run.
    tracing::info!(?exit, finished, ticks, stats = %reader.stats(), "{name} done");
    heartbeat.set_state(ProcessState::Stopping);
    error.into_result()
}
