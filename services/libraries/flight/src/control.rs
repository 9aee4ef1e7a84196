//! Reaction-wheel attitude control: PD on the error quaternion with wheel friction compensation
//! (paper: `u = −P q_v − D ω − T_f(n)`).
//!
//! # Conventions
//!
//! * Attitudes follow [`testbed_model::attitude`]: `q` maps level-frame (L) components to body (B)
//!   components, ω is the body rate relative to L in body axes (rad/s), and a body rotated by a
//!   small positive angle φ about an axis *relative to its target* has the error
//!   `φ = attitude::attitude_error(q_est, q_target)` (rad, body axes).
//! * The error quaternion vector part `q_v` (dimensionless, body axes) is that of the rotation
//!   taking the target to the estimate, with the sign of the quaternion chosen so that its scalar
//!   part is ≥ 0 (shortest rotation, no unwinding): `q_v = sin(|φ|/2) φ̂`, so `q_v ≈ φ/2` for small
//!   errors. See [`error_vector`].
//! * Desired torque on the platform (body axes, Nm): `u_body = −P q_v − D ω` (per-axis gains).
//! * The wheel command is the **motor torque on the wheel** `τ_m` (Nm, wheel `i` on body axis `i`,
//!   positive about `+e_i`). The platform feels `−τ_m`, and the wheel's bearing friction
//!   `T_f(n)` (which brakes the wheel) pushes the platform with `+T_f(n)`, n being the wheel speed
//!   relative to the platform (rad/s). So the body torque from the wheels is `−τ_m + T_f(n)` and
//!   the motor command for `u_body` is `τ_m = −u_body + T̂_f(n)` with the friction model of paper
//!   eq. 3, `T̂_f(n) = T_f0 sign(n) + K n`, evaluated at the **measured** wheel speed.
//!
//! # Friction compensation near zero speed
//!
//! `sign(n)` is replaced by `tanh(n / n_s)` with the speed scale
//! [`PdFrictionConfig::friction_speed_scale_rad_s`] (default `n_s = 0.2 rad/s ≈ 1.9 rpm`, about
//! 20× the tachometer's 1σ noise of 0.1 rpm): the compensation is continuous through `n = 0`
//! (no ±T_f0 switching on noise, so no chatter) and within 4 % of the full Coulomb term for
//! `|n| > 2 n_s`. The residual uncompensated friction only acts while `|n| ≲ n_s`, which — with no
//! external torque — corresponds to body rates below `n_s J_w / I ≈ 7e-6 rad/s`.
//!
//! # Limits
//!
//! * Torque: every `|τ_m,i| ≤ max_torque_nm`. The control part `u_body` is scaled by one factor
//!   `s ∈ [0, 1]` (the largest for which all three wheels fit, friction compensation included), so
//!   the direction of the body torque is kept; only if that is not enough (it never is, as long as
//!   the friction model is below the torque limit) is each wheel clipped.
//! * Momentum: no command may drive a wheel beyond its speed limit `n_max`. With the control
//!   period `T` ([`PdFrictionConfig::control_period_s`]) the wheel speed after one period,
//!   neglecting friction (which only brakes the wheel, so this is conservative) and the platform's
//!   own acceleration (`I ≫ J_w`), is `n + τ_m T / J_w`; each wheel's command is clamped to
//!   `J_w (−n_max − n)/T ≤ τ_m ≤ J_w (n_max − n)/T`. This acts per wheel (a full wheel cannot give
//!   more momentum whatever the other axes need; the other axes keep their control), and above
//!   `n_max` it commands the wheel back to the limit. It only bites within `0.1 Nm · T / J_w`
//!   (≈ 6.3 rad/s, 60 rpm at 10 Hz) of the limit.
//!
//! # Default gains
//!
//! Per axis, linearised (`q_v ≈ φ/2`, rigid body, principal inertia `I_i`):
//! `I_i φ'' + D_i φ' + (P_i/2) φ = 0`, so `ω_n = sqrt(P_i / (2 I_i))` and `ζ = D_i / (2 I_i ω_n)`
//! (see [`closed_loop_modes`]). The defaults ([`PdFrictionConfig::design`] with
//! `I = diag(45.2, 46.1, 62.7) kg m²`, `ω_n = 0.07 rad/s`, `ζ = 0.9`) are
//! `P = (0.4430, 0.4518, 0.6145) Nm`, `D = (5.695, 5.809, 7.900) Nms`.
//! Checks against the envelope: the largest initial demand, 20° heading error, is
//! `P_z sin 10° = 0.107 Nm` (a brief, direction-keeping saturation at 0.1 Nm); 5° tilt needs
//! 0.019 Nm. The peak rate of the 20° heading manoeuvre is about `0.39 ω_n φ0 ≈ 9.6e-3 rad/s`, i.e.
//! `0.60 Nms` of wheel momentum (limit 1 Nms). Settling (error below 0.1° and staying) from
//! 5°/5°/20° takes about 80 s in the truth-feedback simulation of the tests; without friction
//! compensation the wheel Coulomb friction `T_f0` leaves a dead band of `2 T_f0 / P ≈ 0.39°`.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use testbed_model::attitude::Attitude;
use testbed_model::config::WheelConfig;

