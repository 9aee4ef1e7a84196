//! What the process pipeline costs, next to its baseline in the same run:
//! - lockstep speed of the full multi-process pipeline (plant, five simulated gateways,
//!   estimator, controller, logger over iceoryx2) in simulated time per wall time, beside the
//!   in-process closed loop running the same scenario (target: ≥ 200× real time);
//! - CPU time of all the processes of a paced (1× wall time) run per second of run
//!   (target: < 2 % of one core): from a short and a long paced run, the marginal cost per
//!   second (the slope) and the fixed cost of starting and stopping nine processes (the
//!   intercept), and the long run's total over its wall time.
//!
//! `cargo build --release --workspace --bins && cargo run --release -p testbed-bench --bin pipeline_speed [-- --json]`

use anyhow::{Context, Result, bail};
use clap::Parser;
use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};
use testbed_bench::median_time;
use testbed_model::ModelConfig;
use testbed_sim::closed_loop::{self, Scenario};

#[derive(Parser)]
struct Args {
    /// Simulated seconds of each lockstep run.
    #[arg(long, default_value_t = 300.0)]
    duration: f64,
    /// Lockstep runs (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Wall seconds of the paced run.
    #[arg(long, default_value_t = 60.0)]
    paced_duration: f64,
    #[arg(long)]
    json: bool,
}

/// CPU time (user + system) of this process's waited-for descendants so far.
fn children_cpu() -> Duration {
    // SAFETY: getrusage writes into the zeroed struct we own.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage) };
    let tv = |t: libc::timeval| Duration::new(t.tv_sec as u64, t.tv_usec as u32 * 1000);
    tv(usage.ru_utime) + tv(usage.ru_stime)
}

struct PipelineRun {
    wall: Duration,
    /// The plant's own measure: simulated time over wall time from its first tick to its last.
    plant_x_real_time: Option<f64>,
}

fn testbed_run(testbed: &PathBuf, log: &PathBuf, args: &[&str]) -> Result<PipelineRun> {
    let start = Instant::now();
    let out = Command::new(testbed)
        .arg("run")
        .args(args)
        .arg("--log")
        .arg(log)
        .env("RUST_LOG", "warn,plant=info")
        .output()
        .with_context(|| format!("running {}", testbed.display()))?;
    let wall = start.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        bail!("testbed run failed: {stderr}");
    }
    let plant_x_real_time = stderr
        .split("x_real_time=")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok());
    Ok(PipelineRun {
        wall,
        plant_x_real_time,
    })
}

fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[xs.len() / 2]
}

fn main() -> Result<()> {
    let args = Args::parse();
    let bin_dir = std::env::current_exe()?
        .parent()
        .context("bench binary has a directory")?
        .to_path_buf();
    let testbed = bin_dir.join("testbed");
    if !testbed.exists() {
        bail!(
            "{} not found: cargo build --release --workspace --bins first",
            testbed.display()
        );
    }
    let scratch = std::env::temp_dir().join(format!("pipeline-speed-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let log = scratch.join("run.mcap");
    let duration = args.duration.to_string();

    let mut whole = Vec::new();
    let mut ticking = Vec::new();
    for _ in 0..args.repeats.max(1) {
        let run = testbed_run(&testbed, &log, &["--duration", &duration])?;
        whole.push(args.duration / run.wall.as_secs_f64());
        ticking.extend(run.plant_x_real_time);
    }
    let mut scenario = Scenario::paper_stabilisation(ModelConfig::default(), 1);
    scenario.duration_s = args.duration;
    let in_process = median_time(args.repeats.max(1), || {
        closed_loop::run(&scenario).expect("closed loop runs");
    });
    let in_process_x = args.duration / in_process.as_secs_f64();

    let paced_cpu = |seconds: f64| -> Result<(f64, f64)> {
        let before = children_cpu();
        let run = testbed_run(
            &testbed,
            &log,
            &["--paced", "--duration", &seconds.to_string()],
        )?;
        Ok((
            run.wall.as_secs_f64(),
            (children_cpu() - before).as_secs_f64(),
        ))
    };
    let (short_wall, short_cpu) = paced_cpu(5.0)?;
    let (long_wall, long_cpu) = paced_cpu(args.paced_duration)?;
    let marginal = (long_cpu - short_cpu) / (long_wall - short_wall);
    let fixed = short_cpu - marginal * short_wall;
    let cpu_fraction = long_cpu / long_wall;
    let _ = std::fs::remove_dir_all(&scratch);

    let whole_x = median(whole);
    let ticking_x = if ticking.is_empty() {
        f64::NAN
    } else {
        median(ticking)
    };
    let report = serde_json::json!({
        "simulated_s": args.duration,
        "repeats": args.repeats,
        "lockstep_pipeline": {
            "x_real_time_whole_run": whole_x,
            "x_real_time_ticking": ticking_x,
        },
        "in_process_loop": { "x_real_time": in_process_x },
        "pipeline_over_in_process_cost": in_process_x / ticking_x,
        "paced": {
            "wall_s": long_wall,
            "cpu_s_all_processes": long_cpu,
            "cpu_fraction_of_one_core": cpu_fraction,
            "marginal_cpu_fraction_of_one_core": marginal,
            "start_stop_cpu_s": fixed,
        },
    });
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!("{:<58} {:>12}", "", "× real time");
    println!(
        "{:<58} {:>12.0}",
        "lockstep pipeline, 9 processes, clock start to end (median)", ticking_x
    );
    println!(
        "{:<58} {:>12.0}",
        "lockstep pipeline, whole `testbed run` incl. start-up", whole_x
    );
    println!(
        "{:<58} {:>12.0}",
        "in-process closed loop, same scenario (baseline)", in_process_x
    );
    println!(
        "the process split costs {:.0}× the in-process loop's time per tick",
        in_process_x / ticking_x
    );
    println!(
        "paced, all processes: {:.2} % of one core per second of run (marginal), {:.2} s CPU to start and stop;",
        100.0 * marginal,
        fixed
    );
    println!(
        "  a {long_wall:.1} s run used {long_cpu:.3} s CPU in all = {:.2} % of one core over its wall time",
        100.0 * cpu_fraction
    );
    Ok(())
}
