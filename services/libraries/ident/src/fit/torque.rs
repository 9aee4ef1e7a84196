//! Torque causes (centre-of-mass offset, constant torque, aerodynamic drag, inertia error,
//! thruster torque scale, the propellant's centre-of-mass shift): linear in the torque channel,
//! fitted by weighted least squares with `aero_drag`'s coefficients kept ≥ 0 (active set).
//! Columns the data do not excite (a thruster that never fired) are held at their base values
//! (no standard error: not estimated).

use super::{FittedCause, Problem, State, solve_fixed};
use crate::channels::{TORQUE_COLUMNS, TorqueChannel, column_cause, torque_columns};
use crate::effects::Cause;
use crate::error::IdentError;
use crate::stats::NormalEquations;
use nalgebra::{DMatrix, DVector, Vector3};
use testbed_model::thruster_config::THRUSTER_COUNT;

impl Problem<'_> {
    pub(super) fn fit_torque(
        &self,
        state: &State,
        set: &[Cause],
    ) -> Result<([f64; TORQUE_COLUMNS], Vec<FittedCause>), IdentError> {
        let ch = &state.torque;
        let columns: Vec<usize> = set
            .iter()
            .flat_map(|c| torque_columns(*c).into_iter().flatten())
            .collect();
        if ch.len() < 30 {
            return Err(IdentError::Failed(
                "too few usable torque-channel samples to fit".into(),
            ));
        }
        // Base values of the fitted columns (drag must stay ≥ 0 in total).
        let base_value = |col: usize| -> f64 {
            let (cause, off) = column_cause(col);
            cause.values(&self.base)[off]
        };
        // (index into `columns`, delta): columns the data leave at zero are not estimated.
        let mut fixed: Vec<(usize, f64)> = columns
            .iter()
            .enumerate()
            .filter(|(_, c)| !ch.determined(**c))
            .map(|(j, _)| (j, 0.0))
            .collect();
        let ne = torque_normal_equations(ch, &self.held_out, &columns);
        let (theta, stderr) = loop {
            let (theta, stderr) = solve_fixed(&ne, &fixed).ok_or_else(|| {
                IdentError::Failed(format!(
                    "{}: the data do not determine the parameters (no excitation of this effect)",
                    set.iter().map(|c| c.name()).collect::<Vec<_>>().join(" + ")
                ))
            })?;
            // Keep drag coefficients non-negative: hold the most negative at its bound, refit.
            let worst = columns
                .iter()
                .enumerate()
                .filter(|(j, c)| (6..12).contains(*c) && !fixed.iter().any(|(f, _)| f == j))
                .map(|(j, &c)| (j, base_value(c) + theta[j]))
                .filter(|(_, v)| *v < 0.0)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match worst {
                Some((j, _)) => fixed.push((j, -base_value(columns[j]))),
                None => break (theta, stderr),
            }
        };
        // The thrusters' pulse-to-pulse noise: an error of the measured momentum the
        // least-squares errors do not assume (added in quadrature).
        let pulse_var = if ch.thrusters.is_some() {
            let free: Vec<usize> = (0..columns.len())
                .filter(|j| !fixed.iter().any(|(f, _)| f == j))
                .collect();
            let values: Vec<f64> = (0..columns.len())
                .map(|j| fixed.iter().find(|(f, _)| *f == j).map_or(0.0, |f| f.1))
                .collect();
            let cov = if free.is_empty() {
                None
            } else {
                ne.reduce(&free, &values).and_then(|r| r.solve())
            };
            let mut var = vec![0.0; columns.len()];
            if let Some(fit) = cov {
                let cols: Vec<usize> = free.iter().map(|&j| columns[j]).collect();
                let v = pulse_noise_variance(ch, &self.held_out, &cols, &fit.cov_unit);
                for (a, &j) in free.iter().enumerate() {
                    var[j] = v[a];
                }
            }
            var
        } else {
            vec![0.0; columns.len()]
        };
        let stderr: Vec<f64> = stderr
            .iter()
            .zip(&pulse_var)
            .map(|(se, v)| (se * se + v).sqrt())
            .collect();
        let mut delta = [0.0; TORQUE_COLUMNS];
        for (j, &c) in columns.iter().enumerate() {
            delta[c] = theta[j];
        }
        let mut out = Vec::new();
        for &cause in set {
            let range = torque_columns(cause).unwrap_or(0..0);
            let mut values = cause.values(&self.base);
            let mut se = vec![f64::NAN; values.len()];
            for (off, col) in range.clone().enumerate() {
                let j = columns.iter().position(|c| *c == col).unwrap_or(0);
                values[off] += theta[j];
                se[off] = stderr[j];
            }
            out.push(FittedCause::estimated(cause, values, se));
        }
        Ok((delta, out))
    }
}

