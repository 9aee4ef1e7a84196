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
    /// The six cold-gas thrusters (issue 14); off unless the table is present.
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

/// Effects beyond the nominal model. Each is off (`None`) unless its table is present in the
/// configuration, so simulated data can carry them and identification can name them. The table
/// names are the cause names of `testbed identify`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct EffectsConfig {
    pub com_offset: Option<ComOffset>,
    pub earth_rate: Option<EarthRate>,
    pub aero_drag: Option<AeroDrag>,
    pub constant_torque: Option<ConstantTorque>,
    pub inertia_error: Option<InertiaError>,
    pub gyro_scale: Option<GyroScale>,
    pub gyro_misalignment: Option<GyroMisalignment>,
    pub wheel_friction: Option<WheelFriction>,
    pub wheel_torque_scale: Option<WheelTorqueScale>,
    pub actuator_delay: Option<ActuatorDelay>,
    pub magnetic_disturbance: Option<MagneticDisturbance>,
    pub inclinometer_bias: Option<InclinometerBias>,
    pub inclinometer_scale: Option<InclinometerScale>,
    /// Effects outside identification's cause library (the simulator can produce them so tests
    /// can check that `testbed identify` reports them as unexplained rather than absorbing
    /// them into library causes). Off unless configured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub com_drift: Option<ComDrift>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub soft_iron: Option<SoftIron>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_torque: Option<HeadingTorque>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wheel_drag: Option<WheelDrag>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wheel_tilt_torque: Option<WheelTiltTorque>,
    /// Thrust of each thruster times a factor (a worn nozzle, a wrong regulator pressure);
    /// acts only with `[thrusters]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thruster_torque_scale: Option<crate::thruster_config::ThrusterTorqueScale>,
    /// A torque fitted to data (an unexplained effect of `testbed identify`, carried into the
    /// model): see [`crate::physics::fitted_torque`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fitted_torque: Option<FittedTorque>,
    /// A torque between each wheel and the platform fitted to data (an unexplained effect of
    /// `testbed identify` in the wheel channel, carried into the model): see
    /// [`crate::physics::fitted_wheel_torque`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fitted_wheel_torque: Option<FittedWheelTorque>,
    /// A magnetometer error fitted to data (an unexplained effect of `testbed identify` in the
    /// field innovations, carried into the model): see [`crate::devices::fitted_field`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fitted_field: Option<FittedField>,
}

/// A torque fitted to data, `M_a = Σ coefficient × function` per body axis `a`, written by
/// `testbed identify` from the unexplained effects it finds in the torque channels (or by
/// hand). Functions: [`crate::physics::fitted_torque::TorqueFunction`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedTorque {
    /// The terms' time at the plant's start, s (their time is the record's time from its
    /// start; 0 when the run starts where the record did).
    #[serde(default)]
    pub start_time_s: f64,
    pub terms: Vec<FittedTorqueTerm>,
}

/// One term of a [`FittedTorque`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedTorqueTerm {
    /// Body axis of the torque: `x`, `y` or `z`.
    pub axis: String,
    /// The function, by name (`1`, `t_s`, `sin 2ψ`, `w_z`, …).
    pub function: String,
    /// Nm per unit of the function (Nm/s for `t_s`, Nm/(rad/s) for a rate).
    pub coefficient: f64,
}

/// A torque between each wheel and the platform fitted to data, `T_i = Σ coefficient ×
/// function` per wheel `i`, accelerating the wheel in its positive sense (the platform takes the
/// reaction); written by `testbed identify` from the unexplained effects it finds in the wheel
/// channel (or by hand). Functions:
/// [`crate::physics::fitted_wheel_torque::WheelFunction`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedWheelTorque {
    /// The terms' time at the plant's start, s (their time is the record's time from its
    /// start; 0 when the run starts where the record did).
    #[serde(default)]
    pub start_time_s: f64,
    pub terms: Vec<FittedWheelTorqueTerm>,
}

/// One term of a [`FittedWheelTorque`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedWheelTorqueTerm {
    /// The wheel, by the body axis it spins about: `x`, `y` or `z`.
    pub wheel: String,
    /// The function, by name (`1`, `t_s`, `sign n`, `n·|n|`, `τ`, `sin tilt_x`, …).
    pub function: String,
    /// Nm per unit of the function (Nm/s for `t_s`, Nm/(rad/s) for `n` or a rate,
    /// Nm/(rad/s)² for `n·|n|` and `n²`, Nm/Nm for `τ`).
    pub coefficient: f64,
}

