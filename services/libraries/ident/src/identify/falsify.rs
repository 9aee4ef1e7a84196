//! Falsification of the named causes: a cause is kept only if it survives these tests.
//!
//! 1. **Consistency across time blocks.** The record is cut into `blocks` disjoint blocks of
//!    equal duration; in each, the named torque causes and the unexplained torque terms are
//!    fitted jointly (weighted least squares on the torque channel, the residual variance
//!    estimated in the block). Null: the cause's parameters are the same in every block. The
//!    statistic `χ² = Σ_b (θ_b − θ̄)ᵀ C_b⁻¹ (θ_b − θ̄)` (θ̄ the precision-weighted mean) has
//!    `(blocks − 1)·k` degrees of freedom under the null; the cause fails at `p < alpha`. A
//!    time- or state-dependent effect absorbed into a constant cause makes its blocks disagree.
//! 2. **Significance beside the unexplained effect.** The cause must still beat the selection's
//!    threshold (`max(k ln N, χ²_k(1 − alpha))` on the likelihood ratio of the fit data) when
//!    the unexplained terms are in the model: a library cause that only stood in for an
//!    effect of another form is dropped. Torque causes must beat it by the likelihood ratio
//!    (independent residuals) and by the cluster-robust Wald statistic of their parameters
//!    (residuals correlated within a segment of the torque channel, as the search assumes).
//! 3. **No explanation of another kind** (torque and wheel causes). The channel's search (the
//!    torque search, or the wheel search for a wheel cause) is redone without the cause and
//!    without the candidate functions of its own form. The cause is dropped if
//!    that search's cross-validated residual sum is more than 1 % below the one with it, or if
//!    that sum is not above it and the cause is not significant (the same threshold,
//!    likelihood ratio and cluster-robust Wald) beside the terms that search finds (a search
//!    that predicts worse may have found a mimic of the cause's form: a true constant torque
//!    was lost so): the terms of test 2 were found with the cause
//!    in the model, and a cause that stood in for part of an effect shapes them (a constant
//!    torque takes the offset of a heading torque, and the search then settles on the wrong
//!    harmonic, which leaves a trade between the constant torque and a centre-of-mass offset
//!    that grows significant with the rows of the fit).
//!
//! Torque causes are linear in the torque channel; sensor causes are linearised through the
//! attitude filter (forward differences, one filter run per parameter) and tested on the
//! innovations the same way. Wheel causes are linear (or linearised, the delay) in the wheel
//! equation and are tested there, with the whiteness of that equation's residuals as a fourth
//! test (see `wheel`). [`significance_beside`] and [`compete`] are shared by the torque and
//! wheel channels.

use super::unexplained::{Candidates, INNOVATION_LABELS, TorqueCandidates, UnexplainedEffect};
use crate::channels::torque_columns;
use crate::effects::{Cause, Kind};
use crate::fit::{Problem, SetFit};
use crate::stats::{NormalEquations, chi_square_cdf, chi_square_quantile};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Outcome of the tests of one named cause.
#[derive(Debug, Clone, Serialize)]
pub struct CauseTest {
    pub name: &'static str,
    pub kept: bool,
    /// Consistency across time blocks (`None`: not tested for this kind of cause, or not
    /// determined in every block).
    pub consistency: Option<Consistency>,
    /// Likelihood ratio of the cause beside the unexplained terms, and its threshold (`None`:
    /// no unexplained torque term, the selection's test stands).
    pub joint_lr: Option<f64>,
    /// The cluster-robust Wald statistic of the cause's parameters in the same joint fit
    /// (torque causes; clusters are the torque channel's segments): the likelihood ratio
    /// assumes independent residuals, and the cause must beat the threshold by both.
    pub joint_wald: Option<f64>,
    pub joint_threshold: Option<f64>,
    /// Whiteness of the extended equation's residuals (wheel causes: the wheel equation with
    /// the named causes and the unexplained wheel terms; `None` for other causes).
    pub whiteness: Option<Whiteness>,
    /// The competing explanation (torque and wheel causes; `None`: not run, e.g. the cause had
    /// failed an earlier test, or the channel is too short).
    pub competitor: Option<Competitor>,
    /// The test that failed: `consistency`, `joint` (significance beside the others and the
    /// unexplained effects), `competitor` (a generic form explains its part better),
    /// `whiteness`; `None` when kept.
    pub failed: Option<&'static str>,
    /// In words: kept, or which test failed.
    pub verdict: String,
}

