//! The run configuration every process of a run reads: mode, duration, seed, log path, and the
//! model, estimator, controller and manoeuvre. The launcher writes it once per run and passes its
//! path in [`ENV_RUN_CONFIG`]; the logger stores it whole in the run's log.

use crate::ground::GroundConfig;
use ipc_types::{ClockMode, Device, WaitStrategy};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use testbed_flight::choice::ChoiceError;
use testbed_flight::control::ControlError;
use testbed_flight::estimators::{EstimatorConfig, FilterSetup};
use testbed_flight::manoeuvre::Manoeuvre;
use testbed_flight::schedule::{Schedule, ScheduleError};
use testbed_flight::tasks::ControllerConfig;
use testbed_model::ModelConfig;
use testbed_model::balance_config::BalanceConfig;

/// Environment variable holding the path of the run configuration.
pub const ENV_RUN_CONFIG: &str = "TESTBED_RUN_CONFIG";

/// Default of [`RunSection::lockstep_wait`]: blocking costs no CPU between wake-ups, and
/// polling slows a loaded machine down (see the field, and `bench/README.md`).
pub const DEFAULT_LOCKSTEP_WAIT: &str = "block";

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
    /// An actuator that hears no command for this long commands zero (wheel torque, gimbal rate)
    /// until commands come again, s. Default 0.2 s: two periods of the 10 Hz loop (assumed; the
    /// paper gives no value). Only a paced run can miss commands: lockstep waits for them.
    pub command_timeout_s: f64,
    /// Log whose inputs the `replay` process feeds to the estimator and controller.
    pub replay: Option<PathBuf>,
    /// How the controller's commands reach the plant: `direct`, or through the wheel and CMG
    /// gateways, the CAN bus and the CAN board (`can_node`).
    pub actuation: Actuation,
    /// Wall-clock start of the run, ns since the Unix epoch (UTC). The log's message times
    /// (`log_time`, `publish_time`) are this plus the run clock, so viewers show real dates;
    /// samples keep the run clock in their header. `testbed run` sets it when the run starts
    /// (`--start-time-ns` pins it, to reproduce a log byte for byte); unset, the logger takes
    /// the time it opens the log.
    pub start_time_ns: Option<u64>,
    /// How every process of a lockstep run waits for its next sample, in the syntax of
    /// `TESTBED_BUS_WAIT` (which, when set, overrides it): `block`, `spin:<µs>`, `anticipate`.
    /// Default `block`. `spin:500` (after each data wake-up a process polls its subscribers
    /// for up to 500 µs, yielding the CPU between polls, before it sleeps) doubles lockstep
    /// speed on an idle 2-core machine, but on a loaded one the pollers take CPU from the
    /// processes doing the work: 5× slower than `block` at load average 6 (`bench/README.md`).
    /// Paced runs ignore it: they block (or follow the variable).
    pub lockstep_wait: String,
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
            command_timeout_s: 0.2,
            replay: None,
            actuation: Actuation::Direct,
            start_time_ns: None,
            lockstep_wait: DEFAULT_LOCKSTEP_WAIT.to_owned(),
        }
    }
}

/// A whole run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct RunConfig {
    pub run: RunSection,
    pub model: ModelConfig,
    /// The attitude filter by name (`[estimator] filter = "mekf"`) and its parameters
    /// (`[estimator.<filter>]`, derived from `model` where absent).
    pub estimator: EstimatorConfig,
    /// The control law by name (`[controller] law = "pd_friction"`), its parameters
    /// (`[controller.<law>]`), safe mode and thrusters.
    pub controller: ControllerConfig,
    pub manoeuvre: Manoeuvre,
    /// The CAN gateways' links and the simulated CAN board (unused without CAN gateways).
    pub can: CanSection,
    /// The ground link (ground station server and command limits).
    pub ground: GroundConfig,
    /// The balance masses and the balance's target (`testbed balance`); absent: the assumed
    /// set of `BalanceConfig::default` (docs/balance.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub balance: Option<BalanceConfig>,
}

