//! The wheel channel as an equation of the unexplained-effect search, and the falsification of
//! the named wheel causes.
//!
//! **Equation** (per wheel i, [`crate::channels::WheelChannel`]): over one tick interval the
//! spin equation's residual
//! `y = J Δ(n_i + w_i) − s ∫ clamp(τ(t − d)) dt + ∫ T_f(n) dt` (Nms) under the fitted model:
//! measured change of the wheel's momentum minus what the commanded torque and the modelled
//! friction predict. Rows are every other interval (white under the model), without the
//! intervals in which the wheel may have stuck or was near its speed limit.
//!
//! **Candidate functions** f (each entering as `∫ f dt` over the interval, so a coefficient is a
//! torque on the wheel per unit of f, Nm; positive accelerates the wheel in its positive sense):
//!
//! | name | function |
//! |---|---|
//! | `1` | constant |
//! | `t` | time from the record's start over its duration (0 … 1) |
//! | `sign n` | direction of the wheel's spin (a Coulomb level) |
//! | `n` | the wheel's speed relative to the platform, rad/s |
//! | `n·|n|` | quadratic drag (windage) |
//! | `n²` | an even function of the speed (e.g. an imbalance that does not change sign) |
//! | `τ` | the commanded torque (clamped to the drive's limit, at the model's delay), Nm |
//! | `sin tilt_x`, `sin tilt_y` | horizontal components of the down vector in body axes |
//! | `cos ψ`, `sin ψ` | heading harmonics |
//! | `w_x`, `w_y`, `w_z` | body rates, rad/s |
//!
//! Speed functions are integrated with the speed linear over the interval (Gauss–Legendre),
//! the others with the trapezoid rule. The named wheel causes' own regressors (at their fitted
//! values) are forced columns, so their parameters re-adjust with any new term.
//!
//! **Falsification of the wheel causes** (same statistics as the torque causes'): the wheel
//! equation linearised at the fitted values, with the unexplained wheel terms as extra columns,
//! is fitted per time block (a column not determined in every block is held at its fitted
//! value); the cause's parameters must agree across the blocks within their standard errors
//! (χ², `p ≥ consistency_alpha`). Beside unexplained wheel terms the cause must beat the
//! selection's threshold on the likelihood ratio (its part put back into the residual), and the
//! residuals of the extended wheel equation must be white on the wheels the cause acts on
//! (Ljung–Box over [`WHITENESS_LAGS`] lags, Bonferroni over the wheels, `p ≥ consistency_alpha`).
//! The competing explanation (the torque causes' third test, `falsify::compete`): the wheel
//! search is redone without the cause (its values at the base configuration) and without its
//! own form ([`own_form`]); the cause is dropped if that search predicts more than 1 % better
//! out of fold, or at least as well while the cause is not significant beside the terms it
//! finds (likelihood ratio, and the cluster-robust Wald statistic of the cause's change from
//! the base, clusters a third of a block shared by the wheels). Of the failed tests the
//! competitor is reported first: it names the form the cause stood in for.

use super::falsify::{
    CauseTest, Evidence, Failures, Levels, RowSink, Whiteness, compete, consistency,
    falsified_text, rss_of, significance_beside,
};
use super::unexplained::{UnexplainedEffect, competing, fold_of, search_equations};
use crate::channels::{WheelChannel, WheelInterval, friction_regressors, speed_integral};
use crate::effects::{Cause, Kind};
use crate::fit::{Problem, SetFit, WheelModel};
use crate::sparse::{Design, Rows, SparseOptions};
use crate::stats::{NormalEquations, chi_square_cdf, series_stats};
use testbed_model::ModelConfig;

/// Names of the wheel channel's candidate functions (see the module documentation).
pub(super) const WHEEL_NAMES: [&str; 14] = [
    "1",
    "t",
    "sign n",
    "n",
    "n·|n|",
    "n²",
    "τ",
    "sin tilt_x",
    "sin tilt_y",
    "cos ψ",
    "sin ψ",
    "w_x",
    "w_y",
    "w_z",
];

/// Lags of the whiteness test of the extended wheel equation's residuals.
pub const WHITENESS_LAGS: usize = 10;

/// Per wheel and row of the wheel channel: every candidate's `∫ f dt`, s × unit of f.
pub(super) struct WheelCandidates {
    pub names: Vec<&'static str>,
    /// `values[wheel][row][candidate]`.
    pub values: [Vec<Vec<f64>>; 3],
}

