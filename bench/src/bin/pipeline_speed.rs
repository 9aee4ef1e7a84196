//! What the process pipeline costs, next to its baseline in the same run:
//! - lockstep speed of the full multi-process pipeline (plant, five simulated gateways,
//!   estimator, controller, logger over iceoryx2) in simulated time per wall time, beside the
//!   in-process closed loop running the same scenario (target: ≥ 1000× real time while
//!   ticking), and beside itself with every process polling for 500 µs after each data
//!   wake-up (`run.lockstep_wait = "spin:500"`) instead of sleeping on its doorbell (the
//!   default, `block`), and beside itself with every process left where the scheduler puts it
//!   (`testbed run --unplaced`, instead of the profile's placement: the processes of a tick on
//!   one CPU, the logger and ground link on the others), and beside the `simulation-grouped`
//!   profile (the five simulated gateways in one process), with the CPU time each costs per
//!   simulated second;
//! - both against Basilisk's dynamics alone on the same scenario, measured in the same run
//!   (`bench/basilisk_speed.py`: Basilisk's hub + three reaction wheels with friction at
//!   0.01 s; needs `python3` with `bsk` installed, else the report says "not installed");
//! - CPU time of all the processes of a paced (1× wall time) run per second of run
//!   (target: < 2 % of one core): from a short and a long paced run, the marginal cost per
//!   second (the slope) and the fixed cost of starting and stopping nine processes (the
//!   intercept), and the long run's total over its wall time.
//!
//! `cargo build --profile deploy --workspace --bins && target/deploy/pipeline_speed [--json] [--no-paced]`
//! (the pipeline as `launch/launch.sh` builds it; `--release` works alike)

use anyhow::{Context, Result, bail};
use clap::Parser;
use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};
use testbed_bench::{binary_dir, children_cpu, median, median_time};
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
    /// Skip the paced CPU measurement (a minute of wall time).
    #[arg(long)]
    no_paced: bool,
    /// The Python interpreter that runs `bench/basilisk_speed.py`.
    #[arg(long, default_value = "python3")]
    python: String,
}

/// The wait strategy measured beside the default (`block`).
const SPIN: &str = "spin:500";
/// The profile with the five simulated gateways in one process (`sim-devices`).
const GROUPED_PROFILE: &str = "simulation-grouped";

/// The tracing filter of the benchmarked runs: warnings, and the plant's "plant done" line
/// (target `testbed_processes::plant`) that carries `x_real_time`.
const RUN_LOG_FILTER: &str = "warn,testbed_processes::plant=info";

