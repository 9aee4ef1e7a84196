//! What a control law and an attitude filter share as configuration: a component chosen by
//! name (`[controller] law = "…"`, `[estimator] filter = "…"`) with one parameter table per
//! name (`[controller.<name>]`, `[estimator.<name>]`), kept as written until the component is
//! built, so that a run configuration round-trips unchanged and a table for a component that
//! is not selected is still checked.

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

/// Parameter tables by component name, as written in the configuration.
pub type Tables = BTreeMap<String, toml::Value>;

/// Why a named choice or one of its tables is refused: the key (full path), its value and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{key}` = {value}: {reason}")]
pub struct ChoiceError {
    pub key: String,
    pub value: String,
    pub reason: String,
}

impl ChoiceError {
    pub fn new(
        key: impl Into<String>,
        value: impl std::fmt::Display,
        reason: impl Into<String>,
    ) -> Self {
        Self {
            key: key.into(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }
}

/// The parameters from `table` over `defaults`: a key given replaces the default's (nested
/// tables key by key), and a key the parameter type does not have is refused (the types are
/// `deny_unknown_fields`). Without a table, the defaults. `section` (e.g. `controller.pd_friction`)
/// names the table in the error.
pub fn params_from_table<P: Serialize + DeserializeOwned + Clone>(
    section: &str,
    defaults: &P,
    table: Option<&toml::Value>,
) -> Result<P, ChoiceError> {
    let Some(table) = table else {
        return Ok(defaults.clone());
    };
    if !table.is_table() {
        return Err(ChoiceError::new(section, table, "must be a table"));
    }
    let mut merged = toml::Value::try_from(defaults)
        .map_err(|e| ChoiceError::new(section, "(defaults)", e.to_string()))?;
    overlay(&mut merged, table);
    merged
        .try_into()
        .map_err(|e: toml::de::Error| ChoiceError::new(section, table, e.message().to_string()))
}

/// `patch`'s keys written into `base`, tables merged recursively.
fn overlay(base: &mut toml::Value, patch: &toml::Value) {
    match (base, patch) {
        (toml::Value::Table(base), toml::Value::Table(patch)) => {
            for (key, value) in patch {
                match base.get_mut(key) {
                    Some(slot) if slot.is_table() && value.is_table() => overlay(slot, value),
                    _ => {
                        base.insert(key.clone(), value.clone());
                    }
                }
            }
        }
        (base, patch) => *base = patch.clone(),
    }
}

/// The table of `params`, to store in [`Tables`].
pub fn table_of<P: Serialize>(section: &str, params: &P) -> Result<toml::Value, ChoiceError> {
    toml::Value::try_from(params)
        .map_err(|e| ChoiceError::new(section, "(parameters)", e.to_string()))
}

/// The error for a name no entry has: the key, the name, and the names there are.
pub fn unknown_name(key: &str, name: &str, known: &[&str], what: &str) -> ChoiceError {
    ChoiceError::new(
        key,
        format!("{name:?}"),
        format!("no {what} of that name; known: {}", known.join(", ")),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    struct Inner {
        a: f64,
        b: f64,
    }

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Params {
        gain: f64,
        on: bool,
        inner: Inner,
    }

    fn defaults() -> Params {
        Params {
            gain: 0.1,
            on: true,
            inner: Inner { a: 1.0, b: 2.0 },
        }
    }

    impl Default for Inner {
        fn default() -> Self {
            defaults().inner
        }
    }

    #[test]
    fn a_table_overrides_only_the_keys_it_names_even_nested() {
        let table: toml::Value = toml::from_str("gain = 0.3\n[inner]\nb = 5.0\n").unwrap();
        let p = params_from_table("x", &defaults(), Some(&table)).unwrap();
        assert_eq!(p.gain, 0.3);
        assert!(p.on);
        assert_eq!(p.inner, Inner { a: 1.0, b: 5.0 });
        assert_eq!(
            params_from_table("x", &defaults(), None).unwrap(),
            defaults()
        );
    }

    #[test]
    fn an_unknown_key_is_refused_naming_it_and_the_section() {
        let table: toml::Value = toml::from_str("gian = 0.3\n").unwrap();
        let e = params_from_table("controller.x", &defaults(), Some(&table)).unwrap_err();
        assert_eq!(e.key, "controller.x");
        assert!(e.reason.contains("gian"), "{e}");
    }

    #[test]
    fn floats_round_trip_bit_for_bit() {
        let p = Params {
            gain: 0.1 + 0.2,
            ..defaults()
        };
        let table = table_of("x", &p).unwrap();
        let back = params_from_table("x", &defaults(), Some(&table)).unwrap();
        assert_eq!(back.gain.to_bits(), p.gain.to_bits());
    }
}