impl WheelCandidates {
    pub fn new(problem: &Problem, fit: &SetFit) -> Self {
        let data = problem.data;
        let s = &fit.state;
        let ch = &s.wheel;
        let model = WheelModel::from_config(&fit.config);
        let t0 = data.t.first().copied().unwrap_or(0.0);
        let span = (data.t.last().copied().unwrap_or(1.0) - t0).max(1e-9);
        let values = std::array::from_fn(|w| {
            ch.rows[w]
                .iter()
                .map(|row| {
                    let dt = row.t1 - row.t0;
                    let tm = (0.5 * (row.t0 + row.t1) - t0) / span;
                    let tau =
                        data.wheel_cmd_integral(row.t0, row.t1, model.delay_s, ch.max_torque_nm)[w];
                    let mut v = vec![
                        dt,
                        tm * dt,
                        row.n0.signum() * dt,
                        speed_integral(row, |n| n),
                        speed_integral(row, |n| n * n.abs()),
                        speed_integral(row, |n| n * n),
                        tau,
                    ];
                    v.extend(row.platform.iter().map(|p| p * dt));
                    v
                })
                .collect()
        });
        Self {
            names: WHEEL_NAMES.to_vec(),
            values,
        }
    }
}

/// The named wheel causes' regressors of wheel `w` at one row: `(cause, value index, x)` with
/// `x = −∂y/∂θ` (the coefficient of a column is the change of that value that removes the
/// residual), at the fitted `model`. Always the same list for a wheel, whatever the row.
fn named_regressors(
    problem: &Problem,
    ch: &WheelChannel,
    model: &WheelModel,
    named: &[Cause],
    w: usize,
    row: &WheelInterval,
) -> Vec<(Cause, usize, f64)> {
    let data = problem.data;
    let mut out = Vec::new();
    for &cause in named.iter().filter(|c| c.kind() == Kind::Wheel) {
        match cause {
            Cause::WheelTorqueScale => {
                let tau =
                    data.wheel_cmd_integral(row.t0, row.t1, model.delay_s, ch.max_torque_nm)[w];
                out.push((cause, w, tau));
            }
            Cause::WheelFriction => {
                let f = &model.friction[w];
                // The Stribeck level only where the fit chose the Stribeck model (a Stribeck
                // speed of at least the fit's search range's 0.02 rad/s).
                let ns = f.stribeck_speed_rad_s.filter(|ns| *ns >= 0.02);
                let r = friction_regressors(row, ns);
                out.push((cause, w, -r[0]));
                out.push((cause, 3 + w, -r[1]));
                out.push((cause, 6 + w, -r[3]));
                if ns.is_some() {
                    out.push((cause, 9 + w, -r[2]));
                }
            }
            Cause::ActuatorDelay => {
                let h = 0.02;
                let lo = (model.delay_s - h).max(0.0);
                let hi = model.delay_s + h;
                let tau = |d: f64| data.wheel_cmd_integral(row.t0, row.t1, d, ch.max_torque_nm)[w];
                out.push((cause, 0, model.scale[w] * (tau(hi) - tau(lo)) / (hi - lo)));
            }
            _ => {}
        }
    }
    out
}

/// Search each wheel's equation for what the fit `fit` (of the named causes `named`) leaves.
pub(super) fn search_wheels(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &WheelCandidates,
    block_s: f64,
    options: &SparseOptions,
) -> Vec<UnexplainedEffect> {
    search(problem, fit, named, candidates, block_s, options, None).0
}

