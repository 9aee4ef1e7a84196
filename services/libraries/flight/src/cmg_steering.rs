//! Steering of the four-CMG pyramid and a large-angle eigenaxis slew controller that uses it.
//!
//! # Torque sign
//!
//! With `H = I ω + h` the total momentum (`h` the cluster's momentum, body axes, Nms) and no
//! external torque, `I ω' + h' + ω × (I ω + h) = 0`. Writing the body equation as
//! `I ω' + ω × I ω = τ_cmg`, the torque the CMGs exert on the platform is
//! `τ_cmg = −h' − ω × h`, with `h' = J(δ) δ'` ([`CmgPyramid::jacobian`]). For a desired body torque
//! `u` the steering law therefore asks for `h'_des = −u − ω × h` and solves `J(δ) δ' = h'_des`.
//!
//! # Singularity-robust inverse (Nakamura & Hanafusa; Wie's dithered form)
//!
//! `δ' = Jᵀ (J Jᵀ + λ h0² E)⁻¹ h'_des`, with the singularity measure `m = det(Ĵ Ĵᵀ)`,
//! `Ĵ = J / h0` (dimensionless), `λ = λ0 exp(−μ m)` and the dither matrix
//! `E = [[1, ε3, ε2], [ε3, 1, ε1], [ε2, ε1, 1]]`, `ε_i = ε0 sin(ω_d t + φ_i)`. Away from singular
//! configurations `λ` vanishes and the command is the pseudo-inverse (exact torque); near them it
//! trades a small torque error for a bounded gimbal rate. The off-diagonal terms rotate the
//! request out of the singular direction `u_s` (where `Jᵀ u_s = 0`), so the gimbals move even when
//! the request lies along it and the cluster leaves internal singularities that plain damped
//! least squares (`E = I`) cannot leave. `t` (s) is passed in by the caller: pure maths, no clock.
//! The result is then scaled uniformly so that no gimbal exceeds its rate limit (direction kept).
//!
//! Reported singularity measure: `sqrt(det(Ĵ Ĵᵀ))` = `sqrt(det(J Jᵀ)) / h0³`; 0 at a singular
//! configuration, `≈ 1.09` at `δ = 0` for the standard skew.
//!
//! # Eigenaxis slew
//!
//! [`SlewController`]: rate-limited eigenaxis slew. With `φ` the shortest-rotation error vector
//! (rad, body axes, [`crate::control::error_vector`]) the rate command is `ω_c = −k_a φ`, scaled
//! down (direction kept) to `|ω_c| ≤ ω_max`; the torque is `u = I k_r (ω_c − ω) + ω × I ω`, scaled
//! down to `|u| ≤ u_max`. So the platform accelerates at up to `u_max / I`, coasts about the
//! eigenaxis at `ω_max` and converges exponentially once `k_a |φ| < ω_max`. `ω_max` must keep the
//! cluster momentum inside its envelope with margin: with zero total momentum the cluster holds
//! `h = −I ω`, so [`max_slew_rate_rad_s`] gives `ω_max = f · h_env(I ê) / |I ê|`. Defaults:
//! `k_a = 0.2 1/s`, `k_r = 1 1/s` (closed-loop poles of the linear phase: `−0.28`, `−0.72 1/s`),
//! `ω_max = 0.03 rad/s` (1.72 °/s, ≤ 0.6 of the envelope about every body axis: about Z
//! `0.6 · 4 h0 sin β / 62.7 = 0.031 rad/s`), `u_max = 1 Nm` (one CMG gives `h0 δ'_max = 1.57 Nm`).
//! [`SlewController::slew_time_estimate_s`] predicts the manoeuvre time from these limits.

use crate::control::{
    ControlError, check_finite_quaternion, check_finite_vector, check_positive, error_vector,
    invalid, rotation_vector,
};
use nalgebra::{Matrix3, Vector3, Vector4};
use serde::{Deserialize, Serialize};
use testbed_model::attitude::Attitude;
use testbed_model::config::CmgConfig;
use testbed_model::physics::CmgPyramid;

/// Parameters of the singularity-robust steering inverse.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CmgSteeringConfig {
    /// `λ0`: damping at a singular configuration, relative to `h0²` (dimensionless).
    pub lambda0: f64,
    /// `μ`: how fast the damping fades with `det(Ĵ Ĵᵀ)` (dimensionless).
    pub mu: f64,
    /// `ε0`: dither amplitude of the off-diagonal terms of `E` (dimensionless, keep ≪ 1 so that
    /// `E` stays positive definite).
    pub dither_amplitude: f64,
    /// `ω_d`: dither frequency, rad/s.
    pub dither_frequency_rad_s: f64,
    /// `φ_i`: dither phases of `ε1, ε2, ε3`, rad.
    pub dither_phase_rad: [f64; 3],
}

