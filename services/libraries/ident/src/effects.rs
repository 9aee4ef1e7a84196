//! The library of candidate causes: the effects of `testbed_model::config::EffectsConfig`, each
//! with its parameters named by the configuration's keys, their units, and how to read them
//! from and write them into a [`ModelConfig`].
//!
//! Parameters (all in the configuration's own units; vectors are per body axis or per wheel X,
//! Y, Z):
//!
//! | cause | parameters |
//! |---|---|
//! | `com_offset` | `r_m` — centre of mass from the bearing centre, m, body axes |
//! | `com_drift` | `rate_m_per_s` — the centre of mass's drift (thermal expansion, a shifting cable), m/s, body axes: the offset is `r + ṙ t`, `t` the record's time |
//! | `earth_rate` | `latitude_deg` — latitude, degrees north |
//! | `aero_drag` | `c1` — Nm/(rad/s); `c2` — Nm/(rad/s)², per body axis |
//! | `constant_torque` | `torque_nm` — Nm, body axes |
//! | `inertia_error` | `fraction` — relative error of each principal moment |
//! | `gyro_scale` | `ppm` — scale-factor error per gyro, parts per million |
//! | `gyro_misalignment` | `angles_rad` — small rotation of the gyro triad, rad |
//! | `gyro_delay` | `delay_s` — the gyros read the rate this long before their time stamps, s |
//! | `gyro_bias_drift` | `rate_rad_s2` — the gyros' bias changes at this rate beside its random walk (warm-up, the lab's temperature), rad/s² per gyro axis |
//! | `wheel_friction` | `coulomb_pos_nm`, `coulomb_neg_nm`, `viscous_nm_per_rad_s`, `stribeck_nm`, `stribeck_speed_rad_s` per wheel |
//! | `wheel_torque_scale` | `scale` — delivered / commanded motor torque per wheel |
//! | `actuator_delay` | `delay_s` — s |
//! | `magnetic_disturbance` | `hard_iron_gauss` — body-fixed field, gauss |
//! | `soft_iron` | `matrix` — the symmetric soft-iron matrix `S` of `(1 + S) A(q) M_L`, dimensionless, as its six entries `[S_xx, S_yy, S_zz, S_xy, S_yz, S_zx]` |
//! | `inclinometer_bias` | `offset_rad` — mounting offset of the tilt angles θ (body X), φ (body Y), rad |
//! | `inclinometer_scale` | `ppm` — scale error of the tilt angles θ, φ, parts per million |
//! | `inclinometer_cross_axis` | `coupling` — the fraction of φ read in θ and of θ read in φ (cross-axis sensitivity; a sensor turned about the vertical by δ has `[δ, −δ]`), dimensionless |
//! | `inclinometer_lag` | `time_constant_s` — the inclinometer reads the attitude `τ` earlier, about `θ − τ θ̇` (a first-order response, or a late stamp), s |
//! | `magnetometer_lag` | `time_constant_s` — the magnetometer reads the field of the attitude `τ` earlier, s |
//! | `thruster_torque_scale` | `scale` — delivered / nominal thrust per thruster 0–5 |
//! | `propellant_com_shift` | `tank_position_m` — the propellant's centre of mass from the bearing centre, m, body axes (`[thrusters].tank_position_m`) |
//!
//! The last two are candidates only for data with thruster firings and a model with
//! `[thrusters]`. `propellant_com_shift` is the centre-of-mass shift of the draining tank: with
//! `m_u` of propellant used, the gravity torque changes by `−m_u g r_t × G_B`; what is uncertain
//! is where the propellant sits, `r_t`, so that is the parameter (it is written into the model's
//! `[thrusters]` table, not into an effect table).
//!
//! `soft_iron` is the configuration's `matrix` restricted to symmetric matrices (the
//! configuration refuses others): six free values, the diagonal then the off-diagonal pairs in
//! the order of inertia's products, written back as the full symmetric 3×3 `matrix`. An
//! antisymmetric part would be a rotation of the sensor, which the attitude takes up (about
//! the vertical) or a hard iron mimics (about a horizontal axis, on a near-level platform).
//! On a platform that tilts by a few degrees `S_zz` acts on a nearly constant vertical field:
//! beside a hard iron it is determined only by the tilts' change of that field.

use serde::Serialize;
use testbed_model::ModelConfig;
use testbed_model::config::{
    ActuatorDelay, AeroDrag, ComDrift, ComOffset, ConstantTorque, EarthRate,
    GYRO_BIAS_DRIFT_MAX_RAD_S2, GYRO_DELAY_MAX_S, GyroBiasDrift, GyroDelay, GyroMisalignment,
    GyroScale, InclinometerBias, InclinometerCrossAxis, InclinometerLag, InclinometerScale,
    InertiaError, MagneticDisturbance, MagnetometerLag, SENSOR_LAG_MAX_S, SoftIron, WheelFriction,
    WheelTorqueScale,
};
use testbed_model::thruster_config::{THRUSTER_COUNT, ThrusterConfig, ThrusterTorqueScale};

