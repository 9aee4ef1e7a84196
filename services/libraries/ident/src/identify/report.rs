//! The report of `identify` (residuals, selection steps, causes, what remains, gain) and the
//! curves the figures draw.

use super::Options;
use super::rounding::with_error;
use crate::data::Aligned;
use crate::predict::{self, COMPONENTS, ComponentRms, Predictions};
use crate::stats::SeriesStats;
use serde::Serialize;
use std::collections::BTreeMap;
use testbed_model::ModelConfig;

/// Summary of the data analysed.
#[derive(Debug, Clone, Serialize)]
pub struct DataSummary {
    pub source: String,
    pub duration_s: f64,
    pub gyro_rows: usize,
    pub period_s: f64,
    pub devices: Vec<&'static str>,
    /// Fraction of the ticks held out of the fits; with k-fold cross-validation, of the ticks
    /// predicted out of fold (the fits use all the data).
    pub held_out_fraction: f64,
    /// Readings left out as isolated spikes (see [`crate::spikes`]), in file and time order.
    pub spikes: Vec<crate::spikes::Spike>,
    /// The gyro's and the wheels' silences longer than a break ([`crate::data::BREAK_S`]), in
    /// time order.
    pub silences: Vec<crate::data::Silence>,
}

/// Statistics of one residual component.
#[derive(Debug, Clone, Serialize)]
pub struct ComponentReport {
    pub name: String,
    pub unit: &'static str,
    /// RMS divided by the noise the model expects (1 = as noisy as the sensors).
    pub normalised_rms: f64,
    #[serde(flatten)]
    pub stats: SeriesStats,
}

/// Residual report of one model.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualReport {
    /// Multi-step prediction residuals (measured − predicted) over the whole record.
    pub prediction: Vec<ComponentReport>,
    /// Equation-error residuals: platform momentum (the integral of the torque residual over each
    /// segment, Nms), wheel torque (Nm), filter innovations (whitened).
    pub equation_error: Vec<ComponentReport>,
    /// Whitened RMS of each equation-error channel (1 = noise as modelled), fit / held out.
    pub channel_rms_fit: BTreeMap<&'static str, f64>,
    pub channel_rms_held_out: BTreeMap<&'static str, f64>,
}

