//! The launcher's command line and main: the `testbed-launch` role of the `testbed` executable
//! (see [`crate::roles`]) starts, supervises and stops the pipeline processes of one launch
//! profile.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context as _, bail};
use clap::Parser;
use testbed_bus::BusConfig;

use crate::placement::{CPU_LATENCY_DEVICE, CpuLatencyRequest, CpuRoles, available_cpus};
use crate::profile::{ClockMode, Profile};
use crate::roles;
use crate::sys::{self, SignalSet};
use crate::{Plan, ProfileError, Supervisor};

/// Environment variable naming the PM QoS device instead of `/dev/cpu_dma_latency` (tests; a
/// system with the interface elsewhere).
const CPU_LATENCY_DEVICE_ENV: &str = "TESTBED_CPU_LATENCY_DEVICE";

/// Exit status for an unusable profile or command line.
const EXIT_CONFIG: u8 = 2;

/// The launcher's command line.
#[derive(Debug, Parser)]
#[command(
    name = roles::LAUNCHER,
    version,
    about = "Start, supervise and stop the test bed pipeline of a launch profile"
)]
pub struct Args {
    /// Launch profile (TOML), e.g. launch/profiles/simulation.toml.
    profile: PathBuf,
    /// Override [run] mode.
    #[arg(long, value_parser = ["lockstep", "paced"])]
    mode: Option<String>,
    /// Override [run] duration_s.
    #[arg(long)]
    duration_s: Option<f64>,
    /// Override [run] seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Override [run] log.
    #[arg(long)]
    log: Option<PathBuf>,
    /// Override [run] config (relative to the working directory).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Override [run] max_wall_s.
    #[arg(long)]
    max_wall_s: Option<f64>,
    /// Override [platform] cpu_latency_us: hold a PM QoS CPU latency request of this many µs
    /// for the run (0: idle CPUs poll; needs root).
    #[arg(long, value_name = "US")]
    cpu_latency_us: Option<u32>,
    /// Override [supervision] stop_timeout_s (SIGINT → SIGTERM).
    #[arg(long)]
    stop_timeout_s: Option<f64>,
    /// Override [supervision] term_timeout_s (SIGTERM → SIGKILL).
    #[arg(long)]
    term_timeout_s: Option<f64>,
    /// iceoryx2 prefix of the run [default: $TESTBED_BUS_PREFIX or testbed_].
    #[arg(long)]
    bus_prefix: Option<String>,
    /// iceoryx2 root directory of the run [default: $TESTBED_BUS_ROOT or /tmp/iceoryx2/].
    #[arg(long)]
    bus_root: Option<PathBuf>,
    /// Run every process wherever the scheduler puts it: ignore the profile's `cpus` (to
    /// measure what the placement gives, or on a machine shared with other work).
    #[arg(long)]
    unplaced: bool,
    /// Validate the profile, print the start order and exit.
    #[arg(long)]
    check: bool,
    /// Stop the run (as on SIGTERM) when process PID is no longer the launcher's parent:
    /// `testbed run` passes its own pid, so the pipeline never outlives it (and, the run's
    /// processes gone, the launcher removes its bus, which `testbed run` no longer can).
    #[arg(long, value_name = "PID")]
    exit_with_parent: Option<i32>,
}

impl Plan {
    /// The plan of `args`: the profile with the command line's overrides, the bus from the
    /// environment and the command line, the roles the `testbed` executable plays (`role_names`:
    /// the names a profile's non-absolute `command` may give). `Ok(Err)` for a profile error.
    pub fn from_args(
        args: &Args,
        role_names: &[&str],
    ) -> anyhow::Result<Result<Plan, ProfileError>> {
        let mut profile = match Profile::load(&args.profile) {
            Ok(p) => p,
            Err(e) => return Ok(Err(e)),
        };
        let mut run = profile.run.clone();
        if let Some(mode) = &args.mode {
            run.mode = if mode == "lockstep" {
                ClockMode::Lockstep
            } else {
                ClockMode::Paced
            };
        }
        let mut supervision = profile.supervision;
        let overrides = [
            ("--duration-s", args.duration_s, false),
            ("--max-wall-s", args.max_wall_s, false),
            ("--stop-timeout-s", args.stop_timeout_s, true),
            ("--term-timeout-s", args.term_timeout_s, true),
        ];
        for (key, value, allow_zero) in overrides {
            if let Some(v) = value
                && let Err(e) = profile.check_seconds(key, v, allow_zero)
            {
                return Ok(Err(e));
            }
        }
        run.duration_s = args.duration_s.or(run.duration_s);
        run.max_wall_s = args.max_wall_s.or(run.max_wall_s);
        run.seed = args.seed.unwrap_or(run.seed);
        run.log = args.log.clone().or(run.log);
        if let Some(config) = &args.config {
            // Absolute, so that it is not taken relative to the profile.
            let cwd = std::env::current_dir().context("reading the working directory")?;
            run.config = Some(cwd.join(config));
        }
        if let Some(us) = args.cpu_latency_us
            && let Err(e) = profile.check_cpu_latency("--cpu-latency-us", us)
        {
            return Ok(Err(e));
        }
        supervision.stop_timeout_s = args.stop_timeout_s.unwrap_or(supervision.stop_timeout_s);
        supervision.term_timeout_s = args.term_timeout_s.unwrap_or(supervision.term_timeout_s);

        let mut bus =
            BusConfig::from_env().context("reading TESTBED_BUS_* from the environment")?;
        if let Some(prefix) = &args.bus_prefix {
            bus.prefix.clone_from(prefix);
        }
        if let Some(root) = &args.bus_root {
            bus.root.clone_from(root);
        }
        bus.delivery = Plan::delivery_for(run.mode);
        bus.validate().context("bus configuration")?;

        let roles = roles::Roles {
            names: role_names.iter().map(|&name| name.to_owned()).collect(),
            dir: roles::links_dir(&bus),
            exe: std::env::current_exe().context("locating the launcher's executable")?,
        };
        profile.platform.cpu_latency_us = args.cpu_latency_us.or(profile.platform.cpu_latency_us);
        let cpu_roles = if args.unplaced {
            None
        } else {
            let available = available_cpus().context("reading this launcher's CPU affinity")?;
            match CpuRoles::new(available, profile.platform.hot_path_cpu) {
                Ok(roles) => Some(roles),
                Err(reason) => {
                    return Ok(Err(ProfileError::Invalid {
                        file: profile.file.display().to_string(),
                        key: "platform.hot_path_cpu".into(),
                        value: profile
                            .platform
                            .hot_path_cpu
                            .map_or_else(|| "(none)".to_string(), |cpu| cpu.to_string()),
                        reason,
                    }));
                }
            }
        };
        let plan = Plan {
            profile,
            run,
            supervision,
            bus,
            roles,
            cpu_roles,
        };
        if plan.run.mode == ClockMode::Lockstep && plan.has_real_devices() {
            bail!("--mode lockstep: the profile has real devices, which cannot run in lockstep");
        }
        Ok(Ok(plan))
    }
}

