//! `testbed run`: launch the pipeline of a profile as real processes, then summarise its log.
//!
//! The run configuration every process reads is assembled here (the profile's `[run] config`
//! file or the defaults, with the profile's and the command line's mode, duration, seed and log)
//! and written beside the log; `testbed-launch` starts, supervises and stops the processes.
//! Before anything starts or is written, [`preflight`] checks that this computer has what the
//! profile's processes will open.

mod campaign_run;
mod launcher;
pub mod preflight;
mod profiles;
mod report;

pub use launcher::RunLock;
pub use profiles::{find_profile, profile_dirs, profile_names};

use crate::figure;
use crate::progress;
use crate::summary;
use anyhow::{Context, Result, bail};
use ipc_types::ClockMode;
use launcher::{LauncherOverrides, launch};
use report::{panels, print_summary, repair_if_cut, replay_cut_warning};
use std::path::{Path, PathBuf};
use testbed_config::RunConfig;
use testbed_launch::profile::Profile;

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
    /// Dry run: check the profile, the run configuration, the binaries and what the profile
    /// needs of this computer (CAN interfaces, serial ports), print the run's settings and the
    /// processes in start order, and start nothing (writes no file).
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
    /// Run one run of this campaign file (with --campaign-run) through the processes: its
    /// configuration is the one the campaign generated (dispersed values and device seed), so
    /// the estimates equal the campaign's in-process run bit for bit in lockstep. --duration
    /// still shortens it.
    #[arg(long, value_name = "FILE", requires = "campaign_run", conflicts_with_all = ["config", "seed", "replay", "replay_candump"])]
    pub campaign: Option<PathBuf>,
    /// The index of the campaign's run (0 to runs-1), as the campaign's report names it.
    #[arg(long, value_name = "K", requires = "campaign")]
    pub campaign_run: Option<u64>,
    /// The campaign's variant to run (needed when the campaign has variants).
    #[arg(long, value_name = "NAME", requires = "campaign")]
    pub campaign_variant: Option<String>,
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
    let from_campaign = campaign_run::campaign_config(args)?;
    let campaign = from_campaign.is_some();
    let mut config = match (
        from_campaign,
        recorded_log,
        &args.config,
        &profile.run.config,
    ) {
        (Some(config), _, _, _) => config,
        (None, Some(source), _, _) => recorded_config(source)?,
        (None, None, Some(path), _) => RunConfig::load(path)?,
        (None, None, None, Some(path)) => RunConfig::load(&profile.relative_to_profile(path))?,
        (None, None, None, None) => RunConfig::default(),
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
    if campaign {
        // The campaign's duration and seed, unless the command line shortens the run.
        if let Some(d) = args.duration {
            config.run.duration_s = d;
        }
    } else if recorded_log.is_none() {
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

    // Before anything is started or written: what the processes will open is there.
    let preflight = preflight::check(&config.run.profile, &profile, &config);
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
        launch(&profile_path, &config, None, &overrides, true, None, None)?;
        return Ok(preflight?);
    }
    preflight?;
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

/// The run configuration a log was recorded with.
fn recorded_config(log: &Path) -> Result<RunConfig> {
    let recorded = testbed_log::RunLog::open(log)
        .with_context(|| format!("opening the log to replay {}", log.display()))?;
    Ok(RunConfig::from_toml_str(
        recorded.config_toml(),
        &format!("{} (config.toml attachment)", log.display()),
    )?)
}