impl Default for CmgSteeringConfig {
    /// Wie's values (*Space Vehicle Dynamics and Control*, 2nd ed., §7.3): `λ0 = 0.01`, `μ = 10`,
    /// `ε0 = 0.01`, `ω_d = π/2 rad/s`, phases `0, π/2, π`.
    fn default() -> Self {
        use std::f64::consts::{FRAC_PI_2, PI};
        Self {
            lambda0: 0.01,
            mu: 10.0,
            dither_amplitude: 0.01,
            dither_frequency_rad_s: FRAC_PI_2,
            dither_phase_rad: [0.0, FRAC_PI_2, PI],
        }
    }
}

impl CmgSteeringConfig {
    /// Refuse what makes the inverse ill-defined, naming the key and value.
    pub fn validate(&self) -> Result<(), ControlError> {
        for (key, x) in [
            ("lambda0", self.lambda0),
            ("mu", self.mu),
            ("dither_frequency_rad_s", self.dither_frequency_rad_s),
        ] {
            if !(x.is_finite() && x >= 0.0) {
                return Err(invalid(key, x, "must be a finite number >= 0"));
            }
        }
        let e = self.dither_amplitude;
        if !(e.is_finite() && (0.0..0.5).contains(&e)) {
            return Err(invalid(
                "dither_amplitude",
                e,
                "must be within [0, 0.5) (E positive definite)",
            ));
        }
        if !self.dither_phase_rad.iter().all(|x| x.is_finite()) {
            return Err(invalid(
                "dither_phase_rad",
                format!("{:?}", self.dither_phase_rad),
                "must be finite",
            ));
        }
        Ok(())
    }
}

/// One steering command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CmgCommand {
    /// Gimbal rate command per CMG, rad/s (within the rate limit).
    pub gimbal_rate_rad_s: Vector4<f64>,
    /// Body torque this command produces, `−J δ' − ω × h`, Nm, body axes (differs from the request
    /// near singularities and when the rate limit scaled the command).
    pub torque_nm: Vector3<f64>,
    /// `sqrt(det(Ĵ Ĵᵀ))`, `Ĵ = J / h0`: 0 at a singular configuration.
    pub singularity_measure: f64,
    /// The damping `λ` used (relative to `h0²`).
    pub lambda: f64,
    /// True if the gimbal rate limit scaled the command.
    pub saturated: bool,
}

/// `sqrt(det(Ĵ Ĵᵀ))` with `Ĵ = J(δ) / h0` (dimensionless): the singularity measure of the
/// pyramid at gimbal angles `gimbal_rad` (rad).
pub fn singularity_measure(pyramid: &CmgPyramid, gimbal_rad: &Vector4<f64>) -> f64 {
    let j = pyramid.jacobian(gimbal_rad) / pyramid.rotor_momentum_nms();
    (j * j.transpose()).determinant().max(0.0).sqrt()
}

/// Maximum cluster momentum along the unit direction `direction_b` (body axes), Nms: the support
/// function of the momentum envelope, `h0 Σ_i sqrt(1 − (g_i · ê)²)` (each rotor turns in the plane
/// ⟂ its gimbal axis `g_i`, so its best projection is `h0` times the in-plane part of `ê`). Along
/// X or Y it equals [`CmgPyramid::envelope_xy_nms`], along Z [`CmgPyramid::envelope_z_nms`].
/// Returns 0 for a zero or non-finite direction.
pub fn envelope_along(pyramid: &CmgPyramid, direction_b: &Vector3<f64>) -> f64 {
    let Some(e) = direction_b.try_normalize(1e-300) else {
        return 0.0;
    };
    (0..4)
        .map(|i| {
            (1.0 - pyramid.gimbal_axis(i).dot(&e).powi(2))
                .max(0.0)
                .sqrt()
        })
        .sum::<f64>()
        * pyramid.rotor_momentum_nms()
}

/// Largest eigenaxis slew rate (rad/s) about the unit body axis `axis_b` that keeps the cluster
/// momentum `h = −I ω` (zero total momentum) within the fraction `fraction` of its envelope:
/// `fraction · h_env(I ê) / |I ê|`, `inertia` in kg m².
pub fn max_slew_rate_rad_s(
    pyramid: &CmgPyramid,
    inertia: &Matrix3<f64>,
    axis_b: &Vector3<f64>,
    fraction: f64,
) -> f64 {
    let Some(e) = axis_b.try_normalize(1e-300) else {
        return 0.0;
    };
    let ie = inertia * e;
    let norm = ie.norm();
    if norm > 0.0 {
        fraction * envelope_along(pyramid, &ie) / norm
    } else {
        0.0
    }
}

