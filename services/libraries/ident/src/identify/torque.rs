//! The torque channel (the platform's momentum equation per body axis, [`crate::channels`]) as
//! an equation of the unexplained-effect search (its candidate functions: see `equations`),
//! and the falsification of the named torque causes (see `falsify`).

use super::falsify::{
    CauseTest, Evidence, Failures, Levels, RowSink, compete, consistency, falsified_text,
    significance_beside,
};
use super::unexplained::{UnexplainedEffect, competing, fold_of, search_equations};
use crate::channels::{TORQUE_COLUMNS, TorqueChannel, column_cause, torque_columns};
use crate::effects::{Cause, Kind};
use crate::fit::{Problem, SetFit};
use crate::sparse::{Design, Rows, SparseOptions};
use crate::stats::{LsFit, NormalEquations};
use nalgebra::Vector3;
use std::cell::OnceCell;
use testbed_model::attitude;

/// Per-row values of every torque candidate, already in the channel's integral form.
pub(super) struct TorqueCandidates {
    pub names: Vec<&'static str>,
    /// `rows × names.len()`.
    pub values: Vec<Vec<f64>>,
}

const TORQUE_NAMES: [&str; 22] = [
    "1",
    "t",
    "sin tilt_x",
    "sin tilt_y",
    "t·sin tilt_x",
    "t·sin tilt_y",
    "cos ψ",
    "sin ψ",
    "cos 2ψ",
    "sin 2ψ",
    "w_x",
    "w_y",
    "w_z",
    "w_x·|w_x|",
    "w_y·|w_y|",
    "w_z·|w_z|",
    "w_x·w_y",
    "w_y·w_z",
    "w_z·w_x",
    "dw_x/dt",
    "dw_y/dt",
    "dw_z/dt",
];
/// Of [`TORQUE_NAMES`], the first index in derivative (direct) form.
const TORQUE_DIRECT_FROM: usize = 19;

impl TorqueCandidates {
    pub fn new(problem: &Problem, fit: &SetFit) -> Self {
        let data = problem.data;
        let s = &fit.state;
        let ch = &s.torque;
        let t0 = data.t.first().copied().unwrap_or(0.0);
        let span = (data.t.last().copied().unwrap_or(1.0) - t0).max(1e-9);
        let m = TORQUE_NAMES.len();
        let inst = |k: usize| 0.5 * (s.recon.rate[k - 1] + s.recon.rate[k + 1]);
        let integrand = |k: usize| -> Vec<f64> {
            let t = (data.t[k] - t0) / span;
            let g = attitude::gravity_b(&s.recon.q[k]);
            let psi = attitude::heading(&s.recon.q[k]);
            let w = inst(k);
            vec![
                1.0,
                t,
                g.x,
                g.y,
                t * g.x,
                t * g.y,
                psi.cos(),
                psi.sin(),
                (2.0 * psi).cos(),
                (2.0 * psi).sin(),
                w.x,
                w.y,
                w.z,
                w.x * w.x.abs(),
                w.y * w.y.abs(),
                w.z * w.z.abs(),
                w.x * w.y,
                w.y * w.z,
                w.z * w.x,
            ]
        };
        let direct = |k: usize| -> [f64; 3] {
            let w = inst(k);
            [w.x, w.y, w.z]
        };
        let mut values = vec![vec![0.0; m]; ch.len()];
        for seg in &ch.segments {
            let first = seg.start;
            let k0 = ch.ticks[first];
            let d0 = direct(k0);
            let mut acc = [0.0; TORQUE_DIRECT_FROM];
            let mut prev = integrand(k0);
            for r in seg.clone() {
                let k = ch.ticks[r];
                if r > first {
                    let h = 0.5 * (data.t[k] - data.t[ch.ticks[r - 1]]);
                    let f = integrand(k);
                    for j in 0..TORQUE_DIRECT_FROM {
                        acc[j] += h * (prev[j] + f[j]);
                    }
                    prev = f;
                }
                let d = direct(k);
                values[r][..TORQUE_DIRECT_FROM].copy_from_slice(&acc);
                for j in 0..3 {
                    values[r][TORQUE_DIRECT_FROM + j] = d[j] - d0[j];
                }
            }
            let len = seg.len() as f64;
            for j in 0..m {
                let mean = seg.clone().map(|r| values[r][j]).sum::<f64>() / len;
                for r in seg.clone() {
                    values[r][j] -= mean;
                }
            }
        }
        Self {
            names: TORQUE_NAMES.to_vec(),
            values,
        }
    }
}

