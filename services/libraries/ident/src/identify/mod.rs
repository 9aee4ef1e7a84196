//! The analysis of `testbed identify`.
//!
//! 1. **What the simulation gets wrong.** The nominal model (the configuration given) predicts
//!    every measurement channel — rates, tilt, field, wheel speeds — from the estimated state,
//!    re-initialised every `horizon_s` and driven by the recorded commands
//!    ([`crate::predict`]); and the data are checked against its equations of motion
//!    ([`crate::channels`]: the platform's momentum equation, the wheels' equation) and its
//!    sensor models (the attitude filter's innovations). Each residual is described by its RMS,
//!    bias, trend and lag-1 correlation (no white-noise test: these series are correlated by
//!    construction).
//! 2. **Name the cause.** The data are split in time blocks of `block_s`. By default (`folds`
//!    5: k-fold cross-validation over contiguous blocks, block b in fold `b mod folds`) the
//!    fits use all the data, and a candidate significant at 1 % is also fitted k times, each
//!    time without one fold (sensor causes: one Gauss–Newton step from the fit on all the
//!    data, [`crate::fit::Problem::fit_from`]); its held-out statistic is then the sum over
//!    the folds of the left-out fold's log-likelihood ratio against the set chosen so far
//!    (fitted the same way). With `folds` 0 every `held_out_every`-th block is held out of
//!    the fits instead.
//!    Forward selection over the candidate library: at each step every remaining cause is fitted
//!    jointly with those already chosen ([`crate::fit`]); a candidate is significant when its
//!    likelihood ratio on the fit data beats both the information criterion (BIC, `k ln N`)
//!    and the χ² quantile at `1 − alpha`; among the significant ones whose held-out (or
//!    cross-validated) residuals improve, the one that improves them most is chosen. No
//!    candidate chosen: the cause is `none`.
//! 3. **Extend the model**: the configuration given plus the chosen effects with their fitted
//!    values (loadable by `ModelConfig::load`).
//! 4. **Measure the gain**: multi-step prediction error of the nominal and extended model per
//!    component and overall on every fold predicted by the extended model fitted without it
//!    (with `folds` 0: on the held-out blocks); gain = nominal / extended.
//!
//! 5. **Falsify the named causes** (`falsify`; each channel's tests in `torque`, `innovation`,
//!    `wheel`): each must have the same parameters in disjoint time blocks and stay significant
//!    beside the other causes and the unexplained effects, and a torque cause also beside the
//!    best explanation of another form found without it (a wheel cause needs white residuals of
//!    its wheel equation); the worst failure is dropped and the rest refitted and tested again.
//! 6. **Find the form of what remains** (`equations`, [`crate::sparse`]): sparse regression of
//!    each equation's residual (torque per axis: `torque`, each innovation component:
//!    `innovation`, each wheel's spin equation: `wheel`) on a fixed library of candidate
//!    functions of the state and time, with k-fold cross-validation and cluster-robust standard
//!    errors; what it finds is reported as an unexplained effect (`unexplained`).
//! 7. **Second pass** (`sensor`): when the field innovations hold an unexplained effect that
//!    is a function of the attitude (a soft iron), the readings are corrected with it (fitted
//!    in tesla through the filter, carried as `[effects.fitted_field]`) and steps 1–6 are
//!    redone on the corrected estimate; the gain's baseline stays the configuration given.
//!
//! What remains after the chosen causes is checked on the equation-error channels (RMS against
//! the noise the model expects), by the unexplained-effect search, and, if something remains,
//! correlated with the signals the candidate effects would produce.
//!
//! The settings are in `options`, the forward selection of step 2 in `selection`. The report's
//! types and its tables of curves are in `report`; the residual series after a fit, what
//! remains and what it correlates with in `residuals`.

mod change;
mod colour;
mod equations;
mod falsify;
mod guard;
mod innovation;
mod options;
mod report;
mod residuals;
mod rounding;
mod selection;
mod sensor;
mod torque;
mod unexplained;
mod wheel;

pub use change::{CHANGE_ALPHA, Change, ChangeReport};
pub use colour::{
    COLOUR_ALPHA, COLOUR_SEGMENT_S, ChannelWhiteness, INNOVATION_LAGS, InnovationWhiteness,
    WhitenessReport, torque_whiteness,
};
pub use falsify::{CauseTest, Consistency, Trend, Whiteness};
pub use guard::{AcrossEquations, PartlyExplained, Trigger};
pub use options::{Options, held_out_mask};
pub use sensor::SensorCorrection;
pub use unexplained::UnexplainedEffect;

