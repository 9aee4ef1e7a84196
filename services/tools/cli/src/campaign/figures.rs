//! A campaign's figures (SVG and PNG): the empirical distribution functions of the main metrics
//! (one curve per variant), and over time the envelope of the pointing error and the ensemble's
//! NEES against its chi-square interval.

use crate::figure::{self, Panel, Series, XAxis};
use anyhow::Result;
use std::path::{Path, PathBuf};
use testbed_campaign::CampaignFile;
use testbed_campaign::metrics::{Metric, NEES_DOF};
use testbed_campaign::results::RunRow;
use testbed_campaign::summary::CampaignSummary;

/// The metrics drawn as ECDFs, with their axis labels.
const ECDF_METRICS: [(Metric, &str); 6] = [
    (Metric::SettleS, "settling time (s)"),
    (Metric::SteadyErrorXDeg, "steady error X (deg)"),
    (Metric::SteadyErrorYDeg, "steady error Y (deg)"),
    (Metric::SteadyErrorZDeg, "steady error Z (deg)"),
    (Metric::PeakWheelSpeedRpm, "peak wheel speed (rpm)"),
    (Metric::NeesPerDof, "mean NEES per dof"),
];

/// The empirical distribution of `values` as a staircase: the fraction of runs at or below x.
/// Undefined runs count in the denominator, so a curve that ends below 1 says how many never
/// had a value (e.g. never settled).
fn ecdf(mut values: Vec<f64>, runs: usize) -> Vec<(f64, f64)> {
    values.sort_by(f64::total_cmp);
    let n = runs.max(1) as f64;
    let mut points = Vec::with_capacity(2 * values.len());
    for (i, x) in values.iter().enumerate() {
        points.push((*x, i as f64 / n));
        points.push((*x, (i + 1) as f64 / n));
    }
    points
}

/// Writes `ecdf.{svg,png}` and `envelope.{svg,png}` into `out`; returns their paths.
pub fn write(
    out: &Path,
    file: &CampaignFile,
    summary: &CampaignSummary,
    rows: &[RunRow],
) -> Result<Vec<PathBuf>> {
    let variants = &summary.variants;
    let of = |v: &str| -> Vec<&RunRow> { rows.iter().filter(|r| r.variant == v).collect() };
    let title = |what: &str| {
        format!(
            "testbed campaign {}: {what}, {} runs, seed {}",
            summary.campaign, summary.runs, summary.seed
        )
    };

    let ecdf_panels: Vec<Panel> = ECDF_METRICS
        .iter()
        .map(|(metric, _)| {
            Panel::new(
                "fraction of runs",
                variants
                    .iter()
                    .map(|v| {
                        let runs = of(v);
                        let values = runs.iter().filter_map(|r| r.metrics.get(*metric)).collect();
                        Series {
                            label: v.as_str(),
                            points: ecdf(values, runs.len()),
                            dashed: false,
                        }
                    })
                    .collect(),
            )
        })
        .collect();
    let labels: Vec<&str> = ECDF_METRICS.iter().map(|(_, label)| *label).collect();
    let mut written = figure::write_figure_on(
        &out.join("ecdf"),
        &title("distribution of each metric over the runs"),
        XAxis::PerPanel(&labels),
        &ecdf_panels,
    )?;

    let mut panels = Vec::new();
    let band = file.metrics.settle_band_deg;
    let y_labels: Vec<String> = summary
        .per_variant
        .iter()
        .map(|v| {
            if variants.len() > 1 {
                format!("{}: pointing error (deg)", v.variant)
            } else {
                "pointing error (deg)".to_string()
            }
        })
        .collect();
    for (v, label) in summary.per_variant.iter().zip(&y_labels) {
        let e = &v.envelope;
        let curve = |label, ys: &[f64], dashed| Series {
            label,
            points: e.t_s.iter().copied().zip(ys.iter().copied()).collect(),
            dashed,
        };
        let curves = || {
            vec![
                curve("median", &e.median, false),
                curve("5 %", &e.p5, true),
                curve("95 %", &e.p95, true),
                curve("max", &e.max, false),
            ]
        };
        panels.push(Panel::new(label, curves()));
        panels.push(Panel {
            y_range: Some((0.0, 4.0 * band)),
            band: Some(band),
            ..Panel::new(label, curves())
        });
    }
    panels.push(Panel::new(
        "ensemble NEES per dof",
        nees_series(file, summary, rows),
    ));
    written.extend(figure::write_figure(
        &out.join("envelope"),
        &title("pointing error over the runs (near the band below) and ensemble NEES"),
        &panels,
    )?);
    Ok(written)
}

/// Per variant the mean NEES per dof over the runs at each series time from
/// `estimation_from_s`, and (dashed) the 95 % interval of that mean for a consistent filter.
fn nees_series<'a>(
    file: &CampaignFile,
    summary: &'a CampaignSummary,
    rows: &[RunRow],
) -> Vec<Series<'a>> {
    let step = file.metrics.series_step_s;
    let first = (file.metrics.estimation_from_s / step).ceil() as usize;
    let mut out = Vec::new();
    let mut interval = None;
    for v in &summary.per_variant {
        let runs: Vec<&RunRow> = rows.iter().filter(|r| r.variant == v.variant).collect();
        let length = runs.iter().map(|r| r.series.nees.len()).min().unwrap_or(0);
        let points = (first..length)
            .map(|j| {
                let finite: Vec<f64> = runs
                    .iter()
                    .map(|r| r.series.nees[j])
                    .filter(|x| x.is_finite())
                    .collect();
                let mean = finite.iter().sum::<f64>() / (finite.len().max(1) * NEES_DOF) as f64;
                (j as f64 * step, mean)
            })
            .collect();
        out.push(Series {
            label: v.variant.as_str(),
            points,
            dashed: false,
        });
        interval = interval.or(v.consistency.interval_per_dof);
    }
    if let (Some([lo, hi]), Some(t_end)) = (
        interval,
        summary
            .per_variant
            .first()
            .and_then(|v| v.envelope.t_s.last().copied()),
    ) {
        let t0 = first as f64 * step;
        for (label, y) in [("95 % interval", lo), ("", hi)] {
            out.push(Series {
                label,
                points: vec![(t0, y), (t_end, y)],
                dashed: true,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_ecdf_climbs_to_the_defined_fraction() {
        let points = ecdf(vec![3.0, 1.0, 2.0], 4);
        assert_eq!(points.first(), Some(&(1.0, 0.0)));
        assert_eq!(points.last(), Some(&(3.0, 0.75)));
        assert_eq!(points.len(), 6);
    }
}
