//! Speed of `identify` on one hour of 10 Hz data (targets: at most 1 s clean, 3 s with a sensor
//! cause), next to its baselines in the same run: the same identification with its filter
//! passes on one core (as they ran before they were spread across cores), and the time to
//! simulate that hour (the in-process closed loop of the identification experiment, which
//! produced the data).
//!
//! Two records are analysed: clean data (the analysis screens every candidate and names none)
//! and data with one hidden sensor effect (a gyro scale-factor error: the most expensive path,
//! fitted through the attitude filter), each a median of `repeats` runs. The verdicts on one
//! core and on all must be the same.
//!
//! With `--baseline-bin`, another build's `identify_speed` (an earlier commit's, say) is run in
//! turn with this build's identification, `repeats` times each, and the medians compared.
//!
//! `cargo run --release -p testbed-bench --bin identify_speed [-- --duration 3600 --repeats 3 --folds 5 --baseline-bin OTHER/identify_speed --json]`

use anyhow::Context;
use clap::Parser;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use testbed_bench::{baseline_report, median, median_time};
use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::{Options, identify};
use testbed_model::ModelConfig;

/// The targets for one hour of data: clean, and with a sensor cause.
const CLEAN_TARGET_S: f64 = 1.0;
const EFFECT_TARGET_S: f64 = 3.0;

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
    /// Another build's `identify_speed`, run in turn with this build's identification.
    #[arg(long)]
    baseline_bin: Option<PathBuf>,
    #[arg(long)]
    json: bool,
}

