//! The control chain as separate processes: gyro gateway → estimator → controller → wheel
//! gateway, with the pipeline's own logic (`EstimatorNode`, `ControllerNode`, the MEKF and the
//! controller tasks) on the pipeline's sample types.
//!
//! The gyro gateway replays a recorded closed-loop run (gyro, and the inclinometer and
//! magnetometer samples due at the same tick, published just before the gyro sample) at a
//! fixed wall-clock period; the wheel gateway takes each wheel command and publishes the
//! wheel and CMG telemetry of the next tick, so the controller has everything for a tick when
//! its estimate arrives. A cycle's latency runs from the gyro sample entering its gateway
//! (just before it is published) to the wheel command leaving the wheel gateway (received and
//! range-checked). Device time stamps are the recorded run's (10 Hz ticks); only the wall-clock
//! pacing is faster.

use crate::system::{now_ns, sleep_until};
use crate::transport::{Addr, PollPub, PollSub, STALL, Sock, Transport};
use crate::worker::{Role, WorkerResult, WorkerSpec, bus_config, recording, report, say, wait_until};
use anyhow::{Context, Result, bail};
use ipc_types::*;
use std::path::Path;
use std::time::{Duration, Instant};
use testbed_bus::{Bus, EventLoop, Flow, TopicPublisher, TopicSubscriber, WaitStats, WaitStrategy, Waiter};
use testbed_flight::tasks::ControllerTask;
use testbed_flight::controller_node::ControllerNode;
use testbed_flight::estimator_node::EstimatorNode;
use testbed_runtime::RunConfig;

/// `source_id` of the sample that ends the chain.
pub const STOP_SOURCE: u32 = u32::MAX;
/// Device-time period of the recorded run's ticks (10 Hz).
pub const TICK_NS: u64 = 100_000_000;

/// The run configuration every chain process uses (the pipeline's defaults).
pub fn run_config() -> RunConfig {
    RunConfig::default()
}

// ---------------------------------------------------------------------------------------------
// The recording the gateways replay.

const FIELDS: usize = 17;

/// What the devices reported at every tick of a closed-loop run.
pub struct Recording {
    ticks: Vec<[f64; FIELDS]>,
}

impl Recording {
    /// Runs the pipeline's scenario in process for `ticks` ticks and writes what its devices
    /// reported to `path`.
    pub fn record(path: &Path, ticks: usize) -> Result<()> {
        let mut scenario = testbed_sim::closed_loop::Scenario::from_run(&run_config());
        scenario.duration_s = ticks as f64 * TICK_NS as f64 * 1e-9;
        let (_, measurements) = testbed_sim::closed_loop::run_recorded(&scenario)?;
        let mut bytes = Vec::with_capacity(measurements.len() * FIELDS * 8);
        for m in &measurements {
            let tilt = m.tilt_rad;
            let field = m.field_t;
            let row: [f64; FIELDS] = [
                m.gyro_rad_s.x,
                m.gyro_rad_s.y,
                m.gyro_rad_s.z,
                f64::from(u8::from(tilt.is_some())),
                tilt.map_or(0.0, |t| t[0]),
                tilt.map_or(0.0, |t| t[1]),
                f64::from(u8::from(field.is_some())),
                field.map_or(0.0, |f| f.x),
                field.map_or(0.0, |f| f.y),
                field.map_or(0.0, |f| f.z),
                m.wheel_speed_rad_s.x,
                m.wheel_speed_rad_s.y,
                m.wheel_speed_rad_s.z,
                m.gimbal_rad[0],
                m.gimbal_rad[1],
                m.gimbal_rad[2],
                m.gimbal_rad[3],
            ];
            for v in row {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))
    }

    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        let ticks = bytes
            .chunks_exact(FIELDS * 8)
            .map(|row| std::array::from_fn(|i| f64::from_le_bytes(row[i * 8..i * 8 + 8].try_into().expect("8 bytes"))))
            .collect();
        Ok(Self { ticks })
    }

    pub fn len(&self) -> usize {
        self.ticks.len()
    }

    fn header(k: usize) -> SampleHeader {
        SampleHeader::new(k as u64 * TICK_NS, k as u64, SampleHeader::VALID)
    }

    pub fn gyro(&self, k: usize) -> GyroSample {
        let r = &self.ticks[k];
        GyroSample::new(Self::header(k), [r[0], r[1], r[2]])
    }

    pub fn tilt(&self, k: usize) -> Option<InclinometerSample> {
        let r = &self.ticks[k];
        (r[3] != 0.0).then(|| InclinometerSample::new(Self::header(k), [r[4], r[5]]))
    }

    pub fn field(&self, k: usize) -> Option<MagnetometerSample> {
        let r = &self.ticks[k];
        (r[6] != 0.0).then(|| MagnetometerSample::new(Self::header(k), [r[7], r[8], r[9]]))
    }

    pub fn wheels(&self, k: usize, torque: [f64; 3]) -> WheelTelemetry {
        let r = &self.ticks[k];
        WheelTelemetry::new(Self::header(k), [r[10], r[11], r[12]], torque)
    }

    pub fn cmg(&self, k: usize, rate: [f64; 4]) -> CmgTelemetry {
        let r = &self.ticks[k];
        CmgTelemetry::new(Self::header(k), [r[13], r[14], r[15], r[16]], rate)
    }
}