/// The torque search's cross-validated residual sum (whitened, summed over the three axes)
/// with the named causes `named`: what a competing explanation is measured against.
pub(super) fn torque_cv_rss(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &TorqueCandidates,
    block_s: f64,
    options: &SparseOptions,
) -> Option<f64> {
    search_torque(problem, fit, named, candidates, block_s, options, None).1
}

/// The competing explanation of a named torque cause: the torque search redone without it
/// (its fitted part put back into the residual) and without the candidate functions that are
/// the cause's own form (`1` for a constant torque, the tilt terms for a centre-of-mass offset,
/// rates for drag, accelerations and rate products for the inertia). Returns the effects it
/// finds and its cross-validated residual sum, to set against [`torque_cv_rss`] with the
/// cause: a cause whose part a generic form of another kind explains better stood in for that
/// form.
pub(super) fn competing_explanation(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    cause: Cause,
    candidates: &TorqueCandidates,
    block_s: f64,
    options: &SparseOptions,
) -> Option<(Vec<UnexplainedEffect>, f64)> {
    competing(named, cause, |others| {
        search_torque(
            problem,
            fit,
            others,
            candidates,
            block_s,
            options,
            Some(cause),
        )
    })
}

/// The terms of `effects` that are not functions of time (`t`, `t·…`), the effects left
/// with none dropped.
fn not_of_time(effects: &[UnexplainedEffect]) -> Vec<UnexplainedEffect> {
    effects
        .iter()
        .filter_map(|e| {
            let mut e = e.clone();
            e.terms
                .retain(|t| t.name != "t" && !t.name.starts_with("t·"));
            (!e.terms.is_empty()).then_some(e)
        })
        .collect()
}

/// The cause's own form among the torque candidates (excluded from its competitor).
pub(super) fn own_form(cause: Cause) -> &'static [&'static str] {
    match cause {
        Cause::ConstantTorque => &["1"],
        Cause::ComOffset => &["1", "sin tilt_x", "sin tilt_y"],
        Cause::ComDrift => &["t", "t·sin tilt_x", "t·sin tilt_y"],
        Cause::AeroDrag => &["w_x", "w_y", "w_z", "w_x·|w_x|", "w_y·|w_y|", "w_z·|w_z|"],
        Cause::InertiaError => &[
            "dw_x/dt", "dw_y/dt", "dw_z/dt", "w_x·w_y", "w_y·w_z", "w_z·w_x",
        ],
        _ => &[],
    }
}

/// The torque search; with `removed` the residual has that cause's fitted part put back and
/// its own form is not a candidate. Also the cross-validated residual sum over the axes,
/// whitened by each axis's noise (`None` if the channel is too short).
pub(super) fn search_torque(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &TorqueCandidates,
    block_s: f64,
    options: &SparseOptions,
    removed: Option<Cause>,
) -> (Vec<UnexplainedEffect>, Option<f64>) {
    let excluded: &[&str] = removed.map_or(&[], own_form);
    let Some(designs) = torque_designs(
        problem,
        fit,
        named,
        candidates,
        (block_s, options.folds),
        removed,
        excluded,
        &[],
    ) else {
        return (Vec::new(), None);
    };
    let sigma = fit.state.torque.sigma;
    search_equations(
        designs
            .into_iter()
            .map(|(axis, design)| (torque_equation(axis), sigma[axis] * sigma[axis], design)),
        options,
    )
}

/// Name of the torque channel's equation about body axis `axis`: `torque_x` …
pub(super) fn torque_equation(axis: usize) -> String {
    format!("torque_{}", "xyz".as_bytes()[axis.min(2)] as char)
}

