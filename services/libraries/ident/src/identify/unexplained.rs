//! The report of an **unexplained effect** (what no named cause explains), shared by the
//! equations' searches (`torque`, `innovation`, `wheel`; see `equations`), and its terms as a
//! model extension (`[effects.fitted_torque]`, `[effects.fitted_wheel_torque]`).

use super::rounding::round_to;
use crate::effects::Cause;
use crate::sparse::{Design, SparseOptions, SparseResult, Term, search};
use serde::Serialize;
use testbed_model::physics::fitted_torque::{FittedTorque, FittedTorqueTerm, TorqueFunction};
use testbed_model::physics::fitted_wheel_torque::{
    FittedWheelTorque, FittedWheelTorqueTerm, WheelFunction,
};

/// An effect in the residuals that no named cause explains.
#[derive(Debug, Clone, Serialize)]
pub struct UnexplainedEffect {
    /// The equation: `torque_x` … (Nm per unit of the function), `innovation_field_x` …
    /// (whitened innovation per unit).
    pub equation: String,
    /// Unit of the coefficients.
    pub unit: &'static str,
    /// The proposed term, e.g. `torque_y ≈ +3.1e-3 Nm × t·sin tilt_x − …`.
    pub proposed: String,
    /// The terms found (coefficient, cluster-robust standard error).
    pub terms: Vec<Term>,
    /// The named causes' own regressors in this equation, refitted with the terms.
    pub refitted_named: Vec<Term>,
    /// Evidence: |z| threshold (Bonferroni over the candidates), k-fold cross-validated RMS
    /// ratio and held-out RMS ratio of the equation without / with the terms.
    pub z_threshold: f64,
    pub cv_gain: f64,
    pub held_out_gain: f64,
    /// Rows and clusters (independent units) behind the evidence.
    pub rows: usize,
    pub clusters: usize,
    /// The analysis pass that found it: 1 on the data as measured, 2 after the magnetometer
    /// correction of the first pass's field effects (see `Report::sensor_correction`).
    pub pass: u8,
}

/// A named cause's competing explanation: `search` run on the other named causes (the caller
/// puts the cause's fitted part back and leaves out its own form). Its effects and
/// cross-validated residual sum; `None` when the channel is too short for one.
pub(super) fn competing(
    named: &[Cause],
    cause: Cause,
    search: impl FnOnce(&[Cause]) -> (Vec<UnexplainedEffect>, Option<f64>),
) -> Option<(Vec<UnexplainedEffect>, f64)> {
    let others: Vec<Cause> = named.iter().copied().filter(|c| *c != cause).collect();
    let (effects, cv) = search(&others);
    Some((effects, cv?))
}

/// Folds and clusters: interleaved blocks of `block_s` (block b in fold `b mod folds`).
pub(super) fn fold_of(t: f64, block_s: f64) -> usize {
    (t / block_s).floor().max(0.0) as usize
}

/// The sparse search of each equation `(name, noise variance, design)` of a channel in Nm: the
/// effects found, and the cross-validated residual sum over the equations, each whitened by its
/// noise (`None` without equations).
pub(super) fn search_equations(
    equations: impl IntoIterator<Item = (String, f64, Design)>,
    options: &SparseOptions,
) -> (Vec<UnexplainedEffect>, Option<f64>) {
    let mut cv_total = None;
    let mut out = Vec::new();
    for (equation, variance, design) in equations {
        let result = search(&design, options);
        *cv_total.get_or_insert(0.0) += result.cv_rss / variance;
        out.extend(effect(equation, "Nm", result, &design));
    }
    (out, cv_total)
}

/// The unexplained effect the sparse search `result` found in `equation` (`None`: no term).
pub(super) fn effect(
    equation: String,
    unit: &'static str,
    result: SparseResult,
    design: &Design,
) -> Option<UnexplainedEffect> {
    if result.terms.is_empty() {
        return None;
    }
    let mut proposed = format!("{equation} ≈");
    for (i, t) in result.terms.iter().enumerate() {
        let text = round_to(t.value.abs(), t.stderr);
        let sign = match (i, t.value < 0.0) {
            (0, false) => "",
            (0, true) => "−",
            (_, false) => "+ ",
            (_, true) => "− ",
        };
        proposed.push_str(&format!(" {sign}{text} {unit} × {}", t.name));
    }
    Some(UnexplainedEffect {
        equation,
        unit,
        proposed,
        terms: result.terms,
        refitted_named: result.forced,
        z_threshold: result.z_threshold,
        cv_gain: result.cv_gain,
        held_out_gain: result.held_out_gain,
        rows: design.rows(),
        clusters: design.clusters(),
        pass: 1,
    })
}

