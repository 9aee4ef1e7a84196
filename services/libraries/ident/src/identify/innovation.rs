//! The sensor channel (the attitude filter's innovations, whitened, per component) as an
//! equation of the unexplained-effect search (its candidate functions: see `equations`), and
//! the falsification of the named sensor causes on their linearisation through the filter.

use super::falsify::{CauseTest, Evidence, Failures, Levels, consistency, falsified_text, rss_of};
use super::unexplained::{UnexplainedEffect, effect, fold_of};
use crate::effects::{Cause, Kind};
use crate::fit::{Problem, SetFit};
use crate::reconstruct::INNOVATION_LEN;
use crate::sparse::{Design, Rows, SparseOptions, search};
use crate::stats::{LsFit, NormalEquations};
use nalgebra::Vector3;
use testbed_model::attitude;

/// Per filter innovation (all ticks, in the reconstruction's order): the sensor-channel
/// candidates, evaluated at its tick.
pub(super) struct InnovationCandidates {
    pub names: Vec<&'static str>,
    pub values: Vec<Vec<f64>>,
    /// Per innovation and component: its row in the innovation vector (`usize::MAX`: absent).
    pub row: Vec<[usize; INNOVATION_LEN]>,
}

impl InnovationCandidates {
    pub fn new(problem: &Problem, fit: &SetFit) -> Self {
        let data = problem.data;
        let s = &fit.state;
        let t0 = data.t.first().copied().unwrap_or(0.0);
        let span = (data.t.last().copied().unwrap_or(1.0) - t0).max(1e-9);
        let field = problem.base.platform.field_l_t();
        let field_n = field / field.norm().max(1e-300);
        let wheels = data.has_wheels();
        let mut names: Vec<&'static str> = vec![
            "1",
            "t",
            "cos ψ",
            "sin ψ",
            "cos 2ψ",
            "sin 2ψ",
            "t·cos ψ",
            "t·sin ψ",
            "sin tilt_x",
            "sin tilt_y",
            "B_x",
            "B_y",
            "B_z",
            "w_x",
            "w_y",
            "w_z",
        ];
        if wheels {
            names.extend(["n_x", "n_y", "n_z"]);
        }
        let mut next = 0;
        let mut row = Vec::with_capacity(s.recon.innovations.len());
        let values = s
            .recon
            .innovations
            .iter()
            .map(|i| {
                let mut r = [usize::MAX; INNOVATION_LEN];
                for (c, slot) in r.iter_mut().enumerate() {
                    if i.mask & (1 << c) != 0 {
                        *slot = next;
                        next += 1;
                    }
                }
                row.push(r);
                let k = i.tick;
                let q = &s.recon.q[k];
                let t = (data.t[k] - t0) / span;
                let psi = attitude::heading(q);
                let g = attitude::gravity_b(q);
                let b = q * field_n;
                let w = s.recon.rate[k];
                let mut v = vec![
                    1.0,
                    t,
                    psi.cos(),
                    psi.sin(),
                    (2.0 * psi).cos(),
                    (2.0 * psi).sin(),
                    t * psi.cos(),
                    t * psi.sin(),
                    g.x,
                    g.y,
                    b.x,
                    b.y,
                    b.z,
                    w.x,
                    w.y,
                    w.z,
                ];
                if wheels {
                    let n = data.wheel_speed_at(k);
                    v.extend([n.x, n.y, n.z]);
                }
                v
            })
            .collect();
        Self { names, values, row }
    }
}