/// A magnetometer error fitted to data, `ΔM_a = Σ coefficient × function(q)` per body axis `a`
/// of the reading, written by `testbed identify` from the unexplained effects it finds in the
/// field innovations (or by hand). The simulated magnetometer adds it to its reading;
/// identification's filter takes it out of the readings. Functions:
/// [`crate::devices::fitted_field::FieldFunction`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedField {
    pub terms: Vec<FittedFieldTerm>,
}

/// One term of a [`FittedField`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedFieldTerm {
    /// Body axis of the reading: `x`, `y` or `z`.
    pub axis: String,
    /// The function, by name (`1`, `cos 2ψ`, `B_y`, …).
    pub function: String,
    /// Tesla per unit of the function.
    pub coefficient: f64,
}

/// The centre of mass moves at a constant rate (thermal expansion, a draining tank): the offset
/// of `com_offset` plus `rate_m_per_s · t`, `t` the plant's time from its start, s. Not in
/// identification's library.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComDrift {
    /// Drift of the centre of mass, body axes, m/s (thermal: ~1 µm per 10 min = 1.7e-9 m/s).
    pub rate_m_per_s: [f64; 3],
}

/// Soft-iron distortion of the magnetometer: `M_meas = (1 + S) A(q) M_L + M_hard`, `S` the
/// matrix given (rows = body axes of the reading). Not in identification's library.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SoftIron {
    /// `S`, dimensionless, row-major (a few percent for nearby steel).
    pub matrix: [[f64; 3]; 3],
}

/// A torque that varies with the heading ψ: `M = cos_nm cos ψ + sin_nm sin ψ`, body axes (a
/// cable that winds up, a body dipole in the lab's horizontal field). Not in identification's
/// library.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadingTorque {
    /// Amplitude of the `cos ψ` part per body axis, Nm.
    pub cos_nm: [f64; 3],
    /// Amplitude of the `sin ψ` part per body axis, Nm.
    pub sin_nm: [f64; 3],
}

/// A drag torque on each wheel growing with the square of its speed (windage of the rotor):
/// `T_d = c n |n|` opposing the relative motion, added to the bearing friction. Not in
/// identification's library (its friction is Coulomb, Stribeck and viscous).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelDrag {
    /// Coefficient `c` per wheel, Nm/(rad/s)², ≥ 0.
    pub quadratic_nm_per_rad2_s2: [f64; 3],
}

/// A torque between each wheel and the platform that depends on the platform's tilt (a cable to
/// the rotor, a bearing whose drag follows its load): `T_i = sin_tilt_x_nm[i] G_x +
/// sin_tilt_y_nm[i] G_y`, `G` the unit down vector in body axes, accelerating the wheel in its
/// positive sense (the platform takes the reaction). Not in identification's library.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelTiltTorque {
    /// Torque per unit of `G_x` (the sine of the tilt about Y, nearly), per wheel, Nm.
    pub sin_tilt_x_nm: [f64; 3],
    /// Torque per unit of `G_y`, per wheel, Nm.
    pub sin_tilt_y_nm: [f64; 3],
}

/// Centre of mass offset from the bearing's centre of rotation. Gravity torque on the platform:
/// `M = m g (r × G_B)`, `G_B` the unit down vector in body axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComOffset {
    /// Offset of the centre of mass from the bearing centre, body axes, m. Typical: 2–20 µm
    /// horizontal, slightly negative vertical (pendulous).
    pub r_m: [f64; 3],
}

/// The Earth's rotation seen by the gyros: `w_meas += A(q) Ω_E [cos λ, 0, sin λ]_L`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EarthRate {
    /// Latitude λ, degrees north.
    pub latitude_deg: f64,
}

/// Aerodynamic drag on the rotating platform, body axes: `M = −(c1 w + c2 w|w|)` per axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AeroDrag {
    /// Linear coefficient per body axis, Nm/(rad/s).
    pub c1: [f64; 3],
    /// Quadratic coefficient per body axis, Nm/(rad/s)².
    pub c2: [f64; 3],
}

/// A constant torque in body axes (bearing exhaust, cables), Nm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstantTorque {
    pub torque_nm: [f64; 3],
}

