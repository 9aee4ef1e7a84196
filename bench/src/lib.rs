//! Shared measurement helpers: repeat, take the median, compare ratios (these machines are
//! shared and noisy, so absolute times only mean something next to a baseline of the same run);
//! and the latency harness of `latency` ([`latency`]).

pub mod latency;

use std::time::{Duration, Instant};

/// Median wall time of `repeats` calls of `f` (after one warm-up call).
pub fn median_time(repeats: usize, mut f: impl FnMut()) -> Duration {
    f();
    let mut times: Vec<Duration> = (0..repeats.max(1))
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed()
        })
        .collect();
    times.sort();
    times[times.len() / 2]
}