/// One candidate's evaluation in a selection step.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateRow {
    pub name: &'static str,
    /// Parameters estimated.
    pub k: usize,
    /// Likelihood ratio on the fit data, `Σ n ln(RSS/RSS')`.
    pub lr_fit: f64,
    /// Threshold it must beat: max(k ln N, χ²_k(1 − alpha)).
    pub threshold: f64,
    /// BIC change (negative: better).
    pub delta_bic: f64,
    /// Likelihood ratio on the held-out data (positive: predicts them better); with k-fold
    /// cross-validation the sum over the folds of the left-out fold's ratio, NaN when not
    /// computed (not significant at 1 %).
    pub lr_held_out: f64,
    pub significant: bool,
    pub chosen: bool,
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// One named cause.
#[derive(Debug, Clone, Serialize)]
pub struct CauseReport {
    pub name: &'static str,
    pub description: &'static str,
    /// Fitted values under the configuration's keys (the `[effects.<name>]` table).
    pub parameters: serde_json::Map<String, serde_json::Value>,
    /// Standard errors, same keys (`null`: not estimated).
    pub stderr: serde_json::Map<String, serde_json::Value>,
    pub units: serde_json::Map<String, serde_json::Value>,
    pub lr_fit: f64,
    pub delta_bic: f64,
    pub lr_held_out: f64,
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// A residual's correlation with a signal a candidate effect would produce.
#[derive(Debug, Clone, Serialize)]
pub struct Correlation {
    pub residual: String,
    pub signal: String,
    pub r: f64,
}

/// What is left after the chosen causes.
#[derive(Debug, Clone, Serialize)]
pub struct Remaining {
    pub residual_remains: bool,
    pub message: String,
    /// Whitened RMS per equation-error channel on the held-out data.
    pub channel_rms: BTreeMap<&'static str, f64>,
    /// Strongest correlations of the remaining residuals (when residual remains).
    pub correlations: Vec<Correlation>,
}

/// Prediction error of one model on the held-out data.
#[derive(Debug, Clone, Serialize)]
pub struct RmsReport {
    /// Root mean square of the components' normalised RMS (1 = sensor noise).
    pub overall: f64,
    /// Per component: RMS (its unit), normalised RMS, samples.
    pub components: BTreeMap<&'static str, ComponentRms>,
    /// Per channel group (rates, tilt, field, wheel speeds): normalised.
    pub groups: BTreeMap<&'static str, f64>,
}

/// The report of `identify`.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The verdict in a few sentences, first: causes with their parameters rounded to their
    /// uncertainty, unexplained effects with their form and gain, what remains.
    pub summary: Vec<String>,
    pub data: DataSummary,
    pub options: Options,
    /// Item 1: the nominal model's residuals.
    pub nominal_residuals: ResidualReport,
    /// Forward selection, one entry per step.
    pub steps: Vec<Vec<CandidateRow>>,
    /// Borderline causes of the last selection step: below the threshold, but significant at
    /// the 1 % level (`LR > χ²_k(0.99)`) and improving the held-out data. Listed, not named.
    pub possible: Vec<CandidateRow>,
    /// Causes above the threshold at every selection step but never chosen, because their
    /// held-out (cross-validated) likelihood ratio never rose above zero: their last step's
    /// rows. Said, not silently dropped (on a short record the out-of-sample check is weak).
    pub unconfirmed: Vec<CandidateRow>,
    /// Named causes, strongest first (empty: none).
    pub causes: Vec<CauseReport>,
    /// Causes the selection chose whose extended model predicted the held-out data worse than
    /// the configuration given, by more than 1 % (`gain` below 1/1.01): refuted by the data,
    /// not named. They stood in for an effect outside the library; the extended model is then
    /// the configuration given (empty: none).
    pub refuted: Vec<CauseReport>,
    /// `none`, or the causes joined by ` + `.
    pub verdict: String,
    /// The falsification tests of every cause the selection named (dropped ones included).
    pub cause_tests: Vec<super::CauseTest>,
    /// Named causes that explain only part of an equation of their channel: the unrestricted
    /// candidate search does better there, and the remainder is among `unexplained` (see
    /// `guard`).
    pub partly_explained: Vec<super::PartlyExplained>,
    /// Effects no named cause explains, with their proposed form (empty: none found).
    pub unexplained: Vec<super::UnexplainedEffect>,
    /// What the extended model carries beyond the named causes.
    pub extension: ModelExtension,
    pub remaining: Remaining,
    /// The extended model's residuals.
    pub extended_residuals: ResidualReport,
    pub baseline_rms: RmsReport,
    pub extended_rms: RmsReport,
    /// `baseline_rms.overall / extended_rms.overall`.
    pub gain: f64,
    pub gain_by_component: BTreeMap<&'static str, f64>,
    pub gain_by_group: BTreeMap<&'static str, f64>,
    /// The magnetometer correction of the second pass: present when the first pass found an
    /// unexplained effect in the field innovations that the magnetometer's model can take; the
    /// readings were then corrected with it and everything above (except the nominal
    /// residuals and the effects marked `pass: 1`) is the analysis of the corrected estimate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_correction: Option<super::SensorCorrection>,
    /// Whiteness of the torque channel's residual under the extended model per axis, and the
    /// coloured disturbances it finds (see `colour`).
    pub whiteness: super::WhitenessReport,
    /// Residual series whose level changed within the record (see `change`).
    pub changes: super::ChangeReport,
    /// Filter runs the analysis took (both passes).
    pub filter_runs: usize,
    /// Causes left out of the library because the selection chose them and the falsification
    /// tests then dropped them as standing in for an effect of another form: the analysis
    /// above ran again without them and predicts the held-out data better (empty: no rerun, or
    /// the rerun did not predict better).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub stand_ins_left_out: Vec<&'static str>,
}

