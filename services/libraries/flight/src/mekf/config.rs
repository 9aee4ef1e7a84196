//! [`MekfConfig`]: the filter's parameters in SI units, body axes (noise densities, sensor
//! noises, reference field in the level frame, initial state uncertainty, gating, measurement lag
//! tolerance, iterations), built from the model configuration and validated.

use super::MekfError;
use nalgebra::{Matrix6, Vector3};
use serde::{Deserialize, Serialize};
use testbed_model::config::{DEG, ModelConfig};

/// Filter parameters, SI units, body axes. Build it with [`MekfConfig::from_model`]; every field
/// can then be overridden. Checked by [`MekfConfig::validate`] (called by the constructors).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MekfConfig {
    /// Gyro rate noise density `σv` per body axis, rad/s^½.
    pub gyro_noise_density_rad_sqrt_s: [f64; 3],
    /// Gyro bias random walk `σu` per body axis, rad/s^(3/2).
    pub gyro_bias_walk_rad_s32: [f64; 3],
    /// Inclinometer noise 1σ of θ (body X tilt) and φ (body Y tilt), rad. Must be > 0.
    pub inclinometer_sigma_rad: [f64; 2],
    /// Magnetometer noise 1σ per body axis, tesla. Must be > 0.
    pub magnetometer_sigma_t: [f64; 3],
    /// Reference magnetic field `M_L` in the level frame, tesla.
    pub field_l_t: [f64; 3],
    /// Initial gyro bias estimate, body axes, rad/s.
    pub initial_bias_rad_s: [f64; 3],
    /// Initial attitude error 1σ per body axis, rad (diagonal of `P₀`).
    pub initial_attitude_sigma_rad: [f64; 3],
    /// Initial bias error 1σ per body axis, rad/s (diagonal of `P₀`).
    pub initial_bias_sigma_rad_s: [f64; 3],
    /// Innovation gating on or off.
    pub gate_enabled: bool,
    /// Probability that a sample consistent with the filter passes the gate, in (0, 1).
    pub gate_probability: f64,
    /// Largest age, s, of a vector sample relative to the state's time that is still used
    /// (carried to the state's time); older samples are refused.
    pub max_measurement_lag_s: f64,
    /// Maximum linearisations per update (1 = the plain EKF of the paper).
    pub max_update_iterations: u32,
}

impl MekfConfig {
    /// Parameters from the model configuration: sensor noises and field from the device and
    /// platform sections (converted to SI), the initial bias estimate from the gyro's calibrated
    /// bias (paper Table I), and these **assumed** defaults:
    /// * initial attitude 1σ 1° per axis (a TRIAD start is much better; this is conservative);
    /// * initial bias 1σ 0.005 °/s per axis (the calibration, plus the change of the Earth-rate
    ///   components as the platform turns, up to about 0.003 °/s);
    /// * gating on at probability 0.9999;
    /// * measurement lag tolerance of one gyro period;
    /// * up to 3 linearisations per update.
    pub fn from_model(cfg: &ModelConfig) -> Self {
        let period = if cfg.gyro.rate_hz > 0.0 {
            1.0 / cfg.gyro.rate_hz
        } else {
            0.1
        };
        Self {
            gyro_noise_density_rad_sqrt_s: cfg.gyro.noise_density_rad_sqrt_s().into(),
            gyro_bias_walk_rad_s32: cfg.gyro.bias_walk_rad_s32().into(),
            inclinometer_sigma_rad: cfg.inclinometer.noise_rad(),
            magnetometer_sigma_t: cfg.magnetometer.noise_t().into(),
            field_l_t: cfg.platform.field_l_t().into(),
            initial_bias_rad_s: cfg.gyro.bias_rad_s().into(),
            initial_attitude_sigma_rad: [1.0 * DEG; 3],
            initial_bias_sigma_rad_s: [0.005 * DEG; 3],
            gate_enabled: true,
            gate_probability: 0.9999,
            max_measurement_lag_s: period,
            max_update_iterations: 3,
        }
    }