/// Why a controller refused its configuration or an input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ControlError {
    #[error("control configuration: `{key}` = {value}: {reason}")]
    InvalidConfig {
        key: String,
        value: String,
        reason: String,
    },
    #[error("control input `{0}` is not finite")]
    NonFiniteInput(&'static str),
    #[error("CMG steering: the singularity-robust inverse is not defined ({0})")]
    Steering(String),
}

pub(crate) fn invalid(key: &str, value: impl std::fmt::Display, reason: &str) -> ControlError {
    ControlError::InvalidConfig {
        key: key.to_string(),
        value: value.to_string(),
        reason: reason.to_string(),
    }
}

pub(crate) fn check_positive(key: &str, x: f64) -> Result<(), ControlError> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(invalid(key, x, "must be a finite number > 0"))
    }
}

pub(crate) fn check_finite_quaternion(
    q: &Attitude,
    what: &'static str,
) -> Result<(), ControlError> {
    if q.coords.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(ControlError::NonFiniteInput(what))
    }
}

pub(crate) fn check_finite_vector(
    v: &Vector3<f64>,
    what: &'static str,
) -> Result<(), ControlError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(ControlError::NonFiniteInput(what))
    }
}

/// Gains and options of the wheel PD controller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PdFrictionConfig {
    /// Proportional gain per body axis, Nm per unit of error quaternion vector part `q_v`
    /// (dimensionless; `q_v ≈ φ/2`, so the angle stiffness is `P/2` Nm/rad).
    pub p_nm: [f64; 3],
    /// Rate gain per body axis, Nm per rad/s of body rate.
    pub d_nms: [f64; 3],
    /// Add the friction model `T̂_f(n)` to the motor command (paper's `− T_f(n)` term).
    pub friction_compensation: bool,
    /// Speed scale `n_s` of the smooth sign `tanh(n / n_s)` used in the Coulomb term of the
    /// compensation, rad/s.
    pub friction_speed_scale_rad_s: f64,
    /// Control period `T`, s: the horizon over which the momentum limit is enforced (one command is
    /// held for one period).
    pub control_period_s: f64,
}

impl Default for PdFrictionConfig {
    fn default() -> Self {
        Self::design([45.2, 46.1, 62.7], 0.07, 0.9)
    }
}

impl PdFrictionConfig {
    /// Gains for natural frequency `natural_frequency_rad_s` (rad/s) and damping ratio
    /// `damping_ratio` on every axis, for principal moments `inertia_kgm2` (kg m²) of the linearised
    /// loop `I φ'' + D φ' + (P/2) φ = 0`: `P = 2 I ω_n²`, `D = 2 ζ ω_n I`. Friction compensation
    /// on, `n_s = 0.2 rad/s`, `T = 0.1 s`.
    pub fn design(
        inertia_kgm2: [f64; 3],
        natural_frequency_rad_s: f64,
        damping_ratio: f64,
    ) -> Self {
        let w = natural_frequency_rad_s;
        Self {
            p_nm: inertia_kgm2.map(|i| 2.0 * i * w * w),
            d_nms: inertia_kgm2.map(|i| 2.0 * damping_ratio * w * i),
            friction_compensation: true,
            friction_speed_scale_rad_s: 0.2,
            control_period_s: 0.1,
        }
    }

    /// Refuse non-finite or non-positive gains and parameters, naming the key and value.
    pub fn validate(&self) -> Result<(), ControlError> {
        for i in 0..3 {
            check_positive(&format!("p_nm[{i}]"), self.p_nm[i])?;
            let d = self.d_nms[i];
            if !(d.is_finite() && d >= 0.0) {
                return Err(invalid(
                    &format!("d_nms[{i}]"),
                    d,
                    "must be a finite number >= 0",
                ));
            }
        }
        check_positive(
            "friction_speed_scale_rad_s",
            self.friction_speed_scale_rad_s,
        )?;
        check_positive("control_period_s", self.control_period_s)
    }
}

/// Linearised closed-loop mode of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisMode {
    /// Undamped natural frequency `ω_n`, rad/s.
    pub natural_frequency_rad_s: f64,
    /// Damping ratio `ζ`, dimensionless.
    pub damping_ratio: f64,
}

