//! Experiment design (`testbed_ident::design`): the designed programme against
//! the default one, predicted and measured.
//!
//! The measured comparisons hide causes in the truth (four torque and wheel causes; or three
//! sensor causes), design the programme on the nominal model (what a lab user has before
//! identifying), with the default targets and with exactly the hidden causes, run both
//! programmes on the truth for fixed seeds and identify each blind; they compare the standard
//! errors identify reports with the predicted ones, and the actual errors. A third ignored test
//! measures how much unmodelled centre-of-mass offset each programme tolerates. Ignored (about
//! 4.5 minutes in all): run with
//! `cargo test --release -p testbed-ident --test design -- --ignored --nocapture --test-threads 1`;
//! the tables in `docs/measured-data.md` ("Experiment design") are their output.

mod common;
use common::*;
use testbed_ident::design::{self, DesignOptions, Limit};
use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::{Cause, Options, identify};
use testbed_model::ModelConfig;

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// The torque and wheel truth: 0.3 µm / −0.2 µm horizontal and 0.5 µm pendulous
/// centre-of-mass offset (about 1.2 mNm of gravity torque level: no tilt-stop strike in the
/// 600 s of either programme), a constant
/// torque of 0.4, −0.3 and 0.2 mNm, inertia errors of 3, −2 and 4 %, wheel torque scales of
/// 0.95, 1.04 and 0.97.
const TRUTH: &str = "[effects.com_offset]\nr_m = [3.0e-7, -2.0e-7, -5.0e-7]\n\
[effects.constant_torque]\ntorque_nm = [4.0e-4, -3.0e-4, 2.0e-4]\n\
[effects.inertia_error]\nfraction = [0.03, -0.02, 0.04]\n\
[effects.wheel_torque_scale]\nscale = [0.95, 1.04, 0.97]\n";

/// The sensor-side truth: hard iron (0.08, −0.05, 0.1) G, gyro scale (500, −700, 900) ppm and
/// the Earth rate at 43.88° N, the magnitudes of the library's tests.
const SENSOR_TRUTH: &str = "[effects.magnetic_disturbance]\nhard_iron_gauss = [0.08, -0.05, 0.1]\n\
[effects.gyro_scale]\nppm = [500.0, -700.0, 900.0]\n\
[effects.earth_rate]\nlatitude_deg = 43.88\n";

const TORQUE_CAUSES: [Cause; 4] = [
    Cause::ComOffset,
    Cause::ConstantTorque,
    Cause::InertiaError,
    Cause::WheelTorqueScale,
];

const SENSOR_CAUSES: [Cause; 3] = [
    Cause::MagneticDisturbance,
    Cause::GyroScale,
    Cause::EarthRate,
];

/// Every parameter of the hidden causes: (cause, value offset).
fn hidden(causes: &[Cause]) -> Vec<(Cause, usize)> {
    causes
        .iter()
        .flat_map(|&c| (0..c.len()).map(move |i| (c, i)))
        .collect()
}

