//! The controller's configuration (`[controller]`): the law by name (`law = "<name>"`) with its
//! parameter tables (`[controller.<name>]`, [`crate::laws`]), safe mode and thruster control.
//! The law tables are kept as written, so a configuration round-trips unchanged; they are
//! parsed and checked when the law is built or [`ControllerConfig::check`]ed.

use super::GuardedLaw;
use crate::choice::{ChoiceError, Tables};
use crate::control::ControlError;
use crate::laws::{self, ControlLaw, DEFAULT_LAW, LawParams};
use crate::safe_mode::SafeModeConfig;
use crate::thruster_control::ThrusterControlConfig;
use serde::de::Error as _;
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use testbed_model::ModelConfig;
use testbed_model::attitude::Attitude;

/// Keys of `[controller]` that are not a law's table.
const SAFE_MODE: &str = "safe_mode";
const THRUSTERS: &str = "thrusters";
const LAW: &str = "law";

/// Keys of the configuration before laws were chosen by name, and what replaced them.
const REPLACED: &[(&str, &str)] = &[
    (
        "actuators",
        "replaced by `controller.law`: \"pd_friction\" for the wheels, \"cmg_slew\" for the CMGs",
    ),
    (
        "wheels",
        "replaced by [controller.pd_friction] (same fields)",
    ),
    (
        "slew",
        "replaced by [controller.cmg_slew.slew] (same fields)",
    ),
    (
        "steering",
        "replaced by [controller.cmg_slew.steering] (same fields)",
    ),
];

/// Controller configuration: the law by name and its parameters, safe mode, thrusters.
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerConfig {
    /// The control law's name (`controller.law`), one of [`laws::LAWS`].
    pub law: String,
    /// `[controller.<name>]` tables, as written (see [`Self::law_params`]).
    tables: Tables,
    /// When the controller stops trusting its inputs and what it commands then.
    pub safe_mode: SafeModeConfig,
    /// Thruster control; off unless present (needs the model's `[thrusters]`).
    pub thrusters: Option<ThrusterControlConfig>,
}

impl Default for ControllerConfig {
    fn default() -> Self {
        Self::with_law(DEFAULT_LAW)
    }
}

impl ControllerConfig {
    /// The default configuration with law `name` (its default parameters).
    pub fn with_law(name: &str) -> Self {
        Self {
            law: name.to_owned(),
            tables: Tables::new(),
            safe_mode: SafeModeConfig::default(),
            thrusters: None,
        }
    }

    /// The law's name, every law table and safe mode checked, as the controller checks them
    /// when it starts (the law's parameters against the model: [`Self::law`]).
    pub fn check(&self) -> Result<(), ChoiceError> {
        if let Some((key, reason)) = REPLACED.iter().find(|(k, _)| self.tables.contains_key(*k)) {
            return Err(ChoiceError::new(
                format!("controller.{key}"),
                &self.tables[*key],
                *reason,
            ));
        }
        laws::check(&self.law, &self.tables)?;
        self.safe_mode.validate().map_err(from_control)
    }

    /// Writes every parameter of the selected law into its table (defaults included), so that
    /// each value has a key (a campaign disperses them).
    pub fn write_out(&mut self) -> Result<(), ChoiceError> {
        let entry = laws::check(&self.law, &self.tables)?;
        let table = entry.full_table(self.tables.get(&self.law))?;
        self.tables.insert(self.law.clone(), table);
        Ok(())
    }

    /// The parameters of the law whose parameter type is `P` (its table over the defaults),
    /// whether or not it is the selected law: e.g.
    /// `config.law_params::<PdFrictionConfig>()?.friction_compensation`.
    pub fn law_params<P: LawParams>(&self) -> Result<P, ControlError> {
        laws::params(&self.tables).map_err(to_control)
    }

    /// Writes the parameters of the law whose parameter type is `P`.
    pub fn set_law_params<P: LawParams>(&mut self, params: &P) -> Result<(), ControlError> {
        laws::set_params(&mut self.tables, params)
            .map(|_| ())
            .map_err(to_control)
    }