/// Normal equations of the torque channel's weighted least squares in the columns `columns`
/// (indices into the [`TORQUE_COLUMNS`] regressors), on the rows not `held_out`: each row and
/// axis whitened by the channel's a-priori σ, so `XᵀX` is the Fisher information of those
/// parameters (configuration units) for noise as modelled.
pub(crate) fn torque_normal_equations(
    ch: &TorqueChannel,
    held_out: &[bool],
    columns: &[usize],
) -> NormalEquations {
    let mut ne = NormalEquations::new(columns.len());
    let mut row = vec![0.0; columns.len()];
    for (i, &a) in ch.ticks.iter().enumerate() {
        if held_out[a] {
            continue;
        }
        for axis in 0..3 {
            let s = ch.sigma[axis];
            for (j, &c) in columns.iter().enumerate() {
                row[j] = ch.x[i][c][axis] / s;
            }
            ne.add(&row, ch.y[i][axis] / s);
        }
    }
    ne
}

/// Variance of the fitted torque columns `cols` from the thrusters' pulse-to-pulse thrust noise
/// (`thrust_noise_fraction`), for the weighted least squares with unit covariance `cov_unit`
/// (`(XᵀWX)⁻¹` over `cols`) on the rows not `held_out`.
///
/// Pulse p of thruster i (thrust time `a_p`, noise `ξ_p ~ N(0, 1)`) adds `σ s_i a_p T_i ξ_p` to
/// the measured momentum from its tick on: in its segment a step, mean removed like every row.
/// Its influence on the estimate is `δθ_p = (XᵀWX)⁻¹ XᵀW u_p` (`u_p` that step per unit `ξ_p`),
/// and the pulses are independent: `Var θ̂_j = Σ_p (δθ_p)_j²`.
fn pulse_noise_variance(
    ch: &TorqueChannel,
    held_out: &[bool],
    cols: &[usize],
    cov_unit: &DMatrix<f64>,
) -> Vec<f64> {
    let p = cols.len();
    let mut var = vec![0.0; p];
    let Some(th) = &ch.thrusters else {
        return var;
    };
    if th.thrust_noise_fraction == 0.0 || p == 0 {
        return var;
    }
    // Pulses by start tick: (tick, thruster, noise impulse per unit ξ, Nms).
    let mut pulses: Vec<(usize, Vector3<f64>)> = Vec::new();
    for i in 0..THRUSTER_COUNT {
        for &(k, a) in &th.pulses[i] {
            pulses.push((
                k,
                th.torque_nm[i] * (th.thrust_noise_fraction * th.scale[i] * a),
            ));
        }
    }
    pulses.sort_by_key(|(k, _)| *k);
    let w = ch.sigma.map(|s| 1.0 / (s * s));
    for seg in &ch.segments {
        let (first, last) = (ch.ticks[seg.start], ch.ticks[seg.end - 1]);
        // Suffix sums of W x over the segment's fitted rows: after[r][j] (per axis).
        let len = seg.len();
        let mut after = vec![vec![Vector3::zeros(); p]; len + 1];
        for r in (0..len).rev() {
            let row = seg.start + r;
            for j in 0..p {
                after[r][j] = after[r + 1][j];
                if !held_out[ch.ticks[row]] {
                    after[r][j] += ch.x[row][cols[j]].component_mul(&w);
                }
            }
        }
        let lo = pulses.partition_point(|(k, _)| *k < first);
        let hi = pulses.partition_point(|(k, _)| *k < last);
        for (k, impulse) in &pulses[lo..hi] {
            // Rows from the tick after the pulse's on carry it.
            let r0 = ch.ticks[seg.clone()].partition_point(|t| *t <= *k);
            let frac = (len - r0) as f64 / len as f64;
            let v = DVector::from_fn(p, |j, _| (after[r0][j] - after[0][j] * frac).dot(impulse));
            let d = cov_unit * v;
            for j in 0..p {
                var[j] += d[j] * d[j];
            }
        }
    }
    var
}
