//! `testbed run`: launch the pipeline of a profile as real processes, then summarise its log.
//!
//! The run configuration every process reads is assembled here (the profile's `[run] config`
//! file or the defaults, with the profile's and the command line's mode, duration, seed and log)
//! and written beside the log; `testbed-launch` starts, supervises and stops the processes.

use crate::figure::{self, Panel, Series};
use crate::progress;
use crate::summary::{self, RunSeries, RunSummary};
use anyhow::{Context, Result, bail};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};
use std::process::Command;
use testbed_launch::profile::Profile;
use testbed_runtime::{ClockMode, RunConfig};

#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Launch profile: a name in launch/profiles (simulation, can-sim, replay, can-replay,
    /// platform, mixed) or a path to a TOML file.
    #[arg(long, default_value = "simulation", value_name = "NAME|FILE")]
    pub profile: String,
    /// Simulated duration, s [default: the profile's].
    #[arg(long, value_name = "S", allow_negative_numbers = true, value_parser = positive_seconds)]
    pub duration: Option<f64>,
    /// Seed of the simulated devices' noise, 0 to 2^64-1 [default: the profile's].
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = seed)]
    pub seed: Option<u64>,
    /// MCAP log of the run [default: the profile's]; the run configuration (.run.toml) and the
    /// figure (.svg, .png) are written beside it.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Run configuration (TOML: model, estimator, controller, manoeuvre, CAN) instead of the
    /// profile's `[run] config` [default: the profile's, else the built-in defaults].
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Clock mode: lockstep or paced [default: the profile's].
    #[arg(long, value_name = "lockstep|paced", conflicts_with = "paced")]
    pub mode: Option<ClockMode>,
    /// Run at 1× wall time instead of lockstep (same as --mode paced).
    #[arg(long)]
    pub paced: bool,
    /// Stop the run after this much wall time, s (the launcher's max_wall_s) [default: the
    /// profile's, else none].
    #[arg(long, value_name = "S", allow_negative_numbers = true, value_parser = positive_seconds)]
    pub max_wall: Option<f64>,
    /// Hold a PM QoS CPU latency request of this many µs for the run (the profile's `[platform]
    /// cpu_latency_us`): 0 keeps idle CPUs polling, so a sleeping process wakes faster, at
    /// the idle CPUs' power; needs root [default: the profile's, else none].
    #[arg(long, value_name = "US")]
    pub cpu_latency_us: Option<u32>,
    /// Run every process wherever the scheduler puts it, ignoring the profile's `cpus` (by
    /// default the processes of a tick share one CPU and the logger and ground link use the
    /// others: `cpus = "hot-path"` / `"background"`).
    #[arg(long)]
    pub unplaced: bool,
    /// Dry run: check the profile, the run configuration and the binaries, print the run's
    /// settings and the processes in start order, and start nothing (writes no file).
    #[arg(long)]
    pub check: bool,
    /// Feed this log's recorded inputs into the estimator and controller instead of simulating
    /// (with a profile that runs the `replay` process; default profile then: replay). The
    /// recorded run configuration is used, so the estimator and controller are set up as they were.
    #[arg(long, value_name = "LOG", conflicts_with = "replay_candump")]
    pub replay: Option<PathBuf>,
    /// Put the CAN bus traffic this log's run recorded (the `.candump.log` file beside it) back
    /// through the real sensor gateways into the estimator (default profile then: can-replay),
    /// with the recorded run configuration; the summary compares the estimates with the log's.
    #[arg(long, value_name = "LOG")]
    pub replay_candump: Option<PathBuf>,
    /// Wall-clock start of the run written in the log, ns since the Unix epoch [default: now].
    /// Pin it to reproduce a log byte for byte.
    #[arg(long, value_name = "NS")]
    pub start_time_ns: Option<u64>,
    /// Print the summary as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// No progress display while the pipeline runs.
    #[arg(long)]
    pub no_progress: bool,
}

/// `--duration`, `--max-wall`: a positive, finite number of seconds.
fn positive_seconds(text: &str) -> std::result::Result<f64, String> {
    let value: f64 = text
        .parse()
        .map_err(|_| "not a number of seconds".to_string())?;
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err("must be a positive number of seconds".to_string())
    }
}

/// `--seed`: a whole number 0 ..= 2^64 - 1, said so when negative.
fn seed(text: &str) -> std::result::Result<u64, String> {
    text.parse().map_err(|_| {
        if text.starts_with('-') {
            "a seed is a whole number from 0 to 18446744073709551615, not negative".to_string()
        } else {
            "a seed is a whole number from 0 to 18446744073709551615".to_string()
        }
    })
}

