//! Effects outside the cause library, simulated by the project (off-by-default effects of the
//! model crate): a magnetometer error at twice the heading, a torque that varies with the
//! heading, the windage of a wheel. (Soft iron is the library's `soft_iron`: `tests/soft_iron.rs`.) (A centre of mass drifting with time is the library's `com_drift`:
//! `tests/trends.rs`.) Hidden alone and together with a library cause, then
//! identified blind against the nominal model: the library cause must still be named with its
//! parameters, the out-of-library effect reported as **unexplained** in the right equation with
//! the regressors that carry it and a held-out gain, and no library cause named for it.
//!
//! Seeds are fixed; 600 s of the identification experiment each, 1200 s of a full turn for the
//! magnetometer error (see [`identify_full_turn`]).

mod common;
use common::*;
use testbed_ident::Cause;
use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::identify::Identification;

/// A magnetometer error at twice the heading, 0.4–0.7 µT on the horizontal axes (about the
/// size of a few percent of soft iron), outside the library: not a linear map of the field.
const HEADING_FIELD: &str = "[effects.field_heading_error]\n\
    cos_2psi_gauss = [0.006, -0.004, 0.0]\nsin_2psi_gauss = [0.004, 0.006, 0.0]\n";
/// 1–1.5 mNm about Z varying with the heading (a cable winding up, a dipole in the lab field).
const HEADING: &str =
    "[effects.heading_torque]\ncos_nm = [0.0, 0.0, 1.0e-3]\nsin_nm = [0.0, 0.0, 1.5e-3]\n";
const COM: &str = "[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n";
const WHEEL_SCALE: &str = "[effects.wheel_torque_scale]\nscale = [0.95, 1.04, 0.97]\n";
/// Windage of the Y wheel: `c n |n|` with c = 1e-8 Nm/(rad/s)², 0.9 mNm at the experiment's
/// 300 rad/s (as much as its nominal viscous friction there), outside the friction library
/// (Coulomb, Stribeck, viscous).
const WHEEL_DRAG: &str = "[effects.wheel_drag]\nquadratic_nm_per_rad2_s2 = [0.0, 1.0e-8, 0.0]\n";

/// The identification experiment turned a full turn: the heading swept over ±180° at the
/// constant slew rate (no slow zones), 0 → 180° → −180° → 0 in 1200 s, so every heading is
/// visited twice. Over it a second harmonic of the heading is orthogonal to the first, which
/// soft iron makes of the horizontal field, and to a constant (hard iron); over the default
/// ±60° the first harmonics and a constant take up about 80 % of a second harmonic, and the
/// library's soft iron would be named for most of it.
fn full_turn(seed: u64) -> ExperimentOptions {
    ExperimentOptions {
        duration_s: 1200.0,
        seed,
        heading_amplitude_deg: 180.0,
        slow_rate_deg_s: ExperimentOptions::default().heading_rate_deg_s,
        ..ExperimentOptions::default()
    }
}

/// Identify blind, against the nominal model, the data of the full-turn experiment on `truth`.
fn identify_full_turn(truth: &testbed_model::ModelConfig, seed: u64) -> Identification {
    let data = experiment::run(truth, &full_turn(seed))
        .expect("experiment runs")
        .0;
    testbed_ident::identify(&data, &nominal(), &options()).expect("identification runs")
}

fn print(label: &str, id: &Identification) {
    println!("{label}:");
    for line in &id.report.summary {
        println!("    {line}");
    }
    for t in &id.report.cause_tests {
        println!("    test {}: {}", t.name, t.verdict);
    }
}

