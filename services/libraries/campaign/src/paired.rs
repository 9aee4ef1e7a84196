//! A/B comparison on the same dispersed runs: per metric the mean paired difference b − a with
//! its 95 % confidence interval, from a seeded bootstrap of the pairs (no assumption on the
//! metric's distribution; settling times are skewed), runs where the metric is undefined in
//! one or both variants counted apart, and a verdict per metric and overall. Where a run
//! without a value is a failure (never settled), the runs that fail in one variant only are
//! judged too, by an exact McNemar test: b failing where a did not is worse even when the
//! runs that both settle cannot tell the variants apart.

use crate::distribution::stream;
use crate::metrics::{Better, Metric};
use crate::results::RunRow;
use crate::summary::quantile;
use rand::Rng;
use serde::Serialize;
use std::collections::BTreeMap;

/// Bootstrap resamples per metric.
pub const RESAMPLES: usize = 2000;

/// What the interval says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    Better,
    Worse,
    NoDifference,
    TooFewPairs,
}

/// One metric compared.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetricComparison {
    pub metric: &'static str,
    pub unit: &'static str,
    /// The paired quantity: `b − a`, or for a consistency metric its distance from the
    /// consistent value, `|b − t| − |a − t|`.
    pub compared: String,
    /// Runs where both variants define the metric.
    pub pairs: usize,
    /// Runs where only a (only b, neither) defines it.
    pub only_a: usize,
    pub only_b: usize,
    pub neither: usize,
    /// Means over the pairs.
    pub mean_a: Option<f64>,
    pub mean_b: Option<f64>,
    pub mean_difference: Option<f64>,
    pub ci95: Option<[f64; 2]>,
    /// Two-sided exact McNemar p-value of the runs defined in one variant only, for metrics
    /// whose undefined runs are failures.
    pub failures_p: Option<f64>,
    pub outcome: Outcome,
    pub verdict: String,
}

/// Variant `b` against the baseline `a`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    pub a: String,
    pub b: String,
    pub method: String,
    pub metrics: Vec<MetricComparison>,
    pub overall: String,
}