/// Closed-form natural frequency and damping per axis of the linearised loop
/// `I φ'' + D φ' + (P/2) φ = 0` (small angles, `q_v ≈ φ/2`, rigid body, principal moments
/// `inertia_kgm2` in kg m², `P` in Nm, `D` in Nms): `ω_n = sqrt(P / (2 I))`, `ζ = D / (2 I ω_n)`.
pub fn closed_loop_modes(
    p_nm: &[f64; 3],
    d_nms: &[f64; 3],
    inertia_kgm2: &[f64; 3],
) -> [AxisMode; 3] {
    std::array::from_fn(|i| {
        let w = (p_nm[i] / (2.0 * inertia_kgm2[i])).sqrt();
        AxisMode {
            natural_frequency_rad_s: w,
            damping_ratio: d_nms[i] / (2.0 * inertia_kgm2[i] * w),
        }
    })
}

/// Vector part `q_v` (dimensionless, body axes) of the error quaternion of the estimate relative
/// to the target, sign chosen for a non-negative scalar part (shortest rotation):
/// `q_v = sin(|φ|/2) φ̂` with `φ = attitude::attitude_error(q_est, q_target)`, so a body rotated
/// by a small positive angle about an axis relative to the target has `q_v ≈ φ/2` along it.
pub fn error_vector(q_est: &Attitude, q_target: &Attitude) -> Vector3<f64> {
    // q_est = exp(−φ) ⊗ q_target (attitude::apply_error), so q_target ⊗ q_est⁻¹ = exp(+φ).
    let e = (q_target * q_est.inverse()).into_inner();
    if e.w < 0.0 { -e.imag() } else { e.imag() }
}

/// Rotation vector (rad, body axes) of the shortest rotation with vector part `q_v` (`|q_v| ≤ 1`):
/// `2 asin(|q_v|) q̂_v`.
pub fn rotation_vector(q_v: &Vector3<f64>) -> Vector3<f64> {
    let s = q_v.norm();
    if s < 1e-12 {
        2.0 * q_v
    } else {
        q_v * (2.0 * s.min(1.0).asin() / s)
    }
}

/// The wheels' friction model as a compensation uses it, per wheel, N·m (torque braking the
/// wheel): `T_f0 tanh(n / n_s) + K n` (paper eq. 3 with a smooth sign), Coulomb `T_f0` (N·m)
/// and viscous `K` (N·m per rad/s) per wheel, speed scale `n_s` (rad/s), `n` the wheel speeds
/// relative to the platform (rad/s).
pub fn friction_model_nm(
    coulomb_nm: &Vector3<f64>,
    viscous_nm_per_rad_s: &Vector3<f64>,
    speed_scale_rad_s: f64,
    wheel_speed_rad_s: &Vector3<f64>,
) -> Vector3<f64> {
    Vector3::from_fn(|i, _| {
        let n = wheel_speed_rad_s[i];
        coulomb_nm[i] * (n / speed_scale_rad_s).tanh() + viscous_nm_per_rad_s[i] * n
    })
}

/// Motor torques (N·m, wheel `i` on body axis `i`) giving the platform the body torque `u_body`
/// (N·m) on top of compensating `friction` (N·m, each within `±t_max`): `τ_m = −s u_body + f`
/// with the largest `s ∈ [0, 1]` that keeps every `|τ_m,i| ≤ t_max`, so the body torque keeps
/// its direction. Also whether `s < 1`.
pub fn motor_torque_for(
    u_body: &Vector3<f64>,
    friction: &Vector3<f64>,
    t_max: f64,
) -> (Vector3<f64>, bool) {
    // Largest s in [0, 1] with |−s u_i + f_i| ≤ t_max for every wheel (s = 0 is feasible).
    let mut scale: f64 = 1.0;
    for i in 0..3 {
        let (u, f) = (u_body[i], friction[i]);
        if u > 0.0 {
            scale = scale.min((f + t_max) / u);
        } else if u < 0.0 {
            scale = scale.min((t_max - f) / -u);
        }
    }
    let scale = scale.clamp(0.0, 1.0);
    (-u_body * scale + friction, scale < 1.0)
}

/// One wheel command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelCommand {
    /// Motor torque on each wheel (wheel `i` on body axis `i`), Nm. The platform feels its
    /// opposite.
    pub motor_torque_nm: Vector3<f64>,
    /// Body torque the PD asked for, `u_body = −P q_v − D ω`, before limiting, Nm, body axes.
    pub demanded_body_torque_nm: Vector3<f64>,
    /// True if the torque or the momentum limit changed the command.
    pub saturated: bool,
    /// Attitude error of the estimate relative to the target, rotation vector, rad, body axes
    /// (the shortest rotation; for status).
    pub error_rad: Vector3<f64>,
}

/// The wheel parameters the controller needs, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
struct WheelParams {
    inertia_kgm2: f64,
    max_torque_nm: f64,
    max_speed_rad_s: f64,
    coulomb_nm: Vector3<f64>,
    viscous_nm_per_rad_s: Vector3<f64>,
}

/// PD attitude controller on three body-axis reaction wheels with friction compensation.
#[derive(Debug, Clone, PartialEq)]
pub struct WheelController {
    config: PdFrictionConfig,
    wheels: WheelParams,
}

