//! The periodic liveness report of a process.

use std::cell::Cell;
use std::time::Duration;

use ipc_types::{Heartbeat, ProcessState, SampleHeader};

use crate::{Bus, BusError, TopicPublisher};

/// Publishes the process's [`Heartbeat`] (name, pid, state, counters) on the heartbeat topic.
///
/// The process updates state and counters as it works; an [`crate::EventLoop`] it is attached
/// to with [`crate::EventLoop::with_heartbeat`] publishes it every [`period`](Self::period).
pub struct HeartbeatPublisher {
    publisher: TopicPublisher<Heartbeat>,
    current: Cell<Heartbeat>,
    period: Duration,
}

impl core::fmt::Debug for HeartbeatPublisher {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("HeartbeatPublisher")
            .field("current", &self.current.get())
            .field("period", &self.period)
            .finish_non_exhaustive()
    }
}

impl HeartbeatPublisher {
    /// A heartbeat named after `bus` for this process, state [`ProcessState::Starting`].
    pub fn new(bus: &Bus, period: Duration) -> Result<Self, BusError> {
        if period.is_zero() {
            return Err(BusError::Config {
                key: "heartbeat period",
                value: format!("{period:?}"),
                reason: "must be positive".to_owned(),
            });
        }
        let mut current = Heartbeat::new(bus.name(), std::process::id());
        current.set_state(ProcessState::Starting);
        Ok(Self {
            publisher: bus.publisher()?,
            current: Cell::new(current),
            period,
        })
    }

    /// The publication period.
    pub fn period(&self) -> Duration {
        self.period
    }

    fn update(&self, f: impl FnOnce(&mut Heartbeat)) {
        let mut hb = self.current.get();
        f(&mut hb);
        self.current.set(hb);
    }

    /// Sets the reported state.
    pub fn set_state(&self, state: ProcessState) {
        self.update(|hb| hb.set_state(state));
    }

    /// Sets the run-clock time reported in the header (the process's latest sample time).
    pub fn set_time_ns(&self, time_ns: u64) {
        self.update(|hb| hb.header.time_ns = time_ns);
    }

    /// Adds to the samples-received counter.
    pub fn add_samples_in(&self, n: u64) {
        self.update(|hb| hb.samples_in = hb.samples_in.wrapping_add(n));
    }

    /// Adds to the samples-published counter.
    pub fn add_samples_out(&self, n: u64) {
        self.update(|hb| hb.samples_out = hb.samples_out.wrapping_add(n));
    }

    /// Adds to the error counter.
    pub fn add_errors(&self, n: u64) {
        self.update(|hb| hb.errors = hb.errors.wrapping_add(n));
    }

    /// Adds to the decoded-frames counter (gateways).
    pub fn add_frames_ok(&self, n: u64) {
        self.update(|hb| hb.frames_ok = hb.frames_ok.wrapping_add(n));
    }

    /// Adds to the rejected-frames counter (gateways).
    pub fn add_frames_bad(&self, n: u64) {
        self.update(|hb| hb.frames_bad = hb.frames_bad.wrapping_add(n));
    }

    /// The heartbeat as it would be published now (without header sequence).
    pub fn snapshot(&self) -> Heartbeat {
        self.current.get()
    }

    /// Publishes the current heartbeat now (header: sequence = heartbeats sent, VALID).
    pub fn publish(&self) -> Result<(), BusError> {
        let mut hb = self.current.get();
        hb.header = SampleHeader::new(
            hb.header.time_ns,
            self.publisher.sent(),
            SampleHeader::VALID,
        );
        self.publisher.publish(&hb).map(|_| ())
    }

    /// Publishes the current heartbeat; a failure is logged and counted in its error counter.
    pub fn publish_or_count(&self) {
        if let Err(e) = self.publish() {
            self.add_errors(1);
            tracing::warn!(error = %e, "heartbeat not published");
        }
    }
}
