//! The identification's figures (SVG): predictions, equation errors and the gain per window.

use crate::figure::{self, Panel, Series};
use anyhow::Result;
use std::path::Path;
use testbed_ident::identify::{Curve, FigureData};

/// Held-out windows drawn as windows: each (start, value) becomes a horizontal bar over the
/// window (at most `horizon_s`, ending before the next window), with a gap after it, so the
/// held-out blocks are not joined across the fit data between them.
fn window_bars(points: &[(f64, f64)], horizon_s: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(3 * points.len());
    for (i, &(t, v)) in points.iter().enumerate() {
        let end = points
            .get(i + 1)
            .map_or(t + horizon_s, |next| (t + horizon_s).min(next.0));
        out.extend([(t, v), (end, v), (end, f64::NAN)]);
    }
    out
}

/// Display scale and unit of a residual component.
fn display(label: &str) -> (f64, &'static str) {
    match label {
        l if l.starts_with("gyro") => (1e6, "µrad/s"),
        l if l.starts_with("tilt") => (1e6, "µrad"),
        l if l.starts_with("field") => (1e6, "µT"),
        l if l.starts_with("wheel_torque") => (1e3, "mNm"),
        l if l.starts_with("wheel") => (1.0, "rad/s"),
        l if l.starts_with("momentum") => (1e3, "mNms"),
        _ => (1.0, "whitened"),
    }
}

/// At most `n` points of a curve (every k-th).
fn thin(points: &[(f64, f64)], n: usize, scale: f64) -> Vec<(f64, f64)> {
    let step = points.len().div_ceil(n.max(1)).max(1);
    points
        .iter()
        .step_by(step)
        .map(|(t, v)| (*t, v * scale))
        .collect()
}

fn panel_from<'a>(
    curves: &'a [Curve],
    keep: impl Fn(&str) -> bool,
    title: &'a str,
) -> Option<Panel<'a>> {
    let series: Vec<Series<'a>> = curves
        .iter()
        .filter(|c| keep(&c.label))
        .map(|c| {
            let (scale, _) = display(&c.label);
            Series {
                label: c.label.as_str(),
                points: thin(&c.points, 3000, scale),
                dashed: false,
            }
        })
        .collect();
    (!series.is_empty()).then_some(Panel {
        y_label: title,
        series,
        y_range: None,
        band: None,
        marker: None,
    })
}

pub(super) fn write_figures(out: &Path, f: &FigureData, horizon_s: f64) -> Result<Vec<String>> {
    let mut written = Vec::new();
    let prediction: Vec<Panel> = [
        ("gyro", "rate residual (µrad/s)"),
        ("tilt", "tilt residual (µrad)"),
        ("field", "field residual (µT)"),
        ("wheel", "wheel speed residual (rad/s)"),
    ]
    .into_iter()
    .filter_map(|(p, t)| panel_from(&f.nominal_prediction, |l| l.starts_with(p), t))
    .collect();
    if !prediction.is_empty() {
        let path = out.join("nominal_residuals.svg");
        figure::write_svg(
            &path,
            "Nominal model: measured − predicted (re-initialised every window)",
            &prediction,
        )?;
        written.push(path.display().to_string());
    }
    let relabel = |curves: &[Curve], which: &str| -> Vec<Curve> {
        curves
            .iter()
            .map(|c| Curve {
                label: format!("{} ({which})", c.label),
                points: c.points.clone(),
            })
            .collect()
    };
    let both: Vec<Curve> = relabel(&f.nominal_equation, "nominal")
        .into_iter()
        .chain(relabel(&f.extended_equation, "extended"))
        .collect();
    let mut equation = Vec::new();
    for which in ["(nominal)", "(extended)"] {
        for (prefix, title) in [
            ("momentum", "momentum residual (mNms)"),
            ("wheel_torque", "wheel torque residual (mNm)"),
            ("innovation", "filter innovation (whitened)"),
        ] {
            if let Some(p) = panel_from(
                &both,
                |l| l.starts_with(prefix) && l.ends_with(which),
                title,
            ) {
                equation.push(p);
            }
        }
    }
    if !equation.is_empty() {
        let path = out.join("equation_error.svg");
        figure::write_svg(
            &path,
            "Equation-error residuals: nominal, then extended model",
            &equation,
        )?;
        written.push(path.display().to_string());
    }
    let groups = ["rates", "tilt", "field", "wheel speeds"];
    let titles: Vec<String> = groups.iter().map(|g| format!("{g}: RMS / noise")).collect();
    let mut gain = Vec::new();
    for (group, title) in groups.iter().zip(&titles) {
        let nominal = f.held_out_nominal.iter().find(|c| c.label == *group);
        let extended = f.held_out_extended.iter().find(|c| c.label == *group);
        if let (Some(a), Some(b)) = (nominal, extended) {
            gain.push(Panel {
                y_label: title.as_str(),
                series: vec![
                    Series {
                        label: "nominal",
                        points: window_bars(&a.points, horizon_s),
                        dashed: false,
                    },
                    Series {
                        label: "extended",
                        points: window_bars(&b.points, horizon_s),
                        dashed: false,
                    },
                ],
                y_range: None,
                band: None,
                marker: None,
            });
        }
    }
    if !gain.is_empty() {
        let path = out.join("gain.svg");
        figure::write_svg(
            &path,
            "Held-out prediction error per window (bars: the held-out windows; gaps: fit data)",
            &gain,
        )?;
        written.push(path.display().to_string());
    }
    Ok(written)
}