/// The torque search's equations, one design per body axis: the named causes' columns that act
/// on it forced, then the columns `sensor` (a sensor cause's parameters through the estimated
/// state, per row of the channel, forced too), then the candidates but those named in
/// `excluded`; with `removed` the residual has that cause's fitted part put back (and its
/// columns are not forced). `(block_s, folds)`: the clusters' blocks and the cross-validation's
/// folds. `None` if the channel is too short.
#[allow(clippy::too_many_arguments)]
pub(super) fn torque_designs(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &TorqueCandidates,
    (block_s, folds): (f64, usize),
    removed: Option<Cause>,
    excluded: &[&str],
    sensor: &[(String, &[Vector3<f64>])],
) -> Option<Vec<(usize, Design)>> {
    let data = problem.data;
    let ch = &fit.state.torque;
    if ch.len() < 30 {
        return None;
    }
    let mut delta = fit.torque_delta;
    if let Some(range) = removed.and_then(torque_columns) {
        for d in &mut delta[range] {
            *d = 0.0;
        }
    }
    let kept_candidates: Vec<usize> = (0..candidates.names.len())
        .filter(|&j| !excluded.contains(&candidates.names[j]))
        .collect();
    let named_cols: Vec<usize> = named
        .iter()
        .filter(|c| c.kind() == Kind::Torque && Some(**c) != removed)
        .flat_map(|c| torque_columns(*c).into_iter().flatten())
        .collect();
    let mut segment_of = vec![0; ch.len()];
    for (s, seg) in ch.segments.iter().enumerate() {
        for r in seg.clone() {
            segment_of[r] = s;
        }
    }
    let fold: Vec<usize> = (0..ch.len())
        .map(|r| fold_of(data.t[ch.ticks[ch.segments[segment_of[r]].start]], block_s))
        .collect();
    let held: Vec<bool> = ch.ticks.iter().map(|&k| problem.held_out[k]).collect();
    let mut out = Vec::new();
    for axis in 0..3 {
        // The named causes' columns that act on this axis.
        let forced: Vec<usize> = named_cols
            .iter()
            .copied()
            .filter(|&c| ch.x.iter().any(|row| row[c][axis] != 0.0))
            .collect();
        let mut names: Vec<String> = forced.iter().map(|&c| column_name(c)).collect();
        names.extend(sensor.iter().map(|(name, _)| name.clone()));
        names.extend(
            kept_candidates
                .iter()
                .map(|&j| candidates.names[j].to_string()),
        );
        let x: Vec<Vec<f64>> = (0..ch.len())
            .map(|r| {
                let mut row: Vec<f64> = forced.iter().map(|&c| ch.x[r][c][axis]).collect();
                row.extend(sensor.iter().map(|(_, column)| column[r][axis]));
                row.extend(kept_candidates.iter().map(|&j| candidates.values[r][j]));
                row
            })
            .collect();
        let y: Vec<f64> = (0..ch.len())
            .map(|r| ch.whitened(r, &delta)[axis] * ch.sigma[axis])
            .collect();
        let rows = Rows {
            x: &x,
            y: &y,
            cluster: &segment_of,
            fold: &fold,
            held_out: &held,
        };
        out.push((
            axis,
            Design::new(names, forced.len() + sensor.len(), rows, folds),
        ));
    }
    Some(out)
}