/// A labelled time series for figures.
#[derive(Debug, Clone)]
pub struct Curve {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// What the figures need.
#[derive(Debug, Clone, Default)]
pub struct FigureData {
    /// Nominal model, whole record: prediction residuals per component.
    pub nominal_prediction: Vec<Curve>,
    /// Equation-error residuals, nominal and extended: torque (Nm), wheel (Nm), innovations.
    pub nominal_equation: Vec<Curve>,
    pub extended_equation: Vec<Curve>,
    /// Held-out windows: normalised RMS per window and group, nominal and extended.
    pub held_out_nominal: Vec<Curve>,
    pub held_out_extended: Vec<Curve>,
}

/// The result of `identify`.
#[derive(Debug, Clone)]
pub struct Identification {
    pub report: Report,
    /// The extended model (the configuration given plus the named effects).
    pub extended: ModelConfig,
    pub figures: FigureData,
}

/// What the extended model carries beyond the named causes.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ModelExtension {
    /// The unexplained torque terms as a fitted torque (`[effects.fitted_torque]`).
    pub fitted_torque: Option<testbed_model::physics::fitted_torque::FittedTorque>,
    /// The unexplained wheel-channel terms as a fitted wheel torque
    /// (`[effects.fitted_wheel_torque]`).
    pub fitted_wheel_torque: Option<testbed_model::physics::fitted_wheel_torque::FittedWheelTorque>,
    /// Terms found but not carried (`equation: function`).
    pub not_carried: Vec<String>,
    /// Whether the held-out gain's predictions include the fitted torques (`fitted_torque` and
    /// `fitted_wheel_torque`, whichever are carried).
    pub gain_includes_fitted_torque: bool,
    /// Held-out prediction gain of the named causes alone (without the fitted torques), to set
    /// against the extended model's.
    pub gain_without_fitted_torque: Option<f64>,
    /// Why the unexplained torque and wheel terms were not carried (together they did not
    /// improve the held-out prediction).
    pub rejected: Option<String>,
}

