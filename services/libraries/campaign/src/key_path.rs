//! Run-configuration keys named by their path, `model.platform.inertia_kgm2[0][0]`: table keys
//! joined by dots, array elements by `[index]`. Paths are read and written on the run
//! configuration serialised as a [`toml::Value`], so they follow whatever layout the run
//! configuration has (a new table, a renamed key) without a list of known keys here.

use std::fmt;
use toml::Value;

/// One step of a path: a table key or an array index.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub enum Step {
    Key(String),
    Index(usize),
}

/// A parsed key path.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct KeyPath {
    steps: Vec<Step>,
}

/// Why a path could not be parsed, read or written; the message names the path.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PathError {
    #[error(
        "`{path}` is not a key path ({reason}); write keys joined by dots and array elements as [index], e.g. model.gyro.bias_deg_s[0]"
    )]
    Syntax { path: String, reason: &'static str },
    #[error("`{path}` is not in the run configuration: {reason}")]
    Missing { path: String, reason: String },
}

impl KeyPath {
    pub fn parse(text: &str) -> Result<Self, PathError> {
        let syntax = |reason| PathError::Syntax {
            path: text.to_string(),
            reason,
        };
        let mut steps = Vec::new();
        for part in text.split('.') {
            let (name, mut rest) = part.split_at(part.find('[').unwrap_or(part.len()));
            if name.is_empty() {
                return Err(syntax("an empty key"));
            }
            if !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                return Err(syntax("a key of letters, digits, '_' and '-' only"));
            }
            steps.push(Step::Key(name.to_string()));
            while !rest.is_empty() {
                let close = rest.find(']').ok_or_else(|| syntax("a '[' without ']'"))?;
                let index = rest
                    .get(1..close)
                    .filter(|_| rest.starts_with('['))
                    .and_then(|digits| digits.parse::<usize>().ok())
                    .ok_or_else(|| syntax("an index that is not a whole number"))?;
                steps.push(Step::Index(index));
                rest = &rest[close + 1..];
            }
        }
        Ok(Self { steps })
    }

    pub fn steps(&self) -> &[Step] {
        &self.steps
    }

    /// Whether one path is the other or leads into it (`controller.pd_friction` and
    /// `controller.pd_friction.kd`): setting one changes what the other names.
    pub fn overlaps(&self, other: &KeyPath) -> bool {
        let n = self.steps.len().min(other.steps.len());
        self.steps[..n] == other.steps[..n]
    }

    /// The value at this path.
    pub fn get<'v>(&self, root: &'v Value) -> Result<&'v Value, PathError> {
        let mut here = root;
        for (depth, step) in self.steps.iter().enumerate() {
            here = self.child(here, depth, step)?;
        }
        Ok(here)
    }

    /// Replaces the value at this path, which must exist.
    pub fn set(&self, root: &mut Value, value: Value) -> Result<(), PathError> {
        *self.get_mut(root, false)? = value;
        Ok(())
    }

    /// Sets the value at this path, creating the tables on the way that do not exist yet (an
    /// optional table such as `model.effects.com_offset`); arrays are not created.
    pub fn set_creating_tables(&self, root: &mut Value, value: Value) -> Result<(), PathError> {
        *self.get_mut(root, true)? = value;
        Ok(())
    }

    /// The value at this path, for writing; with `create`, missing tables are made on the way.
    fn get_mut<'v>(&self, root: &'v mut Value, create: bool) -> Result<&'v mut Value, PathError> {
        let mut here = root;
        for (depth, step) in self.steps.iter().enumerate() {
            if let (true, Value::Table(t), Step::Key(k)) = (create, &mut *here, step)
                && !t.contains_key(k)
            {
                t.insert(k.clone(), Value::Table(toml::Table::new()));
            }
            // Checked on the shared borrow first, so the error can show the parent's keys.
            self.child(here, depth, step)?;
            here = match (here, step) {
                (Value::Table(t), Step::Key(k)) => t.get_mut(k),
                (Value::Array(a), Step::Index(i)) => a.get_mut(*i),
                _ => None,
            }
            .expect("checked by child()");
        }
        Ok(here)
    }

    /// The step below `here` (at `depth` of this path), or why there is none.
    fn child<'v>(
        &self,
        here: &'v Value,
        depth: usize,
        step: &Step,
    ) -> Result<&'v Value, PathError> {
        let parent = self.prefix(depth);
        let missing = |reason: String| PathError::Missing {
            path: self.to_string(),
            reason,
        };
        match (here, step) {
            (Value::Table(t), Step::Key(k)) => t.get(k).ok_or_else(|| {
                let keys: Vec<&str> = t.keys().map(String::as_str).collect();
                let within = if parent.is_empty() {
                    "the run configuration".to_string()
                } else {
                    format!("`{parent}`")
                };
                let present = if keys.is_empty() {
                    "it is empty".to_string()
                } else {
                    format!("its keys: {}", keys.join(", "))
                };
                missing(format!(
                    "{within} has no key `{k}` ({present}; an optional table that is absent, such as one of model.effects, must be set in the campaign's [base] or its config file first)"
                ))
            }),
            (Value::Array(a), Step::Index(i)) => a.get(*i).ok_or_else(|| {
                missing(format!(
                    "`{parent}` has {} elements, indices 0 to {}",
                    a.len(),
                    a.len().saturating_sub(1)
                ))
            }),
            (Value::Array(a), Step::Key(k)) => Err(missing(format!(
                "`{parent}` is an array of {} elements: write `{parent}[i]`, not `.{k}`",
                a.len()
            ))),
            (_, Step::Index(_)) => Err(missing(format!("`{parent}` is not an array"))),
            (_, Step::Key(k)) => Err(missing(format!(
                "`{parent}` is a value, not a table with a key `{k}`"
            ))),
        }
    }

    /// The first `depth` steps, as text.
    fn prefix(&self, depth: usize) -> String {
        KeyPath {
            steps: self.steps[..depth].to_vec(),
        }
        .to_string()
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, step) in self.steps.iter().enumerate() {
            match step {
                Step::Key(k) if i == 0 => write!(f, "{k}")?,
                Step::Key(k) => write!(f, ".{k}")?,
                Step::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// Lays `fragment` (a run-configuration table, e.g. a campaign's `[base]` or a variant) over
/// `target`: tables are merged key by key, any other value replaces what was there. A key
/// written as a quoted path (`"model.gyro.bias_deg_s[0]" = 0.0`) sets that one element. The
/// result is checked when it is read as a run configuration, which refuses unknown keys.
pub fn overlay(target: &mut Value, fragment: &toml::Table) -> Result<(), PathError> {
    for (key, value) in fragment {
        if key.contains('.') || key.contains('[') {
            KeyPath::parse(key)?.set_creating_tables(target, value.clone())?;
            continue;
        }
        let Value::Table(table) = target else {
            return Err(PathError::Missing {
                path: key.clone(),
                reason: "its parent is not a table".into(),
            });
        };
        match (table.get_mut(key), value) {
            (Some(existing @ Value::Table(_)), Value::Table(inner)) => overlay(existing, inner)?,
            _ => {
                table.insert(key.clone(), value.clone());
            }
        }
    }
    Ok(())
}

/// The paths of every value `fragment` sets (arrays as one value), for telling which keys a
/// variant changes.
pub fn leaf_paths(fragment: &toml::Table) -> Result<Vec<KeyPath>, PathError> {
    fn walk(prefix: &[Step], table: &toml::Table, out: &mut Vec<KeyPath>) -> Result<(), PathError> {
        for (key, value) in table {
            let mut steps = prefix.to_vec();
            if key.contains('.') || key.contains('[') {
                steps.extend(KeyPath::parse(key)?.steps);
            } else {
                steps.push(Step::Key(key.clone()));
            }
            match value {
                Value::Table(inner) => walk(&steps, inner, out)?,
                _ => out.push(KeyPath { steps }),
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(&[], fragment, &mut out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> Value {
        toml::from_str(
            "[model.platform]\ninertia_kgm2 = [[1.0, 0.0], [0.0, 2.0]]\nmass_kg = 350.0\n[run]\nseed = 1\n",
        )
        .unwrap()
    }

    #[test]
    fn parses_and_prints_keys_and_indices() {
        for text in [
            "a",
            "model.gyro.bias_deg_s[0]",
            "m.inertia_kgm2[0][2]",
            "can.serial.gyro-2",
        ] {
            assert_eq!(KeyPath::parse(text).unwrap().to_string(), text);
        }
        for bad in ["", "a..b", "a.", "a[x]", "a[1", "a[1]b", "a b", "a[-1]"] {
            assert!(
                matches!(KeyPath::parse(bad), Err(PathError::Syntax { .. })),
                "{bad}"
            );
        }
    }

    #[test]
    fn reads_and_writes_the_value_at_a_path() {
        let mut value = config();
        let path = KeyPath::parse("model.platform.inertia_kgm2[1][1]").unwrap();
        assert_eq!(path.get(&value).unwrap().as_float(), Some(2.0));
        path.set(&mut value, Value::Float(2.5)).unwrap();
        assert_eq!(path.get(&value).unwrap().as_float(), Some(2.5));
    }

    #[test]
    fn a_missing_key_is_named_with_its_neighbours() {
        let value = config();
        let err = KeyPath::parse("model.platform.mass")
            .unwrap()
            .get(&value)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("`model.platform.mass`")
                && err.contains("`model.platform` has no key `mass`")
                && err.contains("mass_kg"),
            "{err}"
        );
        let err = KeyPath::parse("model.platform.inertia_kgm2[2]")
            .unwrap()
            .get(&value)
            .unwrap_err()
            .to_string();
        assert!(err.contains("has 2 elements"), "{err}");
        let err = KeyPath::parse("model.platform.mass_kg[0]")
            .unwrap()
            .get(&value)
            .unwrap_err()
            .to_string();
        assert!(err.contains("not an array"), "{err}");
        let mut value = value;
        assert!(
            KeyPath::parse("run.speed")
                .unwrap()
                .set(&mut value, Value::Float(1.0))
                .is_err()
        );
    }

    #[test]
    fn overlay_merges_tables_sets_paths_and_lists_its_leaves() {
        let mut value = config();
        let fragment: toml::Table = toml::from_str(
            "model.platform.mass_kg = 300.0\n\"model.platform.inertia_kgm2[0][0]\" = 1.5\n[model.effects.com_offset]\nr_m = [0.0, 0.0, -1e-5]\n",
        )
        .unwrap();
        overlay(&mut value, &fragment).unwrap();
        let at = |p: &str| KeyPath::parse(p).unwrap().get(&value).unwrap().clone();
        assert_eq!(at("model.platform.mass_kg").as_float(), Some(300.0));
        assert_eq!(
            at("model.platform.inertia_kgm2[0][0]").as_float(),
            Some(1.5)
        );
        assert_eq!(
            at("model.platform.inertia_kgm2[1][1]").as_float(),
            Some(2.0)
        );
        assert_eq!(
            at("model.effects.com_offset.r_m[2]").as_float(),
            Some(-1e-5)
        );
        assert_eq!(at("run.seed").as_integer(), Some(1));
        let mut leaves: Vec<String> = leaf_paths(&fragment)
            .unwrap()
            .iter()
            .map(ToString::to_string)
            .collect();
        leaves.sort();
        assert_eq!(
            leaves,
            [
                "model.effects.com_offset.r_m",
                "model.platform.inertia_kgm2[0][0]",
                "model.platform.mass_kg"
            ]
        );
        let a = KeyPath::parse("model.platform").unwrap();
        assert!(a.overlaps(&KeyPath::parse("model.platform.mass_kg").unwrap()));
        assert!(!a.overlaps(&KeyPath::parse("model.gyro").unwrap()));
    }
}