impl RunArgs {
    /// The profile this command line runs: `--profile`, or the replay profiles for `--replay`
    /// and `--replay-candump` when no other profile is named.
    pub fn profile_name(&self) -> &str {
        match (&self.replay, &self.replay_candump, self.profile.as_str()) {
            (Some(_), _, "simulation") => "replay",
            (_, Some(_), "simulation") => "can-replay",
            (_, _, name) => name,
        }
    }
}

pub fn run(args: &RunArgs) -> Result<()> {
    let profile_path = find_profile(args.profile_name())?;
    let profile = Profile::load(&profile_path)?;
    let recorded_log = args.replay.as_ref().or(args.replay_candump.as_ref());
    let paced = args.paced || args.mode == Some(ClockMode::Paced);
    let mut config = match (recorded_log, &args.config, &profile.run.config) {
        (Some(source), _, _) => recorded_config(source)?,
        (None, Some(path), _) => RunConfig::load(path)?,
        (None, None, Some(path)) => RunConfig::load(&profile.relative_to_profile(path))?,
        (None, None, None) => RunConfig::default(),
    };
    if recorded_log.is_some() && paced {
        bail!(
            "--replay and --replay-candump run in lockstep (the replay owns the clock); drop --paced / --mode paced"
        );
    }
    if recorded_log.is_some() && args.config.is_some() {
        bail!("--replay and --replay-candump use the recorded run configuration; drop --config");
    }
    if let Some(source) = &args.replay_candump {
        let candump = source.with_extension("candump.log");
        if !candump.is_file() {
            bail!(
                "--replay-candump {}: no {} beside it (record the run with can.record_candump = true)",
                source.display(),
                candump.display()
            );
        }
        config.can.candump = Some(candump);
        config.can.record_candump = false;
    }
    config.run.profile = profile_path.file_stem().map_or_else(
        || args.profile.clone(),
        |s| s.to_string_lossy().into_owned(),
    );
    config.run.mode = match (args.mode, args.paced) {
        (Some(mode), _) => mode,
        (None, true) => ClockMode::Paced,
        (None, false) => profile.run.mode,
    };
    if recorded_log.is_none() {
        if let Some(d) = args.duration.or(profile.run.duration_s) {
            config.run.duration_s = d;
        }
        config.run.seed = args.seed.unwrap_or(profile.run.seed);
    }
    // A replay is a run of its own: its log starts now, not when the recorded run did.
    config.run.start_time_ns = Some(args.start_time_ns.unwrap_or_else(testbed_log::unix_time_ns));
    config.run.replay = args.replay.clone();
    if let Some(log) = args.log.clone().or_else(|| profile.run.log.clone()) {
        config.run.log = log;
    }
    // The clock owner (plant or replay: the process that ends the run) waits for all the others.
    config.run.participants = profile
        .processes
        .iter()
        .filter(|p| !p.ends_run && !p.observer)
        .map(|p| p.name.clone())
        .collect();
    config.validate("command line")?;
    let ends_by_duration = recorded_log.is_none() && profile.processes.iter().any(|p| p.ends_run);
    let max_wall = args.max_wall.or(profile.run.max_wall_s);
    let overrides = LauncherOverrides {
        max_wall_s: max_wall,
        cpu_latency_us: args.cpu_latency_us,
        unplaced: args.unplaced,
    };

    let log = config.run.log.clone();
    let config_path = log.with_extension("run.toml");
    if args.check {
        println!(
            "profile {} ({}): mode {}, seed {}, {}, log {}, configuration {}{}",
            config.run.profile,
            profile_path.display(),
            config.run.mode.as_str(),
            config.run.seed,
            if ends_by_duration {
                format!("{} simulated s", config.run.duration_s)
            } else {
                "until the source ends or Ctrl-C".to_string()
            },
            log.display(),
            config_path.display(),
            max_wall.map_or_else(String::new, |s| format!(", at most {s} s wall time")),
        );
        return launch(&profile_path, &config, None, &overrides, true, None, None);
    }
    if let Some(dir) = log.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // Held (by this process, the launcher and every pipeline process) until the run's last
    // process is gone: a second run on the same log is refused instead of overwriting it.
    let run_lock = RunLock::acquire(&config_path, &log)?;
    run_lock
        .write(config.to_toml_string().as_bytes())
        .with_context(|| format!("writing the run configuration {}", config_path.display()))?;
    let replay_source = match &args.replay {
        Some(source) => Some(
            testbed_log::RunLog::open(source)
                .with_context(|| format!("opening the log to replay {}", source.display()))?,
        ),
        None => None,
    };

    let follow = (!args.no_progress).then(|| progress::Follow {
        log: log.clone(),
        duration_s: ends_by_duration.then_some(config.run.duration_s),
        target: config.manoeuvre.target(),
    });
    let launched = launch(
        &profile_path,
        &config,
        Some(&config_path),
        &overrides,
        false,
        follow,
        Some(&run_lock),
    );

    if let Some(source) = &args.replay_candump {
        launched?;
        let comparison = summary::compare_estimates(source, &log)?;
        if args.json {
            let mut value = serde_json::to_value(comparison)?;
            value["config"] = serde_json::json!(config_path.display().to_string());
            println!("{}", serde_json::to_string_pretty(&value)?);
        } else {
            println!(
                "CAN replay of {}: {} estimates replayed, {} recorded, {} identical bit for bit; log {}",
                source.display(),
                comparison.replayed,
                comparison.recorded,
                comparison.identical,
                log.display()
            );
        }
        return Ok(());
    }

    // A failed pipeline still leaves a readable log: summarise what was recorded, then fail.
    let summarised = summary::summarise(&log, ends_by_duration.then_some(config.run.duration_s));
    // A logger that died leaves a log cut mid-record, which readers that start from the footer
    // (Python's make_reader, viewers) refuse: make it complete, keeping every complete record.
    let repaired = repair_if_cut(&log);
    let (summary, series, _) = match summarised {
        Ok(s) => s,
        Err(e) => return Err(launched.err().unwrap_or(e)),
    };
    let replay_warning = replay_source.as_ref().and_then(replay_cut_warning);
    if let Some(warning) = &replay_warning {
        eprintln!("warning: {warning}");
    }
    let title = format!(
        "testbed run: profile {}, seed {}. errors are rotation vectors in body axes (truth vs target, estimate vs truth)",
        config.run.profile, config.run.seed
    );
    let figures =
        figure::write_figure(&log.with_extension(""), &title, &panels(&series, &summary))?;
    if args.json {
        let mut value = serde_json::to_value(&summary)?;
        value["figure"] = serde_json::json!(figures[0].display().to_string());
        value["figures"] = serde_json::json!(
            figures
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
        );
        value["config"] = serde_json::json!(config_path.display().to_string());
        if let Some(report) = &repaired {
            value["log_repaired"] = serde_json::json!({
                "messages": report.messages,
                "until_s": report.last_time_ns as f64 * 1e-9,
                "dropped_bytes": report.dropped_bytes,
            });
        }
        if let Some(warning) = &replay_warning {
            value["replay_source_cut"] = serde_json::json!(warning);
        }
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print_summary(&summary, &figures);
        if let Some(report) = &repaired {
            println!(
                "  log repaired         {} complete messages kept (up to t = {:.3} s), {} bytes of a cut record dropped",
                report.messages,
                report.last_time_ns as f64 * 1e-9,
                report.dropped_bytes
            );
        }
    }
    drop(run_lock);
    launched?;
    if summary.health.safe_mode_entries > 0 && !profile.supervision.tolerate_safe_mode {
        anyhow::bail!(
            "the controller entered safe mode {} time(s) during the run (see its health above); a profile that expects this sets `[supervision] tolerate_safe_mode = true`",
            summary.health.safe_mode_entries
        );
    }
    Ok(())
}

