//! Launch profiles: which processes a run starts, in which order, and how they are supervised.
//!
//! ```toml
//! [run]                      # defaults for the run; the command line may override them
//! mode = "lockstep"          # "lockstep" | "paced"
//! duration_s = 600.0         # optional: simulated duration (the plant ends the run)
//! seed = 1                   # default 0
//! log = "runs/sim.mcap"      # optional: run log path (relative: to the working directory)
//! config = "sim-run.toml"    # optional: run configuration file (relative: to this profile)
//! max_wall_s = 3600.0        # optional: the launcher stops everything after this wall time
//!
//! [platform]                 # optional
//! cpu_latency_us = 0         # optional: held for the run as a PM QoS request on
//!                            # /dev/cpu_dma_latency (needs root): idle CPUs use no idle state
//!                            # slower to leave than this; 0 = they poll (see `placement`)
//! hot_path_cpu = 0           # optional: the CPU of the `cpus = "hot-path"` processes
//!                            # (default: the first CPU the launcher may use)
//!
//! [devices]                  # optional; each listed device must be served by one process
//! gyro = "simulated"         # "real" | "simulated"; also inclinometer, magnetometer, wheels, cmg
//!
//! [supervision]              # optional
//! stop_timeout_s = 2.0       # after SIGINT, wait this long before SIGTERM
//! term_timeout_s = 2.0       # after SIGTERM, wait this long before SIGKILL
//! restart_delay_s = 0.5      # delay before restarting a process (on_exit = "restart")
//! heartbeat_timeout_s = 1.5  # a Running process silent this long is hung: killed (0: off)
//! tolerate_safe_mode = false # testbed run exits 0 even if the controller entered safe mode
//!
//! [[process]]
//! name = "sim-gyro"          # unique; [A-Za-z0-9_-], at most 31 bytes
//! command = "sim-gyro"       # a role of `testbed` (see roles), or a program's absolute path
//! args = []                  # default []
//! env = { }                  # extra environment; TESTBED_BUS_* and TESTBED_RUN_* are refused
//! required = true            # default true: its failure fails the run
//! on_exit = "stop_all"       # "stop_all" (default) | "restart" | "ignore"
//! max_restarts = 0           # with on_exit = "restart" only (then at least 1)
//! depends_on = ["plant"]     # started after these
//! ends_run = false           # its successful exit ends the run
//! observer = false           # takes no part in lockstep ticks (the ground link)
//! device = "gyro"            # optional, with `source`: the device this process serves, or a
//!                            # list of them served by one process (`["gyro", "cmg"]`)
//! source = "simulated"
//! cpus = [0]                 # optional: CPU affinity (every CPU when absent), or a role:
//!                            # "hot-path" (one CPU, [platform] hot_path_cpu or the first)
//!                            # or "background" (every other CPU)
//! scheduling = { policy = "fifo", priority = 10 }   # optional: "other" (with `nice`),
//!                            # "fifo" or "rr" (with `priority` 1..=99; needs CAP_SYS_NICE)
//! ```
//!
//! Unknown keys are refused. Every error names the file, the key and the value.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};

pub use ipc_types::{ClockMode, Device};
use serde::Deserialize;

/// Environment variables the launcher sets for every child; a profile may not set them.
pub const RESERVED_ENV_PREFIXES: &[&str] = &[
    "TESTBED_BUS_",
    "TESTBED_RUN_",
    "TESTBED_DEVICE_",
    "TESTBED_RESTART_",
    ipc_types::ENV_SERVED_DEVICES,
];
/// Longest process name (fits `ipc_types::Heartbeat::name` and an iceoryx2 node name).
pub const MAX_NAME_LEN: usize = 31;

/// Programs that own the run's clock: never restarted mid-run.
pub const CLOCK_OWNERS: &[&str] = &["plant", "replay", "can-replay"];

