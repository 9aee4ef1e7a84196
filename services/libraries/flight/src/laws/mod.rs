//! Control laws behind one interface, chosen by name in the run configuration
//! (`[controller] law = "<name>"`, parameters in `[controller.<name>]`).
//!
//! A law is a small struct with its own parameter table. Each control tick it turns the time,
//! the attitude estimate (level frame to body frame), the body rate (rad/s, body axes), the
//! target and the actuators' telemetry into actuator commands ([`ControlOutput`]: wheel motor
//! torques in N·m and/or CMG gimbal rates in rad/s, the attitude error, a saturation flag). It
//! declares which actuators it drives ([`Drives`]).
//!
//! What a law must not bypass stays around it, in the controller
//! ([`crate::tasks::ControllerTask`] and its guard): safe mode, input-loss detection, ground
//! commands, and the actuators' limits — after the law, every wheel torque is clipped to the
//! wheel's torque limit and to what keeps the wheel inside its speed limit over one control
//! period, every gimbal rate to the gimbals' rate limit, and the commands of actuators the law
//! does not drive are zero. Thruster control stays separate (`[controller.thrusters]`).
//!
//! Adding a law: one file here implementing [`ControlLaw`] and [`LawDefinition`], one line in
//! [`LAWS`], one table in the configuration (`docs/control-laws.md`).

pub mod cmg_slew;
pub mod eigenaxis_slew;
pub mod pd_deadband;
pub mod pd_friction;
pub mod pendulum_lqr;

use crate::choice::{self, ChoiceError, Tables};
use crate::control::ControlError;
use nalgebra::{Matrix3, Vector3, Vector4};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::any::TypeId;
use testbed_model::ModelConfig;
use testbed_model::attitude::Attitude;
use testbed_model::physics::ActuatorCommand;

/// Every law there is: its name in the configuration and its type.
pub const LAWS: &[LawEntry] = &[
    law::<pd_friction::PdFriction>("pd_friction"),
    law::<cmg_slew::CmgSlew>("cmg_slew"),
    law::<eigenaxis_slew::EigenaxisSlew>("eigenaxis_slew"),
    law::<pendulum_lqr::PendulumLqr>("pendulum_lqr"),
    law::<pd_deadband::PdDeadband>("pd_deadband"),
];

/// The law of a configuration without `controller.law`: the paper's.
pub const DEFAULT_LAW: &str = "pd_friction";

/// What the controller measured of the actuators (from their telemetry).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorTelemetry {
    /// Wheel speeds relative to the platform, rad/s.
    pub wheel_speed_rad_s: Vector3<f64>,
    /// Gimbal angles, rad.
    pub gimbal_rad: Vector4<f64>,
}

/// One control tick's inputs to a law.
#[derive(Debug, Clone, Copy)]
pub struct LawInput<'a> {
    /// Run time, s.
    pub t_s: f64,
    /// Attitude estimate, level frame to body frame.
    pub attitude: &'a Attitude,
    /// Body rate relative to the level frame, rad/s, body axes.
    pub rate_b_rad_s: &'a Vector3<f64>,
    /// Target attitude, level frame to target frame.
    pub target: &'a Attitude,
    pub telemetry: &'a ActuatorTelemetry,
}

/// One control output.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlOutput {
    pub command: ActuatorCommand,
    /// Attitude error of the estimate relative to the target (rotation vector), rad, body axes.
    pub error_rad: Vector3<f64>,
    /// A torque, momentum or gimbal-rate limit changed the command.
    pub saturated: bool,
    /// CMG singularity measure (`None` without CMGs).
    pub singularity_measure: Option<f64>,
}

/// Which actuators a law commands; the controller zeroes the others' commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Drives {
    pub wheels: bool,
    pub cmgs: bool,
}

impl Drives {
    pub const WHEELS: Self = Self {
        wheels: true,
        cmgs: false,
    };
    pub const CMGS: Self = Self {
        wheels: false,
        cmgs: true,
    };
}