/// The verdict in sentences (see [`Report::summary`]).
// One argument per part of the report the summary speaks of.
#[allow(clippy::too_many_arguments)]
pub(super) fn summary(
    causes: &[CauseReport],
    tests: &[super::CauseTest],
    possible: &[CandidateRow],
    unconfirmed: &[CandidateRow],
    refuted: &[CauseReport],
    effects: &[super::UnexplainedEffect],
    remaining: &Remaining,
    gain: f64,
    extension: &ModelExtension,
    correction: Option<&super::SensorCorrection>,
) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(c) = correction {
        let terms: Vec<String> = c
            .fitted_field
            .terms
            .iter()
            .map(|t| format!("{} {:+.3e} T × {}", t.axis, t.coefficient, t.function))
            .collect();
        out.push(format!(
            "Second pass: the first pass found an unexplained effect in {} (a magnetometer error the filter took as attitude); the readings were corrected with it as [effects.fitted_field] ({}; field residual RMS {:.1} nT before, {:.1} nT after, {} filter runs) and the estimate and the analysis redone. First pass, uncorrected: {} (held-out gain {:.2}×).",
            c.equations.join(", "),
            terms.join(", "),
            c.residual_rms_before_t * 1e9,
            c.residual_rms_after_t * 1e9,
            c.iterations,
            c.first_pass_verdict,
            c.first_pass_gain
        ));
    }
    if causes.is_empty() {
        out.push("Named cause: none.".to_string());
    }
    for c in causes {
        let mut parts = Vec::new();
        for (key, value) in &c.parameters {
            let se = c.stderr.get(key);
            let unit = c.units.get(key).and_then(|u| u.as_str()).unwrap_or("");
            let text = match (value, se) {
                (serde_json::Value::Array(v), Some(serde_json::Value::Array(e))) => format!(
                    "[{}]",
                    v.iter()
                        .zip(e)
                        .map(|(v, e)| with_error(
                            v.as_f64().unwrap_or(f64::NAN),
                            e.as_f64().unwrap_or(f64::NAN)
                        ))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                (v, e) => with_error(
                    v.as_f64().unwrap_or(f64::NAN),
                    e.and_then(|e| e.as_f64()).unwrap_or(f64::NAN),
                ),
            };
            parts.push(format!("{key} = {text} {unit}"));
        }
        // The residual test of the cause's own channel: structure left there is said here.
        let channel = match crate::effects::Cause::from_name(c.name).map(|c| c.kind()) {
            Some(crate::effects::Kind::Torque) => Some("torque_"),
            Some(crate::effects::Kind::Sensor) => Some("innovation_"),
            _ => None,
        };
        let left: Vec<&str> = effects
            .iter()
            .filter(|e| channel.is_some_and(|p| e.equation.starts_with(p)))
            .map(|e| e.equation.as_str())
            .collect();
        let residual_test = if left.is_empty() {
            String::new()
        } else {
            format!(
                " (its channel's residuals fail the structure test in {}: an unexplained effect, fitted beside it)",
                left.join(", ")
            )
        };
        out.push(format!(
            "Named cause: {} ({}): {}{residual_test}.",
            c.name,
            c.description,
            parts.join("; ")
        ));
    }
    if !causes.is_empty()
        || extension.fitted_torque.is_some()
        || extension.fitted_wheel_torque.is_some()
        || correction.is_some()
    {
        out.push(format!(
            "Held-out prediction gain of the extended model: {gain:.2}× (nominal RMS / extended RMS)."
        ));
    }
    if !refuted.is_empty() {
        let names: Vec<&str> = refuted.iter().map(|c| c.name).collect();
        out.push(format!(
            "Refuted: {} — chosen by the selection, but the model extended with {} predicts the held-out data worse than the configuration given ({gain:.2}× nominal RMS / extended RMS): {} in for an effect outside the library ({}), and the extended model is the configuration given.",
            names.join(" + "),
            if names.len() == 1 { "it" } else { "them" },
            if names.len() == 1 { "it stands" } else { "they stand" },
            if effects.is_empty() {
                "too weak for its form to be found"
            } else {
                "see the unexplained effects"
            },
        ));
    }
    for t in tests.iter().filter(|t| !t.kept) {
        out.push(format!("Not named: {} — {}.", t.name, t.verdict));
    }
    for p in possible {
        out.push(format!(
            "Possible (below the threshold, not named): {} — likelihood ratio {:.1} against the threshold {:.1}, held-out {:+.1}.",
            p.name, p.lr_fit, p.threshold, p.lr_held_out
        ));
    }
    for u in unconfirmed {
        out.push(format!(
            "Not chosen: {} — above the threshold at every selection step (likelihood ratio {:.1} against {:.1} at the last) but not confirmed out of sample (held-out {:+.1}); a longer record, or one that excites it more, would decide.",
            u.name, u.lr_fit, u.threshold, u.lr_held_out
        ));
    }
    if effects.is_empty() {
        out.push("Unexplained effect: none found (no candidate function carries a significant part of the remaining residuals).".to_string());
    }
    for e in effects {
        let pass = if e.pass == 1 && correction.is_some() {
            "; first pass, carried as the magnetometer correction"
        } else {
            ""
        };
        out.push(format!(
            "Unexplained effect (not a library cause{pass}): {}; held-out gain {:.2}×, cross-validated {:.2}× in that equation.",
            e.proposed, e.held_out_gain, e.cv_gain
        ));
    }
    if let Some(f) = &extension.fitted_torque {
        out.push(format!(
            "Model extension: the unexplained torque terms are in the extended model as [effects.fitted_torque] ({} terms), so the plant reproduces them; {}.",
            f.terms.len(),
            match (extension.gain_includes_fitted_torque, extension.gain_without_fitted_torque) {
                (true, Some(without)) => format!("the gain above includes them (without them: {without:.2}×)"),
                _ => "the cross-validated gain above leaves them out (the search's folds differ from --folds)".to_string(),
            }
        ));
    }
    if let Some(f) = &extension.fitted_wheel_torque {
        let terms: Vec<String> = f
            .terms
            .iter()
            .map(|t| {
                format!(
                    "wheel {} {:+.3e} Nm × {}",
                    t.wheel, t.coefficient, t.function
                )
            })
            .collect();
        out.push(format!(
            "Model extension: the unexplained wheel terms are in the extended model as [effects.fitted_wheel_torque] ({}), so the plant's wheels reproduce them; {}.",
            terms.join(", "),
            match (extension.gain_includes_fitted_torque, extension.gain_without_fitted_torque) {
                (true, Some(without)) => format!("the gain above includes them (without them: {without:.2}×)"),
                _ => "the cross-validated gain above leaves them out (the search's folds differ from --folds)".to_string(),
            }
        ));
    }
    if let Some(why) = &extension.rejected {
        out.push(format!("Model extension: {why}."));
    }
    if !extension.not_carried.is_empty() {
        out.push(format!(
            "Not carried into the model (a forward simulation cannot apply them as a torque): {}.",
            extension.not_carried.join(", ")
        ));
    }
    if let Some(c) = correction.filter(|c| !c.not_carried.is_empty()) {
        out.push(format!(
            "Not carried into the magnetometer correction (not a function of the attitude): {}.",
            c.not_carried.join(", ")
        ));
    }
    out.push(remaining.message.clone());
    out
}

