//! What the harness and its worker processes exchange. A leaf: it uses no other module of the
//! harness, and every other module may use it.
//!
//! The harness starts the `latency` binary again as `latency worker <WorkerSpec as JSON>`, once
//! per process of a measurement. The worker speaks in lines:
//!
//! - worker → harness (stdout): [`Signal::Ready`] once its receiving ports exist (sockets
//!   bound, bus ports open: a peer may send to it from now on), [`Signal::Measuring`] (drivers:
//!   the measured samples start), [`Signal::Done`] (the last measured sample is through), then
//!   `result <json>` ([`WorkerResult`]) and it exits;
//! - harness → worker (stdin): [`GO`], to the drivers, once every worker of the measurement has
//!   said `ready`. Nobody sends before that, so nobody sends to a socket that is not bound yet.

use anyhow::{Context, Result, bail};
use ipc_types::WaitStrategy;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Write};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;
use testbed_bus::{BusConfig, Delivery, WaitStats};

/// How long a worker may take to start (to open its ports and say `ready`), and how long a
/// receiver waits for its first sample, on a loaded machine: generous, since processes start
/// slowly when the CPUs are busy. A receiver that has had a sample gives up after [`STALL`].
pub const STARTUP: Duration = Duration::from_secs(60);

/// How long a receiver that has had samples waits for the next before it gives up (a broken
/// run must not hang).
pub const STALL: Duration = Duration::from_secs(10);

/// How a sample gets from one process to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub enum Transport {
    /// The pipeline's bus (iceoryx2 + its event service), its event loops waiting this way.
    IoxEvent(WaitStrategy),
    /// iceoryx2 publish/subscribe without events, the receiver polling: the floor.
    IoxPoll,
    /// Unix datagram sockets, blocking reads.
    Uds,
    /// UDP on loopback, blocking reads.
    Udp,
}

impl Transport {
    /// The pipeline as it runs by default.
    pub const BUS: Self = Self::IoxEvent(WaitStrategy::Block);

    pub fn label(self) -> String {
        match self {
            Self::IoxEvent(wait) => format!("iceoryx2 + doorbell ({wait})"),
            Self::IoxPoll => "iceoryx2 busy-poll (floor)".into(),
            Self::Uds => "Unix datagram socket".into(),
            Self::Udp => "UDP loopback".into(),
        }
    }

    pub fn is_bus(self) -> bool {
        matches!(self, Self::IoxEvent(_) | Self::IoxPoll)
    }

    /// The bus with a polling wait strategy.
    pub fn polls(self) -> bool {
        matches!(self, Self::IoxEvent(w) if w.polls())
    }
}

impl Default for Transport {
    fn default() -> Self {
        Self::BUS
    }
}

/// The report's key: `iox-event-<wait>`, `iox-poll`, `uds`, `udp`.
impl From<Transport> for String {
    fn from(t: Transport) -> Self {
        match t {
            Transport::IoxEvent(wait) => format!("iox-event-{wait}"),
            Transport::IoxPoll => "iox-poll".into(),
            Transport::Uds => "uds".into(),
            Transport::Udp => "udp".into(),
        }
    }
}

impl TryFrom<String> for Transport {
    type Error = String;
    fn try_from(key: String) -> Result<Self, String> {
        match key.as_str() {
            "iox-poll" => Ok(Self::IoxPoll),
            "uds" => Ok(Self::Uds),
            "udp" => Ok(Self::Udp),
            _ => match key.strip_prefix("iox-event-") {
                Some(wait) => wait
                    .parse()
                    .map(Self::IoxEvent)
                    .map_err(|e| format!("{key}: {e}")),
                None => Err(format!("unknown transport {key}")),
            },
        }
    }
}

impl std::fmt::Display for Transport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&String::from(*self))
    }
}

/// Where a socket receives.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Addr {
    Uds(PathBuf),
    Udp(SocketAddr),
}

/// What a worker process is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Role {
    /// Hop: sends first, measures the round trips.
    Ping,
    /// Hop: answers.
    Pong,
    /// Chain: replays the recording's sensor samples (the driver).
    Gyro,
    Estimator,
    Controller,
    /// Chain: takes the wheel commands, answers with the next tick's telemetry.
    Wheels,
    /// Paced run: time-stamps every tick's samples on arrival.
    Observer,
}

impl Role {
    pub fn name(self) -> &'static str {
        match self {
            Self::Ping => "ping",
            Self::Pong => "pong",
            Self::Gyro => "gyro-gateway",
            Self::Estimator => "estimator",
            Self::Controller => "controller",
            Self::Wheels => "wheel-gateway",
            Self::Observer => "observer",
        }
    }
}

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
    /// Hop: pause before each exchange; chain: period of the gyro samples (wall time);
    /// observer: the run's tick; µs.
    pub interval_us: u64,
    /// Chain: the recorded measurements the gateways replay.
    pub recording: Option<PathBuf>,
}

