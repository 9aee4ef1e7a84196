//! The statistics of a campaign's runs: per metric the distribution over runs (median, 5 and
//! 95 %, mean, worst), the estimator's consistency over the ensemble, the envelope of the
//! pointing error over time, the worst runs, the runs that reached the safe-mode limit.
//!
//! Every number is a function of the rows in index order, so a merge of shards computes the
//! same bits as one host.

use crate::distribution::{Apply, Distribution};
use crate::file::{CampaignFile, MetricOptions};
use crate::metrics::{Better, Metric, NEES_DOF};
use crate::paired::{self, Comparison};
use crate::results::RunRow;
use serde::Serialize;
use testbed_flight::stats::chi_square_quantile;

/// Quantile `p` of ascending `sorted` values, linear between order statistics (the `R-7` /
/// NumPy default definition); `None` for no values.
pub fn quantile(sorted: &[f64], p: f64) -> Option<f64> {
    let last = sorted.len().checked_sub(1)?;
    let h = p.clamp(0.0, 1.0) * last as f64;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(last);
    Some(sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo]))
}

/// A metric's distribution over the runs that define it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetricSummary {
    pub metric: &'static str,
    pub unit: &'static str,
    pub runs_defined: usize,
    pub runs_undefined: usize,
    /// What a run without a value means ("never settled").
    pub undefined_means: &'static str,
    pub median: Option<f64>,
    pub p5: Option<f64>,
    pub p95: Option<f64>,
    pub mean: Option<f64>,
    /// The largest value, or the farthest from the consistent value for consistency metrics.
    pub worst: Option<f64>,
    pub worst_run: Option<u64>,
}

pub fn metric_summary(rows: &[&RunRow], metric: Metric) -> MetricSummary {
    let defined: Vec<(u64, f64)> = rows
        .iter()
        .filter_map(|r| r.metrics.get(metric).map(|x| (r.index, x)))
        .collect();
    let mut sorted: Vec<f64> = defined.iter().map(|(_, x)| *x).collect();
    sorted.sort_by(f64::total_cmp);
    let badness = |x: f64| match metric.better() {
        Better::Lower => x,
        Better::Near(target) => (x - target).abs(),
    };
    let worst = defined
        .iter()
        .copied()
        .reduce(|w, c| if badness(c.1) > badness(w.1) { c } else { w });
    MetricSummary {
        metric: metric.name(),
        unit: metric.unit(),
        runs_defined: defined.len(),
        runs_undefined: rows.len() - defined.len(),
        undefined_means: metric.undefined_means(),
        median: quantile(&sorted, 0.5),
        p5: quantile(&sorted, 0.05),
        p95: quantile(&sorted, 0.95),
        mean: (!sorted.is_empty()).then(|| sorted.iter().sum::<f64>() / sorted.len() as f64),
        worst: worst.map(|w| w.1),
        worst_run: worst.map(|w| w.0),
    }
}

/// The estimator's consistency over the ensemble of runs: at each series time from
/// `estimation_from_s`, the mean NEES over the runs (independent at one time) lies inside its
/// two-sided 95 % chi-square interval `[χ²(2.5 %, 6N), χ²(97.5 %, 6N)] / N` about 95 % of the
/// time when the filter's covariance is right.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Consistency {
    /// Mean over runs of each run's mean NEES per degree of freedom (1 if consistent).
    pub mean_nees_per_dof: Option<f64>,
    pub dof: usize,
    /// Runs in the ensemble (those with an estimate at every series time counted).
    pub runs: usize,
    /// The ensemble mean's 95 % interval per degree of freedom, for `runs` runs.
    pub interval_per_dof: Option<[f64; 2]>,
    /// Fraction of series times whose ensemble mean NEES lies inside that interval (≈ 0.95).
    pub fraction_inside: Option<f64>,
    /// Series times counted.
    pub times: usize,
}

pub fn consistency(rows: &[&RunRow], options: &MetricOptions) -> Consistency {
    let means: Vec<f64> = rows
        .iter()
        .filter_map(|r| r.metrics.get(Metric::NeesPerDof))
        .collect();
    let first = (options.estimation_from_s / options.series_step_s).ceil() as usize;
    let length = rows.iter().map(|r| r.series.nees.len()).min().unwrap_or(0);
    let ensemble: Vec<&RunRow> = rows
        .iter()
        .copied()
        .filter(|r| {
            r.series.nees[first.min(length)..length]
                .iter()
                .all(|x| x.is_finite())
        })
        .collect();
    let n = ensemble.len();
    let dof = NEES_DOF as f64;
    let interval = (n > 0)
        .then(|| {
            let k = dof * n as f64;
            Some([
                chi_square_quantile(0.025, k)? / k,
                chi_square_quantile(0.975, k)? / k,
            ])
        })
        .flatten();
    let times = length.saturating_sub(first);
    let fraction_inside = interval.filter(|_| times > 0).map(|[lo, hi]| {
        let inside = (first..length)
            .filter(|&j| {
                let mean =
                    ensemble.iter().map(|r| r.series.nees[j]).sum::<f64>() / (n as f64 * dof);
                (lo..=hi).contains(&mean)
            })
            .count();
        inside as f64 / times as f64
    });
    Consistency {
        mean_nees_per_dof: (!means.is_empty())
            .then(|| means.iter().sum::<f64>() / means.len() as f64),
        dof: NEES_DOF,
        runs: n,
        interval_per_dof: interval,
        fraction_inside,
        times,
    }
}

