//! The Fisher information of torque-channel and wheel-channel causes on one estimated state:
//! the `XᵀX` of the whitened normal equations the fits themselves solve ([`torque`] and
//! [`wheels`] build them; nothing is re-derived here), on the ticks the fits use (held-out ticks
//! left out). For noise as modelled (whitened rows of unit variance) `F⁻¹` is the covariance
//! the fits report, so `sqrt(diag F⁻¹)` predicts their standard errors.
//!
//! The torque channel and the wheel channel have independent noise (gyro through the inertia
//! and tachometer, against tachometer alone) and are fitted separately: the information is
//! block-diagonal between them. Sensor causes are not covered: their Jacobians are finite
//! differences through the attitude filter (one filter run per parameter), too slow to repeat
//! for every candidate of a design search.
//!
//! [`torque`]: super::torque
//! [`wheels`]: super::wheels

use super::torque::torque_normal_equations;
use super::{Problem, State, WheelModel};
use crate::channels::{column_cause, torque_columns};
use crate::effects::{Cause, Kind};
use crate::error::IdentError;
use nalgebra::DMatrix;

/// Fisher information of a set of causes' parameters, in the configuration's units.
#[derive(Debug, Clone, PartialEq)]
pub struct Information {
    /// Each parameter: its cause and the offset in [`Cause::values`].
    pub params: Vec<(Cause, usize)>,
    /// `F` (symmetric, parameters in `params` order), per configuration unit squared.
    pub matrix: DMatrix<f64>,
}

/// Whether the information of `cause` can be computed ([`Problem::information`]): the torque
/// causes other than the thrusters' (those need a thruster programme) and `wheel_torque_scale`.
pub fn information_supported(cause: Cause) -> bool {
    match cause.kind() {
        Kind::Torque => !matches!(
            cause,
            Cause::ThrusterTorqueScale | Cause::PropellantComShift
        ),
        Kind::Wheel => cause == Cause::WheelTorqueScale,
        Kind::Sensor => false,
    }
}

impl Problem<'_> {
    /// The Fisher information of the parameters of `causes` on `state` (normally the base
    /// configuration's state): torque causes jointly from the torque channel's normal
    /// equations, `wheel_torque_scale` per wheel from the wheel channel's (friction and delay
    /// held at the base configuration's values, as when they are not fitted). Causes in the
    /// order given, each cause's values in [`Cause::values`] order.
    pub fn information(&self, state: &State, causes: &[Cause]) -> Result<Information, IdentError> {
        if let Some(c) = causes.iter().find(|c| !information_supported(**c)) {
            return Err(IdentError::Options {
                key: "causes".into(),
                value: c.name().into(),
                reason: "no Fisher information for this cause (only the torque causes other than the thrusters' and wheel_torque_scale)".into(),
            });
        }
        let mut params: Vec<(Cause, usize)> = Vec::new();
        for &c in causes {
            if params.iter().any(|(p, _)| *p == c) {
                continue;
            }
            params.extend((0..c.len()).map(|i| (c, i)));
        }
        let p = params.len();
        let mut matrix = DMatrix::zeros(p, p);
        // Torque block: the columns of the torque causes, in `params` order.
        let torque: Vec<(usize, usize)> = params
            .iter()
            .enumerate()
            .filter_map(|(j, (c, off))| torque_columns(*c).map(|r| (j, r.start + off)))
            .collect();
        if !torque.is_empty() {
            let columns: Vec<usize> = torque.iter().map(|(_, col)| *col).collect();
            debug_assert!(columns.iter().all(|&col| {
                let (c, off) = column_cause(col);
                params.contains(&(c, off))
            }));
            let f = torque_normal_equations(&state.torque, &self.held_out, &columns).information();
            for (a, (ja, _)) in torque.iter().enumerate() {
                for (b, (jb, _)) in torque.iter().enumerate() {
                    matrix[(*ja, *jb)] = f[(a, b)];
                }
            }
        }
        // Wheel block: one scale per wheel, independent of the others.
        if let Some(j0) = params
            .iter()
            .position(|(c, _)| *c == Cause::WheelTorqueScale)
        {
            let base = WheelModel::from_config(&self.base);
            for w in 0..3 {
                let (ne, _) = self.wheel_normal_equations(
                    &state.wheel,
                    &base,
                    w,
                    base.delay_s,
                    true,
                    false,
                    None,
                );
                matrix[(j0 + w, j0 + w)] = ne.diag(0);
            }
        }
        Ok(Information { params, matrix })
    }
}
