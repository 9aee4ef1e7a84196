//! The magnetometer correction of the second pass: an unexplained effect in the field
//! innovations (a soft-iron matrix, a heading-dependent error) is a sensor-side effect; the
//! filter that estimates the attitude takes the readings as they are, so its attitude, and the
//! torque channel built on it, carry the error. The functions the sparse search found in the
//! field innovations (those of the attitude, [`FieldFunction`]) are fitted to the field
//! residual in tesla, as an additive error of the reading per body axis, `ΔM = Σ c_j f_j(q)`;
//! the readings are corrected with it (`[effects.fitted_field]`, which the filter subtracts) and
//! the analysis runs again on the corrected estimate.
//!
//! The form: every found function on every axis of the reading (the innovations are whitened
//! with the Cholesky factor of their covariance, which mixes the axes, so a form found in one
//! whitened component need not be confined to one axis of the reading), completed by the
//! magnetometer's own error model, a linear map of the horizontal field (`B_x`, `B_y`), and a
//! constant (see [`fit_field_correction`]).
//!
//! The fit: the coefficients, tesla per unit, minimise the whitened innovations of the filter
//! run on the corrected readings (the fit's ticks: those not held out; with k-fold
//! cross-validation all of them), as a library sensor cause is fitted: the filter's attitude
//! takes up part of a sensor error (its heading follows a distorted field), so the innovations
//! are differentiated through the filter (forward differences, one filter run per coefficient)
//! and Gauss-Newton steps taken (one filter run each, at most [`MAX_ITERATIONS`] per Jacobian
//! and [`MAX_JACOBIANS`] Jacobians, until the sum of squares drops by less than 1 %). Directions the data cannot tell apart (singular
//! values of the Jacobian below 1e-4 of the largest) are left out of the steps, so the
//! coefficients are the smallest that fit.

use super::unexplained::UnexplainedEffect;
use crate::error::IdentError;
use crate::fit::Problem;
use crate::reconstruct::{Reconstruction, reconstruct};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use testbed_model::ModelConfig;
use testbed_model::devices::fitted_field::{FieldFunction, FittedField, FittedFieldTerm};

/// Most Gauss-Newton steps of the correction's fit per Jacobian (each one filter run; the
/// filter's innovations are close to linear in an additive reading error, so a Jacobian serves
/// several steps).
pub const MAX_ITERATIONS: usize = 4;

/// Most Jacobians of the correction's fit (the second only when the first's steps have not
/// converged: a large error, which the filter's attitude follows nonlinearly).
pub const MAX_JACOBIANS: usize = 2;

/// Relative drop of the innovations' sum of squares below which the fit stops.
const CONVERGED: f64 = 0.01;

/// Finite-difference step of a coefficient, tesla (about a tenth of the magnetometer's noise).
const STEP_T: f64 = 1e-8;

/// Singular values of the Jacobian below this fraction of the largest are left out of the
/// steps (functions the data cannot tell apart get the smallest coefficients that fit).
const RCOND: f64 = 1e-4;