/// The pointing error's envelope over the runs at each series time, degrees.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct Envelope {
    pub t_s: Vec<f64>,
    pub median: Vec<f64>,
    pub p5: Vec<f64>,
    pub p95: Vec<f64>,
    pub max: Vec<f64>,
}

pub fn envelope(rows: &[&RunRow], step_s: f64) -> Envelope {
    let length = rows
        .iter()
        .map(|r| r.series.pointing_error_deg.len())
        .max()
        .unwrap_or(0);
    let mut out = Envelope::default();
    for j in 0..length {
        let mut at: Vec<f64> = rows
            .iter()
            .filter_map(|r| r.series.pointing_error_deg.get(j).copied())
            .collect();
        at.sort_by(f64::total_cmp);
        let q = |p| quantile(&at, p).unwrap_or(f64::NAN);
        out.t_s.push(j as f64 * step_s);
        out.median.push(q(0.5));
        out.p5.push(q(0.05));
        out.p95.push(q(0.95));
        out.max.push(q(1.0));
    }
    out
}

/// One of the worst runs, with what made it so.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WorstRun {
    pub index: u64,
    pub settle_s: Option<f64>,
    /// The largest steady error of the three axes, degrees.
    pub steady_error_deg: Option<f64>,
    pub error: Option<String>,
}

/// The `count` worst runs: failed first, then never settled, then the latest to settle; the
/// steady error breaks ties.
pub fn worst_runs(rows: &[&RunRow], count: usize) -> Vec<WorstRun> {
    let steady = |r: &RunRow| {
        [
            Metric::SteadyErrorXDeg,
            Metric::SteadyErrorYDeg,
            Metric::SteadyErrorZDeg,
        ]
        .into_iter()
        .filter_map(|m| r.metrics.get(m))
        .reduce(f64::max)
    };
    let mut ranked: Vec<&RunRow> = rows.to_vec();
    let key = |r: &RunRow| {
        (
            r.error.is_none(),
            -r.metrics.get(Metric::SettleS).unwrap_or(f64::INFINITY),
            -steady(r).unwrap_or(f64::INFINITY),
        )
    };
    ranked.sort_by(|a, b| {
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0)
            .then(ka.1.total_cmp(&kb.1))
            .then(ka.2.total_cmp(&kb.2))
            .then(a.index.cmp(&b.index))
    });
    ranked
        .into_iter()
        .take(count)
        .map(|r| WorstRun {
            index: r.index,
            settle_s: r.metrics.get(Metric::SettleS),
            steady_error_deg: steady(r),
            error: r.error.clone(),
        })
        .collect()
}

/// A run the closed loop could not carry out.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FailedRun {
    pub index: u64,
    pub error: String,
}

/// Everything the report says about one variant's runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VariantSummary {
    pub variant: String,
    pub runs: usize,
    pub failed: Vec<FailedRun>,
    pub metrics: Vec<MetricSummary>,
    pub consistency: Consistency,
    /// Runs whose wheels passed the safe-mode limit: where the real pipeline would enter safe
    /// mode (the in-process loop has no safe mode and runs on).
    pub safe_mode_limit_runs: usize,
    pub tilt_stop_runs: usize,
    pub gate_rejections: u64,
    pub envelope: Envelope,
    pub worst_runs: Vec<WorstRun>,
}

pub fn variant_summary(variant: &str, rows: &[&RunRow], options: &MetricOptions) -> VariantSummary {
    let count_runs = |metric| {
        rows.iter()
            .filter(|r| r.metrics.get(metric).is_some_and(|x| x > 0.0))
            .count()
    };
    VariantSummary {
        variant: variant.to_string(),
        runs: rows.len(),
        failed: rows
            .iter()
            .filter_map(|r| {
                r.error.as_ref().map(|e| FailedRun {
                    index: r.index,
                    error: e.clone(),
                })
            })
            .collect(),
        metrics: Metric::ALL
            .iter()
            .map(|m| metric_summary(rows, *m))
            .collect(),
        consistency: consistency(rows, options),
        safe_mode_limit_runs: count_runs(Metric::SafeModeLimit),
        tilt_stop_runs: count_runs(Metric::TiltStops),
        gate_rejections: rows
            .iter()
            .filter_map(|r| r.metrics.get(Metric::GateRejections))
            .sum::<f64>() as u64,
        envelope: envelope(rows, options.series_step_s),
        worst_runs: worst_runs(rows, 5),
    }
}

/// A dispersion as the summary lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DispersionSummary {
    pub key: String,
    pub distribution: Distribution,
    pub apply: Apply,
}

