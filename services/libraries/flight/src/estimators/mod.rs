//! Attitude filters behind one interface, chosen by name in the run configuration
//! (`[estimator] filter = "<name>"`, parameters in `[estimator.<name>]`, derived from the model
//! where absent).
//!
//! A filter turns sensor samples — gyro rates (rad/s, bias included), inclinometer angles (rad)
//! and the magnetometer's field (T, body axes), times in ns — into an attitude estimate (level
//! frame to body frame) with its gyro bias and the covariance of `[δθ, δb]`
//! ([`FilterEstimate`]). The estimator task ([`crate::tasks::EstimatorTask`]) around it keeps
//! what is not the filter's: assembling each tick's samples, the order within a tick (propagate,
//! then update), missing and invalid samples, start-up (a filter is initialised from the first
//! tick that has both a tilt and a field, [`FilterDefinition::initialise`]) and the published
//! sample. The output types are the MEKF's ([`crate::mekf`]), the first filter: a filter
//! without innovation gating reports its updates as applied.
//!
//! Adding a filter: one file here implementing [`AttitudeFilter`] and [`FilterDefinition`], one
//! line in [`FILTERS`], one table in the configuration (`docs/control-laws.md`).

pub mod complementary;
pub mod mekf;

use crate::choice::{self, ChoiceError, Tables};
use crate::mekf::{MekfCounters, MekfError, UpdateReport, VectorMeasurements};
use nalgebra::Vector3;
use serde::de::{DeserializeOwned, Error as _};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::any::Any;
use std::sync::Arc;
use testbed_model::ModelConfig;

pub use crate::mekf::MekfEstimate as FilterEstimate;

/// Every filter there is: its name in the configuration and its type.
pub const FILTERS: &[FilterEntry] = &[
    filter::<crate::mekf::Mekf>("mekf"),
    filter::<complementary::ComplementaryFilter>("complementary"),
];

/// The filter of a configuration without `estimator.filter`: the paper's MEKF.
pub const DEFAULT_FILTER: &str = "mekf";

/// An attitude filter, as the estimator task calls it.
pub trait AttitudeFilter: Send + std::fmt::Debug {
    /// Advances to `t_ns` with the gyro sample `w_meas_rad_s` (body, rad/s, bias included), the
    /// mean rate since the filter's time. An older sample is refused.
    fn propagate(&mut self, t_ns: u64, w_meas_rad_s: &Vector3<f64>) -> Result<(), MekfError>;
    /// Corrects with the vector samples valid at `t_ns` (either may be absent).
    fn update(
        &mut self,
        t_ns: u64,
        measurements: &VectorMeasurements,
    ) -> Result<UpdateReport, MekfError>;
    /// The current estimate.
    fn estimate(&self) -> FilterEstimate;
    /// Counters since start-up.
    fn counters(&self) -> MekfCounters;
}

/// A filter's parameter table: a serde struct with `deny_unknown_fields`, every field
/// documented with its unit and source.
pub trait FilterParams:
    Serialize + DeserializeOwned + Clone + std::fmt::Debug + Send + Sync + 'static
{
    /// Refuse values the filter cannot use, naming the field (relative to the table).
    fn validate(&self) -> Result<(), MekfError>;
}

/// How the registry builds a filter.
pub trait FilterDefinition: AttitudeFilter + Sized + 'static {
    type Params: FilterParams;
    /// The parameters of a configuration without a table: from the model (sensor noise, field).
    fn default_params(model: &ModelConfig) -> Self::Params;
    /// The filter at start-up, at `t_ns`, from a measured down vector `gravity_b` (body axes,
    /// unit) and field `field_b_t` (body axes, T).
    fn initialise(
        params: &Self::Params,
        t_ns: u64,
        gravity_b: &Vector3<f64>,
        field_b_t: &Vector3<f64>,
    ) -> Result<Self, MekfError>;
}

type Initialise =
    fn(&dyn Any, u64, &Vector3<f64>, &Vector3<f64>) -> Result<Box<dyn AttitudeFilter>, MekfError>;

/// Reads a filter's parameters (any filter's: the entry knows its type).
type ParseParams =
    fn(&str, Option<&toml::Value>, &ModelConfig) -> Result<Arc<dyn Any + Send + Sync>, ChoiceError>;

/// One line of [`FILTERS`]: a name, and how to read its parameters and start the filter.
pub struct FilterEntry {
    pub name: &'static str,
    params: ParseParams,
    full_table: fn(&str, Option<&toml::Value>, &ModelConfig) -> Result<toml::Value, ChoiceError>,
    initialise: Initialise,
}