/// A control law, as the controller calls it once per control tick.
pub trait ControlLaw: Send {
    /// The actuators this law commands.
    fn drives(&self) -> Drives;
    /// The command for one tick. `&mut self`: a law may keep state (an integrator, a filter).
    fn command(&mut self, input: &LawInput<'_>) -> Result<ControlOutput, ControlError>;
    /// The law and its gains in one line, for run reports.
    fn describe(&self) -> String;
}

/// A law's parameter table: a serde struct with `deny_unknown_fields` and defaults for every
/// field, each documented with its unit and source.
pub trait LawParams: Serialize + DeserializeOwned + Default + Clone + 'static {
    /// Refuse values the law cannot use, naming the field (relative to the table).
    fn validate(&self) -> Result<(), ControlError>;
}

/// How the registry builds a law from its parameters and the model (the flight software's
/// nominal model: inertia, wheels, CMGs, centre-of-mass offset…).
pub trait LawDefinition: ControlLaw + Sized + 'static {
    type Params: LawParams;
    fn build(params: &Self::Params, model: &ModelConfig) -> Result<Self, ControlError>;
}

/// Builds a law from its table and the model.
type BuildLaw =
    fn(&str, Option<&toml::Value>, &ModelConfig) -> Result<Box<dyn ControlLaw>, ControlError>;

/// One line of [`LAWS`]: a name, and how to check its table and build the law.
pub struct LawEntry {
    pub name: &'static str,
    params_type: fn() -> TypeId,
    check: fn(&str, Option<&toml::Value>) -> Result<(), ChoiceError>,
    full_table: fn(&str, Option<&toml::Value>) -> Result<toml::Value, ChoiceError>,
    build: BuildLaw,
}

/// The registry entry of law `L` under `name`.
pub const fn law<L: LawDefinition>(name: &'static str) -> LawEntry {
    LawEntry {
        name,
        params_type: TypeId::of::<L::Params>,
        check: check_table::<L::Params>,
        full_table: full_table::<L::Params>,
        build: build_law::<L>,
    }
}

fn check_table<P: LawParams>(name: &str, table: Option<&toml::Value>) -> Result<(), ChoiceError> {
    parse::<P>(name, table).map(|_| ())
}

fn full_table<P: LawParams>(
    name: &str,
    table: Option<&toml::Value>,
) -> Result<toml::Value, ChoiceError> {
    choice::table_of(&section(name), &parse::<P>(name, table)?)
}

fn build_law<L: LawDefinition>(
    name: &str,
    table: Option<&toml::Value>,
    model: &ModelConfig,
) -> Result<Box<dyn ControlLaw>, ControlError> {
    let params = parse::<L::Params>(name, table).map_err(|e| ControlError::InvalidConfig {
        key: e.key,
        value: e.value,
        reason: e.reason,
    })?;
    Ok(Box::new(L::build(&params, model)?))
}

/// The configuration section of law `name`.
pub fn section(name: &str) -> String {
    format!("controller.{name}")
}

/// `P` from the table of law `name` (defaults where absent), validated; keys named in full.
fn parse<P: LawParams>(name: &str, table: Option<&toml::Value>) -> Result<P, ChoiceError> {
    let section = section(name);
    let params = choice::params_from_table(&section, &P::default(), table)?;
    params.validate().map_err(|e| match e {
        ControlError::InvalidConfig { key, value, reason } => {
            ChoiceError::new(format!("{section}.{key}"), value, reason)
        }
        other => ChoiceError::new(&section, "(table)", other.to_string()),
    })?;
    Ok(params)
}

/// The entry named `name`.
pub fn find(name: &str) -> Option<&'static LawEntry> {
    LAWS.iter().find(|e| e.name == name)
}

/// The names of every law.
pub fn names() -> Vec<&'static str> {
    LAWS.iter().map(|e| e.name).collect()
}

/// The entry whose parameter type is `P`.
fn entry_of<P: LawParams>() -> Result<&'static LawEntry, ChoiceError> {
    LAWS.iter()
        .find(|e| (e.params_type)() == TypeId::of::<P>())
        .ok_or_else(|| {
            ChoiceError::new(
                "controller",
                std::any::type_name::<P>(),
                "no registered law has these parameters",
            )
        })
}