    /// Refuse parameters the filter cannot use, naming the first offending field.
    pub fn validate(&self) -> Result<(), MekfError> {
        fn fail(key: &str, value: String, reason: &str) -> Result<(), MekfError> {
            Err(MekfError::InvalidConfig {
                key: key.into(),
                value,
                reason: reason.into(),
            })
        }
        let non_negative: [(&str, &[f64]); 2] = [
            (
                "gyro_noise_density_rad_sqrt_s",
                &self.gyro_noise_density_rad_sqrt_s,
            ),
            ("gyro_bias_walk_rad_s32", &self.gyro_bias_walk_rad_s32),
        ];
        for (key, xs) in non_negative {
            for (i, x) in xs.iter().enumerate() {
                if !(x.is_finite() && *x >= 0.0) {
                    return fail(
                        &format!("{key}[{i}]"),
                        format!("{x}"),
                        "must be finite and >= 0",
                    );
                }
            }
        }
        let positive: [(&str, &[f64]); 4] = [
            ("inclinometer_sigma_rad", &self.inclinometer_sigma_rad),
            ("magnetometer_sigma_t", &self.magnetometer_sigma_t),
            (
                "initial_attitude_sigma_rad",
                &self.initial_attitude_sigma_rad,
            ),
            ("initial_bias_sigma_rad_s", &self.initial_bias_sigma_rad_s),
        ];
        for (key, xs) in positive {
            for (i, x) in xs.iter().enumerate() {
                if !(x.is_finite() && *x > 0.0) {
                    return fail(
                        &format!("{key}[{i}]"),
                        format!("{x}"),
                        "must be finite and > 0",
                    );
                }
            }
        }
        for (key, xs) in [
            ("field_l_t", &self.field_l_t),
            ("initial_bias_rad_s", &self.initial_bias_rad_s),
        ] {
            for (i, x) in xs.iter().enumerate() {
                if !x.is_finite() {
                    return fail(&format!("{key}[{i}]"), format!("{x}"), "must be finite");
                }
            }
        }
        if Vector3::from(self.field_l_t).norm() <= 0.0 {
            return fail(
                "field_l_t",
                format!("{:?}", self.field_l_t),
                "must not be zero",
            );
        }
        let p = self.gate_probability;
        if !(p.is_finite() && p > 0.0 && p < 1.0) {
            return fail("gate_probability", format!("{p}"), "must be within (0, 1)");
        }
        let lag = self.max_measurement_lag_s;
        if !(lag.is_finite() && lag >= 0.0) {
            return fail(
                "max_measurement_lag_s",
                format!("{lag}"),
                "must be finite and >= 0",
            );
        }
        if self.max_update_iterations == 0 {
            return fail("max_update_iterations", "0".into(), "must be >= 1");
        }
        Ok(())
    }

    /// `P₀ = diag(σθ₀², σb₀²)`.
    pub fn initial_covariance(&self) -> Matrix6<f64> {
        let mut p = Matrix6::zeros();
        for i in 0..3 {
            p[(i, i)] = self.initial_attitude_sigma_rad[i].powi(2);
            p[(i + 3, i + 3)] = self.initial_bias_sigma_rad_s[i].powi(2);
        }
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mekf::Mekf;
    use crate::mekf::truth::config;
    use testbed_model::attitude::Attitude;

    /// The configuration carries the model's numbers in SI, and bad values are refused by name.
    #[test]
    fn config_from_model_and_validation() {
        let cfg = config();
        assert!((cfg.gyro_noise_density_rad_sqrt_s[0] - 0.000337 * DEG).abs() < 1e-15);
        assert!((cfg.inclinometer_sigma_rad[1] - 0.0008 * DEG).abs() < 1e-15);
        assert!((cfg.magnetometer_sigma_t[2] - 5.52e-4 * 1e-4).abs() < 1e-18);
        assert!((cfg.field_l_t[2] + 0.480e-4).abs() < 1e-18);
        assert!((cfg.max_measurement_lag_s - 0.1).abs() < 1e-15);
        cfg.validate().expect("defaults valid");
        let mut bad = cfg.clone();
        bad.gate_probability = 1.0;
        let e = Mekf::new(bad, 0, Attitude::identity()).expect_err("refused");
        assert!(e.to_string().contains("gate_probability"), "{e}");
        let mut bad = cfg.clone();
        bad.inclinometer_sigma_rad[1] = 0.0;
        assert!(
            bad.validate()
                .expect_err("refused")
                .to_string()
                .contains("inclinometer_sigma_rad[1]")
        );
        let mut p = cfg.initial_covariance();
        p[(0, 1)] = 1.0;
        assert_eq!(
            Mekf::with_state(cfg, 0, Attitude::identity(), Vector3::zeros(), p).err(),
            Some(MekfError::Covariance)
        );
    }
}