impl CauseTest {
    /// A cause kept on its selection test alone: the falsification tests could not run
    /// (`why`).
    pub(crate) fn not_tested(cause: Cause, why: &str) -> Self {
        Self {
            name: cause.name(),
            kept: true,
            consistency: None,
            joint_lr: None,
            joint_wald: None,
            joint_threshold: None,
            whiteness: None,
            competitor: None,
            failed: None,
            verdict: format!("kept (selection test; {why})"),
        }
    }
}

/// The whiteness test of an equation's residuals (the worst of the wheels tested).
#[derive(Debug, Clone, Serialize)]
pub struct Whiteness {
    /// The worst wheel (0 = X).
    pub wheel: usize,
    /// Ljung–Box statistic and its lags.
    pub ljung_box: f64,
    pub lags: usize,
    /// Its p value, multiplied by the number of wheels tested (Bonferroni), at most 1.
    pub p: f64,
    /// Wheels tested.
    pub wheels: usize,
}

/// The competing-explanation test of one cause: its channel's sparse search redone without
/// the cause and without the candidate functions of its own form.
#[derive(Debug, Clone, Serialize)]
pub struct Competitor {
    /// Cross-validated residual sums of the search with the cause and without it (each
    /// channel's rows whitened by their noise).
    pub cv_with: f64,
    pub cv_without: f64,
    /// The terms the search without it found (`none`).
    pub form: String,
    /// The cause's significance beside those terms: likelihood ratio, cluster-robust Wald
    /// statistic and the selection's threshold (`None`: not computed, because the search
    /// without the cause predicts worse out of fold or the joint fit was not determined).
    pub lr: Option<f64>,
    pub wald: Option<f64>,
    pub threshold: Option<f64>,
}

impl CauseTest {
    /// How clearly the cause failed (for dropping the worst first): the consistency statistic
    /// as a normal score `(χ² − dof)/√(2 dof)`, else how far the likelihood ratio falls short of
    /// its threshold (relative); negative for a kept cause.
    pub fn severity(&self) -> f64 {
        if self.kept {
            return -1.0;
        }
        if let (Some("whiteness"), Some(w)) = (self.failed, &self.whiteness) {
            let dof = w.lags.max(1) as f64;
            return (w.ljung_box - dof) / (2.0 * dof).sqrt();
        }
        match (&self.consistency, self.joint_lr, self.joint_threshold) {
            (Some(c), _, _) if c.p < 1.0 && self.failed == Some("consistency") => {
                (c.chi2 - c.dof as f64) / (2.0 * c.dof as f64).sqrt()
            }
            (_, Some(lr), Some(th)) => {
                1.0 - lr.min(self.joint_wald.unwrap_or(f64::INFINITY)) / th.max(1e-300)
            }
            _ => 0.0,
        }
    }
}

/// The block-consistency test of one cause.
#[derive(Debug, Clone, Serialize)]
pub struct Consistency {
    pub blocks: usize,
    pub chi2: f64,
    pub dof: usize,
    pub p: f64,
    /// Per block: the cause's values (changes from the base configuration, per column) and
    /// standard errors.
    pub values: Vec<Vec<f64>>,
    pub stderr: Vec<Vec<f64>>,
}

/// Joint fit of the torque causes with the unexplained torque terms.
pub(super) struct JointTorque {
    /// Per named torque cause: the fitted change per column and its standard errors (fit data).
    pub delta: Vec<(Cause, Vec<f64>, Vec<f64>)>,
}

/// Columns of the joint torque model: (cause, torque column) of the named causes, and (axis,
/// candidate index) of the unexplained terms.
type JointColumns = (Vec<(Option<Cause>, usize)>, Vec<(usize, usize)>);

/// The design of the joint torque model: named torque causes' columns, then one column per
/// unexplained torque term (on its axis).
fn joint_columns(
    named: &[Cause],
    effects: &[UnexplainedEffect],
    candidates: &TorqueCandidates,
    channel: &crate::channels::TorqueChannel,
) -> JointColumns {
    // (cause, torque column) for named; (axis, candidate index) for the unexplained terms.
    let cols: Vec<(Option<Cause>, usize)> = named
        .iter()
        .filter(|c| c.kind() == Kind::Torque)
        .flat_map(|c| {
            torque_columns(*c)
                .into_iter()
                .flatten()
                .filter(|col| channel.determined(*col))
                .map(move |col| (Some(*c), col))
        })
        .collect();
    let mut extra = Vec::new();
    for e in effects {
        let Some(axis) = e
            .equation
            .strip_prefix("torque_")
            .and_then(|a| "xyz".find(a))
        else {
            continue;
        };
        for t in &e.terms {
            if let Some(j) = candidates.names.iter().position(|n| *n == t.name) {
                extra.push((axis, j));
            }
        }
    }
    (cols, extra)
}

