//! A campaign checked against its base run configuration, and the configuration of each run.
//!
//! The base run configuration (the campaign's `config` file or the defaults, with `[base]` laid
//! over it) is serialised to a [`toml::Value`]; run `k` of a variant is that value with the
//! variant's keys laid over it, each dispersed key set to run `k`'s draw, `run.seed` set to run
//! `k`'s device-noise seed, read back as a [`RunConfig`] and validated as `testbed run` would.
//! Everything a campaign can get wrong is refused by [`Plan::new`] and [`Plan::prepare`] before
//! any run starts.
//!
//! The estimator is designed on the nominal model: when the base configuration derives it from
//! the model, the plan writes it out from the base model, so a dispersed model (a gyro bias, a
//! noise level) changes the truth and not what the filter assumes.

use crate::distribution::{Apply, stream};
use crate::error::CampaignError;
use crate::file::{BASE_VARIANT, CampaignFile};
use crate::key_path::{self, KeyPath};
use rand::Rng;
use testbed_config::RunConfig;
use toml::Value;

/// The key of the device-noise seed, which the campaign sets for each run.
pub const SEED_KEY: &str = "run.seed";

/// A campaign ready to generate its runs.
#[derive(Debug, Clone)]
pub struct Plan {
    pub file: CampaignFile,
    /// The base run configuration, estimator written out.
    base: Value,
    /// The base value of each dispersed key, in [`CampaignFile::dispersions`] order.
    nominals: Vec<f64>,
    /// Whether each dispersed key holds a whole number (an integer in the configuration).
    integer: Vec<bool>,
}

/// What makes run `index` of a variant: its device seed and its dispersed values.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSpec {
    pub index: u64,
    pub variant: String,
    /// `run.seed` of the run.
    pub seed: u64,
    /// The dispersed keys' values, in [`CampaignFile::dispersions`] order.
    pub values: Vec<f64>,
}

/// One run to carry out: what it is, and its checked configuration.
#[derive(Debug, Clone)]
pub struct Job {
    pub spec: RunSpec,
    pub config: RunConfig,
}

impl Plan {
    /// Checks `file` against `base` (its `config` file, or the defaults): the base with
    /// `[base]`, every dispersion's key, kind and landmark values (the ends of a uniform
    /// interval, a normal's mean, each listed value), every variant.
    pub fn new(file: CampaignFile, base: RunConfig) -> Result<Self, CampaignError> {
        let shown = file.path.display().to_string();
        let base_error = |reason: String| CampaignError::Base {
            path: shown.clone(),
            reason,
        };
        let mut value = to_value(&base).map_err(base_error)?;
        key_path::overlay(&mut value, &file.base).map_err(|e| base_error(e.to_string()))?;
        let mut base = read_config(value, &format!("{shown} [base]")).map_err(base_error)?;
        // Every parameter of the law and the filter gets a key, and the filter keeps the
        // nominal model's parameters when the runs disperse the model's truth.
        base.controller
            .write_out()
            .map_err(|e| base_error(e.to_string()))?;
        let model = base.model.clone();
        base.estimator
            .write_out(&model)
            .map_err(|e| base_error(e.to_string()))?;
        let base = to_value(&base).map_err(base_error)?;

        let seed_key = KeyPath::parse(SEED_KEY).expect("a key path");
        let mut nominals = Vec::new();
        let mut integer = Vec::new();
        for d in &file.dispersions {
            let refused = |reason: String| CampaignError::Dispersion {
                path: shown.clone(),
                key: d.key.to_string(),
                reason,
            };
            if d.key.overlaps(&seed_key) {
                return Err(refused(format!(
                    "{SEED_KEY} is the campaign's to set: each run's device seed comes from campaign.seed and the run index"
                )));
            }
            let (nominal, whole) = match d.key.get(&base).map_err(|e| refused(e.to_string()))? {
                Value::Float(x) => (*x, false),
                Value::Integer(n) => (*n as f64, true),
                other => {
                    return Err(refused(format!(
                        "holds {} `{other}`, not a number: only numbers are dispersed (use variants for other values)",
                        other.type_str()
                    )));
                }
            };
            if whole && !(d.apply == Apply::Set && d.distribution.draws_whole_numbers()) {
                return Err(refused(format!(
                    "holds the whole number {nominal}: disperse it with values = [..] of whole numbers"
                )));
            }
            for landmark in d.distribution.landmarks() {
                let x = d.apply.apply(nominal, landmark);
                let mut trial = base.clone();
                d.key
                    .set(&mut trial, number(x, whole))
                    .map_err(|e| refused(e.to_string()))?;
                read_config(trial, &shown)
                    .map_err(|reason| refused(format!("the value {x}: {reason}")))?;
            }
            nominals.push(nominal);
            integer.push(whole);
        }

        for (name, fragment) in &file.variants {
            let refused = |reason: String| CampaignError::Variant {
                path: shown.clone(),
                variant: name.clone(),
                reason,
            };
            let leaves = key_path::leaf_paths(fragment).map_err(|e| refused(e.to_string()))?;
            for leaf in &leaves {
                if let Some(d) = file.dispersions.iter().find(|d| d.key.overlaps(leaf)) {
                    return Err(refused(format!(
                        "sets `{leaf}`, which the dispersion `{}` draws: a variant changes keys the runs share, not dispersed ones",
                        d.key
                    )));
                }
                if leaf.overlaps(&seed_key) {
                    return Err(refused(format!(
                        "sets `{leaf}`: the device seed is the campaign's, the same for every variant"
                    )));
                }
            }
            let mut value = base.clone();
            key_path::overlay(&mut value, fragment).map_err(|e| refused(e.to_string()))?;
            read_config(value, &format!("{shown} [variants.{name}]")).map_err(refused)?;
        }
        Ok(Self {
            file,
            base,
            nominals,
            integer,
        })
    }