// ---------------------------------------------------------------------------------------------
// Messages and ports of every transport.

macro_rules! chain_topics {
    ($mac:ident) => {
        $mac! {
            (Gyro, GyroSample, gyro),
            (Tilt, InclinometerSample, tilt),
            (Field, MagnetometerSample, field),
            (Estimate, AttitudeEstimate, estimate),
            (WheelTm, WheelTelemetry, wheel_tm),
            (CmgTm, CmgTelemetry, cmg_tm),
            (Status, ControllerStatus, status),
            (WheelCmd, WheelCommand, wheel_cmd),
            (CmgCmd, CmgCommand, cmg_cmd),
        }
    };
}

macro_rules! define_messages {
    ($(($v:ident, $t:ty, $f:ident)),* $(,)?) => {
        /// Which topic.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Kind { $($v),* }

        /// A sample of one of the chain's topics (by value, as the bus hands them out).
        #[derive(Debug, Clone, Copy)]
        #[allow(clippy::large_enum_variant)]
        pub enum Msg { $($v($t)),* }

        impl Msg {
            pub fn kind(&self) -> Kind {
                match self { $(Self::$v(_) => Kind::$v),* }
            }
            /// Tag byte and the sample's bytes, as a socket sends them.
            fn encode(&self, out: &mut Vec<u8>) {
                out.clear();
                out.extend_from_slice(&(self.kind() as u32).to_le_bytes());
                out.extend_from_slice(&[0; 4]);
                match self { $(Self::$v(s) => out.extend_from_slice(crate::payload::bytes_of(s))),* }
            }
            fn decode(bytes: &[u8]) -> Option<Self> {
                let tag = u32::from_le_bytes(bytes.get(..4)?.try_into().ok()?);
                let body = bytes.get(8..)?;
                $(
                    if tag == Kind::$v as u32 {
                        let mut s = <$t>::default();
                        let dst = crate::payload::bytes_of_mut(&mut s);
                        if body.len() != dst.len() { return None; }
                        dst.copy_from_slice(body);
                        return Some(Self::$v(s));
                    }
                )*
                None
            }
        }

        /// The bus's ports of one chain process.
        #[derive(Default)]
        pub struct BusPorts {
            $($f: (Option<TopicPublisher<$t>>, Option<TopicSubscriber<$t>>),)*
        }

        impl BusPorts {
            fn new(bus: &Bus, publishes: &[Kind], subscribes: &[Kind]) -> Result<Self> {
                let mut ports = Self::default();
                $(
                    if publishes.contains(&Kind::$v) { ports.$f.0 = Some(bus.publisher::<$t>()?); }
                    if subscribes.contains(&Kind::$v) { ports.$f.1 = Some(bus.subscriber::<$t>()?); }
                )*
                Ok(ports)
            }
            fn attach<'a>(&'a self, events: &mut EventLoop<'_, 'a>) -> Result<()> {
                $( if let Some(s) = &self.$f.1 { events.on_data(s)?; } )*
                Ok(())
            }
            /// Every pending sample, topic by topic in declaration order (the binaries' order).
            fn drain(&self, out: &mut Vec<(Msg, u64)>) -> Result<()> {
                $( if let Some(s) = &self.$f.1 { s.drain(|v| out.push((Msg::$v(v), now_ns())))?; } )*
                Ok(())
            }
            fn send(&self, msg: &Msg) -> Result<()> {
                match msg {
                    $(Msg::$v(v) => {
                        self.$f.0.as_ref().with_context(|| format!("no publisher for {:?}", msg.kind()))?.publish(v)?;
                    })*
                }
                Ok(())
            }
            fn subscribers(&self, kind: Kind) -> usize {
                match kind { $(Kind::$v => self.$f.0.as_ref().map_or(0, |p| p.subscriber_count())),* }
            }
        }

        /// iceoryx2 ports without events, polled.
        #[derive(Default)]
        pub struct PollPorts {
            $($f: (Option<PollPub<$t>>, Option<PollSub<$t>>),)*
        }

        impl PollPorts {
            fn new(bus: &Bus, publishes: &[Kind], subscribes: &[Kind]) -> Result<Self> {
                let mut ports = Self::default();
                $(
                    if publishes.contains(&Kind::$v) { ports.$f.0 = Some(PollPub::<$t>::new(bus)?); }
                    if subscribes.contains(&Kind::$v) { ports.$f.1 = Some(PollSub::<$t>::new(bus)?); }
                )*
                Ok(ports)
            }
            fn poll(&self, out: &mut Vec<(Msg, u64)>) -> Result<()> {
                $( if let Some(s) = &self.$f.1 { while let Some(v) = s.try_receive()? { out.push((Msg::$v(v), now_ns())); } } )*
                Ok(())
            }
            fn send(&self, msg: &Msg) -> Result<()> {
                match msg {
                    $(Msg::$v(v) => self.$f.0.as_ref().with_context(|| format!("no publisher for {:?}", msg.kind()))?.send(v)?,)*
                }
                Ok(())
            }
            fn subscribers(&self, kind: Kind) -> usize {
                match kind { $(Kind::$v => self.$f.0.as_ref().map_or(0, |p| p.subscriber_count())),* }
            }
        }
    };
}