#[derive(Debug, thiserror::Error)]
pub enum RunConfigError {
    #[error("cannot read run configuration {path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error("run configuration {path}: {message}")]
    Parse { path: String, message: String },
    #[error("run configuration {path}: {source}")]
    Model {
        path: String,
        source: testbed_model::config::ConfigError,
    },
    #[error("run configuration {path}: `{key}` = {value}: {reason}")]
    Invalid {
        path: String,
        key: String,
        value: String,
        reason: String,
    },
    /// A component refused its part of the configuration (estimator, controller).
    #[error("run configuration {path}: {component}: {message}")]
    Component {
        path: String,
        component: &'static str,
        message: String,
    },
    #[error(
        "{ENV_RUN_CONFIG} is not set: start this process through the launcher or `testbed run`, or pass --config"
    )]
    NotSet,
}

impl RunConfig {
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, RunConfigError> {
        let config: Self = toml::from_str(text).map_err(|e| RunConfigError::Parse {
            path: origin.to_string(),
            message: e.to_string(),
        })?;
        config.validate(origin)?;
        Ok(config)
    }

    pub fn load(path: &Path) -> Result<Self, RunConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| RunConfigError::Read {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// The configuration named by `--config`, else by [`ENV_RUN_CONFIG`].
    pub fn from_arg_or_env(arg: Option<&Path>) -> Result<(Self, PathBuf), RunConfigError> {
        let path = match arg {
            Some(p) => p.to_path_buf(),
            None => std::env::var_os(ENV_RUN_CONFIG)
                .map(PathBuf::from)
                .ok_or(RunConfigError::NotSet)?,
        };
        Ok((Self::load(&path)?, path))
    }

    pub fn to_toml_string(&self) -> String {
        toml::to_string_pretty(self).expect("a RunConfig always serialises")
    }

    /// How the processes of a lockstep run wait ([`RunSection::lockstep_wait`]); the reason
    /// when it is not a wait strategy.
    pub fn lockstep_wait(&self) -> Result<WaitStrategy, String> {
        self.run
            .lockstep_wait
            .parse()
            .map_err(|e: ipc_types::WaitStrategyError| e.reason)
    }

    pub fn validate(&self, origin: &str) -> Result<(), RunConfigError> {
        self.model
            .validate()
            .map_err(|source| RunConfigError::Model {
                path: origin.to_string(),
                source,
            })?;
        let invalid = |key: &str, value: f64, reason: &str| RunConfigError::Invalid {
            path: origin.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.to_string(),
        };
        if !(self.run.duration_s.is_finite() && self.run.duration_s > 0.0) {
            return Err(invalid(
                "run.duration_s",
                self.run.duration_s,
                "must be > 0",
            ));
        }
        if !(self.run.deadline_slack_s.is_finite() && self.run.deadline_slack_s >= 0.0) {
            return Err(invalid(
                "run.deadline_slack_s",
                self.run.deadline_slack_s,
                "must be >= 0",
            ));
        }
        if !(self.run.command_timeout_s.is_finite() && self.run.command_timeout_s > 0.0) {
            return Err(invalid(
                "run.command_timeout_s",
                self.run.command_timeout_s,
                "must be > 0",
            ));
        }
        self.lockstep_wait()
            .map_err(|reason| RunConfigError::Invalid {
                path: origin.to_string(),
                key: "run.lockstep_wait".to_string(),
                value: format!("{:?}", self.run.lockstep_wait),
                reason,
            })?;
        // What the estimator and controller processes would refuse at start, refused before
        // anything is launched.
        let component = |component, message: String| RunConfigError::Component {
            path: origin.to_string(),
            component,
            message,
        };
        let choice = |e: ChoiceError| RunConfigError::Invalid {
            path: origin.to_string(),
            key: e.key,
            value: e.value,
            reason: e.reason,
        };
        self.estimator.setup(&self.model).map_err(choice)?;
        self.controller.check().map_err(choice)?;
        self.controller
            .law(&self.model, self.manoeuvre.target())
            .map_err(|e| match e {
                ControlError::InvalidConfig { key, value, reason } => {
                    choice(ChoiceError { key, value, reason })
                }
                other => component("controller", other.to_string()),
            })?;
        self.schedule().map_err(|e| RunConfigError::Parse {
            path: origin.to_string(),
            message: e.to_string(),
        })?;
        self.can
            .validate()
            .map_err(|(key, value, reason)| RunConfigError::Invalid {
                path: origin.to_string(),
                key,
                value,
                reason: reason.to_string(),
            })?;
        if let Some(balance) = &self.balance {
            balance.validate().map_err(|e| match e {
                testbed_model::config::ConfigError::Invalid { key, value, reason } => {
                    RunConfigError::Invalid {
                        path: origin.to_string(),
                        key,
                        value,
                        reason,
                    }
                }
                source => RunConfigError::Model {
                    path: origin.to_string(),
                    source,
                },
            })?;
        }
        self.ground
            .validate(self.model.platform.tilt_limit_deg)
            .map_err(|(key, value, reason)| RunConfigError::Invalid {
                path: origin.to_string(),
                key,
                value,
                reason,
            })?;
        Ok(())
    }

    /// The estimator's filter and its parameters over the model's defaults (what the
    /// estimator task starts from); refused as [`Self::validate`] refuses it.
    pub fn estimator_setup(&self) -> Result<FilterSetup, ChoiceError> {
        self.estimator.setup(&self.model)
    }

    pub fn schedule(&self) -> Result<Schedule, ScheduleError> {
        Schedule::from_model(&self.model)
    }
}

/// How the controller's commands reach the plant (`run.actuation`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Actuation {
    /// The plant takes the controller's `WheelCommand` / `CmgCommand` (simulated gateways).
    #[default]
    Direct,
    /// The plant takes the `AppliedWheelCommand` / `AppliedCmgCommand` the (simulated)
    /// CAN board applies, after the wheel and CMG gateways have encoded the commands onto the bus.
    CanNode,
}

