//! Speed of the MEKF on the default run's sensor samples: wall time per propagation (10 Hz) and
//! per vector update (2.5 Hz, the inclinometer and magnetometer blocks gated and applied
//! jointly), medians of repeats; and, with `--baseline-bin`, the same measured by another build
//! of this program (e.g. the commit before a change to the filter), run alternately with this
//! one, repeat by repeat, with the ratio of the medians.
//!
//! The samples come from the simulated plant and sensors (60 s of the default run by default,
//! the plant coasting without commands) and are made once, before any timing. The filter is
//! built from the first vector pair (TRIAD) at the start of each timed pass, so every pass does
//! the same arithmetic.
//!
//! `cargo run --profile deploy -p testbed-bench --bin mekf_speed [-- --duration 60 --passes 20
//!  --repeats 7 --baseline-bin DIR/mekf_speed --json]`

use anyhow::{Context, Result, bail};
use clap::Parser;
use nalgebra::Vector3;
use std::path::PathBuf;
use std::time::Instant;
use testbed_bench::median;
use testbed_config::RunConfig;
use testbed_flight::mekf::{Mekf, MekfConfig, VectorMeasurements};
use testbed_sim::plant_task::PlantTask;
use testbed_sim::sim_devices::{SimGyro, SimInclinometer, SimMagnetometer};

#[derive(Parser)]
struct Args {
    /// Simulated seconds of sensor samples.
    #[arg(long, default_value_t = 60.0)]
    duration: f64,
    /// Passes over the samples per timed repeat (longer repeats, less timer noise).
    #[arg(long, default_value_t = 20)]
    passes: usize,
    /// Timed repeats (the medians are reported).
    #[arg(long, default_value_t = 7)]
    repeats: usize,
    /// Another build of this program, run alternately with this one (`--json --repeats 1`).
    #[arg(long, value_name = "PATH")]
    baseline_bin: Option<PathBuf>,
    #[arg(long)]
    json: bool,
}

/// One tick's samples: time (ns), gyro rate (rad/s, body), and the vector samples due then.
struct Tick {
    t_ns: u64,
    rate_rad_s: Vector3<f64>,
    vectors: Option<VectorMeasurements>,
}

/// Nanoseconds per propagation and per vector update of one timed repeat.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
struct Costs {
    propagate_ns: f64,
    update_ns: f64,
}

fn samples(duration_s: f64) -> Result<(MekfConfig, Vec<Tick>)> {
    let mut config = RunConfig::default();
    config.run.duration_s = duration_s;
    let schedule = config.schedule()?;
    let mut plant = PlantTask::new(&config)?;
    let mut gyro = SimGyro::new(&config, schedule);
    let mut tilt = SimInclinometer::new(&config, schedule);
    let mut field = SimMagnetometer::new(&config, schedule);
    let mut ticks = Vec::new();
    loop {
        let (truth, _) = plant.outputs();
        let g = gyro
            .on_truth(&truth)
            .context("the gyro samples every tick")?;
        let t = tilt.on_truth(&truth);
        let f = field.on_truth(&truth);
        let vectors = (t.is_some() || f.is_some()).then(|| VectorMeasurements {
            tilt_rad: t.map(|s| s.tilt),
            field_b_t: f.map(|s| Vector3::from(s.field)),
        });
        ticks.push(Tick {
            t_ns: g.header.time_ns,
            rate_rad_s: Vector3::from(g.rate),
            vectors,
        });
        if plant.at_end() {
            return Ok((
                config
                    .estimator
                    .filter_params::<testbed_flight::mekf::Mekf>("mekf", &config.model)?,
                ticks,
            ));
        }
        plant.advance()?;
    }
}