/// Repairs the log in place when it was cut (the logger died); says what it did on stderr.
fn repair_if_cut(log: &Path) -> Option<testbed_log::RepairReport> {
    match testbed_log::RunLog::open(log) {
        Ok(opened) if !opened.is_complete() => {}
        _ => return None,
    }
    match crate::log::repair(log, log) {
        Ok(report) => {
            eprintln!(
                "note: the log was not finalised (its logger died); {}",
                crate::log::describe(log, &report)
            );
            Some(report)
        }
        Err(e) => {
            eprintln!(
                "warning: the log {} was not finalised and could not be repaired ({}); every complete record is still readable by a streaming reader; retry with `testbed log repair {}`",
                log.display(),
                crate::errors::report(&e),
                log.display()
            );
            None
        }
    }
}

/// For a replayed log that was cut: how much of it the replay covered.
fn replay_cut_warning(source: &testbed_log::RunLog) -> Option<String> {
    let testbed_log::LogEnd::Truncated { offset, file_len } = source.end() else {
        return None;
    };
    let until_ns = source
        .records()
        .ok()?
        .flatten()
        .map(|r| r.header().time_ns)
        .max()
        .unwrap_or(0);
    Some(format!(
        "the replayed log {} was cut (not finalised: its logger died or the file was truncated): complete records end at byte {offset} of {file_len}; replayed its {} complete messages, up to t = {:.3} s of the recorded run; what came after was never recorded",
        source.path().display(),
        source.message_count(),
        until_ns as f64 * 1e-9
    ))
}

