//! The ground link's counters and its stamped-to-sent latency.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Counters of the link (served at `/stats` and on `testbed/ground/link`).
#[derive(Debug, Default)]
pub struct Stats {
    pub viewers: AtomicU64,
    pub connections: AtomicU64,
    pub sent: AtomicU64,
    pub sent_bytes: AtomicU64,
    pub dropped: AtomicU64,
    pub bad_messages: AtomicU64,
    pub oversized: AtomicU64,
    pub commands_forwarded: AtomicU64,
    pub commands_rejected: AtomicU64,
    pub rate_limited: AtomicU64,
    pub refused_viewers: AtomicU64,
    /// Handshakes refused: a wrong command token, a plain connection to the TLS link, a
    /// failed TLS handshake.
    pub refused_handshakes: AtomicU64,
    /// Advertisements and commands of watching connections, refused.
    pub refused_watch_only: AtomicU64,
    pub latency: Latency,
}

impl Stats {
    pub fn to_json(&self) -> serde_json::Value {
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        serde_json::json!({
            "viewers": g(&self.viewers),
            "connections": g(&self.connections),
            "sent": g(&self.sent),
            "sent_bytes": g(&self.sent_bytes),
            "dropped": g(&self.dropped),
            "bad_messages": g(&self.bad_messages),
            "oversized": g(&self.oversized),
            "commands_forwarded": g(&self.commands_forwarded),
            "commands_rejected": g(&self.commands_rejected),
            "rate_limited": g(&self.rate_limited),
            "refused_viewers": g(&self.refused_viewers),
            "refused_handshakes": g(&self.refused_handshakes),
            "refused_watch_only": g(&self.refused_watch_only),
            "latency_ms": self.latency.to_json(),
        })
    }
}

pub(super) fn add(counter: &AtomicU64, n: u64) {
    counter.fetch_add(n, Ordering::Relaxed);
}

/// Stamped-to-sent latency: from a sample's stamp (its header time, run clock) to the moment
/// its frame is written to a viewer's socket. The run clock is mapped to wall time by the
/// node ([`Latency::observe_stamp`]): the smallest gap between a stamp and the wall time the
/// link drained it, over the last two windows of [`Latency::WINDOW`] (a paced run's clock
/// keeps to the wall clock but may fall behind it under load, measured 4 ms/s: the short
/// window follows that drift, and a drain of every topic every 100 ms gives it samples
/// drained just after they were published). Only paced runs have it: a
/// lockstep run's clock is not wall time.
#[derive(Debug, Default)]
pub struct Latency {
    /// Whether the run clock follows wall time (a paced run).
    paced: AtomicBool,
    /// Smallest `wall − stamp` seen, ns: this window, the previous one.
    offset_now: AtomicU64,
    offset_before: AtomicU64,
    window_start_ns: AtomicU64,
    /// Over the current report period: sum and count (for the mean) and the largest, µs.
    sum_us: AtomicU64,
    count: AtomicU64,
    max_us: AtomicU64,
    /// The last report period's mean and largest, µs (`u64::MAX`: none).
    last_mean_us: AtomicU64,
    last_max_us: AtomicU64,
}

impl Latency {
    /// The window of the stamp-to-wall offset, ns.
    pub const WINDOW: u64 = 2_000_000_000;

    pub fn set_paced(&self, paced: bool) {
        self.paced.store(paced, Ordering::Relaxed);
        self.offset_now.store(u64::MAX, Ordering::Relaxed);
        self.offset_before.store(u64::MAX, Ordering::Relaxed);
        self.last_mean_us.store(u64::MAX, Ordering::Relaxed);
        self.last_max_us.store(u64::MAX, Ordering::Relaxed);
    }

    /// A sample stamped `stamp_ns` (run clock) drained at wall time `wall_ns`. Node thread:
    /// a few atomic operations.
    pub fn observe_stamp(&self, stamp_ns: u64, wall_ns: u64) {
        if !self.paced.load(Ordering::Relaxed) {
            return;
        }
        let gap = wall_ns.saturating_sub(stamp_ns);
        if wall_ns.saturating_sub(self.window_start_ns.load(Ordering::Relaxed)) > Self::WINDOW {
            self.window_start_ns.store(wall_ns, Ordering::Relaxed);
            let now = self.offset_now.swap(gap, Ordering::Relaxed);
            self.offset_before.store(now, Ordering::Relaxed);
        } else {
            self.offset_now.fetch_min(gap, Ordering::Relaxed);
        }
    }

    /// A frame of a sample stamped `stamp_ns` written to a socket at wall time `wall_ns`.
    pub(super) fn sent(&self, stamp_ns: u64, wall_ns: u64) {
        let offset = self
            .offset_now
            .load(Ordering::Relaxed)
            .min(self.offset_before.load(Ordering::Relaxed));
        if offset == u64::MAX {
            return;
        }
        let us = wall_ns.saturating_sub(stamp_ns.saturating_add(offset)) / 1000;
        self.sum_us.fetch_add(us, Ordering::Relaxed);
        self.count.fetch_add(1, Ordering::Relaxed);
        self.max_us.fetch_max(us, Ordering::Relaxed);
    }

    /// Ends a report period (the node, every second): its mean and largest become the ones
    /// reported.
    pub fn roll(&self) {
        let sum = self.sum_us.swap(0, Ordering::Relaxed);
        let count = self.count.swap(0, Ordering::Relaxed);
        let max = self.max_us.swap(0, Ordering::Relaxed);
        let (mean, max) = sum
            .checked_div(count)
            .map_or((u64::MAX, u64::MAX), |mean| (mean, max));
        self.last_mean_us.store(mean, Ordering::Relaxed);
        self.last_max_us.store(max, Ordering::Relaxed);
    }

    /// `{"mean": ms, "max": ms}` over the last second of sending, or nulls (nothing sent, or
    /// a lockstep run).
    pub fn to_json(&self) -> serde_json::Value {
        let ms = |a: &AtomicU64| match a.load(Ordering::Relaxed) {
            u64::MAX => serde_json::Value::Null,
            us => (us as f64 / 1000.0).into(),
        };
        serde_json::json!({"mean": ms(&self.last_mean_us), "max": ms(&self.last_max_us)})
    }
}
