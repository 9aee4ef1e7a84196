//! `complementary`: an explicit complementary filter (Mahony, Hamel & Pflimlin 2008, "Nonlinear
//! complementary filters on the special orthogonal group", IEEE TAC 53(5)), discrete: the gyro
//! integrates the attitude; each vector update pulls it towards the measured directions by a
//! fixed fraction, and an integral term estimates the gyro bias. No covariance is propagated:
//! it reports the steady-state covariance of its linearised error loop (below).
//!
//! # Equations
//!
//! Propagation as the MEKF's ([`crate::mekf`], same hold convention): `ŵ = w_meas − b̂`,
//! `q⁻ = propagate(q⁺, ŵ, Δt)`. At an update, with the predicted down vector `a_g = A(q⁻) G_L`
//! and the measured `y_g` (from the inclinometer angles, unit vectors), the tilt error is
//! `e_g = y_g × a_g` (`= δθ` minus its component along `a_g`, to first order, for the error
//! convention `A_true = (I − [δθ×]) A_est`); the heading error is `e_h = a_g (a_g · (ĥ_y × ĥ_a))`
//! with `ĥ_y`, `ĥ_a` the measured and predicted fields' parts perpendicular to their own down
//! vectors (`y_g`, `a_g`), normalised: the measured pair is the predicted pair rotated by the
//! error, so `ĥ_y × ĥ_a` is `δθ` without its part along `ĥ_a`, and its vertical component is
//! the heading error alone. The magnetometer corrects only the heading, so its larger noise
//! never reaches the tilt. Then `q⁺ = apply_error(q⁻, g_t e_g + g_h e_h)`, `b̂⁺ = b̂ − c (e_g + e_h)`.
//!
//! Gains from time constants and the vector update period `T_u`: `g = 1 − e^{−T_u/τ}` (each
//! update removes that fraction of the error: without bias estimation a step in tilt decays as
//! `(1 − g)ⁿ = e^{−t/τ}`, time constant τ exactly), `c = T_u / τ_b²` (1/s). Per axis the error
//! `x = [θ, β]` (`β = b − b̂`) then follows the linear recurrence from one update to the next
//! `x⁺ = U F x`, `F = [[1, −T_u], [0, 1]]` (propagation), `U = [[1 − g, 0], [c, 1]]` (update);
//! for small `T_u` the continuous loop `θ'' + θ'/τ + θ/τ_b² = 0`.
//!
//! # Reported covariance
//!
//! The steady state of that recurrence with the gyro's rate noise (`σv² T_u`) and bias walk
//! (`σu² T_u`) entering `F` and the measured angle's noise `ν` (inclinometer σ for X and Y,
//! magnetometer σ over the horizontal field for Z) entering the update as
//! `θ⁺ = (1 − g) θ⁻ − g ν`, `β⁺ = β⁻ + c θ⁻ + c ν`, per axis ([`steady_covariance`]).
//!
//! # Defaults (assumed)
//!
//! `τ_t = 5 s` for the tilt, `τ_h = 10 s` for the heading (the magnetometer is ~50× noisier in
//! angle than the inclinometer, digest), `τ_b = 30 s`; `T_u` the inclinometer's period of the
//! model (0.4 s); sensor noises and field from the model as for the MEKF.

use super::{AttitudeFilter, FilterDefinition, FilterEstimate, FilterParams};
use crate::mekf::{
    BlockResult, BlockStatus, MekfConfig, MekfCounters, MekfError, UpdateReport, VectorMeasurements,
};
use nalgebra::{Matrix2, Matrix6, Vector3, Vector6};
use serde::{Deserialize, Serialize};
use testbed_model::ModelConfig;
use testbed_model::attitude::{self, Attitude};

/// Parameters of the complementary filter (`[estimator.complementary]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComplementaryConfig {
    /// `τ_t`: time constant of the tilt correction, s.
    pub tilt_time_constant_s: f64,
    /// `τ_h`: time constant of the heading correction, s.
    pub heading_time_constant_s: f64,
    /// `τ_b`: time constant of the bias integral, s; absent: the bias stays at its initial value.
    pub bias_time_constant_s: Option<f64>,
    /// `T_u`: period of the vector updates the gains are designed for, s (model: inclinometer).
    pub update_period_s: f64,
    /// Initial gyro bias estimate, body axes, rad/s (model: the gyro's calibrated bias).
    pub initial_bias_rad_s: [f64; 3],
    /// Gyro rate noise density `σv` per axis, rad/s^½ (for the reported covariance).
    pub gyro_noise_density_rad_sqrt_s: [f64; 3],
    /// Gyro bias random walk `σu` per axis, rad/s^(3/2) (for the reported covariance).
    pub gyro_bias_walk_rad_s32: [f64; 3],
    /// Inclinometer 1σ of θ and φ, rad (for the reported covariance).
    pub inclinometer_sigma_rad: [f64; 2],
    /// Magnetometer 1σ per body axis, T (for the reported covariance).
    pub magnetometer_sigma_t: [f64; 3],
    /// Reference field `M_L` in the level frame, T.
    pub field_l_t: [f64; 3],
}