/// The unexplained effect must be found in one of `equations`, with one of `regressors` among
/// its terms and a held-out gain above `min_gain`; the named causes must be exactly `library`,
/// each value within 10 % (+ `abs_tol`) of the truth. A torque effect must be carried into the
/// extended model (`[effects.fitted_torque]`), which identification does only when it improves
/// the held-out 10-s predictions by at least 1 % over the named causes alone; checked here
/// again from the reported gains (measured: 1.07× beside a com offset, which dominates the
/// nominal error, to 20× alone). A wheel effect likewise, as `[effects.fitted_wheel_torque]`
/// with every one of its terms on its wheel.
fn check(
    label: &str,
    truth: &testbed_model::ModelConfig,
    id: &Identification,
    library: &[Cause],
    equations: &[&str],
    regressors: &[&str],
    min_gain: f64,
) {
    print(label, id);
    let mut found = names(id);
    found.sort();
    let mut want: Vec<&str> = library.iter().map(|c| c.name()).collect();
    want.sort();
    assert_eq!(
        found, want,
        "{label}: named causes {:?}",
        id.report.cause_tests
    );
    for cause in library {
        let fitted = cause.values(&id.extended);
        let hidden = cause.values(truth);
        for (i, (f, t)) in fitted.iter().zip(&hidden).enumerate() {
            assert!(
                (f - t).abs() <= 0.1 * t.abs() + 1e-7,
                "{label}: {} = {f} vs {t}",
                cause.value_name(i)
            );
        }
    }
    let hit = id.report.unexplained.iter().find(|e| {
        equations.contains(&e.equation.as_str())
            && e.terms
                .iter()
                .any(|t| regressors.contains(&t.name.as_str()))
    });
    let Some(hit) = hit else {
        panic!(
            "{label}: no unexplained effect in {equations:?} with {regressors:?}: {:?}",
            id.report.unexplained
        );
    };
    assert!(
        hit.held_out_gain > min_gain,
        "{label}: held-out gain {} ≤ {min_gain}",
        hit.held_out_gain
    );
    if hit.equation.starts_with("torque_") {
        let ext = &id.report.extension;
        let carried = id
            .extended
            .effects
            .fitted_torque
            .as_ref()
            .unwrap_or_else(|| panic!("{label}: no fitted torque in the extended model"));
        let axis = &hit.equation["torque_".len()..];
        assert!(
            carried.terms.iter().any(|t| t.axis == axis),
            "{label}: {carried:?}"
        );
        let without = ext
            .gain_without_fitted_torque
            .expect("the gain without the fitted torque is measured");
        assert!(
            id.report.gain >= 1.01 * without,
            "{label}: held-out gain {} with the fitted torque, {without} without",
            id.report.gain
        );
    }
    if let Some(wheel) = hit.equation.strip_prefix("wheel_") {
        let ext = &id.report.extension;
        let carried = id
            .extended
            .effects
            .fitted_wheel_torque
            .as_ref()
            .unwrap_or_else(|| panic!("{label}: no fitted wheel torque in the extended model"));
        assert_eq!(ext.fitted_wheel_torque.as_ref(), Some(carried), "{label}");
        // Every term of the wheel effect is carried on its wheel, and nothing on another.
        for t in &hit.terms {
            assert!(
                carried.terms.iter().any(|c| c.wheel == wheel
                    && (c.function == t.name || (t.name == "t" && c.function == "t_s"))),
                "{label}: {} not carried: {carried:?}",
                t.name
            );
        }
        let without = ext
            .gain_without_fitted_torque
            .expect("the gain without the fitted wheel torque is measured");
        println!(
            "    {label}: held-out gain {:.3}× with the fitted wheel torque, {without:.3}× without; by group {:?}",
            id.report.gain, id.report.gain_by_group
        );
        assert!(
            ext.gain_includes_fitted_torque && id.report.gain >= 1.01 * without,
            "{label}: held-out gain {} with the fitted wheel torque, {without} without",
            id.report.gain
        );
    }
    assert!(id.report.remaining.residual_remains, "{label}");
    assert!(
        !id.report.remaining.message.contains("no structure"),
        "{label}: {}",
        id.report.remaining.message
    );
}

/// The extended model's fitted wheel torque on `wheel` in `function` (summed over its terms),
/// Nm per unit of the function; and the model's held-out gain over the named causes' alone.
fn carried_wheel_term(id: &Identification, wheel: &str, function: &str) -> (f64, f64) {
    let carried = id
        .extended
        .effects
        .fitted_wheel_torque
        .as_ref()
        .expect("checked: a fitted wheel torque is carried");
    let c = carried
        .terms
        .iter()
        .filter(|t| t.wheel == wheel && t.function == function)
        .map(|t| t.coefficient)
        .sum();
    let without = id
        .report
        .extension
        .gain_without_fitted_torque
        .expect("checked: the gain without it is measured");
    (c, id.report.gain / without)
}