/// Which fit of a term's coefficient to use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Coefficients {
    /// Fitted on all the data (the extended model written).
    All,
    /// Fitted without the held-out blocks (their prediction).
    FitBlocks,
    /// Fitted without the search's fold f (that fold's prediction).
    WithoutFold(usize),
}

impl Coefficients {
    /// `term`'s coefficient of this kind (NaN for a fold it was not fitted without).
    fn of(self, term: &Term) -> f64 {
        match self {
            Self::All => term.value,
            Self::FitBlocks => term.value_fit_blocks,
            Self::WithoutFold(f) => term.value_without_fold.get(f).copied().unwrap_or(f64::NAN),
        }
    }
}

/// The torque-channel unexplained effects as a model extension, `[effects.fitted_torque]`:
/// each term's function in the plant's form (identification's `t`, 0…1 over the record of
/// `span_s` seconds, becomes `t_s` in seconds from its start, its coefficient divided by the
/// span), with the coefficients `which` says. The second value lists the terms a forward
/// simulation cannot carry (angular accelerations: an inertia change, `inertia_error`'s
/// domain), as `equation: function`.
pub(super) fn fitted_torque(
    effects: &[UnexplainedEffect],
    span_s: f64,
    which: Coefficients,
) -> (Option<FittedTorque>, Vec<String>) {
    let mut terms = Vec::new();
    let mut not_carried = Vec::new();
    for effect in effects {
        let Some(axis) = effect.equation.strip_prefix("torque_") else {
            continue;
        };
        for term in &effect.terms {
            let value = which.of(term);
            let (name, per_unit) = match term.name.strip_prefix('t') {
                Some(rest) if rest.is_empty() || rest.starts_with('·') => {
                    (format!("t_s{rest}"), 1.0 / span_s)
                }
                _ => (term.name.clone(), 1.0),
            };
            match TorqueFunction::from_name(&name) {
                Some(f) if value.is_finite() => terms.push(FittedTorqueTerm {
                    axis: axis.to_string(),
                    function: f.name().to_string(),
                    coefficient: value * per_unit,
                }),
                _ => not_carried.push(format!("{}: {}", effect.equation, term.name)),
            }
        }
    }
    let fitted = (!terms.is_empty()).then_some(FittedTorque {
        start_time_s: 0.0,
        terms,
    });
    (fitted, not_carried)
}

