//! Shared helpers of the identification tests: simulated experiments with hidden effects, blind
//! identification against the nominal model, and parameter checks.

#![allow(dead_code)] // each test binary uses a subset

use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::{Cause, Dataset, Identification, Options, identify};
use testbed_model::ModelConfig;

/// The nominal model: the digest's defaults, no effects.
pub fn nominal() -> ModelConfig {
    ModelConfig::default()
}

/// The nominal model with the effects of a TOML fragment (the hidden truth).
pub fn truth(effects: &str) -> ModelConfig {
    ModelConfig::from_toml_str(effects, "test truth").expect("test truth parses")
}

/// Simulated measured data of the identification experiment on `truth`.
pub fn experiment_data(truth: &ModelConfig, seed: u64, duration_s: f64) -> Dataset {
    let options = ExperimentOptions {
        duration_s,
        seed,
        ..ExperimentOptions::default()
    };
    experiment::run(truth, &options).expect("experiment runs").0
}

/// Identify blind: the data of `truth` against the nominal model.
pub fn identify_blind(truth: &ModelConfig, seed: u64, duration_s: f64) -> Identification {
    let data = experiment_data(truth, seed, duration_s);
    identify(&data, &nominal(), &options()).expect("identification runs")
}

/// The identification's options: the defaults, with `IDENT_FOLDS=K` in the environment K folds
/// of the selection's cross-validation (0: the held-out third instead) and
/// `IDENT_CONSISTENCY_BLOCKS=B` the falsification's block count (to run a suite with other
/// settings).
pub fn options() -> Options {
    let mut options = Options::default();
    if let Ok(k) = std::env::var("IDENT_FOLDS") {
        options.folds = k.parse().expect("IDENT_FOLDS: a number of folds");
    }
    if let Ok(k) = std::env::var("IDENT_CONSISTENCY_BLOCKS") {
        options.consistency_blocks = k
            .parse()
            .expect("IDENT_CONSISTENCY_BLOCKS: a number of blocks");
    }
    options
}

/// Standard errors of a named cause, in the cause's value order (NaN where not estimated).
pub fn stderr(id: &Identification, cause: Cause) -> Vec<f64> {
    let report = id
        .report
        .causes
        .iter()
        .find(|c| c.name == cause.name())
        .expect("cause reported");
    cause
        .params()
        .iter()
        .flat_map(|p| match report.stderr.get(p.key) {
            Some(serde_json::Value::Array(a)) => a
                .iter()
                .map(|x| x.as_f64().unwrap_or(f64::NAN))
                .collect::<Vec<_>>(),
            Some(x) => vec![x.as_f64().unwrap_or(f64::NAN)],
            None => vec![f64::NAN; p.len],
        })
        .collect()
}

/// Names of the causes found, strongest first.
pub fn names(id: &Identification) -> Vec<&'static str> {
    id.report.causes.iter().map(|c| c.name).collect()
}

