//! Model configuration: every physical parameter of the platform, its devices and the effects the
//! nominal model leaves out, loaded from TOML.
//!
//! Defaults are the values of the paper ("A 3-axis Simulator for Spacecraft Attitude Control
//! Research", Dai & Jin, ICIA 2010) and this project's assumptions where it is silent, with the
//! source of each noted on the field: **paper** (a number printed in the paper), **derived**
//! (computed from paper numbers) or **assumed** (not in the paper; this project's default).
//! `docs/parameters.md` lists them all.
//!
//! Units at this edge carry their name in the key (`_deg`, `_rpm`, `_gauss`, ...); the models work
//! in SI and convert once, through the `*_si` accessors below.
//!
//! Unknown keys are refused (`deny_unknown_fields`), and [`ModelConfig::validate`] refuses
//! non-finite numbers, negative magnitudes and an inertia that is not symmetric positive definite,
//! naming the key and the value.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

mod effects;
mod validate;

pub use effects::*;

/// Degrees to radians.
pub const DEG: f64 = std::f64::consts::PI / 180.0;
/// Revolutions per minute to rad/s.
pub const RPM: f64 = 2.0 * std::f64::consts::PI / 60.0;
/// Gauss to tesla.
pub const GAUSS: f64 = 1e-4;
/// Earth's sidereal rotation rate, rad/s (IERS value).
pub const EARTH_RATE_RAD_S: f64 = 7.292_115e-5;

/// Why a configuration was refused.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read model configuration {path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error("model configuration {origin}: {message}")]
    Parse { origin: String, message: String },
    #[error("model configuration: `{key}` = {value}: {reason}")]
    Invalid {
        key: String,
        value: String,
        reason: String,
    },
}

/// Complete model configuration of the test bed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ModelConfig {
    pub platform: PlatformConfig,
    pub gyro: GyroConfig,
    pub inclinometer: InclinometerConfig,
    pub magnetometer: MagnetometerConfig,
    pub wheels: WheelConfig,
    pub cmg: CmgConfig,
    pub effects: EffectsConfig,
    /// The six cold-gas thrusters; off unless the table is present.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thrusters: Option<crate::thruster_config::ThrusterConfig>,
}

/// The rigid platform on its air bearing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlatformConfig {
    /// Total inertia about the bearing centre in body axes, kg m², wheels' and CMGs' rotors
    /// included. **assumed** (digest).
    pub inertia_kgm2: [[f64; 3]; 3],
    /// Total floating mass, kg. **assumed** (digest).
    pub mass_kg: f64,
    /// Local gravity, m/s². **assumed** (digest).
    pub gravity_mps2: f64,
    /// Lab latitude, degrees north. **assumed** (digest); used by the `earth_rate` effect.
    pub latitude_deg: f64,
    /// Mechanical tilt stop about body X and Y, degrees. **paper** (±30°).
    pub tilt_limit_deg: f64,
    /// Lab magnetic field in the level frame L (x north, y west, z up), gauss. **assumed** (digest).
    pub field_l_gauss: [f64; 3],
}

impl Default for PlatformConfig {
    fn default() -> Self {
        Self {
            inertia_kgm2: [[45.2, 0.3, -0.2], [0.3, 46.1, 0.4], [-0.2, 0.4, 62.7]],
            mass_kg: 350.0,
            gravity_mps2: 9.806,
            latitude_deg: 43.88,
            tilt_limit_deg: 30.0,
            field_l_gauss: [0.255, 0.040, -0.480],
        }
    }
}

/// The three fibre-optic gyros (VG-951D), one per body axis.
/// Model: `w_meas = w + b + eta_v`, `b' = eta_u` (paper eq. 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GyroConfig {
    /// Sample rate, Hz, which is also the tick of the estimation and control loop (1 Hz to
    /// 1 kHz). **paper** (10 Hz).
    pub rate_hz: f64,
    /// Initial bias per axis, °/s. **paper** Table I (includes the Earth's rotation).
    pub bias_deg_s: [f64; 3],
    /// Rate noise density `sigma_v` per axis, °/s^½. **derived** from Table I sample noise
    /// × sqrt(0.1 s) (digest, Table 3).
    pub noise_density_deg_sqrt_s: [f64; 3],
    /// Bias random walk `sigma_u` per axis, °/s^(3/2). **assumed** (illegible in the paper).
    pub bias_walk_deg_s32: [f64; 3],
    /// Output resolution (quantum), °/s. **paper** (1e-5 °/s).
    pub resolution_deg_s: f64,
    /// Measurement range ±, °/s. **paper** (±80 °/s).
    pub range_deg_s: f64,
}