/// The whole campaign's summary (`summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CampaignSummary {
    /// The campaign file as named when it ran (the reproducing commands name it so).
    pub campaign: String,
    pub runs: u64,
    pub seed: u64,
    pub variants: Vec<String>,
    pub dispersions: Vec<DispersionSummary>,
    pub metric_options: MetricOptions,
    /// The in-process loop has no clock: deadline misses are a property of the real pipeline
    /// (`testbed run --campaign … --campaign-run K` shows them for one run).
    pub deadline_misses: &'static str,
    pub per_variant: Vec<VariantSummary>,
    pub comparisons: Vec<Comparison>,
}

/// The summary of `rows` (every run of every variant, in (index, variant) order).
pub fn summarise(file: &CampaignFile, rows: &[RunRow]) -> CampaignSummary {
    let variants = file.variant_names();
    let of = |v: &str| -> Vec<&RunRow> { rows.iter().filter(|r| r.variant == v).collect() };
    let per_variant = variants
        .iter()
        .map(|v| variant_summary(v, &of(v), &file.metrics))
        .collect();
    let comparisons = match &file.baseline {
        Some(a) => variants
            .iter()
            .filter(|b| *b != a)
            .map(|b| paired::compare(a, &of(a), b, &of(b), file.seed))
            .collect(),
        None => Vec::new(),
    };
    CampaignSummary {
        campaign: file.path.display().to_string(),
        runs: file.runs,
        seed: file.seed,
        variants,
        dispersions: file
            .dispersions
            .iter()
            .map(|d| DispersionSummary {
                key: d.key.to_string(),
                distribution: d.distribution.clone(),
                apply: d.apply,
            })
            .collect(),
        metric_options: file.metrics,
        deadline_misses: "not counted: the in-process loop has no clock; a run reproduced through the processes (testbed run --campaign FILE --campaign-run K) counts them",
        per_variant,
        comparisons,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::{RunMetrics, RunSeries};

    fn row(index: u64, settle: Option<f64>, nees: &[f64]) -> RunRow {
        let mut metrics = RunMetrics::default();
        metrics.0[Metric::SettleS as usize] = settle;
        metrics.0[Metric::SteadyErrorXDeg as usize] = Some(index as f64 * 0.01);
        RunRow {
            index,
            variant: "base".into(),
            seed: index,
            values: vec![],
            metrics,
            error: None,
            series: RunSeries {
                pointing_error_deg: nees.iter().map(|x| x * 2.0).collect(),
                nees: nees.to_vec(),
            },
        }
    }

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let xs = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(quantile(&xs, 0.5), Some(3.0));
        assert_eq!(quantile(&xs, 0.05), Some(1.2));
        assert_eq!(quantile(&xs, 1.0), Some(5.0));
        assert_eq!(quantile(&[7.0], 0.95), Some(7.0));
        assert_eq!(quantile(&[], 0.5), None);
    }

    #[test]
    fn a_metric_summary_counts_the_undefined_apart_and_names_the_worst_run() {
        let rows = [
            row(0, Some(50.0), &[]),
            row(1, None, &[]),
            row(2, Some(90.0), &[]),
            row(3, Some(70.0), &[]),
        ];
        let refs: Vec<&RunRow> = rows.iter().collect();
        let s = metric_summary(&refs, Metric::SettleS);
        assert_eq!((s.runs_defined, s.runs_undefined), (3, 1));
        assert_eq!(s.median, Some(70.0));
        assert_eq!(s.mean, Some(70.0));
        assert_eq!((s.worst, s.worst_run), (Some(90.0), Some(2)));
        assert_eq!(s.undefined_means, "never settled");
        let worst: Vec<u64> = worst_runs(&refs, 3).iter().map(|w| w.index).collect();
        assert_eq!(worst, [1, 2, 3]);
    }

    #[test]
    fn the_ensemble_nees_is_judged_against_its_chi_square_interval() {
        // Two runs whose NEES per dof is exactly 1 at every time: inside at every time; a
        // third, ten times too large, pushes the mean out.
        let ok = [6.0; 5];
        let rows = [row(0, None, &ok), row(1, None, &ok)];
        let options = MetricOptions {
            estimation_from_s: 1.0,
            series_step_s: 1.0,
            ..MetricOptions::default()
        };
        let refs: Vec<&RunRow> = rows.iter().collect();
        let c = consistency(&refs, &options);
        assert_eq!((c.runs, c.times), (2, 4));
        assert_eq!(c.fraction_inside, Some(1.0));
        let [lo, hi] = c.interval_per_dof.unwrap();
        assert!(lo < 1.0 && hi > 1.0 && lo > 0.2 && hi < 2.2, "[{lo}, {hi}]");
        let rows = [
            row(0, None, &ok),
            row(1, None, &ok),
            row(2, None, &[60.0; 5]),
        ];
        let refs: Vec<&RunRow> = rows.iter().collect();
        assert_eq!(consistency(&refs, &options).fraction_inside, Some(0.0));
        let e = envelope(&refs, 1.0);
        assert_eq!(e.t_s, [0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!((e.median[0], e.max[0]), (12.0, 120.0));
    }
}
