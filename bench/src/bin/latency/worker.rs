//! The benchmark's processes. The harness starts this binary again as `latency worker <spec>`
//! once per process; each worker speaks a line protocol on stdin/stdout:
//!
//! - worker → harness: `ready` (ports exist), `measuring` (the driver starts the measured
//!   samples), `done` (the last measured sample is through), `result <json>` (then it exits);
//! - harness → worker: `go` (drivers only: start sending).

use crate::chain::{self, Recording};
use crate::payload::{Ping, Pong, STOP, filled};
use crate::system::{now_ns, sleep_until};
use crate::transport::{Addr, BusLink, Link, PollLink, PollPub, PollSub, Sock, SockLink, Transport};
use anyhow::{Context, Result, bail};
use ipc_types::{
    AttitudeEstimate, ControllerStatus, GyroSample, SimTruth, Topic, WheelCommand,
};
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};
use testbed_bus::{Bus, BusConfig, Delivery, EventLoop, Flow, SubscriberOptions, WaitStats, WaitStrategy, Waiter};

/// What one worker process does.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct WorkerSpec {
    pub role: Role,
    pub transport: Transport,
    pub bus_prefix: String,
    pub bus_root: String,
    /// Receiving sockets: hop `[ping, pong]`; chain `[estimator, controller, wheels]`.
    pub addrs: Vec<Addr>,
    /// Hop: sample size in bytes (48: the pipeline's gyro sample and wheel command).
    pub size: usize,
    pub warmup: usize,
    pub count: usize,
    /// Hop: pause before each exchange, µs.
    pub gap_us: u64,
    /// Chain: period of the gyro samples, µs of wall time.
    pub period_us: u64,
    /// Chain: the recorded measurements the gateways replay.
    pub recording: Option<PathBuf>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Role {
    Ping,
    Pong,
    Gyro,
    Estimator,
    Controller,
    Wheels,
    Observer,
}

/// What a worker reports.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct WorkerResult {
    /// Send times of the measured samples (by index), ns CLOCK_MONOTONIC; 0 = not sent.
    pub sent: Vec<u64>,
    /// Receive times of the measured samples (by index); 0 = not received.
    pub received: Vec<u64>,
    pub wait: Option<WaitStatsJson>,
    /// Observer: arrival times per tick of truth, gyro, estimate, wheel command, status.
    pub ticks: Vec<[u64; 5]>,
    /// Observer: the controller's deadline-miss count in its last status.
    pub deadline_misses: u64,
    /// Wheel commands out of range (wheel gateway's check).
    pub out_of_range: u64,
}

#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct WaitStatsJson {
    pub woken: u64,
    pub polled: u64,
    pub empty_windows: u64,
    pub stale_notifications: u64,
    /// Data wake-ups delivered by the bus's listener sweep.
    #[serde(default)]
    pub swept: u64,
}

impl From<WaitStats> for WaitStatsJson {
    fn from(s: WaitStats) -> Self {
        Self { woken: s.woken, polled: s.polled, empty_windows: s.empty_windows, stale_notifications: s.stale_notifications, swept: s.swept }
    }
}

/// Writes one protocol line.
pub fn say(line: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{line}");
    let _ = out.flush();
}

/// Blocks until the harness writes `go`.
pub fn wait_for_go() -> Result<()> {
    let mut line = String::new();
    loop {
        line.clear();
        if std::io::stdin().lock().read_line(&mut line)? == 0 {
            bail!("the harness closed stdin before `go`");
        }
        if line.trim() == "go" {
            return Ok(());
        }
    }
}

pub fn report(result: &WorkerResult) -> Result<()> {
    say(&format!("result {}", serde_json::to_string(result)?));
    Ok(())
}

pub fn bus_config(spec: &WorkerSpec) -> BusConfig {
    BusConfig::new(spec.bus_prefix.clone(), spec.bus_root.clone()).with_delivery(Delivery::Overflow)
}

/// Runs the worker `spec` describes.
pub fn run(spec: &WorkerSpec) -> Result<()> {
    crate::system::precise_timers();
    match spec.role {
        Role::Ping | Role::Pong => hop(spec),
        Role::Gyro | Role::Estimator | Role::Controller | Role::Wheels => chain::worker(spec),
        Role::Observer => observer(spec),
    }
}