/// The registry entry of filter `F` under `name`.
pub const fn filter<F: FilterDefinition>(name: &'static str) -> FilterEntry {
    FilterEntry {
        name,
        params: parse_any::<F>,
        full_table: full_table::<F>,
        initialise: initialise_any::<F>,
    }
}

fn parse_any<F: FilterDefinition>(
    name: &str,
    table: Option<&toml::Value>,
    model: &ModelConfig,
) -> Result<Arc<dyn Any + Send + Sync>, ChoiceError> {
    Ok(Arc::new(parse::<F>(name, table, model)?))
}

fn full_table<F: FilterDefinition>(
    name: &str,
    table: Option<&toml::Value>,
    model: &ModelConfig,
) -> Result<toml::Value, ChoiceError> {
    choice::table_of(&section(name), &parse::<F>(name, table, model)?)
}

fn initialise_any<F: FilterDefinition>(
    params: &dyn Any,
    t_ns: u64,
    gravity_b: &Vector3<f64>,
    field_b_t: &Vector3<f64>,
) -> Result<Box<dyn AttitudeFilter>, MekfError> {
    let params = params
        .downcast_ref::<F::Params>()
        .ok_or(MekfError::NonFinite {
            what: "filter parameters of another filter",
        })?;
    Ok(Box::new(F::initialise(params, t_ns, gravity_b, field_b_t)?))
}

/// The configuration section of filter `name`.
pub fn section(name: &str) -> String {
    format!("estimator.{name}")
}

/// `F`'s parameters from the table of filter `name` over the model's defaults, validated.
fn parse<F: FilterDefinition>(
    name: &str,
    table: Option<&toml::Value>,
    model: &ModelConfig,
) -> Result<F::Params, ChoiceError> {
    let section = section(name);
    let params = choice::params_from_table(&section, &F::default_params(model), table)?;
    params.validate().map_err(|e| match e {
        MekfError::InvalidConfig { key, value, reason } => {
            ChoiceError::new(format!("{section}.{key}"), value, reason)
        }
        other => ChoiceError::new(&section, "(table)", other.to_string()),
    })?;
    Ok(params)
}

/// The entry named `name`.
pub fn find(name: &str) -> Option<&'static FilterEntry> {
    FILTERS.iter().find(|e| e.name == name)
}

/// The names of every filter.
pub fn names() -> Vec<&'static str> {
    FILTERS.iter().map(|e| e.name).collect()
}

/// A filter chosen and its parameters read: what the estimator task starts the filter from.
#[derive(Clone)]
pub struct FilterSetup {
    entry: &'static FilterEntry,
    params: Arc<dyn Any + Send + Sync>,
}

impl std::fmt::Debug for FilterSetup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "FilterSetup({})", self.entry.name)
    }
}

impl FilterSetup {
    /// The filter's name.
    pub fn name(&self) -> &'static str {
        self.entry.name
    }

    /// The filter at start-up (see [`FilterDefinition::initialise`]).
    pub fn initialise(
        &self,
        t_ns: u64,
        gravity_b: &Vector3<f64>,
        field_b_t: &Vector3<f64>,
    ) -> Result<Box<dyn AttitudeFilter>, MekfError> {
        (self.entry.initialise)(self.params.as_ref(), t_ns, gravity_b, field_b_t)
    }
}

/// The estimator's configuration (`[estimator]`): the filter by name and its parameter tables,
/// kept as written (a table absent: the parameters derived from the model).
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatorConfig {
    /// The filter's name (`estimator.filter`), one of [`FILTERS`].
    pub filter: String,
    tables: Tables,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self::with_filter(DEFAULT_FILTER)
    }
}

const FILTER: &str = "filter";

impl EstimatorConfig {
    /// Filter `name` with its parameters derived from the model.
    pub fn with_filter(name: &str) -> Self {
        Self {
            filter: name.to_owned(),
            tables: Tables::new(),
        }
    }

    /// The filter chosen and its parameters read over `model`'s defaults; every table checked
    /// (a table for an unknown filter, or a parameter at `[estimator]` level, is refused).
    pub fn setup(&self, model: &ModelConfig) -> Result<FilterSetup, ChoiceError> {
        let entry = find(&self.filter).ok_or_else(|| {
            choice::unknown_name("estimator.filter", &self.filter, &names(), "filter")
        })?;
        for (name, table) in &self.tables {
            let Some(other) = find(name) else {
                let reason = if table.is_table() {
                    format!("no filter of that name; known: {}", names().join(", "))
                } else {
                    format!(
                        "a filter parameter goes in [estimator.<filter>] (the MEKF's in \
                         [estimator.mekf]); [estimator] holds only `filter` (known: {})",
                        names().join(", ")
                    )
                };
                return Err(ChoiceError::new(section(name), table, reason));
            };
            (other.params)(name, Some(table), model)?;
        }
        Ok(FilterSetup {
            entry,
            params: (entry.params)(entry.name, self.tables.get(entry.name), model)?,
        })
    }

