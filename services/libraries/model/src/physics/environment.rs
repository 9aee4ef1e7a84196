//! External torques on the platform about the bearing centre, body axes, from the effects the
//! nominal model leaves out (all off unless configured):
//!
//! * `com_offset`: gravity acting at a centre of mass offset `r` from the bearing centre,
//!   `M = m g (r × G_B)`, `G_B = A(q) G_L` the unit down vector in body axes;
//! * `aero_drag`: `M = −(c1 ⊙ w + c2 ⊙ w ⊙ |w|)` per body axis;
//! * `constant_torque`: bearing exhaust and cable torque, fixed in body axes;
//! * `fitted_torque`: a torque fitted to data ([`super::fitted_torque`]).
//!
//! Sensor-side effects (earth rate, gyro errors, magnetic disturbance) live in `devices`.

use super::fitted_torque::FittedTorqueModel;
use crate::attitude::{self, Attitude};
use crate::config::ModelConfig;
use nalgebra::Vector3;

/// External torque on the platform, Nm, body axes, split by cause so identification code can fit
/// each part.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExternalTorque {
    /// Gravity torque of the centre-of-mass offset, Nm, body axes.
    pub gravity_b: Vector3<f64>,
    /// Aerodynamic drag torque, Nm, body axes.
    pub drag_b: Vector3<f64>,
    /// Constant (exhaust, cable) torque, Nm, body axes.
    pub constant_b: Vector3<f64>,
    /// The fitted torque (`fitted_torque`), Nm, body axes; zero without it.
    pub fitted_b: Vector3<f64>,
}

impl ExternalTorque {
    /// Sum of all parts, Nm, body axes.
    pub fn total_b(&self) -> Vector3<f64> {
        self.gravity_b + self.drag_b + self.constant_b + self.fitted_b
    }
}

/// The external torque model with its coefficients resolved once from the configuration (the
/// plant evaluates it four times per integration step).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExternalTorqueModel {
    /// `m g r`, N m (weight times centre-of-mass offset, body axes); zero without `com_offset`.
    pub weight_moment_b: Vector3<f64>,
    /// Linear drag coefficient per body axis, Nm/(rad/s).
    pub drag_c1: Vector3<f64>,
    /// Quadratic drag coefficient per body axis, Nm/(rad/s)².
    pub drag_c2: Vector3<f64>,
    /// Constant torque, Nm, body axes.
    pub constant_b: Vector3<f64>,
    /// `m g ṙ` of `com_drift`, N m/s, body axes: the weight moment grows by this per second of
    /// plant time ([`ExternalTorqueModel::at_time`]); zero without `com_drift`.
    pub weight_moment_rate_b: Vector3<f64>,
    /// `heading_torque`: amplitudes of the `cos ψ` and `sin ψ` parts, Nm, body axes; zero
    /// without it (then the heading is not computed).
    pub heading_cos_b: Vector3<f64>,
    pub heading_sin_b: Vector3<f64>,
    /// `dipole_torque`: the moment `m`, A m², body axes, and the lab field `B_L`, T (zero moment
    /// without it).
    pub dipole_b: Vector3<f64>,
    pub field_l_t: Vector3<f64>,
    /// `fitted_torque`, resolved.
    pub fitted: FittedTorqueModel,
    /// Plant time the model was resolved at ([`ExternalTorqueModel::at_time`]), s.
    pub time_s: f64,
}

impl ExternalTorqueModel {
    pub fn from_config(config: &ModelConfig) -> Self {
        let e = &config.effects;
        let mg = config.platform.mass_kg * config.platform.gravity_mps2;
        Self {
            weight_moment_b: e
                .com_offset
                .as_ref()
                .map_or_else(Vector3::zeros, |c| Vector3::from(c.r_m) * mg),
            drag_c1: e
                .aero_drag
                .as_ref()
                .map_or_else(Vector3::zeros, |d| Vector3::from(d.c1)),
            drag_c2: e
                .aero_drag
                .as_ref()
                .map_or_else(Vector3::zeros, |d| Vector3::from(d.c2)),
            constant_b: e
                .constant_torque
                .as_ref()
                .map_or_else(Vector3::zeros, |c| Vector3::from(c.torque_nm)),
            weight_moment_rate_b: e
                .com_drift
                .as_ref()
                .map_or_else(Vector3::zeros, |c| Vector3::from(c.rate_m_per_s) * mg),
            heading_cos_b: e
                .heading_torque
                .as_ref()
                .map_or_else(Vector3::zeros, |h| Vector3::from(h.cos_nm)),
            heading_sin_b: e
                .heading_torque
                .as_ref()
                .map_or_else(Vector3::zeros, |h| Vector3::from(h.sin_nm)),
            dipole_b: e
                .dipole_torque
                .as_ref()
                .map_or_else(Vector3::zeros, |d| Vector3::from(d.moment_am2)),
            field_l_t: config.platform.field_l_t(),
            fitted: FittedTorqueModel::from_config(e.fitted_torque.as_ref()),
            time_s: 0.0,
        }
    }