/// A profile that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    /// The file cannot be read.
    #[error("{file}: cannot read the profile: {source}")]
    Read {
        /// The profile file.
        file: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// TOML syntax error, wrong type, unknown key or unknown value (the message shows the line).
    #[error("{file}: {message}")]
    Parse {
        /// The profile file.
        file: String,
        /// The TOML parser's message, with line, column and the offending text.
        message: String,
    },
    /// A value that parses but does not make sense.
    #[error("{file}: {key} = {value}: {reason}")]
    Invalid {
        /// The profile file.
        file: String,
        /// The key, e.g. `process.estimator.depends_on`.
        key: String,
        /// The offending value, as written in TOML.
        value: String,
        /// What is wrong.
        reason: String,
    },
}

/// `device = "gyro"` or `device = ["gyro", "inclinometer"]` (not an empty list; an unknown
/// name is refused with the known ones).
fn one_or_more_devices<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<Device>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged, expecting = "a device name or a list of device names")]
    enum OneOrMore {
        One(String),
        More(Vec<String>),
    }
    let names = match OneOrMore::deserialize(d)? {
        OneOrMore::One(name) => vec![name],
        OneOrMore::More(names) => names,
    };
    if names.is_empty() {
        return Err(serde::de::Error::custom(
            "an empty list: name the devices this process serves, or leave `device` out",
        ));
    }
    names
        .iter()
        .map(|name| name.parse().map_err(serde::de::Error::custom))
        .collect()
}

/// Whether a device is the real one (gateway) or simulated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// A gateway to the real device.
    Real,
    /// A simulated gateway fed by the plant.
    Simulated,
}

impl Source {
    /// The name used in profiles and in `TESTBED_DEVICE_*`.
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Real => "real",
            Self::Simulated => "simulated",
        }
    }
}

/// What the launcher does when a process exits while the run goes on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OnExit {
    /// Stop every process and end the run.
    #[default]
    StopAll,
    /// Start it again, up to `max_restarts` times; then behave like `stop_all` if it is
    /// required, or leave it stopped if not.
    Restart,
    /// Log it and carry on (only for processes that are not required).
    Ignore,
}

impl OnExit {
    fn as_str(self) -> &'static str {
        match self {
            Self::StopAll => "stop_all",
            Self::Restart => "restart",
            Self::Ignore => "ignore",
        }
    }
}

/// `[run]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSettings {
    /// Clock mode.
    pub mode: ClockMode,
    /// Simulated duration, s.
    pub duration_s: Option<f64>,
    /// Random seed.
    #[serde(default)]
    pub seed: u64,
    /// Run log path.
    pub log: Option<PathBuf>,
    /// Run configuration file the processes read (`TESTBED_RUN_CONFIG`); relative paths are
    /// relative to the profile's directory.
    pub config: Option<PathBuf>,
    /// Wall-time limit of the whole run, s.
    pub max_wall_s: Option<f64>,
}

/// `[platform]`: settings of the machine the launcher holds for the run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Platform {
    /// Wake-up latency the CPUs' idle states may add, µs: a PM QoS request the launcher holds
    /// on `/dev/cpu_dma_latency` from start to end of the run (`placement::CpuLatencyRequest`).
    /// `0` keeps idle CPUs polling instead of halting. None: the system's default.
    pub cpu_latency_us: Option<u32>,
    /// The CPU of the processes placed on the hot path (`cpus = "hot-path"`); the
    /// `"background"` ones get every other CPU the launcher may use. None: the first CPU the
    /// launcher may use.
    pub hot_path_cpu: Option<usize>,
}

/// `[supervision]`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Supervision {
    /// Wait after SIGINT before SIGTERM, s.
    pub stop_timeout_s: f64,
    /// Wait after SIGTERM before SIGKILL, s.
    pub term_timeout_s: f64,
    /// Delay before a restart, s.
    pub restart_delay_s: f64,
    /// A running process whose heartbeat (every 0.5 s) stops for this long is hung: it is
    /// killed and its exit policy applies. Three heartbeat periods by default; 0 turns the
    /// watchdog off. s.
    pub heartbeat_timeout_s: f64,
    /// `testbed run` exits 0 even if the controller entered safe mode (for fault-injection and
    /// chaos runs); by default a run with safe mode fails after its summary.
    pub tolerate_safe_mode: bool,
}