/// One whitened row of the joint torque model, interval `i`, body axis `axis`: the columns
/// `cols` of the causes, then the unexplained terms `extra` (each on its own axis), written
/// into `x`; returns the whitened residual `y`.
fn torque_row(
    fit: &SetFit,
    cols: &[(Option<Cause>, usize)],
    extra: &[(usize, usize)],
    candidates: &TorqueCandidates,
    (i, axis): (usize, usize),
    x: &mut [f64],
) -> f64 {
    let ch = &fit.state.torque;
    let sigma = ch.sigma[axis];
    for (j, &(_, col)) in cols.iter().enumerate() {
        x[j] = ch.x[i][col][axis] / sigma;
    }
    for (j, &(a, c)) in extra.iter().enumerate() {
        x[cols.len() + j] = if a == axis {
            candidates.values[i][c] / sigma
        } else {
            0.0
        };
    }
    ch.y[i][axis] / sigma
}

/// Normal equations of the joint torque model over the rows `keep` accepts.
fn normal_equations(
    fit: &SetFit,
    cols: &[(Option<Cause>, usize)],
    extra: &[(usize, usize)],
    candidates: &TorqueCandidates,
    keep: impl Fn(usize) -> bool,
) -> NormalEquations {
    let ch = &fit.state.torque;
    let p = cols.len() + extra.len();
    let mut ne = NormalEquations::new(p);
    let mut row = vec![0.0; p];
    for i in 0..ch.len() {
        if !keep(i) {
            continue;
        }
        for axis in 0..3 {
            let y = torque_row(fit, cols, extra, candidates, (i, axis), &mut row);
            ne.add(&row, y);
        }
    }
    ne
}

/// How much better (relative drop of the cross-validated residual sum) a competing generic
/// form must explain a named cause's part for the cause to be dropped: ties go to the library
/// cause, the physical explanation.
const COMPETITOR_MARGIN: f64 = 0.01;

/// Settings of the tests.
pub(super) struct Levels<'a> {
    /// Disjoint time blocks of the consistency test.
    pub blocks: usize,
    /// Level of the consistency test.
    pub consistency: f64,
    /// The selection's level (its threshold is `max(k ln N, χ²_k(1 − selection))`).
    pub selection: f64,
    /// `N`: scalar residuals in the fit data.
    pub n_fit: f64,
    /// The unexplained-effect search's blocks and settings (for the competing explanation).
    pub block_s: f64,
    pub sparse: &'a crate::sparse::SparseOptions,
}

impl Levels<'_> {
    /// The test of a cause beside the others: the likelihood ratio `n ln(RSS_without /
    /// RSS_with)` of `n` residuals, and the selection's threshold for its `k` parameters,
    /// `max(k ln N, χ²_k(1 − selection))`.
    pub(super) fn joint(&self, n: f64, rss_without: f64, rss_with: f64, k: usize) -> (f64, f64) {
        let lr = n * (rss_without / rss_with.max(1e-300)).ln();
        let threshold = (k as f64 * self.n_fit.ln())
            .max(chi_square_quantile(1.0 - self.selection, k as f64).unwrap_or(f64::INFINITY));
        (lr, threshold)
    }
}