    /// Whether the torque changes with time (`com_drift`, a fitted term in time): the plant
    /// then re-resolves the model with [`ExternalTorqueModel::at_time`] before each substep.
    pub fn time_dependent(&self) -> bool {
        self.weight_moment_rate_b != Vector3::zeros() || self.fitted.uses_time()
    }

    /// The model at plant time `t_s` (s): the weight moment of a drifting centre of mass,
    /// `m g (r + ṙ t)`, held over the substep. `base` is the model at time 0.
    pub fn at_time(base: &Self, t_s: f64) -> Self {
        Self {
            weight_moment_b: base.weight_moment_b + base.weight_moment_rate_b * t_s,
            time_s: t_s,
            ..*base
        }
    }

    /// Torque at attitude `q` (L→B) and body rate `rate_b` (rad/s, body axes).
    pub fn torque(&self, q: &Attitude, rate_b: &Vector3<f64>) -> ExternalTorque {
        ExternalTorque {
            gravity_b: self.weight_moment_b.cross(&attitude::gravity_b(q)),
            drag_b: -(self.drag_c1.component_mul(rate_b)
                + self
                    .drag_c2
                    .component_mul(&rate_b.component_mul(&rate_b.abs()))),
            constant_b: self
                .heading_part(q)
                .map_or(self.constant_b, |h| self.constant_b + h)
                + self.dipole_part(q),
            fitted_b: self.fitted.torque(self.time_s, q, rate_b),
        }
    }

    /// `dipole_torque` at attitude `q`, `m × A(q) B_L`, Nm, body axes (zero without it).
    /// Counted with the constant part in [`ExternalTorque`].
    fn dipole_part(&self, q: &Attitude) -> Vector3<f64> {
        if self.dipole_b == Vector3::zeros() {
            return Vector3::zeros();
        }
        self.dipole_b.cross(&(q * self.field_l_t))
    }

    /// `heading_torque` at attitude `q`, Nm, body axes (`None`, and no heading computed,
    /// without it: the default model's arithmetic is unchanged). Counted with the constant part
    /// in [`ExternalTorque`].
    fn heading_part(&self, q: &Attitude) -> Option<Vector3<f64>> {
        if self.heading_cos_b == Vector3::zeros() && self.heading_sin_b == Vector3::zeros() {
            return None;
        }
        let psi = attitude::heading(q);
        Some(self.heading_cos_b * psi.cos() + self.heading_sin_b * psi.sin())
    }
}

