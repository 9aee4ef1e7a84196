//! The misattribution guard: before a named cause is reported as the explanation of what it
//! absorbed, what it explains in each equation of its channel is set against what the
//! unrestricted candidate search explains there.
//!
//! An effect outside the library can resemble a library cause on part of the data (a torque
//! that follows the heading over ±60° is mostly a constant). The cause is then named, and its
//! channel's search, run *with* the cause in the model, may find nothing beside it: its bar for
//! a new term (1 % of the cross-validated residual sum) is high in a channel where the noise
//! dominates. So, per equation the cause acts in (a torque axis, a wheel, an innovation
//! component), on the same rows:
//!
//! - **with the cause**: the channel's search with every named cause forced (what the report
//!   already has), its cross-validated residual sum `cv_cause`;
//! - **the unrestricted search**: the cause's fitted part put back and its columns not forced,
//!   over the whole candidate library (its own form included), `cv_search` and its terms;
//! - **the trigger**: the search's terms include a function outside the cause's own form and
//!   predict better out of fold, `cv_search < cv_cause` (the selection's held-out likelihood
//!   ratio above zero);
//! - **the remainder**: those functions fitted beside the cause (and the terms found with it)
//!   must pass the test the selection names a cause by, beside the others: likelihood ratio on
//!   the equation's rows above `max(k ln N, χ²_k(1 − alpha))`, the cluster-robust Wald
//!   statistic above the same threshold (as the falsification's joint test), and a lower
//!   cross-validated residual sum than the cause's.
//!
//! When all hold the cause **partly explains** that equation: it stays named, flagged with the
//! statistics ([`PartlyExplained`]), and the remainder is reported as an unexplained effect with
//! its regressors and coefficients (fitted beside the cause), so "no residual remains" is not
//! said. The search's terms passed its own Bonferroni threshold; the remainder's test beside the
//! cause is then one test of a given form.

use super::Options;
use super::falsify::Levels;
use super::innovation::{
    INNOVATION_LABELS, InnovationCandidates, SensorLinear, innovation_designs,
};
use super::torque::{
    JointTorque, TorqueCandidates, joint_torque, own_form as torque_own_form, torque_designs,
    torque_equation,
};
use super::unexplained::{UnexplainedEffect, effect};
use super::wheel::{WheelCandidates, own_form as wheel_own_form, wheel_designs, wheel_equation};
use crate::effects::{Cause, Kind};
use crate::fit::{Problem, SetFit};
use crate::sparse::{Design, SparseOptions, determined_forced, result_for, search};
use serde::Serialize;

/// A named cause that explains only part of an equation (see the module documentation).
#[derive(Debug, Clone, Serialize)]
pub struct PartlyExplained {
    pub cause: &'static str,
    pub equation: String,
    /// Cross-validated residual sums of the equation (its unit squared): with the cause (and the
    /// terms the search found beside it), of the unrestricted search without it, and of the
    /// cause with the remainder.
    pub cv_cause: f64,
    pub cv_search: f64,
    pub cv_with_remainder: f64,
    /// The unrestricted search's form (`equation ≈ …`).
    pub search_form: String,
    /// The remainder beside the cause (`equation ≈ …`), also an unexplained effect.
    pub remainder: String,
    /// The remainder's significance beside the cause: likelihood ratio, cluster-robust Wald
    /// statistic, the selection's threshold for its degrees of freedom.
    pub lr: f64,
    pub wald: f64,
    pub threshold: f64,
    pub dof: usize,
    /// In words.
    pub verdict: String,
}

/// One equation of a cause's channel: the design with every named cause forced (`with`) and
/// the one with the cause's fitted part put back and its columns not forced (`without`), both
/// over the whole candidate library.
pub(super) struct Equation<'a> {
    pub name: String,
    pub unit: &'static str,
    pub with: &'a Design,
    pub without: &'a Design,
}