    /// Changes the parameters of the law whose parameter type is `P` in place.
    pub fn edit_law_params<P: LawParams>(
        &mut self,
        edit: impl FnOnce(&mut P),
    ) -> Result<(), ControlError> {
        let mut params = self.law_params::<P>()?;
        edit(&mut params);
        self.set_law_params(&params)
    }

    /// The control law of this configuration inside the controller's limits, once the whole
    /// configuration is checked (as the controller task checks it when it starts), holding
    /// `target` (level frame to body frame).
    pub fn law(&self, model: &ModelConfig, target: Attitude) -> Result<GuardedLaw, ControlError> {
        self.check().map_err(to_control)?;
        GuardedLaw::new(self, model, target)
    }

    /// The selected law alone, built from its table and `model`.
    pub(super) fn build_law(
        &self,
        model: &ModelConfig,
    ) -> Result<Box<dyn ControlLaw>, ControlError> {
        let entry = laws::find(&self.law).ok_or_else(|| {
            to_control(crate::choice::unknown_name(
                "controller.law",
                &self.law,
                &laws::names(),
                "control law",
            ))
        })?;
        entry.build(self.tables.get(&self.law), model)
    }
}

fn to_control(e: ChoiceError) -> ControlError {
    ControlError::InvalidConfig {
        key: e.key,
        value: e.value,
        reason: e.reason,
    }
}

fn from_control(e: ControlError) -> ChoiceError {
    match e {
        ControlError::InvalidConfig { key, value, reason } => ChoiceError::new(key, value, reason),
        other => ChoiceError::new("controller", "", other.to_string()),
    }
}

impl Serialize for ControllerConfig {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(None)?;
        map.serialize_entry(LAW, &self.law)?;
        map.serialize_entry(SAFE_MODE, &self.safe_mode)?;
        if let Some(thrusters) = &self.thrusters {
            map.serialize_entry(THRUSTERS, thrusters)?;
        }
        for (name, table) in &self.tables {
            map.serialize_entry(name, table)?;
        }
        map.end()
    }
}

impl<'de> Deserialize<'de> for ControllerConfig {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let mut tables = Tables::deserialize(deserializer)?;
        let law = match tables.remove(LAW) {
            None => DEFAULT_LAW.to_owned(),
            Some(toml::Value::String(name)) => name,
            Some(other) => {
                return Err(D::Error::custom(format!(
                    "`controller.law` = {other}: must be the name of a control law"
                )));
            }
        };
        let safe_mode = match tables.remove(SAFE_MODE) {
            None => SafeModeConfig::default(),
            Some(v) => v
                .try_into()
                .map_err(|e| D::Error::custom(format!("controller.safe_mode: {e}")))?,
        };
        let thrusters = match tables.remove(THRUSTERS) {
            None => None,
            Some(v) => Some(
                v.try_into()
                    .map_err(|e| D::Error::custom(format!("controller.thrusters: {e}")))?,
            ),
        };
        Ok(Self {
            law,
            tables,
            safe_mode,
            thrusters,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::laws::pd_friction::PdFrictionConfig;

    fn parse(text: &str) -> ControllerConfig {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn the_old_keys_are_refused_naming_the_new_ones() {
        let e = parse("actuators = \"cmg\"\n").check().unwrap_err();
        assert_eq!(e.key, "controller.actuators");
        assert!(e.reason.contains("controller.law"), "{e}");
        let e = parse("[wheels]\np_nm = [1.0, 1.0, 1.0]\n")
            .check()
            .unwrap_err();
        assert!(e.reason.contains("controller.pd_friction"), "{e}");
    }

    #[test]
    fn round_trips_with_its_tables_and_defaults_to_the_papers_law() {
        let c = parse("");
        assert_eq!(c, ControllerConfig::default());
        assert_eq!(c.law, "pd_friction");
        let mut c = ControllerConfig::with_law("cmg_slew");
        c.edit_law_params(|p: &mut PdFrictionConfig| p.friction_compensation = false)
            .unwrap();
        let text = toml::to_string(&c).unwrap();
        let back: ControllerConfig = toml::from_str(&text).unwrap();
        assert_eq!(back, c, "{text}");
        assert!(
            !back
                .law_params::<PdFrictionConfig>()
                .unwrap()
                .friction_compensation
        );
        back.check().unwrap();
    }
}
