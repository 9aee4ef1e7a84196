//! The control chain as separate processes: gyro gateway → estimator → controller → wheel
//! gateway, with the pipeline's own logic ([`EstimatorTask`], [`ControllerTask`]) on the
//! pipeline's sample types.
//!
//! The gyro gateway replays a recorded closed-loop run (gyro, and the inclinometer and
//! magnetometer samples due at the same tick, published just before the gyro sample) at a
//! fixed wall-clock period; the wheel gateway takes each wheel command and publishes the
//! wheel and CMG telemetry of the next tick, so the controller has everything for a tick when
//! its estimate arrives. A cycle's latency runs from the gyro sample entering its gateway
//! (just before it is published) to the wheel command leaving the wheel gateway (received and
//! range-checked). Device time stamps are the recorded run's (10 Hz ticks); only the wall-clock
//! pacing is faster.

use crate::latency::protocol::{
    Addr, Role, STALL, STARTUP, Signal, Transport, WorkerResult, WorkerSpec, report, say,
    wait_for_go,
};
use crate::latency::recording::{Recording, TICK_NS, run_config};
use crate::latency::system::{now_ns, sleep_until};
use crate::latency::topics::{self, Kind, Msg, Ports};
use crate::latency::transport::{Events, Polling, Sock, poll_until, wait_for_events};
use anyhow::{Context, Result, anyhow, bail};
use std::time::{Duration, Instant};
use testbed_bus::{Bus, EventLoop, WaitStats, Waiter};
use testbed_flight::tasks::{ControllerTask, EstimatorTask};

/// `source_id` of the sample that ends the chain.
pub const STOP_SOURCE: u32 = u32::MAX;

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
    ports: &'a Ports<Events>,
    events: Option<EventLoop<'w, 'a>>,
}

impl ChainLink for BusChain<'_, '_> {
    fn send(&mut self, msg: &Msg) -> Result<()> {
        self.ports.send(msg)
    }
    fn recv(&mut self, out: &mut Vec<(Msg, u64)>) -> Result<()> {
        let events = self
            .events
            .as_mut()
            .context("this process receives nothing")?;
        let ports = self.ports;
        wait_for_events(events, || {
            ports.drain(out)?;
            Ok(!out.is_empty())
        })
    }
    fn subscribers(&self, kind: Kind) -> usize {
        self.ports.subscribers(kind)
    }
    fn wait_stats(&self) -> Option<WaitStats> {
        self.events.as_ref().map(EventLoop::wait_stats)
    }
}

impl ChainLink for Ports<Polling> {
    fn send(&mut self, msg: &Msg) -> Result<()> {
        Ports::send(self, msg)
    }
    fn recv(&mut self, out: &mut Vec<(Msg, u64)>) -> Result<()> {
        poll_until(|| {
            self.drain(out)?;
            Ok(!out.is_empty())
        })
    }
    fn subscribers(&self, kind: Kind) -> usize {
        Ports::subscribers(self, kind)
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
        let Some((_, addr)) = self.routes.iter().find(|(k, _)| *k == msg.topic_id()) else {
            return Ok(());
        };
        topics::encode(msg, &mut self.out)?;
        // A full queue drops the sample (the receiver counts it missing), except the stop
        // marker, which waits for room.
        let stop = msg.header().source_id == STOP_SOURCE;
        let start = Instant::now();
        while !self.sender.send_to(&self.out, addr)? && stop && start.elapsed() < STALL {
            std::thread::sleep(Duration::from_micros(100));
        }
        Ok(())
    }
    fn recv(&mut self, out: &mut Vec<(Msg, u64)>) -> Result<()> {
        let sock = self
            .receive
            .as_ref()
            .context("this process receives nothing")?;
        let mut n = Some(sock.recv(&mut self.buf)?);
        while let Some(len) = n {
            let t = now_ns();
            out.push((
                topics::decode(&self.buf[..len]).context("undecodable message")?,
                t,
            ));
            n = sock.try_recv(&mut self.buf)?;
        }
        Ok(())
    }
}