/// The plant's own speed measure from a run's stderr: the `x_real_time=` of "plant done".
fn plant_x_real_time(stderr: &str) -> Option<f64> {
    stderr
        .lines()
        .find(|l| l.contains("plant done"))?
        .split("x_real_time=")
        .nth(1)?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// What `bench/basilisk_speed.py` measured: Basilisk's simulated seconds per wall second, or
/// why there is no number.
enum Basilisk {
    Measured { x_real_time: f64, version: String },
    NotInstalled(String),
}

fn basilisk(python: &str, duration_s: f64) -> Basilisk {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/basilisk_speed.py");
    let out = Command::new(python)
        .arg(script)
        .args(["--duration", &duration_s.to_string(), "--repeats", "1"])
        .output();
    let out = match out {
        Ok(out) if out.status.success() => out,
        Ok(out) => {
            return Basilisk::NotInstalled(format!(
                "{script} failed: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        Err(e) => return Basilisk::NotInstalled(format!("{python}: {e}")),
    };
    let Ok(report) = serde_json::from_slice::<serde_json::Value>(&out.stdout) else {
        return Basilisk::NotInstalled(format!("{script} printed no JSON"));
    };
    match (
        report["installed"].as_bool(),
        report["x_real_time"].as_f64(),
    ) {
        (Some(true), Some(x_real_time)) => Basilisk::Measured {
            x_real_time,
            version: report["bsk_version"].as_str().unwrap_or("?").to_owned(),
        },
        _ => Basilisk::NotInstalled(format!(
            "not installed ({}): pip install bsk==2.12.1",
            report["error"].as_str().unwrap_or("no Basilisk")
        )),
    }
}

struct PipelineRun {
    wall: Duration,
    /// CPU time of all the run's processes (user + system).
    cpu: Duration,
    /// The plant's own measure: simulated time over wall time from its first tick to its last.
    plant_x_real_time: Option<f64>,
}

/// `testbed run args…`; `wait`: the `TESTBED_BUS_WAIT` of every process (the run's own
/// default when `None`).
fn testbed_run(
    testbed: &PathBuf,
    log: &PathBuf,
    args: &[&str],
    wait: Option<&str>,
) -> Result<PipelineRun> {
    let cpu_before = children_cpu();
    let start = Instant::now();
    let mut command = Command::new(testbed);
    command
        .arg("run")
        .args(args)
        .arg("--log")
        .arg(log)
        .env("RUST_LOG", RUN_LOG_FILTER);
    match wait {
        Some(wait) => command.env(ipc_types::ENV_WAIT, wait),
        None => command.env_remove(ipc_types::ENV_WAIT),
    };
    let out = command
        .output()
        .with_context(|| format!("running {}", testbed.display()))?;
    let wall = start.elapsed();
    let cpu = children_cpu().saturating_sub(cpu_before);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        bail!("testbed run failed: {stderr}");
    }
    let plant_x_real_time = plant_x_real_time(&stderr);
    Ok(PipelineRun {
        wall,
        cpu,
        plant_x_real_time,
    })
}

fn main() -> Result<()> {
    let args = Args::parse();
    let bin_dir = binary_dir()?;
    let testbed = bin_dir.join("testbed");
    if !testbed.exists() {
        bail!(
            "{} not found: cargo build --profile deploy --workspace --bins first",
            testbed.display()
        );
    }
    let scratch = std::env::temp_dir().join(format!("pipeline-speed-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let log = scratch.join("run.mcap");
    let duration = args.duration.to_string();

    // Side by side: each repeat runs the pipeline, then Basilisk, so both see the same load.
    let mut whole = Vec::new();
    let mut ticking = Vec::new();
    let mut cpu_per_simulated_s = Vec::new();
    let mut ticking_spinning = Vec::new();
    let mut spinning_cpu_per_simulated_s = Vec::new();
    let mut ticking_unplaced = Vec::new();
    let mut unplaced_cpu_per_simulated_s = Vec::new();
    let mut ticking_grouped = Vec::new();
    let mut grouped_cpu_per_simulated_s = Vec::new();
    let mut bsk = Vec::new();
    let mut bsk_missing = None;
    let mut bsk_version = String::new();
    for _ in 0..args.repeats.max(1) {
        let run = testbed_run(&testbed, &log, &["--duration", &duration], None)?;
        whole.push(args.duration / run.wall.as_secs_f64());
        ticking.extend(run.plant_x_real_time);
        cpu_per_simulated_s.push(run.cpu.as_secs_f64() / args.duration);
        let spinning = testbed_run(&testbed, &log, &["--duration", &duration], Some(SPIN))?;
        ticking_spinning.extend(spinning.plant_x_real_time);
        spinning_cpu_per_simulated_s.push(spinning.cpu.as_secs_f64() / args.duration);
        let unplaced = testbed_run(
            &testbed,
            &log,
            &["--duration", &duration, "--unplaced"],
            None,
        )?;
        ticking_unplaced.extend(unplaced.plant_x_real_time);
        unplaced_cpu_per_simulated_s.push(unplaced.cpu.as_secs_f64() / args.duration);
        let grouped = testbed_run(
            &testbed,
            &log,
            &["--duration", &duration, "--profile", GROUPED_PROFILE],
            None,
        )?;
        ticking_grouped.extend(grouped.plant_x_real_time);
        grouped_cpu_per_simulated_s.push(grouped.cpu.as_secs_f64() / args.duration);
        if bsk_missing.is_none() {
            match basilisk(&args.python, args.duration) {
                Basilisk::Measured {
                    x_real_time,
                    version,
                } => {
                    bsk.push(x_real_time);
                    bsk_version = version;
                }
                Basilisk::NotInstalled(why) => bsk_missing = Some(why),
            }
        }
    }
    let mut scenario = Scenario::paper_stabilisation(ModelConfig::default(), 1);
    scenario.duration_s = args.duration;
    let in_process = median_time(args.repeats.max(1), || {
        closed_loop::run(&scenario).expect("closed loop runs");
    });
    let in_process_x = args.duration / in_process.as_secs_f64();

    let paced_cpu = |seconds: f64| -> Result<(f64, f64)> {
        if args.no_paced {
            return Ok((f64::NAN, f64::NAN));
        }
        let run = testbed_run(
            &testbed,
            &log,
            &["--paced", "--duration", &seconds.to_string()],
            None,
        )?;
        Ok((run.wall.as_secs_f64(), run.cpu.as_secs_f64()))
    };
    let (short_wall, short_cpu) = paced_cpu(5.0)?;
    let (long_wall, long_cpu) = paced_cpu(args.paced_duration)?;
    let marginal = (long_cpu - short_cpu) / (long_wall - short_wall);
    let fixed = short_cpu - marginal * short_wall;
    let cpu_fraction = long_cpu / long_wall;
    let _ = std::fs::remove_dir_all(&scratch);

    let whole_x = median(whole);
    let median_or_nan = |v: Vec<f64>| if v.is_empty() { f64::NAN } else { median(v) };
    let ticking_x = median_or_nan(ticking);
    let spinning_x = median_or_nan(ticking_spinning);
    let cpu_ms = 1e3 * median_or_nan(cpu_per_simulated_s);
    let spinning_cpu_ms = 1e3 * median_or_nan(spinning_cpu_per_simulated_s);
    let unplaced_x = median_or_nan(ticking_unplaced);
    let unplaced_cpu_ms = 1e3 * median_or_nan(unplaced_cpu_per_simulated_s);
    let grouped_x = median_or_nan(ticking_grouped);
    let grouped_cpu_ms = 1e3 * median_or_nan(grouped_cpu_per_simulated_s);
    let bsk_x = (!bsk.is_empty()).then(|| median(bsk));
    let report = serde_json::json!({
        "simulated_s": args.duration,
        "repeats": args.repeats,
        "lockstep_pipeline": {
            "x_real_time_whole_run": whole_x,
            "x_real_time_ticking": ticking_x,
            "cpu_ms_per_simulated_s": cpu_ms,
            "waiting_with_spin_500": {
                "x_real_time_ticking": spinning_x,
                "cpu_ms_per_simulated_s": spinning_cpu_ms,
            },
            "unplaced": {
                "x_real_time_ticking": unplaced_x,
                "cpu_ms_per_simulated_s": unplaced_cpu_ms,
            },
            "grouped_simulated_gateways": {
                "profile": GROUPED_PROFILE,
                "x_real_time_ticking": grouped_x,
                "cpu_ms_per_simulated_s": grouped_cpu_ms,
            },
        },
        "in_process_loop": { "x_real_time": in_process_x },
        "pipeline_over_in_process_cost": in_process_x / ticking_x,
        "basilisk_dynamics": match bsk_x {
            Some(x) => serde_json::json!({
                "bsk_version": bsk_version,
                "x_real_time": x,
                "lockstep_pipeline_ticking_over_basilisk": ticking_x / x,
                "lockstep_pipeline_whole_run_over_basilisk": whole_x / x,
                "in_process_over_basilisk": in_process_x / x,
            }),
            None => serde_json::json!({ "not_installed": bsk_missing }),
        },
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
        "  the same, every process polling 500 µs after a wake-up", spinning_x
    );
    println!(
        "{:<58} {:>12.0}",
        "  the same, processes placed by the scheduler (--unplaced)", unplaced_x
    );
    println!(
        "{:<58} {:>12.0}",
        "  the simulated gateways in one process (simulation-grouped)", grouped_x
    );
    println!(
        "{:<58} {:>12.0}",
        "lockstep pipeline, whole `testbed run` incl. start-up", whole_x
    );
    println!(
        "{:<58} {:>12.0}",
        "in-process closed loop, same scenario (baseline)", in_process_x
    );
    match bsk_x {
        Some(x) => println!(
            "{:<58} {:>12.0}",
            format!("Basilisk {bsk_version} dynamics alone (hub + 3 wheels, 0.01 s)"),
            x
        ),
        None => println!(
            "{:<58} {:>12}",
            "Basilisk dynamics alone: not installed", "-"
        ),
    }
    println!(
        "the process split costs {:.0}× the in-process loop's time per tick",
        in_process_x / ticking_x
    );
    println!(
        "lockstep wait `{SPIN}`: {:.2}× the speed of `block`, at {:.1} ms CPU (all processes, \
         whole run) per simulated second against {:.1} ms",
        spinning_x / ticking_x,
        spinning_cpu_ms,
        cpu_ms
    );
    println!(
        "placement (the tick's processes on one CPU): {:.2}× the speed of the scheduler's \
         placement, at {:.1} ms CPU per simulated second against {:.1} ms",
        ticking_x / unplaced_x,
        cpu_ms,
        unplaced_cpu_ms
    );
    println!(
        "the simulated gateways in one process: {:.2}× the speed of five, at {:.1} ms CPU per \
         simulated second against {:.1} ms",
        grouped_x / ticking_x,
        grouped_cpu_ms,
        cpu_ms
    );
    match bsk_x {
        Some(x) => println!(
            "lockstep pipeline ÷ Basilisk: {:.2} while ticking, {:.2} whole run; in-process ÷ Basilisk: {:.1}",
            ticking_x / x,
            whole_x / x,
            in_process_x / x
        ),
        None => println!(
            "Basilisk: not installed ({})",
            bsk_missing.as_deref().unwrap_or("?")
        ),
    }
    if args.no_paced {
        return Ok(());
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_plants_speed_from_its_done_line() {
        let stderr = "2026-11-25T15:50:48.051584Z  INFO testbed_processes::plant: plant done \
            exit=Stopped simulated_s=60.00000000000001 wall_s=0.256103176 \
            x_real_time=234.28057760595678 deadline_misses=0\n";
        assert_eq!(plant_x_real_time(stderr), Some(234.28057760595678));
        assert_eq!(
            plant_x_real_time("INFO something else x_real_time=3\n"),
            None
        );
    }

    #[test]
    fn the_run_filter_lets_the_plants_done_line_through() {
        // The plant logs under its module path; a bare `plant=info` directive missed it.
        assert!(RUN_LOG_FILTER.contains("testbed_processes::plant=info"));
    }
}