/// A candidate cause: one effect table of the model configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Cause {
    ComOffset,
    ComDrift,
    EarthRate,
    AeroDrag,
    ConstantTorque,
    InertiaError,
    GyroScale,
    GyroMisalignment,
    GyroDelay,
    GyroBiasDrift,
    WheelFriction,
    WheelTorqueScale,
    ActuatorDelay,
    MagneticDisturbance,
    SoftIron,
    InclinometerBias,
    InclinometerScale,
    InclinometerCrossAxis,
    InclinometerLag,
    MagnetometerLag,
    ThrusterTorqueScale,
    PropellantComShift,
}

/// Which residual channel a cause acts on directly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// The sensors (gyro, magnetometer): fitted through the attitude filter's innovations.
    Sensor,
    /// An external torque or the inertia: the platform's momentum equation.
    Torque,
    /// The wheel drives: the wheels' equation of motion.
    Wheel,
}

/// One parameter array of a cause.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// Key in the effect's configuration table.
    pub key: &'static str,
    /// Number of values (3 per axis or wheel, 1 for a scalar).
    pub len: usize,
    /// Unit and frame.
    pub unit: &'static str,
    /// Bounds accepted by the configuration.
    pub lower: f64,
    pub upper: f64,
    /// Finite-difference step for fits through the attitude filter (sensor causes).
    pub step: f64,
}

const fn spec(
    key: &'static str,
    len: usize,
    unit: &'static str,
    lower: f64,
    upper: f64,
    step: f64,
) -> ParamSpec {
    ParamSpec {
        key,
        len,
        unit,
        lower,
        upper,
        step,
    }
}

const INF: f64 = f64::INFINITY;