/// The named sensor causes linearised at their fitted values: `∂(innovation vector)/∂θ_j` by
/// forward differences through the filter (one filter run per parameter), over all ticks; and
/// the part of a cause without a neutral value (one filter run without it), so that the guard
/// can put every named cause's part back.
pub(super) struct SensorLinear {
    /// Per column: cause, value index, name.
    pub cols: Vec<(Cause, usize, String)>,
    /// Per column: fitted value minus the value that switches the cause off (`None` for
    /// `earth_rate`, which has no neutral value).
    pub delta: Vec<Option<f64>>,
    /// Per column, per innovation-vector row.
    pub j: Vec<Vec<f64>>,
    /// With `earth_rate` named (the one cause without a neutral value): its part of each
    /// innovation-vector row, the innovations with it less those of a filter run without it.
    pub earth_rate: Option<Vec<f64>>,
    /// Per column of a cause that corrects the rate readings ([`corrects_rates`]; empty for
    /// the others), per row of the torque channel: `−∂(momentum residual)/∂θ_j`, Nms per unit,
    /// body axes, the sign of a torque cause's regressor. All empty when a run's torque channel
    /// has other rows.
    pub torque: Vec<Vec<Vector3<f64>>>,
}

impl SensorLinear {
    /// `cause`'s part of each innovation-vector row: its columns times its change from the
    /// neutral values, or, for a cause without them, its part from the run without it.
    pub fn part_of(&self, cause: Cause) -> Option<Vec<f64>> {
        if cause == Cause::EarthRate {
            return self.earth_rate.clone();
        }
        let change = (0..self.cols.len())
            .filter(|&j| self.cols[j].0 == cause)
            .map(|j| self.delta[j])
            .collect::<Option<Vec<f64>>>()?;
        Some(self.part_of_change(cause, &change))
    }

    /// The innovations' change, per innovation-vector row, when `cause`'s values change by
    /// `change` (its parameters' order) from the fitted ones, to first order.
    pub fn part_of_change(&self, cause: Cause, change: &[f64]) -> Vec<f64> {
        let cols: Vec<usize> = (0..self.cols.len())
            .filter(|&j| self.cols[j].0 == cause)
            .collect();
        let rows = self.j.first().map_or(0, Vec::len);
        (0..rows)
            .map(|r| {
                cols.iter()
                    .zip(change)
                    .map(|(&j, d)| self.j[j][r] * d)
                    .sum()
            })
            .collect()
    }

    pub fn new(problem: &Problem, fit: &SetFit, named: &[Cause]) -> Option<Self> {
        let sensor: Vec<Cause> = named
            .iter()
            .copied()
            .filter(|c| c.kind() == Kind::Sensor)
            .collect();
        if sensor.is_empty() {
            return None;
        }
        let r0 = fit.state.recon.innovation_vector(|_| true);
        let mut cols = Vec::new();
        let mut delta = Vec::new();
        let mut taken = Vec::new();
        let mut configs = Vec::new();
        for cause in sensor {
            let values = cause.values(&fit.config);
            let neutral = cause.values(&problem.base);
            let mut offset = 0;
            for spec in cause.params() {
                for e in 0..spec.len {
                    let i = offset + e;
                    let (lo, hi) = cause.bounds(i);
                    let h = if values[i] + spec.step > hi {
                        -spec.step
                    } else {
                        spec.step
                    };
                    let mut v = values.clone();
                    v[i] = (values[i] + h).clamp(lo, hi);
                    if v[i] == values[i] {
                        return None;
                    }
                    taken.push(v[i] - values[i]);
                    let mut config = fit.config.clone();
                    cause.apply(&mut config, &v);
                    configs.push(config);
                    cols.push((cause, i, cause.value_name(i)));
                    delta.push((cause != Cause::EarthRate).then(|| values[i] - neutral[i]));
                }
                offset += spec.len;
            }
        }
        // `earth_rate` has no neutral value: a run without it gives its part.
        let earth_rate = named.contains(&Cause::EarthRate);
        if earth_rate {
            let mut config = fit.config.clone();
            config.effects.earth_rate = None;
            configs.push(config);
        }
        let runs = problem.run_filters(&configs).ok()?;
        let vectors: Vec<Vec<f64>> = runs
            .iter()
            .map(|run| run.innovation_vector(|_| true))
            .collect();
        if vectors.iter().any(|r| r.len() != r0.len()) {
            return None;
        }
        let (steps, off) = vectors.split_at(taken.len());
        let j = steps
            .iter()
            .zip(&taken)
            .map(|(r, taken)| r.iter().zip(&r0).map(|(a, b)| (a - b) / taken).collect())
            .collect();
        // Only the run without `earth_rate` follows the steps.
        let earth_rate = off
            .first()
            .map(|r| r0.iter().zip(r).map(|(a, b)| a - b).collect());
        let ch = &fit.state.torque;
        let torque: Option<Vec<Vec<Vector3<f64>>>> = runs
            .iter()
            .zip(&taken)
            .zip(&cols)
            .map(|((run, taken), (cause, _, _))| {
                if !corrects_rates(*cause) {
                    return Some(Vec::new());
                }
                let stepped = problem.torque_residuals(run);
                (stepped.ticks == ch.ticks).then(|| {
                    let change: Vec<Vector3<f64>> = stepped
                        .y
                        .iter()
                        .zip(&ch.y)
                        .map(|(a, b)| (b - a) / *taken)
                        .collect();
                    without_own_noise(&change, &ch.segments)
                })
            })
            .collect();
        Some(Self {
            cols,
            delta,
            j,
            earth_rate,
            torque: torque.unwrap_or_default(),
        })
    }
}