/// The guard on one equation of `cause` (own form `own` among the candidates): `None` when the
/// cause does not act there or explains it as well as the unrestricted search. Else the flag and
/// the remainder as an unexplained effect (its terms beside every named cause's columns and the
/// terms the search found with them).
pub(super) fn judge(
    cause: Cause,
    own: &[&str],
    eq: &Equation,
    sparse: &SparseOptions,
    levels: &Levels,
) -> Option<(PartlyExplained, UnexplainedEffect)> {
    let prefix = format!("{}.", cause.name());
    let with = eq.with;
    if !with.names[..with.forced]
        .iter()
        .any(|n| n.starts_with(&prefix))
    {
        return None;
    }
    let found = search(with, sparse);
    let free = search(eq.without, sparse);
    let (cv_cause, cv_search) = (found.cv_rss, free.cv_rss);

    // Held out, the search's form must predict better than the cause (the selection's
    // held-out likelihood ratio above zero).
    if cv_search.partial_cmp(&cv_cause) != Some(std::cmp::Ordering::Less) {
        return None;
    }
    let column = |name: &str| with.names.iter().position(|n| n == name);
    // The base: the determined forced columns and the terms found with the cause.
    let mut base = determined_forced(with);
    let nf = base.len();
    base.extend(found.terms.iter().filter_map(|t| column(&t.name)));
    let extra: Vec<usize> = free
        .terms
        .iter()
        .filter(|t| !own.contains(&t.name.as_str()))
        .filter_map(|t| column(&t.name))
        .filter(|j| !base.contains(j))
        .collect();
    if extra.is_empty() {
        return None;
    }
    let mut cols = base.clone();
    cols.extend(&extra);
    let idx: Vec<usize> = (base.len()..cols.len()).collect();
    // The remainder beside the cause: the selection's test of a cause beside those chosen
    // (likelihood ratio above its threshold on the fit data, better held out), with the
    // cluster-robust Wald statistic as in the falsification's joint test.
    let rows = with.rows() as f64;
    let (lr, threshold) = levels.joint(rows, with.fit_rss(&base)?, with.fit_rss(&cols)?, idx.len());
    let wald = with.wald(&cols, &idx)?;
    let cv_with_remainder = with.cv_rss(&cols)?;
    if !(lr > threshold && wald > threshold && cv_with_remainder < cv_cause) {
        return None;
    }
    let base_cv = with.cv_rss(&cols[..nf]).unwrap_or(with.total_rss());
    let result = result_for(with, nf, &cols, found.z_threshold, base_cv);
    let remainder = effect(eq.name.clone(), eq.unit, result, with)?;
    let search_form = effect(eq.name.clone(), eq.unit, free, eq.without)
        .map_or_else(|| "none".to_string(), |e| e.proposed);
    let verdict = format!(
        "partly explains {}: the unrestricted search without it ({search_form}) predicts better out of fold (cross-validated residual sum {:.4e} against {cv_cause:.4e} with it); beside it remains {} (likelihood ratio {lr:.1}, cluster-robust Wald statistic {wald:.1}, threshold {threshold:.1}; cross-validated residual sum {cv_with_remainder:.4e})",
        eq.name, cv_search, remainder.proposed
    );
    Some((
        PartlyExplained {
            cause: cause.name(),
            equation: eq.name.clone(),
            cv_cause,
            cv_search,
            cv_with_remainder,
            search_form,
            remainder: remainder.proposed.clone(),
            lr,
            wald,
            threshold,
            dof: idx.len(),
            verdict,
        },
        remainder,
    ))
}