    /// Run `index`'s device seed and dispersed values (the same for every variant).
    pub fn draws(&self, index: u64) -> (u64, Vec<f64>) {
        // TOML integers are signed: a seed below 2^63 is written and read back unchanged.
        let seed = stream(self.file.seed, index, SEED_KEY).random::<u64>() >> 1;
        let values = self
            .file
            .dispersions
            .iter()
            .zip(&self.nominals)
            .map(|(d, nominal)| {
                let mut rng = stream(self.file.seed, index, &d.key.to_string());
                d.apply.apply(*nominal, d.distribution.draw(&mut rng))
            })
            .collect();
        (seed, values)
    }

    /// Run `index` of `variant` ([`BASE_VARIANT`] without variants) and its configuration.
    pub fn job(&self, index: u64, variant: &str) -> Result<Job, CampaignError> {
        let shown = self.file.path.display().to_string();
        let (seed, values) = self.draws(index);
        let spec = RunSpec {
            index,
            variant: variant.to_string(),
            seed,
            values,
        };
        let refused = |reason: String| CampaignError::Run {
            path: shown.clone(),
            index,
            variant: if self.file.variants.is_empty() {
                String::new()
            } else {
                format!(" (variant {variant})")
            },
            assignments: self.assignments(&spec),
            reason,
        };
        if index >= self.file.runs {
            return Err(refused(format!(
                "the campaign has runs 0 to {}",
                self.file.runs - 1
            )));
        }
        let mut value = self.base.clone();
        match self.file.variants.get(variant) {
            Some(fragment) => {
                key_path::overlay(&mut value, fragment).map_err(|e| refused(e.to_string()))?
            }
            None if variant == BASE_VARIANT && self.file.variants.is_empty() => {}
            None => {
                return Err(refused(format!(
                    "no variant `{variant}` (the variants: {})",
                    self.file.variant_names().join(", ")
                )));
            }
        }
        for ((d, x), whole) in self
            .file
            .dispersions
            .iter()
            .zip(&spec.values)
            .zip(&self.integer)
        {
            d.key
                .set(&mut value, number(*x, *whole))
                .map_err(|e| refused(e.to_string()))?;
        }
        let origin = format!("{shown} run {index}");
        let mut config = read_config(value, &origin).map_err(&refused)?;
        config.run.seed = seed;
        Ok(Job { spec, config })
    }

    /// Every run of `indices` in every variant, run-major (run 0 of each variant, then run 1,
    /// …), all checked: the first refused one is the error.
    pub fn prepare(&self, indices: &[u64]) -> Result<Vec<Job>, CampaignError> {
        use rayon::prelude::*;
        let variants = self.file.variant_names();
        let pairs: Vec<(u64, &String)> = indices
            .iter()
            .flat_map(|&k| variants.iter().map(move |v| (k, v)))
            .collect();
        pairs.par_iter().map(|(k, v)| self.job(*k, v)).collect()
    }

    /// The campaign's fingerprint: FNV-1a of its text and its base run configuration, in hex.
    /// Results with the same fingerprint come from the same runs.
    pub fn fingerprint(&self) -> String {
        let base = toml::to_string(&self.base).unwrap_or_default();
        format!(
            "{:016x}",
            crate::distribution::stable_hash(&format!("{}\n{base}", self.file.text))
        )
    }

    /// `key = value, …` of a run's draws and seed, for messages.
    pub fn assignments(&self, spec: &RunSpec) -> String {
        let mut parts: Vec<String> = self
            .file
            .dispersions
            .iter()
            .zip(&spec.values)
            .map(|(d, x)| format!("{} = {x}", d.key))
            .collect();
        parts.push(format!("{SEED_KEY} = {}", spec.seed));
        parts.join(", ")
    }
}

/// Which runs shard `shard` of `count` carries out: every index `k` with `k % count == shard`,
/// so each shard has a like share of any part of the campaign.
pub fn shard_indices(runs: u64, shard: u64, count: u64) -> Vec<u64> {
    (0..runs).filter(|k| k % count.max(1) == shard).collect()
}

/// A shard written `i/N`: `(i, N)` with `i < N`.
pub fn parse_shard(text: &str) -> Result<(u64, u64), String> {
    let (i, n) = text
        .split_once('/')
        .ok_or_else(|| format!("`{text}` is not a shard: write i/N, e.g. 0/4"))?;
    let parse = |s: &str| {
        s.trim()
            .parse::<u64>()
            .map_err(|_| format!("`{text}` is not a shard: i and N are whole numbers"))
    };
    let (i, n) = (parse(i)?, parse(n)?);
    if n == 0 || i >= n {
        return Err(format!(
            "`{text}` is not a shard: N >= 1 and i from 0 to N-1"
        ));
    }
    Ok((i, n))
}

fn number(x: f64, whole: bool) -> Value {
    if whole {
        Value::Integer(x as i64)
    } else {
        Value::Float(x)
    }
}

fn to_value(config: &RunConfig) -> Result<Value, String> {
    Value::try_from(config).map_err(|e| format!("cannot serialise the run configuration: {e}"))
}

/// The run configuration `value` holds, validated (`origin` names it in messages).
fn read_config(value: Value, origin: &str) -> Result<RunConfig, String> {
    let config: RunConfig = value
        .try_into()
        .map_err(|e: toml::de::Error| format!("run configuration {origin}: {}", e.message()))?;
    config.validate(origin).map_err(|e| e.to_string())?;
    Ok(config)
}

#[cfg(test)]
mod tests;