/// The competing explanation of a named wheel cause: the wheel search redone without it (its
/// fitted part put back into the residual: its values at the base configuration) and without
/// the candidate functions of its own form ([`own_form`]). Returns the effects it finds and its
/// cross-validated residual sum, to set against [`wheel_cv_rss`] with the cause.
pub(super) fn competing_explanation(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    cause: Cause,
    candidates: &WheelCandidates,
    block_s: f64,
    options: &SparseOptions,
) -> Option<(Vec<UnexplainedEffect>, f64)> {
    competing(named, cause, |others| {
        search(
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

/// The wheel search's cross-validated residual sum (whitened by the channel's noise, summed
/// over the wheels searched) with the named causes `named`.
pub(super) fn wheel_cv_rss(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &WheelCandidates,
    block_s: f64,
    options: &SparseOptions,
) -> Option<f64> {
    search(problem, fit, named, candidates, block_s, options, None).1
}

/// A wheel cause's own form among the wheel candidates (excluded from its competitor): the
/// friction's Coulomb levels (`1` and `sign n` span the levels of the two directions) and its
/// viscous level `n`, the torque scale's `τ`. The delay's own form (the change of the command
/// over the delay) is not a candidate.
pub(super) fn own_form(cause: Cause) -> &'static [&'static str] {
    match cause {
        Cause::WheelFriction => &["1", "sign n", "n"],
        Cause::WheelTorqueScale => &["τ"],
        _ => &[],
    }
}

/// The wheel search; with `removed` the residual has that cause at its base values (its fitted
/// part put back) and its own form is not a candidate. Also the cross-validated residual sum
/// over the wheels searched, whitened by the channel's noise (`None` if no wheel has enough
/// rows).
fn search(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &WheelCandidates,
    block_s: f64,
    options: &SparseOptions,
    removed: Option<Cause>,
) -> (Vec<UnexplainedEffect>, Option<f64>) {
    let excluded: &[&str] = removed.map_or(&[], own_form);
    let designs = wheel_designs(
        problem,
        fit,
        named,
        candidates,
        (block_s, options.folds),
        removed,
        excluded,
    );
    let sigma2 = fit.state.wheel.sigma.max(1e-300).powi(2);
    search_equations(
        designs
            .into_iter()
            .map(|(w, design)| (wheel_equation(w), sigma2, design)),
        options,
    )
}

/// The wheel search's equations, one design per wheel with enough rows: the named wheel causes'
/// regressors forced, then the candidates but those named in `excluded`; with `removed` the
/// residual has that cause at its base values (its fitted part put back, its columns not
/// forced). `(block_s, folds)`: the clusters' blocks and the cross-validation's folds.
pub(super) fn wheel_designs(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &WheelCandidates,
    (block_s, folds): (f64, usize),
    removed: Option<Cause>,
    excluded: &[&str],
) -> Vec<(usize, Design)> {
    let data = problem.data;
    let ch = &fit.state.wheel;
    let mut config = fit.config.clone();
    if let Some(cause) = removed {
        cause.apply(&mut config, &cause.values(&problem.base));
    }
    let named: Vec<Cause> = named
        .iter()
        .copied()
        .filter(|c| Some(*c) != removed)
        .collect();
    let model = WheelModel::from_config(&config);
    let kept_candidates: Vec<usize> = (0..candidates.names.len())
        .filter(|&j| !excluded.contains(&candidates.names[j]))
        .collect();
    let mut out = Vec::new();
    for w in 0..3 {
        let rows = &ch.rows[w];
        if rows.len() < 100 {
            continue;
        }
        let forced_rows: Vec<Vec<(Cause, usize, f64)>> = rows
            .iter()
            .map(|row| named_regressors(problem, ch, &model, &named, w, row))
            .collect();
        // Forced columns that the data determine (a direction the wheel never turns in leaves
        // its Coulomb column zero).
        let nf = forced_rows.first().map_or(0, Vec::len);
        let ssq: Vec<f64> = (0..nf)
            .map(|j| forced_rows.iter().map(|r| r[j].2 * r[j].2).sum())
            .collect();
        let max = ssq.iter().copied().fold(0.0, f64::max);
        let forced: Vec<usize> = (0..nf).filter(|&j| ssq[j] > 1e-12 * max).collect();
        let mut names: Vec<String> = forced
            .iter()
            .filter_map(|&j| forced_rows.first().map(|r| r[j].0.value_name(r[j].1)))
            .collect();
        names.extend(
            kept_candidates
                .iter()
                .map(|&j| candidates.names[j].to_string()),
        );
        let x: Vec<Vec<f64>> = (0..rows.len())
            .map(|r| {
                let mut v: Vec<f64> = forced.iter().map(|&j| forced_rows[r][j].2).collect();
                v.extend(kept_candidates.iter().map(|&j| candidates.values[w][r][j]));
                v
            })
            .collect();
        let y: Vec<f64> = rows
            .iter()
            .map(|row| model.residual(data, ch, w, row))
            .collect();
        // Clusters of a third of a block (never across a fit / held-out change), folds of a
        // block, as in the sensor channels.
        let cluster: Vec<usize> = rows.iter().map(|r| fold_of(r.t0, block_s / 3.0)).collect();
        let fold: Vec<usize> = rows.iter().map(|r| fold_of(r.t0, block_s)).collect();
        let held: Vec<bool> = rows.iter().map(|r| problem.held_out[r.k]).collect();
        let design = Design::new(
            names,
            forced.len(),
            Rows {
                x: &x,
                y: &y,
                cluster: &cluster,
                fold: &fold,
                held_out: &held,
            },
            folds,
        );
        out.push((w, design));
    }
    out
}

/// Name of wheel `w`'s equation: `wheel_x`, `wheel_y`, `wheel_z`.
pub(super) fn wheel_equation(w: usize) -> String {
    format!("wheel_{}", "xyz".as_bytes()[w.min(2)] as char)
}

/// One row of the linearised wheel equation: wheel, time, residual (whitened) and the named
/// causes' regressors.
struct LinRow {
    wheel: usize,
    k: usize,
    t: f64,
    y: f64,
    /// The named causes' regressors `(cause, value index, x)`, whitened.
    named: Vec<(Cause, usize, f64)>,
    /// Index of the row in its wheel's rows.
    index: usize,
}

/// The falsification tests of the named wheel causes (see the module documentation).
pub(super) fn wheel_tests(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    effects: &[UnexplainedEffect],
    candidates: &WheelCandidates,
    levels: &Levels,
) -> Vec<CauseTest> {
    let wheel_causes: Vec<Cause> = named
        .iter()
        .copied()
        .filter(|c| c.kind() == Kind::Wheel)
        .collect();
    let not_tested = CauseTest::not_tested;
    let ch = &fit.state.wheel;
    if wheel_causes.is_empty() {
        return Vec::new();
    }
    if ch.len() < 30 {
        return wheel_causes
            .iter()
            .map(|c| not_tested(*c, "too few wheel-channel rows to test"))
            .collect();
    }
    let data = problem.data;
    let model = WheelModel::from_config(&fit.config);
    let sigma = ch.sigma.max(1e-300);
    let rows: Vec<LinRow> = (0..3)
        .flat_map(|w| {
            ch.rows[w]
                .iter()
                .enumerate()
                .map(move |(index, row)| (w, index, row))
        })
        .map(|(w, index, row)| LinRow {
            wheel: w,
            k: row.k,
            t: row.t0,
            y: model.residual(data, ch, w, row) / sigma,
            named: named_regressors(problem, ch, &model, named, w, row)
                .into_iter()
                .map(|(c, i, x)| (c, i, x / sigma))
                .collect(),
            index,
        })
        .collect();
    // Columns: the named causes' values (shared by the rows of every wheel they act on), then
    // the unexplained wheel terms (wheel, candidate).
    let mut cols: Vec<(Cause, usize)> = Vec::new();
    for r in &rows {
        for &(c, i, _) in &r.named {
            if !cols.contains(&(c, i)) {
                cols.push((c, i));
            }
        }
    }
    let extra = extra_terms(effects, candidates);
    let x_of = |r: &LinRow, used: &[usize], extra: &[(usize, usize)]| -> Vec<f64> {
        let mut x: Vec<f64> = used
            .iter()
            .map(|&j| {
                r.named
                    .iter()
                    .find(|(c, i, _)| (*c, *i) == cols[j])
                    .map_or(0.0, |v| v.2)
            })
            .collect();
        x.extend(extra.iter().map(|&(w, c)| {
            if w == r.wheel {
                candidates.values[w][r.index][c] / sigma
            } else {
                0.0
            }
        }));
        x
    };
    let build = |used: &[usize],
                 extra: &[(usize, usize)],
                 keep: &dyn Fn(&LinRow) -> bool,
                 y: &dyn Fn(&LinRow) -> f64| {
        let mut ne = NormalEquations::new(used.len() + extra.len());
        for r in rows.iter().filter(|r| keep(r)) {
            ne.add(&x_of(r, used, extra), y(r));
        }
        ne
    };
    // Time blocks over the channel's span.
    let blocks = levels.blocks;
    let (t0, t1) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
            (a.min(r.t), b.max(r.t))
        });
    let block_of = |t: f64| -> usize {
        (((t - t0) / (t1 - t0).max(1e-9) * blocks as f64) as usize).min(blocks - 1)
    };
    // Columns determined in every block (sum of squares at least 1 % of an even share).
    let ssq = |j: usize, keep: &dyn Fn(&LinRow) -> bool| -> f64 {
        rows.iter()
            .filter(|r| keep(r))
            .map(|r| x_of(r, &[j], &[])[0].powi(2))
            .sum()
    };
    let determined: Vec<usize> = (0..cols.len())
        .filter(|&j| {
            let total = ssq(j, &|_| true);
            total > 0.0
                && (0..blocks)
                    .all(|b| ssq(j, &|r| block_of(r.t) == b) >= 0.01 * total / blocks as f64)
        })
        .collect();
    let per_block: Vec<Option<crate::stats::LsFit>> = (0..blocks)
        .map(|b| build(&determined, &extra, &|r| block_of(r.t) == b, &|r| r.y).solve())
        .collect();
    let fit_rows = |r: &LinRow| !problem.held_out[r.k];
    let all: Vec<usize> = (0..cols.len()).collect();
    // The extended wheel equation on the fit data: its residuals per wheel, in time order.
    let extended = build(&all, &extra, &fit_rows, &|r| r.y).solve();
    let position = |r: &LinRow| (0..r.wheel).map(|w| ch.rows[w].len()).sum::<usize>() + r.index;
    // The wheel search with every named cause, run once for all the competitions.
    let mut cv_with: Option<Option<f64>> = None;
    let mut out = Vec::new();
    for cause in wheel_causes {
        let idx: Vec<usize> = (0..determined.len())
            .filter(|&j| cols[determined[j]].0 == cause)
            .collect();
        let consistency = if idx.is_empty() {
            None
        } else {
            consistency(&per_block, &idx, (t1 - t0) / blocks as f64)
        };
        // The residual with the cause at its base values (its part put back), per row in the
        // order of `rows`.
        let mut base_config: ModelConfig = fit.config.clone();
        cause.apply(&mut base_config, &cause.values(&problem.base));
        let base_model = WheelModel::from_config(&base_config);
        let y_base: Vec<f64> = (0..3)
            .flat_map(|w| ch.rows[w].iter().map(move |row| (w, row)))
            .map(|(w, row)| base_model.residual(data, ch, w, row) / sigma)
            .collect();
        // Significance beside the unexplained wheel terms: the residual with the cause at its
        // base values, fitted without its columns, against the fitted residual with them.
        let (mut joint_lr, mut joint_threshold) = (None, None);
        let own: Vec<usize> = all
            .iter()
            .copied()
            .filter(|&j| cols[j].0 == cause)
            .collect();
        if !extra.is_empty() && !own.is_empty() {
            let others: Vec<usize> = all.iter().copied().filter(|j| !own.contains(j)).collect();
            let without = rss_of(&build(&others, &extra, &fit_rows, &|r| y_base[position(r)]));
            if let (Some(with), Some(without)) = (&extended, without) {
                let (lr, threshold) = levels.joint(with.n as f64, without, with.rss, own.len());
                joint_lr = Some(lr);
                joint_threshold = Some(threshold);
            }
        }
        // Whiteness of the extended equation's residuals on the wheels the cause acts on.
        let whiteness = extended.as_ref().and_then(|f| {
            let wheels: Vec<usize> = (0..3)
                .filter(|&w| {
                    rows.iter()
                        .any(|r| r.wheel == w && r.named.iter().any(|v| v.0 == cause))
                })
                .collect();
            whiteness(&rows, f, &all, &extra, &x_of, &fit_rows, &wheels)
        });
        // The competing explanation (the torque causes' third test, `falsify::compete`): the
        // wheel search without the cause and its own form. Its significance beside the terms
        // that search finds is tested on the columns the fit data determine, the cause's Wald
        // statistic on its total change from the base values (its columns are changes from the
        // fitted values).
        let with = *cv_with.get_or_insert_with(|| {
            wheel_cv_rss(
                problem,
                fit,
                named,
                candidates,
                levels.block_s,
                levels.sparse,
            )
        });
        let mut competitor = None;
        let mut competitor_failed = None;
        if let Some(with) = with
            && !own.is_empty()
            && let Some((rival, without)) = competing_explanation(
                problem,
                fit,
                named,
                cause,
                candidates,
                levels.block_s,
                levels.sparse,
            )
        {
            let rival_extra = extra_terms(&rival, candidates);
            let present: Vec<usize> = all
                .iter()
                .copied()
                .filter(|&j| ssq(j, &fit_rows) > 0.0)
                .collect();
            let idx_present: Vec<usize> = (0..present.len())
                .filter(|&j| cols[present[j]].0 == cause)
                .collect();
            let (fitted, base) = (cause.values(&fit.config), cause.values(&problem.base));
            let offset: Vec<f64> = idx_present
                .iter()
                .map(|&j| {
                    let i = cols[present[j]].1;
                    fitted.get(i).zip(base.get(i)).map_or(0.0, |(f, b)| f - b)
                })
                .collect();
            let cluster_s = levels.block_s / 3.0;
            let equation = |row: &mut RowSink| {
                for r in rows.iter().filter(|r| fit_rows(r)) {
                    let x = x_of(r, &present, &rival_extra);
                    row(&x, r.y, y_base[position(r)], fold_of(r.t, cluster_s));
                }
            };
            let (c, dropped) = compete("wheel", with, without, &rival, || {
                significance_beside(
                    &equation,
                    present.len() + rival_extra.len(),
                    (own.len(), &idx_present, &offset),
                    levels,
                )
            });
            competitor = Some(c);
            competitor_failed = dropped;
        }
        // The failed tests, the competitor first: it says what the cause stood in for (the
        // form the report then carries), where a failed consistency, joint or whiteness test
        // says only that the cause does not describe the wheel.
        let mut failures = Failures::default();
        if let Some(text) = competitor_failed {
            failures.add("competitor", text);
        }
        if let Some(c) = &consistency
            && c.p < levels.consistency
        {
            failures.add("consistency", falsified_text(c, levels.consistency));
        }
        if let (Some(lr), Some(threshold)) = (joint_lr, joint_threshold)
            && lr <= threshold
        {
            failures.add(
                "joint",
                format!(
                    "dropped: not significant beside the unexplained wheel effects (likelihood ratio {lr:.1} ≤ threshold {threshold:.1}); it stood in for an effect of another form"
                ),
            );
        }
        if let Some(wt) = &whiteness
            && wt.p < levels.consistency
        {
            failures.add(
                "whiteness",
                format!(
                    "falsified: the residuals of the extended wheel equation are not white (wheel {}: Ljung–Box {:.1} on {} lags, p = {:.1e} < {:.0e} after Bonferroni over {} wheels); the cause and the unexplained terms do not describe the wheel",
                    "XYZ".as_bytes()[wt.wheel.min(2)] as char,
                    wt.ljung_box,
                    wt.lags,
                    wt.p,
                    levels.consistency,
                    wt.wheels
                ),
            );
        }
        let white = whiteness
            .as_ref()
            .map_or(" (not determined)".to_string(), |w| {
                format!(" (p = {:.2})", w.p)
            });
        let evidence = Evidence {
            consistency,
            joint_lr,
            joint_threshold,
            whiteness,
            competitor,
            ..Evidence::default()
        };
        out.push(CauseTest::verdict(cause, evidence, failures, |c| {
            format!(
                "kept: consistent across {} time blocks (p = {:.2}), residuals of the wheel equation white{white}",
                c.blocks, c.p
            )
        }));
    }
    out
}

/// The unexplained wheel terms of `effects` as (wheel, candidate index).
fn extra_terms(effects: &[UnexplainedEffect], candidates: &WheelCandidates) -> Vec<(usize, usize)> {
    let mut extra = Vec::new();
    for e in effects {
        let Some(w) = (0..3).find(|&w| e.equation == wheel_equation(w)) else {
            continue;
        };
        for t in &e.terms {
            if let Some(j) = candidates.names.iter().position(|n| *n == t.name) {
                extra.push((w, j));
            }
        }
    }
    extra
}

/// The regressors of a row for the named causes' columns `used` and the unexplained terms
/// `extra` (wheel, candidate), whitened.
type RowRegressors<'a> = dyn Fn(&LinRow, &[usize], &[(usize, usize)]) -> Vec<f64> + 'a;

/// Ljung–Box whiteness of the extended wheel equation's residuals (fit `f` of the columns `used`
/// then `extra`) on each wheel of `wheels` (fit rows, time order); the worst wheel, its p value
/// multiplied by the number of wheels (Bonferroni).
fn whiteness(
    rows: &[LinRow],
    f: &crate::stats::LsFit,
    used: &[usize],
    extra: &[(usize, usize)],
    x_of: &RowRegressors,
    keep: &dyn Fn(&LinRow) -> bool,
    wheels: &[usize],
) -> Option<Whiteness> {
    let mut worst: Option<Whiteness> = None;
    for &w in wheels {
        let (t, e): (Vec<f64>, Vec<f64>) = rows
            .iter()
            .filter(|r| r.wheel == w && keep(r))
            .map(|r| {
                let x = x_of(r, used, extra);
                let fitted: f64 = x.iter().zip(f.theta.iter()).map(|(a, b)| a * b).sum();
                (r.t, r.y - fitted)
            })
            .unzip();
        if e.len() < 4 * WHITENESS_LAGS {
            continue;
        }
        let s = series_stats(&t, &e, WHITENESS_LAGS);
        let p = ((1.0 - chi_square_cdf(s.ljung_box, s.lags as f64)) * wheels.len() as f64).min(1.0);
        if worst.as_ref().is_none_or(|b| p < b.p) {
            worst = Some(Whiteness {
                wheel: w,
                ljung_box: s.ljung_box,
                lags: s.lags,
                p,
                wheels: wheels.len(),
            });
        }
    }
    worst
}

/// The named wheel causes of `fit` with their linear values (`wheel_torque_scale`,
/// `wheel_friction`'s levels) changed by the unexplained wheel effects' refit of their forced
/// columns (`refitted_named`: the change that removes the residual beside the terms, and its
/// cluster-robust standard error); the configuration updated with them. `actuator_delay` (one
/// value for three equations) and the Stribeck speed (not a column) stay as fitted.
pub(super) fn refit_beside_terms(fit: &mut SetFit, named: &[Cause], effects: &[UnexplainedEffect]) {
    for e in effects.iter().filter(|e| e.equation.starts_with("wheel_")) {
        for term in &e.refitted_named {
            for &cause in named
                .iter()
                .filter(|c| matches!(c, Cause::WheelTorqueScale | Cause::WheelFriction))
            {
                let Some(i) = (0..cause.len()).find(|&i| cause.value_name(i) == term.name) else {
                    continue;
                };
                if !(term.value.is_finite() && term.stderr.is_finite()) {
                    continue;
                }
                if let Some(f) = fit.causes.iter_mut().find(|f| f.cause == cause) {
                    let (lo, hi) = cause.bounds(i);
                    f.values[i] = (f.values[i] + term.value).clamp(lo, hi);
                    f.stderr[i] = term.stderr;
                    // Without a Stribeck term the breakaway is the larger Coulomb level.
                    if cause == Cause::WheelFriction {
                        for w in 0..3 {
                            if f.values[12 + w] < 0.02 {
                                f.values[9 + w] = f.values[w].max(f.values[3 + w]);
                            }
                        }
                    }
                    cause.apply(&mut fit.config, &f.values);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::normals;
    use nalgebra::{DMatrix, DVector};

    fn rows(y: &[f64]) -> Vec<LinRow> {
        y.iter()
            .enumerate()
            .map(|(i, &y)| LinRow {
                wheel: 0,
                k: 2 * i,
                t: 0.2 * i as f64,
                y,
                named: Vec::new(),
                index: i,
            })
            .collect()
    }

    /// White residuals pass, residuals correlated from row to row (AR(1), coefficient 0.3,
    /// Ljung–Box expected about 2000 × 0.09 ≈ 180 on 10 lags) fail at 1e-3; seed fixed.
    #[test]
    fn whiteness_tells_white_from_correlated_residuals() {
        let none = crate::stats::LsFit {
            theta: DVector::zeros(0),
            cov_unit: DMatrix::zeros(0, 0),
            rss: 0.0,
            n: 2000,
        };
        let x_of = |_: &LinRow, _: &[usize], _: &[(usize, usize)]| Vec::new();
        let keep = |_: &LinRow| true;
        let u = normals(2000, 7);
        let white = whiteness(&rows(&u), &none, &[], &[], &x_of, &keep, &[0]).expect("tested");
        assert!(white.p > 1e-3, "{white:?}");
        let mut ar = u.clone();
        for i in 1..ar.len() {
            ar[i] = 0.3 * ar[i - 1] + u[i];
        }
        let red = whiteness(&rows(&ar), &none, &[], &[], &x_of, &keep, &[0]).expect("tested");
        println!("white: {white:?}\nAR(1): {red:?}");
        assert!(red.p < 1e-3 && red.ljung_box > 100.0, "{red:?}");
        // Too few rows for the lags: not determined.
        assert!(whiteness(&rows(&u[..20]), &none, &[], &[], &x_of, &keep, &[0]).is_none());
    }
}