/// The run configuration a log was recorded with.
fn recorded_config(log: &Path) -> Result<RunConfig> {
    let recorded = testbed_log::RunLog::open(log)
        .with_context(|| format!("opening the log to replay {}", log.display()))?;
    Ok(RunConfig::from_toml_str(
        recorded.config_toml(),
        &format!("{} (config.toml attachment)", log.display()),
    )?)
}

/// Start `testbed-launch` (next to this executable) on the profile and wait for it; with
/// `check`, only its dry run (`--check`: profile, binaries, start order).
///
/// While the launcher runs, this process takes SIGINT, SIGTERM and SIGHUP and forwards them to
/// it (the launcher then stops the pipeline and finalises the log); the launcher stops the run
/// as on SIGTERM if this process dies (`--exit-with-parent`), and its own children get SIGTERM
/// when it dies (PR_SET_PDEATHSIG), so the pipeline never outlives `testbed`. This process is the pipeline's subreaper: it waits for
/// every process of the run, even those a killed launcher orphaned, before removing the bus.
/// Settings of `testbed run` passed on to the launcher over the profile's.
struct LauncherOverrides {
    /// `--max-wall-s`, s.
    max_wall_s: Option<f64>,
    /// `--cpu-latency-us`, µs.
    cpu_latency_us: Option<u32>,
    /// `--unplaced`.
    unplaced: bool,
}

fn launch(
    profile: &Path,
    config: &RunConfig,
    config_path: Option<&Path>,
    overrides: &LauncherOverrides,
    check: bool,
    follow: Option<progress::Follow>,
    run_lock: Option<&RunLock>,
) -> Result<()> {
    let exe = std::env::current_exe().context("locating the testbed executable")?;
    let bin_dir = exe
        .parent()
        .context("the testbed executable has no directory")?;
    let launcher = bin_dir.join("testbed-launch");
    if !launcher.exists() {
        bail!(
            "{} not found: build the pipeline first (launch/launch.sh does; or cargo build --profile deploy -p testbed-cli -p testbed-processes -p testbed-launch, or --release)",
            launcher.display()
        );
    }
    let mut command = Command::new(&launcher);
    if std::env::var_os("RUST_LOG").is_none() {
        // The summary is the output; the processes speak up only for warnings.
        command.env("RUST_LOG", "warn");
    }
    command
        .arg(profile)
        .args(["--mode", config.run.mode.as_str()])
        .args(["--duration-s", &config.run.duration_s.to_string()])
        .args(["--seed", &config.run.seed.to_string()])
        .arg("--log")
        .arg(&config.run.log)
        .arg("--bin-dir")
        .arg(bin_dir);
    if let Some(path) = config_path {
        command.arg("--config").arg(path);
    }
    if let Some(s) = overrides.max_wall_s {
        command.args(["--max-wall-s", &s.to_string()]);
    }
    if let Some(us) = overrides.cpu_latency_us {
        command.args(["--cpu-latency-us", &us.to_string()]);
    }
    if overrides.unplaced {
        command.arg("--unplaced");
    }
    if check {
        command.arg("--check");
        let status = command
            .status()
            .with_context(|| format!("starting {}", launcher.display()))?;
        if !status.success() {
            bail!("the check failed ({status}); the launcher's messages above say what is wrong");
        }
        return Ok(());
    }
    // Buses of earlier runs whose `testbed` died (SIGKILL, crash) are collected first.
    let collected = testbed_bus::collect_dead_runs(Path::new(BUS_BASE), BUS_TAG);
    for failed in &collected.failed {
        eprintln!("warning: cannot remove the bus of a dead earlier run: {failed}");
    }
    // One private bus per run: a fresh directory (mode 0700, unpredictable name) as the root,
    // its name as the prefix of every shared-memory file (short: Unix socket paths < 108 bytes).
    let private = testbed_bus::PrivateRun::create(Path::new(BUS_BASE), BUS_TAG)
        .context("creating the run's private bus directory")?;
    command
        .args(["--bus-prefix", &private.bus.prefix])
        .arg("--bus-root")
        .arg(&private.bus.root);
    // The ground link (issue 13): a command token for this run unless one is configured, and
    // the address it serves printed once it listens.
    let ground_info = Profile::load(profile)
        .ok()
        .filter(|p| p.processes.iter().any(|p| p.command == "ground-link"))
        .map(|_| config.run.log.with_extension("ground.json"));
    if let Some(info) = &ground_info {
        let _ = std::fs::remove_file(info);
        if config.ground.token.is_none() {
            command.env(
                testbed_runtime::ground::ENV_GROUND_TOKEN,
                random_token().context("making the ground command token")?,
            );
        }
    }
    let result = supervise_launcher(&mut command, &launcher, follow, run_lock, ground_info);
    // Every process of the run has been reaped: leave no shared memory, socket or directory.
    if let Err(e) = private.remove() {
        eprintln!("warning: removing the run's iceoryx2 resources: {e}");
    }
    let status = result?;
    if !status.success() {
        bail!(
            "the pipeline failed ({status}); the launcher's messages above say which process and how"
        );
    }
    Ok(())
}

