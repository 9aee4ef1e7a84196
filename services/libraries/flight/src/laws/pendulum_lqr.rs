//! `pendulum_lqr`: an LQR on the air bearing's linearised pendulous model, on the wheels.
//!
//! # Model
//!
//! A centre of mass offset `r` (body axes, m) from the bearing's centre puts the gravity torque
//! `m g (r × G_B)` on the platform (digest, "Effects the nominal model leaves out"; `G_B` the
//! unit down vector in body axes). About a level target, with the small attitude error `φ`
//! of [`crate::control`] (`A = (I − [φ×]) A_target`, so `G_B = G_L − φ × G_L`, `G_L = −e_z`)
//! and `φ' = ω`:
//!
//! `r × (φ × G_L) = (r·G_L) φ − G_L (r·φ)`, so the torque is `τ₀ + G φ` with the static part
//! `τ₀ = m g (r × G_L)` and `G = m g (r_z I₃ − e_z rᵀ)`: a pendulum about X and Y when the
//! centre of mass is below the pivot (`r_z < 0`, `m g r_z φ` restores), an inverted one above;
//! about Z only the horizontal offset couples the tilt into the heading. State `x = [φ, ω]`:
//!
//! `A = [[0, I₃], [I⁻¹ G, 0]]`, `B = [[0], [I⁻¹]]` (the body torque `u`, N m).
//!
//! # Law
//!
//! `u = −K x − τ₀`, `K = R⁻¹ Bᵀ P` from the Riccati equation ([`crate::lqr`]), the static torque
//! at the target fed forward (the regulator holds the target, not the equilibrium the offset
//! would move it to); the motor torque `τ_m = −u + T̂_f(n)` as in the paper's law, scaled down
//! (direction kept) to the torque limit. `φ` is taken as `2 q_v` (exact to first order).
//!
//! Weights by Bryson's rule: `Q = diag(1/φ_max², 1/ω_max²)`, `R = I/u_max²`. Defaults
//! (assumed): `φ_max = 0.25 rad`, `ω_max = 0.015 rad/s`, `u_max = 0.05 N m` (half a wheel's 0.1
//! N m, digest). For a balanced platform this is, per axis of inertia `I_i`, the loop
//! `ω_n² = sqrt(q₁/ρ) / I_i` and about `ζ = 0.9`: near the paper's PD (0.07 rad/s, 0.9).
//!
//! The offset is the flight software's knowledge of it: `com_offset_m` if given, else the
//! model's `effects.com_offset` (absent: balanced, the double integrator).

use super::{
    ControlLaw, ControlOutput, Drives, LawDefinition, LawInput, LawParams, WheelDrive,
    check_inputs, nominal_inertia, wheel_output,
};
use crate::control::{ControlError, check_positive, error_vector, invalid, rotation_vector};
use crate::lqr;
use nalgebra::{DMatrix, Matrix3, Matrix3x6, Vector3, Vector6};
use serde::{Deserialize, Serialize};
use testbed_model::ModelConfig;

/// Parameters of the LQR (`[controller.pendulum_lqr]`); defaults in the module documentation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PendulumLqrConfig {
    /// `φ_max`: attitude error weighted 1 (Bryson), rad.
    pub max_attitude_error_rad: f64,
    /// `ω_max`: body rate weighted 1 (Bryson), rad/s.
    pub max_rate_rad_s: f64,
    /// `u_max`: body torque weighted 1 (Bryson), N m.
    pub max_torque_nm: f64,
    /// Centre-of-mass offset the law designs for, body axes, m; absent: the model's
    /// `effects.com_offset` (or none).
    pub com_offset_m: Option<[f64; 3]>,
    /// Compensate the wheels' friction (the paper's `− T_f(n)` term).
    pub friction_compensation: bool,
    /// `n_s` of the smooth sign in the friction compensation, rad/s ([`crate::control`]).
    pub friction_speed_scale_rad_s: f64,
}