impl Default for GyroConfig {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            bias_deg_s: [-0.00476, -0.00434, -0.00325],
            noise_density_deg_sqrt_s: [0.000337, 0.000334, 0.000312],
            bias_walk_deg_s32: [3e-7; 3],
            resolution_deg_s: 1e-5,
            range_deg_s: 80.0,
        }
    }
}

/// The two-axis inclinometer (LE-30): tilt angles θ (body X) and φ (body Y) against the level
/// plane, `G_B = [sin θ, sin φ, -sqrt(1 - sin²θ - sin²φ)]` (paper eq. 2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InclinometerConfig {
    /// Sample rate, Hz. **paper** (2.5 Hz).
    pub rate_hz: f64,
    /// White noise 1σ of θ and φ, degrees. **paper** Table 2.
    pub noise_deg: [f64; 2],
    /// Measurement range ±, degrees. **paper** (±25°).
    pub range_deg: f64,
}

impl Default for InclinometerConfig {
    fn default() -> Self {
        Self {
            rate_hz: 2.5,
            noise_deg: [0.0010, 0.0008],
            range_deg: 25.0,
        }
    }
}

/// The three-axis magnetometer (CXM-539): `M_meas = A(q) M_L + eta_M`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MagnetometerConfig {
    /// Sample rate, Hz. **paper** (2.5 Hz, programmable 1–150 Hz).
    pub rate_hz: f64,
    /// White noise 1σ per body axis, gauss. **paper** (digest sensor table).
    pub noise_gauss: [f64; 3],
    /// Measurement range ±, gauss. **paper** (±1 G).
    pub range_gauss: f64,
}

impl Default for MagnetometerConfig {
    fn default() -> Self {
        Self {
            rate_hz: 2.5,
            noise_gauss: [6.9e-4, 3.68e-4, 5.52e-4],
            range_gauss: 1.0,
        }
    }
}

/// The three reaction wheels on body X, Y, Z. Friction (paper eq. 3):
/// `T_f(n) = T_f0 sign(n) + K n`, n the wheel speed relative to the platform.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WheelConfig {
    /// Rotor inertia about its spin axis, kg m². **derived** (1 Nms at 6000 rpm).
    pub inertia_kgm2: f64,
    /// Motor torque limit, Nm. **paper** (0.1 Nm).
    pub max_torque_nm: f64,
    /// Speed limit, rpm. **paper** (6000 rpm, 1 Nms).
    pub max_speed_rpm: f64,
    /// Coulomb friction `T_f0` per wheel, Nm. **assumed** (paper's fit illegible).
    pub coulomb_nm: [f64; 3],
    /// Viscous friction `K` per wheel, Nm/(rad/s). **assumed** (paper's fit illegible).
    pub viscous_nm_per_rad_s: [f64; 3],
    /// Telemetry rate, Hz. **assumed** (the control loop's 10 Hz).
    pub telemetry_rate_hz: f64,
    /// Tachometer white noise 1σ, rpm. **assumed**.
    pub speed_noise_rpm: f64,
    /// Tachometer resolution, rpm. **assumed**.
    pub speed_resolution_rpm: f64,
}

impl Default for WheelConfig {
    fn default() -> Self {
        Self {
            inertia_kgm2: 1.0 / (6000.0 * RPM),
            max_torque_nm: 0.1,
            max_speed_rpm: 6000.0,
            coulomb_nm: [1.5e-3; 3],
            viscous_nm_per_rad_s: [3.0e-6; 3],
            telemetry_rate_hz: 10.0,
            speed_noise_rpm: 0.1,
            speed_resolution_rpm: 0.01,
        }
    }
}

/// The four control moment gyros in a pyramid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CmgConfig {
    /// Constant rotor momentum of each CMG, Nms. **paper** (1 Nms).
    pub rotor_momentum_nms: f64,
    /// Pyramid skew angle between each gimbal axis and body Z, degrees. **assumed** (standard
    /// 54.74°, which makes the momentum envelope nearly spherical).
    pub skew_deg: f64,
    /// Gimbal rate limit, °/s. **paper** (90 °/s).
    pub max_gimbal_rate_deg_s: f64,
    /// Stepper motor step at the gimbal (after the gear reducer), degrees. **assumed**.
    pub stepper_step_deg: f64,
    /// Gimbal encoder resolution, degrees. **assumed**.
    pub encoder_resolution_deg: f64,
    /// Telemetry rate, Hz. **assumed** (the control loop's 10 Hz).
    pub telemetry_rate_hz: f64,
}

impl Default for CmgConfig {
    fn default() -> Self {
        Self {
            rotor_momentum_nms: 1.0,
            skew_deg: 54.74,
            max_gimbal_rate_deg_s: 90.0,
            stepper_step_deg: 0.0072,
            encoder_resolution_deg: 360.0 / 65536.0,
            telemetry_rate_hz: 10.0,
        }
    }
}