/// The law of configuration tables: `law` the selected name, `tables` the `[controller.<name>]`
/// tables. Checks the name and every table (a table for an unknown law is refused).
pub fn check(law: &str, tables: &Tables) -> Result<&'static LawEntry, ChoiceError> {
    let entry = find(law)
        .ok_or_else(|| choice::unknown_name("controller.law", law, &names(), "control law"))?;
    for (name, table) in tables {
        let Some(e) = find(name) else {
            return Err(ChoiceError::new(
                section(name),
                table,
                format!(
                    "no control law of that name (a table under [controller] other than \
                     safe_mode and thrusters is a law's parameters); known: {}",
                    names().join(", ")
                ),
            ));
        };
        (e.check)(name, Some(table))?;
    }
    Ok(entry)
}

impl LawEntry {
    /// The law, from its table (`None`: the defaults) and the model.
    pub fn build(
        &self,
        table: Option<&toml::Value>,
        model: &ModelConfig,
    ) -> Result<Box<dyn ControlLaw>, ControlError> {
        (self.build)(self.name, table, model)
    }

    /// Every parameter of the law, from its table (`None`: the defaults), as a table: what a
    /// configuration writes out so that each value has a key (a campaign disperses them).
    pub fn full_table(&self, table: Option<&toml::Value>) -> Result<toml::Value, ChoiceError> {
        (self.full_table)(self.name, table)
    }
}

/// The parameters of the law whose parameter type is `P`, from `tables` (defaults where
/// absent): the typed view for code and tests that change a law's gains.
pub fn params<P: LawParams>(tables: &Tables) -> Result<P, ChoiceError> {
    let entry = entry_of::<P>()?;
    parse(entry.name, tables.get(entry.name))
}

/// Writes `params` as the table of the law whose parameter type is `P`; returns its name.
pub fn set_params<P: LawParams>(
    tables: &mut Tables,
    params: &P,
) -> Result<&'static str, ChoiceError> {
    let entry = entry_of::<P>()?;
    tables.insert(
        entry.name.to_owned(),
        choice::table_of(&section(entry.name), params)?,
    );
    Ok(entry.name)
}

/// What a law on the wheels needs to turn a body torque into motor torques: the model's wheel
/// friction (compensated as the paper's law does) and torque limit.
#[derive(Debug, Clone, PartialEq)]
pub struct WheelDrive {
    coulomb_nm: Vector3<f64>,
    viscous_nm_per_rad_s: Vector3<f64>,
    speed_scale_rad_s: f64,
    max_torque_nm: f64,
    compensate_friction: bool,
}

impl WheelDrive {
    /// From the model's wheels; `speed_scale_rad_s` the `n_s` of the smooth sign
    /// ([`crate::control`]).
    pub fn new(
        wheels: &testbed_model::config::WheelConfig,
        compensate_friction: bool,
        speed_scale_rad_s: f64,
    ) -> Result<Self, ControlError> {
        crate::control::check_positive("wheels.max_torque_nm", wheels.max_torque_nm)?;
        crate::control::check_positive("friction_speed_scale_rad_s", speed_scale_rad_s)?;
        Ok(Self {
            coulomb_nm: Vector3::from(wheels.coulomb_nm),
            viscous_nm_per_rad_s: Vector3::from(wheels.viscous_nm_per_rad_s),
            speed_scale_rad_s,
            max_torque_nm: wheels.max_torque_nm,
            compensate_friction,
        })
    }

    /// Motor torques (N·m) for the body torque `u_body_nm` (N·m, body axes) at the measured
    /// wheel speeds (rad/s): friction compensated, the body torque scaled down (direction kept)
    /// to the torque limit; and whether it was scaled.
    pub fn motor_torque(
        &self,
        u_body_nm: &Vector3<f64>,
        wheel_speed_rad_s: &Vector3<f64>,
    ) -> (Vector3<f64>, bool) {
        let t_max = self.max_torque_nm;
        let friction = if self.compensate_friction {
            crate::control::friction_model_nm(
                &self.coulomb_nm,
                &self.viscous_nm_per_rad_s,
                self.speed_scale_rad_s,
                wheel_speed_rad_s,
            )
            .map(|f| f.clamp(-t_max, t_max))
        } else {
            Vector3::zeros()
        };
        crate::control::motor_torque_for(u_body_nm, &friction, t_max)
    }
}