impl WheelController {
    /// Controller from its gains and the wheels' configuration (torque and speed limits, rotor
    /// inertia, friction model of paper eq. 3).
    pub fn new(config: &PdFrictionConfig, wheels: &WheelConfig) -> Result<Self, ControlError> {
        config.validate()?;
        check_positive("wheels.inertia_kgm2", wheels.inertia_kgm2)?;
        check_positive("wheels.max_torque_nm", wheels.max_torque_nm)?;
        check_positive("wheels.max_speed_rpm", wheels.max_speed_rpm)?;
        for i in 0..3 {
            for (key, x) in [
                ("wheels.coulomb_nm", wheels.coulomb_nm[i]),
                (
                    "wheels.viscous_nm_per_rad_s",
                    wheels.viscous_nm_per_rad_s[i],
                ),
            ] {
                if !(x.is_finite() && x >= 0.0) {
                    return Err(invalid(
                        &format!("{key}[{i}]"),
                        x,
                        "must be a finite number >= 0",
                    ));
                }
            }
        }
        Ok(Self {
            config: config.clone(),
            wheels: WheelParams {
                inertia_kgm2: wheels.inertia_kgm2,
                max_torque_nm: wheels.max_torque_nm,
                max_speed_rad_s: wheels.max_speed_rad_s(),
                coulomb_nm: Vector3::from(wheels.coulomb_nm),
                viscous_nm_per_rad_s: Vector3::from(wheels.viscous_nm_per_rad_s),
            },
        })
    }

    /// The controller's gains and options.
    pub fn config(&self) -> &PdFrictionConfig {
        &self.config
    }

    /// The friction model the compensation uses, per wheel, Nm (torque braking the wheel, so the
    /// platform feels `+T̂_f`): `T_f0 tanh(n / n_s) + K n`, `n` the wheel speed relative to the
    /// platform in rad/s.
    pub fn friction_model(&self, wheel_speed_rad_s: &Vector3<f64>) -> Vector3<f64> {
        friction_model_nm(
            &self.wheels.coulomb_nm,
            &self.wheels.viscous_nm_per_rad_s,
            self.config.friction_speed_scale_rad_s,
            wheel_speed_rad_s,
        )
    }

