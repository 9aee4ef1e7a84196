use std::time::Instant;
use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::{identify, Options};
use testbed_model::ModelConfig;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let effect = args.get(1).cloned().unwrap_or_default();
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let duration: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(600.0);
    let nominal = ModelConfig::default();
    let truth = if effect.is_empty() { nominal.clone() } else { ModelConfig::from_toml_str(&effect, "arg").unwrap() };
    let t = Instant::now();
    let (data, trace) = experiment::run(&truth, &ExperimentOptions { duration_s: duration, seed, ..Default::default() }).unwrap();
    println!("experiment {:?}, tilt stops {}", t.elapsed(), trace.tilt_stops.len());
    let max_tilt = trace.ticks.iter().map(|k| testbed_model::attitude::tilt_angles(&k.truth.q).iter().fold(0.0f64, |a, b| a.max(b.abs()))).fold(0.0, f64::max);
    let max_n: Vec<f64> = (0..3).map(|i| trace.ticks.iter().map(|k| k.truth.wheel_speed[i].abs()).fold(0.0, f64::max)).collect();
    println!("max tilt {:.2} deg, max wheel speeds {:?}", max_tilt.to_degrees(), max_n);
    for w in 0..3 {
        let near: Vec<f64> = data.wheels.iter().filter(|r| r.speed_rad_s[w].abs() < 2.0).map(|r| r.t_s).collect();
        let crossings = data.wheels.windows(2).filter(|p| p[0].speed_rad_s[w] * p[1].speed_rad_s[w] < 0.0).count();
        println!("wheel {w}: {} samples |n|<2, {} sign changes, times {:?}", near.len(), crossings, near.iter().step_by(5).map(|t| *t as i64).collect::<Vec<_>>());
    }
    let t = Instant::now();
    let id = identify(&data, &nominal, &Options::default()).unwrap();
    println!("identify {:?} ({} filter runs)", t.elapsed(), id.report.filter_runs);
    let r = &id.report;
    println!("nominal channel rms fit {:?} held {:?}", r.nominal_residuals.channel_rms_fit, r.nominal_residuals.channel_rms_held_out);
    for (i, step) in r.steps.iter().enumerate() {
        println!("step {i}");
        for c in step { println!("  {:22} k={:2} lr={:12.1} thr={:8.1} held={:12.1} sig={} chosen={} {}", c.name, c.k, c.lr_fit, c.threshold, c.lr_held_out, c.significant, c.chosen, c.note); }
    }
    println!("verdict: {}", r.verdict);
    for c in &r.causes { println!("  {} {} ± {}", c.name, serde_json::Value::Object(c.parameters.clone()), serde_json::Value::Object(c.stderr.clone())); }
    println!("remaining: {}", r.remaining.message);
    for c in &r.remaining.correlations { println!("   {} ~ {} r={:.3}", c.residual, c.signal, c.r); }
    println!("baseline overall {:.3} extended {:.3} gain {:.3}", r.baseline_rms.overall, r.extended_rms.overall, r.gain);
    println!("groups base {:?}\n       ext {:?}", r.baseline_rms.groups, r.extended_rms.groups);
    for e in &r.nominal_residuals.equation_error { println!("  nominal {:22} nrms {:8.3} mean {:10.3e} lag1 {:6.3} white_p {:.2e}", e.name, e.normalised_rms, e.stats.mean, e.stats.lag1, e.stats.white_p); }
}
#[allow(dead_code)]
fn unused() {}
