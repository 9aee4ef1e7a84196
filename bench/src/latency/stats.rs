//! Latency distributions: percentiles by nearest rank over every sample (no binning).

use serde::{Deserialize, Serialize};

/// A latency distribution, in microseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Percentiles {
    /// Number of samples.
    pub n: usize,
    pub p50: f64,
    pub p90: f64,
    pub p99: f64,
    pub p999: f64,
    pub max: f64,
    pub mean: f64,
}

/// The value at quantile `q` (0 < q ≤ 1) of `sorted`, by nearest rank.
pub fn quantile(sorted: &[u64], q: f64) -> u64 {
    assert!(!sorted.is_empty(), "quantile of nothing");
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// Percentiles of `latencies_ns` (sorted in place).
pub fn percentiles(latencies_ns: &mut [u64]) -> Percentiles {
    if latencies_ns.is_empty() {
        return Percentiles::default();
    }
    latencies_ns.sort_unstable();
    let us = |ns: u64| ns as f64 / 1e3;
    let sum: u128 = latencies_ns.iter().map(|&x| u128::from(x)).sum();
    Percentiles {
        n: latencies_ns.len(),
        p50: us(quantile(latencies_ns, 0.50)),
        p90: us(quantile(latencies_ns, 0.90)),
        p99: us(quantile(latencies_ns, 0.99)),
        p999: us(quantile(latencies_ns, 0.999)),
        max: us(*latencies_ns.last().expect("not empty")),
        mean: sum as f64 / latencies_ns.len() as f64 / 1e3,
    }
}

/// Differences `to[i] − from[i]` where both were recorded (non-zero) and `to` is not earlier.
/// Returns the differences and how many pairs were incomplete or out of order.
pub fn differences(from: &[u64], to: &[u64]) -> (Vec<u64>, usize) {
    let mut out = Vec::with_capacity(from.len().min(to.len()));
    let mut missing = from.len().abs_diff(to.len());
    for (&a, &b) in from.iter().zip(to) {
        if a == 0 || b == 0 || b < a {
            missing += 1;
        } else {
            out.push(b - a);
        }
    }
    (out, missing)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let mut v: Vec<u64> = (1..=1000).map(|i| i * 1000).collect();
        v.reverse();
        let p = percentiles(&mut v);
        assert_eq!(p.n, 1000);
        assert_eq!(p.p50, 500.0);
        assert_eq!(p.p90, 900.0);
        assert_eq!(p.p99, 990.0);
        assert_eq!(p.p999, 999.0);
        assert_eq!(p.max, 1000.0);
        assert_eq!(quantile(&[7], 0.999), 7);
        assert_eq!(percentiles(&mut []), Percentiles::default());
    }

    #[test]
    fn differences_skip_incomplete_pairs() {
        let (d, missing) = differences(&[10, 0, 30, 40], &[15, 25, 29]);
        assert_eq!(d, vec![5]);
        assert_eq!(missing, 3);
    }
}
