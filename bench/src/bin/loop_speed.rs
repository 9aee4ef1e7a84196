//! Speed of the in-process closed loop (plant + devices + MEKF + controller) in simulated time
//! per wall time, next to its baseline in the same run: the plant's physics alone.
//!
//! `cargo run --release -p testbed-bench --bin loop_speed [-- --duration 600 --repeats 5 --json]`

use clap::Parser;
use std::time::Duration;
use testbed_bench::median_time;
use testbed_model::ModelConfig;
use testbed_model::physics::{ActuatorCommand, Plant};
use testbed_sim::closed_loop::{self, Scenario};

#[derive(Parser)]
struct Args {
    /// Simulated seconds per run.
    #[arg(long, default_value_t = 600.0)]
    duration: f64,
    /// Timed repeats (the median is reported).
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    #[arg(long)]
    json: bool,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let model = ModelConfig::default();
    let mut scenario = Scenario::paper_stabilisation(model.clone(), 1);
    scenario.duration_s = args.duration;

    let full = median_time(args.repeats, || {
        closed_loop::run(&scenario).expect("closed loop runs");
    });
    let initial = scenario.manoeuvre.initial_state();
    let steps = (args.duration * model.gyro.rate_hz).round() as usize;
    let plant_only = median_time(args.repeats, || {
        let mut plant = Plant::new(&model, initial.clone()).expect("plant");
        let command = ActuatorCommand::default();
        for _ in 0..steps {
            plant
                .step(&command, 1.0 / model.gyro.rate_hz)
                .expect("step");
        }
    });
    let speed = |d: Duration| args.duration / d.as_secs_f64();
    let report = serde_json::json!({
        "simulated_s": args.duration,
        "repeats": args.repeats,
        "in_process_loop": { "median_wall_s": full.as_secs_f64(), "x_real_time": speed(full) },
        "plant_only": { "median_wall_s": plant_only.as_secs_f64(), "x_real_time": speed(plant_only) },
        "loop_over_plant_cost": full.as_secs_f64() / plant_only.as_secs_f64(),
    });
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!("{:<28} {:>14} {:>16}", "", "median wall (s)", "× real time");
        println!(
            "{:<28} {:>14.4} {:>16.0}",
            "in-process closed loop",
            full.as_secs_f64(),
            speed(full)
        );
        println!(
            "{:<28} {:>14.4} {:>16.0}",
            "plant physics only (baseline)",
            plant_only.as_secs_f64(),
            speed(plant_only)
        );
        println!(
            "the full loop costs {:.2}× the physics alone",
            full.as_secs_f64() / plant_only.as_secs_f64()
        );
    }
    Ok(())
}