/// `wheel_friction`, named by the selection for an out-of-library wheel effect, must be dropped by
/// its competing-explanation test: the wheel search without it (and without its own form, the
/// Coulomb and viscous levels) finds `function` in `equation`, predicts at least as well out of
/// fold, and beside that term the friction is not significant (likelihood ratio or
/// cluster-robust Wald statistic at or below the selection's threshold), or the search without
/// it predicts more than 1 % better.
fn friction_dropped_by_the_competitor(
    label: &str,
    id: &Identification,
    equation: &str,
    function: &str,
) {
    let test = id
        .report
        .cause_tests
        .iter()
        .find(|t| t.name == "wheel_friction")
        .unwrap_or_else(|| {
            panic!(
                "{label}: wheel_friction was not named and tested: {:?}",
                id.report.cause_tests
            )
        });
    let c = test
        .competitor
        .as_ref()
        .unwrap_or_else(|| panic!("{label}: no competitor test: {test:?}"));
    println!(
        "    {label}: competitor of wheel_friction: cv {:.1} without, {:.1} with; LR {:?}, Wald {:?}, threshold {:?}; consistency p = {:?}",
        c.cv_without,
        c.cv_with,
        c.lr,
        c.wald,
        c.threshold,
        test.consistency.as_ref().map(|c| c.p)
    );
    assert!(!test.kept, "{label}: {}", test.verdict);
    assert_eq!(test.failed, Some("competitor"), "{label}: {}", test.verdict);
    assert!(
        c.form.contains(equation) && c.form.contains(function),
        "{label}: the search without the friction found {}",
        c.form
    );
    let not_significant = match (c.lr, c.threshold) {
        (Some(lr), Some(th)) => lr.min(c.wald.unwrap_or(f64::INFINITY)) <= th,
        _ => false,
    };
    assert!(
        c.cv_without < 0.99 * c.cv_with || (c.cv_without <= c.cv_with && not_significant),
        "{label}: {c:?}"
    );
}

/// The field regressors a magnetometer error at twice the heading is found with.
const HEADING_FIELD_REGRESSORS: [&str; 2] = ["cos 2ψ", "sin 2ψ"];
const FIELD_EQUATIONS: [&str; 3] = [
    "innovation_field_x",
    "innovation_field_y",
    "innovation_field_z",
];

#[test]
fn a_heading_field_error_alone_and_with_a_wheel_torque_scale() {
    // The field effect is carried into the filter as a magnetometer correction and the analysis
    // redone (the second pass); the correction must reproduce the error, and neither the soft
    // nor the hard iron may be named for it.
    for (label, effects, library, seed) in [
        ("heading field error", HEADING_FIELD.to_string(), vec![], 53),
        (
            "heading field error + wheel torque scale",
            format!("{HEADING_FIELD}{WHEEL_SCALE}"),
            vec![Cause::WheelTorqueScale],
            54,
        ),
    ] {
        let t = truth(&effects);
        let id = identify_full_turn(&t, seed);
        check(
            label,
            &t,
            &id,
            &library,
            &FIELD_EQUATIONS,
            &HEADING_FIELD_REGRESSORS,
            1.05,
        );
        assert!(
            id.report.sensor_correction.is_some(),
            "{label}: no second pass"
        );
        heading_error_reproduced(label, &t, &id);
    }
}

#[test]
fn heading_torque_alone_and_with_a_com_offset() {
    for (label, effects, library, seed) in [
        ("heading torque", HEADING.to_string(), vec![], 55),
        (
            "heading torque + com offset",
            format!("{HEADING}{COM}"),
            vec![Cause::ComOffset],
            56,
        ),
    ] {
        let t = truth(&effects);
        let id = identify_blind(&t, seed, 600.0);
        check(
            label,
            &t,
            &id,
            &library,
            &["torque_z"],
            // Over the experiment's ±60° of heading the first and second harmonics can stand
            // in for each other; the form required is a heading-dependent torque about Z.
            &["cos ψ", "sin ψ", "cos 2ψ", "sin 2ψ"],
            1.5,
        );
    }
}

/// Beside an unexplained torque effect every torque cause selected is tested for significance
/// (its likelihood ratio and cluster-robust Wald statistic beside the effect are reported), also
/// when a constant torque acts on the effect's axis: its column there is the effect's offset.
/// (Before, the offset was added a second time, that fit was singular, and every cause but the
/// constant torque went untested.) Seed 70: a constant torque, a com offset and a heading torque;
/// the constant torque's Z part takes the heading torque's mean, so only the names are checked.
#[test]
fn every_torque_cause_is_tested_beside_an_effect_on_a_constant_torque_axis() {
    let t = truth(&format!(
        "{HEADING}{COM}[effects.constant_torque]\ntorque_nm = [1.5e-3, -1.0e-3, 2.0e-3]\n"
    ));
    let id = identify_blind(&t, 70, 600.0);
    print("constant torque + com offset + heading torque", &id);
    let mut found = names(&id);
    found.sort();
    assert_eq!(found, vec!["com_offset", "constant_torque"]);
    assert!(
        id.report
            .unexplained
            .iter()
            .any(|e| e.equation == "torque_z"),
        "{:?}",
        id.report.unexplained
    );
    for test in &id.report.cause_tests {
        assert!(
            test.joint_lr.is_some() && test.joint_wald.is_some() && test.joint_threshold.is_some(),
            "{}: not tested beside the unexplained effect: {test:?}",
            test.name
        );
        assert!(
            !test.kept
                || test.joint_lr.unwrap_or(0.0) > test.joint_threshold.unwrap_or(f64::INFINITY),
            "{test:?}"
        );
    }
}