impl FilterParams for ComplementaryConfig {
    fn validate(&self) -> Result<(), MekfError> {
        let positive = |key: &str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err(MekfError::InvalidConfig {
                    key: key.into(),
                    value: x.to_string(),
                    reason: "must be a finite number > 0".into(),
                })
            }
        };
        positive("tilt_time_constant_s", self.tilt_time_constant_s)?;
        positive("heading_time_constant_s", self.heading_time_constant_s)?;
        positive("update_period_s", self.update_period_s)?;
        if let Some(t) = self.bias_time_constant_s {
            positive("bias_time_constant_s", t)?;
        }
        let field = Vector3::from(self.field_l_t);
        positive("field_l_t (horizontal part)", field.xy().norm())?;
        let finite = self
            .initial_bias_rad_s
            .iter()
            .chain(&self.gyro_noise_density_rad_sqrt_s)
            .chain(&self.gyro_bias_walk_rad_s32)
            .chain(&self.inclinometer_sigma_rad)
            .chain(&self.magnetometer_sigma_t)
            .all(|x| x.is_finite());
        if !finite {
            return Err(MekfError::NonFinite {
                what: "complementary filter parameter",
            });
        }
        Ok(())
    }
}

impl ComplementaryConfig {
    /// From the model: its sensors' noise and field (as [`MekfConfig::from_model`]) and the
    /// assumed time constants of the module documentation.
    pub fn from_model(model: &ModelConfig) -> Self {
        let mekf = MekfConfig::from_model(model);
        let rate = model.inclinometer.rate_hz;
        Self {
            tilt_time_constant_s: 5.0,
            heading_time_constant_s: 10.0,
            bias_time_constant_s: Some(30.0),
            update_period_s: if rate > 0.0 { 1.0 / rate } else { 0.4 },
            initial_bias_rad_s: mekf.initial_bias_rad_s,
            gyro_noise_density_rad_sqrt_s: mekf.gyro_noise_density_rad_sqrt_s,
            gyro_bias_walk_rad_s32: mekf.gyro_bias_walk_rad_s32,
            inclinometer_sigma_rad: mekf.inclinometer_sigma_rad,
            magnetometer_sigma_t: mekf.magnetometer_sigma_t,
            field_l_t: mekf.field_l_t,
        }
    }

    /// The per-update gains `(g_t, g_h, c)`.
    pub fn gains(&self) -> (f64, f64, f64) {
        let t = self.update_period_s;
        (
            1.0 - (-t / self.tilt_time_constant_s).exp(),
            1.0 - (-t / self.heading_time_constant_s).exp(),
            self.bias_time_constant_s.map_or(0.0, |tb| t / (tb * tb)),
        )
    }
}

/// Steady-state covariance of `[θ, β]` of one axis right after an update (see the module
/// documentation): the fixed point of `P ← U (F P Fᵀ + W) Uᵀ + g_ν g_νᵀ σ_ν²` with
/// `W = diag(σv² T_u, σu² T_u)`, `g_ν = [−g, c]`. `None` if the loop is not stable.
pub fn steady_covariance(
    gain: f64,
    bias_gain: f64,
    period_s: f64,
    rate_noise_density: f64,
    bias_walk: f64,
    angle_sigma: f64,
) -> Option<Matrix2<f64>> {
    let f = Matrix2::new(1.0, -period_s, 0.0, 1.0);
    let u = Matrix2::new(1.0 - gain, 0.0, bias_gain, 1.0);
    let mut w = Matrix2::new(
        rate_noise_density.powi(2) * period_s,
        0.0,
        0.0,
        bias_walk.powi(2) * period_s,
    );
    let noise = nalgebra::Vector2::new(-gain, bias_gain);
    if bias_gain == 0.0 {
        // The bias is not estimated: its error stays what it was (not a steady state), so only
        // the attitude loop `1 − g` must be stable, and the bias walk is left out.
        if !(gain > 0.0 && gain < 2.0) {
            return None;
        }
        w[(1, 1)] = 0.0;
    } else if (u * f)
        .complex_eigenvalues()
        .iter()
        .any(|l| l.norm() >= 1.0)
    {
        return None;
    }
    let mut p = Matrix2::zeros();
    for _ in 0..200_000 {
        let next = u * (f * p * f.transpose() + w) * u.transpose()
            + noise * noise.transpose() * angle_sigma.powi(2);
        let done = (next - p).amax() <= 1e-15 * next.amax();
        p = next;
        if done {
            break;
        }
    }
    Some(p)
}