/// Run both tests on every named cause of `fit`.
pub(super) fn test_causes(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    effects: &[UnexplainedEffect],
    all: &Candidates,
    levels: &Levels,
) -> (Vec<CauseTest>, Option<JointTorque>) {
    let candidates = &all.torque;
    let Levels {
        blocks,
        consistency: alpha_consistency,
        ..
    } = *levels;
    let ch = &fit.state.torque;
    let data = problem.data;
    let (cols, extra) = joint_columns(named, effects, candidates, &fit.state.torque);
    let mut out = Vec::new();
    let mut joint = None;
    if !cols.is_empty() && ch.len() >= 30 {
        let t0 = ch.ticks.first().map_or(0.0, |&k| data.t[k]);
        let t1 = ch.ticks.last().map_or(1.0, |&k| data.t[k]);
        let block_of = |i: usize| -> usize {
            (((data.t[ch.ticks[i]] - t0) / (t1 - t0).max(1e-9) * blocks as f64) as usize)
                .min(blocks - 1)
        };
        let per_block: Vec<Option<crate::stats::LsFit>> = (0..blocks)
            .map(|b| normal_equations(fit, &cols, &extra, candidates, |i| block_of(i) == b).solve())
            .collect();
        let fit_rows = |i: usize| !problem.held_out[ch.ticks[i]];
        let full = normal_equations(fit, &cols, &extra, candidates, fit_rows).solve();
        if let Some(f) = &full {
            let se = f.stderr();
            let mut delta = Vec::new();
            for &cause in named.iter().filter(|c| c.kind() == Kind::Torque) {
                // Every value of the cause: a column not in the fit (not determined) unchanged.
                let at = |col: usize| {
                    (0..cols.len()).find(|&j| cols[j].0 == Some(cause) && cols[j].1 == col)
                };
                let range = torque_columns(cause).unwrap_or(0..0);
                delta.push((
                    cause,
                    range
                        .clone()
                        .map(|col| at(col).map_or(0.0, |j| f.theta[j]))
                        .collect(),
                    range
                        .map(|col| at(col).map_or(f64::NAN, |j| se[j]))
                        .collect(),
                ));
            }
            joint = Some(JointTorque { delta });
        }
        // The torque search with every named cause, computed once for all the competitions.
        let cv_with = super::unexplained::torque_cv_rss(
            problem,
            fit,
            named,
            candidates,
            levels.block_s,
            levels.sparse,
        );
        for &cause in named.iter().filter(|c| c.kind() == Kind::Torque) {
            let idx: Vec<usize> = (0..cols.len())
                .filter(|&j| cols[j].0 == Some(cause))
                .collect();
            let consistency = consistency(&per_block, &idx);
            let mut verdict = String::new();
            let mut kept = true;
            let mut failed = None;
            if let Some(c) = &consistency
                && c.p < alpha_consistency
            {
                kept = false;
                failed = Some("consistency");
                verdict = falsified_text(c, alpha_consistency);
            }
            let (mut joint_lr, mut joint_threshold, mut joint_wald) = (None, None, None);
            {
                // Beside each unexplained effect its offset: a constant part of the cause on
                // that axis cannot be told apart from it. A named constant torque's column on
                // such an axis is that offset: in the constant torque's own test it is replaced
                // by the offset (tested are its other axes), in the others' it stands for it
                // (adding the offset again would make the model singular).
                let effect_axes: Vec<usize> = extra.iter().map(|e| e.0).collect();
                let cols_test: Vec<(Option<Cause>, usize)> = cols
                    .iter()
                    .copied()
                    .filter(|&(c, col)| {
                        !(cause == Cause::ConstantTorque
                            && c == Some(cause)
                            && effect_axes
                                .iter()
                                .any(|&a| ch.x.iter().any(|row| row[col][a] != 0.0)))
                    })
                    .collect();
                let idx_test: Vec<usize> = (0..cols_test.len())
                    .filter(|&j| cols_test[j].0 == Some(cause))
                    .collect();
                let extra_with = with_offsets(&extra, &cols_test, candidates, ch);
                if let Some((lr, threshold, wald)) = torque_significance(
                    fit,
                    &cols_test,
                    &extra_with,
                    candidates,
                    fit_rows,
                    cause,
                    (idx.len(), &idx_test),
                    levels,
                ) {
                    joint_lr = Some(lr);
                    joint_threshold = Some(threshold);
                    joint_wald = wald;
                    if lr <= threshold && kept {
                        kept = false;
                        failed = Some("joint");
                        verdict = format!(
                            "dropped: not significant beside the other named causes and the unexplained effects (likelihood ratio {lr:.1} ≤ threshold {threshold:.1}); it stood in for an effect of another form or for a dropped cause"
                        );
                    } else if let Some(w) = wald.filter(|w| *w <= threshold && kept) {
                        kept = false;
                        failed = Some("joint");
                        verdict = format!(
                            "dropped: not significant beside the other named causes and the unexplained effects once the residuals' correlation within a segment is allowed for (cluster-robust Wald statistic {w:.1} ≤ threshold {threshold:.1}; likelihood ratio {lr:.1}); it stood in for an effect of another form or for a dropped cause"
                        );
                    }
                }
            }
            // Third: no generic form of another kind explains the cause's part as well. The
            // torque search is redone without the cause and its own form (its competitor); the
            // cause is dropped if that search's cross-validated residual sum is more than
            // `COMPETITOR_MARGIN` below the one with it, or, if that sum is not above it, if
            // the cause is not significant beside the terms it finds (the selection's
            // threshold, by the likelihood ratio and
            // by the cluster-robust Wald statistic, as in the joint test). The joint test above
            // takes the terms found *with* the cause, whose form the cause has shaped (a
            // constant torque takes an effect's offset, and the search then settles on another
            // harmonic); here the null model is the best explanation without it.
            let mut competitor = None;
            if kept
                && let Some(with) = cv_with
                && let Some((rival, without)) = super::unexplained::competing_explanation(
                    problem,
                    fit,
                    named,
                    cause,
                    candidates,
                    levels.block_s,
                    levels.sparse,
                )
            {
                let (rival_cols, rival_extra) = joint_columns(named, &rival, candidates, ch);
                debug_assert_eq!(rival_cols, cols);
                let (c, dropped) = compete("torque", with, without, &rival, || {
                    torque_significance(
                        fit,
                        &cols,
                        &rival_extra,
                        candidates,
                        fit_rows,
                        cause,
                        (idx.len(), &idx),
                        levels,
                    )
                });
                if let Some(text) = dropped {
                    kept = false;
                    failed = Some("competitor");
                    verdict = text;
                }
                competitor = Some(c);
            }
            if kept {
                verdict = match &consistency {
                    Some(c) => format!(
                        "kept: consistent across {} time blocks (p = {:.2})",
                        c.blocks, c.p
                    ),
                    None => "kept (block consistency not determined)".into(),
                };
            }
            out.push(CauseTest {
                name: cause.name(),
                kept,
                consistency,
                joint_lr,
                joint_wald,
                joint_threshold,
                whiteness: None,
                competitor,
                failed,
                verdict,
            });
        }
    }
    out.extend(sensor_tests(problem, fit, named, effects, all, levels));
    out.extend(super::wheel::wheel_tests(
        problem, fit, named, effects, &all.wheel, levels,
    ));
    (out, joint)
}

