//! What a run is made of: the profile with the command line's overrides applied, the bus, the
//! roles and the CPUs, and what follows from them (each process's program, arguments,
//! environment and CPUs) before anything starts.

use std::path::{Path, PathBuf};

use testbed_bus::BusConfig;

use crate::placement;
use crate::profile::{ClockMode, Device, ProcessSpec, Profile, RunSettings, Source, Supervision};
use crate::roles::{RoleLinks, Roles};
use crate::supervisor::{
    ENV_DEVICE_PREFIX, ENV_RUN_CONFIG, ENV_RUN_DURATION_S, ENV_RUN_LOG, ENV_RUN_MODE,
    ENV_RUN_PROFILE, ENV_RUN_SEED,
};

/// Everything a run needs: the profile with command-line overrides applied.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The validated profile.
    pub profile: Profile,
    /// `[run]` after overrides.
    pub run: RunSettings,
    /// `[supervision]` after overrides.
    pub supervision: Supervision,
    /// The run's bus (prefix, root; delivery from the mode).
    pub bus: BusConfig,
    /// The roles a non-absolute `command` names, and where they are started from.
    pub roles: Roles,
    /// How the CPUs are shared out for the profile's `cpus` roles; None: every process runs
    /// wherever the scheduler puts it, whatever its `cpus` (`--unplaced`).
    pub cpu_roles: Option<placement::CpuRoles>,
}

impl Plan {
    /// The CPUs `spec` is pinned to in this run: its `cpus` with the roles shared out; None
    /// when it may run anywhere (no `cpus`, or the run is unplaced).
    pub fn affinity(&self, spec: &ProcessSpec) -> Option<Vec<usize>> {
        let roles = self.cpu_roles.as_ref()?;
        spec.cpus.as_ref().map(|cpus| cpus.resolve(roles))
    }

    /// CPUs named by a process's `cpus` that this launcher may not run on (so nor may its
    /// children): `(process, CPU, the CPUs available)`. None in an unplaced run.
    pub fn unavailable_cpus(&self) -> Vec<(String, usize, Vec<usize>)> {
        let Some(roles) = &self.cpu_roles else {
            return Vec::new();
        };
        let available = roles.available();
        self.profile
            .processes
            .iter()
            .flat_map(|spec| {
                self.affinity(spec)
                    .into_iter()
                    .flatten()
                    .filter(|cpu| !available.contains(cpu))
                    .map(|cpu| (spec.name.clone(), cpu, available.to_vec()))
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    /// The program that runs `spec`: an absolute `command` as written, a role its link.
    pub fn program(&self, spec: &ProcessSpec) -> PathBuf {
        let command = Path::new(&spec.command);
        if command.is_absolute() {
            command.to_path_buf()
        } else {
            self.roles.dir.join(command)
        }
    }

    /// What keeps processes of the profile from being started, one message each: an absolute
    /// `command` that is not an executable file, any other that names no role.
    pub fn unrunnable(&self) -> Vec<String> {
        use std::os::unix::fs::PermissionsExt as _;
        self.profile
            .ordered()
            .filter_map(|spec| {
                let command = Path::new(&spec.command);
                if !command.is_absolute() {
                    return (!self.roles.contains(&spec.command)).then(|| {
                        format!(
                            "process {:?}: command {:?} is neither a role of {} ({}) nor an absolute path",
                            spec.name,
                            spec.command,
                            self.roles.exe.display(),
                            self.roles.names.join(", ")
                        )
                    });
                }
                let runnable = std::fs::metadata(command)
                    .map(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
                    .unwrap_or(false);
                (!runnable).then(|| {
                    format!(
                        "process {:?}: no executable at {}",
                        spec.name,
                        command.display()
                    )
                })
            })
            .collect()
    }

    /// Makes the links the profile's roles are started by (see [`crate::roles`]).
    pub fn link_roles(&self) -> std::io::Result<RoleLinks> {
        let used = self
            .profile
            .processes
            .iter()
            .map(|spec| spec.command.as_str())
            .filter(|command| self.roles.contains(command));
        RoleLinks::create(&self.roles.dir, &self.roles.exe, used)
    }

    /// Removes every file of the run's bus, once no process is on it any more (one that is,
    /// such as a monitor a user started, keeps it: the files are removed by the last one).
    pub fn remove_bus(&self) {
        match testbed_bus::remove_all(&self.bus) {
            Ok(removed) => tracing::debug!("removed the {removed} files of the run's bus"),
            Err(e) => tracing::info!("the run's bus is kept: {e}"),
        }
    }

    /// The environment every child gets on top of the launcher's own (which passes `RUST_LOG`
    /// through), before the process's own `env`.
    pub fn run_env(&self) -> Vec<(String, String)> {
        let mut env: Vec<(String, String)> = self
            .bus
            .env_vars()
            .into_iter()
            .map(|(k, v)| (k.to_owned(), v))
            .collect();
        env.push((ENV_RUN_MODE.to_owned(), self.run.mode.as_str().to_owned()));
        env.push((ENV_RUN_SEED.to_owned(), self.run.seed.to_string()));
        if let Some(d) = self.run.duration_s {
            env.push((ENV_RUN_DURATION_S.to_owned(), d.to_string()));
        }
        if let Some(log) = &self.run.log {
            env.push((ENV_RUN_LOG.to_owned(), log.display().to_string()));
        }
        if let Some(config) = &self.run.config {
            let path = self.profile.relative_to_profile(config);
            env.push((ENV_RUN_CONFIG.to_owned(), path.display().to_string()));
        }
        let profile =
            std::fs::canonicalize(&self.profile.file).unwrap_or_else(|_| self.profile.file.clone());
        env.push((ENV_RUN_PROFILE.to_owned(), profile.display().to_string()));
        for device in Device::ALL {
            if let Some(source) = self.profile.devices.get(&device) {
                let key = format!("{ENV_DEVICE_PREFIX}{}", device.name().to_uppercase());
                env.push((key, source.as_str().to_owned()));
            }
        }
        env
    }

    /// Delivery mode for the run: lossless in lockstep, overflow when paced.
    pub fn delivery_for(mode: ClockMode) -> testbed_bus::Delivery {
        match mode {
            ClockMode::Lockstep => testbed_bus::Delivery::Lossless,
            ClockMode::Paced => testbed_bus::Delivery::Overflow,
        }
    }

    /// Whether any device of the run is real.
    pub fn has_real_devices(&self) -> bool {
        self.profile.devices.values().any(|s| *s == Source::Real)
    }
}