    /// The parameters of filter `F` (named `name` in [`FILTERS`]): its table over the model's
    /// defaults, whether or not it is the selected filter.
    pub fn filter_params<F: FilterDefinition>(
        &self,
        name: &str,
        model: &ModelConfig,
    ) -> Result<F::Params, ChoiceError> {
        parse::<F>(name, self.tables.get(name), model)
    }

    /// Writes every parameter of the selected filter into its table (over `model`'s defaults),
    /// so that each value has a key and no longer follows the model (a campaign disperses the
    /// model's truth while the filter keeps the nominal parameters).
    pub fn write_out(&mut self, model: &ModelConfig) -> Result<(), ChoiceError> {
        let entry = find(&self.filter).ok_or_else(|| {
            choice::unknown_name("estimator.filter", &self.filter, &names(), "filter")
        })?;
        let table = (entry.full_table)(entry.name, self.tables.get(entry.name), model)?;
        self.tables.insert(entry.name.to_owned(), table);
        Ok(())
    }

    /// Writes the parameters of filter `name`.
    pub fn set_filter_params<P: FilterParams>(
        &mut self,
        name: &str,
        params: &P,
    ) -> Result<(), ChoiceError> {
        let table = choice::table_of(&section(name), params)?;
        self.tables.insert(name.to_owned(), table);
        Ok(())
    }
}

impl Serialize for EstimatorConfig {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(None)?;
        map.serialize_entry(FILTER, &self.filter)?;
        for (name, table) in &self.tables {
            map.serialize_entry(name, table)?;
        }
        map.end()
    }
}

impl<'de> Deserialize<'de> for EstimatorConfig {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let mut tables = Tables::deserialize(deserializer)?;
        let filter = match tables.remove(FILTER) {
            None => DEFAULT_FILTER.to_owned(),
            Some(toml::Value::String(name)) => name,
            Some(other) => {
                return Err(D::Error::custom(format!(
                    "`estimator.filter` = {other}: must be the name of a filter"
                )));
            }
        };
        Ok(Self { filter, tables })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mekf::MekfConfig;

    fn parse_config(text: &str) -> EstimatorConfig {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn absent_the_mekf_with_its_parameters_from_the_model() {
        let model = ModelConfig::default();
        let c = parse_config("");
        assert_eq!(c, EstimatorConfig::default());
        assert_eq!(c.setup(&model).unwrap().name(), "mekf");
        assert_eq!(
            c.filter_params::<crate::mekf::Mekf>("mekf", &model)
                .unwrap(),
            MekfConfig::from_model(&model)
        );
    }

    #[test]
    fn unknown_names_old_keys_and_unknown_fields_are_refused_naming_them() {
        let model = ModelConfig::default();
        let e = parse_config("filter = \"ukf\"").setup(&model).unwrap_err();
        assert_eq!(e.key, "estimator.filter");
        assert!(
            e.reason.contains("mekf") && e.reason.contains("complementary"),
            "{e}"
        );
        let e = parse_config("gate_enabled = false")
            .setup(&model)
            .unwrap_err();
        assert_eq!(e.key, "estimator.gate_enabled");
        assert!(e.reason.contains("[estimator.mekf]"), "{e}");
        let e = parse_config("[mekf]\ngate_enbled = false")
            .setup(&model)
            .unwrap_err();
        assert_eq!(e.key, "estimator.mekf");
        assert!(e.reason.contains("gate_enbled"), "{e}");
        let e = parse_config("[ekf]\ngate_enabled = false")
            .setup(&model)
            .unwrap_err();
        assert_eq!(e.key, "estimator.ekf");
    }

    #[test]
    fn a_partial_table_overrides_only_its_keys_and_round_trips() {
        let model = ModelConfig::default();
        let c = parse_config("[mekf]\ngate_enabled = false\n");
        let p = c
            .filter_params::<crate::mekf::Mekf>("mekf", &model)
            .unwrap();
        assert!(!p.gate_enabled);
        assert_eq!(
            MekfConfig {
                gate_enabled: false,
                ..MekfConfig::from_model(&model)
            },
            p
        );
        let back: EstimatorConfig = toml::from_str(&toml::to_string(&c).unwrap()).unwrap();
        assert_eq!(back, c);
    }
}