/// The wheel-channel unexplained effects as a model extension, `[effects.fitted_wheel_torque]`:
/// each term of equation `wheel_x|y|z` on that wheel, in the plant's form. Identification's `t`
/// (0…1 over the record of `span_s` seconds) becomes `t_s` in seconds from its start, its
/// coefficient divided by the span; its `τ` (the commanded torque, clamped, at the model's
/// delay) becomes the plant's delivered torque, which is that times the wheel's torque scale
/// (`scale`, 1 without `wheel_torque_scale`), so its coefficient is divided by the scale. The
/// coefficients are those `which` says. The second value lists terms the plant cannot apply
/// (none of the wheel candidates today), as `equation: function`.
pub(super) fn fitted_wheel_torque(
    effects: &[UnexplainedEffect],
    span_s: f64,
    scale: [f64; 3],
    which: Coefficients,
) -> (Option<FittedWheelTorque>, Vec<String>) {
    let mut terms = Vec::new();
    let mut not_carried = Vec::new();
    for effect in effects {
        let Some(wheel) = effect.equation.strip_prefix("wheel_") else {
            continue;
        };
        let Some(index) = testbed_model::physics::fitted_torque::axis_index(wheel) else {
            continue;
        };
        for term in &effect.terms {
            let value = which.of(term);
            let (name, divisor) = match term.name.as_str() {
                "t" => ("t_s", span_s),
                "τ" => ("τ", scale[index]),
                other => (other, 1.0),
            };
            let coefficient = value / divisor;
            match WheelFunction::from_name(name) {
                Some(f) if coefficient.is_finite() => terms.push(FittedWheelTorqueTerm {
                    wheel: wheel.to_string(),
                    function: f.name().to_string(),
                    coefficient,
                }),
                _ => not_carried.push(format!("{}: {}", effect.equation, term.name)),
            }
        }
    }
    let fitted = (!terms.is_empty()).then_some(FittedWheelTorque {
        start_time_s: 0.0,
        terms,
    });
    (fitted, not_carried)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn effect(equation: &str, terms: &[(&str, f64)]) -> UnexplainedEffect {
        UnexplainedEffect {
            equation: equation.into(),
            unit: "Nm",
            proposed: String::new(),
            terms: terms
                .iter()
                .map(|(name, value)| Term {
                    name: name.to_string(),
                    value: *value,
                    stderr: 0.1 * value.abs(),
                    value_fit_blocks: 0.5 * value,
                    value_without_fold: vec![0.25 * value],
                })
                .collect(),
            refitted_named: Vec::new(),
            z_threshold: 4.6,
            cv_gain: 2.0,
            held_out_gain: 2.0,
            rows: 100,
            clusters: 10,
            pass: 1,
        }
    }

    #[test]
    fn torque_terms_become_a_fitted_torque_with_time_in_seconds() {
        let effects = [
            effect(
                "torque_x",
                &[("t", 3e-3), ("t·sin tilt_x", -6e-4), ("dw_x/dt", 2.0)],
            ),
            effect("torque_z", &[("1", 1e-3), ("sin 2ψ", 8e-4)]),
            effect("innovation_field_x", &[("B_x", 0.3)]),
        ];
        let (fitted, not_carried) = fitted_torque(&effects, 600.0, Coefficients::All);
        let fitted = fitted.expect("torque terms carried");
        let got: Vec<(&str, &str, f64)> = fitted
            .terms
            .iter()
            .map(|t| (t.axis.as_str(), t.function.as_str(), t.coefficient))
            .collect();
        assert_eq!(
            got,
            [
                ("x", "t_s", 3e-3 / 600.0),
                ("x", "t_s·sin tilt_x", -6e-4 / 600.0),
                ("z", "1", 1e-3),
                ("z", "sin 2ψ", 8e-4),
            ]
        );
        assert_eq!(not_carried, ["torque_x: dw_x/dt"]);
        // The held-out prediction's values: fitted without the held-out blocks.
        let (held, _) = fitted_torque(&effects, 600.0, Coefficients::FitBlocks);
        assert_eq!(held.expect("carried").terms[2].coefficient, 0.5e-3);
        let (fold, _) = fitted_torque(&effects, 600.0, Coefficients::WithoutFold(0));
        assert_eq!(fold.expect("carried").terms[2].coefficient, 0.25e-3);
        // Sensor effects alone: nothing to carry into the plant.
        assert_eq!(
            fitted_torque(&effects[2..], 600.0, Coefficients::All),
            (None, Vec::new())
        );
    }

    #[test]
    fn wheel_terms_become_a_fitted_wheel_torque_in_the_plants_form() {
        let effects = [
            effect("wheel_y", &[("n·|n|", -1e-8), ("t", 6e-4), ("τ", 0.04)]),
            effect("wheel_x", &[("sin tilt_x", 1e-2)]),
            effect("torque_z", &[("1", 1e-3)]),
        ];
        let scale = [1.0, 0.8, 1.0];
        let (fitted, not_carried) = fitted_wheel_torque(&effects, 600.0, scale, Coefficients::All);
        let fitted = fitted.expect("wheel terms carried");
        let got: Vec<(&str, &str, f64)> = fitted
            .terms
            .iter()
            .map(|t| (t.wheel.as_str(), t.function.as_str(), t.coefficient))
            .collect();
        assert_eq!(
            got,
            [
                ("y", "n·|n|", -1e-8),
                ("y", "t_s", 6e-4 / 600.0),
                ("y", "τ", 0.04 / 0.8),
                ("x", "sin tilt_x", 1e-2),
            ]
        );
        assert!(not_carried.is_empty(), "{not_carried:?}");
        // Every term loads as the model's configuration.
        let mut config = testbed_model::ModelConfig::default();
        config.effects.fitted_wheel_torque = Some(fitted);
        config.validate().expect("valid fitted wheel torque");
        let (held, _) = fitted_wheel_torque(&effects, 600.0, scale, Coefficients::FitBlocks);
        assert_eq!(held.expect("carried").terms[3].coefficient, 0.5e-2);
        let (fold, _) = fitted_wheel_torque(&effects, 600.0, scale, Coefficients::WithoutFold(0));
        assert_eq!(fold.expect("carried").terms[0].coefficient, -0.25e-8);
        // Torque effects alone: nothing for the wheels.
        assert_eq!(
            fitted_wheel_torque(&effects[2..], 600.0, scale, Coefficients::All),
            (None, Vec::new())
        );
    }
}
