//! Forward selection of the named causes (step 2 of the analysis): at each step every remaining
//! candidate is fitted jointly with those already chosen; the significant one that improves the
//! held-out (or cross-validated) residuals most is chosen.

use super::Options;
use super::report::CandidateRow;
use crate::effects::{Cause, Kind};
use crate::fit::{FittedCause, Problem, SensorLinearisation, SetFit};
use crate::stats::chi_square_quantile;
use rayon::prelude::*;
use std::collections::HashMap;
use testbed_model::ModelConfig;

/// What the forward selection chose, and how.
pub(super) struct Selection {
    /// The causes chosen, in the order they were.
    pub selected: Vec<Cause>,
    /// The fit of the chosen set, and per fold the same set fitted on the fold's problem.
    pub current: SetFit,
    pub current_folds: Vec<SetFit>,
    /// Per step, every candidate's row.
    pub steps: Vec<Vec<CandidateRow>>,
    /// The chosen candidates' rows.
    pub chosen_rows: Vec<CandidateRow>,
    /// The sensor causes of the last fit, the next fit's starting values.
    pub warm: HashMap<Cause, FittedCause>,
}

/// The forward selection over `options.candidates`, from the fit of the nominal model
/// (`nominal`, and per fold `nominal_folds`) of `problem` and its folds' problems `folds`;
/// `n_fit` scalar residuals in the fit data.
pub(super) fn forward_selection(
    problem: &Problem,
    folds: &[Problem],
    nominal: &SetFit,
    nominal_folds: &[SetFit],
    n_fit: f64,
    options: &Options,
) -> Selection {
    let cross_validated = options.folds >= 2;
    let available: Vec<Cause> = options
        .candidates
        .iter()
        .copied()
        .filter(|c| available(*c, problem, nominal))
        .collect();
    let mut selected: Vec<Cause> = Vec::new();
    let mut current = nominal.clone();
    let mut current_folds = nominal_folds.to_vec();
    let mut steps = Vec::new();
    let mut chosen_rows: Vec<CandidateRow> = Vec::new();
    let mut warm: HashMap<Cause, FittedCause> = HashMap::new();
    for _ in 0..options.max_causes {
        let threshold_for = |k: usize| {
            (k as f64 * n_fit.ln()).max(
                chi_square_quantile(1.0 - options.alpha, k.max(1) as f64).unwrap_or(f64::INFINITY),
            )
        };
        let screen_of = |cause: Cause| (threshold_for(cause.len()), current.evaluation.fit.rss[0]);
        // The sensor candidates' screens are a filter run each, and those that pass begin
        // their fits with a finite-difference Jacobian: each in one batch across the cores. A
        // run that fails here fails again in its candidate's fit, which reports it.
        let screened: Vec<(Cause, Vec<Cause>, _)> = available
            .iter()
            .filter(|c| !selected.contains(c) && c.kind() == Kind::Sensor)
            .filter_map(|&cause| {
                let set = [selected.as_slice(), &[cause]].concat();
                let request = problem.screen_request(&set, &warm).ok().flatten()?;
                Some((cause, set, request))
            })
            .collect();
        let requests: Vec<_> = screened.iter().map(|(_, _, r)| r.clone()).collect();
        let _ = problem.prefetch_tangents(&requests);
        let first_steps: Vec<ModelConfig> = screened
            .iter()
            .filter(|(cause, _, request)| {
                problem
                    .screen_passes(request, screen_of(*cause))
                    .unwrap_or(false)
            })
            .filter_map(|(_, set, _)| problem.first_jacobian_runs(set, &warm).ok())
            .flatten()
            .collect();
        let _ = problem.prefetch(&first_steps);
        // Every candidate fitted (and cross-validated) on its own, across the cores; then
        // judged in the candidates' order.
        let candidates: Vec<Cause> = available
            .iter()
            .copied()
            .filter(|c| !selected.contains(c))
            .collect();
        let outcomes: Vec<_> = candidates
            .par_iter()
            .map(|&cause| {
                let set = [selected.as_slice(), &[cause]].concat();
                let screen = (cause.kind() == Kind::Sensor).then(|| screen_of(cause));
                problem.fit_screened(&set, &warm, screen).map(|fit| {
                    let lr = current.evaluation.fit.log_ratio(&fit.evaluation.fit);
                    let k = fit.free().saturating_sub(current.free());
                    // Cross-validation of the candidates that can be chosen or listed as
                    // possible (significant at 1 %); the others' is not computed (NaN).
                    let cv = if cross_validated {
                        (k > 0 && lr > chi_square_quantile(0.99, k as f64).unwrap_or(f64::INFINITY))
                            .then(|| {
                                let from = fit.sensor_linearisation.as_deref();
                                cross_validate(folds, &current_folds, &set, from, &sensor_warm)
                            })
                            .flatten()
                    } else {
                        let lr_held = current
                            .evaluation
                            .held_out
                            .log_ratio(&fit.evaluation.held_out);
                        Some((lr_held, Vec::new()))
                    };
                    (fit, lr, k, cv)
                })
            })
            .collect();
        let mut rows = Vec::new();
        let mut best: Option<(usize, SetFit, Vec<SetFit>)> = None;
        for (cause, outcome) in candidates.into_iter().zip(outcomes) {
            match outcome {
                Ok((fit, lr, k, cv)) => {
                    let threshold = threshold_for(k);
                    let significant = k > 0 && lr > threshold;
                    let lr_held = cv.as_ref().map_or(f64::NAN, |(lr, _)| *lr);
                    let note = fit
                        .causes
                        .iter()
                        .find(|c| c.cause == cause)
                        .map(|c| c.note.clone())
                        .unwrap_or_default();
                    rows.push(CandidateRow {
                        name: cause.name(),
                        k,
                        lr_fit: lr,
                        threshold,
                        delta_bic: -lr + k as f64 * n_fit.ln(),
                        lr_held_out: lr_held,
                        significant,
                        chosen: false,
                        note,
                    });
                    if let Some((_, fold_fits)) = cv.filter(|_| significant && lr_held > 0.0)
                        && best
                            .as_ref()
                            .is_none_or(|(i, _, _)| lr_held > rows[*i].lr_held_out)
                    {
                        best = Some((rows.len() - 1, fit, fold_fits));
                    }
                }
                Err(e) => rows.push(CandidateRow {
                    name: cause.name(),
                    k: 0,
                    lr_fit: 0.0,
                    threshold: f64::NAN,
                    delta_bic: f64::NAN,
                    lr_held_out: f64::NAN,
                    significant: false,
                    chosen: false,
                    note: e.to_string(),
                }),
            }
        }
        let Some((i, fit, fold_fits)) = best else {
            steps.push(rows);
            break;
        };
        rows[i].chosen = true;
        let cause = Cause::from_name(rows[i].name).unwrap_or(Cause::ComOffset);
        chosen_rows.push(rows[i].clone());
        steps.push(rows);
        selected.push(cause);
        warm = sensor_warm(&fit);
        current = fit;
        current_folds = fold_fits;
        let mut keep: Vec<&ModelConfig> = current_folds.iter().map(|f| &f.config).collect();
        keep.push(&current.config);
        problem.trim_cache(&keep);
        for f in folds {
            f.trim_cache(&keep);
        }
    }
    Selection {
        selected,
        current,
        current_folds,
        steps,
        chosen_rows,
        warm,
    }
}