/// The sensor causes that correct the rate readings, and so change the estimated rates the
/// dynamics are checked on directly (the others move the estimated attitude, which the torque
/// equations see only through terms of the attitude that the named causes and the search take
/// up). Not `gyro_delay`, which corrects the rates too: its column in the torque equations is
/// the readings' second difference, whose noise the neighbours' mean does not remove, so its
/// value there is biased towards zero (0.079 ± 0.005 s about X for a true 0.1 s).
pub(super) fn corrects_rates(cause: Cause) -> bool {
    matches!(
        cause,
        Cause::GyroScale | Cause::GyroMisalignment | Cause::GyroBiasDrift
    )
}

/// Ticks on each side of a row that [`without_own_noise`] averages.
const NEIGHBOURS: usize = 5;

/// A sensor cause's change of the momentum residual per row, `column`, replaced by the mean of
/// its neighbours in the segment (up to [`NEIGHBOURS`] on each side, the row itself left out).
/// A gyro cause changes the corrected rates in proportion to the readings, their noise
/// included, and the momentum residual holds that same noise: regressed on the raw change, the
/// residual's noise would pull the cause's value towards undoing the readings (an
/// errors-in-variables bias, the larger the less the axis turns). The neighbours' readings
/// carry other noise, and the slow part of the change, which the dynamics can test, is kept.
fn without_own_noise(
    column: &[Vector3<f64>],
    segments: &[std::ops::Range<usize>],
) -> Vec<Vector3<f64>> {
    let mut out = column.to_vec();
    for seg in segments {
        for r in seg.clone() {
            let lo = r.saturating_sub(NEIGHBOURS).max(seg.start);
            let hi = (r + NEIGHBOURS + 1).min(seg.end);
            let n = hi - lo - 1;
            if n > 0 {
                let sum: Vector3<f64> = (lo..hi).filter(|&i| i != r).map(|i| column[i]).sum();
                out[r] = sum / n as f64;
            }
        }
    }
    out
}

pub(super) fn search_innovations(
    problem: &Problem,
    fit: &SetFit,
    candidates: &InnovationCandidates,
    linear: Option<&SensorLinear>,
    block_s: f64,
    options: &SparseOptions,
) -> Vec<UnexplainedEffect> {
    let designs = innovation_designs(
        problem,
        fit,
        (candidates, linear),
        (block_s, options.folds),
        None,
    );
    designs
        .into_iter()
        .filter_map(|(c, design)| {
            let result = search(&design, options);
            effect(
                INNOVATION_LABELS[c].to_string(),
                "1 (whitened)",
                result,
                &design,
            )
        })
        .collect()
}