chain_topics!(define_messages);

/// Send samples, wait (the transport's way) for the next ones.
trait ChainLink {
    fn send(&mut self, msg: &Msg) -> Result<()>;
    fn recv(&mut self, out: &mut Vec<(Msg, u64)>) -> Result<()>;
    /// Subscribers of `kind` (bus transports; sockets: 1).
    fn subscribers(&self, _kind: Kind) -> usize {
        1
    }
    fn wait_stats(&self) -> Option<WaitStats> {
        None
    }
}

struct BusChain<'w, 'a> {
    ports: &'a BusPorts,
    events: Option<EventLoop<'w, 'a>>,
}

impl ChainLink for BusChain<'_, '_> {
    fn send(&mut self, msg: &Msg) -> Result<()> {
        self.ports.send(msg)
    }
    fn recv(&mut self, out: &mut Vec<(Msg, u64)>) -> Result<()> {
        let events = self.events.as_mut().context("this process receives nothing")?;
        let ports = self.ports;
        let start = Instant::now();
        while out.is_empty() {
            if start.elapsed() > STALL {
                bail!("nothing arrived for {STALL:?}");
            }
            let mut failure = None;
            events.run_once(Duration::from_millis(200), |_| {
                if let Err(e) = ports.drain(out) {
                    failure = Some(e);
                    return Flow::Stop;
                }
                Flow::Continue
            })?;
            if let Some(e) = failure {
                return Err(e);
            }
        }
        Ok(())
    }
    fn subscribers(&self, kind: Kind) -> usize {
        self.ports.subscribers(kind)
    }
    fn wait_stats(&self) -> Option<WaitStats> {
        self.events.as_ref().map(EventLoop::wait_stats)
    }
}

struct PollChain {
    ports: PollPorts,
}