/// Innovation mask bits of the three field components.
const FIELD_MASK: u8 = 0b11100;

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
    // The magnetometer's own error model, a linear map of the field (soft iron, scale factors,
    // misalignment), is always fitted beside the found functions (the search finds the
    // strongest terms of each whitened component, not necessarily all of a map's): its columns
    // on the horizontal field, `B_x` and `B_y`. The column on the vertical field, `B_z`, is
    // within a fraction of a percent of a constant on a platform that tilts by a few degrees:
    // only when found. A constant is always fitted and carried: on the headings an experiment
    // covers (±60° by default) the linear map's mean over them cannot be told from a constant,
    // and a constant left out would come back as a hard iron named for it in the second pass.
    let mut columns = functions.clone();
    for f in [
        FieldFunction::FieldX,
        FieldFunction::FieldY,
        FieldFunction::One,
    ] {
        if !columns.contains(&f) {
            columns.push(f);
        }
    }
    let n = columns.len() * 3;
    let config_with = |theta: &DVector<f64>| {
        let mut config = base.clone();
        let c = DMatrix::from_column_slice(columns.len(), 3, theta.as_slice());
        let fitted = to_config(&columns, &c);
        match config.effects.fitted_field.as_mut() {
            Some(old) => old.terms.extend(fitted.terms),
            None => config.effects.fitted_field = Some(fitted),
        }
        config
    };
    let keep = |tick: usize| !problem.held_out.get(tick).copied().unwrap_or(true);
    let run = |theta: &DVector<f64>| -> Result<Reconstruction, IdentError> {
        problem.count_filter_runs(1);
        reconstruct(problem.data, &config_with(theta))
    };
    let field_rms = |recon: &Reconstruction| {
        let (mut sum, mut count) = (0.0, 0usize);
        for i in recon.innovations.iter().filter(|i| {
            i.mask & FIELD_MASK == FIELD_MASK && i.tick >= recon.start() && keep(i.tick)
        }) {
            sum += i.field_residual_t.norm_squared();
            count += 3;
        }
        (sum / count.max(1) as f64).sqrt()
    };
    let mut theta = DVector::<f64>::zeros(n);
    let recon0 = run(&theta)?;
    let r0 = DVector::from_vec(recon0.innovation_vector(keep));
    if r0.len() < 10 * n {
        return Ok(None);
    }
    let mut iterations = 1;
    let (mut r, mut rss) = (r0.clone(), r0.norm_squared());
    let mut recon = recon0.clone();
    'jacobians: for _ in 0..MAX_JACOBIANS {
        // The Jacobian of the whitened innovations of the fit ticks at `theta`, by forward
        // differences.
        let steps: Vec<ModelConfig> = (0..n)
            .map(|j| {
                let mut step = theta.clone();
                step[j] += STEP_T;
                config_with(&step)
            })
            .collect();
        let mut jacobian = DMatrix::<f64>::zeros(r0.len(), n);
        for (j, run_j) in problem.run_filters(&steps)?.iter().enumerate() {
            let r_j = run_j.innovation_vector(keep);
            iterations += 1;
            if r_j.len() != r0.len() {
                return Ok(None);
            }
            for (i, v) in r_j.iter().enumerate() {
                jacobian[(i, j)] = (v - r[i]) / STEP_T;
            }
        }
        let svd = jacobian.svd(true, true);
        let tolerance = RCOND * svd.singular_values.max();
        for _ in 0..MAX_ITERATIONS {
            let Ok(update) = svd.solve(&r, tolerance) else {
                return Ok(None);
            };
            if !update.iter().all(|v| v.is_finite()) {
                return Ok(None);
            }
            let trial = &theta - &update;
            let recon_trial = run(&trial)?;
            iterations += 1;
            let r_trial = DVector::from_vec(recon_trial.innovation_vector(keep));
            if r_trial.len() != r0.len() {
                return Ok(None);
            }
            let rss_trial = r_trial.norm_squared();
            if rss_trial >= rss {
                // Past the linear range: a new Jacobian here.
                continue 'jacobians;
            }
            let improvement = (rss - rss_trial) / rss;
            (theta, r, rss, recon) = (trial, r_trial, rss_trial, recon_trial);
            if improvement < CONVERGED {
                break 'jacobians;
            }
        }
    }
    let coefficients = DMatrix::from_column_slice(columns.len(), 3, theta.as_slice());
    let fitted_field = to_config(&columns, &coefficients);
    if fitted_field.terms.is_empty() {
        return Ok(None);
    }
    Ok(Some(FieldFit {
        fitted_field,
        not_carried,
        iterations,
        rms_before_t: field_rms(&recon0),
        rms_after_t: field_rms(&recon),
    }))
}

/// The coefficients (`functions × axes`, tesla per unit) as `[effects.fitted_field]`.
fn to_config(columns: &[FieldFunction], c: &DMatrix<f64>) -> FittedField {
    let mut terms = Vec::new();
    for (j, f) in columns.iter().enumerate() {
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