/// The guard on every named cause, per equation of its channel (body axis, wheel, innovation
/// component); the channels' candidate libraries `torque`, `wheel` and `sensor` (with the
/// named sensor causes' linearisation; `None`: no sensor cause named, or not linearised). A
/// cause flagged on several equations has one entry per equation.
pub(super) fn causes(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    (torque, wheel, sensor): (
        &TorqueCandidates,
        &WheelCandidates,
        Option<(&InnovationCandidates, &SensorLinear)>,
    ),
    (block_s, sparse): (f64, &SparseOptions),
    levels: &Levels,
) -> Vec<(PartlyExplained, UnexplainedEffect)> {
    let blocks = (block_s, sparse.folds);
    let mut out = Vec::new();
    let guard =
        |cause: Cause, own: &[&str], name: String, unit, with: &Design, without: &Design| {
            let eq = Equation {
                name,
                unit,
                with,
                without,
            };
            judge(cause, own, &eq, sparse, levels)
        };
    let torque_with = torque_designs(problem, fit, named, torque, blocks, None, &[]);
    let wheel_with = wheel_designs(problem, fit, named, wheel, blocks, None, &[]);
    let mut sensor_with = None;
    for &cause in named {
        match cause.kind() {
            Kind::Torque => {
                let (Some(with), Some(without)) = (
                    &torque_with,
                    torque_designs(problem, fit, named, torque, blocks, Some(cause), &[]),
                ) else {
                    continue;
                };
                for ((axis, w), (_, wo)) in with.iter().zip(&without) {
                    let own = torque_own_form(cause);
                    out.extend(guard(cause, own, torque_equation(*axis), "Nm", w, wo));
                }
            }
            Kind::Wheel => {
                let without = wheel_designs(problem, fit, named, wheel, blocks, Some(cause), &[]);
                for ((w, with), (_, wo)) in wheel_with.iter().zip(&without) {
                    let own = wheel_own_form(cause);
                    out.extend(guard(cause, own, wheel_equation(*w), "Nm", with, wo));
                }
            }
            Kind::Sensor => {
                let Some((candidates, linear)) = sensor else {
                    continue;
                };
                let designs = |removed| {
                    innovation_designs(problem, fit, (candidates, Some(linear)), blocks, removed)
                };
                let with = sensor_with.get_or_insert_with(|| designs(None));
                for ((c, w), (_, wo)) in with.iter().zip(&designs(Some(cause))) {
                    let name = INNOVATION_LABELS[*c].to_string();
                    // No candidate is a sensor cause's own form: its effect through the filter
                    // has none of their shapes exactly.
                    out.extend(guard(cause, &[], name, "1 (whitened)", w, wo));
                }
            }
        }
    }
    out
}

/// The guard on the fit `fit` of the named causes `named` after their falsification: each
/// cause flagged, its remainder put among the unexplained `effects` (in place of an effect the
/// search found in that equation, whose terms it includes; one per equation), and the joint
/// fit of the torque causes redone beside the new torque terms.
pub(super) fn apply(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    (options, n_fit): (&Options, f64),
    effects: &mut Vec<UnexplainedEffect>,
    joint: &mut Option<JointTorque>,
) -> Vec<PartlyExplained> {
    if named.is_empty() {
        return Vec::new();
    }
    let levels = Levels::new(options, n_fit);
    let torque = TorqueCandidates::new(problem, fit);
    let wheel = WheelCandidates::new(problem, fit);
    // The sensor causes' linearisation costs a filter run per parameter: only when one is named.
    let linear = named
        .iter()
        .any(|c| c.kind() == Kind::Sensor)
        .then(|| SensorLinear::new(problem, fit, named))
        .flatten();
    let innovation = linear
        .as_ref()
        .map(|_| InnovationCandidates::new(problem, fit));
    let sensor = innovation.as_ref().zip(linear.as_ref());
    let found = causes(
        problem,
        fit,
        named,
        (&torque, &wheel, sensor),
        (options.block_s, &options.sparse),
        &levels,
    );
    let mut out = Vec::new();
    let mut torque_terms = false;
    for (flag, remainder) in found {
        if !out
            .iter()
            .any(|p: &PartlyExplained| p.equation == flag.equation)
        {
            torque_terms |= remainder.equation.starts_with("torque_");
            effects.retain(|e| e.equation != remainder.equation);
            effects.push(remainder);
        }
        out.push(flag);
    }
    if torque_terms {
        *joint = joint_torque(problem, fit, named, effects, &torque);
    }
    out
}

/// The report's summary with a line after each flagged cause's own: `Partly explained: …`.
pub(super) fn annotate(summary: &mut Vec<String>, partly: &[PartlyExplained]) {
    for p in partly.iter().rev() {
        let own = format!("Named cause: {} (", p.cause);
        let at = summary
            .iter()
            .position(|l| l.starts_with(&own))
            .map_or(summary.len(), |i| i + 1);
        summary.insert(at, format!("Partly explained: {} {}.", p.cause, p.verdict));
    }
}