impl ChainLink for PollChain {
    fn send(&mut self, msg: &Msg) -> Result<()> {
        self.ports.send(msg)
    }
    fn recv(&mut self, out: &mut Vec<(Msg, u64)>) -> Result<()> {
        let start = Instant::now();
        let mut polls: u32 = 0;
        loop {
            self.ports.poll(out)?;
            if !out.is_empty() {
                return Ok(());
            }
            polls = polls.wrapping_add(1);
            if polls.is_multiple_of(65_536) && start.elapsed() > STALL {
                bail!("nothing arrived for {STALL:?}");
            }
            std::thread::yield_now();
        }
    }
    fn subscribers(&self, kind: Kind) -> usize {
        self.ports.subscribers(kind)
    }
}

struct SockChain {
    receive: Option<Sock>,
    sender: Sock,
    /// Where each topic goes (none: nobody subscribes, nothing is sent).
    routes: Vec<(Kind, Addr)>,
    out: Vec<u8>,
    buf: Vec<u8>,
}

impl ChainLink for SockChain {
    fn send(&mut self, msg: &Msg) -> Result<()> {
        let kind = msg.kind();
        if let Some((_, addr)) = self.routes.iter().find(|(k, _)| *k == kind) {
            msg.encode(&mut self.out);
            self.sender.send_to(&self.out, addr)?;
        }
        Ok(())
    }
    fn recv(&mut self, out: &mut Vec<(Msg, u64)>) -> Result<()> {
        let sock = self.receive.as_ref().context("this process receives nothing")?;
        self.buf.resize(4096, 0);
        let n = sock.recv(&mut self.buf)?;
        let t = now_ns();
        out.push((Msg::decode(&self.buf[..n]).context("undecodable message")?, t));
        while let Some(n) = sock.try_recv(&mut self.buf)? {
            let t = now_ns();
            out.push((Msg::decode(&self.buf[..n]).context("undecodable message")?, t));
        }
        Ok(())
    }
}

fn topics(role: Role) -> (&'static [Kind], &'static [Kind], &'static str) {
    use Kind::*;
    match role {
        Role::Gyro => (&[Gyro, Tilt, Field], &[], "gyro-gateway"),
        Role::Estimator => (&[Estimate], &[Gyro, Tilt, Field], "estimator"),
        Role::Controller => (&[Status, WheelCmd, CmgCmd], &[Estimate, WheelTm, CmgTm], "controller"),
        _ => (&[WheelTm, CmgTm], &[WheelCmd, CmgCmd], "wheel-gateway"),
    }
}

/// A chain process: its ports on the spec's transport, then its role.
pub fn worker(spec: &WorkerSpec) -> Result<()> {
    let (publishes, subscribes, name) = topics(spec.role);
    match &spec.transport {
        Transport::IoxEvent(wait) => {
            let strategy: WaitStrategy = wait.parse()?;
            let bus = Bus::open(name, &bus_config(spec))?;
            let ports = BusPorts::new(&bus, publishes, subscribes)?;
            let waiter = Waiter::new()?;
            let events = if subscribes.is_empty() {
                None
            } else {
                let mut events = EventLoop::with_wait_strategy(&waiter, strategy);
                ports.attach(&mut events)?;
                Some(events)
            };
            role(spec, &mut BusChain { ports: &ports, events })
        }
        Transport::IoxPoll => {
            let bus = Bus::open(name, &bus_config(spec))?;
            role(spec, &mut PollChain { ports: PollPorts::new(&bus, publishes, subscribes)? })
        }
        Transport::Uds | Transport::Udp => {
            let [estimator, controller, wheels] = <[Addr; 3]>::try_from(spec.addrs.clone()).map_err(|_| anyhow::anyhow!("three socket addresses"))?;
            let receive = match spec.role {
                Role::Estimator => Some(Sock::bind(&estimator)?),
                Role::Controller => Some(Sock::bind(&controller)?),
                Role::Wheels => Some(Sock::bind(&wheels)?),
                _ => None,
            };
            use Kind::*;
            let routes = vec![
                (Gyro, estimator.clone()),
                (Tilt, estimator.clone()),
                (Field, estimator.clone()),
                (Estimate, controller.clone()),
                (WheelTm, controller.clone()),
                (CmgTm, controller),
                (WheelCmd, wheels.clone()),
                (CmgCmd, wheels.clone()),
            ];
            let sender = Sock::sender(&wheels)?;
            role(spec, &mut SockChain { receive, sender, routes, out: Vec::with_capacity(1024), buf: vec![0; 4096] })
        }
    }
}

