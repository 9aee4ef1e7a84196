//! `testbed run`: launch the pipeline of a profile as real processes, then summarise its log.
//!
//! The run configuration every process reads is assembled here (the profile's `[run] config`
//! file or the defaults, with the profile's and the command line's mode, duration, seed and log)
//! and written beside the log; `testbed-launch` starts, supervises and stops the processes.

use crate::figure::{self, Panel, Series};
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::process::Command;
use testbed_bus::BusConfig;
use testbed_launch::profile::Profile;
use crate::summary::{self, RunSeries, RunSummary};
use testbed_runtime::{ClockMode, RunConfig};

#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Launch profile: a name in launch/profiles (simulation, can-sim, platform, mixed) or a TOML path.
    #[arg(long, default_value = "simulation")]
    profile: String,
    /// Simulated duration, s [default: the profile's].
    #[arg(long)]
    duration: Option<f64>,
    /// Seed of the simulated devices' noise [default: the profile's].
    #[arg(long)]
    seed: Option<u64>,
    /// MCAP log of the run [default: the profile's].
    #[arg(long)]
    log: Option<PathBuf>,
    /// Run at 1× wall time instead of lockstep.
    #[arg(long)]
    paced: bool,
    /// Feed this log's recorded inputs into the estimator and controller instead of simulating
    /// (with a profile that runs the `replay` process; default profile then: replay). The
    /// recorded run configuration is used, so the estimator and controller are set up as they were.
    #[arg(long, conflicts_with = "replay_candump")]
    replay: Option<PathBuf>,
    /// Put the CAN bus traffic this log's run recorded (the `.candump.log` file beside it) back
    /// through the real sensor gateways into the estimator (default profile then: can-replay),
    /// with the recorded run configuration; the summary compares the estimates with the log's.
    #[arg(long)]
    replay_candump: Option<PathBuf>,
    /// Print the summary as one JSON object.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &RunArgs) -> Result<()> {
    let profile_name = match (&args.replay, &args.replay_candump, args.profile.as_str()) {
        (Some(_), _, "simulation") => "replay",
        (_, Some(_), "simulation") => "can-replay",
        (_, _, name) => name,
    };
    let profile_path = find_profile(profile_name)?;
    let profile = Profile::load(&profile_path)?;
    let recorded_log = args.replay.as_ref().or(args.replay_candump.as_ref());
    let mut config = match (recorded_log, &profile.run.config) {
        (Some(source), _) => recorded_config(source)?,
        (None, Some(path)) => RunConfig::load(&profile.relative_to_profile(path))?,
        (None, None) => RunConfig::default(),
    };
    if recorded_log.is_some() && args.paced {
        bail!("--replay and --replay-candump run in lockstep (the replay owns the clock); drop --paced");
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
    config.run.profile = profile_path.file_stem().map_or_else(|| args.profile.clone(), |s| s.to_string_lossy().into_owned());
    config.run.mode = if args.paced { ClockMode::Paced } else { profile.run.mode };
    if recorded_log.is_none() {
        if let Some(d) = args.duration.or(profile.run.duration_s) {
            config.run.duration_s = d;
        }
        config.run.seed = args.seed.unwrap_or(profile.run.seed);
    }
    config.run.replay = args.replay.clone();
    if let Some(log) = args.log.clone().or_else(|| profile.run.log.clone()) {
        config.run.log = log;
    }
    // The clock owner (plant or replay: the process that ends the run) waits for all the others.
    config.run.participants =
        profile.processes.iter().filter(|p| !p.ends_run).map(|p| p.name.clone()).collect();
    config.validate("command line")?;

    let log = config.run.log.clone();
    if let Some(dir) = log.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let config_path = log.with_extension("run.toml");
    std::fs::write(&config_path, config.to_toml_string())
        .with_context(|| format!("writing the run configuration {}", config_path.display()))?;

    launch(&profile_path, &config, &config_path)?;

    if let Some(source) = &args.replay_candump {
        let comparison = summary::compare_estimates(source, &log)?;
        if args.json {
            let mut value = serde_json::to_value(&comparison)?;
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

    let (summary, series, _) = summary::summarise(&log)?;
    let figure_path = log.with_extension("svg");
    figure::write_svg(&figure_path, &format!("testbed run: profile {}, seed {}", config.run.profile, config.run.seed), &panels(&series))?;
    if args.json {
        let mut value = serde_json::to_value(&summary)?;
        value["figure"] = serde_json::json!(figure_path.display().to_string());
        value["config"] = serde_json::json!(config_path.display().to_string());
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print_summary(&summary, &figure_path);
    }
    Ok(())
}

/// The run configuration a log was recorded with.
fn recorded_config(log: &Path) -> Result<RunConfig> {
    let recorded = testbed_log::RunLog::open(log).with_context(|| format!("opening the log to replay {}", log.display()))?;
    Ok(RunConfig::from_toml_str(recorded.config_toml(), &format!("{} (config.toml attachment)", log.display()))?)
}

/// Start `testbed-launch` (next to this executable) on the profile and wait for it.
fn launch(profile: &Path, config: &RunConfig, config_path: &Path) -> Result<()> {
    let exe = std::env::current_exe().context("locating the testbed executable")?;
    let bin_dir = exe.parent().context("the testbed executable has no directory")?;
    let launcher = bin_dir.join("testbed-launch");
    if !launcher.exists() {
        bail!(
            "{} not found: build the pipeline first (cargo build --release --workspace --bins)",
            launcher.display()
        );
    }
    // One bus per run: a unique prefix and a short root (Unix socket paths must stay < 108 bytes).
    let id = std::process::id();
    let bus = BusConfig::new(format!("tb{id}_"), format!("/tmp/tb{id}/"));
    let mode = config.run.mode.as_str();
    let mut command = Command::new(&launcher);
    if std::env::var_os("RUST_LOG").is_none() {
        // The summary is the output; the processes speak up only for warnings.
        command.env("RUST_LOG", "warn");
    }
    command
        .arg(profile)
        .args(["--mode", mode])
        .args(["--duration-s", &config.run.duration_s.to_string()])
        .args(["--seed", &config.run.seed.to_string()])
        .arg("--log")
        .arg(&config.run.log)
        .arg("--config")
        .arg(config_path)
        .args(["--bus-prefix", &bus.prefix])
        .arg("--bus-root")
        .arg(&bus.root)
        .arg("--bin-dir")
        .arg(bin_dir);
    // Ctrl-C reaches the whole foreground group: the launcher stops the pipeline and finalises
    // the log; this process waits for it and then summarises what was recorded.
    let _ignore_interrupt = IgnoreInterrupt::new();
    let status = command.status().with_context(|| format!("starting {}", launcher.display()))?;
    // Every process of the run has been reaped: leave no shared memory, socket or directory.
    if let Err(e) = testbed_bus::remove_all(&bus) {
        eprintln!("warning: removing the run's iceoryx2 resources: {e}");
    }
    if !status.success() {
        bail!("the pipeline failed ({status}); the launcher's messages above say which process and how");
    }
    Ok(())
}

/// Ignores SIGINT while alive (restores the default on drop).
struct IgnoreInterrupt;

impl IgnoreInterrupt {
    fn new() -> Self {
        // SAFETY: replacing the SIGINT disposition with SIG_IGN has no preconditions.
        unsafe { libc::signal(libc::SIGINT, libc::SIG_IGN) };
        Self
    }
}

impl Drop for IgnoreInterrupt {
    fn drop(&mut self) {
        // SAFETY: restoring the default disposition has no preconditions.
        unsafe { libc::signal(libc::SIGINT, libc::SIG_DFL) };
    }
}

/// A profile name (looked up in `$TESTBED_PROFILES`, then `launch/profiles` beside the build
/// tree and in the working directory) or a path.
fn find_profile(name: &str) -> Result<PathBuf> {
    let as_path = PathBuf::from(name);
    if as_path.extension().is_some_and(|e| e == "toml") || as_path.components().count() > 1 {
        return Ok(as_path);
    }
    let file = format!("{name}.toml");
    let mut dirs: Vec<PathBuf> = std::env::var_os("TESTBED_PROFILES").map(PathBuf::from).into_iter().collect();
    if let Some(root) = std::env::current_exe().ok().and_then(|e| e.ancestors().nth(3).map(Path::to_path_buf)) {
        dirs.push(root.join("launch/profiles")); // <root>/target/<profile>/testbed
    }
    dirs.push(PathBuf::from("launch/profiles"));
    dirs.iter()
        .map(|d| d.join(&file))
        .find(|p| p.exists())
        .with_context(|| format!("profile `{name}` not found in {dirs:?} (give a path to a .toml file instead)"))
}

fn print_summary(s: &RunSummary, figure: &Path) {
    let settle = s.settle_s.map_or_else(|| "never".to_string(), |t| format!("{t:.1} s"));
    println!("run: {:.1} simulated s, {} ticks, mode {}, seed {}", s.simulated_s, s.ticks, s.mode, s.seed);
    println!("  settling time (within {}° per axis)   {settle}", summary::SETTLE_BAND_DEG);
    println!(
        "  steady error, last {} s (deg)         X {:.4}  Y {:.4}  Z {:.4}",
        summary::STEADY_WINDOW_S, s.steady_deg[0], s.steady_deg[1], s.steady_deg[2]
    );
    println!("  deadline misses                       {}", s.deadline_misses);
    println!("  log                                   {}{}", s.log, if s.log_complete { "" } else { " (not finalised; all complete records read)" });
    println!("  figure                                {}", figure.display());
}

fn panels(series: &RunSeries) -> Vec<Panel<'static>> {
    const AXES: [&str; 3] = ["X", "Y", "Z"];
    let per_axis = |values: &[[f64; 3]]| -> Vec<Series<'static>> {
        (0..3)
            .map(|axis| Series { label: AXES[axis], points: series.t_s.iter().zip(values).map(|(t, v)| (*t, v[axis])).collect() })
            .collect()
    };
    vec![
        Panel { y_label: "attitude error (deg)", series: per_axis(&series.error_deg), y_range: None },
        Panel { y_label: "error, steady scale (deg)", series: per_axis(&series.error_deg), y_range: Some((-0.05, 0.05)) },
        Panel { y_label: "body rate (deg/s)", series: per_axis(&series.rate_deg_s), y_range: None },
        Panel { y_label: "wheel speed (rpm)", series: per_axis(&series.wheel_speed_rpm), y_range: None },
    ]
}