/// The complementary filter.
#[derive(Debug, Clone)]
pub struct ComplementaryFilter {
    gains: (f64, f64, f64),
    field_l: Vector3<f64>,
    t_ns: u64,
    q: Attitude,
    bias: Vector3<f64>,
    covariance: Matrix6<f64>,
    last_w_meas: Option<Vector3<f64>>,
    counters: MekfCounters,
    last_update: Option<UpdateReport>,
}

impl ComplementaryFilter {
    /// The filter at `t_ns` with attitude `q` (L→B) and the configured initial bias.
    pub fn new(config: &ComplementaryConfig, t_ns: u64, q: Attitude) -> Result<Self, MekfError> {
        config.validate()?;
        let (g_t, g_h, c) = config.gains();
        let field_l = Vector3::from(config.field_l_t);
        let sigma_m = Vector3::from(config.magnetometer_sigma_t).norm() / 3f64.sqrt();
        let angle_sigma = [
            config.inclinometer_sigma_rad[0],
            config.inclinometer_sigma_rad[1],
            sigma_m / field_l.xy().norm(),
        ];
        let mut covariance = Matrix6::zeros();
        for i in 0..3 {
            let gain = if i < 2 { g_t } else { g_h };
            let p = steady_covariance(
                gain,
                c,
                config.update_period_s,
                config.gyro_noise_density_rad_sqrt_s[i],
                config.gyro_bias_walk_rad_s32[i],
                angle_sigma[i],
            )
            .ok_or_else(|| MekfError::InvalidConfig {
                key: "bias_time_constant_s".into(),
                value: format!("{:?}", config.bias_time_constant_s),
                reason: "the error loop is unstable with these time constants".into(),
            })?;
            covariance[(i, i)] = p[(0, 0)];
            covariance[(i, i + 3)] = p[(0, 1)];
            covariance[(i + 3, i)] = p[(1, 0)];
            // A bias not estimated still has an error: keep the block invertible.
            covariance[(i + 3, i + 3)] = p[(1, 1)].max(1e-24);
        }
        Ok(Self {
            gains: (g_t, g_h, c),
            field_l,
            t_ns,
            q,
            bias: Vector3::from(config.initial_bias_rad_s),
            covariance,
            last_w_meas: None,
            counters: MekfCounters::default(),
            last_update: None,
        })
    }

    fn advance_to(&mut self, t_ns: u64, w_meas: &Vector3<f64>) {
        let dt_s = (t_ns - self.t_ns) as f64 * 1e-9;
        if dt_s > 0.0 {
            self.q = attitude::propagate(&self.q, &(w_meas - self.bias), dt_s);
            self.q.renormalize();
        }
        self.t_ns = t_ns;
    }
}

impl AttitudeFilter for ComplementaryFilter {
    fn propagate(&mut self, t_ns: u64, w_meas_rad_s: &Vector3<f64>) -> Result<(), MekfError> {
        crate::mekf::check_gyro_sample(&mut self.counters, t_ns, self.t_ns, w_meas_rad_s)?;
        self.advance_to(t_ns, w_meas_rad_s);
        self.last_w_meas = Some(*w_meas_rad_s);
        self.counters.propagations += 1;
        Ok(())
    }