    /// Motor torque command for the estimated attitude `q_est` (L→B), body rate `rate_b` (rad/s,
    /// body axes, relative to L), a target attitude `q_target` (L→target, fixed in L) and the
    /// measured wheel speeds relative to the platform `wheel_speed_rad_s` (rad/s).
    pub fn command(
        &self,
        q_est: &Attitude,
        rate_b: &Vector3<f64>,
        q_target: &Attitude,
        wheel_speed_rad_s: &Vector3<f64>,
    ) -> Result<WheelCommand, ControlError> {
        check_finite_quaternion(q_est, "q_est")?;
        check_finite_quaternion(q_target, "q_target")?;
        check_finite_vector(rate_b, "rate_b")?;
        check_finite_vector(wheel_speed_rad_s, "wheel_speed_rad_s")?;

        let q_v = error_vector(q_est, q_target);
        let p = Vector3::from(self.config.p_nm);
        let d = Vector3::from(self.config.d_nms);
        let u_body = -p.component_mul(&q_v) - d.component_mul(rate_b);
        let t_max = self.wheels.max_torque_nm;
        let friction = if self.config.friction_compensation {
            self.friction_model(wheel_speed_rad_s)
                .map(|f| f.clamp(-t_max, t_max))
        } else {
            Vector3::zeros()
        };

        let (mut torque, mut saturated) = motor_torque_for(&u_body, &friction, t_max);

        // Momentum limit (per wheel) and a final per-wheel torque clip.
        let (j, n_max, period) = (
            self.wheels.inertia_kgm2,
            self.wheels.max_speed_rad_s,
            self.config.control_period_s,
        );
        for i in 0..3 {
            let n = wheel_speed_rad_s[i];
            let hi = j * (n_max - n) / period;
            let lo = j * (-n_max - n) / period;
            let limited = torque[i].min(hi).max(lo).clamp(-t_max, t_max);
            if limited != torque[i] {
                saturated = true;
                torque[i] = limited;
            }
        }

        Ok(WheelCommand {
            motor_torque_nm: torque,
            demanded_body_torque_nm: u_body,
            saturated,
            error_rad: rotation_vector(&q_v),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, UnitQuaternion};
    use testbed_model::attitude;
    use testbed_model::config::DEG;

    fn controller(compensation: bool) -> WheelController {
        let config = PdFrictionConfig {
            friction_compensation: compensation,
            ..PdFrictionConfig::default()
        };
        WheelController::new(&config, &WheelConfig::default()).unwrap()
    }

    /// The body rotated by `angle` about body/level `axis` relative to the target `q_target`.
    fn rotated(q_target: &Attitude, axis: Vector3<f64>, angle: f64) -> Attitude {
        attitude::apply_error(q_target, &(axis.normalize() * angle))
    }

    #[test]
    fn defaults_have_the_documented_modes() {
        let c = PdFrictionConfig::default();
        c.validate().unwrap();
        let modes = closed_loop_modes(&c.p_nm, &c.d_nms, &[45.2, 46.1, 62.7]);
        for m in modes {
            assert!((m.natural_frequency_rad_s - 0.07).abs() < 1e-12);
            assert!((m.damping_ratio - 0.9).abs() < 1e-12);
        }
        assert!((c.p_nm[0] - 0.44296).abs() < 1e-4 && (c.d_nms[2] - 7.9002).abs() < 1e-3);
    }

    #[test]
    fn error_vector_is_half_the_small_rotation_in_body_axes() {
        let target = attitude::from_heading_pitch_roll(0.8, 0.1, -0.05);
        let phi = Vector3::new(0.01, -0.02, 0.015);
        let q = attitude::apply_error(&target, &phi);
        let q_v = error_vector(&q, &target);
        assert!((q_v - phi / 2.0).norm() < 1e-6);
        // Exact: sin(|φ|/2) φ̂, and agrees with attitude_error.
        let big = Vector3::new(0.4, -1.0, 0.7);
        let q = attitude::apply_error(&target, &big);
        let q_v = error_vector(&q, &target);
        assert!((q_v - big.normalize() * (big.norm() / 2.0).sin()).norm() < 1e-12);
        assert!((rotation_vector(&q_v) - attitude::attitude_error(&q, &target)).norm() < 1e-12);
    }

    #[test]
    fn positive_rotation_about_x_gives_negative_body_torque_and_positive_x_wheel_torque() {
        let c = controller(false);
        let target = attitude::from_heading_pitch_roll(0.3, 0.0, 0.0);
        let q = rotated(&target, Vector3::x(), 2.0 * DEG);
        let cmd = c
            .command(&q, &Vector3::zeros(), &target, &Vector3::zeros())
            .unwrap();
        assert!(cmd.demanded_body_torque_nm.x < 0.0);
        assert!(cmd.motor_torque_nm.x > 0.0);
        assert!(cmd.motor_torque_nm.yz().norm() < 1e-12 * cmd.motor_torque_nm.x.abs().max(1.0));
        assert!((cmd.error_rad - Vector3::x() * 2.0 * DEG).norm() < 1e-12);
        // A positive body rate about X is damped the same way.
        let cmd = c
            .command(
                &target,
                &Vector3::new(0.01, 0.0, 0.0),
                &target,
                &Vector3::zeros(),
            )
            .unwrap();
        assert!(cmd.motor_torque_nm.x > 0.0);
        // And the physics agrees: the body feels −τ_m, which turns it back (negative rate).
        let rate_change = -cmd.motor_torque_nm.x / 45.2;
        assert!(rate_change < 0.0);
    }

    #[test]
    fn compensation_cancels_model_friction_at_nonzero_speed() {
        let wheels = WheelConfig::default();
        let (on, off) = (controller(true), controller(false));
        let target = Attitude::identity();
        let q = rotated(&target, Vector3::new(1.0, -2.0, 0.5), 1.0 * DEG);
        let rate = Vector3::new(1e-4, 2e-4, -3e-4);
        let n = Vector3::new(150.0, -80.0, 3.0); // rad/s, all ≫ n_s = 0.2 rad/s
        let a = on.command(&q, &rate, &target, &n).unwrap();
        let b = off.command(&q, &rate, &target, &n).unwrap();
        assert!(!a.saturated && !b.saturated);
        for i in 0..3 {
            // True friction of eq. 3 with sign(n).
            let tf = wheels.coulomb_nm[i] * n[i].signum() + wheels.viscous_nm_per_rad_s[i] * n[i];
            // Body torque = −τ_m + T_f(n) must equal the PD demand with compensation.
            let body_on = -a.motor_torque_nm[i] + tf;
            assert!(
                (body_on - a.demanded_body_torque_nm[i]).abs() < 1e-12,
                "axis {i}"
            );
            // Without compensation the body is off by exactly the friction.
            let body_off = -b.motor_torque_nm[i] + tf;
            assert!((body_off - b.demanded_body_torque_nm[i] - tf).abs() < 1e-15);
        }
        // At rest the smooth sign gives no Coulomb term, and it is continuous through zero.
        let f0 = on.friction_model(&Vector3::zeros());
        assert_eq!(f0, Vector3::zeros());
        let eps = on.friction_model(&Vector3::repeat(1e-4));
        assert!(eps.x.abs() < 1e-6);
    }

    #[test]
    fn saturation_keeps_the_direction_of_the_body_torque() {
        let c = controller(true);
        let target = Attitude::identity();
        let q = rotated(&target, Vector3::new(3.0, -1.0, 2.0), 40.0 * DEG);
        let n = Vector3::new(200.0, -300.0, 0.0);
        let cmd = c
            .command(&q, &Vector3::new(0.01, 0.0, -0.02), &target, &n)
            .unwrap();
        assert!(cmd.saturated);
        let max = cmd.motor_torque_nm.abs().max();
        assert!(max <= 0.1 + 1e-15 && max > 0.1 - 1e-12, "max {max}");
        // Body torque actually applied (compensation removed) is parallel to the demand.
        let applied = -(cmd.motor_torque_nm - c.friction_model(&n));
        let demand = cmd.demanded_body_torque_nm;
        assert!(applied.cross(&demand).norm() < 1e-12 * demand.norm());
        assert!(applied.dot(&demand) > 0.0);
    }

    #[test]
    fn never_commands_a_wheel_beyond_its_speed_limit() {
        let wheels = WheelConfig::default();
        let c = controller(true);
        let n_max = wheels.max_speed_rad_s();
        let j = wheels.inertia_kgm2;
        let period = c.config().control_period_s;
        let target = Attitude::identity();
        // +X error wants a positive X motor torque: the X wheel speeds up.
        let q = rotated(&target, Vector3::x(), 5.0 * DEG);
        let free = c
            .command(
                &q,
                &Vector3::zeros(),
                &target,
                &Vector3::new(100.0, 0.0, 0.0),
            )
            .unwrap();
        // Within this distance of the limit the unconstrained command would overshoot it.
        let reach = free.motor_torque_nm.x * period / j;
        for n in [
            n_max - 10.0,
            n_max - 3.0,
            n_max - 0.5,
            n_max - 0.01,
            n_max,
            n_max + 2.0,
        ] {
            let speed = Vector3::new(n, 0.0, 0.0);
            let cmd = c.command(&q, &Vector3::zeros(), &target, &speed).unwrap();
            let next = n + cmd.motor_torque_nm.x * period / j;
            assert!(next <= n_max + 1e-9, "n = {n}: next {next}");
            assert_eq!(cmd.saturated, n > n_max - reach, "n = {n}");
        }
        // The same near −n_max for a demand that spins the wheel negative.
        let q = rotated(&target, Vector3::z(), -10.0 * DEG);
        let speed = Vector3::new(0.0, 0.0, -n_max + 1.0);
        let cmd = c.command(&q, &Vector3::zeros(), &target, &speed).unwrap();
        assert!(-n_max + 1.0 + cmd.motor_torque_nm.z * period / j >= -n_max - 1e-9);
        // Control on the other axes is not affected by one full wheel.
        let q = rotated(&target, Vector3::new(1.0, 1.0, 0.0), 3.0 * DEG);
        let speed = Vector3::new(n_max, 0.0, 0.0);
        let cmd = c.command(&q, &Vector3::zeros(), &target, &speed).unwrap();
        assert!(cmd.motor_torque_nm.x <= 0.0 + 1e-12);
        assert!(cmd.motor_torque_nm.y > 0.0);
    }

    #[test]
    fn shortest_rotation_sign_flips_at_180_degrees_without_unwinding() {
        let c = controller(false);
        let target = attitude::from_heading_pitch_roll(0.2, 0.0, 0.0);
        let z = Vector3::zeros();
        let before = c
            .command(
                &rotated(&target, Vector3::z(), 179.0 * DEG),
                &z,
                &target,
                &z,
            )
            .unwrap();
        let after = c
            .command(
                &rotated(&target, Vector3::z(), 181.0 * DEG),
                &z,
                &target,
                &z,
            )
            .unwrap();
        // At +179° turn back by −179° (negative body torque); at +181° = −179°, turn on (positive).
        assert!(before.demanded_body_torque_nm.z < 0.0 && after.demanded_body_torque_nm.z > 0.0);
        assert!((before.error_rad.z - 179.0 * DEG).abs() < 1e-9);
        assert!((after.error_rad.z + 179.0 * DEG).abs() < 1e-9);
        // q and −q are the same attitude: same command.
        let q = rotated(&target, Vector3::new(0.3, -0.2, 1.0), 200.0 * DEG);
        let neg = UnitQuaternion::new_unchecked(-q.into_inner());
        let a = c.command(&q, &z, &target, &z).unwrap();
        let b = c.command(&neg, &z, &target, &z).unwrap();
        assert!((a.motor_torque_nm - b.motor_torque_nm).norm() < 1e-15);
        let neg_target = UnitQuaternion::new_unchecked(-target.into_inner());
        let b = c.command(&q, &z, &neg_target, &z).unwrap();
        assert!((a.motor_torque_nm - b.motor_torque_nm).norm() < 1e-15);
        assert!(a.error_rad.norm() <= std::f64::consts::PI + 1e-12);
    }

    #[test]
    fn non_finite_inputs_and_bad_gains_are_refused() {
        let c = controller(true);
        let q = Attitude::identity();
        let z = Vector3::zeros();
        let err = c
            .command(&q, &Vector3::new(f64::NAN, 0.0, 0.0), &q, &z)
            .unwrap_err();
        assert_eq!(err, ControlError::NonFiniteInput("rate_b"));
        assert!(
            c.command(&q, &z, &q, &Vector3::repeat(f64::INFINITY))
                .is_err()
        );
        let mut config = PdFrictionConfig::default();
        config.p_nm[1] = -1.0;
        let msg = WheelController::new(&config, &WheelConfig::default())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("p_nm[1]") && msg.contains("-1"), "{msg}");
    }

    // ---------------------------------------------------------------------------------------
    // Closed loop with truth feedback (perfect attitude and rate, measured wheel speed = truth),
    // controller at 10 Hz with zero-order hold, run on two truth models:
    //
    // * the shared `testbed_model::physics::Plant` (full configured inertia with its products of
    //   inertia, RK4 with event-located wheel stick–slip, drive limits), and
    // * an independent internal reference model, written before the Plant existed and kept as a
    //   cross-check: rigid platform (diagonal inertia, rotors included) with three body-axis wheels,
    //   `(I − J) ω' = −(τ_m − T_f) − ω × (I ω + J n)`, `J n' = τ_m − T_f − J ω'`, Coulomb + viscous
    //   friction of eq. 3 and stiction (a wheel at `n = 0` stays stuck while `|τ_m| ≤ T_f0`),
    //   integrated at 100 Hz.
    // ---------------------------------------------------------------------------------------

    /// What the closed-loop runs need from a truth model.
    trait Truth {
        /// Attitude, body rate (rad/s), wheel speeds relative to the platform (rad/s).
        fn truth(&self) -> (Attitude, Vector3<f64>, Vector3<f64>);
        /// Hold the motor torques (Nm) for `dt` seconds.
        fn advance(&mut self, motor: &Vector3<f64>, dt: f64);
    }

    struct WheelSim {
        inertia: Matrix3<f64>,
        wheels: WheelConfig,
        q: Attitude,
        rate: Vector3<f64>,
        speed: Vector3<f64>,
    }

    impl WheelSim {
        fn new(q: Attitude) -> Self {
            Self {
                inertia: Matrix3::from_diagonal(&Vector3::new(45.2, 46.1, 62.7)),
                wheels: WheelConfig::default(),
                q,
                rate: Vector3::zeros(),
                speed: Vector3::zeros(),
            }
        }

        fn step(&mut self, motor: &Vector3<f64>, dt: f64) {
            let j = self.wheels.inertia_kgm2;
            let mut friction = Vector3::zeros();
            let mut stuck = [false; 3];
            for i in 0..3 {
                let n = self.speed[i];
                let tf0 = self.wheels.coulomb_nm[i];
                if n == 0.0 && motor[i].abs() <= tf0 {
                    friction[i] = motor[i]; // static friction holds the wheel
                    stuck[i] = true;
                } else {
                    let dir = if n != 0.0 {
                        n.signum()
                    } else {
                        motor[i].signum()
                    };
                    friction[i] = tf0 * dir + self.wheels.viscous_nm_per_rad_s[i] * n;
                }
            }
            let net = motor - friction; // torque accelerating each wheel (absolute)
            let h = self.inertia * self.rate + self.speed * j;
            let lhs = self.inertia - Matrix3::identity() * j;
            let rhs = -net - self.rate.cross(&h);
            let rate_dot = lhs.lu().solve(&rhs).unwrap();
            for i in 0..3 {
                if stuck[i] {
                    continue;
                }
                let n_dot = net[i] / j - rate_dot[i];
                let next = self.speed[i] + n_dot * dt;
                // Crossing zero under friction: stop there (stiction decides next step).
                self.speed[i] = if self.speed[i] != 0.0 && next * self.speed[i] < 0.0 {
                    0.0
                } else {
                    next
                };
            }
            let new_rate = self.rate + rate_dot * dt;
            self.q = attitude::propagate(&self.q, &(0.5 * (self.rate + new_rate)), dt);
            self.rate = new_rate;
        }
    }

    impl Truth for WheelSim {
        fn truth(&self) -> (Attitude, Vector3<f64>, Vector3<f64>) {
            (self.q, self.rate, self.speed)
        }
        fn advance(&mut self, motor: &Vector3<f64>, dt: f64) {
            let sub = (dt / 0.01).round().max(1.0) as usize;
            for _ in 0..sub {
                self.step(motor, dt / sub as f64);
            }
        }
    }

    impl Truth for Plant {
        fn truth(&self) -> (Attitude, Vector3<f64>, Vector3<f64>) {
            let s = self.state();
            (s.q, s.rate_b, s.wheel_speed)
        }
        fn advance(&mut self, motor: &Vector3<f64>, dt: f64) {
            let command = ActuatorCommand {
                wheel_torque_nm: *motor,
                gimbal_rate_rad_s: Vector4::zeros(),
            };
            self.step(&command, dt).unwrap();
        }
    }

    use nalgebra::Vector4;
    use testbed_model::ModelConfig;
    use testbed_model::physics::{ActuatorCommand, Plant, PlatformState};

    struct Run {
        settle_time_s: f64,
        final_error_deg: Vector3<f64>,
        max_motor_torque_nm: f64,
        max_wheel_momentum_nms: f64,
    }

    fn target() -> Attitude {
        attitude::from_heading_pitch_roll(0.5, 0.0, 0.0)
    }

    /// 5° about X, 5° about Y, 20° heading error, at rest, wheels stopped.
    fn initial_attitude() -> Attitude {
        attitude::apply_error(&target(), &Vector3::new(5.0, 5.0, 20.0).map(|d| d * DEG))
    }

    fn plant() -> Plant {
        let state = PlatformState {
            q: initial_attitude(),
            ..PlatformState::default()
        };
        Plant::new(&ModelConfig::default(), state).unwrap()
    }

    /// Settling: the last time any axis's error exceeded 0.1°.
    fn run(truth: &mut dyn Truth, compensation: bool, duration_s: f64) -> Run {
        let c = controller(compensation);
        let j = WheelConfig::default().inertia_kgm2;
        let target = target();
        let period = 0.1;
        let mut settle: f64 = 0.0;
        let (mut max_tau, mut max_h): (f64, f64) = (0.0, 0.0);
        let steps = (duration_s / period).round() as usize;
        for k in 0..steps {
            let (q, rate, speed) = truth.truth();
            let cmd = c.command(&q, &rate, &target, &speed).unwrap();
            max_tau = max_tau.max(cmd.motor_torque_nm.abs().max());
            max_h = max_h.max((speed * j).abs().max());
            if cmd.error_rad.abs().max() > 0.1 * DEG {
                settle = (k + 1) as f64 * period;
            }
            truth.advance(&cmd.motor_torque_nm, period);
        }
        let (q, _, _) = truth.truth();
        let err = attitude::attitude_error(&q, &target) / DEG;
        Run {
            settle_time_s: settle,
            final_error_deg: err,
            max_motor_torque_nm: max_tau,
            max_wheel_momentum_nms: max_h,
        }
    }

    fn check_settling(name: &str, r: &Run) {
        eprintln!(
            "{name}, with compensation: settle (< 0.1°) {:.1} s, error at 300 s {:.5?} deg, max |τ_m| {:.4} Nm, max |h_w| {:.3} Nms",
            r.settle_time_s,
            r.final_error_deg.as_slice(),
            r.max_motor_torque_nm,
            r.max_wheel_momentum_nms
        );
        assert!(r.settle_time_s < 110.0, "settle {}", r.settle_time_s);
        assert!(r.max_motor_torque_nm <= 0.1 + 1e-12);
        assert!(r.max_wheel_momentum_nms < 1.0);
        // Paper (physical test): below 0.02° about X/Y, 0.05° about Z.
        assert!(
            r.final_error_deg.xy().abs().max() < 0.02,
            "{:?}",
            r.final_error_deg
        );
        assert!(r.final_error_deg.z.abs() < 0.05, "{:?}", r.final_error_deg);
    }

    fn check_compensation_gain(name: &str, on: &Run, off: &Run) {
        eprintln!(
            "{name}: steady error with compensation {:.5?} deg, without {:.5?} deg (settle {:.1} s / {:.1} s)",
            on.final_error_deg.as_slice(),
            off.final_error_deg.as_slice(),
            on.settle_time_s,
            off.settle_time_s
        );
        let c = PdFrictionConfig::default();
        // Without compensation the wheel's Coulomb friction holds the platform inside the dead
        // band |φ| ≲ 2 T_f0 / P (rad).
        for i in 0..3 {
            let band_deg = 2.0 * 1.5e-3 / c.p_nm[i] / DEG;
            assert!(off.final_error_deg[i].abs() < 1.05 * band_deg, "axis {i}");
        }
        assert!(off.final_error_deg.norm() > 3.0 * on.final_error_deg.norm());
    }

    #[test]
    fn plant_truth_feedback_settles_from_5_5_20_degrees_in_about_100_s() {
        check_settling("Plant", &run(&mut plant(), true, 300.0));
    }

    #[test]
    fn plant_friction_compensation_reduces_the_steady_error() {
        let on = run(&mut plant(), true, 300.0);
        let off = run(&mut plant(), false, 300.0);
        check_compensation_gain("Plant", &on, &off);
    }

    #[test]
    fn reference_model_settles_and_compensation_helps() {
        let on = run(&mut WheelSim::new(initial_attitude()), true, 300.0);
        let off = run(&mut WheelSim::new(initial_attitude()), false, 300.0);
        check_settling("reference model", &on);
        check_compensation_gain("reference model", &on, &off);
    }
}