/// The link a CAN gateway talks over (`can.link`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CanLink {
    /// A Linux SocketCAN interface (`can.interface`): the platform's CAN bus.
    #[default]
    Socketcan,
    /// The software CAN bus on iceoryx2 (topic `testbed/can/bus`), served by `sim-can-node` or
    /// `can-replay`.
    SoftwareBus,
    /// A `candump -L` file (`can.candump`), replayed at `can.replay_speed`.
    Candump,
}

/// A device wired straight to the computer by RS-232 (`[can.serial.<device>]`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SerialLinkConfig {
    /// Serial device, e.g. `/dev/ttyUSB0`.
    pub path: PathBuf,
    /// Line rate, baud.
    #[serde(default = "default_baud")]
    pub baud: u32,
}

fn default_baud() -> u32 {
    115_200
}

/// Frame faults the simulated CAN board injects (`[can.faults]`): each frame (except the board's
/// tick sync) is dropped, corrupted, delayed past its tick's sync or duplicated with these
/// probabilities, seeded by `run.seed`. Both directions: the sensor frames it sends and the
/// command frames it receives.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct CanFaults {
    pub drop: f64,
    pub corrupt: f64,
    pub delay: f64,
    pub duplicate: f64,
}

/// The CAN board's bit rate, bit/s (PROTOCOL.md): `can.bitrate` unless set.
pub const DEFAULT_CAN_BITRATE: u32 = 500_000;

fn is_default_bitrate(bitrate: &u32) -> bool {
    *bitrate == DEFAULT_CAN_BITRATE
}