/// The extended model, written to TOML and read back, reproduces a heading-dependent torque
/// that no library cause names (carried as `[effects.fitted_torque]`): the same experiment (same
/// seed, so the same sensor noise) run on the extended model follows the truth's wheel speeds
/// (in closed loop the wheels take up the external torque, so their speeds carry its integral)
/// far closer than the nominal model does. Bound: at least 5× closer in RMS over the run (a
/// fitted torque of the wrong sign or form would not come within 5×).
#[test]
fn the_extended_model_reproduces_an_unexplained_torque_in_simulation() {
    let t = truth(HEADING);
    let id = identify_blind(&t, 55, 600.0);
    let text = id.extended.to_toml_string();
    assert!(text.contains("[effects.fitted_torque]"), "{text}");
    let extended = testbed_model::ModelConfig::from_toml_str(&text, "extended model")
        .expect("the extended model reads back");
    let (nom, ext) = wheel_speed_rms_from_truth(&t, &extended, 55, 600.0);
    assert!(nom > 5.0 * ext, "nominal {nom} rad/s, extended {ext} rad/s");
}

/// The extended model carries the magnetometer correction into simulation: the same
/// experiment (same seed, so the same sensor noise) run on the extended model reads a field
/// closer to the truth's readings than the nominal model does. Bound: at least 3× closer in
/// RMS over the run (the error is 0.4–0.7 µT against 0.07 µT of noise per axis; a correction of
/// the wrong sign or form would not come within 3×). Measured values are printed.
#[test]
fn the_extended_model_reproduces_a_heading_field_error_in_simulation() {
    let t = truth(HEADING_FIELD);
    let id = identify_full_turn(&t, 53);
    let text = id.extended.to_toml_string();
    assert!(text.contains("[[effects.fitted_field.terms]]"), "{text}");
    let extended = testbed_model::ModelConfig::from_toml_str(&text, "extended model")
        .expect("the extended model reads back");
    let field = |model: &testbed_model::ModelConfig| {
        experiment::run(model, &full_turn(53))
            .expect("experiment runs")
            .0
            .magnetometer
    };
    let (truth_run, extended_run, nominal_run) = (field(&t), field(&extended), field(&nominal()));
    let rms = |run: &[testbed_ident::data::FieldRow]| {
        let sum: f64 = truth_run
            .iter()
            .zip(run)
            .map(|(a, b)| (a.field_t - b.field_t).norm_squared())
            .sum();
        (sum / (3 * truth_run.len().max(1)) as f64).sqrt()
    };
    let (ext, nom) = (rms(&extended_run), rms(&nominal_run));
    println!(
        "field RMS difference from the truth's readings: nominal {:.1} nT, extended {:.1} nT ({:.1}× closer)",
        nom * 1e9,
        ext * 1e9,
        nom / ext
    );
    assert!(nom > 3.0 * ext, "nominal {nom} T, extended {ext} T");
}

/// A magnetometer error at twice the heading with a centre-of-mass offset. The error distorts
/// the estimated heading and the torque channel is built on that estimate; the first pass's
/// field-innovation effect is carried into the filter as a magnetometer correction
/// (`[effects.fitted_field]`) and the analysis redone: the com offset is named with its values,
/// the error is reported as the first pass's unexplained field effect, no library cause (the
/// soft iron, the hard iron) stands in for it, and the correction reproduces it.
#[test]
fn a_heading_field_error_with_a_com_offset() {
    let t = truth(&format!("{HEADING_FIELD}{COM}"));
    let id = identify_full_turn(&t, 54);
    check(
        "heading field error + com offset",
        &t,
        &id,
        &[Cause::ComOffset],
        &FIELD_EQUATIONS,
        &HEADING_FIELD_REGRESSORS,
        1.05,
    );
    let correction = id
        .report
        .sensor_correction
        .as_ref()
        .expect("the second pass ran with a magnetometer correction");
    assert!(
        id.report
            .summary
            .iter()
            .any(|l| l.starts_with("Second pass")),
        "{:?}",
        id.report.summary
    );
    assert_eq!(
        id.extended.effects.fitted_field.as_ref(),
        Some(&correction.fitted_field),
        "the extended model carries the correction"
    );
    assert!(
        correction.residual_rms_after_t < 0.5 * correction.residual_rms_before_t,
        "field residual {} T before, {} T after",
        correction.residual_rms_before_t,
        correction.residual_rms_after_t
    );
    heading_error_reproduced("heading field error + com offset", &t, &id);
}