/// The same two tests for the sensor causes, on their linearisation ([`SensorLinear`]): per
/// block one Gauss–Newton step from the fitted values (with the unexplained innovation terms
/// as extra columns) for the consistency, and the likelihood ratio of the innovations with and
/// without the cause (its effect removed to first order, `r − J_c Δθ_c`) beside the unexplained
/// terms for the significance.
fn sensor_tests(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    effects: &[UnexplainedEffect],
    all_candidates: &Candidates,
    levels: &Levels,
) -> Vec<CauseTest> {
    let innovation = &all_candidates.innovation;
    let linear = all_candidates.linear.as_ref();
    let Levels {
        blocks,
        consistency: alpha_consistency,
        ..
    } = *levels;
    let sensor: Vec<Cause> = named
        .iter()
        .copied()
        .filter(|c| c.kind() == Kind::Sensor)
        .collect();
    let not_tested = CauseTest::not_tested;
    let Some(lin) = linear else {
        return sensor
            .iter()
            .map(|c| not_tested(*c, "its linearisation through the filter failed"))
            .collect();
    };
    let data = problem.data;
    let inn = &fit.state.recon.innovations;
    // Unexplained innovation terms: (component, candidate index).
    let mut extra: Vec<(usize, usize)> = Vec::new();
    for e in effects {
        let Some(c) = INNOVATION_LABELS.iter().position(|l| *l == e.equation) else {
            continue;
        };
        for t in &e.terms {
            if let Some(j) = innovation.names.iter().position(|n| *n == t.name) {
                extra.push((c, j));
            }
        }
    }
    let (Some(first), Some(last)) = (inn.first(), inn.last()) else {
        return Vec::new();
    };
    let (t0, t1) = (data.t[first.tick], data.t[last.tick]);
    let block_of = |tick: usize| -> usize {
        (((data.t[tick] - t0) / (t1 - t0).max(1e-9) * blocks as f64) as usize).min(blocks - 1)
    };
    // Rows: (innovation index, component, vector row).
    let rows: Vec<(usize, usize, usize)> = (0..inn.len())
        .flat_map(|i| {
            (0..INNOVATION_LABELS.len())
                .filter(move |&c| innovation.row[i][c] != usize::MAX)
                .map(move |c| (i, c, innovation.row[i][c]))
        })
        .collect();
    // Normal equations of `y ≈ [J_used, U] β` over the rows `keep` accepts, y the innovation
    // with the causes in `removed` taken out to first order.
    let build = |used: &[usize],
                 removed: &[usize],
                 keep: &dyn Fn(usize) -> bool,
                 sign: f64,
                 extra: &[(usize, usize)]| {
        let p = used.len() + extra.len();
        let mut ne = NormalEquations::new(p);
        let mut x = vec![0.0; p];
        for &(i, c, r) in &rows {
            if !keep(inn[i].tick) {
                continue;
            }
            let mut y = inn[i].values[c];
            for &j in removed {
                y -= lin.j[j][r] * lin.delta[j].unwrap_or(0.0);
            }
            for (a, &j) in used.iter().enumerate() {
                x[a] = lin.j[j][r];
            }
            for (a, &(ec, cand)) in extra.iter().enumerate() {
                x[used.len() + a] = if ec == c {
                    innovation.values[i][cand]
                } else {
                    0.0
                };
            }
            ne.add(&x, sign * y);
        }
        ne
    };
    let all: Vec<usize> = (0..lin.cols.len()).collect();
    // For the significance test, each unexplained effect with its offset (see the torque test).
    let mut extra1 = extra.clone();
    if let Some(one) = innovation.names.iter().position(|n| *n == "1") {
        for c in 0..INNOVATION_LABELS.len() {
            if extra.iter().any(|e| e.0 == c) && !extra1.contains(&(c, one)) {
                extra1.push((c, one));
            }
        }
    }
    let mut out = Vec::new();
    for cause in sensor {
        let idx: Vec<usize> = all
            .iter()
            .copied()
            .filter(|&j| lin.cols[j].0 == cause)
            .collect();
        // Consistency: per block, δ_b solving J δ ≈ −r (one Gauss–Newton step).
        let per_block: Vec<Option<crate::stats::LsFit>> = (0..blocks)
            .map(|b| build(&all, &[], &|tick| block_of(tick) == b, -1.0, &extra).solve())
            .collect();
        let consistency = consistency(&per_block, &idx);
        let mut kept = true;
        let mut failed = None;
        let mut verdict = String::new();
        if let Some(c) = &consistency
            && c.p < alpha_consistency
        {
            kept = false;
            failed = Some("consistency");
            verdict = falsified_text(c, alpha_consistency);
        }
        let (mut joint_lr, mut joint_threshold) = (None, None);
        let removable = idx.iter().all(|&j| lin.delta[j].is_some());
        if !extra.is_empty() && removable {
            let fit_rows = |tick: usize| !problem.held_out[tick];
            let others: Vec<usize> = all.iter().copied().filter(|j| !idx.contains(j)).collect();
            let with = build(&all, &idx, &fit_rows, 1.0, &extra1).solve();
            let without = rss_of(&build(&others, &idx, &fit_rows, 1.0, &extra1));
            if let (Some(w), Some(wo)) = (with, without) {
                let (lr, threshold) = levels.joint(w.n as f64, wo, w.rss, idx.len());
                joint_lr = Some(lr);
                joint_threshold = Some(threshold);
                if lr <= threshold && kept {
                    kept = false;
                    failed = Some("joint");
                    verdict = format!(
                        "dropped: not significant once the unexplained effect is modelled (likelihood ratio {lr:.1} ≤ threshold {threshold:.1}); it stood in for an effect of another form"
                    );
                }
            }
        }
        if kept {
            verdict = match &consistency {
                Some(c) => format!(
                    "kept: consistent across {} time blocks (p = {:.2}, linearised through the filter)",
                    c.blocks, c.p
                ),
                None => "kept (block consistency not determined)".into(),
            };
        }
        out.push(CauseTest {
            name: cause.name(),
            kept,
            consistency,
            joint_lr,
            joint_wald: None,
            joint_threshold,
            whiteness: None,
            competitor: None,
            failed,
            verdict,
        });
    }
    out
}