impl Default for PendulumLqrConfig {
    fn default() -> Self {
        Self {
            max_attitude_error_rad: 0.25,
            max_rate_rad_s: 0.015,
            max_torque_nm: 0.05,
            com_offset_m: None,
            friction_compensation: true,
            friction_speed_scale_rad_s: 0.2,
        }
    }
}

impl LawParams for PendulumLqrConfig {
    fn validate(&self) -> Result<(), ControlError> {
        check_positive("max_attitude_error_rad", self.max_attitude_error_rad)?;
        check_positive("max_rate_rad_s", self.max_rate_rad_s)?;
        check_positive("max_torque_nm", self.max_torque_nm)?;
        check_positive(
            "friction_speed_scale_rad_s",
            self.friction_speed_scale_rad_s,
        )?;
        if let Some(r) = self.com_offset_m
            && !r.iter().all(|x| x.is_finite())
        {
            return Err(invalid("com_offset_m", format!("{r:?}"), "must be finite"));
        }
        Ok(())
    }
}

/// The linearised pendulous model and its weights.
#[derive(Debug, Clone, PartialEq)]
pub struct PendulumModel {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub q: DMatrix<f64>,
    pub r: DMatrix<f64>,
    /// Static gravity torque at the level target `τ₀ = m g (r × G_L)`, N m.
    pub static_torque_nm: Vector3<f64>,
    /// `G`, N m per rad.
    pub stiffness_nm_per_rad: Matrix3<f64>,
}

impl PendulumModel {
    /// The model of `inertia` (kg m²), weight `m g` (N) and offset `r_m` (m, body axes).
    pub fn new(
        inertia: &Matrix3<f64>,
        weight_n: f64,
        r_m: &Vector3<f64>,
        config: &PendulumLqrConfig,
    ) -> Result<Self, ControlError> {
        let inverse = inertia
            .try_inverse()
            .ok_or_else(|| invalid("platform.inertia_kgm2", format!("{inertia:?}"), "singular"))?;
        let down = -Vector3::z();
        let stiffness = (Matrix3::identity() * r_m.z - Vector3::z() * r_m.transpose()) * weight_n;
        let mut a = DMatrix::zeros(6, 6);
        a.view_mut((0, 3), (3, 3)).copy_from(&Matrix3::identity());
        a.view_mut((3, 0), (3, 3)).copy_from(&(inverse * stiffness));
        let mut b = DMatrix::zeros(6, 3);
        b.view_mut((3, 0), (3, 3)).copy_from(&inverse);
        let mut q = DMatrix::zeros(6, 6);
        for i in 0..3 {
            q[(i, i)] = config.max_attitude_error_rad.powi(-2);
            q[(i + 3, i + 3)] = config.max_rate_rad_s.powi(-2);
        }
        let r = DMatrix::identity(3, 3) * config.max_torque_nm.powi(-2);
        Ok(Self {
            a,
            b,
            q,
            r,
            static_torque_nm: r_m.cross(&down) * weight_n,
            stiffness_nm_per_rad: stiffness,
        })
    }

    /// A stabilising start for Newton–Kleinman: `u = −I (ω₀² φ + 2 ω₀ ω) − G φ` makes every
    /// axis `φ'' + 2 ω₀ φ' + ω₀² φ = 0` (ω₀ = 0.05 rad/s).
    fn stabilising_gain(&self, inertia: &Matrix3<f64>) -> DMatrix<f64> {
        let w0 = 0.05;
        let mut k = DMatrix::zeros(3, 6);
        k.view_mut((0, 0), (3, 3))
            .copy_from(&(inertia * (w0 * w0) + self.stiffness_nm_per_rad));
        k.view_mut((0, 3), (3, 3))
            .copy_from(&(inertia * (2.0 * w0)));
        k
    }
}

/// The LQR on the pendulous model.
pub struct PendulumLqr {
    config: PendulumLqrConfig,
    gain: Matrix3x6<f64>,
    static_torque_nm: Vector3<f64>,
    drive: WheelDrive,
}