/// The magnetometer correction of the extended model against the hidden heading error: over
/// the attitudes the full turn covers (every heading, tilts of a few degrees) the fitted error
/// `ΔM(q)` plus any hard and soft iron named must match `c cos 2ψ + s sin 2ψ` up to a rotation
/// about the vertical (a constant heading offset, which no magnetometer-only correction can
/// see: the filter takes it as attitude), to within 20 % of the error's RMS. Measured values
/// are printed.
fn heading_error_reproduced(label: &str, truth: &testbed_model::ModelConfig, id: &Identification) {
    use nalgebra::{Matrix3, Vector3};
    use testbed_model::attitude::{from_heading_pitch_roll, heading};
    use testbed_model::config::GAUSS;
    use testbed_model::devices::fitted_field::FittedFieldModel;
    let e = truth
        .effects
        .field_heading_error
        .as_ref()
        .expect("the truth has a heading field error");
    let (c, s) = (
        Vector3::from(e.cos_2psi_gauss) * GAUSS,
        Vector3::from(e.sin_2psi_gauss) * GAUSS,
    );
    let field_l = truth.platform.field_l_t();
    let fitted = FittedFieldModel::from_config(id.extended.effects.fitted_field.as_ref(), &field_l);
    let effects = &id.extended.effects;
    let hard_iron = effects
        .magnetic_disturbance
        .as_ref()
        .map_or_else(Vector3::zeros, |d| Vector3::from(d.hard_iron_gauss) * GAUSS);
    let soft_iron = effects
        .soft_iron
        .as_ref()
        .map_or_else(Matrix3::zeros, |s| Matrix3::from_fn(|i, j| s.matrix[i][j]));
    let attitudes: Vec<_> = (-36..36)
        .flat_map(|k| {
            let psi = (k as f64 * 5.0).to_radians();
            [(0.03, -0.02), (-0.02, 0.03)]
                .map(|(pitch, roll)| from_heading_pitch_roll(psi, pitch, roll))
        })
        .collect();
    // Best rotation about the vertical: ΔM ≈ truth + ε (b × z_B) with z_B the level z in body
    // axes; ε fitted by least squares.
    let rows: Vec<(Vector3<f64>, Vector3<f64>, Vector3<f64>)> = attitudes
        .iter()
        .map(|q| {
            let b = q * field_l;
            let axis = q * Vector3::z();
            let two_psi = 2.0 * heading(q);
            (
                fitted.error_t(q) + hard_iron + soft_iron * b,
                c * two_psi.cos() + s * two_psi.sin(),
                b.cross(&axis),
            )
        })
        .collect();
    let eps = rows.iter().map(|(f, t, r)| (f - t).dot(r)).sum::<f64>()
        / rows.iter().map(|(_, _, r)| r.norm_squared()).sum::<f64>();
    let n = rows.len() as f64;
    let err = (rows
        .iter()
        .map(|(f, t, r)| (f - t - eps * r).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    let size = (rows.iter().map(|(_, t, _)| t.norm_squared()).sum::<f64>() / n).sqrt();
    println!(
        "{label}: fitted field correction vs the hidden heading error: RMS difference {:.1} nT of {:.1} nT ({:.0} %), heading offset absorbed {:.2e} rad",
        err * 1e9,
        size * 1e9,
        100.0 * err / size,
        eps
    );
    assert!(err < 0.2 * size, "{label}: {err} T vs {size} T");
}

/// Clean data (the nominal model simulated, seeds 100–119, as the library's own clean-data
/// test): no unexplained effect on any seed. The search's family-wise level is 1e-4 per
/// equation (11 equations: 3 torque axes, 5 innovation components, 3 wheels), so the expected
/// number of false finds in 20 records is about 0.02
/// if its null (no structure; clusters independent) holds; 20/20 clean is the bound checked.
#[test]
fn clean_data_give_no_unexplained_effect_on_20_of_20_seeds() {
    let clean = nominal();
    let mut found = Vec::new();
    let mut named = Vec::new();
    for seed in 100..120 {
        let id = identify_blind(&clean, seed, 600.0);
        println!(
            "clean seed {seed}: {} ; unexplained: {:?}",
            id.report.verdict,
            id.report
                .unexplained
                .iter()
                .map(|e| (&e.proposed, e.held_out_gain))
                .collect::<Vec<_>>()
        );
        if !id.report.unexplained.is_empty() {
            found.push(seed);
        }
        if !id.report.causes.is_empty() {
            named.push(seed);
        }
    }
    println!("unexplained on {found:?}; causes on {named:?}");
    assert!(
        found.is_empty(),
        "unexplained effects on clean data: {found:?}"
    );
    assert!(named.is_empty(), "causes named on clean data: {named:?}");
}

/// A quadratic drag on the Y wheel (not a library cause) is reported as an unexplained effect
/// in the wheel channel (`wheel_y`) with a speed-squared regressor, its coefficient the drag
/// (a torque opposing the spin, −c per unit of `n·|n|`) within 10 %, and a held-out gain of the
/// wheel equation above 1.1 (measured 1.15× on seed 57, cross-validated 1.71×: the held-out
/// blocks happen to hold slower speeds of the Y wheel). The term is carried into the extended
/// model (`[effects.fitted_wheel_torque]`, wheel y, `n·|n|`, within 10 % of −1e-8 Nm/(rad/s)²),
/// which raises the model's held-out prediction gain at least threefold over the named causes
/// alone (measured 10.6× against 1.00× on seed 57, 58.5× against 6.15× beside the scale on seed
/// 58). No library cause is named (a wheel friction that absorbs part of it
/// through its viscous level must be falsified), nothing is found on the other wheels. Alone
/// (seed 57) and beside a wheel torque scale (seed 58), which must still be named with its
/// values within 10 % (`check`).
#[test]
fn wheel_drag_alone_and_with_a_wheel_torque_scale() {
    for (label, effects, library, seed) in [
        ("wheel drag", WHEEL_DRAG.to_string(), vec![], 57),
        (
            "wheel drag + wheel torque scale",
            format!("{WHEEL_DRAG}{WHEEL_SCALE}"),
            vec![Cause::WheelTorqueScale],
            58,
        ),
    ] {
        let t = truth(&effects);
        let id = identify_blind(&t, seed, 600.0);
        for e in &id.report.unexplained {
            println!(
                "    {} (held-out gain {:.2}, cv {:.2})",
                e.proposed, e.held_out_gain, e.cv_gain
            );
        }
        check(
            label,
            &t,
            &id,
            &library,
            &["wheel_y"],
            &["n·|n|", "n²"],
            1.1,
        );
        let hit = id
            .report
            .unexplained
            .iter()
            .find(|e| e.equation == "wheel_y")
            .expect("checked");
        let quadratic: f64 = hit
            .terms
            .iter()
            .filter(|t| t.name == "n·|n|")
            .map(|t| t.value)
            .sum();
        assert!(
            (quadratic + 1.0e-8).abs() <= 0.1e-8,
            "{label}: n·|n| coefficient {quadratic} Nm vs −1e-8: {}",
            hit.proposed
        );
        let others: Vec<&str> = id
            .report
            .unexplained
            .iter()
            .filter(|e| e.equation == "wheel_x" || e.equation == "wheel_z")
            .map(|e| e.proposed.as_str())
            .collect();
        assert!(others.is_empty(), "{label}: {others:?}");
        // The selection names `wheel_friction` for the drag first (its viscous level takes part
        // of it); the search without it finds the drag's `n·|n|` on wheel y.
        friction_dropped_by_the_competitor(label, &id, "wheel_y", "n·|n|");
        // The extended model carries the drag as the plant's `n·|n|` torque on the Y wheel, and
        // it multiplies the held-out prediction gain (measured 10.6× against 1.00× alone, 58.5×
        // against 6.15× beside the scale).
        let (c, ratio) = carried_wheel_term(&id, "y", "n·|n|");
        assert!(
            (c + 1.0e-8).abs() <= 0.1e-8,
            "{label}: carried n·|n| coefficient {c} Nm vs −1e-8"
        );
        assert!(ratio >= 3.0, "{label}: gain ratio {ratio}");
        assert!(
            id.extended
                .effects
                .fitted_wheel_torque
                .as_ref()
                .is_some_and(|f| f.terms.iter().all(|t| t.wheel == "y")),
            "{label}: {:?}",
            id.extended.effects.fitted_wheel_torque
        );
        // Every named wheel cause went through the wheel tests.
        for test in id
            .report
            .cause_tests
            .iter()
            .filter(|t| t.name.starts_with("wheel_"))
        {
            println!("    {}: {:?}", test.name, test.whiteness);
            assert!(
                test.consistency.is_some() || test.whiteness.is_some(),
                "{label}: {test:?}"
            );
        }
        // Beside the drag term the torque scale is refitted with it: within 0.003 of the truth
        // (the tolerance of the scale alone in `tests/causes.rs`; from the selection's fit,
        // before the refit, the Y scale was 1.0329 ± 0.0010 against 1.04).
        if library.contains(&Cause::WheelTorqueScale) {
            let fitted = Cause::WheelTorqueScale.values(&id.extended);
            let hidden = Cause::WheelTorqueScale.values(&t);
            for (f, h) in fitted.iter().zip(&hidden) {
                assert!(
                    (f - h).abs() <= 0.003,
                    "{label}: scale {fitted:?} vs {hidden:?}"
                );
            }
        }
    }
}

/// A torque on the X wheel that follows the platform's tilt (`[effects.wheel_tilt_torque]`,
/// 1e-2 Nm per unit of `G_x`: 1.2 mNm at the experiment's 7° steps), not a library cause, is
/// reported in `wheel_x` with `sin tilt_x`, its coefficient within 10 % of 1e-2 Nm, a held-out
/// gain above 1.1 (measured 2.37× in the wheel equation); nothing is named and nothing is found
/// on the other wheels. The term is carried into the extended model as the X wheel's
/// `sin tilt_x` fitted wheel torque, and the model's held-out prediction gain rises at least
/// threefold (measured 38.8× against 1.00×). Seed 59.
#[test]
fn a_wheel_torque_that_follows_the_tilt_is_unexplained_in_the_wheel_channel() {
    let t = truth(
        "[effects.wheel_tilt_torque]\nsin_tilt_x_nm = [1.0e-2, 0.0, 0.0]\nsin_tilt_y_nm = [0.0, 0.0, 0.0]\n",
    );
    let id = identify_blind(&t, 59, 600.0);
    for e in &id.report.unexplained {
        println!(
            "    {} (held-out gain {:.2}, cv {:.2})",
            e.proposed, e.held_out_gain, e.cv_gain
        );
    }
    check(
        "wheel tilt torque",
        &t,
        &id,
        &[],
        &["wheel_x"],
        &["sin tilt_x"],
        1.1,
    );
    let hit = id
        .report
        .unexplained
        .iter()
        .find(|e| e.equation == "wheel_x")
        .expect("checked");
    let c: f64 = hit
        .terms
        .iter()
        .filter(|t| t.name == "sin tilt_x")
        .map(|t| t.value)
        .sum();
    assert!((c - 1.0e-2).abs() <= 1.0e-3, "{}", hit.proposed);
    // The selection names `wheel_friction` for the tilt torque first; the search without it
    // finds `sin tilt_x` on wheel x.
    friction_dropped_by_the_competitor("wheel tilt torque", &id, "wheel_x", "sin tilt_x");
    // Carried into the extended model as the plant's `sin tilt_x` torque on the X wheel; the
    // held-out prediction gain rises from 1.00× (nothing named) to 38.8× (seed 59).
    let (carried, ratio) = carried_wheel_term(&id, "x", "sin tilt_x");
    assert!(
        (carried - 1.0e-2).abs() <= 1.0e-3,
        "carried sin tilt_x coefficient {carried} Nm vs 1e-2"
    );
    assert!(ratio >= 3.0, "gain ratio {ratio}");
    let others: Vec<&str> = id
        .report
        .unexplained
        .iter()
        .filter(|e| e.equation == "wheel_y" || e.equation == "wheel_z")
        .map(|e| e.proposed.as_str())
        .collect();
    assert!(others.is_empty(), "{others:?}");
}

/// How often the checks above hold on other seeds (ignored: 28 identifications; prints the
/// share per scenario; run with `--ignored --nocapture`, `IDENT_SCENARIO=<text>` for the
/// scenarios whose label contains it).
#[test]
#[ignore]
fn out_of_library_checks_over_more_seeds() {
    let heading = ["cos ψ", "sin ψ", "cos 2ψ", "sin 2ψ"];
    let field_eq = FIELD_EQUATIONS;
    let field = HEADING_FIELD_REGRESSORS;
    // (label, hidden effects, library causes, equations, regressors, least held-out gain); the
    // magnetometer's scenarios on the full turn, the others on the default experiment.
    type Scenario<'a> = (&'a str, String, Vec<Cause>, Vec<&'a str>, Vec<&'a str>, f64);
    let scenarios: Vec<Scenario> = vec![
        (
            "heading field error",
            HEADING_FIELD.into(),
            vec![],
            field_eq.to_vec(),
            field.to_vec(),
            1.05,
        ),
        (
            "heading field error + wheel scale",
            format!("{HEADING_FIELD}{WHEEL_SCALE}"),
            vec![Cause::WheelTorqueScale],
            field_eq.to_vec(),
            field.to_vec(),
            1.05,
        ),
        (
            "heading field error + com offset",
            format!("{HEADING_FIELD}{COM}"),
            vec![Cause::ComOffset],
            field_eq.to_vec(),
            field.to_vec(),
            1.05,
        ),
        (
            "heading torque",
            HEADING.into(),
            vec![],
            vec!["torque_z"],
            heading.to_vec(),
            1.5,
        ),
        (
            "heading torque + com",
            format!("{HEADING}{COM}"),
            vec![Cause::ComOffset],
            vec!["torque_z"],
            heading.to_vec(),
            1.5,
        ),
        (
            "wheel drag",
            WHEEL_DRAG.into(),
            vec![],
            vec!["wheel_y"],
            vec!["n·|n|", "n²"],
            1.1,
        ),
        (
            "wheel drag + wheel scale",
            format!("{WHEEL_DRAG}{WHEEL_SCALE}"),
            vec![Cause::WheelTorqueScale],
            vec!["wheel_y"],
            vec!["n·|n|", "n²"],
            1.1,
        ),
    ];
    // `IDENT_SCENARIO=<text>`: only the scenarios whose label contains it.
    let only = std::env::var("IDENT_SCENARIO").ok();
    for (label, effects, library, equations, regressors, gain) in scenarios
        .iter()
        .filter(|s| only.as_deref().is_none_or(|o| s.0.contains(o)))
    {
        let t = truth(effects);
        let mut ok = 0;
        for seed in 61..65 {
            let id = if label.starts_with("heading field") {
                identify_full_turn(&t, seed)
            } else {
                identify_blind(&t, seed, 600.0)
            };
            let pass = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                check(label, &t, &id, library, equations, regressors, *gain)
            }))
            .is_ok();
            ok += pass as usize;
        }
        println!("ROBUSTNESS {label}: {ok}/4 seeds pass");
    }
}

