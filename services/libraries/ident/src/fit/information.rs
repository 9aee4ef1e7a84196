//! The Fisher information of candidate causes on one estimated state. Torque and wheel causes:
//! the `XᵀX` of the whitened normal equations the fits themselves solve ([`torque`] and
//! [`wheels`] build them; nothing is re-derived here), on the ticks the fits use (held-out ticks
//! left out). For noise as modelled (whitened rows of unit variance) `F⁻¹` is the covariance
//! the fits report, so `sqrt(diag F⁻¹)` predicts their standard errors.
//!
//! A wheel that never changes direction leaves the Coulomb level of the other direction with no
//! information: the matrix is singular there, which the design counts as an undetermined
//! direction.
//!
//! The torque channel and the wheel channel have independent noise (gyro through the inertia
//! and tachometer, against tachometer alone) and are fitted separately: the information is
//! block-diagonal between them. The sensor causes act on the attitude filter's innovations:
//! their information is `JᵀJ` of the whitened innovations' Jacobian, by forward differences
//! through the filter as the sensor fit computes it (one filter run per parameter), a third
//! block (identify fits them first and on the innovations alone).
//!
//! [`torque`]: super::torque
//! [`wheels`]: super::wheels

use super::torque::torque_normal_equations;
use super::{Problem, State, TangentRun, WheelModel};
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

/// Whether the information of `cause` can be computed ([`Problem::information`]): the sensor
/// causes, the torque causes other than the thrusters' (those need a thruster programme),
/// `wheel_torque_scale` and `wheel_friction`'s linear levels.
pub fn information_supported(cause: Cause) -> bool {
    match cause.kind() {
        Kind::Torque => !matches!(
            cause,
            Cause::ThrusterTorqueScale | Cause::PropellantComShift
        ),
        Kind::Wheel => matches!(cause, Cause::WheelTorqueScale | Cause::WheelFriction),
        Kind::Sensor => true,
    }
}

/// The values of `cause` ([`Cause::values`] offsets) the information covers: all of them,
/// except for `wheel_friction` its linear levels only (`coulomb_pos_nm`, `coulomb_neg_nm`,
/// `viscous_nm_per_rad_s`: offsets 0–8); the Stribeck level and speed enter non-linearly (the
/// fit searches the speed) and are left out.
pub fn information_params(cause: Cause) -> std::ops::Range<usize> {
    match cause {
        Cause::WheelFriction => 0..9,
        _ => 0..cause.len(),
    }
}

impl Problem<'_> {
    /// The Fisher information of the parameters of `causes` on `state` (normally the base
    /// configuration's state): torque causes jointly from the torque channel's normal
    /// equations, `wheel_torque_scale` and `wheel_friction`'s levels per wheel from the wheel
    /// channel's (delay, and friction when not a target, held at the base configuration's
    /// values, as when they are not fitted). Causes in the order given, each cause's values
    /// ([`information_params`]) in [`Cause::values`] order.
    pub fn information(&self, state: &State, causes: &[Cause]) -> Result<Information, IdentError> {
        if let Some(c) = causes.iter().find(|c| !information_supported(**c)) {
            return Err(IdentError::Options {
                key: "causes".into(),
                value: c.name().into(),
                reason: "no Fisher information for this cause (the thrusters' causes need the thruster programme; of the wheel causes only wheel_torque_scale and wheel_friction)".into(),
            });
        }
        let mut params: Vec<(Cause, usize)> = Vec::new();
        for &c in causes {
            if params.iter().any(|(p, _)| *p == c) {
                continue;
            }
            params.extend(information_params(c).map(|i| (c, i)));
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
        // Wheel block: per wheel, its scale and friction levels (the unknowns
        // `[scale, coulomb_pos, coulomb_neg, stribeck, viscous]` of the wheel fit, Stribeck
        // term off), independent of the other wheels.
        let fit_scale = params.iter().any(|(c, _)| *c == Cause::WheelTorqueScale);
        let fit_friction = params.iter().any(|(c, _)| *c == Cause::WheelFriction);
        if fit_scale || fit_friction {
            let base = WheelModel::from_config(&self.base);
            let index = |c: Cause, off: usize| params.iter().position(|p| *p == (c, off));
            let rows = self.wheel_rows(&state.wheel);
            for w in 0..3 {
                let drive = rows.drive_integrals(w, base.delay_s);
                let (ne, _) =
                    rows.normal_equations(&base, w, &drive, fit_scale, fit_friction, None);
                let f = ne.information();
                // (unknown of the wheel fit, parameter index)
                let map: Vec<(usize, usize)> = [
                    (0, index(Cause::WheelTorqueScale, w)),
                    (1, index(Cause::WheelFriction, w)),
                    (2, index(Cause::WheelFriction, 3 + w)),
                    (4, index(Cause::WheelFriction, 6 + w)),
                ]
                .into_iter()
                .filter_map(|(u, j)| j.map(|j| (u, j)))
                .collect();
                for &(ua, ja) in &map {
                    for &(ub, jb) in &map {
                        matrix[(ja, jb)] = f[(ua, ub)];
                    }
                }
            }
        }
        // Attitude block: the sensor causes jointly, from the Jacobian of the filter's whitened
        // innovations by its sensitivities (one run, `crate::tangent`; the sensor fit's own
        // Jacobian is finite differences at the same steps), at the base configuration's values
        // of the causes (Earth rate on at the lab's latitude).
        let sensor: Vec<(usize, Cause, usize)> = params
            .iter()
            .enumerate()
            .filter(|(_, (c, _))| c.kind() == Kind::Sensor)
            .map(|(j, (c, off))| (j, *c, *off))
            .collect();
        if !sensor.is_empty() {
            let theta: Vec<f64> = sensor
                .iter()
                .map(|&(_, c, off)| c.values(&self.base)[off])
                .collect();
            let build = |t: &[f64]| {
                let mut config = self.base.clone();
                for cause in Cause::ALL {
                    let mut values = cause.values(&config);
                    let mut any = false;
                    for (k, &(_, c, off)) in sensor.iter().enumerate() {
                        if c == cause {
                            values[off] = t[k];
                            any = true;
                        }
                    }
                    if any {
                        cause.apply(&mut config, &values);
                    }
                }
                config
            };
            let steps: Vec<f64> = sensor.iter().map(|&(_, c, off)| step_of(c, off)).collect();
            let all: Vec<usize> = (0..sensor.len()).collect();
            let run = TangentRun::stepped(
                &theta,
                &all,
                &steps,
                |k| sensor[k].1.bounds(sensor[k].2),
                build,
            );
            let f = self.tangent_normal_equations(&run)?.information();
            for (a, &(ja, _, _)) in sensor.iter().enumerate() {
                for (b, &(jb, _, _)) in sensor.iter().enumerate() {
                    matrix[(ja, jb)] = f[(a, b)];
                }
            }
        }
        Ok(Information { params, matrix })
    }
}

/// Finite-difference step of value `off` of `cause` (its parameter array's step).
fn step_of(cause: Cause, off: usize) -> f64 {
    let mut i = off;
    for p in cause.params() {
        if i < p.len {
            return p.step;
        }
        i -= p.len;
    }
    1e-6
}