/// 128 random bits from the OS, hex: the run's ground command token.
fn random_token() -> std::io::Result<String> {
    use std::io::Read as _;
    let mut bytes = [0u8; 16];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Waits (up to a minute) for the ground link's `<log>.ground.json` and prints the ground
/// page's address and the command token on stderr.
fn print_ground_info(info: &Path) {
    let start = std::time::Instant::now();
    while start.elapsed() < std::time::Duration::from_secs(60) {
        if let Some(v) = std::fs::read(info)
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        {
            let field = |k: &str| v[k].as_str().unwrap_or("?").to_owned();
            eprintln!(
                "ground station: {}  (Foxglove WebSocket {}; command token {})",
                field("url"),
                field("ws"),
                field("token")
            );
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
}

/// Directory of the runs' private bus roots, and the start of their names (`/tmp/tb<pid>_…`).
const BUS_BASE: &str = "/tmp";
const BUS_TAG: &str = "tb";
/// How long the processes a dead launcher left get to end (they got SIGTERM) before SIGKILL.
const ORPHAN_WAIT: std::time::Duration = std::time::Duration::from_secs(10);

/// Starts the launcher, forwards stop signals to it, waits for it and then for every process
/// it left (see [`launch`]).
fn supervise_launcher(
    command: &mut Command,
    launcher: &Path,
    follow: Option<progress::Follow>,
    run_lock: Option<&RunLock>,
    ground_info: Option<PathBuf>,
) -> Result<std::process::ExitStatus> {
    use std::os::unix::process::CommandExt as _;
    use testbed_launch::sys::{self, SignalSet};
    // SAFETY: prctl(PR_SET_CHILD_SUBREAPER) only changes this process's attributes.
    if unsafe { libc::prctl(libc::PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) } != 0 {
        eprintln!(
            "warning: cannot become the pipeline's subreaper: {}",
            std::io::Error::last_os_error()
        );
    }
    // Before any thread exists (the progress display starts below): signals are taken
    // synchronously; the launcher gets an empty mask (prepare_child).
    let signals = SignalSet::block(&[sys::SIGINT, sys::SIGTERM, sys::SIGHUP, sys::SIGCHLD])
        .context("blocking the stop signals")?;
    // SAFETY: getpid has no preconditions.
    let parent = unsafe { libc::getpid() };
    let lock_fd = run_lock.map(RunLock::raw_fd);
    // The launcher stops the run when this process dies (even by SIGKILL); see
    // sys::stop_when_orphaned for why not PR_SET_PDEATHSIG.
    command.args(["--exit-with-parent", &parent.to_string()]);
    // SAFETY: the closure makes only async-signal-safe calls (sigprocmask, fcntl).
    unsafe {
        command.pre_exec(move || {
            sys::unblock_all()?;
            if let Some(fd) = lock_fd {
                // Inherited across exec by the launcher and its children: the run keeps the
                // log locked until its last process is gone, even if this one dies first.
                if libc::fcntl(fd, libc::F_SETFD, 0) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
            }
            Ok(())
        });
    }
    // Own process group: a Ctrl-C in the terminal reaches this process only, which forwards it
    // once (the launcher takes a second stop signal as "kill the rest at once").
    command.process_group(0);
    let mut child = match command.spawn() {
        Ok(child) => child,
        Err(e) => {
            let _ = signals.unblock();
            return Err(e).with_context(|| format!("starting {}", launcher.display()));
        }
    };
    let launcher_pid = libc::pid_t::try_from(child.id()).unwrap_or(libc::pid_t::MAX);
    let progress = follow.map(progress::Progress::start);
    if let Some(info) = ground_info {
        // Detached: it ends by itself once it printed, or after a minute.
        let _ = std::thread::Builder::new()
            .name("ground-info".into())
            .spawn(move || print_ground_info(&info));
    }
    let status = loop {
        // SIGCHLD ends the wait as soon as the launcher exits: every thread of this process
        // blocks it (the mask is set before any thread starts), so it stays pending until this
        // wait takes it. The timeout is only a fallback, and long: each wake-up of this loop is
        // CPU of the run (a paced run's whole pipeline is some 0.6 % of a core).
        match signals.wait(Some(std::time::Duration::from_secs(10))) {
            Ok(Some(signal)) if signal != sys::SIGCHLD => {
                // SAFETY: kill(2) on our own child, not yet reaped (its pid cannot be reused).
                unsafe { libc::kill(launcher_pid, signal) };
            }
            Ok(_) => {}
            Err(e) => eprintln!("warning: waiting for signals: {e}"),
        }
        match child.try_wait() {
            Ok(Some(status)) => break Ok(status),
            Ok(None) => {}
            Err(e) => break Err(e),
        }
    };
    wait_for_orphans();
    if let Some(progress) = progress {
        progress.finish();
    }
    let _ = signals.unblock();
    status.with_context(|| format!("waiting for {}", launcher.display()))
}

/// Reaps the processes a dead launcher left (reparented to this subreaper; they got SIGTERM
/// from PR_SET_PDEATHSIG), killing those still running after [`ORPHAN_WAIT`].
fn wait_for_orphans() {
    let deadline = std::time::Instant::now() + ORPHAN_WAIT;
    let mut killed = false;
    loop {
        let mut status = 0;
        // SAFETY: waitpid writes the status it is given.
        let pid = unsafe { libc::waitpid(-1, &mut status, libc::WNOHANG) };
        match pid {
            p if p > 0 => continue,
            0 => {}
            _ => return, // ECHILD: no child left
        }
        if !killed && std::time::Instant::now() >= deadline {
            for orphan in own_children() {
                eprintln!("warning: pipeline process {orphan} did not stop; killing it");
                // SAFETY: kill(2) on our own child, not yet reaped (its pid cannot be reused).
                unsafe { libc::kill(orphan, libc::SIGKILL) };
            }
            killed = true;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// The pids whose parent is this process (from /proc).
fn own_children() -> Vec<libc::pid_t> {
    let me = std::process::id().to_string();
    std::fs::read_dir("/proc")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<libc::pid_t>().ok())
        .filter(|pid| {
            // /proc/<pid>/stat: "pid (comm) state ppid ..."; comm may hold spaces and ')'.
            std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
                stat.rsplit_once(')')
                    .and_then(|(_, rest)| rest.split_whitespace().nth(1).map(|p| p == me))
                    .unwrap_or(false)
            })
        })
        .collect()
}

/// The lock of one run on its log: an exclusive `flock` on the run configuration file beside
/// the log (`<log>.run.toml`), which every run writes anyway, so no extra file is left.
pub struct RunLock {
    file: std::fs::File,
}

impl RunLock {
    /// Locks `config_path` (creating it, not truncating it yet); refuses, naming the log, when
    /// another run holds it.
    fn acquire(config_path: &Path, log: &Path) -> Result<Self> {
        use std::os::fd::AsRawFd as _;
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(config_path)
            .with_context(|| format!("opening the run configuration {}", config_path.display()))?;
        // SAFETY: flock on a file descriptor this function owns.
        if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            let e = std::io::Error::last_os_error();
            if e.raw_os_error() == Some(libc::EWOULDBLOCK) {
                bail!(
                    "another testbed run is using the log {} (its run configuration {} is locked): wait for it to end, or give this run another --log",
                    log.display(),
                    config_path.display()
                );
            }
            return Err(e).with_context(|| format!("locking {}", config_path.display()));
        }
        Ok(Self { file })
    }

    /// Replaces the file's content (the lock stays: same open file).
    fn write(&self, bytes: &[u8]) -> std::io::Result<()> {
        use std::io::Write as _;
        let mut file = &self.file;
        file.set_len(0)?;
        std::io::Seek::seek(&mut file, std::io::SeekFrom::Start(0))?;
        file.write_all(bytes)
    }

    fn raw_fd(&self) -> libc::c_int {
        use std::os::fd::AsRawFd as _;
        self.file.as_raw_fd()
    }
}

/// Where profiles are looked up by name: `$TESTBED_PROFILES`, then `launch/profiles` of the
/// source tree the executable was built in, then `launch/profiles` in the working directory.
pub fn profile_dirs() -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::env::var_os("TESTBED_PROFILES")
        .map(PathBuf::from)
        .into_iter()
        .collect();
    if let Some(root) = std::env::current_exe()
        .ok()
        .and_then(|e| e.ancestors().nth(3).map(Path::to_path_buf))
    {
        dirs.push(root.join("launch/profiles")); // <root>/target/<profile>/testbed
    }
    dirs.push(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../launch/profiles"));
    dirs.push(PathBuf::from("launch/profiles"));
    dirs
}

/// The profile names (`*.toml` stems) in `dir`, sorted.
pub fn profile_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect();
    names.sort();
    names
}

/// A profile name (see [`profile_dirs`]) or a path.
pub fn find_profile(name: &str) -> Result<PathBuf> {
    let as_path = PathBuf::from(name);
    if as_path.extension().is_some_and(|e| e == "toml") || as_path.components().count() > 1 {
        return Ok(as_path);
    }
    let file = format!("{name}.toml");
    let dirs = profile_dirs();
    if let Some(found) = dirs.iter().map(|d| d.join(&file)).find(|p| p.is_file()) {
        return Ok(found);
    }
    match dirs.iter().find(|d| d.is_dir()) {
        Some(dir) => bail!(
            "no profile `{name}`; the profiles are {} (in {}), or give the path of a .toml file",
            profile_names(dir).join(", "),
            dir.display()
        ),
        None => bail!(
            "no profile `{name}`: no launch/profiles directory found (set TESTBED_PROFILES or give the path of a .toml file)"
        ),
    }
}

fn print_summary(s: &RunSummary, figures: &[PathBuf]) {
    let settle = s
        .settle_s
        .map_or_else(|| "never".to_string(), |t| format!("{t:.1} s"));
    let xyz = |v: [f64; 3], digits: usize| {
        format!(
            "X {:.*}  Y {:.*}  Z {:.*}",
            digits, v[0], digits, v[1], digits, v[2]
        )
    };
    let status = if s.interrupted {
        "  INTERRUPTED: the run ended early; the numbers cover what was recorded"
    } else {
        ""
    };
    println!(
        "run: profile {}, {:.1} simulated s, {} ticks, mode {}, seed {}{status}",
        s.profile, s.simulated_s, s.ticks, s.mode, s.seed
    );
    println!("  initial condition    {}", s.initial_condition);
    println!("  controller           {}", s.controller);
    if s.attitude_from == "truth" {
        println!(
            "  attitude error = rotation vector from target to true attitude, body axes, degrees"
        );
    } else {
        println!(
            "  attitude error = the controller's error of the ESTIMATE against the target (no truth in this log), body axes, degrees"
        );
    }
    println!(
        "  settling time        {settle}   (first time after which |error| stays within {}° on every axis)",
        summary::SETTLE_BAND_DEG
    );
    println!(
        "  steady error         {}   (max |error| per axis over the last {} s, deg)",
        xyz(s.steady_deg, 4),
        summary::STEADY_WINDOW_S
    );
    if s.simulated_s < summary::STEADY_WINDOW_S {
        println!(
            "  warning: the run is shorter ({:.1} s) than the steady window ({} s): the steady error covers the whole run, transient included",
            s.simulated_s,
            summary::STEADY_WINDOW_S
        );
    }
    println!(
        "  peak wheel speed     {}   (max |speed| per wheel, rpm)",
        xyz(s.peak_wheel_rpm, 0)
    );
    if let Some(e) = &s.estimator {
        println!(
            "  estimator error      RMS {}   max {}   (estimate vs truth, deg, {} estimates)",
            xyz(e.rms_deg, 4),
            xyz(e.max_deg, 4),
            e.compared
        );
        println!(
            "  estimator 3σ         {}   (the filter's own attitude 3σ at the end, deg)",
            xyz(e.final_3sigma_deg, 4)
        );
    }
    if let (None, Some(sigma)) = (&s.estimator, s.estimate_3sigma_deg) {
        println!(
            "  estimator 3σ         {}   (the filter's own attitude 3σ at the end, deg)",
            xyz(sigma, 4)
        );
    }
    if let Some(t) = &s.thrusters {
        let on = t.on_time_s.map(|x| format!("{x:.1}")).join(" ");
        let c = Vector3::from(t.com_shift_m) * 1e6;
        println!(
            "  thrusters            fired in {} periods, on-time [{on}] s per thruster, {} commands refused{}",
            t.firing_periods,
            t.refused,
            if t.disabled {
                ", DISABLED (stuck-open valve)"
            } else {
                ""
            }
        );
        println!(
            "  propellant used      {:.2} g; CoM shift ({:.3}, {:.3}, {:.3}) µm (body axes)",
            t.propellant_used_kg * 1e3,
            c.x,
            c.y,
            c.z
        );
    }
    println!("  deadline misses      {}", s.deadline_misses);
    print_health(&s.health);
    println!(
        "  log                  {}{}",
        s.log,
        if s.log_complete {
            ""
        } else {
            " (not finalised; all complete records read)"
        }
    );
    for f in figures {
        println!("  figure               {}", f.display());
    }
}

/// How many health events the summary lists (all are in the log and in `--json`).
const EVENTS_SHOWN: usize = 20;

fn print_health(h: &summary::HealthSummary) {
    if h.can_frames_ok + h.can_frames_bad > 0 {
        println!(
            "  CAN frames           {} decoded, {} rejected (all links)",
            h.can_frames_ok, h.can_frames_bad
        );
    }
    if !h.marked {
        println!(
            "  health               no fault: no safe mode, process exit, restart, hang, lost input or zeroed command"
        );
        return;
    }
    println!(
        "  HEALTH               safe mode entered {} times ({} cycles), process exits {}, restarts {}, hangs {}, inputs lost {}, commands zeroed {}{}",
        h.safe_mode_entries,
        h.safe_mode_cycles,
        h.process_exits,
        h.restarts,
        h.hangs,
        h.inputs_lost,
        h.commands_zeroed,
        if h.aborted { ", RUN ABORTED" } else { "" }
    );
    for e in h.events.iter().take(EVENTS_SHOWN) {
        println!(
            "    t = {:>8.1} s  {:<18} {:<28} by {}{}",
            e.t_s,
            e.kind,
            e.subject,
            e.reporter,
            match e.kind.as_str() {
                "safe mode entered" => format!(
                    " ({})",
                    testbed_flight::safe_mode::SafeReasons(e.detail).describe()
                ),
                "process exited" if e.detail > 128 => format!(" (signal {})", e.detail - 128),
                "process exited" => format!(" (exit status {})", e.detail),
                "input lost" | "process hung" => format!(" (silent {:.2} s)", e.value),
                _ => String::new(),
            }
        );
    }
    if h.events.len() > EVENTS_SHOWN {
        println!(
            "    … {} more events in the log (topic testbed/system/health, or --json)",
            h.events.len() - EVENTS_SHOWN
        );
    }
    for segment in &h.segments {
        println!("  log segment          {segment}   (written by the restarted logger)");
    }
}

fn panels<'a>(series: &RunSeries, summary: &RunSummary) -> Vec<Panel<'a>> {
    let per_axis = |t: &[f64],
                    values: &[[f64; 3]],
                    labels: [&'a str; 3],
                    dashed: bool,
                    sign: f64|
     -> Vec<Series<'a>> {
        (0..3)
            .map(|axis| Series {
                label: labels[axis],
                points: t
                    .iter()
                    .zip(values)
                    .map(|(t, v)| (*t, sign * v[axis]))
                    .collect(),
                dashed,
            })
            .collect()
    };
    const XYZ: [&str; 3] = ["X", "Y", "Z"];
    let band = summary::SETTLE_BAND_DEG;
    let error = || per_axis(&series.t_s, &series.error_deg, XYZ, false, 1.0);
    let mut estimate_vs_truth = per_axis(
        &series.estimate_t_s,
        &series.estimate_error_deg,
        ["error X", "error Y", "error Z"],
        false,
        1.0,
    );
    estimate_vs_truth.extend(per_axis(
        &series.estimate_t_s,
        &series.estimate_3sigma_deg,
        ["±3σ X", "±3σ Y", "±3σ Z"],
        true,
        1.0,
    ));
    estimate_vs_truth.extend(per_axis(
        &series.estimate_t_s,
        &series.estimate_3sigma_deg,
        ["", "", ""],
        true,
        -1.0,
    ));
    // The filter's error after its start-up transient sets the scale: the first estimates
    // (initial covariance) would flatten everything else.
    let settled_estimates = series
        .estimate_t_s
        .iter()
        .zip(&series.estimate_3sigma_deg)
        .filter(|(t, _)| **t >= 10.0);
    let sigma_scale = settled_estimates
        .map(|(_, s)| s[0].max(s[1]).max(s[2]))
        .fold(0.0_f64, f64::max);
    let error_scale = series
        .estimate_t_s
        .iter()
        .zip(&series.estimate_error_deg)
        .filter(|(t, _)| **t >= 10.0)
        .map(|(_, e)| e[0].abs().max(e[1].abs()).max(e[2].abs()))
        .fold(0.0_f64, f64::max);
    let estimate_range = (sigma_scale.max(error_scale) > 0.0)
        .then(|| 1.3 * sigma_scale.max(error_scale))
        .map(|r| (-r, r));
    vec![
        Panel::new("attitude error (deg)", error()),
        Panel {
            band: Some(band),
            marker: summary.settle_s.map(|t| {
                (
                    t,
                    format!("settled at {t:.1} s (within ±{band}° from here on)"),
                )
            }),
            y_range: Some((-5.0 * band, 5.0 * band)),
            ..Panel::new("error, zoom; ±0.1° band (deg)", error())
        },
        Panel {
            y_range: estimate_range,
            ..Panel::new("estimate error, ±3σ (deg)", estimate_vs_truth)
        },
        Panel::new(
            "wheel torque cmd (mNm)",
            per_axis(
                &series.command_t_s,
                &series.wheel_torque_mnm,
                XYZ,
                false,
                1.0,
            ),
        ),
        Panel::new(
            "wheel speed (rpm)",
            per_axis(&series.t_s, &series.wheel_speed_rpm, XYZ, false, 1.0),
        ),
        Panel::new(
            "body rate (deg/s)",
            per_axis(&series.t_s, &series.rate_deg_s, XYZ, false, 1.0),
        ),
    ]
}