/// The sensor channel's equations, one design per innovation component with enough rows: the
/// named sensor causes' columns (their Jacobian rows of the component) forced, so their values
/// re-adjust with any new term, then every candidate. With `removed`, a cause and a part of
/// each innovation-vector row (its fitted part, [`SensorLinear::part_of`]), the innovations
/// have that part taken out (`r − J_c Δθ_c` to first order) and the cause's columns are not
/// forced. `(block_s, folds)`: the blocks and folds.
pub(super) fn innovation_designs(
    problem: &Problem,
    fit: &SetFit,
    (candidates, linear): (&InnovationCandidates, Option<&SensorLinear>),
    (block_s, folds): (f64, usize),
    removed: Option<(Cause, &[f64])>,
) -> Vec<(usize, Design)> {
    let data = problem.data;
    let s = &fit.state;
    let part = removed.map(|(_, part)| part);
    let removed = removed.map(|(cause, _)| cause);
    let mut out = Vec::new();
    for c in 0..INNOVATION_LEN {
        let rows: Vec<usize> = (0..s.recon.innovations.len())
            .filter(|&i| candidates.row[i][c] != usize::MAX)
            .collect();
        if rows.len() < 100 {
            continue;
        }
        let forced: Vec<usize> = linear.map_or(Vec::new(), |l| {
            (0..l.cols.len())
                .filter(|&j| Some(l.cols[j].0) != removed)
                .filter(|&j| rows.iter().any(|&i| l.j[j][candidates.row[i][c]] != 0.0))
                .collect()
        });
        let mut names: Vec<String> = forced
            .iter()
            .filter_map(|&j| linear.map(|l| l.cols[j].2.clone()))
            .collect();
        names.extend(candidates.names.iter().map(|n| n.to_string()));
        let x: Vec<Vec<f64>> = rows
            .iter()
            .map(|&i| {
                let mut row: Vec<f64> = forced
                    .iter()
                    .filter_map(|&j| linear.map(|l| l.j[j][candidates.row[i][c]]))
                    .collect();
                row.extend(&candidates.values[i]);
                row
            })
            .collect();
        let inn = &s.recon.innovations;
        let y: Vec<f64> = rows
            .iter()
            .map(|&i| {
                let r = candidates.row[i][c];
                inn[i].values[c] - part.map_or(0.0, |p| p[r])
            })
            .collect();
        // Clusters of a third of a block (never across a fit / held-out change).
        let cluster: Vec<usize> = rows
            .iter()
            .map(|&i| fold_of(data.t[inn[i].tick], block_s / 3.0))
            .collect();
        let fold: Vec<usize> = rows
            .iter()
            .map(|&i| fold_of(data.t[inn[i].tick], block_s))
            .collect();
        let held: Vec<bool> = rows
            .iter()
            .map(|&i| problem.held_out[inn[i].tick])
            .collect();
        let rows = Rows {
            x: &x,
            y: &y,
            cluster: &cluster,
            fold: &fold,
            held_out: &held,
        };
        out.push((c, Design::new(names, forced.len(), rows, folds)));
    }
    out
}

/// Names of the innovation components (the equations of the sensor channel).
pub(super) const INNOVATION_LABELS: [&str; INNOVATION_LEN] = [
    "innovation_tilt_1",
    "innovation_tilt_2",
    "innovation_field_x",
    "innovation_field_y",
    "innovation_field_z",
];