impl Default for Supervision {
    fn default() -> Self {
        Self {
            stop_timeout_s: 2.0,
            term_timeout_s: 2.0,
            restart_delay_s: 0.5,
            heartbeat_timeout_s: 1.5,
            tolerate_safe_mode: false,
        }
    }
}

fn default_true() -> bool {
    true
}

/// One `[[process]]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProcessSpec {
    /// Unique name; also `TESTBED_PROCESS_NAME` of the child.
    pub name: String,
    /// Binary name (next to the launcher) or absolute path.
    pub command: String,
    /// Arguments.
    #[serde(default)]
    pub args: Vec<String>,
    /// Extra environment.
    #[serde(default)]
    pub env: BTreeMap<String, String>,
    /// Whether its failure fails the run.
    #[serde(default = "default_true")]
    pub required: bool,
    /// Exit policy.
    #[serde(default)]
    pub on_exit: OnExit,
    /// Restart budget (with `on_exit = "restart"`).
    #[serde(default)]
    pub max_restarts: u32,
    /// Processes started before this one.
    #[serde(default)]
    pub depends_on: Vec<String>,
    /// A successful exit ends the run.
    #[serde(default)]
    pub ends_run: bool,
    /// A pure observer (the ground link): not a participant of the lockstep start barrier or
    /// of any tick, so in lockstep its exit does not end the run (its `on_exit` applies).
    #[serde(default)]
    pub observer: bool,
    /// The devices this process serves: one (`device = "gyro"`) or several sharing a process
    /// (`device = ["gyro", "inclinometer"]`, the `sim-devices` process); empty when it serves
    /// none. The launcher passes them in `TESTBED_SERVED_DEVICES`.
    #[serde(default, deserialize_with = "one_or_more_devices")]
    pub device: Vec<Device>,
    /// Whether that device is real or simulated.
    pub source: Option<Source>,
    /// CPUs the process may run on (its affinity): indices, e.g. `[0]`, or a role,
    /// `"hot-path"` or `"background"` ([`crate::placement::Cpus`]); every CPU when absent.
    #[serde(default)]
    pub cpus: Option<crate::placement::Cpus>,
    /// Scheduling policy, e.g. `{ policy = "fifo", priority = 10 }`; inherited when absent.
    #[serde(default)]
    pub scheduling: Option<crate::placement::Scheduling>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProfile {
    run: RunSettings,
    #[serde(default)]
    platform: Platform,
    #[serde(default)]
    devices: BTreeMap<Device, Source>,
    #[serde(default)]
    supervision: Supervision,
    #[serde(default, rename = "process")]
    processes: Vec<ProcessSpec>,
}

/// A validated profile.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// The file it was read from.
    pub file: PathBuf,
    /// `[run]`.
    pub run: RunSettings,
    /// `[platform]`.
    pub platform: Platform,
    /// `[devices]`.
    pub devices: BTreeMap<Device, Source>,
    /// `[supervision]`.
    pub supervision: Supervision,
    /// The processes in file order.
    pub processes: Vec<ProcessSpec>,
    /// Indices into `processes` in start order (dependencies first, otherwise file order).
    pub start_order: Vec<usize>,
}