const P_COM: &[ParamSpec] = &[spec("r_m", 3, "m, body axes", -1e-3, 1e-3, 1e-7)];
const P_COM_DRIFT: &[ParamSpec] = &[spec(
    "rate_m_per_s",
    3,
    "m/s, body axes",
    -1e-3,
    1e-3,
    1e-10,
)];
const P_EARTH: &[ParamSpec] = &[spec("latitude_deg", 1, "degrees north", -90.0, 90.0, 0.5)];
const P_DRAG: &[ParamSpec] = &[
    spec("c1", 3, "Nm/(rad/s), per body axis", 0.0, INF, 1e-3),
    spec("c2", 3, "Nm/(rad/s)², per body axis", 0.0, INF, 1e-2),
];
const P_CONST: &[ParamSpec] = &[spec("torque_nm", 3, "Nm, body axes", -INF, INF, 1e-4)];
const P_INERTIA: &[ParamSpec] = &[
    spec(
        "fraction",
        3,
        "relative error of each principal moment",
        -0.5,
        0.5,
        1e-3,
    ),
    spec(
        "products_kgm2",
        3,
        "kg m², products of inertia [xy, yz, zx]",
        -INF,
        INF,
        1e-3,
    ),
];
const P_SCALE: &[ParamSpec] = &[spec(
    "ppm",
    3,
    "parts per million, per gyro axis",
    -1e5,
    1e5,
    100.0,
)];
const P_MISALIGN: &[ParamSpec] = &[spec(
    "angles_rad",
    3,
    "rad, about body X, Y, Z",
    -0.1,
    0.1,
    1e-4,
)];
const P_GYRO_DELAY: &[ParamSpec] = &[spec("delay_s", 1, "s", 0.0, GYRO_DELAY_MAX_S, 0.01)];
const P_GYRO_DRIFT: &[ParamSpec] = &[spec(
    "rate_rad_s2",
    3,
    "rad/s², per gyro axis",
    -GYRO_BIAS_DRIFT_MAX_RAD_S2,
    GYRO_BIAS_DRIFT_MAX_RAD_S2,
    1e-8,
)];
const P_FRICTION: &[ParamSpec] = &[
    spec("coulomb_pos_nm", 3, "Nm, per wheel", 0.0, INF, 1e-4),
    spec("coulomb_neg_nm", 3, "Nm, per wheel", 0.0, INF, 1e-4),
    spec(
        "viscous_nm_per_rad_s",
        3,
        "Nm/(rad/s), per wheel",
        0.0,
        INF,
        1e-7,
    ),
    spec("stribeck_nm", 3, "Nm, per wheel", 0.0, INF, 1e-4),
    spec(
        "stribeck_speed_rad_s",
        3,
        "rad/s, per wheel",
        1e-6,
        INF,
        0.1,
    ),
];
const P_TSCALE: &[ParamSpec] = &[spec(
    "scale",
    3,
    "dimensionless, per wheel",
    1e-6,
    INF,
    1e-3,
)];
const P_THRUSTER_SCALE: &[ParamSpec] = &[spec(
    "scale",
    THRUSTER_COUNT,
    "dimensionless: delivered / nominal thrust, per thruster 0–5",
    1e-6,
    INF,
    1e-3,
)];
const P_TANK: &[ParamSpec] = &[spec(
    "tank_position_m",
    3,
    "m, body axes, propellant's centre of mass from the bearing centre",
    -1.0,
    1.0,
    1e-3,
)];
const P_TILT_BIAS: &[ParamSpec] = &[spec(
    "offset_rad",
    2,
    "rad, tilt angles θ (body X) and φ (body Y)",
    -0.1,
    0.1,
    1e-4,
)];
const P_TILT_SCALE: &[ParamSpec] = &[spec(
    "ppm",
    2,
    "parts per million, tilt angles θ (body X) and φ (body Y)",
    -1e5,
    1e5,
    100.0,
)];
// The step: 1e-4 of a 5° tilt is 9 µrad, a few percent of the inclinometer's noise.
const P_TILT_CROSS: &[ParamSpec] = &[spec(
    "coupling",
    2,
    "dimensionless: the fraction of φ read in θ, of θ read in φ",
    -0.1,
    0.1,
    1e-4,
)];
const P_TILT_LAG: &[ParamSpec] = &[spec("time_constant_s", 1, "s", 0.0, SENSOR_LAG_MAX_S, 0.05)];
const P_FIELD_LAG: &[ParamSpec] = &[spec("time_constant_s", 1, "s", 0.0, SENSOR_LAG_MAX_S, 0.05)];
const P_DELAY: &[ParamSpec] = &[spec("delay_s", 1, "s", 0.0, 10.0, 0.01)];
const P_MAG: &[ParamSpec] = &[spec(
    "hard_iron_gauss",
    3,
    "gauss, body axes",
    -INF,
    INF,
    0.005,
)];
// The step: 0.2 % of a 0.55-G field is 0.1 µT, about the magnetometer's noise.
const P_SOFT: &[ParamSpec] = &[spec(
    "matrix",
    6,
    "dimensionless, symmetric: [S_xx, S_yy, S_zz, S_xy, S_yz, S_zx]",
    -0.5,
    0.5,
    2e-3,
)];

/// Row and column in the soft-iron matrix of each of its six values.
const SOFT_IRON_ENTRIES: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)];

/// The six values of a symmetric soft-iron matrix (its upper and lower entries are equal; the
/// configuration refuses others), in [`SOFT_IRON_ENTRIES`] order.
pub fn soft_iron_values(matrix: &[[f64; 3]; 3]) -> [f64; 6] {
    SOFT_IRON_ENTRIES.map(|(i, j)| matrix[i][j])
}

/// The symmetric matrix of six values in [`SOFT_IRON_ENTRIES`] order.
pub fn soft_iron_matrix(values: &[f64]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (&(i, j), &v) in SOFT_IRON_ENTRIES.iter().zip(values) {
        m[i][j] = v;
        m[j][i] = v;
    }
    m
}

impl Cause {
    /// Every cause, in the library's order.
    pub const ALL: [Cause; 22] = [
        Cause::ComOffset,
        Cause::ComDrift,
        Cause::EarthRate,
        Cause::AeroDrag,
        Cause::ConstantTorque,
        Cause::InertiaError,
        Cause::GyroScale,
        Cause::GyroMisalignment,
        Cause::GyroDelay,
        Cause::GyroBiasDrift,
        Cause::WheelFriction,
        Cause::WheelTorqueScale,
        Cause::ActuatorDelay,
        Cause::MagneticDisturbance,
        Cause::SoftIron,
        Cause::InclinometerBias,
        Cause::InclinometerScale,
        Cause::InclinometerCrossAxis,
        Cause::InclinometerLag,
        Cause::MagnetometerLag,
        Cause::ThrusterTorqueScale,
        Cause::PropellantComShift,
    ];

