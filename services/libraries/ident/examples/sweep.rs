//! Development sweep: each hidden effect over seeds, fitted values against the truth (error, in
//! standard errors and per cent), verdicts and gains.
//!
//! `cargo run --release -p testbed-ident --example sweep -- DIR SEEDS DURATION NAME...`: the
//! truth of NAME is `DIR/NAME.toml` (an effects table; an empty file for clean data), SEEDS a
//! comma-separated list.
use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::{Cause, Options, identify};
use testbed_model::ModelConfig;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = &args[1];
    let seeds: Vec<u64> = args[2]
        .split(',')
        .map(|s| s.parse().expect("sweep"))
        .collect();
    let duration: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(600.0);
    for name in args[4..].iter() {
        let text = std::fs::read_to_string(format!("{dir}/{name}.toml")).expect("sweep");
        let truth = ModelConfig::from_toml_str(&text, name).expect("sweep");
        for &seed in &seeds {
            let (data, _) = experiment::run(
                &truth,
                &ExperimentOptions {
                    duration_s: duration,
                    seed,
                    ..Default::default()
                },
            )
            .expect("sweep");
            let id = identify(&data, &ModelConfig::default(), &Options::default()).expect("sweep");
            let r = &id.report;
            let mut line = format!(
                "{name:10} seed {seed:2}: verdict {:30} gain {:8.3}",
                r.verdict, r.gain
            );
            for c in &r.causes {
                let cause = Cause::from_name(c.name).expect("sweep");
                let fitted = cause.values(&id.extended);
                let true_v = if cause.present(&truth) {
                    cause.values(&truth)
                } else {
                    vec![]
                };
                if !true_v.is_empty() {
                    let se = cause
                        .params()
                        .iter()
                        .flat_map(|p| match c.stderr.get(p.key).expect("sweep") {
                            serde_json::Value::Array(a) => a
                                .iter()
                                .map(|x| x.as_f64().unwrap_or(f64::NAN))
                                .collect::<Vec<_>>(),
                            x => vec![x.as_f64().unwrap_or(f64::NAN)],
                        })
                        .collect::<Vec<_>>();
                    let z: Vec<String> = fitted
                        .iter()
                        .zip(&true_v)
                        .zip(&se)
                        .map(|((f, t), s)| {
                            format!(
                                "{:+.1e}({:+.1}σ,{:+.0}%)",
                                f - t,
                                (f - t) / s,
                                100.0 * (f - t) / t.abs().max(1e-300)
                            )
                        })
                        .collect();
                    line += &format!("\n      {}: {}", c.name, z.join(" "));
                }
            }
            println!("{line}");
        }
    }
}