pub use report::{
    CandidateRow, CauseReport, ComponentReport, Correlation, Curve, DataSummary, FigureData,
    Identification, Remaining, Report, ResidualReport, RmsReport,
};
pub use rounding::{round_to, with_error};

use report::{prediction_curves, rms_report, window_curves};
use residuals::{equation_error, remaining};
use selection::{Selection, forward_selection, sensor_warm};

use crate::data::{Aligned, Dataset, block_index};
use crate::effects::{Cause, Kind};
use crate::error::IdentError;
use crate::fit::{Problem, SetFit};
use crate::predict::{self, COMPONENTS};
use crate::stats::chi_square_quantile;
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use testbed_model::ModelConfig;

/// Identify what the model gets wrong in `data` (see the module documentation).
///
/// When the first pass finds an unexplained effect in the field innovations whose functions
/// the magnetometer's model can take, the readings are corrected with it ([`sensor`]) and the
/// analysis runs again on the corrected estimate (the second pass, whose report this is; the
/// first pass's field effects and the correction are in it).
pub fn identify(
    data: &Dataset,
    model: &ModelConfig,
    options: &Options,
) -> Result<Identification, IdentError> {
    options.validate()?;
    model.validate()?;
    data.check_rows()?;
    let (cleaned, spikes) = crate::spikes::remove(data, model);
    let mut identification = identify_clean(&cleaned, model, options)?;
    let report = &mut identification.report;
    if let Some(line) = crate::data::silences_summary(&report.data.silences) {
        report.summary.insert(0, line);
    }
    if let Some(line) = crate::spikes::summary(&spikes) {
        report.summary.insert(0, line);
    }
    report.data.spikes = spikes;
    Ok(identification)
}

/// [`identify`] on data without spikes.
fn identify_clean(
    data: &Dataset,
    model: &ModelConfig,
    options: &Options,
) -> Result<Identification, IdentError> {
    crate::sanity::check(data, model)?;
    let aligned = Aligned::new(data);
    let first = identify_pass(data, &aligned, model, options, None)?;
    let (first, options, left_out) = without_stand_ins(data, &aligned, model, options, first)?;
    let mut identification = with_sensor_correction(data, &aligned, model, &options, first)?;
    if let Some(left_out) = left_out {
        let report = &mut identification.report;
        report.summary.insert(0, left_out.summary);
        report.stand_ins_left_out = left_out.names;
    }
    Ok(identification)
}

/// The second pass, when the first found an unexplained effect in the field innovations that
/// the magnetometer's model can take (see [`identify`]); otherwise the first pass.
fn with_sensor_correction(
    data: &Dataset,
    aligned: &Aligned,
    model: &ModelConfig,
    options: &Options,
    first: Identification,
) -> Result<Identification, IdentError> {
    let equations = sensor::field_equations(&first.report.unexplained);
    if equations.is_empty() {
        return Ok(first);
    }
    let problem = Problem::new(
        aligned,
        model.clone(),
        held_out_mask(aligned, options),
        options.block_s,
        options.fit.clone(),
    );
    let Some(fit) = sensor::fit_field_correction(&problem, model, &first.report.unexplained)?
    else {
        return Ok(first);
    };
    let mut corrected = model.clone();
    match corrected.effects.fitted_field.as_mut() {
        Some(old) => old.terms.extend(fit.fitted_field.terms.iter().cloned()),
        None => corrected.effects.fitted_field = Some(fit.fitted_field.clone()),
    }
    corrected.validate()?;
    let first_effects: Vec<UnexplainedEffect> = first
        .report
        .unexplained
        .iter()
        .filter(|e| equations.contains(&e.equation))
        .cloned()
        .map(|mut e| {
            e.pass = 1;
            e
        })
        .collect();
    let prior = FirstPass {
        original: model,
        effects: first_effects,
        correction: SensorCorrection {
            equations,
            fitted_field: fit.fitted_field,
            not_carried: fit.not_carried,
            iterations: fit.iterations,
            residual_rms_before_t: fit.rms_before_t,
            residual_rms_after_t: fit.rms_after_t,
            first_pass_verdict: first.report.verdict.clone(),
            first_pass_gain: first.report.gain,
        },
        filter_runs: first.report.filter_runs + problem.filter_runs(),
        nominal_residuals: first.report.nominal_residuals,
        nominal_prediction: first.figures.nominal_prediction,
        nominal_equation: first.figures.nominal_equation,
    };
    identify_pass(data, aligned, &corrected, options, Some(prior))
}