    fn update(
        &mut self,
        t_ns: u64,
        measurements: &VectorMeasurements,
    ) -> Result<UpdateReport, MekfError> {
        if t_ns < self.t_ns {
            self.counters.out_of_order_vector += 1;
            return Err(MekfError::Stale {
                t_ns,
                state_ns: self.t_ns,
                tolerance_ns: 0,
            });
        }
        if t_ns > self.t_ns {
            // Stamped ahead: extrapolate with the held rate (rest before any gyro sample).
            let held = self.last_w_meas.unwrap_or(self.bias);
            self.advance_to(t_ns, &held);
            self.counters.extrapolations += 1;
        }
        let (g_t, g_h, c) = self.gains;
        let predicted_down = attitude::gravity_b(&self.q);
        let mut report = UpdateReport {
            t_ns,
            lag_s: 0.0,
            gravity: BlockResult::default(),
            magnetic: BlockResult::default(),
            iterations: 0,
            correction: Vector6::zeros(),
        };
        let mut tilt_error = Vector3::zeros();
        let mut measured_down = predicted_down;
        match measurements.tilt_rad {
            None => self.counters.gravity.missing += 1,
            Some([theta, phi]) => match attitude::gravity_from_tilt(theta, phi) {
                Some(measured) if measured.iter().all(|x| x.is_finite()) => {
                    tilt_error = measured.cross(&predicted_down);
                    measured_down = measured;
                    report.gravity.status = BlockStatus::Applied;
                    self.counters.gravity.applied += 1;
                }
                _ => {
                    report.gravity.status = BlockStatus::Invalid;
                    self.counters.gravity.invalid += 1;
                }
            },
        }
        let mut heading_error = Vector3::zeros();
        match measurements.field_b_t {
            None => self.counters.magnetic.missing += 1,
            Some(measured) => {
                // Each field's part perpendicular to its own down vector: the measured pair is
                // the predicted pair rotated by the error, so the tilt error drops out and
                // the cross product's component along the vertical is the heading error.
                let horizontal = |v: Vector3<f64>, down: &Vector3<f64>| v - down * v.dot(down);
                let predicted =
                    horizontal(self.q * self.field_l, &predicted_down).try_normalize(1e-30);
                let seen = horizontal(measured, &measured_down).try_normalize(1e-30);
                match (measured.iter().all(|x| x.is_finite()), seen, predicted) {
                    (true, Some(seen), Some(predicted)) => {
                        heading_error =
                            predicted_down * seen.cross(&predicted).dot(&predicted_down);
                        report.magnetic.status = BlockStatus::Applied;
                        self.counters.magnetic.applied += 1;
                    }
                    _ => {
                        report.magnetic.status = BlockStatus::Invalid;
                        self.counters.magnetic.invalid += 1;
                    }
                }
            }
        }
        let applied = report.gravity.status == BlockStatus::Applied
            || report.magnetic.status == BlockStatus::Applied;
        if applied {
            let dtheta = tilt_error * g_t + heading_error * g_h;
            let dbias = -(tilt_error + heading_error) * c;
            self.q = attitude::apply_error(&self.q, &dtheta);
            self.q.renormalize();
            self.bias += dbias;
            report.iterations = 1;
            report.correction =
                Vector6::new(dtheta.x, dtheta.y, dtheta.z, dbias.x, dbias.y, dbias.z);
            self.counters.updates_applied += 1;
        } else {
            self.counters.updates_skipped += 1;
        }
        self.last_update = Some(report);
        Ok(report)
    }

    fn estimate(&self) -> FilterEstimate {
        FilterEstimate {
            t_ns: self.t_ns,
            attitude: self.q,
            rate_rad_s: self.last_w_meas.map_or(Vector3::zeros(), |w| w - self.bias),
            bias_rad_s: self.bias,
            covariance: self.covariance,
            last_update: self.last_update,
            counters: self.counters,
        }
    }

    fn counters(&self) -> MekfCounters {
        self.counters
    }
}

impl FilterDefinition for ComplementaryFilter {
    type Params = ComplementaryConfig;

    fn default_params(model: &ModelConfig) -> ComplementaryConfig {
        ComplementaryConfig::from_model(model)
    }