pub(super) fn falsified_text(c: &Consistency, alpha: f64) -> String {
    format!(
        "falsified: its parameters differ between {} time blocks (χ² = {:.1} on {} degrees of freedom, p = {:.1e} < {:.0e}); a time- or state-dependent effect, not a constant one",
        c.blocks, c.chi2, c.dof, c.p, alpha
    )
}

/// The unexplained terms `extra` with each one's axis offset (`1`) added, except on an axis
/// where a named constant torque's column in `cols` is that offset already.
fn with_offsets(
    extra: &[(usize, usize)],
    cols: &[(Option<Cause>, usize)],
    candidates: &TorqueCandidates,
    ch: &crate::channels::TorqueChannel,
) -> Vec<(usize, usize)> {
    let mut out = extra.to_vec();
    let Some(one) = candidates.names.iter().position(|n| *n == "1") else {
        return out;
    };
    for axis in 0..3 {
        let covered = cols.iter().any(|&(c, col)| {
            c == Some(Cause::ConstantTorque) && ch.x.iter().any(|row| row[col][axis] != 0.0)
        });
        if extra.iter().any(|e| e.0 == axis) && !covered && !out.contains(&(axis, one)) {
            out.push((axis, one));
        }
    }
    out
}

/// The rows of a linear equation, for [`significance_beside`]: calls `row(x, y, y_without,
/// cluster)` once per row of the fit data, with `x` the regressors of every column (whitened),
/// `y` the residual the columns are fitted to, `y_without` the residual with the tested cause's
/// part put back (its values at the base configuration; `y` itself where the columns carry the
/// whole cause) and `cluster` the row's cluster (residuals may be correlated within one).
pub(super) type EquationRows<'a> = dyn Fn(&mut RowSink) + 'a;

