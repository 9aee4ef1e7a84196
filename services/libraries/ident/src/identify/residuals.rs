//! After a fit: the equation-error residual series (torque, wheel torque, innovations) and their
//! report, whether residual remains after the chosen causes, and what it correlates with.

use super::Options;
use super::report::{ComponentReport, Correlation, Curve, Remaining, ResidualReport};
use crate::channels::{TORQUE_COLUMNS, friction_regressors};
use crate::fit::{CHANNELS, ChannelRss, Evaluation, Problem, SetFit, WheelModel};
use crate::predict::{COMPONENTS, Predictions, UNITS};
use crate::reconstruct::INNOVATION_LEN;
use crate::stats::{correlation, series_stats};
use std::collections::BTreeMap;
use testbed_model::attitude;

/// Equation-error residual series of a fitted set: torque (Nm), wheel torque (Nm), innovations
/// (whitened); and its residual report with the prediction residuals.
pub(super) fn equation_error(
    problem: &Problem,
    fit: &SetFit,
    prediction: &Predictions,
) -> (Vec<Curve>, ResidualReport) {
    let data = problem.data;
    let s = &fit.state;
    let mut curves = Vec::new();
    // Torque channel: momentum residual (integral of the torque residual), Nms.
    let mut torque: [Vec<(f64, f64)>; 3] = Default::default();
    for (i, &k) in s.torque.ticks.iter().enumerate() {
        let r = s
            .torque
            .whitened(i, &fit.torque_delta)
            .component_mul(&s.torque.sigma);
        for axis in 0..3 {
            torque[axis].push((data.t[k], r[axis]));
        }
    }
    let torque_sigma = [s.torque.sigma.x, s.torque.sigma.y, s.torque.sigma.z];
    let wheel_model = WheelModel::from_config(&fit.config);
    let mut wheel: [Vec<(f64, f64)>; 3] = Default::default();
    let mut wheel_sigma = 0.0;
    for (w, rows) in s.wheel.rows.iter().enumerate() {
        for row in rows {
            let dt = row.t1 - row.t0;
            wheel[w].push((row.t0, wheel_model.residual(data, &s.wheel, w, row) / dt));
            wheel_sigma = s.wheel.sigma / dt;
        }
    }
    let mut innovations: [Vec<(f64, f64)>; INNOVATION_LEN] = Default::default();
    for i in &s.recon.innovations {
        for c in 0..INNOVATION_LEN {
            if i.mask & (1 << c) != 0 {
                innovations[c].push((data.t[i.tick], i.values[c]));
            }
        }
    }
    let mut equation = Vec::new();
    let names_t = ["momentum_x", "momentum_y", "momentum_z"];
    let names_w = ["wheel_torque_x", "wheel_torque_y", "wheel_torque_z"];
    let names_i = [
        "innovation_tilt_1",
        "innovation_tilt_2",
        "innovation_field_x",
        "innovation_field_y",
        "innovation_field_z",
    ];
    for (series, names, unit, sigma) in [
        (&torque[..], &names_t[..], "Nms", &torque_sigma[..]),
        (&wheel[..], &names_w[..], "Nm", &[wheel_sigma; 3][..]),
        (
            &innovations[..],
            &names_i[..],
            "1 (whitened)",
            &[1.0; 5][..],
        ),
    ] {
        for (c, xs) in series.iter().enumerate() {
            if xs.is_empty() {
                continue;
            }
            let t: Vec<f64> = xs.iter().map(|p| p.0).collect();
            let v: Vec<f64> = xs.iter().map(|p| p.1).collect();
            let stats = series_stats(&t, &v, 10);
            equation.push(ComponentReport {
                name: names[c].to_string(),
                unit,
                normalised_rms: stats.rms / sigma[c].max(1e-300),
                stats,
            });
            curves.push(Curve {
                label: names[c].to_string(),
                points: xs.clone(),
            });
        }
    }
    let mut pred = Vec::new();
    for c in 0..COMPONENTS.len() {
        let xs = &prediction.residuals[c];
        if xs.is_empty() {
            continue;
        }
        let t: Vec<f64> = xs.iter().map(|p| p.0).collect();
        let v: Vec<f64> = xs.iter().map(|p| p.1).collect();
        let stats = series_stats(&t, &v, 10);
        pred.push(ComponentReport {
            name: COMPONENTS[c].to_string(),
            unit: UNITS[c],
            normalised_rms: stats.rms / prediction.sigma[c],
            stats,
        });
    }
    let rms_map = |e: &ChannelRss| -> BTreeMap<&'static str, f64> {
        (0..3)
            .filter(|&c| e.n[c] > 0)
            .map(|c| (CHANNELS[c], e.normalised_rms(c)))
            .collect()
    };
    let Evaluation {
        fit: f,
        held_out: h,
    } = fit.evaluation;
    (
        curves,
        ResidualReport {
            prediction: pred,
            equation_error: equation,
            channel_rms_fit: rms_map(&f),
            channel_rms_held_out: rms_map(&h),
        },
    )
}