/// `[can]`: the CAN gateways' links and the simulated CAN board.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CanSection {
    /// The gateways' link.
    pub link: CanLink,
    /// SocketCAN interface (`link = "socketcan"`).
    pub interface: String,
    /// The bus's bit rate, bit/s: the CAN board's setting (PROTOCOL.md), which the SocketCAN
    /// interface must be brought up with; `testbed run` checks it before a run. Not written
    /// when it is the default, so a configuration reads and writes as before the key existed.
    #[serde(skip_serializing_if = "is_default_bitrate")]
    pub bitrate: u32,
    /// Identifier base of the board's protocol (a multiple of 16, at most 0x790: seven device blocks of 16 below 0x7FF).
    pub id_base: u16,
    /// `candump -L` file: the gateways' input with `link = "candump"`, and `can-replay`'s.
    pub candump: Option<PathBuf>,
    /// `link = "candump"`: replay speed relative to the recorded time stamps; 0 = as fast as
    /// possible.
    pub replay_speed: f64,
    /// The logger also writes the software bus's traffic as a `candump -L` file beside the run
    /// log (`<log>.candump.log`), readable by can-utils (`canplayer`, `log2asc`).
    pub record_candump: bool,
    /// The board commands zero torque / zero gimbal rate after this long without a valid
    /// command, s.
    pub command_timeout_s: f64,
    /// Devices wired directly by RS-232, by device name (gyro, inclinometer, magnetometer,
    /// wheels, cmg): their gateway uses this serial line instead of `link`.
    pub serial: std::collections::BTreeMap<String, SerialLinkConfig>,
    /// Faults the simulated CAN board injects.
    pub faults: CanFaults,
}

impl Default for CanSection {
    fn default() -> Self {
        Self {
            link: CanLink::Socketcan,
            interface: "can0".into(),
            bitrate: DEFAULT_CAN_BITRATE,
            id_base: 0x100,
            candump: None,
            replay_speed: 1.0,
            record_candump: false,
            command_timeout_s: 0.5,
            serial: Default::default(),
            faults: CanFaults::default(),
        }
    }
}

