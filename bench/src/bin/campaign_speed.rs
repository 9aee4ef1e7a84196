//! Speed of a Monte Carlo campaign on the in-process closed loop: the worked campaign
//! (`campaigns/paper-dispersed.toml`, 23 dispersions) at `--runs` runs of `--duration` simulated
//! seconds, on one worker beside two workers in the same run (repeats interleaved, medians), with
//! the speed-up; every measurement also checks that the rows are the same whatever the workers.
//!
//! `cargo run --release -p testbed-bench --bin campaign_speed [-- --runs 1000 --duration 150 --repeats 3 --json]`

use clap::Parser;
use std::path::PathBuf;
use std::time::Instant;
use testbed_bench::median;
use testbed_campaign::{CampaignFile, Plan, execute, results};
use testbed_config::RunConfig;

#[derive(Parser)]
struct Args {
    /// The campaign file [default: the worked campaign].
    #[arg(long)]
    campaign: Option<PathBuf>,
    /// Runs of the campaign (its own count replaced).
    #[arg(long, default_value_t = 1000)]
    runs: u64,
    /// Simulated seconds per run.
    #[arg(long, default_value_t = 150.0)]
    duration: f64,
    /// Timed repeats per worker count (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// The worker counts compared, the first the baseline.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    workers: Vec<usize>,
    #[arg(long)]
    json: bool,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let path = args.campaign.clone().unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../campaigns/paper-dispersed.toml")
    });
    let mut file = CampaignFile::load(&path)?;
    file.runs = args.runs;
    file.base.insert(
        "run".into(),
        toml::Value::Table(toml::Table::from_iter([(
            "duration_s".to_string(),
            toml::Value::Float(args.duration),
        )])),
    );
    let plan = Plan::new(file, RunConfig::default())?;
    let indices: Vec<u64> = (0..args.runs).collect();
    let variants = plan.file.variant_names().len() as u64;

    let mut walls: Vec<Vec<f64>> = vec![Vec::new(); args.workers.len()];
    let mut prepare_s = Vec::new();
    let mut reference = None;
    for _ in 0..args.repeats {
        // Interleaved, so that a change in the machine's load falls on every worker count.
        for (slot, &workers) in args.workers.iter().enumerate() {
            let started = Instant::now();
            let jobs = plan.prepare(&indices)?;
            let prepared = started.elapsed().as_secs_f64();
            let rows = execute::run_jobs(&jobs, &plan.file.metrics, workers, &|| {})?;
            walls[slot].push(started.elapsed().as_secs_f64());
            prepare_s.push(prepared);
            // Compared as written (a NaN is not equal to itself, its text is).
            let written = (
                results::runs_csv(&plan.file.keys(), &rows),
                results::series_csv(&rows, plan.file.metrics.series_step_s),
            );
            match &reference {
                None => reference = Some(written),
                Some(first) => anyhow::ensure!(
                    first == &written,
                    "{workers} worker(s) gave other rows than the first measurement"
                ),
            }
        }
    }
    let simulated_s = (args.runs * variants) as f64 * args.duration;
    let medians: Vec<f64> = walls.iter().map(|w| median(w.clone())).collect();
    let per_worker: Vec<serde_json::Value> = args
        .workers
        .iter()
        .zip(&medians)
        .map(|(workers, wall)| {
            serde_json::json!({
                "workers": workers,
                "median_wall_s": wall,
                "runs_per_s": (args.runs * variants) as f64 / wall,
                "x_real_time": simulated_s / wall,
                "speed_up_over_first": medians[0] / wall,
            })
        })
        .collect();
    let report = serde_json::json!({
        "campaign": path.display().to_string(),
        "runs": args.runs * variants,
        "simulated_s_per_run": args.duration,
        "repeats": args.repeats,
        "median_prepare_s": median(prepare_s),
        "rows_identical_across_workers": true,
        "measurements": per_worker,
    });
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!(
        "{} runs × {} simulated s of {} (every run's configuration generated and checked first: median {:.2} s)",
        args.runs * variants,
        args.duration,
        path.display(),
        report["median_prepare_s"].as_f64().unwrap_or(f64::NAN)
    );
    println!(
        "{:>8} {:>16} {:>10} {:>14} {:>10}",
        "workers", "median wall (s)", "runs/s", "× real time", "speed-up"
    );
    for m in &per_worker {
        println!(
            "{:>8} {:>16.2} {:>10.1} {:>14.0} {:>10.2}",
            m["workers"],
            m["median_wall_s"].as_f64().unwrap_or(f64::NAN),
            m["runs_per_s"].as_f64().unwrap_or(f64::NAN),
            m["x_real_time"].as_f64().unwrap_or(f64::NAN),
            m["speed_up_over_first"].as_f64().unwrap_or(f64::NAN)
        );
    }
    println!("rows identical for every worker count: yes");
    Ok(())
}
