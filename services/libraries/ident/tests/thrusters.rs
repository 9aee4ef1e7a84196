//! Identification from data with thruster firings: a simulated run in which
//! the thrusters dump the wheels' momentum against a constant disturbance, with a hidden
//! per-thruster thrust scale error, a hidden tank-position error or a drifting gyro bias,
//! identified blind against the model without it (the model knows the thrusters and the
//! disturbance). Clean data must give `none`.

mod common;
use common::*;
use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::{Cause, Dataset, Identification, Options, identify};
use testbed_model::ModelConfig;
use testbed_model::config::ConstantTorque;
use testbed_model::thruster_config::{ThrusterConfig, ThrusterTorqueScale};

/// Constant disturbance, Nm, body axes: ten times the thruster show's, so the wheels reach the
/// dump threshold (0.5 Nms) from 0.1 Nms within 220–330 s.
const DISTURBANCE_NM: [f64; 3] = [1.2e-3, -1.2e-3, 1.8e-3];

/// The model the data are identified against: the default platform with the six thrusters and
/// the constant disturbance.
fn model() -> ModelConfig {
    let mut m = ModelConfig {
        thrusters: Some(ThrusterConfig::default()),
        ..ModelConfig::default()
    };
    m.effects.constant_torque = Some(ConstantTorque {
        torque_nm: DISTURBANCE_NM,
    });
    m
}

/// The run: tilt steps of 7° every 30 s at a fixed heading (so the propellant's gravity torque
/// has a vertical lever too), the wheels starting at 55 % of their momentum with the signs
/// opposite to what the disturbance builds up, and momentum dumping. The first dump fires
/// thrusters 0, 3 and 4; the disturbance then fills the wheels the other way and the later dumps
/// fire 1, 2 and 5: every thruster fires.
fn run(truth: &ModelConfig, seed: u64, duration_s: f64) -> Dataset {
    let options = ExperimentOptions::thruster_programme(duration_s, seed);
    experiment::run(truth, &options).expect("run").0
}

fn report(label: &str, data: &Dataset, id: &Identification) {
    let mut on = [0.0; 6];
    for r in &data.thrusters {
        for (a, x) in on.iter_mut().zip(&r.on_time_s) {
            *a += x;
        }
    }
    println!("{label}: commanded on-time per thruster {on:.2?} s");
    print_steps(label, id);
    println!(
        "{label}: verdict {} gain {:.3} remaining {}",
        id.report.verdict, id.report.gain, id.report.remaining.message
    );
}

const SEEDS: [u64; 3] = [31, 32, 33];

#[test]
fn a_thruster_at_80_percent_is_named_with_every_scale_within_3_standard_errors() {
    // Thruster 2 (+Y) delivers 80 % of its thrust (a worn nozzle); the others are nominal.
    let nominal = model();
    let mut truth = model();
    truth.effects.thruster_torque_scale = Some(ThrusterTorqueScale {
        scale: [1.0, 1.0, 0.8, 1.0, 1.0, 1.0],
    });
    let mut beyond = Vec::new();
    let mut chi2 = 0.0;
    for seed in SEEDS {
        let label = format!("thruster scale seed {seed}");
        let data = run(&truth, seed, 600.0);
        let id = identify(&data, &nominal, &Options::default()).expect("identification runs");
        report(&label, &data, &id);
        assert_eq!(names(&id), vec!["thruster_torque_scale"], "{label}");
        // Every thruster fired, so every scale is estimated (standard errors 0.13–0.18 %: least
        // squares and the pulses' 2 % thrust noise), within 0.01 of the truth (5 % of the hidden
        // error), and the hidden one within 3 standard errors on every seed.
        let fitted = Cause::ThrusterTorqueScale.values(&id.extended);
        let hidden = Cause::ThrusterTorqueScale.values(&truth);
        let se = stderr(&id, Cause::ThrusterTorqueScale);
        for i in 0..6 {
            let z = (fitted[i] - hidden[i]) / se[i];
            println!(
                "{label}: scale[{i}] = {:.5} (true {:.2}, se {:.2e}, {z:+.2} σ)",
                fitted[i], hidden[i], se[i]
            );
            assert!(se[i].is_finite() && se[i] > 0.0, "{label}: scale[{i}]");
            assert!((fitted[i] - hidden[i]).abs() <= 0.01, "{label}: scale[{i}]");
            chi2 += z * z;
            if z.abs() > 3.0 {
                beyond.push((seed, i, z));
            }
        }
        let z2 = (fitted[2] - hidden[2]) / se[2];
        assert!(z2.abs() <= 3.0, "{label}: the hidden scale is {z2} σ off");
        // The model without the scale error mispredicts every dump; measured 3.5–3.8.
        assert!(id.report.gain > 2.0, "{label}: gain {}", id.report.gain);
        assert_eq!(extended_round_trip(&id, "thruster-scale"), id.extended);
    }
    // Over the 18 values: measured χ² = 34 (1.9 per value) and one value beyond 3 σ (seed 31,
    // thruster 4, −3.3 σ). The errors themselves are calibrated (χ² per value 0.85 over 12 more
    // seeds, `scale_standard_errors_are_calibrated`); thruster 4 fires only at the start of the
    // run and carries the estimator's start-up (mean −1.6 σ). Asserted: at most one of 18
    // beyond 3 σ and none beyond 4 σ, χ² per value ≤ 2.5.
    println!("thruster scale: χ² {chi2:.1} over 18 values; beyond 3 σ: {beyond:?}");
    assert!(
        beyond.len() <= 1 && beyond.iter().all(|b| b.2.abs() <= 4.0),
        "{beyond:?}"
    );
    assert!(chi2 / 18.0 <= 2.5, "χ² {chi2}");
}