impl Profile {
    /// Reads and validates the profile at `path`.
    pub fn load(path: &Path) -> Result<Self, ProfileError> {
        let text = std::fs::read_to_string(path).map_err(|source| ProfileError::Read {
            file: path.display().to_string(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses and validates `text`, naming `file` in errors.
    pub fn parse(text: &str, file: &Path) -> Result<Self, ProfileError> {
        let file_name = file.display().to_string();
        let raw: RawProfile = toml::from_str(text).map_err(|e| ProfileError::Parse {
            file: file_name.clone(),
            message: e.to_string().trim_end().to_owned(),
        })?;
        let mut profile = Self {
            file: file.to_path_buf(),
            run: raw.run,
            platform: raw.platform,
            devices: raw.devices,
            supervision: raw.supervision,
            processes: raw.processes,
            start_order: Vec::new(),
        };
        profile.validate()?;
        profile.start_order = profile.topological_order()?;
        Ok(profile)
    }

    fn invalid(
        &self,
        key: impl Into<String>,
        value: impl fmt::Debug,
        reason: impl Into<String>,
    ) -> ProfileError {
        ProfileError::Invalid {
            file: self.file.display().to_string(),
            key: key.into(),
            value: format!("{value:?}"),
            reason: reason.into(),
        }
    }

    /// Checks one setting of `[run]` or `[supervision]` (also used for command-line overrides).
    pub fn check_seconds(
        &self,
        key: &str,
        value: f64,
        allow_zero: bool,
    ) -> Result<(), ProfileError> {
        let ok = value.is_finite() && (value > 0.0 || (allow_zero && value == 0.0));
        if ok {
            Ok(())
        } else {
            let what = if allow_zero {
                "non-negative"
            } else {
                "positive"
            };
            Err(self.invalid(
                key,
                value,
                format!("must be a finite, {what} number of seconds"),
            ))
        }
    }

    /// Checks a PM QoS CPU latency request, µs (also used for the command-line override).
    pub fn check_cpu_latency(&self, key: &str, us: u32) -> Result<(), ProfileError> {
        if us <= crate::placement::MAX_CPU_LATENCY_US {
            Ok(())
        } else {
            Err(self.invalid(
                key,
                us,
                format!(
                    "at most {} µs (the kernel's default, no constraint)",
                    crate::placement::MAX_CPU_LATENCY_US
                ),
            ))
        }
    }

    fn validate(&self) -> Result<(), ProfileError> {
        if let Some(d) = self.run.duration_s {
            self.check_seconds("run.duration_s", d, false)?;
        }
        if let Some(w) = self.run.max_wall_s {
            self.check_seconds("run.max_wall_s", w, false)?;
        }
        for (key, path) in [("run.log", &self.run.log), ("run.config", &self.run.config)] {
            if path.as_ref().is_some_and(|p| p.as_os_str().is_empty()) {
                return Err(self.invalid(key, "", "must not be empty"));
            }
        }
        if let Some(us) = self.platform.cpu_latency_us {
            self.check_cpu_latency("platform.cpu_latency_us", us)?;
        }
        if let Some(cpu) = self.platform.hot_path_cpu
            && cpu > crate::placement::MAX_CPU
        {
            return Err(self.invalid(
                "platform.hot_path_cpu",
                cpu,
                format!("beyond {}", crate::placement::MAX_CPU),
            ));
        }
        let s = self.supervision;
        self.check_seconds("supervision.stop_timeout_s", s.stop_timeout_s, true)?;
        self.check_seconds("supervision.term_timeout_s", s.term_timeout_s, true)?;
        self.check_seconds("supervision.restart_delay_s", s.restart_delay_s, true)?;
        self.check_seconds(
            "supervision.heartbeat_timeout_s",
            s.heartbeat_timeout_s,
            true,
        )?;
        if self.run.mode == ClockMode::Lockstep
            && let Some((device, _)) = self.devices.iter().find(|(_, s)| **s == Source::Real)
        {
            return Err(self.invalid(
                "run.mode",
                "lockstep",
                format!(
                    "lockstep needs every device simulated, but devices.{} = \"real\" (use \"paced\")",
                    device.name()
                ),
            ));
        }
        if self.processes.is_empty() {
            return Err(self.invalid("process", "[]", "a profile needs at least one [[process]]"));
        }
        let mut names = HashMap::new();
        for (i, p) in self.processes.iter().enumerate() {
            self.validate_process(i, p)?;
            if let Some(first) = names.insert(p.name.as_str(), i) {
                return Err(self.invalid(
                    format!("process[{i}].name"),
                    &p.name,
                    format!("duplicate: process[{first}] has the same name"),
                ));
            }
        }
        self.validate_devices()
    }

    fn validate_process(&self, index: usize, p: &ProcessSpec) -> Result<(), ProfileError> {
        let name_ok = !p.name.is_empty()
            && p.name.len() <= MAX_NAME_LEN
            && p.name
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_');
        if !name_ok {
            return Err(self.invalid(
                format!("process[{index}].name"),
                &p.name,
                format!("expected 1 to {MAX_NAME_LEN} characters from [A-Za-z0-9_-]"),
            ));
        }
        let key = |field: &str| format!("process.{}.{field}", p.name);
        if p.command.trim().is_empty() || p.command.contains('\0') {
            return Err(self.invalid(key("command"), &p.command, "must name a role or a program"));
        }
        for (k, v) in &p.env {
            if k.is_empty() || k.contains('=') || k.contains('\0') || v.contains('\0') {
                return Err(self.invalid(key("env"), k, "not a valid environment variable"));
            }
            if RESERVED_ENV_PREFIXES
                .iter()
                .any(|prefix| k.starts_with(prefix))
            {
                return Err(self.invalid(
                    key("env"),
                    k,
                    format!("set by the launcher for every process ({RESERVED_ENV_PREFIXES:?})"),
                ));
            }
        }
        if p.required && p.on_exit == OnExit::Ignore {
            return Err(self.invalid(
                key("on_exit"),
                p.on_exit.as_str(),
                "a required process cannot be ignored when it exits (set required = false)",
            ));
        }
        match (p.on_exit, p.max_restarts) {
            (OnExit::Restart, 0) => {
                return Err(self.invalid(
                    key("max_restarts"),
                    0,
                    "on_exit = \"restart\" needs max_restarts of at least 1",
                ));
            }
            (OnExit::StopAll | OnExit::Ignore, n) if n > 0 => {
                return Err(self.invalid(
                    key("max_restarts"),
                    n,
                    format!(
                        "only used with on_exit = \"restart\" (on_exit = {:?})",
                        p.on_exit.as_str()
                    ),
                ));
            }
            _ => {}
        }
        let program = Path::new(&p.command)
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default();
        if CLOCK_OWNERS.contains(&program) && p.on_exit == OnExit::Restart {
            return Err(self.invalid(
                key("on_exit"),
                p.on_exit.as_str(),
                format!(
                    "{program} owns the run's clock: a restarted {program} would start time again \
                     at 0 (use \"stop_all\")"
                ),
            ));
        }
        if let Some(crate::placement::Cpus::List(cpus)) = &p.cpus {
            let mut seen = std::collections::BTreeSet::new();
            if cpus.is_empty() {
                return Err(self.invalid(key("cpus"), cpus, "names no CPU (leave it out for all)"));
            }
            if let Some(cpu) = cpus
                .iter()
                .find(|&&c| c > crate::placement::MAX_CPU || !seen.insert(c))
            {
                return Err(self.invalid(
                    key("cpus"),
                    cpus,
                    format!(
                        "CPU {cpu} is repeated or beyond {}",
                        crate::placement::MAX_CPU
                    ),
                ));
            }
        }
        if let Some(scheduling) = &p.scheduling
            && let Err(reason) = scheduling.check()
        {
            return Err(self.invalid(key("scheduling"), scheduling, reason));
        }
        match (p.device.first(), p.source) {
            (Some(_), None) => {
                return Err(self.invalid(key("source"), "(missing)", "`device` needs `source`"));
            }
            (None, Some(s)) => {
                return Err(self.invalid(
                    key("device"),
                    "(missing)",
                    format!("`source = \"{}\"` needs `device`", s.as_str()),
                ));
            }
            _ => {}
        }
        Ok(())
    }

    fn validate_devices(&self) -> Result<(), ProfileError> {
        let mut served: BTreeMap<Device, &str> = BTreeMap::new();
        for p in &self.processes {
            let Some(source) = p.source else {
                continue;
            };
            let key = format!("process.{}.device", p.name);
            for &device in &p.device {
                let Some(chosen) = self.devices.get(&device) else {
                    return Err(self.invalid(
                        key,
                        device.name(),
                        format!("[devices] does not list {}", device.name()),
                    ));
                };
                if *chosen != source {
                    return Err(self.invalid(
                        format!("process.{}.source", p.name),
                        source.as_str(),
                        format!("devices.{} = \"{}\"", device.name(), chosen.as_str()),
                    ));
                }
                if let Some(other) = served.insert(device, &p.name) {
                    return Err(self.invalid(
                        key,
                        device.name(),
                        if other == p.name {
                            "listed twice".to_owned()
                        } else {
                            format!("process {other:?} already serves this device")
                        },
                    ));
                }
            }
        }
        for device in self.devices.keys() {
            if !served.contains_key(device) {
                return Err(self.invalid(
                    format!("devices.{}", device.name()),
                    self.devices[device].as_str(),
                    "no [[process]] serves this device (set its `device` and `source`)",
                ));
            }
        }
        Ok(())
    }

    /// Dependencies first; among processes that are ready, file order.
    fn topological_order(&self) -> Result<Vec<usize>, ProfileError> {
        let index: HashMap<&str, usize> = self
            .processes
            .iter()
            .enumerate()
            .map(|(i, p)| (p.name.as_str(), i))
            .collect();
        let n = self.processes.len();
        let mut deps: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (i, p) in self.processes.iter().enumerate() {
            for dep in &p.depends_on {
                let Some(&j) = index.get(dep.as_str()) else {
                    return Err(self.invalid(
                        format!("process.{}.depends_on", p.name),
                        dep,
                        "no process has this name",
                    ));
                };
                if !deps[i].contains(&j) {
                    deps[i].push(j);
                }
            }
        }
        let mut order = Vec::with_capacity(n);
        let mut started = vec![false; n];
        while order.len() < n {
            let next = (0..n).find(|&i| !started[i] && deps[i].iter().all(|&j| started[j]));
            match next {
                Some(i) => {
                    started[i] = true;
                    order.push(i);
                }
                None => {
                    let cycle = find_cycle(&deps, &started);
                    let names: Vec<&str> = cycle
                        .iter()
                        .map(|&i| self.processes[i].name.as_str())
                        .collect();
                    let first = names.first().copied().unwrap_or_default();
                    return Err(self.invalid(
                        format!("process.{first}.depends_on"),
                        &self.processes[cycle[0]].depends_on,
                        format!("dependency cycle: {} -> {first}", names.join(" -> ")),
                    ));
                }
            }
        }
        Ok(order)
    }

    /// The processes in start order.
    pub fn ordered(&self) -> impl Iterator<Item = &ProcessSpec> {
        self.start_order.iter().map(|&i| &self.processes[i])
    }

    /// `path` resolved against the profile's directory (absolute paths unchanged).
    pub fn relative_to_profile(&self, path: &Path) -> PathBuf {
        match self.file.parent() {
            Some(dir) if path.is_relative() => dir.join(path),
            _ => path.to_path_buf(),
        }
    }
}

/// A cycle among the processes not started yet (each of which waits for another one).
fn find_cycle(deps: &[Vec<usize>], started: &[bool]) -> Vec<usize> {
    let Some(mut current) = (0..deps.len()).find(|&i| !started[i]) else {
        return Vec::new();
    };
    let mut path = Vec::new();
    loop {
        if let Some(pos) = path.iter().position(|&i| i == current) {
            return path.split_off(pos);
        }
        path.push(current);
        match deps[current].iter().find(|&&j| !started[j]) {
            Some(&j) => current = j,
            None => return path,
        }
    }
}