/// What [`EquationRows`] calls per row: `(x, y, y_without, cluster)`.
pub(super) type RowSink<'a> = dyn FnMut(&[f64], f64, f64, usize) + 'a;

/// How significant a cause is beside the other columns of a linear equation (`p` columns,
/// `rows`): `(likelihood ratio, the selection's threshold for `dof` degrees of freedom,
/// cluster-robust Wald statistic)`. The likelihood ratio sets the fit of every column to `y`
/// against the fit without the cause's columns `idx` to `y_without`; the Wald statistic tests
/// the cause's total change from its base values, `offset + θ_idx` (`offset`: the fitted values'
/// change from the base, zero where the columns carry the whole cause), with the sandwich
/// covariance over `rows`' clusters. `None` when a fit is not determined. Shared by the torque
/// and wheel channels' joint and competitor tests.
pub(super) fn significance_beside(
    rows: &EquationRows,
    p: usize,
    (dof, idx, offset): (usize, &[usize], &[f64]),
    levels: &Levels,
) -> Option<(f64, f64, Option<f64>)> {
    let others: Vec<usize> = (0..p).filter(|j| !idx.contains(j)).collect();
    let mut with = NormalEquations::new(p);
    let mut without = NormalEquations::new(others.len());
    let mut x_without = vec![0.0; others.len()];
    rows(&mut |x, y, y_without, _| {
        with.add(x, y);
        for (a, &j) in others.iter().enumerate() {
            x_without[a] = x[j];
        }
        without.add(&x_without, y_without);
    });
    let f = with.solve()?;
    let rss_without = rss_of(&without)?;
    let (lr, threshold) = levels.joint(with.rows() as f64, rss_without, f.rss, dof);
    // Scores per cluster at the joint solution.
    let mut scores: std::collections::BTreeMap<usize, DVector<f64>> = Default::default();
    rows(&mut |x, y, _, cluster| {
        let e = y - x
            .iter()
            .zip(f.theta.iter())
            .map(|(a, t)| a * t)
            .sum::<f64>();
        let s = scores.entry(cluster).or_insert_with(|| DVector::zeros(p));
        for j in 0..p {
            s[j] += x[j] * e;
        }
    });
    let scores: Vec<DVector<f64>> = scores.into_values().collect();
    let mut total = f.clone();
    for (&j, o) in idx.iter().zip(offset) {
        total.theta[j] += o;
    }
    let wald = total.cluster_robust_wald(&scores, idx);
    Some((lr, threshold, wald))
}

/// [`significance_beside`] in the torque channel: the cause beside the columns `cols` and the
/// unexplained terms `extra`, on the rows `keep` takes (the channel's `y` is the residual of the
/// base model, so the cause's columns carry all of it); clusters are the channel's segments,
/// their three axes together.
#[allow(clippy::too_many_arguments)]
fn torque_significance(
    fit: &SetFit,
    cols: &[(Option<Cause>, usize)],
    extra: &[(usize, usize)],
    candidates: &TorqueCandidates,
    keep: impl Fn(usize) -> bool + Copy,
    cause: Cause,
    (dof, idx): (usize, &[usize]),
    levels: &Levels,
) -> Option<(f64, f64, Option<f64>)> {
    debug_assert!(idx.iter().all(|&j| cols[j].0 == Some(cause)));
    let ch = &fit.state.torque;
    let p = cols.len() + extra.len();
    let rows = |row: &mut RowSink| {
        let mut x = vec![0.0; p];
        for (s, seg) in ch.segments.iter().enumerate() {
            for i in seg.clone().filter(|&i| keep(i)) {
                for axis in 0..3 {
                    let y = torque_row(fit, cols, extra, candidates, (i, axis), &mut x);
                    row(&x, y, y, s);
                }
            }
        }
    };
    significance_beside(&rows, p, (dof, idx, &vec![0.0; idx.len()]), levels)
}