#[test]
fn a_tank_off_its_assumed_position_is_named_as_the_propellant_com_shift() {
    // The propellant sits 5 mm off its assumed horizontal position on both axes (the model
    // assumes (2, 1, −100) mm): the 5–8 g used over the run make a gravity torque that grows
    // to 0.5 mNm.
    let nominal = model();
    let mut truth = model();
    if let Some(t) = truth.thrusters.as_mut() {
        t.tank_position_m = [0.007, -0.004, -0.10];
    }
    for seed in SEEDS {
        let label = format!("tank position seed {seed}");
        let data = run(&truth, seed, 600.0);
        let id = identify(&data, &nominal, &Options::default()).expect("identification runs");
        report(&label, &data, &id);
        assert_eq!(names(&id), vec!["propellant_com_shift"], "{label}");
        // Horizontal within 3 standard errors (about 0.05 mm) and 0.5 mm (a tenth of the hidden
        // error); the vertical position acts only through the 7° tilt steps (standard error
        // about 0.7 mm): within 3 standard errors and 3 mm.
        check_within(&label, &id, &truth, Cause::PropellantComShift, 3.0, 3e-3);
        let fitted = Cause::PropellantComShift.values(&id.extended);
        let hidden = Cause::PropellantComShift.values(&truth);
        for (axis, (f, h)) in fitted.iter().zip(&hidden).take(2).enumerate() {
            assert!(
                (f - h).abs() <= 0.5e-3,
                "{label}: axis {axis} error {} m",
                f - h
            );
        }
        // Measured 2.5–2.9.
        assert!(id.report.gain > 1.5, "{label}: gain {}", id.report.gain);
        assert_eq!(extended_round_trip(&id, "tank"), id.extended);
    }
}

/// The attitude filter's runs are shared between configurations with the same sensor causes
/// (`SensorKey`), so its pulse correction must not depend on the torque causes: a thrust
/// scale or an inertia error leaves the reconstruction of thruster data bit for bit.
#[test]
fn the_reconstruction_of_thruster_data_depends_on_the_sensor_causes_only() {
    let nominal = model();
    let data = testbed_ident::data::Aligned::new(&run(&nominal, 41, 600.0));
    let mut other = nominal.clone();
    other.effects.thruster_torque_scale = Some(ThrusterTorqueScale {
        scale: [0.8, 1.0, 1.2, 1.0, 0.9, 1.0],
    });
    Cause::InertiaError.apply(&mut other, &[0.05, -0.05, 0.02, 0.5, 0.0, -0.5]);
    let reconstruct = |m: &ModelConfig| testbed_ident::reconstruct::reconstruct(&data, m);
    let (a, b) = (reconstruct(&nominal), reconstruct(&other));
    let (a, b) = (a.expect("filter run"), b.expect("filter run"));
    assert_eq!(a.q, b.q);
    assert_eq!(a.rate, b.rate);
}

#[test]
fn a_gyro_bias_drift_is_named_on_thruster_data() {
    // The drift of `causes.rs`' `gyro_bias_drift` in the momentum-dumping runs: the pulses'
    // rate steps inside the ticks are propagated where they fall, so they are no drift (clean
    // records below) and a drift is still one.
    let nominal = model();
    let mut truth = model();
    truth.effects.gyro_bias_drift = Some(testbed_model::config::GyroBiasDrift {
        rate_rad_s2: [1e-7, -7e-8, 5e-8],
    });
    for seed in SEEDS {
        let label = format!("gyro bias drift seed {seed}");
        let data = run(&truth, seed, 600.0);
        let id = identify(&data, &nominal, &Options::default()).expect("identification runs");
        report(&label, &data, &id);
        assert_eq!(names(&id), vec!["gyro_bias_drift"], "{label}");
        // Measured within 2.1 σ.
        check_within(&label, &id, &truth, Cause::GyroBiasDrift, 3.0, 1e-8);
        // Measured 2.2–2.4.
        assert!(id.report.gain > 1.5, "{label}: gain {}", id.report.gain);
    }
}

