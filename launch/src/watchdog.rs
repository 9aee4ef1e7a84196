//! The launcher's view of the run on the bus: every process's heartbeat, watched against
//! `supervision.heartbeat_timeout_s`, and the health events the launcher reports (exits,
//! restarts, hangs, an aborted run).
//!
//! A process is watched from its first `Running` (or `Degraded`) heartbeat until it reports
//! `Stopping`: before, it may still be opening devices or waiting at the start barrier; after,
//! it may take a while to finalise (the logger writing its summary). Heartbeats are matched by
//! pid, so a restarted process is watched afresh.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use ipc_types::{HealthEvent, HealthEventKind, Heartbeat, ProcessState, SampleHeader};
use testbed_bus::{Bus, BusConfig, BusError, SubscriberOptions, TopicPublisher, TopicSubscriber};

/// The launcher's name on the bus and in health events.
pub const LAUNCHER: &str = "launcher";

/// How often the launcher looks at the heartbeats (at most this late in noticing a hang
/// beyond the timeout). Half a second: a third of the default 1.5 s timeout, so a hung process
/// is killed 1.5 to 2 s after its last heartbeat. Each look (the heartbeats, every child's
/// state) is a timer wake-up of some 80 µs of CPU here, which at four a second was most of the
/// launcher's paced CPU. A hung process's actuators do not wait for it: the
/// gateways and the plant command zero after two silent control periods (0.2 s); the look
/// period only delays the restart. Exits are noticed at once all the same (SIGCHLD ends the
/// wait).
pub const POLL_PERIOD: Duration = Duration::from_millis(500);

#[derive(Debug, Clone, Copy)]
struct Seen {
    at: Instant,
    watched: bool,
    /// Whether any of its heartbeats said `Running` or `Degraded`.
    ran: bool,
}

/// Heartbeats in, health events out.
pub struct Watchdog {
    heartbeats: TopicSubscriber<Heartbeat>,
    health: TopicPublisher<HealthEvent>,
    /// Latest heartbeat per pid.
    seen: HashMap<u32, Seen>,
    /// The newest run time any heartbeat reported, ns (the time stamp of launcher events).
    run_time_ns: u64,
    timeout: Duration,
    // Dropped last: the ports above belong to this node.
    _bus: Bus,
}

impl Watchdog {
    /// Joins the run's bus as [`LAUNCHER`].
    pub fn open(config: &BusConfig, timeout: Duration) -> Result<Self, BusError> {
        let bus = Bus::open(LAUNCHER, config)?;
        Ok(Self {
            // Heartbeats always overflow: a launcher that falls behind never blocks anyone.
            heartbeats: bus.subscriber_with(SubscriberOptions::buffer(256))?,
            health: bus.publisher()?,
            seen: HashMap::new(),
            run_time_ns: 0,
            timeout,
            _bus: bus,
        })
    }

    /// Takes every pending heartbeat.
    pub fn poll(&mut self) {
        let now = Instant::now();
        let seen = &mut self.seen;
        let run_time = &mut self.run_time_ns;
        let drained = self.heartbeats.drain(|hb| {
            *run_time = (*run_time).max(hb.header.time_ns);
            let watched = matches!(
                hb.state(),
                Some(ProcessState::Running | ProcessState::Degraded)
            );
            let ran = watched || seen.get(&hb.pid).is_some_and(|s| s.ran);
            seen.insert(
                hb.pid,
                Seen {
                    at: now,
                    watched,
                    ran,
                },
            );
        });
        if let Err(e) = drained {
            tracing::warn!("reading heartbeats: {e}");
        }
    }

    /// How long the watched process `pid` has been silent, if longer than the timeout.
    pub fn hung(&self, pid: u32, now: Instant) -> Option<Duration> {
        let seen = self.seen.get(&pid)?;
        let silent = now.saturating_duration_since(seen.at);
        (seen.watched && silent >= self.timeout).then_some(silent)
    }

    /// Whether process `pid` ever reported `Running` (or `Degraded`) in the heartbeats taken.
    pub fn ran(&self, pid: u32) -> bool {
        self.seen.get(&pid).is_some_and(|s| s.ran)
    }

    /// Forgets `pid` (it ended).
    pub fn forget(&mut self, pid: u32) {
        self.seen.remove(&pid);
    }

    /// Publishes a health event about `subject` (and logs nothing: the caller does).
    pub fn report(&self, kind: HealthEventKind, subject: &str, detail: u32, value: f64) {
        let header = SampleHeader::new(self.run_time_ns, self.health.sent(), SampleHeader::VALID);
        let event = HealthEvent::new(header, LAUNCHER, subject, kind, detail, value);
        if let Err(e) = self.health.publish(&event) {
            tracing::warn!("health event not published: {e}");
        }
    }

    /// The newest run time seen in a heartbeat, s.
    pub fn run_time_s(&self) -> f64 {
        self.run_time_ns as f64 * 1e-9
    }
}