/// A cause the selection chose and the falsification tests then dropped as standing in for
/// an effect of another form (`joint`) took its step of the forward selection from the
/// library's other causes: one of those may be the effect. The pass runs again with the
/// stand-ins left out of the candidates, and the rerun is taken when it explains what the
/// stand-ins could not: its extended model predicts the held-out data better, it leaves fewer
/// unexplained effects, and the guard flags none of its causes as explaining only part of its
/// channel (a cause from outside the effect's form, standing in again). The options it ran
/// with go on to the second pass, and what was left out is returned beside it.
fn without_stand_ins(
    data: &Dataset,
    aligned: &Aligned,
    model: &ModelConfig,
    options: &Options,
    first: Identification,
) -> Result<(Identification, Options, Option<StandInsLeftOut>), IdentError> {
    let stand_ins: Vec<Cause> = first
        .report
        .cause_tests
        .iter()
        .filter(|t| t.failed == Some("joint"))
        .filter_map(|t| Cause::from_name(t.name))
        .collect();
    if stand_ins.is_empty() {
        return Ok((first, options.clone(), None));
    }
    let rerun_options = Options {
        candidates: options
            .candidates
            .iter()
            .copied()
            .filter(|c| !stand_ins.contains(c))
            .collect(),
        ..options.clone()
    };
    let mut rerun = identify_pass(data, aligned, model, &rerun_options, None)?;
    let explains = rerun.report.gain > first.report.gain
        && rerun.report.unexplained.len() < first.report.unexplained.len()
        && rerun.report.partly_explained.is_empty();
    if !explains {
        return Ok((first, options.clone(), None));
    }
    let names: Vec<&'static str> = stand_ins.iter().map(|c| c.name()).collect();
    let them = if names.len() == 1 { "it" } else { "them" };
    let summary = format!(
        "Ran again without {}: chosen, then dropped as standing in for an effect of another \
         form. Without {them} the causes named explain it: the extended model predicts the \
         held-out data {:.2}× better than the configuration given (with {them}: {:.2}×), and \
         {} of {} unexplained effects remain.",
        names.join(", "),
        rerun.report.gain,
        first.report.gain,
        rerun.report.unexplained.len(),
        first.report.unexplained.len()
    );
    rerun.report.filter_runs += first.report.filter_runs;
    let left_out = StandInsLeftOut { names, summary };
    Ok((rerun, rerun_options, Some(left_out)))
}

/// The stand-ins an analysis ran again without ([`without_stand_ins`]), and the summary line
/// that says so.
struct StandInsLeftOut {
    names: Vec<&'static str>,
    summary: String,
}

/// What the second pass takes from the first.
struct FirstPass<'m> {
    /// The configuration given (the second pass's is it plus the correction): the baseline of
    /// the gain.
    original: &'m ModelConfig,
    /// The first pass's field-innovation effects (the correction's form).
    effects: Vec<UnexplainedEffect>,
    correction: SensorCorrection,
    filter_runs: usize,
    nominal_residuals: ResidualReport,
    nominal_prediction: Vec<Curve>,
    nominal_equation: Vec<Curve>,
}