#[test]
fn clean_thruster_data_give_none() {
    let nominal = model();
    for seed in [41, 42, 43, 44, 45] {
        let label = format!("clean thrusters seed {seed}");
        let data = run(&nominal, seed, 600.0);
        assert!(
            data.thrusters
                .iter()
                .any(|r| r.on_time_s.iter().any(|x| *x > 0.0))
        );
        let id = identify(&data, &nominal, &Options::default()).expect("identification runs");
        report(&label, &data, &id);
        // Both thruster causes were candidates (fitted, not significant).
        for c in [Cause::ThrusterTorqueScale, Cause::PropellantComShift] {
            let row = id.report.steps[0]
                .iter()
                .find(|r| r.name == c.name())
                .expect("a candidate");
            assert!(!row.significant, "{label}: {}", c.name());
        }
        assert_eq!(id.report.verdict, "none", "{label}");
        assert_eq!(id.extended, nominal, "{label}");
        assert!((id.report.gain - 1.0).abs() < 1e-12, "{label}");
    }
}

#[test]
fn data_without_thruster_firings_do_not_offer_the_thruster_causes() {
    // The identification experiment without thrusters, and with thrusters that never fire.
    let plain = experiment_data(&nominal(), 51, 300.0);
    assert!(plain.thrusters.is_empty());
    let quiet_model = ModelConfig {
        thrusters: Some(ThrusterConfig::default()),
        ..ModelConfig::default()
    };
    let quiet = experiment_data(&quiet_model, 51, 300.0);
    assert!(!quiet.thrusters.is_empty());
    assert!(quiet.thrusters.iter().all(|r| r.on_time_s == [0.0; 6]));
    // The thrusters that never fire change nothing in the run.
    assert_eq!(quiet.gyro, plain.gyro);
    for (data, model) in [(&plain, nominal()), (&quiet, quiet_model)] {
        let id = identify(data, &model, &Options::default()).expect("identification runs");
        let listed: Vec<&str> = id.report.steps[0].iter().map(|r| r.name).collect();
        assert!(
            !listed.contains(&"thruster_torque_scale") && !listed.contains(&"propellant_com_shift"),
            "{listed:?}"
        );
        assert_eq!(listed.len(), Cause::ALL.len() - 2);
    }
}

#[test]
fn thruster_data_round_trip_through_the_csv_directory() {
    let data = run(&model(), 61, 120.0);
    let dir = std::env::temp_dir().join(format!("testbed-ident-thr-{}", std::process::id()));
    let written = testbed_ident::data::write_dir(&dir, &data).expect("written");
    assert!(written.iter().any(|p| p.ends_with("thrusters.csv")));
    let text = std::fs::read_to_string(dir.join("thrusters.csv")).expect("read");
    assert!(
        text.starts_with(
            "t_s,on_time_0_s,on_time_1_s,on_time_2_s,on_time_3_s,on_time_4_s,on_time_5_s\n"
        ),
        "{}",
        &text[..80]
    );
    let back = testbed_ident::data::read_dir(&dir).expect("read back");
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(back.thrusters, data.thrusters);
    assert_eq!(back.gyro, data.gyro);
    // A negative on-time is refused, naming the file, row and column.
    let mut bad = back.clone();
    bad.thrusters[3].on_time_s[4] = -0.01;
    let e = bad.check().expect_err("refused").to_string();
    assert!(
        e.contains("thrusters.csv") && e.contains("row 4") && e.contains("on_time_4_s"),
        "{e}"
    );
}

/// Calibration of the scales' standard errors over 12 more seeds: χ² per value over the 72
/// fitted scales must lie in [0.5, 1.5] (for calibrated errors its mean is 1 and its standard
/// deviation √(2/72) = 0.17: the band is ±3 of those). Measured 2026-11-24: 0.85 — calibrated;
/// the one systematic error is thruster 4 (+Z) at a mean of −1.6 σ (−0.27 %): it fires only in
/// the first dump, at the start of the run, while the heading estimate is still settling.
/// `cargo test --release -p testbed-ident --test thrusters scale_standard_errors_are_calibrated
/// -- --ignored --nocapture` (about 20 s).
#[test]
#[ignore = "a 12-seed study, about 20 s"]
fn scale_standard_errors_are_calibrated() {
    let nominal = model();
    let mut truth = model();
    truth.effects.thruster_torque_scale = Some(ThrusterTorqueScale {
        scale: [1.0, 1.0, 0.8, 1.0, 1.0, 1.0],
    });
    let mut zs = Vec::new();
    for seed in 100..112u64 {
        let data = run(&truth, seed, 600.0);
        let id = identify(&data, &nominal, &Options::default()).expect("identification runs");
        assert_eq!(names(&id), vec!["thruster_torque_scale"], "seed {seed}");
        let fitted = Cause::ThrusterTorqueScale.values(&id.extended);
        let hidden = Cause::ThrusterTorqueScale.values(&truth);
        let se = stderr(&id, Cause::ThrusterTorqueScale);
        let z: Vec<f64> = (0..6).map(|i| (fitted[i] - hidden[i]) / se[i]).collect();
        println!(
            "seed {seed}: z {:?}",
            z.iter().map(|v| format!("{v:+.2}")).collect::<Vec<_>>()
        );
        zs.extend(z);
    }
    let per_value = zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64;
    println!("χ² per value {per_value:.2} over {} values", zs.len());
    assert!((0.5..=1.5).contains(&per_value), "χ² per value {per_value}");
}
