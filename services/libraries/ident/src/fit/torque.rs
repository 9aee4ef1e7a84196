//! Torque causes (centre-of-mass offset, constant torque, aerodynamic drag, inertia error,
//! thruster torque scale, the propellant's centre-of-mass shift): linear in the torque channel,
//! fitted by weighted least squares with `aero_drag`'s coefficients kept ≥ 0 (active set).
//! Columns the data do not excite (a thruster that never fired) are held at their base values
//! (no standard error: not estimated).

use super::{FittedCause, Problem, State, solve_fixed};
use crate::channels::{TORQUE_COLUMNS, column_cause, torque_columns};
use crate::effects::Cause;
use crate::error::IdentError;
use crate::stats::NormalEquations;

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
        let mut ne = NormalEquations::new(columns.len());
        let mut row = vec![0.0; columns.len()];
        for (i, &a) in ch.ticks.iter().enumerate() {
            if self.held_out[a] {
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
