//! The worker processes: `latency worker <spec>` runs one ([`run`]). The hop's ping and pong
//! and the paced run's observer are here; the chain's processes are in [`chain`].

use crate::latency::chain;
use crate::latency::payload::{Payload, Ping, Pong, STOP, filled, header_of, set_sequence};

use crate::latency::protocol::{
    Addr, Role, STARTUP, Signal, Transport, WorkerResult, WorkerSpec, report, say, wait_for_go,
};
use crate::latency::system::{now_ns, precise_timers, sleep_until};
use crate::latency::transport::{PollPub, PollSub, Sock, poll_until, wait_for_events};
use anyhow::{Context, Result, bail};
use ipc_types::{
    AttitudeEstimate, ControllerStatus, GyroSample, SimTruth, Topic, WaitStrategy, WheelCommand,
};
use std::time::{Duration, Instant};
use testbed_bus::{
    Bus, EventLoop, Flow, SubscriberOptions, TopicPublisher, TopicSubscriber, WaitStats, Waiter,
};

/// Runs the worker `spec` describes.
pub fn run(spec: &WorkerSpec) -> Result<()> {
    precise_timers();
    match spec.role {
        Role::Ping | Role::Pong => match spec.size {
            48 => hop::<GyroSample, WheelCommand>(spec),
            64 => hop::<Ping<40>, Pong<40>>(spec),
            1024 => hop::<Ping<1000>, Pong<1000>>(spec),
            8192 => hop::<Ping<8168>, Pong<8168>>(spec),
            65_536 => hop::<Ping<65_512>, Pong<65_512>>(spec),
            other => bail!("no sample type of {other} bytes (48, 64, 1024, 8192, 65536)"),
        },
        Role::Gyro | Role::Estimator | Role::Controller | Role::Wheels => chain::worker(spec),
        Role::Observer => observer(spec),
    }
}

// ---------------------------------------------------------------------------------------------
// One hop, ping-pong: ping sends `P` and gets `Q` back.

fn hop<P: Payload, Q: Payload>(spec: &WorkerSpec) -> Result<()> {
    match spec.role {
        Role::Ping => endpoint::<P, Q>(spec, true),
        _ => endpoint::<Q, P>(spec, false),
    }
}

fn endpoint<Tx: Payload, Rx: Payload>(spec: &WorkerSpec, initiator: bool) -> Result<()> {
    let bus = || Bus::open(spec.role.name(), &spec.bus_config());
    let msg = || Box::new(Tx::from_wire(&filled::<Tx>(0)));
    match spec.transport {
        Transport::IoxEvent(strategy) => {
            let bus = bus()?;
            let (tx, rx) = (bus.publisher::<Tx>()?, bus.subscriber::<Rx>()?);
            let waiter = Waiter::new()?;
            let mut events = EventLoop::with_wait_strategy(&waiter, strategy);
            events.on_data(&rx)?;
            ping_pong(
                &mut BusLink {
                    tx: &tx,
                    rx: &rx,
                    events,
                    msg: msg(),
                },
                spec,
                initiator,
            )
        }
        Transport::IoxPoll => {
            let bus = bus()?;
            ping_pong(
                &mut PollLink {
                    tx: PollPub::<Tx>::new(&bus)?,
                    rx: PollSub::<Rx>::new(&bus)?,
                    msg: msg(),
                },
                spec,
                initiator,
            )
        }
        Transport::Uds | Transport::Udp => {
            let (mine, peer) = if initiator { (0, 1) } else { (1, 0) };
            let sock = Sock::bind(&spec.addrs[mine])?;
            let link = SockLink::<Tx, Rx> {
                sock,
                peer: spec.addrs[peer].clone(),
                msg: Box::new(filled::<Tx>(0)),
                buf: Box::new(bytemuck::Zeroable::zeroed()),
            };
            ping_pong(&mut { link }, spec, initiator)
        }
    }
}

/// One direction out, one in. `recv` waits the transport's way for at least one sample and
/// reports every arrived sample's sequence number with the time it was taken.
pub trait Link {
    fn send(&mut self, seq: u64) -> Result<()>;
    fn recv(&mut self, out: &mut Vec<(u64, u64)>) -> Result<()>;
    /// Whether the peer is connected (bus transports); sockets are always ready.
    fn peer_ready(&self) -> bool {
        true
    }
    fn wait_stats(&self) -> Option<WaitStats> {
        None
    }
}