/// What a chain process publishes and subscribes to.
fn topics(role: Role) -> (&'static [Kind], &'static [Kind]) {
    use crate::latency::topics::Kind::{AttitudeEstimate as Estimate, ControllerStatus as Status};
    use crate::latency::topics::Kind::{CmgCommand as CmgCmd, CmgTelemetry as CmgTm, Gyro};
    use crate::latency::topics::Kind::{Inclinometer as Tilt, Magnetometer as Field};
    use crate::latency::topics::Kind::{WheelCommand as WheelCmd, WheelTelemetry as WheelTm};
    match role {
        Role::Gyro => (&[Gyro, Tilt, Field], &[]),
        Role::Estimator => (&[Estimate], &[Gyro, Tilt, Field]),
        Role::Controller => (&[Status, WheelCmd, CmgCmd], &[Estimate, WheelTm, CmgTm]),
        _ => (&[WheelTm, CmgTm], &[WheelCmd, CmgCmd]),
    }
}

/// A chain process: its ports on the spec's transport, `ready`, then its role.
pub fn worker(spec: &WorkerSpec) -> Result<()> {
    let (publishes, subscribes) = topics(spec.role);
    let bus = || Bus::open(spec.role.name(), &spec.bus_config());
    match spec.transport {
        Transport::IoxEvent(strategy) => {
            let bus = bus()?;
            let ports = Ports::<Events>::new(&bus, publishes, subscribes)?;
            let waiter = Waiter::new()?;
            let mut events =
                (!subscribes.is_empty()).then(|| EventLoop::with_wait_strategy(&waiter, strategy));
            if let Some(events) = &mut events {
                ports.attach(events)?;
            }
            role(
                spec,
                &mut BusChain {
                    ports: &ports,
                    events,
                },
            )
        }
        Transport::IoxPoll => role(
            spec,
            &mut Ports::<Polling>::new(&bus()?, publishes, subscribes)?,
        ),
        Transport::Uds | Transport::Udp => {
            let [estimator, controller, wheels] = <[Addr; 3]>::try_from(spec.addrs.clone())
                .map_err(|_| anyhow!("three socket addresses"))?;
            let receive = match spec.role {
                Role::Estimator => Some(Sock::bind(&estimator)?),
                Role::Controller => Some(Sock::bind(&controller)?),
                Role::Wheels => Some(Sock::bind(&wheels)?),
                _ => None,
            };
            let routes = [
                (Kind::Gyro, &estimator),
                (Kind::Inclinometer, &estimator),
                (Kind::Magnetometer, &estimator),
                (Kind::AttitudeEstimate, &controller),
                (Kind::WheelTelemetry, &controller),
                (Kind::CmgTelemetry, &controller),
                (Kind::WheelCommand, &wheels),
                (Kind::CmgCommand, &wheels),
            ];
            let routes = routes.into_iter().map(|(k, a)| (k, a.clone())).collect();
            let sender = Sock::sender(&wheels)?;
            role(
                spec,
                &mut SockChain {
                    receive,
                    sender,
                    routes,
                    out: Vec::with_capacity(1024),
                    buf: vec![0; 4096],
                },
            )
        }
    }
}

fn role(spec: &WorkerSpec, link: &mut dyn ChainLink) -> Result<()> {
    // Every port of this process exists: a peer may send to it.
    say(Signal::Ready);
    let config = run_config();
    match spec.role {
        Role::Gyro => gyro_gateway(spec, link),
        Role::Estimator => stage(
            spec,
            link,
            &mut EstimatorTask::new(config.estimator_setup()?, config.schedule()?),
        ),
        Role::Controller => stage(
            spec,
            link,
            &mut ControllerTask::new(
                &config.controller,
                &config.model,
                config.manoeuvre.target(),
                config.schedule()?,
            )?,
        ),
        _ => wheel_gateway(spec, link),
    }
}

fn recording(spec: &WorkerSpec) -> Result<Recording> {
    Recording::load(
        spec.recording
            .as_ref()
            .context("the chain needs a recording")?,
    )
}