/// Checks the law's inputs are finite (a law is given what the estimator published).
pub fn check_inputs(input: &LawInput<'_>) -> Result<(), ControlError> {
    crate::control::check_finite_quaternion(input.attitude, "q_est")?;
    crate::control::check_finite_quaternion(input.target, "q_target")?;
    crate::control::check_finite_vector(input.rate_b_rad_s, "rate_b")?;
    crate::control::check_finite_vector(&input.telemetry.wheel_speed_rad_s, "wheel_speed_rad_s")
}

/// A wheel law's output: motor torques, the attitude error, saturation.
pub fn wheel_output(
    motor_torque_nm: Vector3<f64>,
    error_rad: Vector3<f64>,
    saturated: bool,
) -> ControlOutput {
    ControlOutput {
        command: ActuatorCommand {
            wheel_torque_nm: motor_torque_nm,
            gimbal_rate_rad_s: Vector4::zeros(),
        },
        error_rad,
        saturated,
        singularity_measure: None,
    }
}

/// The platform's nominal inertia, kg m² (body frame): the flight software knows it, never the
/// plant's true one.
pub fn nominal_inertia(model: &ModelConfig) -> Result<Matrix3<f64>, ControlError> {
    model
        .platform
        .inertia()
        .ok_or_else(|| ControlError::InvalidConfig {
            key: "platform.inertia_kgm2".into(),
            value: format!("{:?}", model.platform.inertia_kgm2),
            reason: "must be symmetric positive definite".into(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_law_has_one_name_one_parameter_type_and_builds_from_its_defaults() {
        let model = ModelConfig::default();
        for (i, e) in LAWS.iter().enumerate() {
            assert!(LAWS[..i].iter().all(|o| o.name != e.name), "{}", e.name);
            assert!(
                LAWS[..i]
                    .iter()
                    .all(|o| (o.params_type)() != (e.params_type)()),
                "{}",
                e.name
            );
            let law = e
                .build(None, &model)
                .unwrap_or_else(|err| panic!("{}: {err}", e.name));
            assert!(!law.describe().is_empty());
        }
        assert!(find(DEFAULT_LAW).is_some());
    }

    #[test]
    fn an_unknown_name_lists_the_known_ones() {
        let e = check("pid", &Tables::new()).err().unwrap();
        assert_eq!(e.key, "controller.law");
        assert!(e.value.contains("pid"));
        for name in names() {
            assert!(e.reason.contains(name), "{e}");
        }
    }

    #[test]
    fn a_table_for_an_unknown_law_or_an_unknown_field_is_refused_naming_it() {
        let mut tables = Tables::new();
        tables.insert(
            "wheels".into(),
            toml::from_str("p_nm = [1.0, 1.0, 1.0]").unwrap(),
        );
        let e = check(DEFAULT_LAW, &tables).err().unwrap();
        assert_eq!(e.key, "controller.wheels", "{e}");
        assert!(e.reason.contains("no control law of that name"), "{e}");
        let mut tables = Tables::new();
        tables.insert(
            "pd_friction".into(),
            toml::from_str("p_gain = 1.0").unwrap(),
        );
        let e = check(DEFAULT_LAW, &tables).err().unwrap();
        assert_eq!(e.key, "controller.pd_friction");
        assert!(e.reason.contains("p_gain"), "{e}");
        let mut tables = Tables::new();
        tables.insert(
            "pd_friction".into(),
            toml::from_str("p_nm = [1.0, -1.0, 1.0]").unwrap(),
        );
        let e = check(DEFAULT_LAW, &tables).err().unwrap();
        assert_eq!(e.key, "controller.pd_friction.p_nm[1]", "{e}");
    }

    #[test]
    fn typed_parameters_round_trip_through_the_tables() {
        let mut tables = Tables::new();
        let mut p: pd_friction::PdFrictionConfig = params(&tables).unwrap();
        assert_eq!(p, pd_friction::PdFrictionConfig::default());
        p.friction_compensation = false;
        assert_eq!(set_params(&mut tables, &p).unwrap(), "pd_friction");
        assert_eq!(params::<pd_friction::PdFrictionConfig>(&tables).unwrap(), p);
    }
}