/// Is there residual left after the chosen causes, and what does it correlate with? Three
/// statements, consistent with the numbers the report prints: the equation-error channels'
/// RMS against the noise the model expects (held-out data), the unexplained effects found, and
/// the extended model's multi-step prediction error against the sensor noise.
pub(super) fn remaining(
    problem: &Problem,
    fit: &SetFit,
    options: &Options,
    effects: &[super::UnexplainedEffect],
    extended: &super::RmsReport,
) -> Remaining {
    let e = &fit.evaluation.held_out;
    let channel_rms: BTreeMap<&'static str, f64> = (0..3)
        .filter(|&c| e.n[c] > 0)
        .map(|c| (CHANNELS[c], e.normalised_rms(c)))
        .collect();
    let high: Vec<&'static str> = channel_rms
        .iter()
        .filter(|(_, v)| **v > options.remaining_rms)
        .map(|(k, _)| *k)
        .collect();
    // Prediction: the groups (rates, tilt, field, wheel speeds) at their normalised RMS.
    let groups = extended
        .groups
        .iter()
        .map(|(g, v)| format!("{g} {v:.1}×"))
        .collect::<Vec<_>>()
        .join(", ");
    let prediction = format!(
        "the extended model's {:.0}-s predictions of the held-out data stay at {groups} the sensor noise (the multi-step error includes the filter's state error at each re-initialisation, so 1× is not expected)",
        options.horizon_s
    );
    if high.is_empty() && effects.is_empty() {
        return Remaining {
            residual_remains: false,
            message: format!(
                "What remains: no structure — every equation-error channel is within {:.2}× the noise the model expects on the held-out data and no candidate function is significant; {prediction}.",
                options.remaining_rms
            ),
            channel_rms,
            correlations: Vec::new(),
        };
    }
    let correlations = correlate(problem, fit);
    let top = correlations.first().map_or(String::new(), |c| {
        format!(
            "; strongest correlation: {} with {} (r = {:.2})",
            c.residual, c.signal, c.r
        )
    });
    let mut parts = Vec::new();
    if !high.is_empty() {
        parts.push(format!(
            "residual remains in the {} channel{} (RMS above {:.2}× the expected noise on held-out data){top}",
            high.join(", "),
            if high.len() > 1 { "s" } else { "" },
            options.remaining_rms
        ));
    }
    if !effects.is_empty() {
        parts.push(format!(
            "structure remains in {} (the unexplained effect{} above)",
            effects
                .iter()
                .map(|e| e.equation.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            if effects.len() > 1 { "s" } else { "" }
        ));
    }
    Remaining {
        residual_remains: true,
        message: format!("What remains: {}; {prediction}.", parts.join("; ")),
        channel_rms,
        correlations,
    }
}

/// Correlations of the equation-error residuals with the candidate effects' signals, strongest
/// first (top 8).
fn correlate(problem: &Problem, fit: &SetFit) -> Vec<Correlation> {
    let data = problem.data;
    let s = &fit.state;
    let mut out = Vec::new();
    // Torque channel: against every torque regressor and the rates.
    if !s.torque.is_empty() {
        for axis in 0..3 {
            let r: Vec<f64> = (0..s.torque.len())
                .map(|i| s.torque.whitened(i, &fit.torque_delta)[axis])
                .collect();
            for col in (0..TORQUE_COLUMNS).filter(|c| s.torque.determined(*c)) {
                let x: Vec<f64> = s.torque.x.iter().map(|row| row[col][axis]).collect();
                let (cause, off) = crate::channels::column_cause(col);
                out.push(Correlation {
                    residual: format!("momentum_{}", "xyz".as_bytes()[axis] as char),
                    signal: cause.value_name(off),
                    r: correlation(&r, &x),
                });
            }
            for c in 0..3 {
                let x: Vec<f64> = s.torque.ticks.iter().map(|&k| s.recon.rate[k][c]).collect();
                out.push(Correlation {
                    residual: format!("momentum_{}", "xyz".as_bytes()[axis] as char),
                    signal: format!("rate_{}", "xyz".as_bytes()[c] as char),
                    r: correlation(&r, &x),
                });
            }
        }
    }
    // Wheel channel: against the command, the friction regressors and the command's change.
    let model = WheelModel::from_config(&fit.config);
    for (w, rows) in s.wheel.rows.iter().enumerate() {
        if rows.len() < 3 {
            continue;
        }
        let r: Vec<f64> = rows
            .iter()
            .map(|row| model.residual(data, &s.wheel, w, row))
            .collect();
        let name = format!("wheel_torque_{}", "xyz".as_bytes()[w] as char);
        let tau: Vec<f64> = rows
            .iter()
            .map(|row| {
                data.wheel_cmd_integral(row.t0, row.t1, model.delay_s, s.wheel.max_torque_nm)[w]
            })
            .collect();
        let dtau: Vec<f64> = rows
            .iter()
            .map(|row| {
                data.wheel_cmd_integral(row.t0, row.t1, model.delay_s, s.wheel.max_torque_nm)[w]
                    - data.wheel_cmd_integral(
                        row.t0,
                        row.t1,
                        model.delay_s + data.period_s,
                        s.wheel.max_torque_nm,
                    )[w]
            })
            .collect();
        out.push(Correlation {
            residual: name.clone(),
            signal: "wheel_torque_scale (command)".into(),
            r: correlation(&r, &tau),
        });
        out.push(Correlation {
            residual: name.clone(),
            signal: "actuator_delay (command change)".into(),
            r: correlation(&r, &dtau),
        });
        let labels = [
            "wheel_friction.coulomb_pos_nm",
            "wheel_friction.coulomb_neg_nm",
            "wheel_friction.stribeck_nm (n_s = 1 rad/s)",
            "wheel_friction.viscous_nm_per_rad_s",
        ];
        for (j, label) in labels.iter().enumerate() {
            let x: Vec<f64> = rows
                .iter()
                .map(|row| friction_regressors(row, Some(1.0))[j])
                .collect();
            out.push(Correlation {
                residual: name.clone(),
                signal: (*label).into(),
                r: correlation(&r, &x),
            });
        }
    }
    // Innovations: against the rates and the heading.
    let inn = &s.recon.innovations;
    for c in 0..INNOVATION_LEN {
        let rows: Vec<_> = inn.iter().filter(|i| i.mask & (1 << c) != 0).collect();
        if rows.len() < 3 {
            continue;
        }
        let r: Vec<f64> = rows.iter().map(|i| i.values[c]).collect();
        let name = [
            "innovation_tilt_1",
            "innovation_tilt_2",
            "innovation_field_x",
            "innovation_field_y",
            "innovation_field_z",
        ][c];
        for axis in 0..3 {
            let x: Vec<f64> = rows.iter().map(|i| s.recon.rate[i.tick][axis]).collect();
            out.push(Correlation {
                residual: name.into(),
                signal: format!(
                    "rate_{} (gyro scale/misalignment)",
                    "xyz".as_bytes()[axis] as char
                ),
                r: correlation(&r, &x),
            });
        }
        let cos: Vec<f64> = rows
            .iter()
            .map(|i| attitude::heading(&s.recon.q[i.tick]).cos())
            .collect();
        let sin: Vec<f64> = rows
            .iter()
            .map(|i| attitude::heading(&s.recon.q[i.tick]).sin())
            .collect();
        out.push(Correlation {
            residual: name.into(),
            signal: "cos(heading) (earth rate, hard iron)".into(),
            r: correlation(&r, &cos),
        });
        out.push(Correlation {
            residual: name.into(),
            signal: "sin(heading) (earth rate, hard iron)".into(),
            r: correlation(&r, &sin),
        });
    }
    out.retain(|c| c.r.is_finite());
    out.sort_by(|a, b| b.r.abs().total_cmp(&a.r.abs()));
    out.truncate(8);
    out
}