impl WorkerSpec {
    /// The spec's bus, dropping the oldest sample where a subscriber falls behind.
    pub fn bus_config(&self) -> BusConfig {
        BusConfig::new(self.bus_prefix.clone(), self.bus_root.clone())
            .with_delivery(Delivery::Overflow)
    }
}

/// What a worker reports.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct WorkerResult {
    /// Send times of the measured samples (by index), ns CLOCK_MONOTONIC; 0 = not sent.
    pub sent: Vec<u64>,
    /// Receive times of the measured samples (by index); 0 = not received.
    pub received: Vec<u64>,
    pub wait: Option<WaitCounts>,
    /// Observer: arrival times per tick of truth, gyro, estimate, wheel command, status.
    pub ticks: Vec<[u64; 5]>,
    /// Observer: the controller's deadline-miss count in its last status.
    pub deadline_misses: u64,
    /// Wheel commands out of range (wheel gateway's check).
    pub out_of_range: u64,
}

/// How an event loop's data wake-ups came about ([`WaitStats`]).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct WaitCounts {
    pub woken: u64,
    pub polled: u64,
    pub empty_windows: u64,
    pub stale_notifications: u64,
}

impl WaitCounts {
    pub fn add(&mut self, o: Self) {
        self.woken += o.woken;
        self.polled += o.polled;
        self.empty_windows += o.empty_windows;
        self.stale_notifications += o.stale_notifications;
    }

    /// Data wake-ups of every kind.
    pub fn wakeups(&self) -> u64 {
        self.woken + self.polled
    }
}

impl From<WaitStats> for WaitCounts {
    fn from(s: WaitStats) -> Self {
        Self {
            woken: s.woken,
            polled: s.polled,
            empty_windows: s.empty_windows,
            stale_notifications: s.stale_notifications,
        }
    }
}

/// A worker's progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Signal {
    Ready,
    Measuring,
    Done,
}

impl Signal {
    fn word(self) -> &'static str {
        match self {
            Self::Ready => "ready",
            Self::Measuring => "measuring",
            Self::Done => "done",
        }
    }
}

/// A line from a worker.
#[derive(Debug)]
pub enum Line {
    Signal(Signal),
    Result(Box<WorkerResult>),
}

const RESULT: &str = "result ";

/// The harness's word to start.
pub const GO: &str = "go";

impl Line {
    /// The line's meaning; `None` for anything else a worker printed.
    pub fn parse(line: &str) -> Result<Option<Self>> {
        if let Some(json) = line.strip_prefix(RESULT) {
            return Ok(Some(Self::Result(
                serde_json::from_str(json).context("unreadable result")?,
            )));
        }
        Ok([Signal::Ready, Signal::Measuring, Signal::Done]
            .into_iter()
            .find(|s| s.word() == line)
            .map(Self::Signal))
    }
}

fn write_line(line: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{line}");
    let _ = out.flush();
}

/// Worker: tells the harness `signal`.
pub fn say(signal: Signal) {
    write_line(signal.word());
}

/// Worker: sends the result (the last line).
pub fn report(result: &WorkerResult) -> Result<()> {
    write_line(&format!("{RESULT}{}", serde_json::to_string(result)?));
    Ok(())
}

/// Worker: blocks until the harness writes [`GO`].
pub fn wait_for_go() -> Result<()> {
    let mut line = String::new();
    loop {
        line.clear();
        if std::io::stdin().lock().read_line(&mut line)? == 0 {
            bail!("the harness closed stdin before `{GO}`");
        }
        if line.trim() == GO {
            return Ok(());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transports_round_trip_through_their_keys() {
        for t in [
            Transport::BUS,
            Transport::IoxEvent(WaitStrategy::ANTICIPATE),
            Transport::IoxPoll,
            Transport::Uds,
            Transport::Udp,
        ] {
            assert_eq!(Transport::try_from(String::from(t)), Ok(t));
        }
        assert_eq!(String::from(Transport::BUS), "iox-event-block");
        assert_eq!(
            Transport::try_from("iox-event-spin:50".to_string()).map(String::from),
            Ok("iox-event-spin:50".into())
        );
    }

    #[test]
    fn lines_parse() {
        assert!(matches!(
            Line::parse("ready").unwrap(),
            Some(Line::Signal(Signal::Ready))
        ));
        assert!(matches!(
            Line::parse("result {}").unwrap(),
            Some(Line::Result(_))
        ));
        assert!(Line::parse("something else").unwrap().is_none());
    }
}
