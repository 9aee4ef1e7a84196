//! The magnetometer correction of the second pass: an unexplained effect in the field
//! innovations (a soft-iron matrix, a heading-dependent error) is a sensor-side effect; the
//! filter that estimates the attitude takes the readings as they are, so its attitude, and the
//! torque channel built on it, carry the error. The functions the sparse search found in the
//! field innovations (those of the attitude, [`FieldFunction`]) are fitted to the field
//! residual in tesla, as an additive error of the reading per body axis, `ΔM = Σ c_j f_j(q)`;
//! the readings are corrected with it (`[effects.fitted_field]`, which the filter subtracts) and
//! the analysis runs again on the corrected estimate.
//!
//! The fit: every found function on every axis of the reading (the innovations are whitened
//! with the Cholesky factor of their covariance, which mixes the axes, so the form found in one
//! whitened component need not be confined to one axis of the reading), plus a constant that
//! is carried only if the search found one (otherwise it stands for a library cause, the hard
//! iron, which the second pass names). The filter's attitude takes up part of a sensor error
//! (its heading follows a distorted field), so the fit is repeated on the filter run with the
//! correction so far, and the corrections added, until the update is below a hundredth of the
//! correction (at most [`MAX_ITERATIONS`] filter runs). Fitted on the ticks not held out (with
//! k-fold cross-validation: all of them).

use super::unexplained::UnexplainedEffect;
use crate::error::IdentError;
use crate::fit::Problem;
use crate::reconstruct::{Reconstruction, reconstruct};
use nalgebra::DMatrix;
use serde::Serialize;
use testbed_model::ModelConfig;
use testbed_model::config::{FittedField, FittedFieldTerm};
use testbed_model::devices::fitted_field::FieldFunction;

/// Most filter runs of the correction's fit.
pub const MAX_ITERATIONS: usize = 5;

/// Relative size of the last update at which the fit stops.
const CONVERGED: f64 = 0.01;

/// The equations the correction comes from.
const FIELD_PREFIX: &str = "innovation_field_";

/// The magnetometer correction found in the first pass and carried into the second.
#[derive(Debug, Clone, Serialize)]
pub struct SensorCorrection {
    /// The field-innovation equations whose unexplained effects it comes from.
    pub equations: Vec<String>,
    /// The correction, `[effects.fitted_field]` (tesla per unit of each function).
    pub fitted_field: FittedField,
    /// Terms found but not carried (`equation: function`): functions of time, rates or wheel
    /// speeds, which the magnetometer's model does not take.
    pub not_carried: Vec<String>,
    /// Filter runs of the fit (each a refit on the run with the correction so far).
    pub iterations: usize,
    /// RMS of the field residual (reading minus the reading predicted from the filter's prior
    /// attitude, all axes) on the fit ticks, before and after the correction, tesla.
    pub residual_rms_before_t: f64,
    pub residual_rms_after_t: f64,
    /// The first pass's verdict (its named causes, on the uncorrected estimate).
    pub first_pass_verdict: String,
    /// The first pass's held-out prediction gain.
    pub first_pass_gain: f64,
}

/// The functions of the field-innovation effects in `effects` that the correction can carry,
/// and the terms it cannot (`equation: function`).
pub(super) fn field_functions(effects: &[UnexplainedEffect]) -> (Vec<FieldFunction>, Vec<String>) {
    let mut functions = Vec::new();
    let mut not_carried = Vec::new();
    for e in effects
        .iter()
        .filter(|e| e.equation.starts_with(FIELD_PREFIX))
    {
        for t in &e.terms {
            match FieldFunction::from_name(&t.name) {
                Some(f) => {
                    if !functions.contains(&f) {
                        functions.push(f);
                    }
                }
                None => not_carried.push(format!("{}: {}", e.equation, t.name)),
            }
        }
    }
    (functions, not_carried)
}

/// The equations of `effects` the correction comes from.
pub(super) fn field_equations(effects: &[UnexplainedEffect]) -> Vec<String> {
    effects
        .iter()
        .filter(|e| e.equation.starts_with(FIELD_PREFIX))
        .map(|e| e.equation.clone())
        .collect()
}

/// The fitted correction and its fit's record (see the module documentation); `None` when the
/// effects hold no function the correction can carry or the data do not determine it.
pub(super) struct FieldFit {
    pub fitted_field: FittedField,
    pub not_carried: Vec<String>,
    pub iterations: usize,
    pub rms_before_t: f64,
    pub rms_after_t: f64,
}