/// Seconds of one identification of the clean and of the hidden-effect record by `bin` (its
/// `--json` report, one repeat).
fn baseline_once(bin: &std::path::Path, args: &Args) -> anyhow::Result<(f64, f64, u64)> {
    let report = baseline_report(
        bin,
        &[
            "--duration".into(),
            args.duration.to_string(),
            "--folds".into(),
            args.folds.to_string(),
        ],
    )?;
    let field = |key: &str| {
        report[key]
            .as_f64()
            .with_context(|| format!("the baseline {}'s report has no {key}", bin.display()))
    };
    Ok((
        field("identify_clean_s")?,
        field("identify_hidden_effect_s")?,
        field("identify_hidden_effect_filter_runs")? as u64,
    ))
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
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut timed = Vec::new();
    for threads in [1, cores] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        let mut verdicts = (String::new(), String::new());
        let clean_time = median_time(args.repeats, || {
            verdicts.0 = pool
                .install(|| identify(&clean, &nominal, &analysis))
                .expect("identify runs")
                .report
                .verdict;
        });
        let mut filter_runs = 0;
        let effect_time = median_time(args.repeats, || {
            let id = pool
                .install(|| identify(&effect, &nominal, &analysis))
                .expect("identify runs");
            verdicts.1 = id.report.verdict;
            filter_runs = id.report.filter_runs;
        });
        timed.push((threads, clean_time, effect_time, verdicts, filter_runs));
    }
    anyhow::ensure!(
        timed[0].3 == timed[1].3,
        "the verdicts on one core and on {cores} differ: {:?} against {:?}",
        timed[0].3,
        timed[1].3
    );
    let (_, serial_clean, serial_effect, _, _) = timed[0];
    let (_, clean_time, effect_time, verdicts, filter_runs) = timed.pop().expect("two timings");
    // One filter pass over the record, the unit of the analysis's cost.
    let filter = {
        let aligned = testbed_ident::data::Aligned::new(&clean);
        let start = Instant::now();
        testbed_ident::reconstruct::reconstruct(&aligned, &nominal)?;
        start.elapsed()
    };
    let s = |d: Duration| d.as_secs_f64();
    // Beside another build: one identification of each record by this build, then one by the
    // other, `repeats` times.
    let beside = match &args.baseline_bin {
        None => None,
        Some(bin) => {
            let (mut this, mut other) = ((Vec::new(), Vec::new()), (Vec::new(), Vec::new()));
            let mut other_runs = 0;
            for _ in 0..args.repeats {
                let start = Instant::now();
                identify(&clean, &nominal, &analysis)?;
                this.0.push(s(start.elapsed()));
                let start = Instant::now();
                identify(&effect, &nominal, &analysis)?;
                this.1.push(s(start.elapsed()));
                let (c, e, runs) = baseline_once(bin, &args)?;
                other.0.push(c);
                other.1.push(e);
                other_runs = runs;
            }
            Some(serde_json::json!({
                "bin": bin.display().to_string(),
                "this_clean_s": median(this.0),
                "this_hidden_effect_s": median(this.1),
                "baseline_clean_s": median(other.0),
                "baseline_hidden_effect_s": median(other.1),
                "baseline_hidden_effect_filter_runs": other_runs,
            }))
        }
    };
    let rows = clean.gyro.len();
    let report = serde_json::json!({
        "data_s": args.duration,
        "gyro_rows": rows,
        "repeats": args.repeats,
        "folds": args.folds,
        "simulate_the_hour_s": s(simulate),
        "cores": cores,
        "identify_clean_one_core_s": s(serial_clean),
        "identify_hidden_effect_one_core_s": s(serial_effect),
        "identify_clean_s": s(clean_time),
        "identify_clean_verdict": verdicts.0,
        "identify_hidden_effect_s": s(effect_time),
        "identify_hidden_effect_verdict": verdicts.1,
        "identify_hidden_effect_filter_runs": filter_runs,
        "one_filter_pass_s": s(filter),
        "clean_over_simulation": s(clean_time) / s(simulate),
        "hidden_effect_over_simulation": s(effect_time) / s(simulate),
        "clean_speedup": s(serial_clean) / s(clean_time),
        "hidden_effect_speedup": s(serial_effect) / s(effect_time),
        "target_clean_s": CLEAN_TARGET_S,
        "target_hidden_effect_s": EFFECT_TARGET_S,
        "within_target": s(clean_time) <= CLEAN_TARGET_S && s(effect_time) <= EFFECT_TARGET_S,
        "beside_baseline": beside,
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
            format!("identify, clean data, {cores} cores"),
            s(clean_time),
            verdicts.0
        );
        println!(
            "{:<46} {:>10.3}  ({:.2}× faster)",
            "identify, clean data, one core (baseline)",
            s(serial_clean),
            s(serial_clean) / s(clean_time)
        );
        println!(
            "{:<46} {:>10.3}  -> {} ({filter_runs} filter passes)",
            format!("identify, hidden gyro scale error, {cores} cores"),
            s(effect_time),
            verdicts.1
        );
        println!(
            "{:<46} {:>10.3}  ({:.2}× faster)",
            "identify, hidden gyro scale error, one core",
            s(serial_effect),
            s(serial_effect) / s(effect_time)
        );
        println!(
            "{:<46} {:>10.3}",
            "one attitude-filter pass over the record",
            s(filter)
        );
        if let Some(b) = &beside {
            let f = |k: &str| b[k].as_f64().unwrap_or(f64::NAN);
            println!(
                "beside {} (alternated, medians of {}): clean {:.3} s against {:.3} s ({:.2}×), \
                 hidden effect {:.3} s against {:.3} s ({:.2}×; {} filter passes there)",
                b["bin"].as_str().unwrap_or(""),
                args.repeats,
                f("this_clean_s"),
                f("baseline_clean_s"),
                f("baseline_clean_s") / f("this_clean_s"),
                f("this_hidden_effect_s"),
                f("baseline_hidden_effect_s"),
                f("baseline_hidden_effect_s") / f("this_hidden_effect_s"),
                b["baseline_hidden_effect_filter_runs"],
            );
        }
        println!(
            "identify costs {:.1}× (clean) and {:.1}× (hidden effect) the simulation of the same \
             data; targets ≤ {CLEAN_TARGET_S} s clean, ≤ {EFFECT_TARGET_S} s with the effect: {}",
            s(clean_time) / s(simulate),
            s(effect_time) / s(simulate),
            if s(clean_time) <= CLEAN_TARGET_S && s(effect_time) <= EFFECT_TARGET_S {
                "met"
            } else {
                "MISSED"
            }
        );
    }
    Ok(())
}
