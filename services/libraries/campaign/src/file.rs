//! The campaign file (TOML): how many runs, the campaign seed, the base run configuration, the
//! dispersions by key path, the variants compared on the same dispersed runs, and the options
//! of the metrics. `docs/campaigns.md` describes it for users.
//!
//! ```toml
//! [campaign]
//! runs = 200
//! seed = 2026
//! config = "run.toml"        # optional: a run configuration, relative to this file
//!
//! [base]                     # optional: keys laid over the run configuration
//! run.duration_s = 150.0
//!
//! [dispersions]
//! "manoeuvre.initial_pitch_deg" = { uniform = { low = -5.0, high = 5.0 } }
//! "model.gyro.bias_deg_s[0]" = { normal = { mean = 0.0, std = 5e-4 }, apply = "add" }
//!
//! [variants.with]            # optional: two or more parameter sets, same runs
//! controller.pd_friction.friction_compensation = true
//! [variants.without]
//! controller.pd_friction.friction_compensation = false
//! ```

use crate::distribution::{Apply, Distribution};
use crate::error::CampaignError;
use crate::key_path::KeyPath;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The options of the metrics (`[metrics]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MetricOptions {
    /// A run has settled once every axis of its true pointing error stays within this band
    /// to the end, degrees (the paper's stabilisation: 0.1°).
    pub settle_band_deg: f64,
    /// The steady error is the largest error per axis over this final window, s.
    pub steady_window_s: f64,
    /// The estimator's metrics (3σ, NEES) count from this time on, s: after the filter has
    /// converged from its initial uncertainty.
    pub estimation_from_s: f64,
    /// Period of the series kept of each run (pointing error and NEES) for the envelope and
    /// the ensemble consistency, s.
    pub series_step_s: f64,
}

impl Default for MetricOptions {
    fn default() -> Self {
        Self {
            settle_band_deg: 0.1,
            steady_window_s: 50.0,
            estimation_from_s: 30.0,
            series_step_s: 1.0,
        }
    }
}

impl MetricOptions {
    fn check(&self) -> Result<(), String> {
        for (key, value) in [
            ("settle_band_deg", self.settle_band_deg),
            ("steady_window_s", self.steady_window_s),
            ("series_step_s", self.series_step_s),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!("metrics.{key} = {value}: must be > 0"));
            }
        }
        if !(self.estimation_from_s.is_finite() && self.estimation_from_s >= 0.0) {
            return Err(format!(
                "metrics.estimation_from_s = {}: must be >= 0",
                self.estimation_from_s
            ));
        }
        Ok(())
    }
}

/// One declared dispersion.
#[derive(Debug, Clone, PartialEq)]
pub struct Dispersion {
    pub key: KeyPath,
    pub distribution: Distribution,
    pub apply: Apply,
}

/// A parsed campaign file (not yet checked against a run configuration: see
/// [`crate::plan::Plan`]).
#[derive(Debug, Clone)]
pub struct CampaignFile {
    /// The file as named by the user (in messages and in the commands that reproduce a run).
    pub path: PathBuf,
    /// Its text, as read (kept with the results, for merging shards).
    pub text: String,
    pub runs: u64,
    pub seed: u64,
    /// The base run configuration file, relative to the working directory (resolved from the
    /// campaign file's directory).
    pub config: Option<PathBuf>,
    pub base: toml::Table,
    /// Sorted by key.
    pub dispersions: Vec<Dispersion>,
    /// Sorted by name; empty: one run configuration per run.
    pub variants: BTreeMap<String, toml::Table>,
    /// The variant the others are compared with.
    pub baseline: Option<String>,
    pub metrics: MetricOptions,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileToml {
    campaign: CampaignToml,
    #[serde(default)]
    metrics: MetricOptions,
    #[serde(default)]
    base: toml::Table,
    #[serde(default)]
    dispersions: toml::Table,
    #[serde(default)]
    variants: BTreeMap<String, toml::Table>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CampaignToml {
    runs: u64,
    seed: u64,
    config: Option<PathBuf>,
    baseline: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecToml {
    uniform: Option<UniformToml>,
    normal: Option<NormalToml>,
    values: Option<Vec<f64>>,
    #[serde(default)]
    apply: Apply,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct UniformToml {
    low: f64,
    high: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NormalToml {
    mean: f64,
    std: f64,
}

/// The keys of a dispersion's table; a table without them holds further keys
/// (`[dispersions.manoeuvre] initial_pitch_deg = { … }`).
const SPEC_KEYS: [&str; 4] = ["uniform", "normal", "values", "apply"];

/// The name of the run configuration a campaign without variants runs.
pub const BASE_VARIANT: &str = "base";

impl CampaignFile {
    pub fn load(path: &Path) -> Result<Self, CampaignError> {
        let text = std::fs::read_to_string(path).map_err(|source| CampaignError::Read {
            path: path.display().to_string(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses `text`, the campaign file at `path` (which locates a relative `config`).
    pub fn parse(text: &str, path: &Path) -> Result<Self, CampaignError> {
        let shown = path.display().to_string();
        let parse = |message: String| CampaignError::Parse {
            path: shown.clone(),
            message,
        };
        let file: FileToml = toml::from_str(text).map_err(|e| parse(e.to_string()))?;
        if file.campaign.runs == 0 {
            return Err(parse(
                "campaign.runs = 0: a campaign has at least one run".into(),
            ));
        }
        file.metrics.check().map_err(parse)?;
        for name in file.variants.keys() {
            if name.is_empty()
                || !name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                return Err(parse(format!(
                    "variant `{name}`: a variant's name is letters, digits, '_' and '-' (it names files and columns)"
                )));
            }
        }
        if file.variants.len() == 1 {
            return Err(parse(
                "one variant: a comparison needs two or more (without variants, [base] holds the run's settings)".into(),
            ));
        }
        let baseline = match file.campaign.baseline {
            Some(name) if !file.variants.contains_key(&name) => {
                return Err(parse(format!(
                    "campaign.baseline = {name:?}: no such variant (the variants: {})",
                    file.variants.keys().cloned().collect::<Vec<_>>().join(", ")
                )));
            }
            Some(name) => Some(name),
            None => file.variants.keys().next().cloned(),
        };
        let mut dispersions = Vec::new();
        collect_dispersions(&shown, "", &file.dispersions, &mut dispersions)?;
        dispersions.sort_by_key(|d| d.key.to_string());
        let config = file.campaign.config.map(|c| {
            path.parent()
                .filter(|d| !d.as_os_str().is_empty() && c.is_relative())
                .map_or(c.clone(), |d| d.join(&c))
        });
        Ok(Self {
            path: path.to_path_buf(),
            text: text.to_string(),
            runs: file.campaign.runs,
            seed: file.campaign.seed,
            config,
            base: file.base,
            dispersions,
            variants: file.variants,
            baseline,
            metrics: file.metrics,
        })
    }

    /// The names of the run configurations each run is run with: the variants, or
    /// [`BASE_VARIANT`] alone.
    pub fn variant_names(&self) -> Vec<String> {
        if self.variants.is_empty() {
            vec![BASE_VARIANT.to_string()]
        } else {
            self.variants.keys().cloned().collect()
        }
    }

    /// The dispersed keys, in column order.
    pub fn keys(&self) -> Vec<String> {
        self.dispersions.iter().map(|d| d.key.to_string()).collect()
    }
}

/// Reads the dispersions of `table` (keys below `prefix`) into `out`.
fn collect_dispersions(
    file: &str,
    prefix: &str,
    table: &toml::Table,
    out: &mut Vec<Dispersion>,
) -> Result<(), CampaignError> {
    for (name, value) in table {
        let key = if prefix.is_empty() {
            name.clone()
        } else {
            format!("{prefix}.{name}")
        };
        let refused = |reason: String| CampaignError::Dispersion {
            path: file.to_string(),
            key: key.clone(),
            reason,
        };
        let toml::Value::Table(spec) = value else {
            return Err(refused(format!(
                "{value} is not a distribution: write e.g. {{ normal = {{ mean = 0.0, std = 1.0 }} }}, {{ uniform = {{ low = -1.0, high = 1.0 }} }} or {{ values = [1.0, 2.0] }}"
            )));
        };
        if !spec.keys().any(|k| SPEC_KEYS.contains(&k.as_str())) {
            collect_dispersions(file, &key, spec, out)?;
            continue;
        }
        let path = KeyPath::parse(&key).map_err(|e| refused(e.to_string()))?;
        let spec: SpecToml = toml::Value::Table(spec.clone())
            .try_into()
            .map_err(|e: toml::de::Error| refused(e.message().to_string()))?;
        let mut given = Vec::new();
        if let Some(u) = spec.uniform {
            given.push(Distribution::Uniform {
                low: u.low,
                high: u.high,
            });
        }
        if let Some(n) = spec.normal {
            given.push(Distribution::Normal {
                mean: n.mean,
                std: n.std,
            });
        }
        if let Some(values) = spec.values {
            given.push(Distribution::Values(values));
        }
        let distribution = match given.len() {
            1 => given.remove(0),
            0 => {
                return Err(refused(
                    "no distribution: give uniform, normal or values".into(),
                ));
            }
            _ => return Err(refused("more than one of uniform, normal, values".into())),
        };
        distribution.check().map_err(refused)?;
        if out.iter().any(|d| d.key == path) {
            return Err(refused("declared twice".into()));
        }
        out.push(Dispersion {
            key: path,
            distribution,
            apply: spec.apply,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<CampaignFile, CampaignError> {
        CampaignFile::parse(text, Path::new("campaigns/c.toml"))
    }

    #[test]
    fn reads_dispersions_quoted_or_nested_variants_and_defaults() {
        let file = parse(
            "[campaign]\nruns = 10\nseed = 3\nconfig = \"run.toml\"\n\
             [dispersions]\n\"model.gyro.bias_deg_s[0]\" = { normal = { mean = 0.0, std = 1e-4 }, apply = \"add\" }\n\
             [dispersions.manoeuvre]\ninitial_pitch_deg = { uniform = { low = -5, high = 5 } }\n\
             [variants.b]\ncontroller.pd_friction.friction_compensation = false\n\
             [variants.a]\ncontroller.pd_friction.friction_compensation = true\n",
        )
        .unwrap();
        assert_eq!(file.runs, 10);
        assert_eq!(file.config, Some(PathBuf::from("campaigns/run.toml")));
        assert_eq!(
            file.keys(),
            ["manoeuvre.initial_pitch_deg", "model.gyro.bias_deg_s[0]"]
        );
        assert_eq!(
            file.dispersions[0].distribution,
            Distribution::Uniform {
                low: -5.0,
                high: 5.0
            }
        );
        assert_eq!(file.dispersions[1].apply, Apply::Add);
        assert_eq!(file.variant_names(), ["a", "b"]);
        assert_eq!(file.baseline.as_deref(), Some("a"));
        assert_eq!(file.metrics, MetricOptions::default());
        let plain = parse("[campaign]\nruns = 1\nseed = 0\n").unwrap();
        assert_eq!(plain.variant_names(), [BASE_VARIANT]);
        assert_eq!(plain.baseline, None);
    }

    #[test]
    fn refuses_bad_distributions_naming_file_key_and_value() {
        let refused = |dispersion: &str| {
            parse(&format!(
                "[campaign]\nruns = 2\nseed = 1\n[dispersions]\n{dispersion}\n"
            ))
            .unwrap_err()
            .to_string()
        };
        let err = refused("\"model.gyro.bias_deg_s[0]\" = { normal = { mean = 0.0, std = -0.1 } }");
        assert!(
            err.contains("campaigns/c.toml")
                && err.contains("`model.gyro.bias_deg_s[0]`")
                && err.contains("std = -0.1"),
            "{err}"
        );
        let err = refused("\"manoeuvre.initial_pitch_deg\" = { uniform = { low = 3, high = 1 } }");
        assert!(
            err.contains("`manoeuvre.initial_pitch_deg`") && err.contains("low = 3 > high = 1"),
            "{err}"
        );
        let err = refused("\"controller.pd_friction.kd\" = { values = [] }");
        assert!(
            err.contains("`controller.pd_friction.kd`") && err.contains("empty"),
            "{err}"
        );
        let err = refused(
            "\"a.b\" = { normal = { mean = 0.0, std = 1.0 }, uniform = { low = 0, high = 1 } }",
        );
        assert!(err.contains("more than one"), "{err}");
        let err = refused("\"a.b\" = { normal = { mean = 0.0, sd = 1.0 } }");
        assert!(err.contains("`a.b`") && err.contains("sd"), "{err}");
        let err = refused("\"a.b\" = 3.0");
        assert!(err.contains("not a distribution"), "{err}");
        let err = refused("\"a..b\" = { values = [1.0] }");
        assert!(err.contains("not a key path"), "{err}");
    }

    #[test]
    fn refuses_a_bad_campaign_section() {
        let err = |text: &str| parse(text).unwrap_err().to_string();
        assert!(err("[campaign]\nruns = 0\nseed = 1\n").contains("campaign.runs = 0"));
        assert!(err("[campaign]\nruns = 2\n").contains("seed"));
        assert!(
            err("[campaign]\nruns = 2\nseed = 1\n[metrics]\nsettle_band_deg = -1\n")
                .contains("metrics.settle_band_deg = -1")
        );
        assert!(err("[campaign]\nruns = 2\nseed = 1\n[variants.a]\n").contains("one variant"));
        assert!(
            err("[campaign]\nruns = 2\nseed = 1\nbaseline = \"c\"\n[variants.a]\n[variants.b]\n")
                .contains("baseline = \"c\"")
        );
        assert!(
            err("[campaign]\nruns = 2\nseed = 1\n[variants.\"a b\"]\n[variants.c]\n")
                .contains("variant `a b`")
        );
    }
}
