//! The effects beyond the nominal model, `[effects.*]` of the model configuration.

use crate::devices::fitted_field::FittedField;
use crate::physics::fitted_torque::FittedTorque;
use crate::physics::fitted_wheel_torque::FittedWheelTorque;
use crate::thruster_config::ThrusterTorqueScale;
use serde::{Deserialize, Serialize};

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
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_delay: Option<GyroDelay>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_bias_drift: Option<GyroBiasDrift>,
    pub wheel_friction: Option<WheelFriction>,
    pub wheel_torque_scale: Option<WheelTorqueScale>,
    pub actuator_delay: Option<ActuatorDelay>,
    pub magnetic_disturbance: Option<MagneticDisturbance>,
    pub inclinometer_bias: Option<InclinometerBias>,
    pub inclinometer_scale: Option<InclinometerScale>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub soft_iron: Option<SoftIron>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inclinometer_lag: Option<InclinometerLag>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub magnetometer_lag: Option<MagnetometerLag>,
    /// Effects outside identification's cause library (the simulator can produce them so tests
    /// can check that `testbed identify` reports them as unexplained rather than absorbing
    /// them into library causes). Off unless configured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub com_drift: Option<ComDrift>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field_heading_error: Option<FieldHeadingError>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_torque: Option<HeadingTorque>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dipole_torque: Option<DipoleTorque>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wheel_drag: Option<WheelDrag>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gauss_markov_torque: Option<GaussMarkovTorque>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wheel_tilt_torque: Option<WheelTiltTorque>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inclinometer_cross_axis: Option<InclinometerCrossAxis>,
    /// Thrust of each thruster times a factor (a worn nozzle, a wrong regulator pressure);
    /// acts only with `[thrusters]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thruster_torque_scale: Option<ThrusterTorqueScale>,
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

/// The centre of mass moves at a constant rate (thermal expansion, a draining tank): the offset
/// of `com_offset` plus `rate_m_per_s · t`, `t` the plant's time from its start, s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComDrift {
    /// Drift of the centre of mass, body axes, m/s (thermal: ~1 µm per 10 min = 1.7e-9 m/s).
    pub rate_m_per_s: [f64; 3],
}

/// Soft-iron distortion of the magnetometer: `M_meas = (1 + S) A(q) M_L + M_hard`, `S` the
/// matrix given (rows = body axes of the reading). `S` must be symmetric: induced
/// magnetisation is symmetric in the field, and an antisymmetric part is a rotation of the
/// sensor, which the attitude takes up (about the vertical) or a hard iron mimics (about a
/// horizontal axis on a near-level platform). A cause of identification's library.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SoftIron {
    /// `S`, dimensionless, row-major, symmetric (a few percent for nearby steel).
    pub matrix: [[f64; 3]; 3],
}

/// A magnetometer error at twice the heading ψ: `ΔM = cos_2psi_gauss cos 2ψ + sin_2psi_gauss
/// sin 2ψ`, body axes (the lab field's gradient swept by a magnetometer off the rotation axis,
/// a second-harmonic compass deviation). Not a linear map of the field, so neither hard nor
/// soft iron; not in identification's library.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldHeadingError {
    /// Amplitude of the `cos 2ψ` part per body axis of the reading, gauss.
    pub cos_2psi_gauss: [f64; 3],
    /// Amplitude of the `sin 2ψ` part per body axis of the reading, gauss.
    pub sin_2psi_gauss: [f64; 3],
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

/// A magnetic dipole fixed in the platform (a magnet in a motor, a current loop of the
/// harness) in the lab's field: `M = m × B_B`, `B_B = A(q) B_L` the lab field
/// (`[platform] field_l_gauss`) in body axes. Depends on the heading and on the tilt. Not in
/// identification's library.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DipoleTorque {
    /// Magnetic moment `m`, body axes, A m² (20 A m² in the default 54 µT field: about 1 mNm).
    pub moment_am2: [f64; 3],
}