/// Name of a torque column (`com_offset.r_m[0]` …).
pub(super) fn column_name(col: usize) -> String {
    debug_assert!(col < TORQUE_COLUMNS);
    let (cause, off) = column_cause(col);
    cause.value_name(off)
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
    channel: &TorqueChannel,
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

/// The falsification tests of the named torque causes (see `falsify`); also their joint fit
/// with the unexplained torque terms `effects`.
pub(super) fn torque_tests(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    effects: &[UnexplainedEffect],
    candidates: &TorqueCandidates,
    levels: &Levels,
) -> (Vec<CauseTest>, Option<JointTorque>) {
    let Levels {
        blocks,
        consistency: alpha_consistency,
        ..
    } = *levels;
    let ch = &fit.state.torque;
    let data = problem.data;
    let (cols, extra) = joint_columns(named, effects, candidates, &fit.state.torque);
    let mut out = Vec::new();
    if cols.is_empty() || ch.len() < 30 {
        return (out, None);
    }
    let t0 = ch.ticks.first().map_or(0.0, |&k| data.t[k]);
    let t1 = ch.ticks.last().map_or(1.0, |&k| data.t[k]);
    let block_of = |i: usize| -> usize {
        (((data.t[ch.ticks[i]] - t0) / (t1 - t0).max(1e-9) * blocks as f64) as usize)
            .min(blocks - 1)
    };
    let per_block: Vec<Option<LsFit>> = (0..blocks)
        .map(|b| normal_equations(fit, &cols, &extra, candidates, |i| block_of(i) == b).solve())
        .collect();
    let fit_rows = |i: usize| !problem.held_out[ch.ticks[i]];
    let joint = joint_fit(problem, fit, named, &cols, &extra, candidates);
    // The torque search with every named cause, computed once for all the competitions.
    let cv_with = torque_cv_rss(
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
        // The search without the cause and its own form, for the consistency test's second
        // look and the competition: computed when first needed.
        let competitor = OnceCell::new();
        let competitor = || {
            competitor
                .get_or_init(|| {
                    competing_explanation(
                        problem,
                        fit,
                        named,
                        cause,
                        candidates,
                        levels.block_s,
                        levels.sparse,
                    )
                })
                .as_ref()
        };
        let span = (t1 - t0) / blocks as f64;
        let mut evidence = Evidence {
            consistency: consistency(&per_block, &idx, span),
            ..Evidence::default()
        };
        // Blocks that disagree without a trend may disagree only because an effect of another
        // form, which the search with the cause in the model did not reach, changes from block
        // to block (a heading torque over each block's headings): the blocks are compared
        // again beside the terms of the search without the cause and its own form, but for
        // functions of time (what the blocks test; without `1` the search takes `t` for a
        // constant). The cause is kept if they agree there; the guard then reports the
        // remainder.
        if let Some(c) = &evidence.consistency
            && c.p < alpha_consistency
            && !c
                .trend
                .as_ref()
                .is_some_and(|t| t.drifts(alpha_consistency))
            && let Some((rival, _)) = competitor()
            && let beside_terms = not_of_time(rival)
            && !beside_terms.is_empty()
        {
            let (_, rival_extra) = joint_columns(named, &beside_terms, candidates, ch);
            let beside: Vec<Option<LsFit>> = (0..blocks)
                .map(|b| {
                    normal_equations(fit, &cols, &rival_extra, candidates, |i| block_of(i) == b)
                        .solve()
                })
                .collect();
            if let Some(mut again) = consistency(&beside, &idx, span)
                && again.p >= alpha_consistency
            {
                again.beside = beside_terms
                    .iter()
                    .flat_map(|e| {
                        e.terms
                            .iter()
                            .map(|t| format!("{}: {}", e.equation, t.name))
                    })
                    .collect();
                evidence.consistency = Some(again);
            }
        }
        let mut failures = Failures::default();
        if let Some(c) = &evidence.consistency
            && c.p < alpha_consistency
        {
            failures.add("consistency", falsified_text(c, alpha_consistency));
        }
        // Beside each unexplained effect its offset: a constant part of the cause on that axis
        // cannot be told apart from it. A named constant torque's column on such an axis is
        // that offset: in the constant torque's own test it is replaced by the offset (tested
        // are its other axes) where the effect's terms take up much of a constant (a heading
        // torque's mean over the experiment's headings), in the others' it stands for it
        // (adding the offset again would make the model singular). Where they take up little
        // of it (rates, their derivatives), the constant is no part of the effect and is
        // tested there.
        let cols_test: Vec<(Option<Cause>, usize)> = cols
            .iter()
            .copied()
            .filter(|&(c, col)| {
                !(cause == Cause::ConstantTorque
                    && c == Some(cause)
                    && (0..3).any(|a| {
                        ch.x.iter().any(|row| row[col][a] != 0.0)
                            && share_of_constant(ch, candidates, (col, a), &extra)
                                >= CONSTANT_IN_EFFECT
                    }))
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
            evidence.joint_lr = Some(lr);
            evidence.joint_threshold = Some(threshold);
            evidence.joint_wald = wald;
            if lr <= threshold && failures.none() {
                failures.add(
                    "joint",
                    format!(
                        "dropped: not significant beside the other named causes and the unexplained effects (likelihood ratio {lr:.1} ≤ threshold {threshold:.1}); it stood in for an effect of another form or for a dropped cause"
                    ),
                );
            } else if let Some(w) = wald.filter(|w| *w <= threshold && failures.none()) {
                failures.add(
                    "joint",
                    format!(
                        "dropped: not significant beside the other named causes and the unexplained effects once the residuals' correlation within a segment is allowed for (cluster-robust Wald statistic {w:.1} ≤ threshold {threshold:.1}; likelihood ratio {lr:.1}); it stood in for an effect of another form or for a dropped cause"
                    ),
                );
            }
        }
        // Third: no generic form of another kind explains the cause's part as well. The torque
        // search is redone without the cause and its own form (its competitor); the cause is
        // dropped if that search's cross-validated residual sum is more than the competitor
        // margin (`falsify::compete`) below the one with it, or, if that sum is not above it, if
        // the cause is not significant beside the terms it finds (the selection's threshold, by
        // the likelihood ratio and by the cluster-robust Wald statistic, as in the joint test).
        // The joint test above takes the terms found *with* the cause, whose form the cause has
        // shaped (a constant torque takes an effect's offset, and the search then settles on
        // another harmonic); here the null model is the best explanation without it.
        if failures.none()
            && let Some(with) = cv_with
            && let Some((rival, without)) = competitor()
        {
            let (rival_cols, rival_extra) = joint_columns(named, rival, candidates, ch);
            debug_assert_eq!(rival_cols, cols);
            let (c, dropped) = compete("torque", with, *without, rival, || {
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
                failures.add("competitor", text);
            }
            evidence.competitor = Some(c);
        }
        out.push(CauseTest::verdict(cause, evidence, failures, |c| {
            let beside = if c.beside.is_empty() {
                String::new()
            } else {
                format!(
                    " beside the terms of another form the search without it finds ({}), not without them",
                    c.beside.join("; ")
                )
            };
            format!(
                "kept: consistent across {} time blocks (p = {:.2}){beside}",
                c.blocks, c.p
            )
        }));
    }
    (out, joint)
}

/// The joint fit of the named torque causes with the unexplained torque terms of `effects`
/// (`None`: no named torque cause, a short channel, or not determined).
pub(super) fn joint_torque(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    effects: &[UnexplainedEffect],
    candidates: &TorqueCandidates,
) -> Option<JointTorque> {
    let ch = &fit.state.torque;
    let (cols, extra) = joint_columns(named, effects, candidates, ch);
    if cols.is_empty() || ch.len() < 30 {
        return None;
    }
    joint_fit(problem, fit, named, &cols, &extra, candidates)
}

/// [`joint_torque`] on the joint model's columns `cols` and terms `extra`, on the fit rows.
fn joint_fit(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    cols: &[(Option<Cause>, usize)],
    extra: &[(usize, usize)],
    candidates: &TorqueCandidates,
) -> Option<JointTorque> {
    let ch = &fit.state.torque;
    let fit_rows = |i: usize| !problem.held_out[ch.ticks[i]];
    let f = normal_equations(fit, cols, extra, candidates, fit_rows).solve()?;
    let se = f.stderr();
    let mut delta = Vec::new();
    for &cause in named.iter().filter(|c| c.kind() == Kind::Torque) {
        // Every value of the cause: a column not in the fit (not determined) unchanged.
        let at =
            |col: usize| (0..cols.len()).find(|&j| cols[j].0 == Some(cause) && cols[j].1 == col);
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
    Some(JointTorque { delta })
}

/// Share of a constant torque's column above which the unexplained terms on its axis are
/// taken to hold a constant part of their own (the constant is then not tested on that axis
/// beside them; see [`torque_tests`]).
const CONSTANT_IN_EFFECT: f64 = 0.5;

/// The share of the torque column `col` on `axis` (a constant torque's: a ramp in each
/// segment) that the unexplained terms of `extra` on that axis take up, over all rows: `R²` of
/// the column regressed on them; 0 without terms there.
fn share_of_constant(
    ch: &TorqueChannel,
    candidates: &TorqueCandidates,
    (col, axis): (usize, usize),
    extra: &[(usize, usize)],
) -> f64 {
    let terms: Vec<usize> = extra.iter().filter(|e| e.0 == axis).map(|e| e.1).collect();
    if terms.is_empty() {
        return 0.0;
    }
    let mut ne = NormalEquations::new(terms.len());
    let mut total = 0.0;
    let mut row = vec![0.0; terms.len()];
    for (r, x) in ch.x.iter().enumerate() {
        let y = x[col][axis];
        for (v, &j) in row.iter_mut().zip(&terms) {
            *v = candidates.values[r][j];
        }
        ne.add(&row, y);
        total += y * y;
    }
    match ne.solve() {
        Some(fit) if total > 0.0 => (1.0 - fit.rss / total).clamp(0.0, 1.0),
        // Terms the rows do not determine take up all of it.
        _ => 1.0,
    }
}

/// The unexplained terms `extra` with each one's axis offset (`1`) added, except on an axis
/// where a named constant torque's column in `cols` is that offset already.
fn with_offsets(
    extra: &[(usize, usize)],
    cols: &[(Option<Cause>, usize)],
    candidates: &TorqueCandidates,
    ch: &TorqueChannel,
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