/// Reported standard errors and actual errors of the hidden parameters (NaN where the cause
/// was not named), the causes named and the tilt-stop strikes.
fn measure(
    truth: &ModelConfig,
    causes: &[Cause],
    options: &ExperimentOptions,
) -> (Vec<f64>, Vec<f64>, Vec<&'static str>, usize) {
    let (data, trace) = experiment::run(truth, options).expect("experiment runs");
    let id = identify(&data, &nominal(), &Options::default()).expect("identification runs");
    let named = names(&id);
    let mut se = Vec::new();
    let mut err = Vec::new();
    for (cause, i) in hidden(causes) {
        if named.contains(&cause.name()) {
            se.push(stderr(&id, cause)[i]);
            err.push(cause.values(&id.extended)[i] - cause.values(truth)[i]);
        } else {
            se.push(f64::NAN);
            err.push(f64::NAN);
        }
    }
    (se, err, named, trace.tilt_stops.len())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[test]
fn the_search_beats_the_default_within_the_limits() {
    // About 50 closed-loop simulations of 600 s: a few seconds in a release build.
    let settings = DesignOptions::default();
    let d =
        design::design(&nominal(), &ExperimentOptions::default(), &settings).expect("design runs");
    println!(
        "{} simulated, {} rejected; log det {:.2} -> {:.2}; {:?}",
        d.evaluated,
        d.rejected,
        d.baseline.criterion.log_det,
        d.chosen.criterion.log_det,
        d.chosen.options
    );
    assert!(d.baseline.admissible(), "{:?}", d.baseline.rejected);
    assert!(d.chosen.admissible());
    assert_eq!(d.chosen.criterion.unidentified, 0);
    assert!(d.chosen.criterion.log_det >= d.baseline.criterion.log_det);
    assert!(d.chosen.tilt_stop_strikes == 0);
    assert!(d.chosen.max_tilt_deg <= 30.0 - settings.limits.tilt_margin_deg);
    assert!(d.chosen.max_wheel_speed_fraction <= settings.limits.wheel_speed_fraction);
    assert_eq!(d.chosen.options.duration_s, 600.0);
    // Some candidates broke a limit (the grids reach past them) and were not chosen; none
    // failed to simulate.
    assert!(d.rejected > 0);
    assert_eq!(d.rejections.len(), d.rejected);
    assert!(d.rejections.iter().all(|r| r.limit != Limit::Failed));
    for r in &d.rejections {
        println!("rejected {:?}: {}", r.limit, r.why);
    }
    // Deterministic: the chosen programme evaluated again gives the same criterion.
    let again = design::evaluate(&nominal(), &d.chosen.options, &settings).expect("evaluates");
    assert_eq!(again.criterion, d.chosen.criterion);
    assert_eq!(d.parameters.len(), d.chosen.stderr.len());
    assert!(d.chosen.stderr.iter().all(|s| s.is_finite() && *s > 0.0));
    // A horizontal centre-of-mass offset and a constant torque about a horizontal axis differ
    // only through the cosine of a few degrees of tilt: the report says the programme cannot
    // tell them apart.
    for c in &d.unseparable {
        println!(
            "unseparable: {} and {}: {:?}",
            c.first, c.second, c.correlation
        );
    }
    let pair = |a: &str, b: &str| {
        d.unseparable.iter().any(|c| {
            (c.first.starts_with(a) && c.second.starts_with(b))
                || (c.first.starts_with(b) && c.second.starts_with(a))
        })
    };
    assert!(
        pair("constant_torque.", "com_offset."),
        "{:?}",
        d.unseparable
    );
}

#[test]
fn a_programme_past_the_wheel_limit_is_rejected() {
    // 0.9 °/s of heading slew needs about 1 Nms on the Z wheel: past 85 % of its speed.
    let fast = ExperimentOptions {
        heading_rate_deg_s: 0.9,
        ..ExperimentOptions::default()
    };
    let e = design::evaluate(&nominal(), &fast, &DesignOptions::default()).expect("evaluates");
    println!(
        "{:?}, wheel at {:.2}",
        e.rejected, e.max_wheel_speed_fraction
    );
    assert!(!e.admissible());
    assert!(e.max_wheel_speed_fraction > 0.85);
    assert_eq!(e.limit, Some(Limit::WheelSpeed));
    assert!(e.rejected.as_deref().is_some_and(|r| r.contains("wheel")));
}

/// What [`compare`] asserts beyond the design's own guarantees.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Check {
    /// The targets are exactly the hidden causes: predictions within their bounds.
    Exact,
    /// The targets include the hidden causes and others.
    Targets,
    /// The hidden causes are not among the targets: measured only (their naming aside).
    Unchecked,
}