fn role(spec: &WorkerSpec, link: &mut dyn ChainLink) -> Result<()> {
    match spec.role {
        Role::Gyro => gyro_gateway(spec, link),
        Role::Estimator => estimator(spec, link),
        Role::Controller => controller(spec, link),
        _ => wheel_gateway(spec, link),
    }
}

fn stopping<T: Topic>(mut sample: T) -> T {
    sample.header_mut().source_id = STOP_SOURCE;
    sample
}

fn gyro_gateway(spec: &WorkerSpec, link: &mut dyn ChainLink) -> Result<()> {
    let rec = recording(spec)?;
    let total = spec.warmup + spec.count;
    anyhow::ensure!(rec.len() > total + 1, "the recording holds {} ticks, {} needed", rec.len(), total + 2);
    let mut sent = vec![0_u64; total];
    say("ready");
    crate::worker::wait_for_go()?;
    if spec.transport.is_bus() {
        wait_until("the estimator", || link.subscribers(Kind::Gyro) > 0)?;
    }
    // Let the rest of the chain connect; the warm-up cycles absorb what remains.
    std::thread::sleep(Duration::from_millis(200));
    let period = spec.period_us * 1000;
    let start = now_ns() + 10_000_000;
    #[allow(clippy::needless_range_loop)]
    for k in 0..total {
        sleep_until(start + k as u64 * period);
        if k == spec.warmup {
            say("measuring");
        }
        if let Some(s) = rec.tilt(k) {
            link.send(&Msg::Tilt(s))?;
        }
        if let Some(s) = rec.field(k) {
            link.send(&Msg::Field(s))?;
        }
        let gyro = rec.gyro(k);
        sent[k] = now_ns();
        link.send(&Msg::Gyro(gyro))?;
    }
    sleep_until(now_ns() + 2 * period);
    // The real estimator treats this as one more tick; the bench's own stops on it.
    link.send(&Msg::Gyro(stopping(rec.gyro(total))))?;
    report(&WorkerResult { sent: sent[spec.warmup..].to_vec(), ..WorkerResult::default() })
}

/// Index of the tick a sample belongs to, if it is one of the measured ones.
fn measured(spec: &WorkerSpec, time_ns: u64) -> Option<usize> {
    let k = (time_ns / TICK_NS) as usize;
    (k >= spec.warmup && k < spec.warmup + spec.count).then(|| k - spec.warmup)
}

fn estimator(spec: &WorkerSpec, link: &mut dyn ChainLink) -> Result<()> {
    let config = run_config();
    let mut node = EstimatorNode::new(config.estimator_config(), config.schedule()?);
    let mut batch = Vec::with_capacity(16);
    // When each measured tick's gyro sample was taken and its estimate published.
    let (mut received, mut sent) = (vec![0_u64; spec.count], vec![0_u64; spec.count]);
    say("ready");
    loop {
        batch.clear();
        if let Err(e) = link.recv(&mut batch) {
            eprintln!("estimator: {e:#}");
            break;
        }
        let mut stop = None;
        for &(msg, t) in &batch {
            match &msg {
                Msg::Gyro(s) if s.header.source_id == STOP_SOURCE => stop = Some(s.header),
                Msg::Gyro(s) => {
                    if let Some(i) = measured(spec, s.header.time_ns) {
                        received[i] = t;
                    }
                    node.on_gyro(s)
                }
                Msg::Tilt(s) => node.on_inclinometer(s),
                Msg::Field(s) => node.on_magnetometer(s),
                _ => {}
            }
        }
        for e in node.ready() {
            if let Some(i) = measured(spec, e.header.time_ns) {
                sent[i] = now_ns();
            }
            link.send(&Msg::Estimate(e))?;
        }
        if let Some(header) = stop {
            link.send(&Msg::Estimate(AttitudeEstimate { header, ..AttitudeEstimate::default() }))?;
            break;
        }
    }
    report(&WorkerResult { received, sent, wait: link.wait_stats().map(Into::into), ..WorkerResult::default() })
}