/// One pass of the analysis on the estimate of `model`'s sensor model; the second (`prior`
/// given) reports against the configuration given and carries the first's findings.
fn identify_pass(
    data: &Dataset,
    aligned: &Aligned,
    model: &ModelConfig,
    options: &Options,
    prior: Option<FirstPass>,
) -> Result<Identification, IdentError> {
    let block = |t: f64| block_index(t, options.block_s);
    let cross_validated = options.folds >= 2;
    let held_out = held_out_mask(aligned, options);
    let problem = Problem::new(
        aligned,
        model.clone(),
        held_out.clone(),
        options.block_s,
        options.fit.clone(),
    );
    let fold_masks: Vec<Vec<bool>> = (0..options.folds)
        .map(|j| {
            aligned
                .t
                .iter()
                .map(|&t| block(t) % options.folds == j)
                .collect()
        })
        .collect();
    let folds: Vec<Problem> = fold_masks
        .iter()
        .map(|mask| problem.with_held_out(mask.clone()))
        .collect();

    // Baseline.
    let empty = HashMap::new();
    let mut nominal = problem.fit(&[], &empty)?;
    if nominal.state.recon.start() >= aligned.len() {
        return Err(IdentError::Failed(format!(
            "{}: the attitude filter never started (no usable inclinometer/magnetometer sample pair)",
            data.source.display()
        )));
    }
    let n_fit = nominal.evaluation.fit.total().max(2) as f64;
    let nominal_folds: Vec<SetFit> = folds
        .iter()
        .map(|f| f.fit(&[], &empty))
        .collect::<Result<_, _>>()?;
    let Selection {
        selected,
        mut current,
        current_folds,
        steps,
        chosen_rows,
        mut warm,
    } = forward_selection(&problem, &folds, &nominal, &nominal_folds, n_fit, options);

    // Falsify the named causes and search what remains (see `equations`).
    let mut named = selected.clone();
    let analyse = |fit: &SetFit, named: &[Cause]| {
        let candidates = equations::Candidates::new(&problem, fit, named);
        let effects = equations::search_all(
            &problem,
            fit,
            named,
            &candidates,
            options.block_s,
            &options.sparse,
        );
        let (tests, joint) = equations::test_causes(
            &problem,
            fit,
            named,
            &effects,
            &candidates,
            &falsify::Levels::new(options, n_fit),
        );
        (effects, tests, joint, candidates)
    };
    let (mut effects, mut tests, mut joint, mut candidates) = analyse(&current, &named);
    let mut cause_tests: Vec<CauseTest> = Vec::new();
    let mut sensor_dropped = false;
    for _ in 0..=options.max_causes {
        // Drop the worst failure only, then search and test again: a cause that failed beside
        // a wrongly named one may pass once that one is gone.
        let Some(worst) = tests
            .iter()
            .filter(|t| !t.kept)
            .max_by(|a, b| a.severity().total_cmp(&b.severity()))
            .cloned()
        else {
            break;
        };
        let Some(dropped) = Cause::from_name(worst.name) else {
            break;
        };
        cause_tests.push(worst);
        named.retain(|c| *c != dropped);
        // A dropped sensor cause was fitted jointly with the others: refit them.
        if dropped.kind() == Kind::Sensor {
            warm.retain(|c, _| c.kind() != Kind::Sensor);
            sensor_dropped = true;
        }
        current = problem.fit(&named, &warm)?;
        (effects, tests, joint, candidates) = analyse(&current, &named);
    }
    cause_tests.extend(tests.iter().cloned());
    // A named cause that the unrestricted search explains better in one of its equations
    // explains it only partly: flagged, its remainder among the unexplained effects (`guard`).
    let mut partly = if options.misattribution_guard {
        guard::apply(
            &problem,
            (&current, &named, &candidates),
            (options, n_fit),
            &mut effects,
            &mut joint,
        )
    } else {
        Vec::new()
    };
    let absorbing: Vec<(Cause, Vec<f64>)> = current
        .causes
        .iter()
        .map(|f| (f.cause, f.values.clone()))
        .collect();
    // With unexplained torque terms, the named torque causes take their values from the joint
    // fit (they no longer absorb part of the new effect).
    let torque_terms = effects.iter().any(|e| e.equation.starts_with("torque_"));
    if let (true, Some(joint)) = (torque_terms, &joint) {
        for (cause, delta, se) in &joint.delta {
            let mut values = cause.values(&problem.base);
            for (v, d) in values.iter_mut().zip(delta) {
                *v += d;
            }
            cause.apply(&mut current.config, &values);
            if let Some(f) = current.causes.iter_mut().find(|f| f.cause == *cause) {
                f.values = values;
                f.stderr = se.clone();
            }
        }
    }
    // With unexplained wheel terms, the named wheel causes' linear values (torque scale,
    // friction levels) take the search's refit beside the terms (its forced columns; the delay
    // and the Stribeck speed, shared or nonlinear, stay as fitted).
    wheel::refit_beside_terms(&mut current, &named, &effects);
    // What the terms took from each cause: a fold's fit of the causes, made without the terms,
    // absorbs it again, and is shifted by it where the fold is predicted with the terms.
    let beside_terms: Vec<(Cause, Vec<f64>)> = current
        .causes
        .iter()
        .filter_map(|f| {
            let (_, before) = absorbing.iter().find(|(c, _)| *c == f.cause)?;
            let shift: Vec<f64> = f.values.iter().zip(before).map(|(a, b)| a - b).collect();
            shift.iter().any(|d| *d != 0.0).then_some((f.cause, shift))
        })
        .collect();
    let selected = named;

    let mut causes: Vec<CauseReport> = selected
        .iter()
        .filter_map(|cause| {
            let row = chosen_rows.iter().find(|r| r.name == cause.name())?;
            let f = current.causes.iter().find(|c| c.cause == *cause)?;
            Some(CauseReport {
                name: cause.name(),
                description: cause.description(),
                parameters: cause.to_json(&f.values),
                stderr: cause.to_json(&f.stderr),
                units: cause.units_json(),
                lr_fit: row.lr_fit,
                delta_bic: row.delta_bic,
                lr_held_out: row.lr_held_out,
                note: f.note.clone(),
            })
        })
        .collect();
    // The unexplained torque terms become a fitted torque in the extended model, the wheel
    // channel's a fitted wheel torque (each added to one the model already has); held-out
    // predictions use the terms fitted without the held-out blocks.
    let span_s = (aligned.t.last().copied().unwrap_or(1.0)
        - aligned.t.first().copied().unwrap_or(0.0))
    .max(1e-9);
    use unexplained::Coefficients;
    let with_terms = |base: &ModelConfig, which: Coefficients| {
        let (fitted, mut not_carried) = unexplained::fitted_torque(&effects, span_s, which);
        // The wheel terms' `τ` is the commanded torque; the plant's is the delivered one
        // (times the torque scale of `base`).
        let scale = crate::fit::WheelModel::from_config(base).scale;
        let (fitted_wheel, wheel_not_carried) =
            unexplained::fitted_wheel_torque(&effects, span_s, scale, which);
        not_carried.extend(wheel_not_carried);
        let mut config = base.clone();
        if let Some(new) = &fitted {
            match config.effects.fitted_torque.as_mut() {
                Some(old) => old.terms.extend(new.terms.iter().cloned()),
                None => config.effects.fitted_torque = Some(new.clone()),
            }
        }
        if let Some(new) = &fitted_wheel {
            match config.effects.fitted_wheel_torque.as_mut() {
                Some(old) => old.terms.extend(new.terms.iter().cloned()),
                None => config.effects.fitted_wheel_torque = Some(new.clone()),
            }
        }
        (config, (fitted, fitted_wheel), not_carried)
    };
    let (mut extended, (fitted_torque, fitted_wheel_torque), not_carried) =
        with_terms(&current.config, Coefficients::All);
    let (extended_fit_blocks, _, _) = with_terms(&current.config, Coefficients::FitBlocks);
    let carries_terms = fitted_torque.is_some() || fitted_wheel_torque.is_some();
    let extends = !selected.is_empty() || carries_terms;
    // With k-fold cross-validation each fold is predicted with the terms fitted without it,
    // which needs the search's folds to be the selection's (same count, same blocks).
    let fold_terms = options.folds == options.sparse.folds;
    let mut extension = report::ModelExtension {
        gain_includes_fitted_torque: carries_terms && (!cross_validated || fold_terms),
        fitted_torque,
        fitted_wheel_torque,
        not_carried,
        gain_without_fitted_torque: None,
        rejected: None,
    };
    // The extended model must load as it is written.
    ModelConfig::from_toml_str(&extended.to_toml_string(), "extended model")?;

    // Gain: cross-validated (each fold predicted by the named causes fitted without it) or on
    // the held-out blocks. In the second pass the baseline is the configuration given, on its
    // own (uncorrected) estimate, and the extended model always differs from it (the
    // correction).
    let baseline_recon = match &prior {
        Some(p) => Some(crate::reconstruct::reconstruct(aligned, p.original)?),
        None => None,
    };
    let (baseline_recon, baseline_model) = match (&baseline_recon, &prior) {
        (Some(r), Some(p)) => (r, p.original),
        _ => (&*nominal.state.recon, model),
    };
    let second_pass = prior.is_some();
    let extends = extends || second_pass;
    // `named_only`: the same predictions without the fitted torque (when it is carried);
    // `tiling`: with cross-validation the held-out windows, which tile the whole record (the
    // baseline's predictions there are its residual report's).
    let (base_held, ext_held, held_fraction, named_only, tiling) = if !cross_validated {
        let held_fraction =
            held_out.iter().filter(|h| **h).count() as f64 / held_out.len().max(1) as f64;
        let spans = held_out_spans(&held_out, &nominal.state.recon.spans);
        let windows = predict::windows(aligned, &spans, options.horizon_s);
        let base_held = predict::predict(aligned, baseline_recon, baseline_model, &windows)?;
        let ext_held = if extends {
            predict::predict(
                aligned,
                &current.state.recon,
                &extended_fit_blocks,
                &windows,
            )?
        } else {
            base_held.clone()
        };
        // What carrying the fitted torques adds: the named causes alone.
        let named_only = match (carries_terms, selected.is_empty() && !second_pass) {
            (false, _) => None,
            (true, true) => Some(base_held.clone()),
            (true, false) => Some(predict::predict(
                aligned,
                &current.state.recon,
                &current.config,
                &windows,
            )?),
        };
        (base_held, ext_held, held_fraction, named_only, None)
    } else {
        let fold_windows: Vec<Vec<(usize, usize)>> = fold_masks
            .iter()
            .map(|mask| {
                let spans = held_out_spans(mask, &nominal.state.recon.spans);
                predict::windows(aligned, &spans, options.horizon_s)
            })
            .collect();
        let mut windows: Vec<(usize, usize)> = fold_windows.iter().flatten().copied().collect();
        windows.sort_unstable();
        let held_fraction = windows.iter().map(|(a, b)| b + 1 - a).sum::<usize>() as f64
            / aligned.len().max(1) as f64;
        let base_held = predict::predict(aligned, baseline_recon, baseline_model, &windows)?;
        let mut cv_nominal = crate::fit::ChannelRss::default();
        let mut cv_extended = crate::fit::ChannelRss::default();
        let carry = extension.gain_includes_fitted_torque;
        let (ext_held, named_only) = if !extends {
            for f in &nominal_folds {
                cv_nominal.add(&f.evaluation.held_out);
            }
            cv_extended = cv_nominal;
            (base_held.clone(), None)
        } else {
            // Each fold fitted and predicted on its own, across the cores.
            let per_fold: Vec<_> = folds
                .par_iter()
                .enumerate()
                .map(|(j, fold)| -> Result<_, IdentError> {
                    let warm_j = if sensor_dropped {
                        HashMap::new()
                    } else {
                        sensor_warm(&current_folds[j])
                    };
                    let fit_j = if selected.is_empty() {
                        nominal_folds[j].clone()
                    } else {
                        fold.fit(&selected, &warm_j)?
                    };
                    let without_terms = predict::predict(
                        aligned,
                        &fit_j.state.recon,
                        &fit_j.config,
                        &fold_windows[j],
                    )?;
                    let with_fold_terms = if carry {
                        let (config_j, _, _) = with_terms(
                            &shifted(&fit_j, &beside_terms),
                            Coefficients::WithoutFold(j),
                        );
                        Some(predict::predict(
                            aligned,
                            &fit_j.state.recon,
                            &config_j,
                            &fold_windows[j],
                        )?)
                    } else {
                        None
                    };
                    Ok((fit_j.evaluation.held_out, without_terms, with_fold_terms))
                })
                .collect::<Result<_, _>>()?;
            let mut parts = Vec::with_capacity(folds.len());
            let mut parts_without_terms = Vec::with_capacity(folds.len());
            for (j, (held_out_j, without_terms, with_fold_terms)) in
                per_fold.into_iter().enumerate()
            {
                cv_nominal.add(&nominal_folds[j].evaluation.held_out);
                cv_extended.add(&held_out_j);
                match with_fold_terms {
                    Some(with) => {
                        parts.push(with);
                        parts_without_terms.push(without_terms);
                    }
                    None => parts.push(without_terms),
                }
            }
            let named_only = carry.then(|| predict::Predictions::merge(parts_without_terms));
            (predict::Predictions::merge(parts), named_only)
        };
        // The held-out channel sums reported are the cross-validated ones.
        nominal.evaluation.held_out = cv_nominal;
        current.evaluation.held_out = cv_extended;
        (
            base_held,
            ext_held,
            held_fraction,
            named_only,
            Some(windows),
        )
    };
    // The fitted torque stays in the extended model only if it improves the held-out
    // prediction by at least 1 % (the sparse search's own bar); a term that stands in for a
    // sensor-side effect (the torque channel is built on the filter's attitude) need not.
    let overall = |p: &predict::Predictions| predict::Predictions::overall(&p.rms(|_| true));
    let ext_held = match named_only {
        Some(named_only) => {
            let (with, without) = (overall(&ext_held), overall(&named_only));
            let base = overall(&base_held);
            extension.gain_without_fitted_torque = Some(base / without);
            if with > without * (1.0 - MIN_EXTENSION_GAIN) {
                extension.rejected = Some(format!(
                    "the fitted {} not carried into the extended model: {} not improve the held-out prediction by 1 % ({:.2}× without, {:.2}× with)",
                    match (&extension.fitted_torque, &extension.fitted_wheel_torque) {
                        (Some(_), Some(_)) => "torque and wheel torque are",
                        (None, Some(_)) => "wheel torque is",
                        _ => "torque is",
                    },
                    if extension.fitted_torque.is_some() && extension.fitted_wheel_torque.is_some()
                    {
                        "together they do"
                    } else {
                        "it does"
                    },
                    base / without,
                    base / with
                ));
                extension.fitted_torque = None;
                extension.fitted_wheel_torque = None;
                extended = current.config.clone();
                named_only
            } else {
                ext_held
            }
        }
        None => ext_held,
    };
    let extends = !selected.is_empty()
        || extension.fitted_torque.is_some()
        || extension.fitted_wheel_torque.is_some()
        || second_pass;

    // Residual reports, nominal and extended.
    let (all_windows, own_prediction) = match tiling {
        Some(windows) => (windows, None),
        None => {
            let all_spans: Vec<(usize, usize)> = (nominal.state.recon.spans.iter())
                .map(|s| (s.start, s.end))
                .collect();
            let all_windows = predict::windows(aligned, &all_spans, options.horizon_s);
            let prediction =
                predict::predict(aligned, baseline_recon, baseline_model, &all_windows)?;
            (all_windows, Some(prediction))
        }
    };
    let nominal_prediction = own_prediction.as_ref().unwrap_or(&base_held);
    let (nominal_equation, nominal_report) = equation_error(&problem, &nominal, nominal_prediction);
    let own_extended = if extends {
        Some(predict::predict(
            aligned,
            &current.state.recon,
            &extended,
            &all_windows,
        )?)
    } else {
        None
    };
    let extended_prediction = own_extended.as_ref().unwrap_or(nominal_prediction);
    let (extended_equation, extended_report) =
        equation_error(&problem, &current, extended_prediction);

    let base_rms = base_held.rms(|_| true);
    let ext_rms = ext_held.rms(|_| true);
    let baseline_rms = rms_report(&base_rms);
    let extended_rms = rms_report(&ext_rms);
    let gain = baseline_rms.overall / extended_rms.overall;
    let mut gain_by_component = BTreeMap::new();
    for c in 0..COMPONENTS.len() {
        if let (Some(a), Some(b)) = (base_rms[c], ext_rms[c]) {
            gain_by_component.insert(COMPONENTS[c], a.rms / b.rms);
        }
    }
    let gain_by_group = baseline_rms
        .groups
        .iter()
        .filter_map(|(g, a)| extended_rms.groups.get(g).map(|b| (*g, a / b)))
        .collect();
    // The test of the extension itself: the model extended with the named causes must predict
    // the held-out data better than the configuration given. Worse by more than the 1 % bar,
    // the data refute them: they are the library's nearest stand-in for an effect outside it
    // (a clock offset between two devices, say). They are reported as refuted, not named, and
    // the extended model is the configuration given.
    let refuted = if !causes.is_empty() && gain * (1.0 + MIN_EXTENSION_GAIN) < 1.0 {
        if extension.fitted_torque.is_some() || extension.fitted_wheel_torque.is_some() {
            extension.rejected = Some(format!(
                "the fitted terms not carried: the model extended with them and the refuted causes predicts the held-out data worse than the configuration given ({gain:.2}×)"
            ));
            extension.fitted_torque = None;
            extension.fitted_wheel_torque = None;
        }
        extension.gain_includes_fitted_torque = false;
        extended = model.clone();
        // The guard's flags speak of named causes.
        partly.clear();
        std::mem::take(&mut causes)
    } else {
        Vec::new()
    };
    let verdict = if causes.is_empty() {
        "none".to_string()
    } else {
        causes
            .iter()
            .map(|c| c.name)
            .collect::<Vec<_>>()
            .join(" + ")
    };

    // The second pass: the first pass's field effects (the correction's form) lead the
    // unexplained effects (what remains after the named causes includes them: the correction is
    // an unexplained term, not a cause).
    let (effects, sensor_correction, first_pass) = match prior {
        Some(p) => {
            let mut all = p.effects;
            all.extend(effects.into_iter().map(|mut e| {
                e.pass = 2;
                e
            }));
            let rest = (
                p.filter_runs,
                p.nominal_residuals,
                p.nominal_prediction,
                p.nominal_equation,
            );
            (all, Some(p.correction), Some(rest))
        }
        None => (effects, None, None),
    };
    let remaining = remaining(&problem, &current, options, &effects, &extended_rms);
    let figures = FigureData {
        nominal_prediction: prediction_curves(nominal_prediction),
        nominal_equation,
        extended_equation,
        held_out_nominal: window_curves(&base_held, aligned),
        held_out_extended: window_curves(&ext_held, aligned),
    };
    let devices = [
        (!data.gyro.is_empty(), "gyro"),
        (!data.inclinometer.is_empty(), "inclinometer"),
        (!data.magnetometer.is_empty(), "magnetometer"),
        (!data.wheels.is_empty(), "wheels"),
        (!data.cmg.is_empty(), "cmg"),
        (!data.thrusters.is_empty(), "thrusters"),
    ]
    .into_iter()
    .filter_map(|(p, n)| p.then_some(n))
    .collect();
    // Borderline causes: the last step's candidates that did not reach the threshold but are
    // significant at 1 % and improve the held-out data (not named, but not silently dropped).
    let possible: Vec<CandidateRow> = steps
        .last()
        .map(|rows| {
            rows.iter()
                .filter(|r| {
                    !r.chosen
                        && !selected.iter().any(|c| c.name() == r.name)
                        && r.k > 0
                        && r.lr_held_out > 0.0
                        && r.lr_fit > chi_square_quantile(0.99, r.k as f64).unwrap_or(f64::INFINITY)
                        && !(r.significant && cause_tests.iter().any(|t| t.name == r.name))
                })
                .cloned()
                .collect()
        })
        .unwrap_or_default();
    // The second pass reports the first pass's nominal residuals (of the configuration given).
    let (mut nominal_report, mut figures, mut filter_runs) = (nominal_report, figures, 0);
    if let Some((runs, residuals, prediction, equation)) = first_pass {
        nominal_report = residuals;
        figures.nominal_prediction = prediction;
        figures.nominal_equation = equation;
        filter_runs += runs + 1;
    }
    // Whiteness of the torque channel under the extended model: a coloured disturbance.
    let whiteness = colour::whiteness(aligned, &current.state.recon, &extended);
    // A level that changed within the record: no constant cause explains it.
    let changes = change::changes(aligned, &current.state.recon, options.horizon_s);
    let unconfirmed = report::unconfirmed(&steps);
    let mut summary = report::summary(
        &causes,
        &cause_tests,
        &possible,
        &unconfirmed,
        &refuted,
        &effects,
        &remaining,
        gain,
        &extension,
        sensor_correction.as_ref(),
    );
    guard::annotate(&mut summary, &partly);
    summary.extend(whiteness.lines());
    let structured: Vec<&str> = effects
        .iter()
        .map(|e| e.equation.as_str())
        .chain(
            whiteness
                .innovations
                .iter()
                .filter(|w| w.coloured)
                .map(|w| w.channel.as_str()),
        )
        .collect();
    summary.extend(changes.lines(&structured));
    let report = Report {
        summary,
        data: DataSummary {
            source: data.source.display().to_string(),
            duration_s: data.duration_s(),
            gyro_rows: data.gyro.len(),
            period_s: aligned.period_s,
            devices,
            held_out_fraction: held_fraction,
            spikes: Vec::new(),
            silences: aligned.silences(),
        },
        options: options.clone(),
        nominal_residuals: nominal_report,
        steps,
        possible,
        unconfirmed,
        causes,
        refuted,
        verdict,
        cause_tests,
        partly_explained: partly,
        unexplained: effects,
        extension,
        remaining,
        extended_residuals: extended_report,
        baseline_rms,
        extended_rms,
        gain,
        gain_by_component,
        gain_by_group,
        sensor_correction,
        whiteness,
        changes,
        filter_runs: filter_runs
            + problem.filter_runs()
            + folds.iter().map(Problem::filter_runs).sum::<usize>(),
        stand_ins_left_out: Vec::new(),
    };
    Ok(Identification {
        report,
        extended,
        figures,
    })
}