    /// The configuration table's name (`[effects.<name>]`), which is also the cause's name.
    pub fn name(self) -> &'static str {
        match self {
            Cause::ComOffset => "com_offset",
            Cause::ComDrift => "com_drift",
            Cause::EarthRate => "earth_rate",
            Cause::AeroDrag => "aero_drag",
            Cause::ConstantTorque => "constant_torque",
            Cause::InertiaError => "inertia_error",
            Cause::GyroScale => "gyro_scale",
            Cause::GyroMisalignment => "gyro_misalignment",
            Cause::GyroDelay => "gyro_delay",
            Cause::GyroBiasDrift => "gyro_bias_drift",
            Cause::WheelFriction => "wheel_friction",
            Cause::WheelTorqueScale => "wheel_torque_scale",
            Cause::ActuatorDelay => "actuator_delay",
            Cause::MagneticDisturbance => "magnetic_disturbance",
            Cause::SoftIron => "soft_iron",
            Cause::InclinometerBias => "inclinometer_bias",
            Cause::InclinometerScale => "inclinometer_scale",
            Cause::InclinometerCrossAxis => "inclinometer_cross_axis",
            Cause::InclinometerLag => "inclinometer_lag",
            Cause::MagnetometerLag => "magnetometer_lag",
            Cause::ThrusterTorqueScale => "thruster_torque_scale",
            Cause::PropellantComShift => "propellant_com_shift",
        }
    }

    /// The cause of a name (as [`Cause::name`] gives it).
    pub fn from_name(name: &str) -> Option<Cause> {
        Cause::ALL.into_iter().find(|c| c.name() == name)
    }

    /// One line on what the effect is.
    pub fn description(self) -> &'static str {
        match self {
            Cause::ComOffset => {
                "centre of mass offset from the bearing centre: gravity torque m g (r × G_B)"
            }
            Cause::ComDrift => {
                "the centre of mass drifts at a constant rate (thermal expansion, a shifting \
                 cable): gravity torque m g (ṙ t × G_B) growing with time"
            }
            Cause::EarthRate => {
                "the Earth's rotation sensed by the gyros, fixed in the level frame"
            }
            Cause::AeroDrag => "aerodynamic drag torque −(c1 w + c2 w|w|) per body axis",
            Cause::ConstantTorque => "constant torque in body axes (bearing exhaust, cables)",
            Cause::InertiaError => "principal moments of inertia differ from the nominal",
            Cause::GyroScale => "gyro scale-factor error per axis",
            Cause::GyroMisalignment => "gyro triad misaligned by a small rotation",
            Cause::GyroDelay => {
                "the gyros read the rate a delay before their time stamps (latency, stamped on \
                 arrival)"
            }
            Cause::GyroBiasDrift => {
                "the gyros' bias drifts at a constant rate (warm-up, the lab's temperature), \
                 faster than its random walk lets the filter follow"
            }
            Cause::WheelFriction => {
                "wheel friction beyond eq. 3: per-wheel levels, direction asymmetry, Stribeck"
            }
            Cause::WheelTorqueScale => "wheel motors deliver a scaled torque",
            Cause::ActuatorDelay => "actuator commands act after a delay",
            Cause::MagneticDisturbance => {
                "body-fixed (hard-iron) field added to the magnetometer reading"
            }
            Cause::SoftIron => {
                "soft iron: the magnetometer reads (1 + S) times the field, S symmetric"
            }
            Cause::InclinometerBias => {
                "inclinometer mounted off level with the body axes: a constant offset of its angles"
            }
            Cause::InclinometerScale => "inclinometer scale-factor error per angle",
            Cause::InclinometerCrossAxis => {
                "each inclinometer angle reads a fraction of the other (cross-axis sensitivity, \
                 or the sensor turned about the vertical)"
            }
            Cause::InclinometerLag => {
                "the inclinometer's angles lag the platform's (a first-order response, or stamped \
                 late): it reads the attitude τ earlier, about θ − τ θ̇"
            }
            Cause::MagnetometerLag => {
                "the magnetometer lags the platform (it averages, or is stamped late): it reads \
                 the field of the attitude τ earlier"
            }
            Cause::ThrusterTorqueScale => {
                "thrusters deliver a scaled thrust (worn nozzle, regulator set wrong), per thruster"
            }
            Cause::PropellantComShift => {
                "the draining tank moves the centre of mass: gravity torque −m_u g (r_t × G_B) \
                 growing with the propellant used; r_t is the tank position"
            }
        }
    }

    pub fn kind(self) -> Kind {
        match self {
            Cause::EarthRate
            | Cause::GyroScale
            | Cause::GyroMisalignment
            | Cause::GyroDelay
            | Cause::GyroBiasDrift
            | Cause::MagneticDisturbance
            | Cause::SoftIron
            | Cause::InclinometerBias
            | Cause::InclinometerScale
            | Cause::InclinometerCrossAxis
            | Cause::InclinometerLag
            | Cause::MagnetometerLag => Kind::Sensor,
            Cause::ComOffset
            | Cause::ComDrift
            | Cause::AeroDrag
            | Cause::ConstantTorque
            | Cause::InertiaError
            | Cause::ThrusterTorqueScale
            | Cause::PropellantComShift => Kind::Torque,
            Cause::WheelFriction | Cause::WheelTorqueScale | Cause::ActuatorDelay => Kind::Wheel,
        }
    }

    /// Whether the cause acts on the magnetometer's reading (hard and soft iron).
    pub fn magnetometer(self) -> bool {
        matches!(self, Cause::MagneticDisturbance | Cause::SoftIron)
    }

    /// Whether the cause acts on the magnetometer's readings (the data need a magnetometer).
    pub fn needs_field(self) -> bool {
        self.magnetometer() || self == Cause::MagnetometerLag
    }

    /// Whether the cause acts on the inclinometer's readings (the data need an inclinometer).
    pub fn needs_tilt(self) -> bool {
        matches!(
            self,
            Cause::InclinometerBias
                | Cause::InclinometerScale
                | Cause::InclinometerCrossAxis
                | Cause::InclinometerLag
        )
    }

    /// Parameter arrays, in the order of [`Cause::values`].
    pub fn params(self) -> &'static [ParamSpec] {
        match self {
            Cause::ComOffset => P_COM,
            Cause::ComDrift => P_COM_DRIFT,
            Cause::EarthRate => P_EARTH,
            Cause::AeroDrag => P_DRAG,
            Cause::ConstantTorque => P_CONST,
            Cause::InertiaError => P_INERTIA,
            Cause::GyroScale => P_SCALE,
            Cause::GyroMisalignment => P_MISALIGN,
            Cause::GyroDelay => P_GYRO_DELAY,
            Cause::GyroBiasDrift => P_GYRO_DRIFT,
            Cause::WheelFriction => P_FRICTION,
            Cause::WheelTorqueScale => P_TSCALE,
            Cause::ActuatorDelay => P_DELAY,
            Cause::MagneticDisturbance => P_MAG,
            Cause::SoftIron => P_SOFT,
            Cause::InclinometerBias => P_TILT_BIAS,
            Cause::InclinometerScale => P_TILT_SCALE,
            Cause::InclinometerCrossAxis => P_TILT_CROSS,
            Cause::InclinometerLag => P_TILT_LAG,
            Cause::MagnetometerLag => P_FIELD_LAG,
            Cause::ThrusterTorqueScale => P_THRUSTER_SCALE,
            Cause::PropellantComShift => P_TANK,
        }
    }

    /// Total number of values.
    #[allow(clippy::len_without_is_empty)] // a cause always has values
    pub fn len(self) -> usize {
        self.params().iter().map(|p| p.len).sum()
    }

    /// Lower and upper bound of value `i`.
    pub fn bounds(self, i: usize) -> (f64, f64) {
        let mut k = i;
        for p in self.params() {
            if k < p.len {
                return (p.lower, p.upper);
            }
            k -= p.len;
        }
        (-INF, INF)
    }

    /// `key[index]` name of value `i` (`soft_iron.matrix[row][column]` for the soft iron).
    pub fn value_name(self, i: usize) -> String {
        if let (Cause::SoftIron, Some((r, c))) = (self, SOFT_IRON_ENTRIES.get(i)) {
            return format!("soft_iron.matrix[{r}][{c}]");
        }
        let mut k = i;
        for p in self.params() {
            if k < p.len {
                return if p.len == 1 {
                    format!("{}.{}", self.name(), p.key)
                } else {
                    format!("{}.{}[{k}]", self.name(), p.key)
                };
            }
            k -= p.len;
        }
        format!("{}[{i}]", self.name())
    }

    /// Whether the configuration has the effect.
    pub fn present(self, config: &ModelConfig) -> bool {
        let e = &config.effects;
        match self {
            Cause::ComOffset => e.com_offset.is_some(),
            Cause::ComDrift => e.com_drift.is_some(),
            Cause::EarthRate => e.earth_rate.is_some(),
            Cause::AeroDrag => e.aero_drag.is_some(),
            Cause::ConstantTorque => e.constant_torque.is_some(),
            Cause::InertiaError => e.inertia_error.is_some(),
            Cause::GyroScale => e.gyro_scale.is_some(),
            Cause::GyroMisalignment => e.gyro_misalignment.is_some(),
            Cause::GyroDelay => e.gyro_delay.is_some(),
            Cause::GyroBiasDrift => e.gyro_bias_drift.is_some(),
            Cause::WheelFriction => e.wheel_friction.is_some(),
            Cause::WheelTorqueScale => e.wheel_torque_scale.is_some(),
            Cause::ActuatorDelay => e.actuator_delay.is_some(),
            Cause::MagneticDisturbance => e.magnetic_disturbance.is_some(),
            Cause::SoftIron => e.soft_iron.is_some(),
            Cause::InclinometerBias => e.inclinometer_bias.is_some(),
            Cause::InclinometerScale => e.inclinometer_scale.is_some(),
            Cause::InclinometerCrossAxis => e.inclinometer_cross_axis.is_some(),
            Cause::InclinometerLag => e.inclinometer_lag.is_some(),
            Cause::MagnetometerLag => e.magnetometer_lag.is_some(),
            Cause::ThrusterTorqueScale => e.thruster_torque_scale.is_some(),
            // The tank position is part of `[thrusters]`: present with the thrusters.
            Cause::PropellantComShift => config.thrusters.is_some(),
        }
    }

    /// Whether a sensor cause at `values` leaves every reading as it is without it: zero, for
    /// every sensor cause but `earth_rate`, which has no such value. The sensor model then
    /// computes exactly what it computes without the effect (identity matrices, zero offsets),
    /// so a filter run does not see it.
    pub fn neutral(self, values: &[f64]) -> bool {
        self.kind() == Kind::Sensor && self != Cause::EarthRate && values.iter().all(|v| *v == 0.0)
    }

    /// The effect's values in `config`, flattened in [`Cause::params`] order; when the effect is
    /// absent, the values that reproduce the configuration without it (the nominal friction for
    /// `wheel_friction`, unit scale, zero elsewhere), except `earth_rate`, which has no neutral
    /// value and starts from `platform.latitude_deg`.
    pub fn values(self, config: &ModelConfig) -> Vec<f64> {
        let e = &config.effects;
        match self {
            Cause::ComOffset => e.com_offset.as_ref().map_or([0.0; 3], |x| x.r_m).to_vec(),
            Cause::ComDrift => e
                .com_drift
                .as_ref()
                .map_or([0.0; 3], |x| x.rate_m_per_s)
                .to_vec(),
            Cause::EarthRate => vec![
                e.earth_rate
                    .as_ref()
                    .map_or(config.platform.latitude_deg, |x| x.latitude_deg),
            ],
            Cause::AeroDrag => e
                .aero_drag
                .as_ref()
                .map_or([0.0; 6], |x| cat(&x.c1, &x.c2))
                .to_vec(),
            Cause::ConstantTorque => e
                .constant_torque
                .as_ref()
                .map_or([0.0; 3], |x| x.torque_nm)
                .to_vec(),
            Cause::InertiaError => e
                .inertia_error
                .as_ref()
                .map_or([0.0; 6], |x| {
                    cat(&x.fraction, &x.products_kgm2.unwrap_or([0.0; 3]))
                })
                .to_vec(),
            Cause::GyroScale => e.gyro_scale.as_ref().map_or([0.0; 3], |x| x.ppm).to_vec(),
            Cause::GyroMisalignment => e
                .gyro_misalignment
                .as_ref()
                .map_or([0.0; 3], |x| x.angles_rad)
                .to_vec(),
            Cause::GyroDelay => vec![e.gyro_delay.as_ref().map_or(0.0, |x| x.delay_s)],
            Cause::GyroBiasDrift => e
                .gyro_bias_drift
                .as_ref()
                .map_or([0.0; 3], |x| x.rate_rad_s2)
                .to_vec(),
            Cause::WheelFriction => {
                let f = e
                    .wheel_friction
                    .clone()
                    .unwrap_or_else(|| nominal_friction(config));
                [
                    f.coulomb_pos_nm,
                    f.coulomb_neg_nm,
                    f.viscous_nm_per_rad_s,
                    f.stribeck_nm,
                    f.stribeck_speed_rad_s,
                ]
                .concat()
            }
            Cause::WheelTorqueScale => e
                .wheel_torque_scale
                .as_ref()
                .map_or([1.0; 3], |x| x.scale)
                .to_vec(),
            Cause::ActuatorDelay => vec![e.actuator_delay.as_ref().map_or(0.0, |x| x.delay_s)],
            Cause::MagneticDisturbance => e
                .magnetic_disturbance
                .as_ref()
                .map_or([0.0; 3], |x| x.hard_iron_gauss)
                .to_vec(),
            Cause::SoftIron => e
                .soft_iron
                .as_ref()
                .map_or([0.0; 6], |x| soft_iron_values(&x.matrix))
                .to_vec(),
            Cause::InclinometerBias => e
                .inclinometer_bias
                .as_ref()
                .map_or([0.0; 2], |x| x.offset_rad)
                .to_vec(),
            Cause::InclinometerScale => e
                .inclinometer_scale
                .as_ref()
                .map_or([0.0; 2], |x| x.ppm)
                .to_vec(),
            Cause::InclinometerCrossAxis => e
                .inclinometer_cross_axis
                .as_ref()
                .map_or([0.0; 2], |x| x.coupling)
                .to_vec(),
            Cause::InclinometerLag => vec![
                e.inclinometer_lag
                    .as_ref()
                    .map_or(0.0, |x| x.time_constant_s),
            ],
            Cause::MagnetometerLag => vec![
                e.magnetometer_lag
                    .as_ref()
                    .map_or(0.0, |x| x.time_constant_s),
            ],
            Cause::ThrusterTorqueScale => e
                .thruster_torque_scale
                .as_ref()
                .map_or([1.0; THRUSTER_COUNT], |x| x.scale)
                .to_vec(),
            Cause::PropellantComShift => config
                .thrusters
                .as_ref()
                .map_or_else(
                    || ThrusterConfig::default().tank_position_m,
                    |t| t.tank_position_m,
                )
                .to_vec(),
        }
    }

    /// Switch the effect on in `config` with `values` (in [`Cause::values`] order, clamped to
    /// the configuration's bounds).
    pub fn apply(self, config: &mut ModelConfig, values: &[f64]) {
        let v: Vec<f64> = values
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let (lo, hi) = self.bounds(i);
                x.clamp(lo, hi)
            })
            .collect();
        let a3 = |i: usize| [v[i], v[i + 1], v[i + 2]];
        let e = &mut config.effects;
        match self {
            Cause::ComOffset => e.com_offset = Some(ComOffset { r_m: a3(0) }),
            Cause::ComDrift => {
                e.com_drift = Some(ComDrift {
                    rate_m_per_s: a3(0),
                })
            }
            Cause::EarthRate => e.earth_rate = Some(EarthRate { latitude_deg: v[0] }),
            Cause::AeroDrag => {
                e.aero_drag = Some(AeroDrag {
                    c1: a3(0),
                    c2: a3(3),
                })
            }
            Cause::ConstantTorque => e.constant_torque = Some(ConstantTorque { torque_nm: a3(0) }),
            Cause::InertiaError => {
                e.inertia_error = Some(InertiaError {
                    fraction: a3(0),
                    products_kgm2: Some(a3(3)),
                })
            }
            Cause::GyroScale => e.gyro_scale = Some(GyroScale { ppm: a3(0) }),
            Cause::GyroMisalignment => {
                e.gyro_misalignment = Some(GyroMisalignment { angles_rad: a3(0) })
            }
            Cause::GyroDelay => e.gyro_delay = Some(GyroDelay { delay_s: v[0] }),
            Cause::GyroBiasDrift => e.gyro_bias_drift = Some(GyroBiasDrift { rate_rad_s2: a3(0) }),
            Cause::WheelFriction => {
                e.wheel_friction = Some(WheelFriction {
                    coulomb_pos_nm: a3(0),
                    coulomb_neg_nm: a3(3),
                    viscous_nm_per_rad_s: a3(6),
                    stribeck_nm: a3(9),
                    stribeck_speed_rad_s: a3(12),
                })
            }
            Cause::WheelTorqueScale => {
                e.wheel_torque_scale = Some(WheelTorqueScale { scale: a3(0) })
            }
            Cause::ActuatorDelay => e.actuator_delay = Some(ActuatorDelay { delay_s: v[0] }),
            Cause::MagneticDisturbance => {
                e.magnetic_disturbance = Some(MagneticDisturbance {
                    hard_iron_gauss: a3(0),
                })
            }
            Cause::SoftIron => {
                e.soft_iron = Some(SoftIron {
                    matrix: soft_iron_matrix(&v),
                })
            }
            Cause::InclinometerBias => {
                e.inclinometer_bias = Some(InclinometerBias {
                    offset_rad: [v[0], v[1]],
                })
            }
            Cause::InclinometerScale => {
                e.inclinometer_scale = Some(InclinometerScale { ppm: [v[0], v[1]] })
            }
            Cause::InclinometerCrossAxis => {
                e.inclinometer_cross_axis = Some(InclinometerCrossAxis {
                    coupling: [v[0], v[1]],
                })
            }
            Cause::InclinometerLag => {
                e.inclinometer_lag = Some(InclinometerLag {
                    time_constant_s: v[0],
                })
            }
            Cause::MagnetometerLag => {
                e.magnetometer_lag = Some(MagnetometerLag {
                    time_constant_s: v[0],
                })
            }
            Cause::ThrusterTorqueScale => {
                e.thruster_torque_scale = Some(ThrusterTorqueScale {
                    scale: std::array::from_fn(|i| v[i]),
                })
            }
            // Without thrusters there is no tank to move (the cause is never a candidate then).
            Cause::PropellantComShift => {
                if let Some(t) = config.thrusters.as_mut() {
                    t.tank_position_m = a3(0);
                }
            }
        }
    }

    /// Values and standard errors as a JSON object keyed by the configuration's keys (arrays for
    /// vectors; `null` where a standard error is not defined).
    pub fn to_json(self, values: &[f64]) -> serde_json::Map<String, serde_json::Value> {
        let mut map = serde_json::Map::new();
        let mut i = 0;
        for p in self.params() {
            let slice = &values[i..i + p.len];
            let value = if p.len == 1 {
                json_number(slice[0])
            } else {
                serde_json::Value::Array(slice.iter().map(|x| json_number(*x)).collect())
            };
            map.insert(p.key.to_string(), value);
            i += p.len;
        }
        map
    }

    /// Units of each key, as a JSON object.
    pub fn units_json(self) -> serde_json::Map<String, serde_json::Value> {
        self.params()
            .iter()
            .map(|p| (p.key.to_string(), serde_json::Value::from(p.unit)))
            .collect()
    }
}