fn controller(spec: &WorkerSpec, link: &mut dyn ChainLink) -> Result<()> {
    let config = run_config();
    let schedule = config.schedule()?;
    let task = ControllerTask::new(&config.controller, &config.model, config.manoeuvre.target())?;
    let mut node = ControllerNode::new(task, config.controller.actuators, schedule);
    let mut batch = Vec::with_capacity(16);
    // When each measured tick's estimate was taken and its wheel command published.
    let (mut received, mut sent) = (vec![0_u64; spec.count], vec![0_u64; spec.count]);
    say("ready");
    loop {
        batch.clear();
        if let Err(e) = link.recv(&mut batch) {
            eprintln!("controller: {e:#}");
            break;
        }
        let mut stop = None;
        for &(msg, t) in &batch {
            match &msg {
                Msg::Estimate(e) if e.header.source_id == STOP_SOURCE => stop = Some(e.header),
                Msg::Estimate(e) => {
                    if let Some(i) = measured(spec, e.header.time_ns) {
                        received[i] = t;
                    }
                    node.on_estimate(e)
                }
                Msg::WheelTm(t) => node.on_wheel_telemetry(t),
                Msg::CmgTm(t) => node.on_cmg_telemetry(t),
                _ => {}
            }
        }
        for cycle in node.ready() {
            link.send(&Msg::Status(cycle.status))?;
            if let Some(i) = measured(spec, cycle.wheels.header.time_ns) {
                sent[i] = now_ns();
            }
            link.send(&Msg::WheelCmd(cycle.wheels))?;
            link.send(&Msg::CmgCmd(cycle.cmg))?;
        }
        if let Some(header) = stop {
            link.send(&Msg::WheelCmd(WheelCommand { header, ..WheelCommand::default() }))?;
            break;
        }
    }
    report(&WorkerResult { received, sent, wait: link.wait_stats().map(Into::into), ..WorkerResult::default() })
}

/// Largest plausible wheel motor torque, Nm (the gateway's range check).
const TORQUE_LIMIT_NM: f64 = 1.0;

fn wheel_gateway(spec: &WorkerSpec, link: &mut dyn ChainLink) -> Result<()> {
    let rec = recording(spec)?;
    let total = spec.warmup + spec.count;
    let mut received = vec![0_u64; total];
    let mut out_of_range = 0;
    let mut batch = Vec::with_capacity(16);
    say("ready");
    crate::worker::wait_for_go()?;
    if spec.transport.is_bus() {
        wait_until("the controller", || link.subscribers(Kind::WheelTm) > 0)?;
    }
    link.send(&Msg::WheelTm(rec.wheels(0, [0.0; 3])))?;
    link.send(&Msg::CmgTm(rec.cmg(0, [0.0; 4])))?;
    let mut cmg_rate = [0.0; 4];
    let mut said_done = false;
    'run: loop {
        batch.clear();
        if let Err(e) = link.recv(&mut batch) {
            // Stalled (samples lost on the way): report what arrived.
            eprintln!("wheel gateway: {e:#}; reporting what arrived");
            break 'run;
        }
        for &(msg, t) in &batch {
            match msg {
                Msg::WheelCmd(c) => {
                    let k = (c.header.time_ns / TICK_NS) as usize;
                    if c.header.source_id == STOP_SOURCE || k >= total {
                        break 'run;
                    }
                    if received[k] == 0 {
                        received[k] = t;
                    }
                    if !c.torque.iter().all(|x| x.is_finite() && x.abs() <= TORQUE_LIMIT_NM) {
                        out_of_range += 1;
                    }
                    if k + 1 < rec.len() {
                        link.send(&Msg::WheelTm(rec.wheels(k + 1, c.torque)))?;
                        link.send(&Msg::CmgTm(rec.cmg(k + 1, cmg_rate)))?;
                    }
                    if k + 1 == total && !said_done {
                        say("done");
                        said_done = true;
                    }
                }
                Msg::CmgCmd(c) => cmg_rate = c.gimbal_rate,
                _ => {}
            }
        }
    }
    if !said_done {
        say("done");
    }
    report(&WorkerResult { received: received[spec.warmup..].to_vec(), out_of_range, wait: link.wait_stats().map(Into::into), ..WorkerResult::default() })
}