/// The bus: publish, and an event loop on the subscriber.
pub struct BusLink<'w, 'a, Tx: Topic, Rx: Topic> {
    pub tx: &'a TopicPublisher<Tx>,
    pub rx: &'a TopicSubscriber<Rx>,
    pub events: EventLoop<'w, 'a>,
    pub msg: Box<Tx>,
}

impl<Tx: Topic, Rx: Topic> Link for BusLink<'_, '_, Tx, Rx> {
    fn send(&mut self, seq: u64) -> Result<()> {
        self.msg.header_mut().sequence = seq;
        self.tx.publish(&self.msg)?;
        Ok(())
    }
    fn recv(&mut self, out: &mut Vec<(u64, u64)>) -> Result<()> {
        let rx = self.rx;
        wait_for_events(&mut self.events, || {
            rx.drain(|s| {
                let t = now_ns();
                out.push((std::hint::black_box(&s).header().sequence, t));
            })?;
            Ok(!out.is_empty())
        })
    }
    fn peer_ready(&self) -> bool {
        self.tx.subscriber_count() > 0 && self.rx.publisher_count() > 0
    }
    fn wait_stats(&self) -> Option<WaitStats> {
        Some(self.events.wait_stats())
    }
}

/// iceoryx2 without events, polling.
pub struct PollLink<Tx: Topic, Rx: Topic> {
    pub tx: PollPub<Tx>,
    pub rx: PollSub<Rx>,
    pub msg: Box<Tx>,
}

impl<Tx: Topic, Rx: Topic> Link for PollLink<Tx, Rx> {
    fn send(&mut self, seq: u64) -> Result<()> {
        self.msg.header_mut().sequence = seq;
        self.tx.send(&self.msg)
    }
    fn recv(&mut self, out: &mut Vec<(u64, u64)>) -> Result<()> {
        let rx = &self.rx;
        poll_until(|| {
            while let Some(s) = rx.try_receive()? {
                out.push((s.header().sequence, now_ns()));
            }
            Ok(!out.is_empty())
        })
    }
    fn peer_ready(&self) -> bool {
        self.tx.subscriber_count() > 0 && self.rx.publisher_count() > 0
    }
}

/// A socket: the samples' plain-bytes twins, sent to the peer's address, received on our own.
pub struct SockLink<Tx: Payload, Rx: Payload> {
    pub sock: Sock,
    pub peer: Addr,
    pub msg: Box<Tx::Wire>,
    pub buf: Box<Rx::Wire>,
}

impl<Tx: Payload, Rx: Payload> Link for SockLink<Tx, Rx> {
    fn send(&mut self, seq: u64) -> Result<()> {
        set_sequence(&mut *self.msg, seq);
        self.sock
            .send_to(bytemuck::bytes_of(&*self.msg), &self.peer)?;
        Ok(())
    }
    fn recv(&mut self, out: &mut Vec<(u64, u64)>) -> Result<()> {
        let size = size_of::<Rx::Wire>();
        let mut n = Some(self.sock.recv(bytemuck::bytes_of_mut(&mut *self.buf))?);
        while let Some(got) = n {
            let t = now_ns();
            if got != size {
                bail!("short message: {got} of {size} bytes");
            }
            out.push((
                header_of(std::hint::black_box(bytemuck::bytes_of(&*self.buf))).sequence,
                t,
            ));
            n = self.sock.try_recv(bytemuck::bytes_of_mut(&mut *self.buf))?;
        }
        Ok(())
    }
}