/// External torque breakdown (gravity, drag, constant), Nm, body axes, at attitude `q` (L→B) and
/// body rate `rate_b` (rad/s, relative to L, body axes).
pub fn external_torque(
    config: &ModelConfig,
    q: &Attitude,
    rate_b: &Vector3<f64>,
) -> ExternalTorque {
    ExternalTorqueModel::from_config(config).torque(q, rate_b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_heading_pitch_roll;
    use crate::config::{AeroDrag, ComOffset, ConstantTorque};

    /// `dipole_torque`: `m × B_B`. Level at heading 0 (`B_B = B_L`) a moment along X gives
    /// `(0, −m_x B_z, m_x B_y)`; about any heading a vertical moment's torque is horizontal,
    /// `m_z` times the horizontal field's magnitude, and always normal to the moment.
    #[test]
    fn dipole_torque_is_the_moment_across_the_field_in_body_axes() {
        use crate::config::DipoleTorque;
        let mut config = ModelConfig::default();
        let b = config.platform.field_l_t();
        config.effects.dipole_torque = Some(DipoleTorque {
            moment_am2: [20.0, 0.0, 0.0],
        });
        let level = from_heading_pitch_roll(0.0, 0.0, 0.0);
        let t = ExternalTorqueModel::from_config(&config)
            .torque(&level, &Vector3::zeros())
            .total_b();
        let want = Vector3::new(0.0, -20.0 * b.z, 20.0 * b.y);
        assert!((t - want).norm() < 1e-15, "{t:?} vs {want:?}");
        config.effects.dipole_torque = Some(DipoleTorque {
            moment_am2: [0.0, 0.0, 20.0],
        });
        let model = ExternalTorqueModel::from_config(&config);
        let horizontal = (b.x * b.x + b.y * b.y).sqrt();
        for psi in [0.3, 1.9, -2.4] {
            let t = model
                .torque(&from_heading_pitch_roll(psi, 0.0, 0.0), &Vector3::zeros())
                .total_b();
            assert!(t.z.abs() < 1e-15, "{t:?}");
            assert!(
                ((t.x.hypot(t.y)) - 20.0 * horizontal).abs() < 1e-15,
                "{t:?}"
            );
        }
        // Off by default: no dipole part.
        let nominal = ExternalTorqueModel::from_config(&ModelConfig::default());
        assert_eq!(nominal.dipole_part(&level), Vector3::zeros());
    }

    #[test]
    fn heading_torque_and_com_drift_follow_their_formulas() {
        use crate::config::{ComDrift, HeadingTorque};
        let mut config = ModelConfig::default();
        config.effects.heading_torque = Some(HeadingTorque {
            cos_nm: [0.0, 1e-3, 2e-3],
            sin_nm: [3e-3, 0.0, -1e-3],
        });
        let model = ExternalTorqueModel::from_config(&config);
        assert!(!model.time_dependent());
        for psi in [0.0, 0.7, -2.0] {
            let q = from_heading_pitch_roll(psi, 0.0, 0.0);
            let t = model.torque(&q, &Vector3::zeros()).total_b();
            let want = Vector3::new(
                3e-3 * psi.sin(),
                1e-3 * psi.cos(),
                2e-3 * psi.cos() - 1e-3 * psi.sin(),
            );
            assert!((t - want).norm() < 1e-15, "{t:?} vs {want:?}");
        }
        // The drift: at time t the weight moment is that of r + ṙ t.
        let mut drift = ModelConfig::default();
        drift.effects.com_offset = Some(ComOffset {
            r_m: [1e-6, 0.0, 0.0],
        });
        drift.effects.com_drift = Some(ComDrift {
            rate_m_per_s: [0.0, 2e-9, 0.0],
        });
        let base = ExternalTorqueModel::from_config(&drift);
        assert!(base.time_dependent());
        let at = ExternalTorqueModel::at_time(&base, 500.0);
        let mg = drift.platform.mass_kg * drift.platform.gravity_mps2;
        assert!((at.weight_moment_b - Vector3::new(1e-6, 1e-6, 0.0) * mg).norm() < 1e-15);
        // Off by default: the nominal model is not time-dependent and has no heading part.
        let nominal = ExternalTorqueModel::from_config(&ModelConfig::default());
        assert!(
            !nominal.time_dependent()
                && nominal
                    .heading_part(&from_heading_pitch_roll(1.0, 0.0, 0.0))
                    .is_none()
        );
    }

    #[test]
    fn nominal_platform_feels_no_torque() {
        let q = from_heading_pitch_roll(0.4, 0.2, -0.1);
        let t = external_torque(&ModelConfig::default(), &q, &Vector3::new(0.1, -0.2, 0.3));
        assert_eq!(t.total_b(), Vector3::zeros());
    }

    #[test]
    fn gravity_torque_is_the_lever_arm_times_weight_at_several_attitudes() {
        let mut config = ModelConfig::default();
        let r_b = Vector3::new(12e-6, -5e-6, -3e-6);
        config.effects.com_offset = Some(ComOffset { r_m: r_b.into() });
        let mg = 350.0 * 9.806;
        for (psi, theta, phi) in [
            (0.0, 0.0, 0.0),
            (1.0, 0.3, -0.2),
            (-2.5, -0.45, 0.5),
            (0.3, 0.0, 0.52),
        ] {
            let q = from_heading_pitch_roll(psi, theta, phi);
            // Independent truth: the weight m g (0, 0, −1) acts at the centre of mass r, worked in
            // the level frame and rotated into body axes with the attitude matrix.
            let a = q.to_rotation_matrix().into_inner();
            let r_l = a.transpose() * r_b;
            let weight_l = Vector3::new(0.0, 0.0, -mg);
            let truth_b = a * r_l.cross(&weight_l);
            let t = external_torque(&config, &q, &Vector3::zeros());
            assert!(
                (t.gravity_b - truth_b).norm() < 1e-15,
                "{:?} vs {truth_b:?}",
                t.gravity_b
            );
            assert_eq!(t.total_b(), t.gravity_b);
        }
        // Level platform: only the horizontal offset acts, M = m g (−r_y, r_x, 0).
        let t = external_torque(&config, &Attitude::identity(), &Vector3::zeros());
        assert!((t.gravity_b - mg * Vector3::new(-r_b.y, r_b.x, 0.0)).norm() < 1e-15);
    }

    #[test]
    fn drag_opposes_rate_per_axis_and_constant_adds() {
        let mut config = ModelConfig::default();
        config.effects.aero_drag = Some(AeroDrag {
            c1: [1e-3, 2e-3, 3e-3],
            c2: [1e-2, 0.0, 2e-2],
        });
        config.effects.constant_torque = Some(ConstantTorque {
            torque_nm: [1e-4, -2e-4, 3e-4],
        });
        let w = Vector3::new(0.1, -0.2, -0.3);
        let t = external_torque(&config, &Attitude::identity(), &w);
        let drag = Vector3::new(-(1e-4 + 1e-4), 4e-4, 9e-4 + 1.8e-3);
        assert!((t.drag_b - drag).norm() < 1e-15, "{:?}", t.drag_b);
        assert_eq!(t.constant_b, Vector3::new(1e-4, -2e-4, 3e-4));
        assert!((t.total_b() - drag - t.constant_b).norm() < 1e-18);
    }
}