/// Design on the nominal model with `settings`, then run the default and the designed
/// programmes on the truth for every seed and identify each blind; print the table and check
/// what the design guarantees. With [`Check::Exact`] the predicted standard errors are those of
/// the fit identify makes (otherwise the prediction also estimates target causes identify does
/// not fit, which changes some errors).
fn compare(
    label: &str,
    truth_toml: &str,
    causes: &[Cause],
    seeds: &[u64],
    settings: &DesignOptions,
    check: Check,
) {
    let exact = check == Check::Exact;
    let truth = truth(truth_toml);
    let baseline = ExperimentOptions::default();
    let d = design::design(&nominal(), &baseline, settings).expect("design runs");
    println!(
        "## {label}: {} candidates simulated ({} rejected), {} passes",
        d.evaluated, d.rejected, d.passes
    );
    println!("default:  {:?}", d.baseline.options);
    println!("designed: {:?}", d.chosen.options);
    println!(
        "log det: default {:.2}, designed {:.2}; max tilt {:.1}° -> {:.1}°, max wheel speed {:.0} % -> {:.0} %",
        d.baseline.criterion.log_det,
        d.chosen.criterion.log_det,
        d.baseline.max_tilt_deg,
        d.chosen.max_tilt_deg,
        100.0 * d.baseline.max_wheel_speed_fraction,
        100.0 * d.chosen.max_wheel_speed_fraction
    );
    // What the search guarantees: the baseline is a candidate and only a better admissible
    // candidate replaces it.
    assert_eq!(d.chosen.criterion.unidentified, 0);
    assert!(d.chosen.criterion.log_det >= d.baseline.criterion.log_det);
    assert!(d.chosen.admissible());

    let params = hidden(causes);
    // Predicted standard errors (NaN when the parameter is not a target).
    let predicted = |c: Cause, i: usize| {
        d.parameters
            .iter()
            .position(|p| *p == c.value_name(i))
            .map_or((f64::NAN, f64::NAN), |j| {
                (d.baseline.stderr[j], d.chosen.stderr[j])
            })
    };
    let n = params.len();
    // Per parameter, over the seeds in which both programmes named its cause.
    let (mut se_a, mut se_b, mut ratio) = (vec![vec![]; n], vec![vec![]; n], vec![vec![]; n]);
    let (mut err_a, mut err_b) = (vec![vec![]; n], vec![vec![]; n]);
    let (mut all_a, mut all_b, mut strikes) = (0, 0, 0);
    for &seed in seeds {
        let a = measure(
            &truth,
            causes,
            &ExperimentOptions {
                seed,
                ..d.baseline.options.clone()
            },
        );
        let b = measure(
            &truth,
            causes,
            &ExperimentOptions {
                seed,
                ..d.chosen.options.clone()
            },
        );
        println!(
            "seed {seed}: default names {:?} ({} stop strikes), designed names {:?} ({} stop strikes)",
            a.2, a.3, b.2, b.3
        );
        strikes += a.3 + b.3;
        all_a += usize::from(a.0.iter().all(|s| s.is_finite()));
        all_b += usize::from(b.0.iter().all(|s| s.is_finite()));
        for k in 0..n {
            if a.0[k].is_finite() && b.0[k].is_finite() {
                se_a[k].push(a.0[k]);
                se_b[k].push(b.0[k]);
                ratio[k].push(b.0[k] / a.0[k]);
                err_a[k].push(a.1[k]);
                err_b[k].push(b.1[k]);
            }
        }
    }
    println!(
        "every hidden cause named: default {all_a} of {} seeds, designed {all_b}; tilt-stop strikes {strikes}",
        seeds.len()
    );
    println!(
        "| parameter | SE default, predicted | SE default, reported (median) | SE designed, predicted | SE designed, reported (median) | ratio predicted | ratio reported (median) | RMS error default | RMS error designed |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let (mut norm_a, mut norm_b) = (Vec::new(), Vec::new());
    for (k, &(c, i)) in params.iter().enumerate() {
        let (pa, pb) = predicted(c, i);
        let (ma, mb, mr) = (
            median(se_a[k].clone()),
            median(se_b[k].clone()),
            median(ratio[k].clone()),
        );
        println!(
            "| `{}` | {pa:.2e} | {ma:.2e} | {pb:.2e} | {mb:.2e} | {:.2} | {mr:.2} | {:.2e} | {:.2e} |",
            c.value_name(i),
            pb / pa,
            rms(&err_a[k]),
            rms(&err_b[k])
        );
        // Each parameter's errors in units of its standard error on the default programme
        // (predicted, or reported when not a target): every parameter weighs the same.
        let unit = if pa.is_finite() { pa } else { ma };
        norm_a.extend(err_a[k].iter().map(|e| e / unit));
        norm_b.extend(err_b[k].iter().map(|e| e / unit));
        assert!(
            ratio[k].len() >= seeds.len() / 2,
            "{}: too few seeds",
            c.value_name(i)
        );
        if exact {
            // The information is the fits' own normal equations: the standard errors identify
            // reports (residual-scaled) are within a third of the prediction, and the measured
            // reduction is the predicted one within 25 %.
            for (m, p) in [(ma, pa), (mb, pb)] {
                assert!(
                    (0.75..=1.33).contains(&(m / p)),
                    "{}: reported {m:.3e} against predicted {p:.3e}",
                    c.value_name(i)
                );
            }
            assert!(mr <= 1.25 * pb / pa, "{}: ratio {mr:.2}", c.value_name(i));
        }
        // A reduction wherever the prediction promises one of at least 20 % (the D-criterion
        // improves the determinant, not every parameter).
        if pb / pa < 0.8 {
            assert!(mr < 1.0, "{}: ratio {mr:.2}", c.value_name(i));
        }
    }
    let (ra, rb) = (rms(&norm_a), rms(&norm_b));
    println!(
        "RMS actual error over every hidden parameter and seed, in predicted standard errors of the default programme: default {ra:.2}, designed {rb:.2}"
    );
    // Where the design promises much smaller standard errors overall (geometric mean of the
    // predicted ratios below 0.6), the actual errors must follow (the default's RMS is near 1
    // if its standard errors are calibrated). The RMS of n normalised errors scatters by about
    // 1/√(2n) relative (±13 % for the 28 values of 4 seeds × 7 parameters), so a smaller
    // promised reduction is not testable on these seeds.
    let promised = (params
        .iter()
        .map(|&(c, i)| {
            let (pa, pb) = predicted(c, i);
            (pb / pa).ln()
        })
        .sum::<f64>()
        / n as f64)
        .exp();
    println!("geometric mean of the predicted ratios {promised:.2}");
    if promised < 0.6 {
        assert!(
            rb < ra,
            "RMS error designed {rb:.2} against default {ra:.2}"
        );
    }
    if check != Check::Unchecked {
        assert!(all_b >= all_a);
    }
}

#[test]
#[ignore]
fn designed_programme_reduces_the_standard_errors() {
    let seeds = [51, 52, 53, 54, 55, 56, 57, 58];
    // Designed for exactly the hidden causes: predicted and reported standard errors compare
    // one to one.
    let exact = DesignOptions {
        targets: TORQUE_CAUSES.to_vec(),
        ..DesignOptions::default()
    };
    compare(
        "torque and wheel causes hidden, targets = those causes",
        TRUTH,
        &TORQUE_CAUSES,
        &seeds,
        &exact,
        Check::Exact,
    );
    // The default targets (what `testbed experiment --design` uses): every covered cause.
    compare(
        "torque and wheel causes hidden, default targets",
        TRUTH,
        &TORQUE_CAUSES,
        &seeds,
        &DesignOptions::default(),
        Check::Targets,
    );
}

#[test]
#[ignore]
fn sensor_causes_designed_for_and_not() {
    let seeds = [61, 62, 63, 64];
    let exact = DesignOptions {
        targets: SENSOR_CAUSES.to_vec(),
        ..DesignOptions::default()
    };
    compare(
        "sensor causes hidden, targets = those causes",
        SENSOR_TRUTH,
        &SENSOR_CAUSES,
        &seeds,
        &exact,
        Check::Exact,
    );
    compare(
        "sensor causes hidden, default targets",
        SENSOR_TRUTH,
        &SENSOR_CAUSES,
        &seeds,
        &DesignOptions::default(),
        Check::Targets,
    );
    // A design for the torque and wheel causes alone takes no account of the sensor causes:
    // what it costs them is measured, not bounded (no assertion on the ratios but the naming).
    let torque_only = DesignOptions {
        targets: TORQUE_CAUSES.to_vec(),
        ..DesignOptions::default()
    };
    compare(
        "sensor causes hidden, targets = torque and wheel causes",
        SENSOR_TRUTH,
        &SENSOR_CAUSES,
        &seeds,
        &torque_only,
        Check::Unchecked,
    );
}

/// How much unmodelled centre-of-mass offset the designed programme (default targets) tolerates
/// before it breaks the limits, against the default programme: horizontal offsets not in the
/// model, along +X, −X, +Y and −Y, worst wheel speed and tilt-stop strikes. Measured and
/// printed; asserted: at the design's allowance both keep the limits (the design checks
/// exactly these four directions, so this holds by construction for the designed programme
/// and is a measurement for the default one).
#[test]
#[ignore]
fn tolerance_to_an_unmodelled_com_offset() {
    let settings = DesignOptions::default();
    let d =
        design::design(&nominal(), &ExperimentOptions::default(), &settings).expect("design runs");
    let limit = settings.limits.wheel_speed_fraction;
    println!(
        "| horizontal offset | programme | worst wheel speed, % of limit | tilt-stop strikes |"
    );
    println!("|---|---|---|---|");
    for r in [1e-7, 2e-7, 2.5e-7, 5e-7, 1e-6, 2e-6] {
        for (label, options) in [
            ("default", &d.baseline.options),
            ("designed", &d.chosen.options),
        ] {
            let mut worst_wheel = 0.0f64;
            let mut strikes = 0;
            for dir in [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]] {
                let t = truth(&format!(
                    "[effects.com_offset]\nr_m = [{}, {}, 0.0]\n",
                    r * dir[0],
                    r * dir[1]
                ));
                let (_, trace) = experiment::run(&t, options).expect("runs");
                let wheel = trace
                    .ticks
                    .iter()
                    .map(|t| t.truth.wheel_speed.amax())
                    .fold(0.0, f64::max);
                worst_wheel = worst_wheel.max(wheel / t.wheels.max_speed_rad_s());
                strikes += trace.tilt_stops.len();
            }
            println!(
                "| {:.2} µm | {label} | {:.0} | {strikes} |",
                r * 1e6,
                100.0 * worst_wheel
            );
            if r == settings.limits.com_allowance_m {
                assert!(worst_wheel <= limit && strikes == 0, "{label} at {r}");
            }
        }
    }
}