fn ping_pong(link: &mut dyn Link, spec: &WorkerSpec, initiator: bool) -> Result<()> {
    let total = spec.warmup + spec.count;
    let (mut sent, mut received) = (vec![0_u64; total], vec![0_u64; total]);
    let mut batch = Vec::with_capacity(16);
    // The link's ports exist: the peer may send.
    say(Signal::Ready);
    if initiator {
        wait_for_go()?;
        let start = Instant::now();
        while !link.peer_ready() {
            if start.elapsed() > STARTUP {
                bail!("timed out waiting for the peer's ports");
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        std::thread::sleep(Duration::from_millis(50));
        let gap = spec.interval_us * 1000;
        for k in 0..total {
            if k == spec.warmup {
                say(Signal::Measuring);
            }
            if gap > 0 {
                sleep_until(now_ns() + gap);
            }
            sent[k] = now_ns();
            link.send(k as u64)?;
            while received[k] == 0 {
                batch.clear();
                link.recv(&mut batch)?;
                if let Some(&(_, t)) = batch.iter().find(|(seq, _)| *seq == k as u64) {
                    received[k] = t;
                }
            }
        }
        say(Signal::Done);
        link.send(STOP)?;
    } else {
        'serve: loop {
            batch.clear();
            link.recv(&mut batch)?;
            for &(seq, t) in &batch {
                if seq == STOP {
                    break 'serve;
                }
                let k = seq as usize;
                if k < total {
                    received[k] = t;
                    sent[k] = now_ns();
                    link.send(seq)?;
                }
            }
        }
    }
    let measured = |v: Vec<u64>| v[spec.warmup..].to_vec();
    report(&WorkerResult {
        sent: measured(sent),
        received: measured(received),
        wait: link.wait_stats().map(Into::into),
        ..WorkerResult::default()
    })
}

// ---------------------------------------------------------------------------------------------
// Observer of a `testbed run --paced`: wall-clock arrival of every tick's samples.

fn observer(spec: &WorkerSpec) -> Result<()> {
    let bus = Bus::open("latency-observer", &spec.bus_config()).context("opening the run's bus")?;
    let options = SubscriberOptions::buffer(64);
    let truth = bus.subscriber_with::<SimTruth>(options)?;
    let gyro = bus.subscriber_with::<GyroSample>(options)?;
    let estimate = bus.subscriber_with::<AttitudeEstimate>(options)?;
    let command = bus.subscriber_with::<WheelCommand>(options)?;
    let status = bus.subscriber_with::<ControllerStatus>(options)?;
    let waiter = Waiter::new()?;
    let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
    events.on_data(&truth)?;
    events.on_data(&gyro)?;
    events.on_data(&estimate)?;
    events.on_data(&command)?;
    events.on_data(&status)?;
    say(Signal::Ready);
    let period_ns = spec.interval_us * 1000;
    let last_tick = spec.count;
    let mut ticks: Vec<[u64; 5]> = vec![[0; 5]; last_tick + 1];
    let mut deadline_misses = 0;
    let mut last_data = Instant::now();
    let mut seen_any = false;
    let mut done = false;
    while !done {
        let idle_limit = Duration::from_secs(if seen_any { 3 } else { 60 });
        if last_data.elapsed() > idle_limit {
            break;
        }
        let exit = events.run_once(Duration::from_millis(200), |_| {
            let t = now_ns();
            let mut note = |time_ns: u64, column: usize| {
                let k = (time_ns / period_ns) as usize;
                if time_ns.is_multiple_of(period_ns) && k <= last_tick && ticks[k][column] == 0 {
                    ticks[k][column] = t;
                }
            };
            let mut n = 0;
            n += truth.drain(|s| note(s.header.time_ns, 0)).unwrap_or(0);
            n += gyro.drain(|s| note(s.header.time_ns, 1)).unwrap_or(0);
            n += estimate.drain(|s| note(s.header.time_ns, 2)).unwrap_or(0);
            n += command
                .drain(|s| {
                    note(s.header.time_ns, 3);
                    done |= s.header.time_ns >= last_tick as u64 * period_ns;
                })
                .unwrap_or(0);
            n += status
                .drain(|s| {
                    note(s.header.time_ns, 4);
                    deadline_misses = deadline_misses.max(s.deadline_misses);
                })
                .unwrap_or(0);
            if n > 0 {
                last_data = Instant::now();
                seen_any = true;
            }
            Flow::Continue
        })?;
        if exit.is_some() {
            break;
        }
    }
    report(&WorkerResult {
        ticks,
        deadline_misses,
        ..WorkerResult::default()
    })
}