    fn initialise(
        params: &ComplementaryConfig,
        t_ns: u64,
        gravity_b: &Vector3<f64>,
        field_b_t: &Vector3<f64>,
    ) -> Result<Self, MekfError> {
        let field_l = Vector3::from(params.field_l_t);
        let q = crate::mekf::triad(gravity_b, field_b_t, &attitude::gravity_l(), &field_l)?;
        Self::new(params, t_ns, q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_model::config::DEG;

    const PERIOD_NS: u64 = 100_000_000;

    /// A step in tilt: the filter starts believing a `step` error, measures the true (level,
    /// at rest, bias-free) attitude exactly; the error of each update, per axis.
    fn step_response(
        config: &ComplementaryConfig,
        step: Vector3<f64>,
        updates: usize,
    ) -> Vec<Vector3<f64>> {
        let truth = Attitude::identity();
        let believed = attitude::apply_error(&truth, &(-step));
        let mut f = ComplementaryFilter::new(config, 0, believed).unwrap();
        let field_b = truth * Vector3::from(config.field_l_t);
        let tilt = attitude::tilt_angles(&truth);
        let every = (config.update_period_s * 1e9).round() as u64 / PERIOD_NS;
        let mut errors = Vec::new();
        for k in 1..=(updates as u64 * every) {
            let t = k * PERIOD_NS;
            f.propagate(t, &Vector3::zeros()).unwrap();
            if k % every == 0 {
                f.update(
                    t,
                    &VectorMeasurements {
                        tilt_rad: Some(tilt),
                        field_b_t: Some(field_b),
                    },
                )
                .unwrap();
                errors.push(attitude::attitude_error(&truth, &f.estimate().attitude));
            }
        }
        errors
    }

    fn config() -> ComplementaryConfig {
        let mut c = ComplementaryConfig::from_model(&ModelConfig::default());
        c.initial_bias_rad_s = [0.0; 3];
        c
    }

    #[test]
    fn without_bias_estimation_a_tilt_step_decays_with_the_time_constant() {
        let mut c = config();
        c.bias_time_constant_s = None;
        let step = Vector3::new(1e-3, -0.5e-3, 2e-3);
        let errors = step_response(&c, step, 50);
        let (g_t, g_h, _) = c.gains();
        for (n, e) in errors.iter().enumerate() {
            let t = (n + 1) as f64 * c.update_period_s;
            // (1 − g)ⁿ = e^{−t/τ}: the closed form of the first-order loop.
            let expected = Vector3::new(
                step.x * (-t / c.tilt_time_constant_s).exp(),
                step.y * (-t / c.tilt_time_constant_s).exp(),
                step.z * (-t / c.heading_time_constant_s).exp(),
            );
            // The loop is linear to first order: what is left is second order in the step
            // (rotations about different axes corrected by different gains do not commute),
            // below 0.1 |θ0|².
            assert!(
                (e - expected).amax() < 0.1 * step.norm_squared(),
                "update {n}: {e} vs {expected}"
            );
            assert!(
                ((1.0 - g_t).powi(n as i32 + 1) - (-t / c.tilt_time_constant_s).exp()).abs()
                    < 1e-12
            );
            let _ = g_h;
        }
    }

    #[test]
    fn with_bias_estimation_the_error_follows_the_linear_recurrence() {
        let c = config();
        let step = Vector3::new(1e-3, 1e-3, 1e-3);
        let errors = step_response(&c, step, 200);
        let (g_t, g_h, bias_gain) = c.gains();
        for axis in 0..3 {
            let g = if axis < 2 { g_t } else { g_h };
            let m = Matrix2::new(1.0 - g, 0.0, bias_gain, 1.0)
                * Matrix2::new(1.0, -c.update_period_s, 0.0, 1.0);
            let mut x = nalgebra::Vector2::new(step[axis], 0.0);
            for (n, e) in errors.iter().enumerate() {
                x = m * x;
                // First order exact; second-order terms below 0.1 |θ0|² (as above).
                assert!(
                    (e[axis] - x[0]).abs() < 0.1 * step.norm_squared(),
                    "axis {axis}, update {n}: {} vs {}",
                    e[axis],
                    x[0]
                );
            }
        }
    }

    #[test]
    fn the_steady_covariance_is_the_fixed_point_and_tilt_noise_is_filtered() {
        let c = config();
        let (g_t, _, bias_gain) = c.gains();
        let p = steady_covariance(g_t, bias_gain, 0.4, 1e-5, 1e-8, 2e-5).unwrap();
        let f = Matrix2::new(1.0, -0.4, 0.0, 1.0);
        let u = Matrix2::new(1.0 - g_t, 0.0, bias_gain, 1.0);
        let w = Matrix2::new(1e-10 * 0.4, 0.0, 0.0, 1e-16 * 0.4);
        let nu = nalgebra::Vector2::new(-g_t, bias_gain);
        let next = u * (f * p * f.transpose() + w) * u.transpose() + nu * nu.transpose() * 4e-10;
        assert!((next - p).amax() < 1e-12 * p.amax());
        // Without gyro noise the tilt σ is the measurement's times sqrt(g / (2 − g)) (first
        // order loop, no bias): the filter averages over about 2/g samples.
        let q = steady_covariance(g_t, 0.0, 0.4, 0.0, 0.0, 2e-5).unwrap();
        let expected = 2e-5 * (g_t / (2.0 - g_t)).sqrt();
        assert!((q[(0, 0)].sqrt() - expected).abs() < 1e-9 * expected);
        let _ = DEG;
    }
}