#[test]
fn identifying_again_with_the_extended_model_finds_the_wheel_drag_explained() {
    // The wheel channel's residual takes out the fitted wheel torque a configuration already
    // carries (as the torque channel takes out a fitted torque): a second identification from
    // the extended model finds nothing more on that wheel and does not add the term twice.
    let t = truth(WHEEL_DRAG);
    let data = experiment_data(&t, 57, 600.0);
    let first = testbed_ident::identify(&data, &nominal(), &options()).expect("first pass");
    let (c1, _) = carried_wheel_term(&first, "y", "n·|n|");
    assert!((c1 + 1.0e-8).abs() <= 0.1e-8, "first pass: {c1}");
    let second = testbed_ident::identify(&data, &first.extended, &options()).expect("again");
    let again: Vec<&str> = second
        .report
        .unexplained
        .iter()
        .filter(|e| e.equation.starts_with("wheel_"))
        .map(|e| e.proposed.as_str())
        .collect();
    assert!(again.is_empty(), "found again: {again:?}");
    let total: f64 = second
        .extended
        .effects
        .fitted_wheel_torque
        .as_ref()
        .map_or(0.0, |f| {
            f.terms
                .iter()
                .filter(|t| t.wheel == "y" && t.function == "n·|n|")
                .map(|t| t.coefficient)
                .sum()
        });
    assert!(
        (total + 1.0e-8).abs() <= 0.1e-8,
        "the extended model's n·|n| on wheel y after two passes: {total} Nm vs −1e-8"
    );
    let named: Vec<&str> = second.report.causes.iter().map(|c| c.name).collect();
    assert!(
        !named.iter().any(|n| n.starts_with("wheel_")),
        "no wheel cause for an explained drag: {named:?}"
    );
}