fn json_number(x: f64) -> serde_json::Value {
    serde_json::Number::from_f64(x).map_or(serde_json::Value::Null, serde_json::Value::Number)
}

fn cat(a: &[f64; 3], b: &[f64; 3]) -> [f64; 6] {
    [a[0], a[1], a[2], b[0], b[1], b[2]]
}

/// The `wheel_friction` table that reproduces the nominal friction of eq. 3 (no asymmetry,
/// breakaway = Coulomb, so the Stribeck term vanishes whatever its speed).
pub fn nominal_friction(config: &ModelConfig) -> WheelFriction {
    let w = &config.wheels;
    WheelFriction {
        coulomb_pos_nm: w.coulomb_nm,
        coulomb_neg_nm: w.coulomb_nm,
        viscous_nm_per_rad_s: w.viscous_nm_per_rad_s,
        stribeck_nm: w.coulomb_nm,
        stribeck_speed_rad_s: [1.0; 3],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_round_trip_through_apply_and_the_toml() {
        for cause in Cause::ALL {
            let mut config = ModelConfig {
                thrusters: Some(ThrusterConfig::default()),
                ..ModelConfig::default()
            };
            let values: Vec<f64> = cause
                .values(&config)
                .iter()
                .enumerate()
                .map(|(i, x)| x + 1e-5 * (i + 1) as f64)
                .collect();
            cause.apply(&mut config, &values);
            assert!(cause.present(&config));
            assert_eq!(cause.values(&config), values, "{}", cause.name());
            let text = config.to_toml_string();
            let back = ModelConfig::from_toml_str(&text, "round-trip").unwrap();
            assert_eq!(back, config, "{}", cause.name());
            assert_eq!(Cause::from_name(cause.name()), Some(cause));
            assert_eq!(cause.len(), values.len());
        }
    }

    #[test]
    fn soft_iron_values_are_the_symmetric_matrix_entries() {
        let mut config = ModelConfig::default();
        Cause::SoftIron.apply(&mut config, &[0.01, 0.02, 0.03, 0.04, 0.05, 0.06]);
        let m = config.effects.soft_iron.as_ref().map(|s| s.matrix);
        assert_eq!(
            m,
            Some([[0.01, 0.04, 0.06], [0.04, 0.02, 0.05], [0.06, 0.05, 0.03]])
        );
        assert!(config.validate().is_ok());
        assert_eq!(Cause::SoftIron.value_name(3), "soft_iron.matrix[0][1]");
        assert_eq!(Cause::SoftIron.value_name(5), "soft_iron.matrix[2][0]");
    }

    #[test]
    fn neutral_values_reproduce_the_nominal_model() {
        use testbed_model::physics::{Wheel, wheel_breakaway_torque, wheel_friction_torque};
        let nominal = ModelConfig::default();
        let mut with = nominal.clone();
        Cause::WheelFriction.apply(&mut with, &Cause::WheelFriction.values(&nominal));
        for wheel in Wheel::ALL {
            for n in [-300.0, -0.3, 0.2, 50.0] {
                let a = wheel_friction_torque(&nominal, wheel, n);
                let b = wheel_friction_torque(&with, wheel, n);
                assert!((a - b).abs() < 1e-15);
            }
            assert_eq!(
                wheel_breakaway_torque(&nominal, wheel),
                wheel_breakaway_torque(&with, wheel)
            );
        }
    }
}