/// Singularity-robust steering of the CMG pyramid.
#[derive(Debug, Clone, PartialEq)]
pub struct CmgSteering {
    pyramid: CmgPyramid,
    max_gimbal_rate_rad_s: f64,
    config: CmgSteeringConfig,
}

impl CmgSteering {
    /// Steering law from its parameters and the CMG configuration (rotor momentum, skew, rate
    /// limit).
    pub fn new(config: &CmgSteeringConfig, cmg: &CmgConfig) -> Result<Self, ControlError> {
        config.validate()?;
        check_positive("cmg.rotor_momentum_nms", cmg.rotor_momentum_nms)?;
        check_positive("cmg.max_gimbal_rate_deg_s", cmg.max_gimbal_rate_deg_s)?;
        if !(cmg.skew_deg.is_finite() && cmg.skew_deg > 0.0 && cmg.skew_deg < 90.0) {
            return Err(invalid(
                "cmg.skew_deg",
                cmg.skew_deg,
                "must be within (0, 90)",
            ));
        }
        Ok(Self {
            pyramid: CmgPyramid::from_config(cmg),
            max_gimbal_rate_rad_s: cmg.max_gimbal_rate_rad_s(),
            config: config.clone(),
        })
    }

    /// The cluster geometry.
    pub fn pyramid(&self) -> &CmgPyramid {
        &self.pyramid
    }

    /// Gimbal rate limit, rad/s.
    pub fn max_gimbal_rate_rad_s(&self) -> f64 {
        self.max_gimbal_rate_rad_s
    }

    /// The dither matrix `E` at time `time_s` (s).
    pub fn dither_matrix(&self, time_s: f64) -> Matrix3<f64> {
        let c = &self.config;
        let eps: [f64; 3] = std::array::from_fn(|i| {
            c.dither_amplitude * (c.dither_frequency_rad_s * time_s + c.dither_phase_rad[i]).sin()
        });
        Matrix3::new(
            1.0, eps[2], eps[1], eps[2], 1.0, eps[0], eps[1], eps[0], 1.0,
        )
    }

    /// Gimbal rates for the desired body torque `torque_b` (Nm, body axes) at gimbal angles
    /// `gimbal_rad` (rad), body rate `rate_b` (rad/s, body axes; pass zero to skip the `ω × h`
    /// term) and time `time_s` (s, drives the dither).
    pub fn steer(
        &self,
        torque_b: &Vector3<f64>,
        gimbal_rad: &Vector4<f64>,
        rate_b: &Vector3<f64>,
        time_s: f64,
    ) -> Result<CmgCommand, ControlError> {
        check_finite_vector(torque_b, "torque_b")?;
        check_finite_vector(rate_b, "rate_b")?;
        if !gimbal_rad.iter().all(|x| x.is_finite()) {
            return Err(ControlError::NonFiniteInput("gimbal_rad"));
        }
        if !time_s.is_finite() {
            return Err(ControlError::NonFiniteInput("time_s"));
        }
        let h0 = self.pyramid.rotor_momentum_nms();
        let (h, jac) = self.pyramid.momentum_and_jacobian(gimbal_rad);
        let j_hat = jac / h0;
        let jjt = j_hat * j_hat.transpose();
        let det = jjt.determinant().max(0.0);
        let lambda = self.config.lambda0 * (-self.config.mu * det).exp();
        let a = jjt + self.dither_matrix(time_s) * lambda;
        // Desired momentum rate, in units of h0 per second.
        let h_dot = (-torque_b - rate_b.cross(&h)) / h0;
        let y = match a.cholesky() {
            Some(chol) => chol.solve(&h_dot),
            None => a.lu().solve(&h_dot).ok_or_else(|| {
                ControlError::Steering(format!(
                    "J Jᵀ + λE singular (det(J Jᵀ) = {det:e}, λ = {lambda:e})"
                ))
            })?,
        };
        let mut rate = j_hat.transpose() * y;
        if !rate.iter().all(|x| x.is_finite()) {
            return Err(ControlError::Steering(format!(
                "non-finite gimbal rate (λ = {lambda:e})"
            )));
        }
        let peak = rate.amax();
        let saturated = peak > self.max_gimbal_rate_rad_s;
        if saturated {
            rate *= self.max_gimbal_rate_rad_s / peak;
        }
        Ok(CmgCommand {
            gimbal_rate_rad_s: rate,
            torque_nm: -(jac * rate) - rate_b.cross(&h),
            singularity_measure: det.sqrt(),
            lambda,
            saturated,
        })
    }
}