impl PendulumLqr {
    /// The gain `K` (N m per rad, N m s per rad).
    pub fn gain(&self) -> &Matrix3x6<f64> {
        &self.gain
    }
}

/// The model and LQR solution the law is built from.
pub fn design(
    config: &PendulumLqrConfig,
    model: &ModelConfig,
) -> Result<(PendulumModel, lqr::Lqr), ControlError> {
    let inertia = nominal_inertia(model)?;
    let r_m = config
        .com_offset_m
        .or_else(|| model.effects.com_offset.as_ref().map(|c| c.r_m))
        .unwrap_or([0.0; 3]);
    let weight_n = model.platform.mass_kg * model.platform.gravity_mps2;
    let plant = PendulumModel::new(&inertia, weight_n, &Vector3::from(r_m), config)?;
    let k0 = plant.stabilising_gain(&inertia);
    let solution = lqr::solve(&plant.a, &plant.b, &plant.q, &plant.r, &k0)
        .map_err(|e| invalid("controller.pendulum_lqr", "(design)", &e.to_string()))?;
    Ok((plant, solution))
}

impl LawDefinition for PendulumLqr {
    type Params = PendulumLqrConfig;

    fn build(params: &PendulumLqrConfig, model: &ModelConfig) -> Result<Self, ControlError> {
        let (plant, solution) = design(params, model)?;
        Ok(Self {
            config: params.clone(),
            gain: Matrix3x6::from_fn(|i, j| solution.k[(i, j)]),
            static_torque_nm: plant.static_torque_nm,
            drive: WheelDrive::new(
                &model.wheels,
                params.friction_compensation,
                params.friction_speed_scale_rad_s,
            )?,
        })
    }
}

impl ControlLaw for PendulumLqr {
    fn drives(&self) -> Drives {
        Drives::WHEELS
    }

    fn command(&mut self, input: &LawInput<'_>) -> Result<ControlOutput, ControlError> {
        check_inputs(input)?;
        let q_v = error_vector(input.attitude, input.target);
        let phi = q_v * 2.0;
        let rate = input.rate_b_rad_s;
        let x = Vector6::new(phi.x, phi.y, phi.z, rate.x, rate.y, rate.z);
        let u = -self.gain * x - self.static_torque_nm;
        let (torque, saturated) = self
            .drive
            .motor_torque(&u, &input.telemetry.wheel_speed_rad_s);
        Ok(wheel_output(torque, rotation_vector(&q_v), saturated))
    }