/// A number with three significant digits (trailing zeros kept), in exponent form when very
/// small or large.
pub fn sig3(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    if x.abs() < 1e-4 || x.abs() >= 1e6 {
        return format!("{x:.2e}");
    }
    let decimals = (2 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    format!("{x:.decimals$}")
}

/// Compares `b_rows` with `a_rows` run by run (paired by index); `seed` seeds the bootstrap.
pub fn compare(a: &str, a_rows: &[&RunRow], b: &str, b_rows: &[&RunRow], seed: u64) -> Comparison {
    let b_by_index: BTreeMap<u64, &RunRow> = b_rows.iter().map(|r| (r.index, *r)).collect();
    let pairs: Vec<(&RunRow, &RunRow)> = a_rows
        .iter()
        .filter_map(|ra| b_by_index.get(&ra.index).map(|rb| (*ra, *rb)))
        .collect();
    let metrics: Vec<MetricComparison> = Metric::ALL
        .iter()
        .map(|m| compare_metric(*m, a, b, &pairs, seed))
        .collect();
    let names = |outcome| -> Vec<&str> {
        metrics
            .iter()
            .filter(|m| m.outcome == outcome)
            .map(|m| m.metric)
            .collect()
    };
    let list = |v: &[&str]| {
        if v.is_empty() {
            String::new()
        } else {
            format!(" ({})", v.join(", "))
        }
    };
    let (better, worse, same) = (
        names(Outcome::Better),
        names(Outcome::Worse),
        names(Outcome::NoDifference),
    );
    let settle = &metrics[Metric::SettleS as usize];
    let overall = format!(
        "{b} against {a} over {} paired runs: better on {} metric(s){}, worse on {}{}, no difference detected on {}; never settled: {a} {} run(s), {b} {}",
        pairs.len(),
        better.len(),
        list(&better),
        worse.len(),
        list(&worse),
        same.len(),
        settle.only_b + settle.neither,
        settle.only_a + settle.neither,
    );
    Comparison {
        a: a.to_string(),
        b: b.to_string(),
        method: format!(
            "mean paired difference with a 95 % percentile bootstrap interval ({RESAMPLES} resamples of the pairs, seeded by the campaign seed)"
        ),
        metrics,
        overall,
    }
}

fn compare_metric(
    metric: Metric,
    a: &str,
    b: &str,
    pairs: &[(&RunRow, &RunRow)],
    seed: u64,
) -> MetricComparison {
    let (mut only_a, mut only_b, mut neither) = (0, 0, 0);
    let mut both = Vec::new();
    for (ra, rb) in pairs {
        match (ra.metrics.get(metric), rb.metrics.get(metric)) {
            (Some(x), Some(y)) => both.push((x, y)),
            (Some(_), None) => only_a += 1,
            (None, Some(_)) => only_b += 1,
            (None, None) => neither += 1,
        }
    }
    let (judged, compared): (Vec<f64>, String) = match metric.better() {
        Better::Lower => (
            both.iter().map(|(x, y)| y - x).collect(),
            format!("{b} − {a}"),
        ),
        Better::Near(t) => (
            both.iter()
                .map(|(x, y)| (y - t).abs() - (x - t).abs())
                .collect(),
            format!("|{b} − {t}| − |{a} − {t}|"),
        ),
    };
    let n = judged.len();
    let mean = |xs: &mut dyn Iterator<Item = f64>| (n > 0).then(|| xs.sum::<f64>() / n as f64);
    let mean_difference = mean(&mut judged.iter().copied());
    let ci95 = (n >= 2).then(|| {
        bootstrap_interval(
            &judged,
            &stream(
                seed,
                u64::MAX,
                &format!("bootstrap {a} {b} {}", metric.name()),
            ),
        )
    });
    let by_interval = match ci95 {
        None => Outcome::TooFewPairs,
        Some([_, hi]) if hi < 0.0 => Outcome::Better,
        Some([lo, _]) if lo > 0.0 => Outcome::Worse,
        Some(_) => Outcome::NoDifference,
    };
    // b fails (is undefined) in `only_a` runs where a does not, a in `only_b`.
    let failures_p = (metric.undefined_is_failure() && only_a + only_b > 0)
        .then(|| mcnemar_p(only_a as u64, only_b as u64));
    let outcome = match failures_p {
        Some(p) if p < 0.05 && only_a > only_b => Outcome::Worse,
        Some(p) if p < 0.05 => Outcome::Better,
        _ => by_interval,
    };
    let unit = metric.unit();
    let with_unit = |x: f64| {
        if unit.is_empty() {
            sig3(x)
        } else {
            format!("{} {unit}", sig3(x))
        }
    };
    let mut verdict = match (mean_difference, ci95) {
        (Some(d), Some([lo, hi])) => format!(
            "{}: {compared} = {} on average over {n} pairs (95 % CI {} to {}): {}",
            metric.name(),
            with_unit(d),
            with_unit(lo),
            with_unit(hi),
            match by_interval {
                Outcome::Better => format!("{b} is better"),
                Outcome::Worse => format!("{b} is worse"),
                _ if lo == 0.0 && hi == 0.0 => "no difference (every pair equal)".to_string(),
                _ => "no difference detected".to_string(),
            }
        ),
        _ => format!("{}: {n} pair(s), too few to compare", metric.name()),
    };
    if only_a + only_b + neither > 0 {
        verdict.push_str(&format!(
            "; {}: {a} only {only_b} run(s), {b} only {only_a}, both {neither}",
            metric.undefined_means()
        ));
    }
    if let Some(p) = failures_p {
        verdict.push_str(&format!(
            " (exact McNemar test of the runs that fail in one variant only: p = {}{})",
            sig3(p),
            match outcome {
                Outcome::Worse if p < 0.05 => format!(": {b} is worse"),
                Outcome::Better if p < 0.05 => format!(": {b} is better"),
                _ => String::new(),
            }
        ));
    }
    MetricComparison {
        metric: metric.name(),
        unit,
        compared,
        pairs: n,
        only_a,
        only_b,
        neither,
        mean_a: mean(&mut both.iter().map(|p| p.0)),
        mean_b: mean(&mut both.iter().map(|p| p.1)),
        mean_difference,
        ci95,
        failures_p,
        outcome,
        verdict,
    }
}

/// Two-sided exact McNemar test: the probability, if either variant were as likely to be the
/// one that fails, of discordant counts at least as uneven as `x` against `y`
/// (`2 · P(Bin(x + y, ½) ≤ min(x, y))`, at most 1).
pub fn mcnemar_p(x: u64, y: u64) -> f64 {
    let n = x + y;
    let k = x.min(y);
    // Σ_{i ≤ k} C(n, i) / 2^n, in logarithms so that large n does not overflow.
    let ln_half_n = -(n as f64) * std::f64::consts::LN_2;
    let mut ln_c = 0.0; // ln C(n, 0)
    let mut tail = 0.0;
    for i in 0..=k {
        if i > 0 {
            ln_c += ((n - i + 1) as f64).ln() - (i as f64).ln();
        }
        tail += (ln_c + ln_half_n).exp();
    }
    (2.0 * tail).min(1.0)
}

/// The 2.5 and 97.5 % quantiles of the means of [`RESAMPLES`] resamples (with replacement)
/// of `xs`.
fn bootstrap_interval(xs: &[f64], rng: &rand_chacha::ChaCha8Rng) -> [f64; 2] {
    let mut rng = rng.clone();
    let n = xs.len();
    let mut means: Vec<f64> = (0..RESAMPLES)
        .map(|_| (0..n).map(|_| xs[rng.random_range(0..n)]).sum::<f64>() / n as f64)
        .collect();
    means.sort_by(f64::total_cmp);
    [
        quantile(&means, 0.025).unwrap_or(f64::NAN),
        quantile(&means, 0.975).unwrap_or(f64::NAN),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::{RunMetrics, RunSeries};
    use rand::SeedableRng;
    use rand_distr::{Distribution as _, StandardNormal};

    fn row(index: u64, variant: &str, settle: Option<f64>, nees: f64) -> RunRow {
        let mut metrics = RunMetrics::default();
        metrics.0[Metric::SettleS as usize] = settle;
        metrics.0[Metric::NeesPerDof as usize] = Some(nees);
        metrics.0[Metric::TiltStops as usize] = Some(0.0);
        RunRow {
            index,
            variant: variant.into(),
            seed: 0,
            values: vec![],
            metrics,
            error: None,
            series: RunSeries::default(),
        }
    }

    /// 200 pairs, seed fixed: b settles 2 s later than a plus N(0, 1 s) noise, so the 95 %
    /// interval (half-width about 2 × 1/√200 ≈ 0.14 s) lies well above 0 and contains 2
    /// (it misses 2 for about one seed in 20; this seed is fixed).
    #[test]
    fn a_shift_is_found_with_its_interval_and_undefined_runs_are_counted_apart() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut a = Vec::new();
        let mut b = Vec::new();
        for k in 0..200 {
            let base = 60.0 + 10.0 * rng.random::<f64>();
            let noise: f64 = StandardNormal.sample(&mut rng);
            a.push(row(k, "a", Some(base), 1.0));
            let settle = (k >= 3).then_some(base + 2.0 + noise);
            b.push(row(k, "b", settle, 1.0 + 0.5 * rng.random::<f64>()));
        }
        let ar: Vec<&RunRow> = a.iter().collect();
        let br: Vec<&RunRow> = b.iter().collect();
        let c = compare("a", &ar, "b", &br, 11);
        let settle = &c.metrics[Metric::SettleS as usize];
        assert_eq!(
            (settle.pairs, settle.only_a, settle.only_b, settle.neither),
            (197, 3, 0, 0)
        );
        let [lo, hi] = settle.ci95.unwrap();
        assert!(lo > 1.5 && lo < 2.0 && hi > 2.0 && hi < 2.5, "[{lo}, {hi}]");
        assert_eq!(settle.outcome, Outcome::Worse);
        assert!(
            settle.verdict.contains("b is worse")
                && settle
                    .verdict
                    .contains("never settled: a only 0 run(s), b only 3"),
            "{}",
            settle.verdict
        );
        // NEES per dof: b farther from 1, so worse.
        let nees = &c.metrics[Metric::NeesPerDof as usize];
        assert_eq!(nees.outcome, Outcome::Worse);
        assert_eq!(
            c.metrics[Metric::TiltStops as usize].outcome,
            Outcome::NoDifference
        );
        assert!(
            c.metrics[Metric::TiltStops as usize]
                .verdict
                .contains("every pair equal")
        );
        assert_eq!(
            c.metrics[Metric::SaturationS as usize].outcome,
            Outcome::TooFewPairs
        );
        assert!(
            c.overall.contains("worse on 2")
                && c.overall.contains("never settled: a 0 run(s), b 3"),
            "{}",
            c.overall
        );
        // The same inputs give the same interval: the bootstrap is seeded.
        assert_eq!(compare("a", &ar, "b", &br, 11), c);
    }

    /// Reference values of the two-sided exact binomial (McNemar) test, computed by hand:
    /// 2 · Σ C(n, i) / 2^n.
    #[test]
    fn mcnemar_p_values_are_the_exact_binomial_tails() {
        let close = |p: f64, expected: f64| (p - expected).abs() < 1e-12 * expected;
        assert!(close(mcnemar_p(3, 0), 0.25));
        assert!(close(mcnemar_p(8, 2), 2.0 * 56.0 / 1024.0));
        assert_eq!(mcnemar_p(4, 4), 1.0);
        assert!(mcnemar_p(79, 0) < 1e-20);
        // Failures in b only, where both settle alike: worse by the failures alone.
        let a: Vec<RunRow> = (0..20).map(|k| row(k, "a", Some(60.0), 1.0)).collect();
        let b: Vec<RunRow> = (0..20)
            .map(|k| row(k, "b", (k >= 10).then_some(60.0), 1.0))
            .collect();
        let c = compare(
            "a",
            &a.iter().collect::<Vec<_>>(),
            "b",
            &b.iter().collect::<Vec<_>>(),
            1,
        );
        let settle = &c.metrics[Metric::SettleS as usize];
        assert_eq!(settle.outcome, Outcome::Worse);
        assert!(
            settle.verdict.contains("McNemar") && settle.verdict.ends_with("b is worse)"),
            "{}",
            settle.verdict
        );
    }

    #[test]
    fn numbers_keep_three_significant_digits() {
        assert_eq!(sig3(123.456), "123");
        assert_eq!(sig3(-0.0123456), "-0.0123");
        assert_eq!(sig3(4.2), "4.20");
        assert_eq!(sig3(0.0), "0");
        assert_eq!(sig3(3.35e-5), "3.35e-5");
        assert_eq!(sig3(-2.5e-24), "-2.50e-24");
    }
}