/// Gains and limits of the eigenaxis slew.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlewConfig {
    /// `k_a`: commanded rate per radian of attitude error, 1/s.
    pub attitude_gain_per_s: f64,
    /// `k_r`: bandwidth of the rate loop, 1/s (torque `I k_r Δω`).
    pub rate_gain_per_s: f64,
    /// `ω_max`: slew rate limit (norm of the commanded rate), rad/s.
    pub max_rate_rad_s: f64,
    /// `u_max`: limit on the norm of the commanded body torque, Nm.
    pub max_torque_nm: f64,
}

impl Default for SlewConfig {
    fn default() -> Self {
        Self {
            attitude_gain_per_s: 0.2,
            rate_gain_per_s: 1.0,
            max_rate_rad_s: 0.03,
            max_torque_nm: 1.0,
        }
    }
}

impl SlewConfig {
    /// Refuse non-finite or non-positive values, naming the key.
    pub fn validate(&self) -> Result<(), ControlError> {
        check_positive("attitude_gain_per_s", self.attitude_gain_per_s)?;
        check_positive("rate_gain_per_s", self.rate_gain_per_s)?;
        check_positive("max_rate_rad_s", self.max_rate_rad_s)?;
        check_positive("max_torque_nm", self.max_torque_nm)
    }
}

/// One slew command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlewCommand {
    /// Desired body torque, Nm, body axes (give it to [`CmgSteering::steer`]).
    pub torque_nm: Vector3<f64>,
    /// Commanded body rate, rad/s, body axes.
    pub rate_command_rad_s: Vector3<f64>,
    /// Attitude error (shortest rotation vector of the estimate relative to the target), rad,
    /// body axes.
    pub error_rad: Vector3<f64>,
    /// True if the torque limit scaled the torque.
    pub saturated: bool,
}

/// Rate-limited eigenaxis slew controller (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct SlewController {
    config: SlewConfig,
    inertia: Matrix3<f64>,
}

impl SlewController {
    /// Controller for a platform of inertia `inertia` (kg m², body axes).
    pub fn new(config: &SlewConfig, inertia: Matrix3<f64>) -> Result<Self, ControlError> {
        config.validate()?;
        if !testbed_model::config::is_symmetric_positive_definite(&inertia) {
            return Err(invalid(
                "inertia",
                format!("{inertia:?}"),
                "must be symmetric positive definite",
            ));
        }
        Ok(Self {
            config: config.clone(),
            inertia,
        })
    }

    /// The controller's gains and limits.
    pub fn config(&self) -> &SlewConfig {
        &self.config
    }

    /// Desired body torque towards `q_target` (L→target) from the estimate `q_est` (L→B) and
    /// body rate `rate_b` (rad/s, body axes).
    pub fn torque(
        &self,
        q_est: &Attitude,
        rate_b: &Vector3<f64>,
        q_target: &Attitude,
    ) -> Result<SlewCommand, ControlError> {
        check_finite_quaternion(q_est, "q_est")?;
        check_finite_quaternion(q_target, "q_target")?;
        check_finite_vector(rate_b, "rate_b")?;
        let c = &self.config;
        let phi = rotation_vector(&error_vector(q_est, q_target));
        let mut rate_cmd = -phi * c.attitude_gain_per_s;
        let n = rate_cmd.norm();
        if n > c.max_rate_rad_s {
            rate_cmd *= c.max_rate_rad_s / n;
        }
        let mut torque = self.inertia * (rate_cmd - rate_b) * c.rate_gain_per_s
            + rate_b.cross(&(self.inertia * rate_b));
        let n = torque.norm();
        let saturated = n > c.max_torque_nm;
        if saturated {
            torque *= c.max_torque_nm / n;
        }
        Ok(SlewCommand {
            torque_nm: torque,
            rate_command_rad_s: rate_cmd,
            error_rad: phi,
            saturated,
        })
    }