/// The true inertia differs from the nominal: `I_true = I_nom + diag(fraction ⊙ diag(I_nom)) + P`,
/// `P` the symmetric matrix of product errors (zero diagonal).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InertiaError {
    /// Relative error of each principal moment (e.g. 0.03 for +3 %), dimensionless.
    pub fraction: [f64; 3],
    /// Errors of the products of inertia `[I_xy, I_yz, I_zx]`, kg m² (absent: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub products_kgm2: Option<[f64; 3]>,
}

/// Gyro scale factor error per axis: `w_meas = (1 + s) w`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroScale {
    /// Scale factor error per gyro axis, parts per million.
    pub ppm: [f64; 3],
}

/// Gyro triad misalignment as a small rotation: `w_meas = (I − [m×]) w`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroMisalignment {
    /// Small rotation angles of the triad about body X, Y, Z, rad (typical 0.1–1 mrad).
    pub angles_rad: [f64; 3],
}

/// Wheel friction beyond eq. 3, per wheel: direction asymmetry and Stribeck effect.
/// `T_f(n) = (T_c(dir) + (T_s − T_c(dir)) exp(−(n/n_s)²)) sign(n) + K n`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelFriction {
    /// Coulomb friction for positive speed per wheel, Nm.
    pub coulomb_pos_nm: [f64; 3],
    /// Coulomb friction for negative speed per wheel (magnitude), Nm.
    pub coulomb_neg_nm: [f64; 3],
    /// Viscous coefficient per wheel, Nm/(rad/s).
    pub viscous_nm_per_rad_s: [f64; 3],
    /// Static (breakaway) friction per wheel, Nm; equal to Coulomb for no Stribeck effect.
    pub stribeck_nm: [f64; 3],
    /// Stribeck speed per wheel, rad/s.
    pub stribeck_speed_rad_s: [f64; 3],
}

/// Motor torque delivered = scale × commanded, per wheel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelTorqueScale {
    /// Scale per wheel, dimensionless (1 = nominal).
    pub scale: [f64; 3],
}

/// Actuator commands take effect this long after they were issued.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorDelay {
    /// Delay, s.
    pub delay_s: f64,
}

/// A body-fixed (hard iron) field added to the magnetometer's reading: motors, the building.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagneticDisturbance {
    /// Hard-iron field in body axes, gauss (tens of µT = a few 0.1 G at most).
    pub hard_iron_gauss: [f64; 3],
}

/// The inclinometer reads the tilt with a constant offset: its mounting is not level with the
/// body axes (a shim, a screw), or its zero has moved. Typical: 0.01–0.1° (a tenth of a
/// millimetre over a 10-cm base is 0.06°).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InclinometerBias {
    /// Offset added to the measured tilt `[θ, φ]` of body X and body Y, rad.
    pub offset_rad: [f64; 2],
}