/// The extended model written as TOML and loaded back as `ModelConfig::load` would.
pub fn extended_round_trip(id: &Identification, tag: &str) -> ModelConfig {
    let dir = std::env::temp_dir().join(format!("testbed-ident-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("extended.toml");
    std::fs::write(&path, id.extended.to_toml_string()).expect("write");
    let back = ModelConfig::load(&path).expect("the extended model loads as it is");
    std::fs::remove_dir_all(&dir).ok();
    back
}

/// Check one hidden cause: named alone, every value within `tol(i, truth)` and within 5
/// standard errors where one is given, no residual left, held-out gain above `min_gain`.
pub fn check_single(
    label: &str,
    truth: &ModelConfig,
    cause: Cause,
    id: &Identification,
    min_gain: f64,
    tol: impl Fn(usize, f64) -> f64,
) {
    let report = &id.report;
    assert_eq!(
        names(id),
        vec![cause.name()],
        "{label}: causes {:?}",
        report.steps
    );
    let fitted = cause.values(&id.extended);
    let hidden = cause.values(truth);
    let se = stderr(id, cause);
    for i in 0..fitted.len() {
        let err = fitted[i] - hidden[i];
        let allowed = tol(i, hidden[i]);
        println!(
            "{label}: {} = {:.6e} (true {:.6e}, error {:+.2e}, {:+.1} σ, allowed ±{:.2e})",
            cause.value_name(i),
            fitted[i],
            hidden[i],
            err,
            err / se[i],
            allowed
        );
        assert!(
            err.abs() <= allowed,
            "{label}: {} = {} vs true {} (allowed ±{allowed})",
            cause.value_name(i),
            fitted[i],
            hidden[i]
        );
        if se[i].is_finite() {
            assert!(
                err.abs() <= 5.0 * se[i],
                "{label}: {} error {err} is more than 5 standard errors ({})",
                cause.value_name(i),
                se[i]
            );
        }
    }
    println!(
        "{label}: held-out gain {:.3} (groups {:?})",
        report.gain, report.gain_by_group
    );
    assert!(
        report.gain > min_gain,
        "{label}: held-out gain {} ≤ {min_gain}",
        report.gain
    );
    assert!(
        !report.remaining.residual_remains,
        "{label}: {}",
        report.remaining.message
    );
    // A library cause alone explains all it absorbed: not flagged by the misattribution guard.
    assert!(
        report.partly_explained.is_empty(),
        "{label}: {:?}",
        report.partly_explained
    );
    assert_eq!(extended_round_trip(id, label), id.extended);
}

/// The identification experiment (seed `seed`, `duration_s`) run on `truth`, `extended` and the
/// nominal model: the RMS over the run of each one's wheel-speed difference from the truth's
/// (rad/s), `(nominal, extended)`. In closed loop the wheels take up the external torque, so
/// their speeds carry its integral: a model that reproduces the effect follows them.
pub fn wheel_speed_rms_from_truth(
    truth: &ModelConfig,
    extended: &ModelConfig,
    seed: u64,
    duration_s: f64,
) -> (f64, f64) {
    let wheels = |model: &ModelConfig| experiment_data(model, seed, duration_s).wheels;
    let (truth_run, extended_run, nominal_run) =
        (wheels(truth), wheels(extended), wheels(&nominal()));
    let rms = |run: &[testbed_ident::data::WheelRow]| {
        let sum: f64 = truth_run
            .iter()
            .zip(run)
            .map(|(a, b)| (a.speed_rad_s - b.speed_rad_s).norm_squared())
            .sum();
        (sum / truth_run.len() as f64).sqrt()
    };
    let (nom, ext) = (rms(&nominal_run), rms(&extended_run));
    println!(
        "wheel-speed RMS difference from the truth: nominal {nom:.3} rad/s, extended {ext:.3} rad/s ({:.1}× closer)",
        nom / ext
    );
    (nom, ext)
}

/// Prints every candidate of every selection step: its likelihood ratio against the threshold,
/// its held-out ratio, whether it was chosen, and the fit's note.
pub fn print_steps(label: &str, id: &Identification) {
    for (i, step) in id.report.steps.iter().enumerate() {
        for r in step {
            println!(
                "{label}: step {i}: {} (k {}): LR {:.1} (threshold {:.1}), held-out {:.1}{}; {}",
                r.name,
                r.k,
                r.lr_fit,
                r.threshold,
                r.lr_held_out,
                if r.chosen { ", chosen" } else { "" },
                r.note
            );
        }
    }
}

/// Prints a named cause's values beside the truth, with their standard errors, and requires each
/// within `k` standard errors (finite and positive) and within `abs` of the truth.
pub fn check_within(
    label: &str,
    id: &Identification,
    truth: &ModelConfig,
    cause: Cause,
    k: f64,
    abs: f64,
) {
    let fitted = cause.values(&id.extended);
    let hidden = cause.values(truth);
    let se = stderr(id, cause);
    for i in 0..fitted.len() {
        let err = fitted[i] - hidden[i];
        println!(
            "{label}: {} = {:.5e} ± {:.1e} (true {:.5e}, error {:+.2e}, {:+.2} σ)",
            cause.value_name(i),
            fitted[i],
            se[i],
            hidden[i],
            err,
            err / se[i]
        );
        assert!(
            se[i].is_finite() && se[i] > 0.0 && err.abs() <= k * se[i] && err.abs() <= abs,
            "{label}: {} = {} ± {} vs true {} (bounds {k} standard errors and ±{abs})",
            cause.value_name(i),
            fitted[i],
            se[i],
            hidden[i]
        );
    }
}