impl ModelConfig {
    /// Parse and validate a TOML document; `origin` names it in errors (a path, or `"<inline>"`).
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let config: ModelConfig = toml::from_str(text).map_err(|e| ConfigError::Parse {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        config.validate()?;
        Ok(config)
    }

    /// Read, parse and validate a TOML file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// The configuration as TOML (round-trips through [`ModelConfig::from_toml_str`]).
    pub fn to_toml_string(&self) -> String {
        toml::to_string_pretty(self).expect("a ModelConfig always serialises")
    }

    /// The platform inertia the plant integrates: nominal, with `effects.inertia_error` applied.
    /// `None` if it is not symmetric positive definite (refused by [`ModelConfig::validate`]).
    pub fn true_inertia(&self) -> Option<Matrix3<f64>> {
        let mut inertia = self.platform.inertia()?;
        if let Some(err) = &self.effects.inertia_error {
            for i in 0..3 {
                inertia[(i, i)] *= 1.0 + err.fraction[i];
            }
            if let Some(p) = err.products_kgm2 {
                for (k, (a, b)) in [(0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
                    inertia[(a, b)] += p[k];
                    inertia[(b, a)] += p[k];
                }
            }
        }
        is_symmetric_positive_definite(&inertia).then_some(inertia)
    }
}

impl PlatformConfig {
    /// Nominal inertia, kg m², body axes; `None` if not symmetric positive definite.
    pub fn inertia(&self) -> Option<Matrix3<f64>> {
        let m = Matrix3::from_fn(|i, j| self.inertia_kgm2[i][j]);
        is_symmetric_positive_definite(&m).then_some(m)
    }
    /// Lab field in the level frame, tesla.
    pub fn field_l_t(&self) -> Vector3<f64> {
        Vector3::from(self.field_l_gauss) * GAUSS
    }
    /// Tilt stop, rad.
    pub fn tilt_limit_rad(&self) -> f64 {
        self.tilt_limit_deg * DEG
    }
}

impl GyroConfig {
    /// Sample period, s.
    pub fn period_s(&self) -> f64 {
        1.0 / self.rate_hz
    }
    /// Initial bias, rad/s.
    pub fn bias_rad_s(&self) -> Vector3<f64> {
        Vector3::from(self.bias_deg_s) * DEG
    }
    /// `sigma_v`, rad/s^½.
    pub fn noise_density_rad_sqrt_s(&self) -> Vector3<f64> {
        Vector3::from(self.noise_density_deg_sqrt_s) * DEG
    }
    /// `sigma_u`, rad/s^(3/2).
    pub fn bias_walk_rad_s32(&self) -> Vector3<f64> {
        Vector3::from(self.bias_walk_deg_s32) * DEG
    }
}

impl InclinometerConfig {
    /// θ and φ noise 1σ, rad.
    pub fn noise_rad(&self) -> [f64; 2] {
        [self.noise_deg[0] * DEG, self.noise_deg[1] * DEG]
    }
}

impl MagnetometerConfig {
    /// Noise 1σ per axis, tesla.
    pub fn noise_t(&self) -> Vector3<f64> {
        Vector3::from(self.noise_gauss) * GAUSS
    }
}

impl WheelConfig {
    /// Speed limit, rad/s.
    pub fn max_speed_rad_s(&self) -> f64 {
        self.max_speed_rpm * RPM
    }
    /// Tachometer white noise 1σ, rad/s.
    pub fn speed_noise_rad_s(&self) -> f64 {
        self.speed_noise_rpm * RPM
    }
    /// Momentum limit J·n_max, Nms.
    pub fn max_momentum_nms(&self) -> f64 {
        self.inertia_kgm2 * self.max_speed_rad_s()
    }
}

impl CmgConfig {
    /// Gimbal rate limit, rad/s.
    pub fn max_gimbal_rate_rad_s(&self) -> f64 {
        self.max_gimbal_rate_deg_s * DEG
    }
}

/// True if `m` is symmetric (to 1e-9 relative) and positive definite (Cholesky succeeds).
pub fn is_symmetric_positive_definite(m: &Matrix3<f64>) -> bool {
    let scale = m.abs().max().max(f64::MIN_POSITIVE);
    let symmetric = (m - m.transpose()).abs().max() <= 1e-9 * scale;
    symmetric && m.iter().all(|x| x.is_finite()) && m.cholesky().is_some()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(text: &str) -> String {
        match ModelConfig::from_toml_str(text, "test.toml") {
            Ok(_) => panic!("configuration should be refused:\n{text}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn defaults_are_valid_and_round_trip() {
        let config = ModelConfig::default();
        config.validate().unwrap();
        let text = config.to_toml_string();
        assert_eq!(
            ModelConfig::from_toml_str(&text, "round-trip").unwrap(),
            config
        );
        assert_eq!(ModelConfig::from_toml_str("", "empty").unwrap(), config);
    }

    #[test]
    fn wheel_inertia_gives_one_nms_at_6000_rpm() {
        let w = WheelConfig::default();
        assert!((w.max_momentum_nms() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn unknown_key_is_named() {
        let msg = refused("[platform]\nmass_kgg = 3.0\n");
        assert!(msg.contains("mass_kgg"), "{msg}");
        assert!(msg.contains("test.toml"), "{msg}");
        let msg = refused("[effects.com_offset]\nr_m = [0.0, 0.0, 0.0]\nextra = 1\n");
        assert!(msg.contains("extra"), "{msg}");
    }

    #[test]
    fn negative_inertia_is_named_with_value() {
        let msg =
            refused("[platform]\ninertia_kgm2 = [[-45.2, 0, 0], [0, 46.1, 0], [0, 0, 62.7]]\n");
        assert!(msg.contains("platform.inertia_kgm2"), "{msg}");
        assert!(msg.contains("-45.2"), "{msg}");
        assert!(msg.contains("positive definite"), "{msg}");
    }

    #[test]
    fn non_symmetric_inertia_is_refused() {
        let msg =
            refused("[platform]\ninertia_kgm2 = [[45.2, 1.0, 0], [0, 46.1, 0], [0, 0, 62.7]]\n");
        assert!(msg.contains("symmetric"), "{msg}");
    }

    #[test]
    fn non_symmetric_soft_iron_is_refused_naming_the_entry() {
        let msg = refused(
            "[effects.soft_iron]\nmatrix = [[0.03, 0.02, 0.0], [0.01, -0.03, 0.0], [0.0, 0.0, 0.0]]\n",
        );
        assert!(msg.contains("effects.soft_iron.matrix[0][1]"), "{msg}");
        assert!(msg.contains("symmetric"), "{msg}");
        let ok = "[effects.soft_iron]\nmatrix = [[0.03, 0.02, 0.0], [0.02, -0.03, 0.0], [0.0, 0.0, 0.0]]\n";
        assert!(ModelConfig::from_toml_str(ok, "test.toml").is_ok());
    }

    #[test]
    fn indefinite_inertia_with_positive_diagonal_is_refused() {
        // Positive diagonal, but a products of inertia so large the matrix is indefinite.
        let msg = refused("[platform]\ninertia_kgm2 = [[45, 50, 0], [50, 46, 0], [0, 0, 62]]\n");
        assert!(msg.contains("positive definite"), "{msg}");
    }

    #[test]
    fn nan_is_named() {
        let msg = refused("[gyro]\nrange_deg_s = nan\n");
        assert!(
            msg.contains("gyro.range_deg_s") && msg.contains("NaN"),
            "{msg}"
        );
        let msg = refused("[effects.com_offset]\nr_m = [1e-6, nan, 0.0]\n");
        assert!(msg.contains("effects.com_offset.r_m[1]"), "{msg}");
    }

    #[test]
    fn negative_noise_is_named() {
        let msg = refused("[magnetometer]\nnoise_gauss = [1e-4, -2e-4, 1e-4]\n");
        assert!(
            msg.contains("magnetometer.noise_gauss[1]") && msg.contains("-0.0002"),
            "{msg}"
        );
    }

    #[test]
    fn effects_are_off_by_default_and_switch_on() {
        assert_eq!(ModelConfig::default().effects, EffectsConfig::default());
        let config = ModelConfig::from_toml_str(
            "[effects.com_offset]\nr_m = [5e-6, -3e-6, -1e-6]\n[effects.earth_rate]\nlatitude_deg = 43.88\n",
            "inline",
        )
        .unwrap();
        assert_eq!(config.effects.com_offset.unwrap().r_m, [5e-6, -3e-6, -1e-6]);
        assert!(config.effects.aero_drag.is_none());
    }

    #[test]
    fn inertia_error_scales_principal_moments() {
        let mut config = ModelConfig::default();
        config.effects.inertia_error = Some(InertiaError {
            fraction: [0.02, 0.0, -0.03],
            products_kgm2: None,
        });
        let truth = config.true_inertia().unwrap();
        assert!((truth[(0, 0)] - 45.2 * 1.02).abs() < 1e-12);
        assert!((truth[(2, 2)] - 62.7 * 0.97).abs() < 1e-12);
        assert_eq!(truth[(0, 1)], 0.3);
    }
}
