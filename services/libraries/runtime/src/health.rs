//! Health of a running process: the events it reports ([`HealthReporter`]) and the liveness of
//! its input streams ([`InputWatch`]).
//!
//! An input stream is lost when it delivered nothing for one and a half of its periods, so that
//! the loss is noticed within two periods by a process that wakes once per period (paced only:
//! in lockstep time stands still while a process waits, and a process that dies or hangs ends
//! the run through the launcher). Losing and regaining an input is logged, reported on the
//! health topic and shown in the heartbeat (`Degraded` while any input is lost); what to do
//! about it is the node's business (the controller's safe mode, an actuator gateway's zero
//! command).

use ipc_types::{HealthEvent, HealthEventKind, ProcessState, SampleHeader, Topic};
use std::cell::Cell;
use std::time::{Duration, Instant};
use testbed_bus::{Bus, BusError, HeartbeatPublisher, TopicPublisher, TopicSubscriber};

/// Periods of silence after which an input's deadline wakes its process ([`crate::WakeOn::input`]):
/// the process can act (an actuator gateway commands zero) within two periods.
pub const LOST_AFTER_PERIODS: u32 = 2;

/// Publishes the process's [`HealthEvent`]s (and logs each one).
pub struct HealthReporter {
    name: String,
    publisher: TopicPublisher<HealthEvent>,
}

impl HealthReporter {
    /// A reporter named `name` on `bus`.
    pub fn new(bus: &Bus, name: &str) -> Result<Self, BusError> {
        Ok(Self {
            name: name.to_owned(),
            publisher: bus.publisher()?,
        })
    }

    /// Reports `kind` about `subject` at run time `time_ns` (see [`HealthEvent`] for `detail`
    /// and `value`). A failure to publish is logged, never fatal: the event is also in the
    /// process's log output.
    pub fn report(
        &self,
        time_ns: u64,
        kind: HealthEventKind,
        subject: &str,
        detail: u32,
        value: f64,
    ) {
        if kind.is_fault() {
            tracing::warn!(
                t_s = time_ns as f64 * 1e-9,
                subject,
                detail,
                value,
                "{}",
                kind.name()
            );
        } else {
            tracing::info!(
                t_s = time_ns as f64 * 1e-9,
                subject,
                detail,
                value,
                "{}",
                kind.name()
            );
        }
        let header = SampleHeader::new(time_ns, self.publisher.sent(), SampleHeader::VALID);
        let event = HealthEvent::new(header, &self.name, subject, kind, detail, value);
        if let Err(e) = self.publisher.publish(&event) {
            tracing::warn!(error = %e, "health event not published");
        }
    }
}

/// When a subscriber last took a sample, whatever its type.
pub trait LastReceived {
    fn last_received(&self) -> Option<Instant>;
}

impl<T: Topic> LastReceived for TopicSubscriber<T> {
    fn last_received(&self) -> Option<Instant> {
        TopicSubscriber::last_received(self)
    }
}

struct Watched<'a> {
    topic: &'static str,
    limit: Duration,
    port: &'a dyn LastReceived,
    lost_since: Cell<Option<Instant>>,
}

/// The input streams a process watches, each against 1.5 of its periods.
#[derive(Default)]
pub struct InputWatch<'a> {
    inputs: Vec<Watched<'a>>,
}

impl<'a> InputWatch<'a> {
    /// Watches `subscriber`, whose stream has period `period`: lost after 1.5 periods of
    /// silence, so that a process waking once per period notices within two.
    pub fn watch<T: Topic>(&mut self, subscriber: &'a TopicSubscriber<T>, period: Duration) {
        self.inputs.push(Watched {
            topic: T::NAME,
            limit: period * 3 / 2,
            port: subscriber,
            lost_since: Cell::new(None),
        });
    }

    /// Whether nothing is watched.
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }

    /// The longest silence after which a watched input counts as lost (the loop must wake at
    /// least this often to notice), if any input is watched.
    pub fn longest_limit(&self) -> Option<Duration> {
        self.inputs.iter().map(|w| w.limit).max()
    }

    /// Inputs lost now.
    pub fn lost(&self) -> usize {
        self.inputs
            .iter()
            .filter(|w| w.lost_since.get().is_some())
            .count()
    }

    /// Checks every input at wall time `now`: reports inputs lost or regained since the last
    /// check, and sets the heartbeat state (`Degraded` while any input is lost).
    pub fn check(&self, now: Instant, heartbeat: &HeartbeatPublisher, health: &HealthReporter) {
        if self.inputs.is_empty() {
            return;
        }
        let time_ns = heartbeat.snapshot().header.time_ns;
        for w in &self.inputs {
            // A stream that has not started cannot be late (the pipeline may still start).
            let Some(last) = w.port.last_received() else {
                continue;
            };
            let silent = now.saturating_duration_since(last);
            match (w.lost_since.get(), silent >= w.limit) {
                (None, true) => {
                    w.lost_since.set(Some(last));
                    health.report(
                        time_ns,
                        HealthEventKind::InputLost,
                        w.topic,
                        0,
                        silent.as_secs_f64(),
                    );
                }
                (Some(since), false) => {
                    w.lost_since.set(None);
                    let outage = last.saturating_duration_since(since);
                    health.report(
                        time_ns,
                        HealthEventKind::InputRestored,
                        w.topic,
                        0,
                        outage.as_secs_f64(),
                    );
                }
                _ => {}
            }
        }
        let state = heartbeat.snapshot().state();
        match (self.lost() > 0, state) {
            (true, Some(ProcessState::Running)) => heartbeat.set_state(ProcessState::Degraded),
            (false, Some(ProcessState::Degraded)) => heartbeat.set_state(ProcessState::Running),
            _ => {}
        }
    }
}