/// The inclinometer's angles read scaled: `(1 + s) θ` (its gain calibration is off).
/// Typical: a few thousand ppm (0.1–2 %) for electrolytic and MEMS tilt sensors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InclinometerScale {
    /// Scale error of `[θ, φ]`, parts per million.
    pub ppm: [f64; 2],
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

    /// Refuse what no physical platform can have. Names the first offending key and value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let mut v = Validator::default();
        let p = &self.platform;
        for (i, row) in p.inertia_kgm2.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                v.finite(&format!("platform.inertia_kgm2[{i}][{j}]"), *x);
            }
        }
        v.inertia("platform.inertia_kgm2", &p.inertia_kgm2);
        v.positive("platform.mass_kg", p.mass_kg);
        v.positive("platform.gravity_mps2", p.gravity_mps2);
        v.within("platform.latitude_deg", p.latitude_deg, -90.0, 90.0);
        v.within("platform.tilt_limit_deg", p.tilt_limit_deg, 0.0, 90.0);
        v.finite_all("platform.field_l_gauss", &p.field_l_gauss);

        let g = &self.gyro;
        // The gyro rate is the loop's tick: from 1 Hz (slower, and a paced run waits seconds
        // per tick) to 1 kHz (the event loop's timers resolve milliseconds).
        v.within("gyro.rate_hz", g.rate_hz, 1.0, 1000.0);
        v.finite_all("gyro.bias_deg_s", &g.bias_deg_s);
        v.non_negative_all("gyro.noise_density_deg_sqrt_s", &g.noise_density_deg_sqrt_s);
        v.non_negative_all("gyro.bias_walk_deg_s32", &g.bias_walk_deg_s32);
        v.non_negative("gyro.resolution_deg_s", g.resolution_deg_s);
        v.positive("gyro.range_deg_s", g.range_deg_s);

        let n = &self.inclinometer;
        v.positive("inclinometer.rate_hz", n.rate_hz);
        v.non_negative_all("inclinometer.noise_deg", &n.noise_deg);
        v.within("inclinometer.range_deg", n.range_deg, 0.0, 90.0);

        let m = &self.magnetometer;
        v.positive("magnetometer.rate_hz", m.rate_hz);
        v.non_negative_all("magnetometer.noise_gauss", &m.noise_gauss);
        v.positive("magnetometer.range_gauss", m.range_gauss);

        let w = &self.wheels;
        v.positive("wheels.inertia_kgm2", w.inertia_kgm2);
        v.positive("wheels.max_torque_nm", w.max_torque_nm);
        v.positive("wheels.max_speed_rpm", w.max_speed_rpm);
        v.non_negative_all("wheels.coulomb_nm", &w.coulomb_nm);
        v.non_negative_all("wheels.viscous_nm_per_rad_s", &w.viscous_nm_per_rad_s);
        v.positive("wheels.telemetry_rate_hz", w.telemetry_rate_hz);
        v.non_negative("wheels.speed_noise_rpm", w.speed_noise_rpm);
        v.non_negative("wheels.speed_resolution_rpm", w.speed_resolution_rpm);

        let c = &self.cmg;
        v.positive("cmg.rotor_momentum_nms", c.rotor_momentum_nms);
        v.within("cmg.skew_deg", c.skew_deg, 0.0, 90.0);
        v.positive("cmg.max_gimbal_rate_deg_s", c.max_gimbal_rate_deg_s);
        v.non_negative("cmg.stepper_step_deg", c.stepper_step_deg);
        v.non_negative("cmg.encoder_resolution_deg", c.encoder_resolution_deg);
        v.positive("cmg.telemetry_rate_hz", c.telemetry_rate_hz);

        let e = &self.effects;
        if let Some(x) = &e.com_offset {
            v.finite_all("effects.com_offset.r_m", &x.r_m);
        }
        if let Some(x) = &e.earth_rate {
            v.within(
                "effects.earth_rate.latitude_deg",
                x.latitude_deg,
                -90.0,
                90.0,
            );
        }
        if let Some(x) = &e.aero_drag {
            v.non_negative_all("effects.aero_drag.c1", &x.c1);
            v.non_negative_all("effects.aero_drag.c2", &x.c2);
        }
        if let Some(x) = &e.constant_torque {
            v.finite_all("effects.constant_torque.torque_nm", &x.torque_nm);
        }
        if let Some(x) = &e.inertia_error {
            for (i, f) in x.fraction.iter().enumerate() {
                v.within(
                    &format!("effects.inertia_error.fraction[{i}]"),
                    *f,
                    -0.5,
                    0.5,
                );
            }
            if let Some(p) = &x.products_kgm2 {
                v.finite_all("effects.inertia_error.products_kgm2", p);
            }
            let nominal = self.platform.inertia();
            let truth = self.true_inertia();
            if nominal.is_some() && truth.is_none() {
                v.fail(
                    "effects.inertia_error.fraction",
                    format!("{:?}", x.fraction),
                    "makes the true inertia non-positive-definite",
                );
            }
        }
        if let Some(x) = &e.gyro_scale {
            v.finite_all("effects.gyro_scale.ppm", &x.ppm);
        }
        if let Some(x) = &e.gyro_misalignment {
            for (i, a) in x.angles_rad.iter().enumerate() {
                v.within(
                    &format!("effects.gyro_misalignment.angles_rad[{i}]"),
                    *a,
                    -0.1,
                    0.1,
                );
            }
        }
        if let Some(x) = &e.wheel_friction {
            v.non_negative_all("effects.wheel_friction.coulomb_pos_nm", &x.coulomb_pos_nm);
            v.non_negative_all("effects.wheel_friction.coulomb_neg_nm", &x.coulomb_neg_nm);
            v.non_negative_all(
                "effects.wheel_friction.viscous_nm_per_rad_s",
                &x.viscous_nm_per_rad_s,
            );
            v.non_negative_all("effects.wheel_friction.stribeck_nm", &x.stribeck_nm);
            v.positive_all(
                "effects.wheel_friction.stribeck_speed_rad_s",
                &x.stribeck_speed_rad_s,
            );
        }
        if let Some(x) = &e.wheel_torque_scale {
            v.positive_all("effects.wheel_torque_scale.scale", &x.scale);
        }
        if let Some(x) = &e.actuator_delay {
            v.within("effects.actuator_delay.delay_s", x.delay_s, 0.0, 10.0);
        }
        if let Some(x) = &e.magnetic_disturbance {
            v.finite_all(
                "effects.magnetic_disturbance.hard_iron_gauss",
                &x.hard_iron_gauss,
            );
        }
        if let Some(x) = &e.inclinometer_bias {
            for (i, b) in x.offset_rad.iter().enumerate() {
                // Beyond a few degrees it is not a mounting offset but a wrong axis convention.
                v.within(
                    &format!("effects.inclinometer_bias.offset_rad[{i}]"),
                    *b,
                    -0.1,
                    0.1,
                );
            }
        }
        if let Some(x) = &e.inclinometer_scale {
            for (i, s) in x.ppm.iter().enumerate() {
                v.within(
                    &format!("effects.inclinometer_scale.ppm[{i}]"),
                    *s,
                    -1e5,
                    1e5,
                );
            }
        }
        if let Some(x) = &e.com_drift {
            v.finite_all("effects.com_drift.rate_m_per_s", &x.rate_m_per_s);
        }
        if let Some(x) = &e.soft_iron {
            for (i, row) in x.matrix.iter().enumerate() {
                for (j, m) in row.iter().enumerate() {
                    v.within(
                        &format!("effects.soft_iron.matrix[{i}][{j}]"),
                        *m,
                        -0.5,
                        0.5,
                    );
                }
            }
        }
        if let Some(x) = &e.heading_torque {
            v.finite_all("effects.heading_torque.cos_nm", &x.cos_nm);
            v.finite_all("effects.heading_torque.sin_nm", &x.sin_nm);
        }
        if let Some(x) = &e.wheel_drag {
            for (i, c) in x.quadratic_nm_per_rad2_s2.iter().enumerate() {
                v.within(
                    &format!("effects.wheel_drag.quadratic_nm_per_rad2_s2[{i}]"),
                    *c,
                    0.0,
                    1.0,
                );
            }
        }
        if let Some(x) = &e.wheel_tilt_torque {
            v.finite_all("effects.wheel_tilt_torque.sin_tilt_x_nm", &x.sin_tilt_x_nm);
            v.finite_all("effects.wheel_tilt_torque.sin_tilt_y_nm", &x.sin_tilt_y_nm);
        }
        if let Some(x) = &e.thruster_torque_scale {
            v.positive_all("effects.thruster_torque_scale.scale", &x.scale);
        }
        if let Some(x) = &e.fitted_torque {
            use crate::physics::fitted_torque::{TorqueFunction, axis_index};
            v.finite("effects.fitted_torque.start_time_s", x.start_time_s);
            for (i, term) in x.terms.iter().enumerate() {
                let key = format!("effects.fitted_torque.terms[{i}]");
                if axis_index(&term.axis).is_none() {
                    v.fail(
                        &format!("{key}.axis"),
                        term.axis.clone(),
                        "must be x, y or z",
                    );
                }
                v.known_function(
                    &format!("{key}.function"),
                    &term.function,
                    TorqueFunction::from_name(&term.function).is_some(),
                    TorqueFunction::ALL.iter().map(|f| f.name()),
                );
                v.finite(&format!("{key}.coefficient"), term.coefficient);
            }
        }
        if let Some(x) = &e.fitted_wheel_torque {
            use crate::physics::fitted_torque::axis_index;
            use crate::physics::fitted_wheel_torque::WheelFunction;
            v.finite("effects.fitted_wheel_torque.start_time_s", x.start_time_s);
            for (i, term) in x.terms.iter().enumerate() {
                let key = format!("effects.fitted_wheel_torque.terms[{i}]");
                if axis_index(&term.wheel).is_none() {
                    v.fail(
                        &format!("{key}.wheel"),
                        term.wheel.clone(),
                        "must be x, y or z (the wheel's spin axis)",
                    );
                }
                v.known_function(
                    &format!("{key}.function"),
                    &term.function,
                    WheelFunction::from_name(&term.function).is_some(),
                    WheelFunction::ALL.iter().map(|f| f.name()),
                );
                v.finite(&format!("{key}.coefficient"), term.coefficient);
            }
        }
        if let Some(x) = &e.fitted_field {
            use crate::devices::fitted_field::FieldFunction;
            use crate::physics::fitted_torque::axis_index;
            for (i, term) in x.terms.iter().enumerate() {
                let key = format!("effects.fitted_field.terms[{i}]");
                if axis_index(&term.axis).is_none() {
                    v.fail(
                        &format!("{key}.axis"),
                        term.axis.clone(),
                        "must be x, y or z",
                    );
                }
                v.known_function(
                    &format!("{key}.function"),
                    &term.function,
                    FieldFunction::from_name(&term.function).is_some(),
                    FieldFunction::ALL.iter().map(|f| f.name()),
                );
                v.finite(&format!("{key}.coefficient"), term.coefficient);
            }
        }
        v.finish()?;
        match &self.thrusters {
            Some(t) => t.validate(),
            None => Ok(()),
        }
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