/// The filter started by TRIAD from the first tick with both vector samples, and that tick's
/// index.
fn start(config: &MekfConfig, ticks: &[Tick]) -> Result<(Mekf, usize)> {
    for (i, tick) in ticks.iter().enumerate() {
        if let Some(VectorMeasurements {
            tilt_rad: Some([theta, phi]),
            field_b_t: Some(field),
        }) = tick.vectors
        {
            let gravity = testbed_model::attitude::gravity_from_tilt(theta, phi)
                .context("the first tilt sample gives a gravity direction")?;
            let mekf = Mekf::initialise_from_vectors(config.clone(), tick.t_ns, &gravity, &field)?;
            return Ok((mekf, i));
        }
    }
    bail!("no tick has both vector samples")
}

/// One timed repeat: `passes` passes over the ticks, propagations and updates timed apart (the
/// clock read around each call is included, the same in both builds).
fn measure(config: &MekfConfig, ticks: &[Tick], passes: usize) -> Result<Costs> {
    let (mut propagate_s, mut update_s) = (0.0, 0.0);
    let (mut propagations, mut updates) = (0u64, 0u64);
    for _ in 0..passes {
        let (mut mekf, first) = start(config, ticks)?;
        for tick in &ticks[first + 1..] {
            let t0 = Instant::now();
            mekf.propagate(tick.t_ns, &tick.rate_rad_s)?;
            propagate_s += t0.elapsed().as_secs_f64();
            propagations += 1;
            if let Some(vectors) = &tick.vectors {
                let t0 = Instant::now();
                let report = mekf.update(tick.t_ns, vectors);
                update_s += t0.elapsed().as_secs_f64();
                std::hint::black_box(report)?;
                updates += 1;
            }
        }
        std::hint::black_box(mekf.estimate());
    }
    Ok(Costs {
        propagate_ns: propagate_s * 1e9 / propagations.max(1) as f64,
        update_ns: update_s * 1e9 / updates.max(1) as f64,
    })
}

fn baseline_repeat(bin: &std::path::Path, args: &Args) -> Result<Costs> {
    let report = testbed_bench::baseline_report(
        bin,
        &[
            "--duration".into(),
            args.duration.to_string(),
            "--passes".into(),
            args.passes.to_string(),
        ],
    )?;
    Ok(serde_json::from_value(report["this_build"].clone())?)
}

fn medians(costs: &[Costs]) -> Costs {
    Costs {
        propagate_ns: median(costs.iter().map(|c| c.propagate_ns).collect()),
        update_ns: median(costs.iter().map(|c| c.update_ns).collect()),
    }
}

fn main() -> Result<()> {
    let args = Args::parse();
    let (config, ticks) = samples(args.duration)?;
    let updates = ticks.iter().filter(|t| t.vectors.is_some()).count();
    let mut this = Vec::new();
    let mut baseline = Vec::new();
    for _ in 0..args.repeats {
        this.push(measure(&config, &ticks, args.passes)?);
        if let Some(bin) = &args.baseline_bin {
            baseline.push(baseline_repeat(bin, &args)?);
        }
    }
    let this = medians(&this);
    let baseline = (!baseline.is_empty()).then(|| medians(&baseline));
    let report = serde_json::json!({
        "ticks": ticks.len(),
        "vector_updates": updates,
        "passes": args.passes,
        "repeats": args.repeats,
        "this_build": this,
        "baseline": baseline,
        "baseline_over_this": baseline.map(|b| serde_json::json!({
            "propagate": b.propagate_ns / this.propagate_ns,
            "update": b.update_ns / this.update_ns,
        })),
    });
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!(
        "MEKF on {} ticks ({updates} vector updates) × {} passes, medians of {} repeats, ns per call",
        ticks.len(),
        args.passes,
        args.repeats
    );
    println!("{:<12} {:>12} {:>12}", "", "propagate", "update");
    println!(
        "{:<12} {:>12.0} {:>12.0}",
        "this build", this.propagate_ns, this.update_ns
    );
    if let Some(b) = baseline {
        println!(
            "{:<12} {:>12.0} {:>12.0}",
            "baseline", b.propagate_ns, b.update_ns
        );
        println!(
            "{:<12} {:>11.2}× {:>11.2}×",
            "baseline ÷ this",
            b.propagate_ns / this.propagate_ns,
            b.update_ns / this.update_ns
        );
    }
    Ok(())
}