/// Waits until a bus peer subscribes to `kind` (sockets: at once).
fn wait_for_peer(link: &dyn ChainLink, kind: Kind) -> Result<()> {
    let start = Instant::now();
    while link.subscribers(kind) == 0 {
        if start.elapsed() > STARTUP {
            bail!("timed out waiting for a subscriber of {kind:?}");
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    Ok(())
}

fn gyro_gateway(spec: &WorkerSpec, link: &mut dyn ChainLink) -> Result<()> {
    let rec = recording(spec)?;
    let total = spec.warmup + spec.count;
    anyhow::ensure!(
        rec.len() > total + 1,
        "the recording holds {} ticks, {} needed",
        rec.len(),
        total + 2
    );
    let mut sent = vec![0_u64; total];
    wait_for_go()?;
    wait_for_peer(link, Kind::Gyro)?;
    // Let the rest of the chain connect; the warm-up cycles absorb what remains.
    std::thread::sleep(Duration::from_millis(200));
    let period = spec.interval_us * 1000;
    let start = now_ns() + 10_000_000;
    for (k, sent) in sent.iter_mut().enumerate() {
        sleep_until(start + k as u64 * period);
        if k == spec.warmup {
            say(Signal::Measuring);
        }
        for msg in [
            rec.tilt(k).map(Msg::Inclinometer),
            rec.field(k).map(Msg::Magnetometer),
        ]
        .into_iter()
        .flatten()
        {
            link.send(&msg)?;
        }
        let gyro = rec.gyro(k);
        *sent = now_ns();
        link.send(&Msg::Gyro(gyro))?;
    }
    sleep_until(now_ns() + 2 * period);
    // The real estimator treats this as one more tick; the bench's own stops on it.
    let mut stop = rec.gyro(total);
    stop.header.source_id = STOP_SOURCE;
    link.send(&Msg::Gyro(stop))?;
    report(&WorkerResult {
        sent: sent[spec.warmup..].to_vec(),
        ..WorkerResult::default()
    })
}

/// Index of the tick a sample belongs to, if it is one of the measured ones.
fn measured(spec: &WorkerSpec, time_ns: u64) -> Option<usize> {
    let k = (time_ns / TICK_NS) as usize;
    (k >= spec.warmup && k < spec.warmup + spec.count).then(|| k - spec.warmup)
}

/// The pipeline's task logic between the chain's topics: the estimator and the controller.
trait Stage {
    /// The topic whose sample starts the measured stage (and, marked, stops the chain).
    const TRIGGER: Kind;
    /// The topic whose sample ends it.
    const OUTPUT: Kind;
    fn take(&mut self, msg: &Msg);
    fn emit(&mut self, out: &mut Vec<Msg>);
}

impl Stage for EstimatorTask {
    const TRIGGER: Kind = Kind::Gyro;
    const OUTPUT: Kind = Kind::AttitudeEstimate;
    fn take(&mut self, msg: &Msg) {
        match msg {
            Msg::Gyro(s) => self.on_gyro(s),
            Msg::Inclinometer(s) => self.on_inclinometer(s),
            Msg::Magnetometer(s) => self.on_magnetometer(s),
            _ => {}
        }
    }
    fn emit(&mut self, out: &mut Vec<Msg>) {
        out.extend(self.ready().into_iter().map(Msg::AttitudeEstimate));
    }
}

impl Stage for ControllerTask {
    const TRIGGER: Kind = Kind::AttitudeEstimate;
    const OUTPUT: Kind = Kind::WheelCommand;
    fn take(&mut self, msg: &Msg) {
        match msg {
            Msg::AttitudeEstimate(e) => self.on_estimate(e),
            Msg::WheelTelemetry(t) => self.on_wheel_telemetry(t),
            Msg::CmgTelemetry(t) => self.on_cmg_telemetry(t),
            _ => {}
        }
    }
    fn emit(&mut self, out: &mut Vec<Msg>) {
        for cycle in self.ready() {
            out.extend([
                Msg::ControllerStatus(cycle.status),
                Msg::WheelCommand(cycle.wheels),
                Msg::CmgCommand(cycle.cmg),
            ]);
        }
    }
}

/// A task's process: takes every arrived sample, publishes what the task has ready, and times
/// each measured tick from its trigger taken to its output published.
fn stage<S: Stage>(spec: &WorkerSpec, link: &mut dyn ChainLink, task: &mut S) -> Result<()> {
    let (mut batch, mut outputs) = (Vec::with_capacity(16), Vec::with_capacity(16));
    let (mut received, mut sent) = (vec![0_u64; spec.count], vec![0_u64; spec.count]);
    loop {
        batch.clear();
        if let Err(e) = link.recv(&mut batch) {
            eprintln!("{}: {e:#}", spec.role.name());
            break;
        }
        let mut stop = None;
        for (msg, t) in &batch {
            let header = *msg.header();
            if msg.topic_id() == S::TRIGGER {
                if header.source_id == STOP_SOURCE {
                    stop = Some(header);
                    continue;
                }
                if let Some(i) = measured(spec, header.time_ns) {
                    received[i] = *t;
                }
            }
            task.take(msg);
        }
        outputs.clear();
        task.emit(&mut outputs);
        for msg in &outputs {
            if let Some(i) =
                measured(spec, msg.header().time_ns).filter(|_| msg.topic_id() == S::OUTPUT)
            {
                sent[i] = now_ns();
            }
            link.send(msg)?;
        }
        if let Some(header) = stop {
            link.send(
                &topics::empty(S::OUTPUT, header).context("the output is a topic of the chain")?,
            )?;
            break;
        }
    }
    report(&WorkerResult {
        received,
        sent,
        wait: link.wait_stats().map(Into::into),
        ..WorkerResult::default()
    })
}

/// Largest plausible wheel motor torque, Nm (the gateway's range check).
const TORQUE_LIMIT_NM: f64 = 1.0;

fn wheel_gateway(spec: &WorkerSpec, link: &mut dyn ChainLink) -> Result<()> {
    let rec = recording(spec)?;
    let total = spec.warmup + spec.count;
    let mut received = vec![0_u64; total];
    let mut out_of_range = 0;
    let mut batch = Vec::with_capacity(16);
    wait_for_go()?;
    wait_for_peer(link, Kind::WheelTelemetry)?;
    link.send(&Msg::WheelTelemetry(rec.wheels(0, [0.0; 3])))?;
    link.send(&Msg::CmgTelemetry(rec.cmg(0, [0.0; 4])))?;
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
                Msg::WheelCommand(c) => {
                    let k = (c.header.time_ns / TICK_NS) as usize;
                    if c.header.source_id == STOP_SOURCE || k >= total {
                        break 'run;
                    }
                    if received[k] == 0 {
                        received[k] = t;
                    }
                    if !c
                        .torque
                        .iter()
                        .all(|x| x.is_finite() && x.abs() <= TORQUE_LIMIT_NM)
                    {
                        out_of_range += 1;
                    }
                    if k + 1 < rec.len() {
                        let telemetry = [
                            Msg::WheelTelemetry(rec.wheels(k + 1, c.torque)),
                            Msg::CmgTelemetry(rec.cmg(k + 1, cmg_rate)),
                        ];
                        for m in &telemetry {
                            let sent = link.send(m);
                            // Past the last measured tick the controller may have stopped.
                            if k + 1 < total {
                                sent?;
                            }
                        }
                    }
                    if k + 1 == total && !said_done {
                        say(Signal::Done);
                        said_done = true;
                    }
                }
                Msg::CmgCommand(c) => cmg_rate = c.gimbal_rate,
                _ => {}
            }
        }
    }
    if !said_done {
        say(Signal::Done);
    }
    report(&WorkerResult {
        received: received[spec.warmup..].to_vec(),
        out_of_range,
        wait: link.wait_stats().map(Into::into),
        ..WorkerResult::default()
    })
}