/// The sensor causes of `fit`, as starting values of the next fit (the filter is run per
/// parameter, so a warm start saves runs).
pub(super) fn sensor_warm(fit: &SetFit) -> HashMap<Cause, FittedCause> {
    fit.causes
        .iter()
        .filter(|c| c.cause.kind() == Kind::Sensor)
        .map(|c| (c.cause, c.clone()))
        .collect()
}

/// Cross-validation of the set `set` over the folds: fitted on each fold's problem (sensor
/// causes of the fold's current fit warm, `warm_of`; from the fit on all the data, `from`,
/// when it fitted sensor causes), the sum over the folds of the held-out log-likelihood ratio
/// against `current` (the set chosen so far, fitted the same way), and the fold fits. `None`
/// when a fold's fit fails (the fold does not determine the set).
fn cross_validate(
    folds: &[Problem],
    current: &[SetFit],
    set: &[Cause],
    from: Option<&SensorLinearisation>,
    warm_of: &(dyn Fn(&SetFit) -> HashMap<Cause, FittedCause> + Sync),
) -> Option<(f64, Vec<SetFit>)> {
    // The folds' filter runs at once, across the cores (they share one cache).
    if let (Some(from), Some(first)) = (from, folds.first()) {
        let configs: Vec<ModelConfig> = folds.iter().filter_map(|f| f.step_config(from)).collect();
        first.prefetch(&configs).ok()?;
    }
    let mut lr = 0.0;
    let mut fits = Vec::with_capacity(folds.len());
    for (fold, cur) in folds.iter().zip(current) {
        let fit = fold.fit_from(set, &warm_of(cur), from).ok()?;
        lr += cur.evaluation.held_out.log_ratio(&fit.evaluation.held_out);
        fits.push(fit);
    }
    Some((lr, fits))
}

/// Whether the data can say anything about a cause.
fn available(cause: Cause, problem: &Problem, nominal: &SetFit) -> bool {
    let s = &nominal.state;
    let excited = |cause: Cause| {
        crate::channels::torque_columns(cause)
            .into_iter()
            .flatten()
            .any(|c| s.torque.excited[c])
    };
    match cause.kind() {
        Kind::Sensor => {
            !s.recon.innovations.is_empty()
                && (!cause.needs_field() || !problem.data.field.is_empty())
                && (!cause.needs_tilt() || !problem.data.tilt.is_empty())
        }
        // The thrusters' causes only with thruster firings in the data (and `[thrusters]` in
        // the model): otherwise their columns are zero.
        Kind::Torque => {
            s.torque.len() >= 30
                && (!matches!(
                    cause,
                    Cause::ThrusterTorqueScale | Cause::PropellantComShift
                ) || excited(cause))
        }
        Kind::Wheel => s.wheel.len() >= 10,
    }
}