/// The launcher's main: `role_names` are the names of the roles of this executable (which a
/// profile's non-absolute `command` names; see [`crate::roles`]).
pub fn main(role_names: &[&str]) -> ExitCode {
    // Before anything else (and before any thread exists): the launcher takes its signals
    // synchronously; children get a clean mask.
    let signals = match SignalSet::block(&sys::WAITED) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("testbed-launch: cannot block signals: {e}");
            return ExitCode::from(1);
        }
    };
    testbed_bus::init_logging();
    let args = Args::parse();
    if let Some(parent) = args.exit_with_parent
        && let Err(e) = sys::stop_when_orphaned(parent)
    {
        tracing::error!("cannot watch the parent process {parent}: {e}");
        return ExitCode::from(1);
    }
    let plan = match Plan::from_args(&args, role_names) {
        Ok(Ok(plan)) => plan,
        Ok(Err(e)) => {
            tracing::error!("invalid profile: {e}");
            return ExitCode::from(EXIT_CONFIG);
        }
        Err(e) => {
            tracing::error!("{e:#}");
            return ExitCode::from(EXIT_CONFIG);
        }
    };
    let unrunnable = plan.unrunnable();
    if args.check {
        for (i, spec) in plan.profile.ordered().enumerate() {
            let cpus = plan
                .affinity(spec)
                .map(|cpus| format!("  (CPUs {cpus:?})"))
                .unwrap_or_default();
            println!(
                "{:>2}. {:<24} {} {}{cpus}",
                i + 1,
                spec.name,
                spec.command,
                spec.args.join(" ")
            );
        }
    }
    if !unrunnable.is_empty() {
        for problem in &unrunnable {
            tracing::error!("{problem}");
        }
        return ExitCode::from(EXIT_CONFIG);
    }
    let unavailable = plan.unavailable_cpus();
    if !unavailable.is_empty() {
        for (name, cpu, available) in &unavailable {
            tracing::error!(
                "{}: process.{name}.cpus names CPU {cpu}, which this launcher may not use (CPUs {available:?})",
                plan.profile.file.display()
            );
        }
        return ExitCode::from(EXIT_CONFIG);
    }
    if args.check {
        return ExitCode::SUCCESS;
    }
    if let Some(roles) = &plan.cpu_roles
        && plan.profile.processes.iter().any(|p| p.cpus.is_some())
    {
        tracing::info!(
            "placement: the hot path on CPU {}, the background on CPUs {:?}",
            roles.hot_path(),
            roles.background()
        );
    }
    // Held until the launcher exits: the kernel ends the request with the file.
    let device = std::env::var_os(CPU_LATENCY_DEVICE_ENV)
        .filter(|d| !d.is_empty())
        .map_or_else(|| PathBuf::from(CPU_LATENCY_DEVICE), PathBuf::from);
    let request = plan
        .profile
        .platform
        .cpu_latency_us
        .map(|us| CpuLatencyRequest::hold_at(&device, us));
    let _cpu_latency = match request {
        None => None,
        Some(Ok(request)) => {
            tracing::info!(
                "holding CPU latency {} µs for the run ({})",
                request.latency_us(),
                device.display()
            );
            Some(request)
        }
        Some(Err(e)) => {
            tracing::error!(
                "{}: platform.cpu_latency_us: {e}",
                plan.profile.file.display()
            );
            return ExitCode::from(EXIT_CONFIG);
        }
    };
    tracing::info!(
        "profile {}: mode {}, bus prefix {:?} root {:?} ({} delivery), {} processes",
        plan.profile.file.display(),
        plan.run.mode,
        plan.bus.prefix,
        plan.bus.root_string(),
        plan.bus.delivery,
        plan.profile.processes.len()
    );
    let links = match plan.link_roles() {
        Ok(links) => links,
        Err(e) => {
            tracing::error!("cannot make the links the processes are started by: {e}");
            return ExitCode::from(1);
        }
    };
    let outcome = Supervisor::new(&plan, &signals).run();
    // The run's processes are gone: leave nothing of its bus behind (`testbed run` would, but
    // the launcher outlives it when it is killed).
    drop(links);
    plan.remove_bus();
    ExitCode::from(u8::try_from(outcome.exit_code).unwrap_or(1))
}