/// A slowly wandering external torque on the platform: per body axis a first-order
/// Gauss–Markov (Ornstein–Uhlenbeck) process of stationary rms `rms_nm` and autocorrelation
/// `e^{−|Δt|/T}`, `T = correlation_time_s` (air currents, a creeping cable); see
/// [`crate::physics::gauss_markov`]. Not in identification's library: `testbed identify`
/// reports it as a coloured disturbance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaussMarkovTorque {
    /// Stationary rms per body axis, Nm, ≥ 0.
    pub rms_nm: [f64; 3],
    /// Correlation time `T`, s, 0.1–10⁴.
    pub correlation_time_s: f64,
    /// Seed of its random stream (the same seed, the same torque).
    #[serde(default)]
    pub seed: u64,
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

/// The gyros' readings are of the rate `delay_s` earlier than their time stamps: the latency of
/// their sampling, filtering and transport when a reading is stamped on arrival.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroDelay {
    /// Delay, s (0 to [`GYRO_DELAY_MAX_S`]).
    pub delay_s: f64,
}

/// The gyros' bias changes at a constant rate on top of its random walk, `b' = ḃ + η_u`: the
/// drift of a gyro warming up or of the lab's temperature over a record, far beyond what the
/// random walk (`gyro.bias_walk_deg_s32`) lets the estimator follow.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroBiasDrift {
    /// Rate of change of the bias per gyro axis, rad/s² (within ±[`GYRO_BIAS_DRIFT_MAX_RAD_S2`]).
    pub rate_rad_s2: [f64; 3],
}

/// The largest bias drift a configuration accepts, rad/s²: 1e-4 rad/s² is 20 °/s in an hour,
/// a gyro far outside any specification.
pub const GYRO_BIAS_DRIFT_MAX_RAD_S2: f64 = 1e-4;

/// The longest gyro delay a configuration accepts, s: five periods of the paper's 10-Hz gyros,
/// far beyond a device's latency; a longer one is a clock error, not a delay.
pub const GYRO_DELAY_MAX_S: f64 = 0.5;

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

/// The inclinometer's angles lag the platform's: it reads the angles of the attitude `τ`
/// earlier ([`crate::attitude::lagged`]), about `θ − τ θ̇`. It is what a first-order response of
/// time constant `τ` reads (an electrolytic sensor's settling, an output filter) while the
/// platform moves slowly against `1/τ`, and what readings stamped `τ` late read: at the
/// platform's manoeuvres (periods of tens of seconds) the two are alike. Typical 0.1–1 s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InclinometerLag {
    /// `τ`, s (0 to [`SENSOR_LAG_MAX_S`]).
    pub time_constant_s: f64,
}

/// The magnetometer lags the platform: it reads the field of the attitude `τ` earlier
/// ([`crate::attitude::lagged`]): a device that averages or filters its samples, or readings
/// stamped on arrival. Typical 0.01–0.2 s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagnetometerLag {
    /// `τ`, s (0 to [`SENSOR_LAG_MAX_S`]).
    pub time_constant_s: f64,
}

/// The longest lag of a vector sensor a configuration accepts, s: beyond it a first-order
/// response no longer reads like the attitude a lag earlier at the platform's motions.
pub const SENSOR_LAG_MAX_S: f64 = 2.0;

/// Each inclinometer angle also reads a fraction of the other: `θ_meas = … + k_θ φ`,
/// `φ_meas = … + k_φ θ` (the cross-axis sensitivity of a datasheet; a sensor turned about the
/// vertical by δ has `k_θ = −k_φ ≈ δ`). With `inclinometer_scale` on the diagonal it makes the
/// inclinometer's reading a general 2×2 map of the angles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InclinometerCrossAxis {
    /// `[k_θ, k_φ]`: the fraction of `φ` read in `θ` and of `θ` read in `φ`, dimensionless
    /// (datasheets give up to a few percent).
    pub coupling: [f64; 2],
}

/// The inclinometer's angles read scaled: `(1 + s) θ` (its gain calibration is off).
/// Typical: a few thousand ppm (0.1–2 %) for electrolytic and MEMS tilt sensors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InclinometerScale {
    /// Scale error of `[θ, φ]`, parts per million.
    pub ppm: [f64; 2],
}