/// The competing explanation's verdict, the same in every channel: the cause is dropped if the
/// search without it (cross-validated residual sum `without`, terms `rival`) predicts more than
/// [`COMPETITOR_MARGIN`] better out of fold than the search with it (`with`), or if it predicts
/// at least as well and the cause is not significant beside its terms (`significance`, see
/// [`significance_beside`]: the likelihood ratio or the cluster-robust Wald statistic at or
/// below the selection's threshold). A search that predicts worse may have found a mimic of the
/// cause's form, so the cause is not tested beside it. Returns the test's outcome and, when the
/// cause is dropped, the verdict.
pub(super) fn compete(
    channel: &str,
    with: f64,
    without: f64,
    rival: &[UnexplainedEffect],
    significance: impl FnOnce() -> Option<(f64, f64, Option<f64>)>,
) -> (Competitor, Option<String>) {
    let form: Vec<&str> = rival.iter().map(|e| e.proposed.as_str()).collect();
    let form = if form.is_empty() {
        "none".to_string()
    } else {
        form.join("; ")
    };
    let mut out = Competitor {
        cv_with: with,
        cv_without: without,
        form,
        lr: None,
        wald: None,
        threshold: None,
    };
    if without < with * (1.0 - COMPETITOR_MARGIN) {
        let text = format!(
            "dropped: a form of another kind explains its part better ({channel} channel's cross-validated residual sum {without:.1} without it, {with:.1} with it: {}); it stood in for that form",
            out.form
        );
        return (out, Some(text));
    }
    if without > with {
        return (out, None);
    }
    // The explanation without it predicts at least as well out of fold: the cause must then
    // add something significant beside its terms.
    let Some((lr, threshold, wald)) = significance() else {
        return (out, None);
    };
    (out.lr, out.wald, out.threshold) = (Some(lr), wald, Some(threshold));
    if lr.min(wald.unwrap_or(f64::INFINITY)) > threshold {
        return (out, None);
    }
    let text = format!(
        "dropped: not significant beside the form of another kind found without it ({}; likelihood ratio {lr:.1}, cluster-robust Wald statistic {}, threshold {threshold:.1}); it stood in for that form",
        out.form,
        wald.map_or("not determined".to_string(), |w| format!("{w:.1}"))
    );
    (out, Some(text))
}

/// Residual sum at the least-squares solution (`Σ y²` with no unknowns).
pub(super) fn rss_of(ne: &NormalEquations) -> Option<f64> {
    if ne.params() == 0 {
        Some(ne.yty())
    } else {
        ne.solve().map(|f| f.rss)
    }
}

/// χ² consistency of the parameters `idx` across the block fits (`None` if a block does not
/// determine them).
pub(super) fn consistency(
    per_block: &[Option<crate::stats::LsFit>],
    idx: &[usize],
) -> Option<Consistency> {
    let k = idx.len();
    let mut thetas = Vec::new();
    let mut weights = Vec::new();
    for f in per_block {
        let f = f.as_ref()?;
        let cov = f.cov();
        let c = DMatrix::from_fn(k, k, |a, b| cov[(idx[a], idx[b])]);
        let w = c.try_inverse()?;
        thetas.push(DVector::from_fn(k, |a, _| f.theta[idx[a]]));
        weights.push(w);
    }
    let wsum: DMatrix<f64> = weights.iter().fold(DMatrix::zeros(k, k), |a, w| a + w);
    let wt: DVector<f64> = weights
        .iter()
        .zip(&thetas)
        .fold(DVector::zeros(k), |a, (w, t)| a + w * t);
    let mean = wsum.try_inverse()? * wt;
    let chi2: f64 = weights
        .iter()
        .zip(&thetas)
        .map(|(w, t)| {
            let d = t - &mean;
            (d.transpose() * w * &d)[(0, 0)]
        })
        .sum();
    let dof = (per_block.len() - 1) * k;
    let p = 1.0 - chi_square_cdf(chi2, dof as f64);
    Some(Consistency {
        blocks: per_block.len(),
        chi2,
        dof,
        p,
        values: thetas.iter().map(|t| t.iter().copied().collect()).collect(),
        stderr: per_block
            .iter()
            .map(|f| {
                f.as_ref()
                    .map(|f| {
                        let se = f.stderr();
                        idx.iter().map(|&j| se[j]).collect()
                    })
                    .unwrap_or_default()
            })
            .collect(),
    })
}
