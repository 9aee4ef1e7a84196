//! The run configuration every process of a run reads: mode, duration, seed, log path, and the
//! model, estimator, controller and manoeuvre. The launcher writes it once per run and passes its
//! path in [`ENV_RUN_CONFIG`]; the logger stores it whole in the run's log.

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use testbed_gnc::closed_loop::{Feedback, Manoeuvre, Scenario, Schedule};
use testbed_gnc::mekf::MekfConfig;
use testbed_gnc::tasks::ControllerConfig;
use testbed_model::ModelConfig;

/// Environment variable holding the path of the run configuration.
pub const ENV_RUN_CONFIG: &str = "TESTBED_RUN_CONFIG";

/// Who owns time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ClockMode {
    /// The plant advances only when the pipeline has answered the current tick: as fast as the
    /// machine allows, and byte-identical logs for the same seed.
    #[default]
    Lockstep,
    /// The plant advances at 1× wall time whether or not the pipeline answered (late answers are
    /// deadline misses).
    Paced,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RunSection {
    /// Launch profile the run came from (recorded in the log).
    pub profile: String,
    pub mode: ClockMode,
    /// Simulated duration, s.
    pub duration_s: f64,
    /// Seed of every simulated device's noise.
    pub seed: u64,
    /// MCAP log of the run.
    pub log: PathBuf,
    /// Processes the plant waits for (heartbeat `Running`) before it starts the clock.
    pub participants: Vec<String>,
    /// Slack after a tick's period before the controller counts a missed deadline, s.
    pub deadline_slack_s: f64,
}

impl Default for RunSection {
    fn default() -> Self {
        Self {
            profile: "simulation".into(),
            mode: ClockMode::Lockstep,
            duration_s: 150.0,
            seed: 1,
            log: PathBuf::from("out/run.mcap"),
            participants: Vec::new(),
            deadline_slack_s: 0.05,
        }
    }
}

/// A whole run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct RunConfig {
    pub run: RunSection,
    pub model: ModelConfig,
    /// Estimator settings; derived from `model` when absent.
    pub estimator: Option<MekfConfig>,
    pub controller: ControllerConfig,
    pub manoeuvre: Manoeuvre,
}

#[derive(Debug, thiserror::Error)]
pub enum RunConfigError {
    #[error("cannot read run configuration {path}: {source}")]
    Read { path: String, source: std::io::Error },
    #[error("run configuration {path}: {message}")]
    Parse { path: String, message: String },
    #[error("run configuration {path}: {source}")]
    Model { path: String, source: testbed_model::config::ConfigError },
    #[error("run configuration {path}: `{key}` = {value}: {reason}")]
    Invalid { path: String, key: String, value: String, reason: String },
    #[error("{ENV_RUN_CONFIG} is not set: start this process through the launcher or `testbed run`, or pass --config")]
    NotSet,
}

impl RunConfig {
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, RunConfigError> {
        let config: Self = toml::from_str(text)
            .map_err(|e| RunConfigError::Parse { path: origin.to_string(), message: e.to_string() })?;
        config.validate(origin)?;
        Ok(config)
    }

    pub fn load(path: &Path) -> Result<Self, RunConfigError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| RunConfigError::Read { path: path.display().to_string(), source })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// The configuration named by `--config`, else by [`ENV_RUN_CONFIG`].
    pub fn from_arg_or_env(arg: Option<&Path>) -> Result<(Self, PathBuf), RunConfigError> {
        let path = match arg {
            Some(p) => p.to_path_buf(),
            None => std::env::var_os(ENV_RUN_CONFIG).map(PathBuf::from).ok_or(RunConfigError::NotSet)?,
        };
        Ok((Self::load(&path)?, path))
    }

    pub fn to_toml_string(&self) -> String {
        toml::to_string_pretty(self).expect("a RunConfig always serialises")
    }

    pub fn validate(&self, origin: &str) -> Result<(), RunConfigError> {
        self.model.validate().map_err(|source| RunConfigError::Model { path: origin.to_string(), source })?;
        let invalid = |key: &str, value: f64, reason: &str| RunConfigError::Invalid {
            path: origin.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.to_string(),
        };
        if !(self.run.duration_s.is_finite() && self.run.duration_s > 0.0) {
            return Err(invalid("run.duration_s", self.run.duration_s, "must be > 0"));
        }
        if !(self.run.deadline_slack_s.is_finite() && self.run.deadline_slack_s >= 0.0) {
            return Err(invalid("run.deadline_slack_s", self.run.deadline_slack_s, "must be >= 0"));
        }
        self.schedule().map_err(|e| RunConfigError::Parse { path: origin.to_string(), message: e.to_string() })?;
        Ok(())
    }

    pub fn estimator_config(&self) -> MekfConfig {
        self.estimator.clone().unwrap_or_else(|| MekfConfig::from_model(&self.model))
    }

    pub fn schedule(&self) -> Result<Schedule, testbed_gnc::closed_loop::LoopError> {
        Schedule::from_model(&self.model)
    }

    /// The same run as an in-process closed loop (for comparison with the pipeline).
    pub fn scenario(&self) -> Scenario {
        Scenario {
            model: self.model.clone(),
            controller: self.controller.clone(),
            estimator: self.estimator_config(),
            feedback: Feedback::Estimate,
            manoeuvre: self.manoeuvre.clone(),
            duration_s: self.run.duration_s,
            seed: self.run.seed,
            schedule: Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_refuses_bad_values_by_name() {
        let config = RunConfig::default();
        let text = config.to_toml_string();
        assert_eq!(RunConfig::from_toml_str(&text, "rt").unwrap(), config);
        let err = RunConfig::from_toml_str("[run]\nduration_s = -3\n", "run.toml").unwrap_err().to_string();
        assert!(err.contains("run.duration_s") && err.contains("-3") && err.contains("run.toml"), "{err}");
        let err = RunConfig::from_toml_str("[run]\nspeed = 3\n", "run.toml").unwrap_err().to_string();
        assert!(err.contains("speed"), "{err}");
        let err = RunConfig::from_toml_str("[model.platform]\nmass_kg = nan\n", "run.toml").unwrap_err().to_string();
        assert!(err.contains("platform.mass_kg"), "{err}");
    }
}