impl CanSection {
    /// `(key, value, reason)` of the first invalid setting.
    fn validate(&self) -> Result<(), (String, String, &'static str)> {
        let bad = |key: &str, value: String, reason| Err((format!("can.{key}"), value, reason));
        if !self.id_base.is_multiple_of(16) || self.id_base > 0x790 {
            return bad(
                "id_base",
                self.id_base.to_string(),
                "must be a multiple of 16, at most 1936 (0x790)",
            );
        }
        if !(self.replay_speed.is_finite() && self.replay_speed >= 0.0) {
            return bad(
                "replay_speed",
                self.replay_speed.to_string(),
                "must be >= 0 (0: as fast as possible)",
            );
        }
        if !(self.command_timeout_s.is_finite() && self.command_timeout_s > 0.0) {
            return bad(
                "command_timeout_s",
                self.command_timeout_s.to_string(),
                "must be > 0",
            );
        }
        if !(1..=1_000_000).contains(&self.bitrate) {
            return bad(
                "bitrate",
                self.bitrate.to_string(),
                "must be from 1 to 1000000 bit/s (classic CAN)",
            );
        }
        if self.link == CanLink::Socketcan && self.interface.trim().is_empty() {
            return bad(
                "interface",
                format!("{:?}", self.interface),
                "must name a CAN interface",
            );
        }
        for (device, link) in &self.serial {
            if Device::from_name(device).is_none() {
                return bad(
                    &format!("serial.{device}"),
                    device.clone(),
                    "not a device (gyro, inclinometer, magnetometer, wheels, cmg)",
                );
            }
            if link.baud == 0 {
                return bad(&format!("serial.{device}.baud"), "0".into(), "must be > 0");
            }
        }
        let f = &self.faults;
        for (key, rate) in [
            ("drop", f.drop),
            ("corrupt", f.corrupt),
            ("delay", f.delay),
            ("duplicate", f.duplicate),
        ] {
            if !(rate.is_finite() && (0.0..=1.0).contains(&rate)) {
                return bad(
                    &format!("faults.{key}"),
                    rate.to_string(),
                    "must be a probability from 0 to 1",
                );
            }
        }
        let total = f.drop + f.corrupt + f.delay + f.duplicate;
        if total > 1.0 {
            return bad(
                "faults",
                total.to_string(),
                "the fault probabilities must add up to at most 1",
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_balance_table_is_read_and_a_bad_mass_refused_by_key() {
        let masses = |mass: &str| {
            format!(
                "[balance]\nvertical_target_m = -2e-6\n\
                 [[balance.masses]]\nname = \"a\"\nmass_kg = {mass}\ncentre_m = [0.0, 0.0, 0.0]\n\
                 axis = [1.0, 0.0, 0.0]\ntravel_m = [-0.01, 0.01]\nposition_stddev_m = 0.0\n\
                 [[balance.masses]]\nname = \"b\"\nmass_kg = 1.0\ncentre_m = [0.0, 0.0, 0.0]\n\
                 axis = [0.0, 1.0, 0.0]\ntravel_m = [-0.01, 0.01]\nposition_stddev_m = 0.0\n\
                 [[balance.masses]]\nname = \"c\"\nmass_kg = 1.0\ncentre_m = [0.0, 0.0, 0.0]\n\
                 axis = [0.0, 0.0, 1.0]\ntravel_m = [-0.01, 0.01]\nposition_stddev_m = 0.0\n"
            )
        };
        let config = RunConfig::from_toml_str(&masses("0.5"), "b.toml").expect("valid");
        let balance = config.balance.clone().expect("[balance] read");
        assert_eq!(balance.vertical_target_m, -2e-6);
        assert_eq!(balance.masses[0].mass_kg, 0.5);
        let text = config.to_toml_string();
        assert_eq!(RunConfig::from_toml_str(&text, "rt").unwrap(), config);
        let err = RunConfig::from_toml_str(&masses("-1.0"), "b.toml")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("balance.masses[0].mass_kg")
                && err.contains("-1")
                && err.contains("b.toml"),
            "{err}"
        );
        // No table: none, and nothing of it written.
        assert!(RunConfig::default().balance.is_none());
        assert!(!RunConfig::default().to_toml_string().contains("balance"));
    }

    #[test]
    fn round_trips_and_refuses_bad_values_by_name() {
        let config = RunConfig::default();
        let text = config.to_toml_string();
        assert_eq!(RunConfig::from_toml_str(&text, "rt").unwrap(), config);
        let err = RunConfig::from_toml_str("[run]\nduration_s = -3\n", "run.toml")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("run.duration_s") && err.contains("-3") && err.contains("run.toml"),
            "{err}"
        );
        let err = RunConfig::from_toml_str("[run]\nspeed = 3\n", "run.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("speed"), "{err}");
        let err = RunConfig::from_toml_str("[model.platform]\nmass_kg = nan\n", "run.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("platform.mass_kg"), "{err}");
        let err = RunConfig::from_toml_str("[run]\nlockstep_wait = \"spin:fast\"\n", "run.toml")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("run.lockstep_wait")
                && err.contains("spin:fast")
                && err.contains("run.toml"),
            "{err}"
        );
        assert_eq!(config.lockstep_wait(), Ok(WaitStrategy::Block));
        let spinning =
            RunConfig::from_toml_str("[run]\nlockstep_wait = \"spin:500\"\n", "run.toml")
                .expect("spin:500 is a wait strategy");
        assert_eq!(
            spinning.lockstep_wait(),
            Ok(WaitStrategy::SpinAfterWake {
                spin: std::time::Duration::from_micros(500)
            })
        );
    }

    #[test]
    fn what_the_processes_would_refuse_is_refused_at_load() {
        let refused = |text: &str| {
            RunConfig::from_toml_str(text, "run.toml")
                .unwrap_err()
                .to_string()
        };
        // A NaN gain: the controller would refuse it at start.
        let err = refused("[controller.pd_friction]\np_nm = [nan, 1.0, 1.0]\n");
        assert!(
            err.contains("controller.pd_friction.p_nm[0]") && err.contains("run.toml"),
            "{err}"
        );
        // Laws and filters by name: an unknown name lists the known ones, a table for an
        // unknown law or an unknown field is refused naming it, the old keys name the new.
        for (text, key, says) in [
            (
                "[controller]\nlaw = \"pid\"\n",
                "controller.law",
                "pd_friction",
            ),
            (
                "[controller.pid]\ngain = 1.0\n",
                "controller.pid",
                "cmg_slew",
            ),
            (
                "[controller.pd_friction]\ngain = 1.0\n",
                "controller.pd_friction",
                "gain",
            ),
            (
                "[controller]\nactuators = \"cmg\"\n",
                "controller.actuators",
                "controller.law",
            ),
            (
                "[controller.wheels]\np_nm = [1.0, 1.0, 1.0]\n",
                "controller.wheels",
                "pd_friction",
            ),
            (
                "[estimator]\nfilter = \"ukf\"\n",
                "estimator.filter",
                "mekf",
            ),
            (
                "[estimator]\ngate_enabled = false\n",
                "estimator.gate_enabled",
                "[estimator.mekf]",
            ),
            ("[estimator.mekf]\ngate = false\n", "estimator.mekf", "gate"),
        ] {
            let err = refused(text);
            assert!(
                err.contains(&format!("`{key}`")) && err.contains(says) && err.contains("run.toml"),
                "{text}: {err}"
            );
        }
        let config = RunConfig::from_toml_str(
            "[controller]\nlaw = \"cmg_slew\"\n[controller.cmg_slew.slew]\nmax_rate_rad_s = 0.02\n\
             [estimator.mekf]\ngate_enabled = false\n",
            "ok.toml",
        )
        .unwrap();
        assert_eq!(
            RunConfig::from_toml_str(&config.to_toml_string(), "rt").unwrap(),
            config
        );
        // Loop rates the pipeline cannot serve (1e10 Hz panicked five processes, 0.001 Hz hung
        // a paced run).
        for rate in ["1e10", "0.001"] {
            let err = refused(&format!("[model.gyro]\nrate_hz = {rate}\n"));
            assert!(err.contains("gyro.rate_hz"), "{err}");
        }
        assert!(RunConfig::from_toml_str("[model.gyro]\nrate_hz = 10.0\n", "ok.toml").is_ok());
    }

    #[test]
    fn can_section_round_trips_and_refuses_bad_values_by_name() {
        let text = "[run]\nactuation = \"can_node\"\n[can]\nlink = \"software_bus\"\nrecord_candump = true\n\
                    [can.faults]\ndrop = 0.01\ncorrupt = 0.005\n[can.serial.gyro]\npath = \"/dev/ttyUSB0\"\n";
        let config = RunConfig::from_toml_str(text, "can.toml").unwrap();
        assert_eq!(config.run.actuation, Actuation::CanNode);
        assert_eq!(config.can.link, CanLink::SoftwareBus);
        assert_eq!(config.can.serial["gyro"].baud, 115_200);
        assert_eq!(config.can.bitrate, DEFAULT_CAN_BITRATE);
        // The default bit rate is not written: a default configuration reads as it always did.
        assert!(!config.to_toml_string().contains("bitrate"));
        let fast = RunConfig::from_toml_str("[can]\nbitrate = 1000000\n", "fast.toml").unwrap();
        assert_eq!(fast.can.bitrate, 1_000_000);
        assert_eq!(
            RunConfig::from_toml_str(&fast.to_toml_string(), "rt").unwrap(),
            fast
        );
        assert_eq!(
            RunConfig::from_toml_str(&config.to_toml_string(), "rt").unwrap(),
            config
        );
        for (text, key) in [
            ("[can.faults]\ndrop = 1.5\n", "can.faults.drop"),
            ("[can.faults]\ndrop = 0.6\ncorrupt = 0.6\n", "can.faults"),
            ("[can]\nid_base = 257\n", "can.id_base"),
            ("[can]\nbitrate = 0\n", "can.bitrate"),
            ("[can]\nbitrate = 2000000\n", "can.bitrate"),
            (
                "[can.serial.sonar]\npath = \"/dev/null\"\n",
                "can.serial.sonar",
            ),
        ] {
            let err = RunConfig::from_toml_str(text, "run.toml")
                .unwrap_err()
                .to_string();
            assert!(err.contains(key) && err.contains("run.toml"), "{err}");
        }
    }
}