/// Least relative drop of the held-out prediction's RMS for the fitted torque to be carried.
const MIN_EXTENSION_GAIN: f64 = 0.01;

/// Contiguous runs of held-out ticks within the spans of estimates `estimated`.
fn held_out_spans(held: &[bool], estimated: &[Range<usize>]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for span in estimated {
        let mut k = span.start;
        while k < span.end {
            if held[k] {
                let a = k;
                while k < span.end && held[k] {
                    k += 1;
                }
                out.push((a, k));
            } else {
                k += 1;
            }
        }
    }
    out
}

/// The configuration of `fit` with each cause of `shifts` moved by its shift (clamped to the
/// cause's bounds).
fn shifted(fit: &SetFit, shifts: &[(Cause, Vec<f64>)]) -> ModelConfig {
    let mut config = fit.config.clone();
    for (cause, shift) in shifts {
        let Some(f) = fit.causes.iter().find(|f| f.cause == *cause) else {
            continue;
        };
        let values: Vec<f64> = f
            .values
            .iter()
            .zip(shift)
            .enumerate()
            .map(|(i, (v, d))| {
                let (lo, hi) = cause.bounds(i);
                (v + d).clamp(lo, hi)
            })
            .collect();
        cause.apply(&mut config, &values);
    }
    config
}