pub(super) fn rms_report(rms: &[Option<ComponentRms>; 11]) -> RmsReport {
    let mut components = BTreeMap::new();
    let mut groups: BTreeMap<&'static str, (f64, usize)> = BTreeMap::new();
    for (c, r) in rms.iter().enumerate() {
        if let Some(r) = r {
            components.insert(COMPONENTS[c], *r);
            let g = groups.entry(predict::group(c)).or_insert((0.0, 0));
            g.0 += r.normalised * r.normalised;
            g.1 += 1;
        }
    }
    RmsReport {
        overall: Predictions::overall(rms),
        components,
        groups: groups
            .into_iter()
            .map(|(g, (s, n))| (g, (s / n as f64).sqrt()))
            .collect(),
    }
}

pub(super) fn prediction_curves(p: &Predictions) -> Vec<Curve> {
    (0..COMPONENTS.len())
        .filter(|&c| !p.residuals[c].is_empty())
        .map(|c| Curve {
            label: COMPONENTS[c].to_string(),
            points: p.residuals[c].iter().map(|(t, r, _)| (*t, *r)).collect(),
        })
        .collect()
}

pub(super) fn window_curves(p: &Predictions, data: &Aligned) -> Vec<Curve> {
    let per = p.per_window(data);
    let mut groups: BTreeMap<&'static str, BTreeMap<u64, (f64, f64, usize)>> = BTreeMap::new();
    for (c, series) in per.iter().enumerate() {
        for &(t, v) in series {
            let e = groups
                .entry(predict::group(c))
                .or_default()
                .entry(t.to_bits())
                .or_insert((t, 0.0, 0));
            e.1 += v * v;
            e.2 += 1;
        }
    }
    groups
        .into_iter()
        .map(|(g, m)| {
            let mut points: Vec<(f64, f64)> = m
                .into_values()
                .map(|(t, s, n)| (t, (s / n as f64).sqrt()))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            Curve {
                label: g.to_string(),
                points,
            }
        })
        .collect()
}

/// The causes above the threshold at every step of `steps` and never chosen (their held-out
/// likelihood ratio never rose above zero, or could not be computed): their rows of the last
/// step.
pub(super) fn unconfirmed(steps: &[Vec<CandidateRow>]) -> Vec<CandidateRow> {
    let Some(last) = steps.last() else {
        return Vec::new();
    };
    last.iter()
        .filter(|r| {
            !r.chosen
                && (r.lr_held_out.is_nan() || r.lr_held_out <= 0.0)
                && steps.iter().all(|step| {
                    step.iter()
                        .any(|x| x.name == r.name && x.significant && !x.chosen)
                })
        })
        .cloned()
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(name: &'static str, significant: bool, chosen: bool, lr_held_out: f64) -> CandidateRow {
        CandidateRow {
            name,
            k: 3,
            lr_fit: if significant { 40.0 } else { 5.0 },
            threshold: 20.0,
            delta_bic: 0.0,
            lr_held_out,
            significant,
            chosen,
            note: String::new(),
        }
    }

    /// Two steps: `com_offset` chosen in the first; `gyro_scale` above the threshold in both
    /// but never better out of sample; `aero_drag` above it only in the second; `inertia_error`
    /// never. Only `gyro_scale` is unconfirmed.
    #[test]
    fn a_cause_significant_at_every_step_and_never_chosen_is_unconfirmed() {
        let steps = vec![
            vec![
                row("com_offset", true, true, 30.0),
                row("gyro_scale", true, false, -2.0),
                row("aero_drag", false, false, -1.0),
                row("inertia_error", false, false, 1.0),
            ],
            vec![
                row("gyro_scale", true, false, -1.5),
                row("aero_drag", true, false, -0.5),
                row("inertia_error", false, false, 1.0),
            ],
        ];
        let names: Vec<&str> = unconfirmed(&steps).iter().map(|r| r.name).collect();
        assert_eq!(names, ["gyro_scale"]);
        assert!(unconfirmed(&[]).is_empty());
    }
}