/// Collects the first validation failure with its key and value.
#[derive(Default)]
struct Validator {
    first: Option<ConfigError>,
}

impl Validator {
    fn fail(&mut self, key: &str, value: String, reason: &str) {
        if self.first.is_none() {
            self.first = Some(ConfigError::Invalid {
                key: key.to_string(),
                value,
                reason: reason.to_string(),
            });
        }
    }
    /// A fitted term's function name: `found` says whether it names one of `known`.
    fn known_function<'a>(
        &mut self,
        key: &str,
        name: &str,
        found: bool,
        known: impl Iterator<Item = &'a str>,
    ) {
        if !found {
            let known: Vec<&str> = known.collect();
            self.fail(
                key,
                name.to_string(),
                &format!("unknown function; known: {}", known.join(", ")),
            );
        }
    }
    fn finite(&mut self, key: &str, x: f64) {
        if !x.is_finite() {
            self.fail(key, format!("{x}"), "must be a finite number");
        }
    }
    fn finite_all(&mut self, key: &str, xs: &[f64]) {
        for (i, x) in xs.iter().enumerate() {
            self.finite(&format!("{key}[{i}]"), *x);
        }
    }
    fn positive(&mut self, key: &str, x: f64) {
        if !(x.is_finite() && x > 0.0) {
            self.fail(key, format!("{x}"), "must be a finite number > 0");
        }
    }
    fn positive_all(&mut self, key: &str, xs: &[f64]) {
        for (i, x) in xs.iter().enumerate() {
            self.positive(&format!("{key}[{i}]"), *x);
        }
    }
    fn non_negative(&mut self, key: &str, x: f64) {
        if !(x.is_finite() && x >= 0.0) {
            self.fail(key, format!("{x}"), "must be a finite number >= 0");
        }
    }
    fn non_negative_all(&mut self, key: &str, xs: &[f64]) {
        for (i, x) in xs.iter().enumerate() {
            self.non_negative(&format!("{key}[{i}]"), *x);
        }
    }
    fn within(&mut self, key: &str, x: f64, lo: f64, hi: f64) {
        if !(x.is_finite() && x >= lo && x <= hi) {
            self.fail(key, format!("{x}"), &format!("must be within [{lo}, {hi}]"));
        }
    }
    fn inertia(&mut self, key: &str, rows: &[[f64; 3]; 3]) {
        let m = Matrix3::from_fn(|i, j| rows[i][j]);
        if !m.iter().all(|x| x.is_finite()) {
            return; // already reported element-wise
        }
        let value = format!("{rows:?}");
        let scale = m.abs().max().max(f64::MIN_POSITIVE);
        if (m - m.transpose()).abs().max() > 1e-9 * scale {
            self.fail(key, value, "must be symmetric");
        } else if m.cholesky().is_none() {
            self.fail(
                key,
                value,
                "must be positive definite (all principal moments > 0)",
            );
        }
    }
    fn finish(self) -> Result<(), ConfigError> {
        self.first.map_or(Ok(()), Err)
    }
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