    fn describe(&self) -> String {
        let c = &self.config;
        format!(
            "LQR on the pendulous model, φ_max {} rad, ω_max {} rad/s, u_max {} N m, K diag {:?}",
            c.max_attitude_error_rad,
            c.max_rate_rad_s,
            c.max_torque_nm,
            [self.gain[(0, 0)], self.gain[(1, 1)], self.gain[(2, 2)]]
                .map(|x| (x * 1000.0).round() / 1000.0)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_model::config::ComOffset;

    /// The digest's platform with a pendulous offset: 3 µm, −2 µm horizontal, 10 µm below the
    /// pivot (digest: 2–20 µm horizontal, slightly negative vertical, typical after balancing).
    fn pendulous_model() -> ModelConfig {
        let mut model = ModelConfig::default();
        model.effects.com_offset = Some(ComOffset {
            r_m: [3e-6, -2e-6, -10e-6],
        });
        model
    }

    #[test]
    fn the_gain_solves_the_riccati_equation_and_the_closed_loop_is_stable() {
        let model = pendulous_model();
        let (plant, solution) = design(&PendulumLqrConfig::default(), &model).unwrap();
        let residual =
            lqr::riccati_residual(&plant.a, &plant.b, &plant.q, &plant.r, &solution.p).unwrap();
        let relative = residual.amax() / plant.q.amax();
        eprintln!(
            "pendulum LQR: Riccati residual {relative:.2e} (relative), {} Newton iterations",
            solution.iterations
        );
        assert!(relative < 1e-10, "{residual}");
        // P symmetric positive definite.
        assert!(solution.p.clone().cholesky().is_some());
        let closed = &plant.a - &plant.b * &solution.k;
        let poles = closed.complex_eigenvalues();
        for p in poles.iter() {
            assert!(p.re < 0.0, "pole {p}");
            // Each pole is one of A − BK: det(λI − (A − BK)) vanishes there (checked by the
            // smallest singular value of the complex matrix, relative to its scale).
            let m = DMatrix::<nalgebra::Complex<f64>>::identity(6, 6) * *p
                - closed.map(|x| nalgebra::Complex::new(x, 0.0));
            let sv = m.clone().svd(false, false).singular_values;
            assert!(sv.min() < 1e-9 * sv.max(), "{p}: {sv}");
        }
    }

    #[test]
    fn decoupled_axes_have_the_closed_form_per_axis_gain_and_poles() {
        // Diagonal inertia, offset straight below the pivot: each axis is θ'' = a θ + b u with
        // a = m g r_z / I_i (Z: a = 0), b = 1/I_i, and the 2×2 Riccati equation solves in
        // closed form: p2 = (ρ/b²)(a + sqrt(a² + b² q1/ρ)), p3 = sqrt((ρ/b²)(2 p2 + q2)),
        // K = (b/ρ) [p2, p3]; poles: roots of s² + b k2 s + (b k1 − a).
        let mut model = ModelConfig::default();
        model.platform.inertia_kgm2 = [[45.2, 0.0, 0.0], [0.0, 46.1, 0.0], [0.0, 0.0, 62.7]];
        let r_z = -10e-6;
        model.effects.com_offset = Some(ComOffset {
            r_m: [0.0, 0.0, r_z],
        });
        let config = PendulumLqrConfig::default();
        let (plant, solution) = design(&config, &model).unwrap();
        let poles = (&plant.a - &plant.b * &solution.k).complex_eigenvalues();
        let weight = model.platform.mass_kg * model.platform.gravity_mps2;
        let (q1, q2, rho) = (
            config.max_attitude_error_rad.powi(-2),
            config.max_rate_rad_s.powi(-2),
            config.max_torque_nm.powi(-2),
        );
        for i in 0..3 {
            let inertia = model.platform.inertia_kgm2[i][i];
            let a = if i < 2 { weight * r_z / inertia } else { 0.0 };
            let b = 1.0 / inertia;
            let p2 = rho / (b * b) * (a + (a * a + b * b * q1 / rho).sqrt());
            let p3 = (rho / (b * b) * (2.0 * p2 + q2)).sqrt();
            let (k1, k2) = (b / rho * p2, b / rho * p3);
            let (got1, got2) = (solution.k[(i, i)], solution.k[(i, i + 3)]);
            assert!((got1 - k1).abs() < 1e-9 * k1, "axis {i}: {got1} vs {k1}");
            assert!((got2 - k2).abs() < 1e-9 * k2, "axis {i}: {got2} vs {k2}");
            // Off-diagonal gains vanish.
            for j in (0..6).filter(|&j| j != i && j != i + 3) {
                assert!(solution.k[(i, j)].abs() < 1e-9 * k1);
            }
            let damping = b * k2;
            let stiffness = b * k1 - a;
            let zeta = damping / (2.0 * stiffness.sqrt());
            let wn = stiffness.sqrt();
            eprintln!("axis {i}: ω_n {wn:.4} rad/s, ζ {zeta:.3}");
            // Both roots of the axis's characteristic polynomial are eigenvalues of A − BK.
            let disc = nalgebra::Complex::new(damping * damping - 4.0 * stiffness, 0.0).sqrt();
            for root in [(-damping + disc) / 2.0, (-damping - disc) / 2.0] {
                let nearest = poles
                    .iter()
                    .map(|p| (p - root).norm())
                    .fold(f64::MAX, f64::min);
                assert!(nearest < 1e-9, "axis {i}: root {root} not among {poles}");
            }
            assert!(zeta > 0.8 && zeta < 1.0 && wn > 0.05 && wn < 0.09);
        }
    }
}