/// Polls `ready` for up to 10 s.
pub fn wait_until(what: &str, ready: impl Fn() -> bool) -> Result<()> {
    let start = Instant::now();
    while !ready() {
        if start.elapsed() > Duration::from_secs(10) {
            bail!("timed out waiting for {what}");
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// One hop, ping-pong.

fn hop(spec: &WorkerSpec) -> Result<()> {
    match spec.size {
        48 => hop_typed::<GyroSample, WheelCommand>(spec),
        64 => hop_typed::<Ping<40>, Pong<40>>(spec),
        1024 => hop_typed::<Ping<1000>, Pong<1000>>(spec),
        8192 => hop_typed::<Ping<8168>, Pong<8168>>(spec),
        65_536 => hop_typed::<Ping<65_512>, Pong<65_512>>(spec),
        other => bail!("no sample type of {other} bytes (48, 64, 1024, 8192, 65536)"),
    }
}

fn hop_typed<P: Topic, Q: Topic>(spec: &WorkerSpec) -> Result<()> {
    match spec.role {
        Role::Ping => endpoint::<P, Q>(spec, true),
        _ => endpoint::<Q, P>(spec, false),
    }
}

fn endpoint<Tx: Topic, Rx: Topic>(spec: &WorkerSpec, initiator: bool) -> Result<()> {
    let name = if initiator { "ping" } else { "pong" };
    match &spec.transport {
        Transport::IoxEvent(wait) => {
            let strategy: WaitStrategy = wait.parse()?;
            let bus = Bus::open(name, &bus_config(spec))?;
            let tx = bus.publisher::<Tx>()?;
            let rx = bus.subscriber::<Rx>()?;
            let waiter = Waiter::new()?;
            let mut events = EventLoop::with_wait_strategy(&waiter, strategy);
            events.on_data(&rx)?;
            let mut link = BusLink { tx: &tx, rx: &rx, events, msg: Box::new(filled::<Tx>(0)) };
            ping_pong(&mut link, spec, initiator)
        }
        Transport::IoxPoll => {
            let bus = Bus::open(name, &bus_config(spec))?;
            let mut link = PollLink { tx: PollPub::<Tx>::new(&bus)?, rx: PollSub::<Rx>::new(&bus)?, msg: Box::new(filled::<Tx>(0)) };
            ping_pong(&mut link, spec, initiator)
        }
        Transport::Uds | Transport::Udp => {
            let (mine, peer) = if initiator { (0, 1) } else { (1, 0) };
            let mut link = SockLink::<Tx, Rx> {
                sock: Sock::bind(&spec.addrs[mine])?,
                peer: spec.addrs[peer].clone(),
                msg: Box::new(filled::<Tx>(0)),
                buf: Box::new(Rx::default()),
            };
            ping_pong(&mut link, spec, initiator)
        }
    }
}

fn ping_pong<Tx, Rx>(link: &mut dyn Link<Tx, Rx>, spec: &WorkerSpec, initiator: bool) -> Result<()> {
    let total = spec.warmup + spec.count;
    let (mut sent, mut received) = (vec![0_u64; total], vec![0_u64; total]);
    let mut batch = Vec::with_capacity(16);
    say("ready");
    if initiator {
        wait_for_go()?;
        wait_until("the peer's ports", || link.peer_ready())?;
        std::thread::sleep(Duration::from_millis(50));
        let gap = spec.gap_us * 1000;
        for k in 0..total {
            if k == spec.warmup {
                say("measuring");
            }
            if gap > 0 {
                sleep_until(now_ns() + gap);
            }
            sent[k] = now_ns();
            link.send(k as u64)?;
            while received[k] == 0 {
                batch.clear();
                link.recv(&mut batch)?;
                for &(seq, t) in &batch {
                    if seq == k as u64 {
                        received[k] = t;
                    }
                }
            }
        }
        say("done");
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
    report(&WorkerResult {
        sent: sent[spec.warmup..].to_vec(),
        received: received[spec.warmup..].to_vec(),
        wait: link.wait_stats().map(Into::into),
        ..WorkerResult::default()
    })
}

// ---------------------------------------------------------------------------------------------
// Observer of a `testbed run --paced`: wall-clock arrival of every tick's samples.

fn observer(spec: &WorkerSpec) -> Result<()> {
    let config = BusConfig::new(spec.bus_prefix.clone(), spec.bus_root.clone()).with_delivery(Delivery::Overflow);
    let bus = Bus::open("latency-observer", &config).context("opening the run's bus")?;
    let options = SubscriberOptions::buffer(64);
    let truth = bus.subscriber_with::<SimTruth>(options)?;
    let gyro = bus.subscriber_with::<GyroSample>(options)?;
    let estimate = bus.subscriber_with::<AttitudeEstimate>(options)?;
    let command = bus.subscriber_with::<WheelCommand>(options)?;
    let status = bus.subscriber_with::<ControllerStatus>(options)?;
    let waiter = Waiter::new()?;
    let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
    for attach in [
        events.on_data(&truth),
        events.on_data(&gyro),
        events.on_data(&estimate),
        events.on_data(&command),
        events.on_data(&status),
    ] {
        attach?;
    }
    say("ready");
    let period_ns = spec.period_us * 1000;
    let last_tick = spec.count;
    let mut ticks: Vec<[u64; 5]> = vec![[0; 5]; last_tick + 1];
    let mut deadline_misses = 0;
    let mut last_data = Instant::now();
    let mut seen_any = false;
    let mut done = false;
    while !done {
        let idle_limit = if seen_any { Duration::from_secs(3) } else { Duration::from_secs(60) };
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
            n += command.drain(|s| {
                note(s.header.time_ns, 3);
                if s.header.time_ns >= last_tick as u64 * period_ns {
                    done = true;
                }
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
    report(&WorkerResult { ticks, deadline_misses, ..WorkerResult::default() })?;
    Ok(())
}

/// Loads the chain's recording.
pub fn recording(spec: &WorkerSpec) -> Result<Recording> {
    let path = spec.recording.as_ref().context("the chain needs a recording")?;
    Recording::load(path)
}