/// Fit the correction to the data of `problem`, its filter runs on `base` plus the correction.
pub(super) fn fit_field_correction(
    problem: &Problem,
    base: &ModelConfig,
    effects: &[UnexplainedEffect],
) -> Result<Option<FieldFit>, IdentError> {
    let (functions, not_carried) = field_functions(effects);
    if functions.is_empty() {
        return Ok(None);
    }
    // A constant is always fitted (it would otherwise load the other functions with a hard
    // iron), carried only when found.
    let constant_found = functions.contains(&FieldFunction::One);
    let mut columns = functions.clone();
    if !constant_found {
        columns.push(FieldFunction::One);
    }
    let field_l = base.platform.field_l_t();
    let field_unit_l = field_l / field_l.norm().max(1e-300);
    let mut coefficients = DMatrix::<f64>::zeros(columns.len(), 3);
    let mut iterations = 0;
    let mut rms_before_t = f64::NAN;
    let mut rms_after_t = f64::NAN;
    let config_with = |c: &DMatrix<f64>| {
        let mut config = base.clone();
        config.effects.fitted_field = Some(to_config(&columns, c, constant_found));
        config
    };
    for _ in 0..MAX_ITERATIONS {
        let config = config_with(&coefficients);
        problem.filter_runs.set(problem.filter_runs.get() + 1);
        let recon = reconstruct(problem.data, &config)?;
        iterations += 1;
        let Some((x, y)) = design(problem, &recon, &columns, &field_unit_l) else {
            return Ok(None);
        };
        let rms = (y.norm_squared() / (y.len().max(1) as f64)).sqrt();
        if iterations == 1 {
            rms_before_t = rms;
        }
        rms_after_t = rms;
        if iterations == MAX_ITERATIONS {
            break;
        }
        let Ok(update) = x.clone().svd(true, true).solve(&y, 1e-12) else {
            return Ok(None);
        };
        if !update.iter().all(|v| v.is_finite()) {
            return Ok(None);
        }
        // The carried functions accumulate; the nuisance constant (never subtracted from the
        // readings) is refitted each time.
        let carried = functions.len();
        coefficients += &update;
        if !constant_found {
            coefficients.row_mut(carried).copy_from(&update.row(carried));
        }
        let size = coefficients.rows(0, carried).amax();
        if update.rows(0, carried).amax() <= CONVERGED * size {
            // The last update is in; its residual is one filter run away.
            let config = config_with(&coefficients);
            problem.filter_runs.set(problem.filter_runs.get() + 1);
            let recon = reconstruct(problem.data, &config)?;
            iterations += 1;
            if let Some((_, y)) = design(problem, &recon, &columns, &field_unit_l) {
                rms_after_t = (y.norm_squared() / (y.len().max(1) as f64)).sqrt();
            }
            break;
        }
    }
    let fitted_field = to_config(&columns, &coefficients, constant_found);
    if fitted_field.terms.is_empty() {
        return Ok(None);
    }
    Ok(Some(FieldFit {
        fitted_field,
        not_carried,
        iterations,
        rms_before_t,
        rms_after_t,
    }))
}

/// The least-squares problem of one iteration: per field update on a fit tick (all three axes
/// present), the functions at the filter's attitude of that tick, and the raw residual, tesla
/// (`rows × 3`). `None` with fewer rows than 10 per function.
fn design(
    problem: &Problem,
    recon: &Reconstruction,
    columns: &[FieldFunction],
    field_unit_l: &nalgebra::Vector3<f64>,
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let rows: Vec<_> = recon
        .innovations
        .iter()
        .filter(|i| {
            i.mask & 0b11100 == 0b11100
                && i.tick >= recon.start
                && !problem.held_out.get(i.tick).copied().unwrap_or(true)
        })
        .collect();
    if rows.len() < 10 * columns.len() {
        return None;
    }
    let x = DMatrix::from_fn(rows.len(), columns.len(), |r, j| {
        columns[j].value(&recon.q[rows[r].tick], field_unit_l)
    });
    let y = DMatrix::from_fn(rows.len(), 3, |r, a| rows[r].field_residual_t[a]);
    Some((x, y))
}

/// The coefficients (`functions × axes`, tesla per unit) as `[effects.fitted_field]`; the
/// constant only if `constant_found`.
fn to_config(columns: &[FieldFunction], c: &DMatrix<f64>, constant_found: bool) -> FittedField {
    let mut terms = Vec::new();
    for (j, f) in columns.iter().enumerate() {
        if *f == FieldFunction::One && !constant_found {
            continue;
        }
        for (a, axis) in ["x", "y", "z"].iter().enumerate() {
            let value = c[(j, a)];
            if value != 0.0 && value.is_finite() {
                terms.push(FittedFieldTerm {
                    axis: axis.to_string(),
                    function: f.name().to_string(),
                    coefficient: value,
                });
            }
        }
    }
    FittedField { terms }
}
