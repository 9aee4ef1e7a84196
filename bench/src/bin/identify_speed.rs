//! Speed of `identify` on one hour of 10 Hz data (target: under 10 s), next to its baseline in
//! the same run: the time to simulate that hour (the in-process closed loop of the
//! identification experiment, which produced the data).
//!
//! Two records are analysed: clean data (the analysis screens every candidate and names none)
//! and data with one hidden sensor effect (a gyro scale-factor error: the most expensive path,
//! fitted through the attitude filter), each a median of `repeats` runs.
//!
//! `cargo run --release -p testbed-bench --bin identify_speed [-- --duration 3600 --repeats 3 --folds 5 --json]`

use clap::Parser;
use std::time::{Duration, Instant};
use testbed_bench::median_time;
use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::{Options, identify};
use testbed_model::ModelConfig;

#[derive(Parser)]
struct Args {
    /// Simulated seconds of data.
    #[arg(long, default_value_t = 3600.0)]
    duration: f64,
    /// Timed repeats (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Folds of the selection's cross-validation (`Options::folds`; 0: the held-out third).
    #[arg(long, default_value_t = Options::default().folds)]
    folds: usize,
    #[arg(long)]
    json: bool,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let nominal = ModelConfig::default();
    let hidden = ModelConfig::from_toml_str(
        "[effects.gyro_scale]\nppm = [500.0, -700.0, 900.0]\n",
        "bench",
    )?;
    let options = ExperimentOptions {
        duration_s: args.duration,
        seed: 1,
        ..ExperimentOptions::default()
    };

    let simulate = median_time(args.repeats, || {
        experiment::run(&nominal, &options).expect("experiment runs");
    });
    let (clean, _) = experiment::run(&nominal, &options)?;
    let (effect, _) = experiment::run(&hidden, &options)?;
    let analysis = Options {
        folds: args.folds,
        ..Options::default()
    };
    let mut verdicts = (String::new(), String::new());
    let clean_time = median_time(args.repeats, || {
        verdicts.0 = identify(&clean, &nominal, &analysis)
            .expect("identify runs")
            .report
            .verdict;
    });
    let mut filter_runs = 0;
    let effect_time = median_time(args.repeats, || {
        let id = identify(&effect, &nominal, &analysis).expect("identify runs");
        verdicts.1 = id.report.verdict;
        filter_runs = id.report.filter_runs;
    });
    // One filter pass over the record, the unit of the analysis's cost.
    let filter = {
        let aligned = testbed_ident::data::Aligned::new(&clean);
        let start = Instant::now();
        testbed_ident::reconstruct::reconstruct(&aligned, &nominal)?;
        start.elapsed()
    };
    let s = |d: Duration| d.as_secs_f64();
    let rows = clean.gyro.len();
    let report = serde_json::json!({
        "data_s": args.duration,
        "gyro_rows": rows,
        "repeats": args.repeats,
        "folds": args.folds,
        "simulate_the_hour_s": s(simulate),
        "identify_clean_s": s(clean_time),
        "identify_clean_verdict": verdicts.0,
        "identify_hidden_effect_s": s(effect_time),
        "identify_hidden_effect_verdict": verdicts.1,
        "identify_hidden_effect_filter_runs": filter_runs,
        "one_filter_pass_s": s(filter),
        "clean_over_simulation": s(clean_time) / s(simulate),
        "hidden_effect_over_simulation": s(effect_time) / s(simulate),
        "target_s": 10.0,
        "within_target": s(clean_time) < 10.0 && s(effect_time) < 10.0,
    });
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{:.0} s of 10 Hz data ({rows} gyro rows), medians of {} runs, folds {}",
            args.duration, args.repeats, args.folds
        );
        println!("{:<46} {:>10}", "", "wall (s)");
        println!(
            "{:<46} {:>10.3}",
            "simulate the hour (baseline)",
            s(simulate)
        );
        println!(
            "{:<46} {:>10.3}  -> {}",
            "identify, clean data",
            s(clean_time),
            verdicts.0
        );
        println!(
            "{:<46} {:>10.3}  -> {} ({filter_runs} filter passes)",
            "identify, hidden gyro scale error",
            s(effect_time),
            verdicts.1
        );
        println!(
            "{:<46} {:>10.3}",
            "one attitude-filter pass over the record",
            s(filter)
        );
        println!(
            "identify costs {:.1}× (clean) and {:.1}× (hidden effect) the simulation of the same data; target < 10 s: {}",
            s(clean_time) / s(simulate),
            s(effect_time) / s(simulate),
            if s(clean_time) < 10.0 && s(effect_time) < 10.0 {
                "met"
            } else {
                "MISSED"
            }
        );
    }
    Ok(())
}