    /// Predicted time (s) of a rest-to-rest slew by `angle_rad` about the unit body axis `axis_b`
    /// until the error is below `settle_angle_rad`: acceleration to `ω_max` at `u_max / I_e`
    /// (`I_e = êᵀ I ê`) plus the rate-loop lag `1/k_r`, coasting at `ω_max` until the error is
    /// `ω_max / k_a`, then the linear phase, whose slow pole is
    /// `p = (k_r − sqrt(k_r² − 4 k_r k_a)) / 2` (or `k_r / 2` if complex), from `ω_max / k_a`
    /// down to the settle angle. For short slews that never reach `ω_max` only the linear phase
    /// counts.
    pub fn slew_time_estimate_s(
        &self,
        angle_rad: f64,
        axis_b: &Vector3<f64>,
        settle_angle_rad: f64,
    ) -> f64 {
        let c = &self.config;
        let e = axis_b.try_normalize(1e-300).unwrap_or_else(Vector3::z);
        let i_e = e.dot(&(self.inertia * e));
        let disc =
            c.rate_gain_per_s * c.rate_gain_per_s - 4.0 * c.rate_gain_per_s * c.attitude_gain_per_s;
        let pole = if disc >= 0.0 {
            (c.rate_gain_per_s - disc.sqrt()) / 2.0
        } else {
            c.rate_gain_per_s / 2.0
        };
        let linear_start = c.max_rate_rad_s / c.attitude_gain_per_s;
        let angle = angle_rad.abs();
        let settle = settle_angle_rad.abs().max(1e-12);
        if angle <= linear_start {
            return (angle / settle).ln().max(0.0) / pole;
        }
        let t_acc = c.max_rate_rad_s * i_e / c.max_torque_nm + 1.0 / c.rate_gain_per_s;
        let acc_angle = 0.5 * c.max_rate_rad_s * t_acc;
        let coast = ((angle - linear_start - acc_angle) / c.max_rate_rad_s).max(0.0);
        t_acc + coast + (linear_start / settle).ln().max(0.0) / pole
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_model::attitude;
    use testbed_model::config::{DEG, ModelConfig};

    fn steering() -> CmgSteering {
        CmgSteering::new(&CmgSteeringConfig::default(), &CmgConfig::default()).unwrap()
    }

    fn deg4(a: f64, b: f64, c: f64, d: f64) -> Vector4<f64> {
        Vector4::new(a, b, c, d) * DEG
    }

    /// Deterministic pseudo-random numbers in [−1, 1) (a small LCG; no dependency needed).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    #[test]
    fn sr_inverse_reproduces_the_torque_away_from_singularities() {
        let s = steering();
        let mut rng = Lcg(7);
        let mut checked = 0;
        for k in 0..400 {
            let d = Vector4::from_fn(|_, _| rng.next() * std::f64::consts::PI);
            if singularity_measure(s.pyramid(), &d) < 0.7 {
                continue; // det(ĴĴᵀ) < 0.49: λ not negligible
            }
            let u = Vector3::from_fn(|_, _| rng.next() * 0.5);
            let w = Vector3::from_fn(|_, _| rng.next() * 0.02);
            let cmd = s.steer(&u, &d, &w, k as f64 * 0.1).unwrap();
            assert!(!cmd.saturated);
            // J δ' = −u − ω × h, i.e. the produced torque equals the request.
            let h = s.pyramid().momentum(&d);
            let residual = s.pyramid().jacobian(&d) * cmd.gimbal_rate_rad_s + u + w.cross(&h);
            assert!(
                residual.norm() < 1e-3 * u.norm(),
                "residual {residual} for {u}"
            );
            assert!((cmd.torque_nm - u).norm() < 1e-3 * u.norm());
            checked += 1;
        }
        assert!(checked > 50, "{checked}");
        // At δ = 0 (h = 0): non-singular, measure sqrt(det diag(2cβ², 2cβ², 4sβ²)) ≈ 1.09.
        let m0 = singularity_measure(s.pyramid(), &Vector4::zeros());
        assert!((m0 - 1.0887).abs() < 1e-3, "{m0}");
    }

    #[test]
    fn rate_limit_scales_the_whole_command() {
        let s = steering();
        let d = deg4(10.0, -20.0, 30.0, 5.0);
        let u = Vector3::new(3.0, -2.0, 4.0);
        let cmd = s.steer(&u, &d, &Vector3::zeros(), 0.0).unwrap();
        assert!(cmd.saturated);
        assert!((cmd.gimbal_rate_rad_s.amax() - 90.0 * DEG).abs() < 1e-12);
        // Produced torque parallel to the request (non-singular configuration).
        assert!(cmd.torque_nm.normalize().dot(&u.normalize()) > 0.999);
    }

    #[test]
    fn internal_singularity_is_bounded_and_escaped_by_the_dither() {
        let s = steering();
        let p = *s.pyramid();
        let ds = deg4(-90.0, 0.0, 90.0, 0.0);
        // Singular: every Jacobian column ⟂ X; h = (2 h0 cos β, 0, 0) is well inside the envelope.
        let m = singularity_measure(&p, &ds);
        assert!(m < 1e-12, "{m}");
        let h = p.momentum(&ds);
        assert!((h - Vector3::new(2.0 * p.skew_rad().cos(), 0.0, 0.0)).norm() < 1e-12);
        assert!(p.jacobian(&ds).row(0).norm() < 1e-12);
        // Elliptic (Wie's test): with the singular direction u = X, Q = diag(u · ĥ_i) and a basis N
        // of the null space of J, P = Nᵀ Q N is definite, so null motion cannot leave it.
        let jac = p.jacobian(&ds);
        let cb = p.skew_rad().cos();
        let null = nalgebra::Matrix4x2::new(1.0, cb, 0.0, 1.0, -1.0, cb, 0.0, -1.0);
        assert!((jac * null).norm() < 1e-12);
        let q = nalgebra::Matrix4::from_diagonal(&Vector4::from_fn(|i, _| {
            p.rotor_direction(i, ds[i]).x
        }));
        let pm = null.transpose() * q * null;
        let eig = pm.symmetric_eigenvalues();
        assert!(eig.iter().all(|&x| x > 1e-3), "P eigenvalues {eig}");

        // Bounded commands around it, for torques in every direction.
        let mut rng = Lcg(3);
        for _ in 0..200 {
            let d = ds + Vector4::from_fn(|_, _| rng.next() * 1.0 * DEG);
            let u = Vector3::from_fn(|_, _| rng.next() * 1.5);
            let cmd = s
                .steer(&u, &d, &Vector3::zeros(), rng.next() * 10.0)
                .unwrap();
            assert!(cmd.gimbal_rate_rad_s.iter().all(|x| x.is_finite()));
            assert!(cmd.gimbal_rate_rad_s.amax() <= s.max_gimbal_rate_rad_s() + 1e-12);
        }

        // A torque request along the singular direction: plain damped least squares (E = I) does
        // not move the gimbals; the dithered inverse does and leaves the singularity.
        let u = Vector3::new(-0.5, 0.0, 0.0); // h' = +0.5 X
        let plain = CmgSteering::new(
            &CmgSteeringConfig {
                dither_amplitude: 0.0,
                ..CmgSteeringConfig::default()
            },
            &CmgConfig::default(),
        )
        .unwrap();
        let stuck = plain.steer(&u, &ds, &Vector3::zeros(), 0.0).unwrap();
        assert!(stuck.gimbal_rate_rad_s.amax() < 1e-12);
        let moving = s.steer(&u, &ds, &Vector3::zeros(), 0.0).unwrap();
        assert!(
            moving.gimbal_rate_rad_s.amax() > 1e-3,
            "{}",
            moving.gimbal_rate_rad_s
        );
        let (mut d, mut t, dt) = (ds, 0.0, 0.01);
        let mut best: f64 = 0.0;
        let mut last = moving;
        while t < 3.0 {
            last = s.steer(&u, &d, &Vector3::zeros(), t).unwrap();
            d += last.gimbal_rate_rad_s * dt;
            t += dt;
            best = best.max(singularity_measure(&p, &d));
        }
        eprintln!(
            "escape: measure {:.3} after 3 s (max {best:.3}); torque {:.4?} vs request {:?}",
            singularity_measure(&p, &d),
            last.torque_nm.as_slice(),
            u.as_slice()
        );
        assert!(singularity_measure(&p, &d) > 0.2);
        assert!((last.torque_nm - u).norm() < 0.05 * u.norm());
    }

    /// Maximum of `h(δ) · ê` over the gimbal angles: a 24⁴ grid, then coordinate-wise local
    /// refinement from the best grid point.
    fn numerical_max(p: &CmgPyramid, e: &Vector3<f64>) -> (f64, f64) {
        let n = 24;
        let step = 2.0 * std::f64::consts::PI / n as f64;
        let angle = |k: usize| -std::f64::consts::PI + k as f64 * step;
        let (mut best, mut arg) = (f64::NEG_INFINITY, Vector4::zeros());
        let mut grid_max = f64::NEG_INFINITY;
        for a in 0..n {
            for b in 0..n {
                for c in 0..n {
                    for d in 0..n {
                        let g = Vector4::new(angle(a), angle(b), angle(c), angle(d));
                        let v = p.momentum(&g).dot(e);
                        grid_max = grid_max.max(v);
                        if v > best {
                            best = v;
                            arg = g;
                        }
                    }
                }
            }
        }
        let mut h = step;
        while h > 1e-10 {
            let mut improved = false;
            for i in 0..4 {
                for sign in [-1.0, 1.0] {
                    let mut g = arg;
                    g[i] += sign * h;
                    let v = p.momentum(&g).dot(e);
                    if v > best {
                        best = v;
                        arg = g;
                        improved = true;
                    }
                }
            }
            if !improved {
                h *= 0.5;
            }
        }
        (best, grid_max)
    }

    #[test]
    fn momentum_envelope_matches_the_analytic_extents() {
        let p = CmgPyramid::from_config(&CmgConfig::default());
        let (xy, z) = (p.envelope_xy_nms(), p.envelope_z_nms());
        for (e, analytic) in [
            (Vector3::x(), xy),
            (-Vector3::x(), xy),
            (Vector3::y(), xy),
            (-Vector3::y(), xy),
            (Vector3::z(), z),
            (-Vector3::z(), z),
        ] {
            let (refined, grid) = numerical_max(&p, &e);
            eprintln!(
                "envelope along {:?}: numerical {refined:.9}, analytic {analytic:.9}",
                e.as_slice()
            );
            assert!((refined - analytic).abs() < 1e-9, "{refined} vs {analytic}");
            assert!(grid <= analytic + 1e-12);
            assert!((envelope_along(&p, &e) - analytic).abs() < 1e-12);
        }
        // No configuration exceeds the support function in any direction.
        let mut rng = Lcg(11);
        for _ in 0..20000 {
            let d = Vector4::from_fn(|_, _| rng.next() * std::f64::consts::PI);
            let e = Vector3::from_fn(|_, _| rng.next());
            let h = p.momentum(&d);
            assert!(h.dot(&e.normalize()) <= envelope_along(&p, &e) + 1e-12);
        }
        // Values: 2 + 2 cos 54.74° = 3.15458 Nms, 4 sin 54.74° = 3.26616 Nms.
        assert!((xy - 3.15458).abs() < 1e-5 && (z - 3.26616).abs() < 1e-5);
    }

    #[test]
    fn default_slew_rate_stays_within_the_envelope_margin() {
        let config = ModelConfig::default();
        let p = CmgPyramid::from_config(&config.cmg);
        let inertia = config.platform.inertia().unwrap();
        for axis in [Vector3::x(), Vector3::y(), Vector3::z()] {
            let limit = max_slew_rate_rad_s(&p, &inertia, &axis, 0.6);
            assert!(
                SlewConfig::default().max_rate_rad_s <= limit,
                "{axis:?}: {limit}"
            );
        }
        let z = max_slew_rate_rad_s(&p, &inertia, &Vector3::z(), 0.6);
        assert!((z - 0.03125).abs() < 2e-4, "{z}");
    }

    #[test]
    fn slew_torque_signs_and_limits() {
        let c = SlewController::new(
            &SlewConfig::default(),
            Matrix3::from_diagonal(&Vector3::new(45.2, 46.1, 62.7)),
        )
        .unwrap();
        let target = Attitude::identity();
        // Body 90° positive about Z from the target: turn back, negative rate and torque about Z.
        let q = attitude::apply_error(&target, &(Vector3::z() * 90.0 * DEG));
        let cmd = c.torque(&q, &Vector3::zeros(), &target).unwrap();
        assert!(cmd.rate_command_rad_s.z < 0.0 && cmd.torque_nm.z < 0.0);
        assert!((cmd.rate_command_rad_s.norm() - 0.03).abs() < 1e-12);
        assert!(cmd.saturated && (cmd.torque_nm.norm() - 1.0).abs() < 1e-12);
        assert!(
            c.torque(&q, &Vector3::new(0.0, f64::NAN, 0.0), &target)
                .is_err()
        );
    }

    /// What the slew runs need from a truth model.
    trait CmgTruth {
        /// Attitude, body rate (rad/s), gimbal angles (rad).
        fn truth(&self) -> (Attitude, Vector3<f64>, Vector4<f64>);
        /// Hold the gimbal rates (rad/s) for `dt` seconds.
        fn advance(&mut self, gimbal_rate: &Vector4<f64>, dt: f64);
    }

    /// Independent reference model (written before the shared `Plant` existed, kept as a
    /// cross-check): rigid platform, `I = diag(45.2, 46.1, 62.7) kg m²`, no external torque, with the
    /// CMG cluster, `I ω' = −J(δ) δ' − ω × (I ω + h(δ))`, ideal gimbal servos, RK2 at 100 Hz.
    struct RigidCmg {
        inertia: Matrix3<f64>,
        pyramid: CmgPyramid,
        q: Attitude,
        w: Vector3<f64>,
        d: Vector4<f64>,
    }

    impl CmgTruth for RigidCmg {
        fn truth(&self) -> (Attitude, Vector3<f64>, Vector4<f64>) {
            (self.q, self.w, self.d)
        }
        fn advance(&mut self, rate: &Vector4<f64>, period: f64) {
            let inv = self.inertia.try_inverse().unwrap();
            let (p, inertia) = (self.pyramid, self.inertia);
            let f = |w: &Vector3<f64>, d: &Vector4<f64>| {
                inv * (-(p.jacobian(d) * rate) - w.cross(&(inertia * w + p.momentum(d))))
            };
            let sub = (period / 0.01).round().max(1.0) as usize;
            let dt = period / sub as f64;
            for _ in 0..sub {
                let k1 = f(&self.w, &self.d);
                let k2 = f(&(self.w + k1 * (dt / 2.0)), &(self.d + rate * (dt / 2.0)));
                let w_new = self.w + k2 * dt;
                self.q = attitude::propagate(&self.q, &(0.5 * (self.w + w_new)), dt);
                self.w = w_new;
                self.d += rate * dt;
            }
        }
    }

    impl CmgTruth for Plant {
        fn truth(&self) -> (Attitude, Vector3<f64>, Vector4<f64>) {
            let s = self.state();
            (s.q, s.rate_b, s.gimbal)
        }
        fn advance(&mut self, rate: &Vector4<f64>, dt: f64) {
            let command = ActuatorCommand {
                wheel_torque_nm: Vector3::zeros(),
                gimbal_rate_rad_s: *rate,
            };
            self.step(&command, dt).unwrap();
        }
    }

    use testbed_model::physics::{ActuatorCommand, Plant, PlatformState};

    /// 90° heading slew (rest to rest, gimbals at 0, zero momentum), slew controller + steering at
    /// 10 Hz with zero-order hold and truth feedback. Done when `|φ| < 0.5°` and `|ω| < 0.05°/s`;
    /// the deadline is [`SlewController::slew_time_estimate_s`] (to 0.2°, where the linear phase's
    /// rate falls below 0.05°/s) + 10 %.
    fn heading_slew(name: &str, truth: &mut dyn CmgTruth, inertia: Matrix3<f64>) {
        let s = steering();
        let p = *s.pyramid();
        let slew = SlewController::new(&SlewConfig::default(), inertia).unwrap();
        let (q_start, _, _) = truth.truth();
        let q_target = attitude::apply_error(&q_start, &(Vector3::z() * 90.0 * DEG));
        assert!(
            (attitude::heading(&q_target) - attitude::heading(&q_start) - 90.0 * DEG).abs() < 1e-9
        );
        let period = 0.1;
        let mut t = 0.0;
        let (mut max_rate, mut min_measure, mut max_h): (f64, f64, f64) = (0.0, f64::INFINITY, 0.0);
        let mut done_at = None;
        let estimate = slew.slew_time_estimate_s(90.0 * DEG, &Vector3::z(), 0.2 * DEG);
        while t < 200.0 {
            let (q, w, d) = truth.truth();
            let cmd = slew.torque(&q, &w, &q_target).unwrap();
            let steer = s.steer(&cmd.torque_nm, &d, &w, t).unwrap();
            max_rate = max_rate.max(steer.gimbal_rate_rad_s.amax());
            min_measure = min_measure.min(steer.singularity_measure);
            max_h = max_h.max(p.momentum(&d).norm());
            if done_at.is_none() && cmd.error_rad.norm() < 0.5 * DEG && w.norm() < 0.05 * DEG {
                done_at = Some(t);
            }
            truth.advance(&steer.gimbal_rate_rad_s, period);
            t += period;
        }
        let (q, w, d) = truth.truth();
        let final_error = attitude::attitude_error(&q, &q_target).norm() / DEG;
        let done = done_at.expect("slew did not complete");
        eprintln!(
            "{name}: 90° CMG slew done (|φ| < 0.5°, |ω| < 0.05°/s) at {done:.1} s, estimate {estimate:.1} s; \
             max gimbal rate {:.2}°/s, min singularity measure {min_measure:.3}, max |h| {max_h:.3} Nms, \
             at 200 s error {final_error:.2e}° rate {:.1e}°/s, gimbals {:.3?}°",
            max_rate / DEG,
            w.norm() / DEG,
            (d / DEG).as_slice()
        );
        assert!(done <= 1.1 * estimate, "done {done} vs estimate {estimate}");
        assert!(
            done >= 0.7 * estimate,
            "estimate too pessimistic: {done} vs {estimate}"
        );
        assert!(max_rate <= 90.0 * DEG + 1e-12);
        assert!(min_measure > 0.3, "{min_measure}");
        assert!(max_h < 0.7 * p.envelope_z_nms());
        assert!(final_error < 0.01);
    }

    #[test]
    fn ninety_degree_heading_slew_with_the_cmgs_on_the_plant() {
        let config = ModelConfig::default();
        let mut plant = Plant::new(&config, PlatformState::default()).unwrap();
        heading_slew("Plant", &mut plant, config.platform.inertia().unwrap());
    }

    #[test]
    fn ninety_degree_heading_slew_with_the_cmgs_on_the_reference_model() {
        let inertia = Matrix3::from_diagonal(&Vector3::new(45.2, 46.1, 62.7));
        let mut model = RigidCmg {
            inertia,
            pyramid: CmgPyramid::from_config(&CmgConfig::default()),
            q: Attitude::identity(),
            w: Vector3::zeros(),
            d: Vector4::zeros(),
        };
        heading_slew("reference model", &mut model, inertia);
    }
}