/// The torque causes' consistency and significance tests for the sensor causes, on their
/// linearisation ([`SensorLinear`]): per block one Gauss–Newton step from the fitted values
/// (with the unexplained innovation terms as extra columns) for the consistency, and the
/// likelihood ratio of the innovations with and without the cause (its effect removed to first
/// order, `r − J_c Δθ_c`) beside the unexplained terms for the significance.
pub(super) fn sensor_tests(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    effects: &[UnexplainedEffect],
    (innovation, linear): (&InnovationCandidates, Option<&SensorLinear>),
    levels: &Levels,
) -> Vec<CauseTest> {
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
                 removed: Option<&[f64]>,
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
            let y = inn[i].values[c] - removed.map_or(0.0, |p| p[r]);
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
        // Consistency: per block, δ_b solving J δ ≈ −r (one Gauss–Newton step). The
        // magnetometer's two causes are nearly degenerate within a block of a few minutes (the
        // hard iron and the soft iron's columns on the nearly constant vertical field, and on a
        // field that turns through a small arc of heading), and block fits of both together
        // come out far apart although the whole record's fit is at its optimum (in simulation
        // with both hidden: χ² = 4·10⁴ on 18 degrees of freedom with 4 blocks, 10 with 2); so
        // each is tested with the other held at its value on the whole record.
        let block_cols: Vec<usize> = all
            .iter()
            .copied()
            .filter(|&j| {
                let other = lin.cols[j].0;
                !(other != cause && other.magnetometer() && cause.magnetometer())
            })
            .collect();
        let block_idx: Vec<usize> = idx
            .iter()
            .filter_map(|j| block_cols.iter().position(|c| c == j))
            .collect();
        let per_block: Vec<Option<LsFit>> = (0..blocks)
            .map(|b| build(&block_cols, None, &|tick| block_of(tick) == b, -1.0, &extra).solve())
            .collect();
        let mut evidence = Evidence {
            consistency: consistency(&per_block, &block_idx, (t1 - t0) / blocks as f64),
            ..Evidence::default()
        };
        let mut failures = Failures::default();
        if let Some(c) = &evidence.consistency
            && c.p < alpha_consistency
        {
            failures.add("consistency", falsified_text(c, alpha_consistency));
        }
        if !extra.is_empty()
            && let Some(part) = lin.part_of(cause)
        {
            let fit_rows = |tick: usize| !problem.held_out[tick];
            let others: Vec<usize> = all.iter().copied().filter(|j| !idx.contains(j)).collect();
            let with = build(&all, Some(&part), &fit_rows, 1.0, &extra1).solve();
            let without = rss_of(&build(&others, Some(&part), &fit_rows, 1.0, &extra1));
            if let (Some(w), Some(wo)) = (with, without) {
                let (lr, threshold) = levels.joint(w.n as f64, wo, w.rss, idx.len());
                evidence.joint_lr = Some(lr);
                evidence.joint_threshold = Some(threshold);
                if lr <= threshold && failures.none() {
                    failures.add(
                        "joint",
                        format!(
                            "dropped: not significant once the unexplained effect is modelled (likelihood ratio {lr:.1} ≤ threshold {threshold:.1}); it stood in for an effect of another form"
                        ),
                    );
                }
            }
        }
        out.push(CauseTest::verdict(cause, evidence, failures, |c| {
            format!(
                "kept: consistent across {} time blocks (p = {:.2}, linearised through the filter)",
                c.blocks, c.p
            )
        }));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A change that varies slowly is kept (a straight line is its neighbours' mean), and a
    /// row's own value, its noise, is left out of it; segments are not crossed.
    #[test]
    fn a_row_is_the_mean_of_its_neighbours_in_its_segment() {
        let line: Vec<Vector3<f64>> = (0..40).map(|i| Vector3::repeat(i as f64)).collect();
        let segments = [0..20, 20..40];
        let out = without_own_noise(&line, &segments);
        for r in NEIGHBOURS..20 - NEIGHBOURS {
            assert!((out[r] - line[r]).norm() < 1e-12, "row {r}: {}", out[r]);
        }
        // At a segment's start only the later rows of that segment count.
        let first: f64 = (21..=20 + NEIGHBOURS).map(|i| i as f64).sum::<f64>() / NEIGHBOURS as f64;
        assert!((out[20].x - first).abs() < 1e-12, "{}", out[20].x);
        let mut spike = vec![Vector3::zeros(); 20];
        spike[10] = Vector3::repeat(1.0);
        let whole = std::slice::from_ref(&(0..20));
        let out = without_own_noise(&spike, whole);
        assert_eq!(out[10], Vector3::zeros());
        assert!((out[9].x - 1.0 / (2 * NEIGHBOURS) as f64).abs() < 1e-12);
    }
}
