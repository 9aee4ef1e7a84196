//! The misattribution guard (`identify::guard`): a library cause that explains only part of what
//! it absorbed is flagged as partly explaining, and the remainder is reported as an unexplained
//! effect with its form, instead of "no residual remains".
//!
//! Each case is first identified with the guard off (`Options::misattribution_guard`), which
//! reproduces the misattribution (the library cause named, no unexplained effect, no residual),
//! then with it on. Seeds are fixed; 600 or 1200 s of the identification experiment.

mod common;
use common::*;
use testbed_ident::identify::{Identification, PartlyExplained, Report, Trigger};
use testbed_ident::{Cause, Options};
use testbed_model::config::GAUSS;

/// A constant torque about X and Y (a library cause, truly acting).
const CONSTANT_XY: &str = "[effects.constant_torque]\ntorque_nm = [1.5e-3, -1.0e-3, 0.0]\n";

/// The inclinometer turned 5 mrad about the vertical: each angle reads a fraction of the other
/// (`inclinometer_cross_axis`: outside the library where the library is given without it).
const TURNED: &str = "[effects.inclinometer_cross_axis]\ncoupling = [0.005, -0.005]\n";

/// The library without `inclinometer_cross_axis`, and without `without`.
fn library_without_cross_axis(without: &[Cause]) -> Vec<Cause> {
    Cause::ALL
        .into_iter()
        .filter(|c| *c != Cause::InclinometerCrossAxis && !without.contains(c))
        .collect()
}

fn print(label: &str, id: &Identification) {
    println!("{label}: verdict {}", id.report.verdict);
    for line in &id.report.summary {
        println!("    {line}");
    }
}

fn identify_with(data: &testbed_ident::Dataset, guard: bool) -> Identification {
    identify_among(data, guard, Cause::ALL.to_vec())
}

/// [`identify_with`] from the `candidates` only.
fn identify_among(
    data: &testbed_ident::Dataset,
    guard: bool,
    candidates: Vec<Cause>,
) -> Identification {
    let options = Options {
        misattribution_guard: guard,
        candidates,
        ..options()
    };
    testbed_ident::identify(data, &nominal(), &options).expect("identification runs")
}

/// Identify with the guard off and check the misattribution: `named` alone, no unexplained
/// effect, "no residual remains".
fn misattributed(label: &str, data: &testbed_ident::Dataset, named: &[&str]) {
    let before = identify_with(data, false);
    print(&format!("{label}, guard off"), &before);
    assert_eq!(names(&before), named, "{label}");
    assert!(before.report.unexplained.is_empty(), "{label}");
    assert!(!before.report.remaining.residual_remains, "{label}");
    assert!(before.report.partly_explained.is_empty(), "{label}");
}

/// The flag of `cause` on `equation`.
fn flag_on<'a>(label: &str, r: &'a Report, cause: &str, equation: &str) -> &'a PartlyExplained {
    r.partly_explained
        .iter()
        .find(|p| p.cause == cause && p.equation == equation)
        .unwrap_or_else(|| {
            panic!(
                "{label}: {cause} not flagged on {equation}: {:?}",
                r.partly_explained
            )
        })
}

/// The coefficient and standard error of the unexplained term `function` in `equation`.
fn remainder_term(label: &str, r: &Report, equation: &str, function: &str) -> (f64, f64) {
    let remainder = r
        .unexplained
        .iter()
        .find(|e| e.equation == equation)
        .unwrap_or_else(|| panic!("{label}: no remainder in {equation}: {:?}", r.unexplained));
    let term = remainder
        .terms
        .iter()
        .find(|t| t.name == function)
        .unwrap_or_else(|| panic!("{label}: {}", remainder.proposed));
    (term.value, term.stderr)
}

/// The remainder's term `function` in `equation`, within 3 standard errors of `truth`.
fn check_remainder(label: &str, r: &Report, equation: &str, function: &str, truth: f64) {
    let (value, stderr) = remainder_term(label, r, equation, function);
    assert!(
        (value - truth).abs() <= 3.0 * stderr,
        "{label}: {equation} {function} coefficient {value} ± {stderr} against {truth}"
    );
}

/// What the guard must turn: `named` (the library causes, with the guard off: named alone, no
/// unexplained effect, "no residual remains") flagged on `torque_z` with the remainder `cos ψ`
/// (the unrestricted search finds `cos ψ` and predicts better out of fold; beside the causes
/// the term beats the selection's threshold by the likelihood ratio and the cluster-robust Wald
/// statistic), its coefficient within 3 standard errors of `cos_psi_nm`, and a residual said to
/// remain. Returns the identification with the guard on.
fn check_turned(
    label: &str,
    data: &testbed_ident::Dataset,
    named: &[&str],
    cos_psi_nm: f64,
) -> Identification {
    misattributed(label, data, named);

    let after = identify_with(data, true);
    print(&format!("{label}, guard on"), &after);
    let r = &after.report;
    assert_eq!(names(&after), named, "{label}");
    let [flag] = r.partly_explained.as_slice() else {
        panic!("{label}: {:?}", r.partly_explained);
    };
    println!("    {flag:?}");
    assert_eq!(
        (flag.cause, flag.equation.as_str()),
        ("constant_torque", "torque_z")
    );
    assert!(
        flag.lr > flag.threshold && flag.wald > flag.threshold,
        "{flag:?}"
    );
    assert!(flag.cv_search < flag.cv_cause, "{flag:?}");
    assert!(flag.cv_with_remainder < flag.cv_cause, "{flag:?}");
    assert!(flag.search_form.contains("cos ψ"), "{flag:?}");
    check_remainder(label, r, "torque_z", "cos ψ", cos_psi_nm);
    assert!(r.remaining.residual_remains, "{label}");
    assert!(
        r.summary
            .iter()
            .any(|l| l.starts_with("Partly explained: constant_torque partly explains torque_z")),
        "{label}: {:?}",
        r.summary
    );
    // In report.json.
    let json = serde_json::to_value(r).expect("the report serialises");
    assert_eq!(
        json["partly_explained"][0]["equation"], "torque_z",
        "{label}"
    );
    after
}

/// With the heading: a torque about Z of `amplitude · cos ψ` (out of the library) beside a
/// constant torque about X and Y. Over the experiment's ±60° of heading it is mostly a
/// constant, and the constant torque's Z value takes it: with the guard off `constant_torque`
/// is named alone and "no residual remains" (the search beside the cause needs 1 % of the
/// cross-validated residual sum: the remainder is 0.5 % of it); with it on, flagged with the
/// remainder `cos ψ`. Measured: seed 81 at 0.15 mNm, likelihood ratio 34.7 and Wald 38.5
/// against 23.9; seed 82 at 0.12 mNm, 31.6 and 29.5.
#[test]
fn a_constant_torque_standing_in_for_a_heading_torque_partly_explains_it() {
    for (amplitude, seed) in [(1.5e-4, 81), (1.2e-4, 82)] {
        let label = format!("heading torque {amplitude:e} Nm + constant torque, seed {seed}");
        let t = truth(&format!(
            "{CONSTANT_XY}[effects.heading_torque]\ncos_nm = [0.0, 0.0, {amplitude:e}]\nsin_nm = [0.0, 0.0, 0.0]\n"
        ));
        let data = experiment_data(&t, seed, 600.0);
        let after = check_turned(&label, &data, &["constant_torque"], amplitude);
        // The constant torque's X and Y values are still the truth's, within 10 %.
        let fitted = testbed_ident::Cause::ConstantTorque.values(&after.extended);
        for (f, h) in fitted.iter().zip([1.5e-3, -1.0e-3]) {
            assert!((f - h).abs() <= 0.1 * h.abs(), "{label}: {fitted:?}");
        }
    }
}

/// In the lab's field: a magnetic dipole of 5 A m² along body Y (`[effects.dipole_torque]`,
/// `M = m × B_B`) beside the constant torque about X and Y, 1200 s. Its torque about X is
/// `m_y B_z`, the vertical field's part: body-fixed like a centre-of-mass offset's in gravity, it
/// is one (`com_offset` is named beside the constant torque, and rightly no experiment on the
/// bearing can tell the two apart). Its torque about Z, `−m_y B_x` = `−m_y B_north cos ψ − m_y
/// B_west sin ψ`, follows the heading and is not a library cause's: the constant torque's Z value
/// takes it. With the guard off `constant_torque + com_offset` are named and "no residual
/// remains"; with it on, the constant torque is flagged on `torque_z` with the remainder `cos ψ`,
/// its coefficient within 3 standard errors of `−m_y B_north` (−1.275e-4 Nm; the `sin ψ` part,
/// 2e-5 Nm, is below what the record resolves). Measured: likelihood ratio 35.4 and Wald 24.8
/// (seed 82), 39.0 and 39.6 (seed 83) against 23.9. On 600 s the remainder is not significant
/// beside the two causes (seed 82: 9.7 and 6.8), and the misattribution stands.
#[test]
fn a_constant_torque_standing_in_for_a_dipole_in_the_lab_field_partly_explains_it() {
    let moment_am2 = 5.0;
    let t = truth(&format!(
        "{CONSTANT_XY}[effects.dipole_torque]\nmoment_am2 = [0.0, {moment_am2:e}, 0.0]\n"
    ));
    let b_north_t = t.platform.field_l_gauss[0] * GAUSS;
    for seed in [82, 83] {
        let label = format!("dipole {moment_am2} A m² along Y + constant torque, seed {seed}");
        let data = experiment_data(&t, seed, 1200.0);
        check_turned(
            &label,
            &data,
            &["constant_torque", "com_offset"],
            -moment_am2 * b_north_t,
        );
    }
}

/// Blocks that disagree only through the remainder: the same dipole and constant torque over
/// an hour. Each block's headings differ, so the `cos ψ` torque about Z moves the constant
/// torque's Z value from block to block and its blocks disagreed (χ² = 34.0 on 9 degrees of
/// freedom): it was dropped and the true constant torque reported as an unexplained `1` about X
/// and Y. Its blocks are now compared again beside the terms the search without it finds (`cos
/// ψ` about Z; p = 0.007 against 1e-3), agree there, and the cause is kept, flagged as partly
/// explaining `torque_z` with the remainder `cos ψ`. About Y its value is the truth's within
/// 5 %; about X, with the centre-of-mass offset's `r_y` that shares it, the truth plus the
/// dipole's `m_y B_z`.
#[test]
fn blocks_that_disagree_only_through_the_remainder_keep_the_cause() {
    let moment_am2 = 5.0;
    let t = truth(&format!(
        "{CONSTANT_XY}[effects.dipole_torque]\nmoment_am2 = [0.0, {moment_am2:e}, 0.0]\n"
    ));
    let data = experiment_data(&t, 82, 3600.0);
    let id = identify_with(&data, true);
    print("dipole 5 A m² along Y + constant torque, 1 h, seed 82", &id);
    let r = &id.report;
    assert!(names(&id).contains(&"constant_torque"), "{}", r.verdict);
    let test = r
        .cause_tests
        .iter()
        .find(|c| c.name == "constant_torque")
        .expect("the constant torque is tested");
    let consistency = test.consistency.as_ref().expect("tested across blocks");
    println!(
        "    consistency beside {:?}, p = {:.3}",
        consistency.beside, consistency.p
    );
    assert!(
        consistency.beside.iter().any(|b| b.contains("cos ψ")),
        "{consistency:?}"
    );
    assert!(
        r.partly_explained
            .iter()
            .any(|p| p.cause == "constant_torque" && p.equation == "torque_z"),
        "{:?}",
        r.partly_explained
    );
    assert!(
        !r.unexplained
            .iter()
            .any(|e| e.equation != "torque_z" && e.terms.iter().any(|t| t.name == "1")),
        "a constant left unexplained: {:?}",
        r.unexplained
            .iter()
            .map(|e| &e.proposed)
            .collect::<Vec<_>>()
    );
    let b_vertical_t = t.platform.field_l_gauss[2] * GAUSS;
    let fitted = testbed_ident::Cause::ConstantTorque.values(&id.extended);
    let com = testbed_ident::Cause::ComOffset.values(&id.extended);
    let weight_n = t.platform.mass_kg * t.platform.gravity_mps2;
    // About X the constant torque and the offset's `r_y` (its torque `−m g r_y` at level, the
    // down vector along −Z) share the truth and `m_y B_z`.
    let x = fitted[0] - weight_n * com.get(1).copied().unwrap_or(0.0);
    for (f, h) in [
        (x, 1.5e-3 + moment_am2 * b_vertical_t),
        (fitted[1], -1.0e-3),
    ] {
        assert!(
            (f - h).abs() <= 0.05 * h.abs(),
            "{f} against {h}: {fitted:?} {com:?}"
        );
    }
}

/// With the tilt, across equations: a torque about X of 1 mNm per unit of `G_y` (a cable that
/// resists tilting about X only, say) beside the constant torque, 600 s, seeds 83 and 84. About X it
/// has the form of a vertical centre-of-mass offset's torque (`−m g r_z G_y`), and `com_offset`
/// is named for it with no residual. The same offset would also act about Y (`m g r_z G_x`),
/// where nothing does; each equation's search fits the cause's columns there alone and finds
/// nothing beside them, and the joint `r_z` is a compromise. With the guard on, the offset's
/// `r_z` fitted to each equation alone disagree (seed 83: −2.87e-7 ± 1.4e-8 m about X, 2e-8 ±
/// 1.7e-8 m about Y, χ² 212.9 on 3 degrees of freedom against 31.3), and the cause is flagged
/// in both equations with the remainders `sin tilt_y` about X and `sin tilt_x` about Y (Wald
/// 114.0 and 85.1 against 23.9; seed 84: 76.7 and 77.4). Checked: `r_z` from each equation within 3 standard errors
/// of what that equation holds (`−A / (m g)` and 0), and the joint value with the remainders
/// reproduces the truth's torque in both equations within 3 standard errors. Over seeds 81–86
/// the misattribution stands without the guard on 4 records of 600 s (on the other two, and on
/// all six of 1200 s, the search finds the torque itself); the guard turns 3 of them (seed 86
/// in one equation). On seed 81 the values disagree as well (χ² 80.9), but an `inertia_error`
/// also named takes part of it and the remainders fall below the threshold: not flagged.
#[test]
fn a_centre_of_mass_offset_standing_in_for_a_torque_about_one_tilt_axis_partly_explains_it() {
    let amplitude = 1.0e-3;
    let t = truth(&format!(
        "{CONSTANT_XY}[effects.fitted_torque]\nterms = [ {{ axis = \"x\", function = \"sin tilt_y\", coefficient = {amplitude:e} }} ]\n"
    ));
    for seed in [83, 84] {
        let label = format!("torque about X per unit of G_y + constant torque, seed {seed}");
        let data = experiment_data(&t, seed, 600.0);
        misattributed(&label, &data, &["constant_torque", "com_offset"]);

        let after = identify_with(&data, true);
        print(&format!("{label}, guard on"), &after);
        let r = &after.report;
        assert_eq!(names(&after), ["constant_torque", "com_offset"], "{label}");
        assert!(r.remaining.residual_remains, "{label}");
        let weight_n = t.platform.mass_kg * t.platform.gravity_mps2;
        let r_z = testbed_ident::Cause::ComOffset.values(&after.extended)[2];
        // Per equation: the offset's r_z there alone, what that equation holds, and the remainder's
        // function with the torque it carries beside the joint value (`m g r_z` per unit of `G_x`
        // about Y, `−m g r_z` per unit of `G_y` about X).
        for (equation, r_z_alone, function, held_nm) in [
            (
                "torque_x",
                -amplitude / weight_n,
                "sin tilt_y",
                amplitude + weight_n * r_z,
            ),
            ("torque_y", 0.0, "sin tilt_x", -weight_n * r_z),
        ] {
            let flag = flag_on(&label, r, "com_offset", equation);
            println!("    {flag:?}");
            assert!(flag.wald > flag.threshold, "{flag:?}");
            let Trigger::Across(across) = &flag.trigger else {
                panic!("{label}, {equation}: not flagged across equations: {flag:?}");
            };
            assert!(across.chi2 > across.threshold, "{across:?}");
            let j = across
                .parameters
                .iter()
                .position(|p| p == "com_offset.r_m[2]")
                .expect("r_z is shared");
            let (_, value, se) = across
                .equations
                .iter()
                .find(|(e, _, _)| e == equation)
                .expect("the equation's values");
            assert!(
                (value[j] - r_z_alone).abs() <= 3.0 * se[j],
                "{equation}: r_z alone {} ± {} against {r_z_alone}",
                value[j],
                se[j]
            );
            check_remainder(&label, r, equation, function, held_nm);
        }
    }
}

/// An actuator effect: a torque of 1.5e-4 Nm × `cos ψ` on the X wheel (its motor in the lab's
/// field, say) beside a friction departure (the `wheel_friction` of `tests/causes.rs`), 1200 s.
/// The X wheel's speed follows the heading (the wheels hold the platform's momentum bias, and
/// the experiment runs the X wheel through zero), so the direction of its spin follows `cos ψ`
/// and the friction law's Coulomb asymmetry on X takes the torque's mean: with the guard off
/// `wheel_friction` is named alone and "no residual remains". The unrestricted search does not
/// flag it (it has no Stribeck form and loses to the friction law), and the search beside the
/// cause finds `cos ψ` below its 1 % bar. With the guard on, `cos ψ` beside the friction law
/// passes the selection's test (seed 81: likelihood ratio 48.7, Wald 49.3; seed 82: 34.8 and
/// 44.3; threshold 23.9): flagged, the remainder's coefficient within 3 standard errors of the
/// truth, carried into the extended model as a fitted wheel torque, and the friction law refitted
/// beside it back at the truth's Coulomb levels on X.
#[test]
fn a_friction_law_standing_in_for_a_heading_dependent_wheel_torque_partly_explains_it() {
    let amplitude = 1.5e-4;
    let t = truth(&format!(
        "[effects.wheel_friction]\n\
         coulomb_pos_nm = [1.2e-3, 1.5e-3, 1.8e-3]\n\
         coulomb_neg_nm = [1.8e-3, 1.5e-3, 1.3e-3]\n\
         viscous_nm_per_rad_s = [3e-6, 4e-6, 2.5e-6]\n\
         stribeck_nm = [3e-3, 1.5e-3, 3.5e-3]\n\
         stribeck_speed_rad_s = [0.8, 1.0, 1.5]\n\
         [effects.fitted_wheel_torque]\n\
         terms = [ {{ wheel = \"x\", function = \"cos ψ\", coefficient = {amplitude:e} }} ]\n"
    ));
    for seed in [81, 82] {
        let label = format!("cos ψ torque on the X wheel + wheel friction, seed {seed}");
        let data = experiment_data(&t, seed, 1200.0);
        misattributed(&label, &data, &["wheel_friction"]);

        let after = identify_with(&data, true);
        print(&format!("{label}, guard on"), &after);
        let r = &after.report;
        assert_eq!(names(&after), ["wheel_friction"], "{label}");
        let [flag] = r.partly_explained.as_slice() else {
            panic!("{label}: {:?}", r.partly_explained);
        };
        println!("    {flag:?}");
        assert_eq!(
            (flag.cause, flag.equation.as_str()),
            ("wheel_friction", "wheel_x"),
            "{label}"
        );
        assert!(
            flag.lr > flag.threshold && flag.wald > flag.threshold,
            "{flag:?}"
        );
        assert!(flag.cv_with_remainder < flag.cv_cause, "{flag:?}");
        assert!(r.remaining.residual_remains, "{label}");
        check_remainder(&label, r, "wheel_x", "cos ψ", amplitude);
        let text = after.extended.to_toml_string();
        assert!(text.contains("[effects.fitted_wheel_torque]"), "{text}");
        // Refitted beside the remainder, the X wheel's Coulomb levels are the truth's within
        // 3 % (as in `tests/causes.rs`; seed 81 had 1.074e-3 and 1.902e-3 with the guard off).
        let friction = testbed_ident::Cause::WheelFriction.values(&after.extended);
        for (fitted, truth) in [(friction[0], 1.2e-3), (friction[3], 1.8e-3)] {
            assert!(
                (fitted - truth).abs() <= 0.03 * truth,
                "{label}: X Coulomb level {fitted} against {truth}"
            );
        }
    }
}

/// A sensor distortion that brought in a gyro cause: a magnetometer error of 2 µT × `sin ψ` on
/// its Y axis beside a hard iron, 600 s, seeds 81 and 82. The error moves the filter's attitude
/// and `earth_rate` (a latitude near 89°) was named for part of what that does. Its
/// falsification beside the unexplained field terms never ran: it removes a cause's part
/// through its change from its neutral values, and `earth_rate` has none. Its part is now the
/// innovations less those of a filter run without it: not significant beside the field terms
/// (likelihood ratio 4.5 and 0.4, threshold 23.9), it is dropped, and the field error stays
/// unexplained. (`tests/causes.rs` names a true `earth_rate` still.)
#[test]
fn an_earth_rate_brought_in_by_a_field_error_is_dropped() {
    let t = truth(
        "[effects.magnetic_disturbance]\nhard_iron_gauss = [0.02, -0.01, 0.0]\n\
         [[effects.fitted_field.terms]]\naxis = \"y\"\nfunction = \"sin ψ\"\ncoefficient = 2e-6\n",
    );
    for seed in [81, 82] {
        let label = format!("field error 2 µT × sin ψ + hard iron, seed {seed}");
        let id = identify_with(&experiment_data(&t, seed, 600.0), true);
        print(&label, &id);
        let r = &id.report;
        assert!(!names(&id).contains(&"earth_rate"), "{label}");
        let test = r
            .cause_tests
            .iter()
            .find(|c| c.name == "earth_rate")
            .unwrap_or_else(|| panic!("{label}: earth_rate not tested"));
        assert!(!test.kept, "{label}: {test:?}");
        assert!(
            test.joint_lr
                .zip(test.joint_threshold)
                .is_some_and(|(lr, t)| lr <= t),
            "{label}: {test:?}"
        );
        assert!(
            r.unexplained
                .iter()
                .any(|e| e.equation.starts_with("innovation_field")),
            "{label}: the field error is not reported"
        );
    }
}

/// The inclinometer turned 5 mrad about the vertical (`[effects.inclinometer_cross_axis]
/// coupling = [0.005, −0.005]`, each angle reading a fraction of the other), 600 s, seeds 81 and
/// 82, and beside the constant torque (seed 81), from a library without
/// `inclinometer_cross_axis`: a sensor distortion outside the library. It leaves innovations
/// proportional to the rates, which `gyro_delay` takes first and then drops for the
/// unexplained effect's form: nothing wrong is named, and the remainder is `w_x` in
/// `innovation_tilt_1`, `w_y` in `innovation_tilt_2`. The constant torque beside it is named.
#[test]
fn a_turned_inclinometer_is_unexplained_rather_than_a_gyro_cause() {
    let beside = format!("{TURNED}{CONSTANT_XY}");
    for (effects, seed, named) in [
        (TURNED, 81, &[][..]),
        (TURNED, 82, &[][..]),
        (&beside, 81, &["constant_torque"][..]),
    ] {
        let label = format!("inclinometer turned 5 mrad, {named:?}, seed {seed}");
        let data = experiment_data(&truth(effects), seed, 600.0);
        let id = identify_among(&data, true, library_without_cross_axis(&[]));
        print(&label, &id);
        let r = &id.report;
        assert_eq!(names(&id), named, "{label}");
        assert!(r.partly_explained.is_empty(), "{label}");
        for (equation, rate) in [("innovation_tilt_1", "w_x"), ("innovation_tilt_2", "w_y")] {
            remainder_term(&label, r, equation, rate);
        }
    }
}

/// The same turned inclinometer from the whole library: `gyro_delay` is chosen first and
/// dropped as a stand-in as above (with `inertia_error` after it on seed 81), and without the
/// stand-ins the analysis runs again and names
/// `inclinometer_cross_axis`, its two couplings within 3 standard errors of ±5e-3 (beside the
/// constant torque too, named within 3 of its own), with nothing left unexplained.
#[test]
fn a_turned_inclinometer_is_named_once_the_gyro_delay_standing_in_for_it_is_left_out() {
    let beside = format!("{TURNED}{CONSTANT_XY}");
    for (effects, seed, named) in [
        (TURNED, 81, &["inclinometer_cross_axis"][..]),
        (TURNED, 82, &["inclinometer_cross_axis"][..]),
        (
            &beside,
            81,
            &["constant_torque", "inclinometer_cross_axis"][..],
        ),
    ] {
        let t = truth(effects);
        let label = format!("inclinometer turned 5 mrad, {named:?}, seed {seed}");
        let id = identify_with(&experiment_data(&t, seed, 600.0), true);
        print(&label, &id);
        let r = &id.report;
        let mut got = names(&id);
        got.sort_unstable();
        assert_eq!(got, named, "{label}");
        assert!(r.stand_ins_left_out.contains(&"gyro_delay"), "{label}");
        check_within(&label, &id, &t, Cause::InclinometerCrossAxis, 3.0, 3e-4);
        if named.contains(&"constant_torque") {
            check_within(&label, &id, &t, Cause::ConstantTorque, 3.0, 3e-4);
        }
        assert!(r.unexplained.is_empty(), "{label}: {:?}", r.unexplained);
        assert!(r.partly_explained.is_empty(), "{label}");
    }
}

/// A sensor distortion a gyro cause stands in for, from a library without the sensors' clocks
/// (`gyro_delay`, which otherwise takes it, as above, and the vector sensors' lags, which take
/// part of it): the same turned inclinometer, seeds and constant torque.
/// The innovations see only the sensors' relative alignment, and a gyro triad turned −5 mrad
/// about Z explains them: with the guard off `gyro_misalignment` is named (its Z angle
/// −5.02e-3 ± 6.6e-5 rad) and no flag raised. But its correction then turns the estimated
/// rates against the wheels and the inertia: fitted to the torque equations the Z angle is zero
/// (seed 81: −7e-5 ± 2.7e-4 rad about X, 2.0e-4 ± 2.8e-4 about Y; χ² 669 on 9 degrees of
/// freedom against 94). With the guard on the cause is flagged on both tilt innovations, and
/// held at the dynamics' values the innovations keep the turned inclinometer's form: `w_x` in
/// `innovation_tilt_1`, `w_y` in `innovation_tilt_2` (Wald 2297 and 2145 against 27.6).
/// Checked: the Z angle in the torque equations about X and Y within 3 standard errors of 0
/// (the gyros are aligned), the innovations' within 3 of −5e-3, and beside it the constant
/// torque named with its values within 3 standard errors. Seeds 81–86 alone: flagged on all
/// six.
#[test]
fn a_gyro_misalignment_standing_in_for_a_turned_inclinometer_partly_explains_it() {
    let beside = format!("{TURNED}{CONSTANT_XY}");
    for (effects, seed, named) in [
        (TURNED, 81, &["gyro_misalignment"][..]),
        (TURNED, 82, &["gyro_misalignment"][..]),
        (&beside, 81, &["constant_torque", "gyro_misalignment"][..]),
    ] {
        let t = truth(effects);
        let label = format!("inclinometer turned 5 mrad, {named:?}, seed {seed}");
        let data = experiment_data(&t, seed, 600.0);
        let library = library_without_cross_axis(&[
            Cause::GyroDelay,
            Cause::InclinometerLag,
            Cause::MagnetometerLag,
        ]);
        let before = identify_among(&data, false, library.clone());
        print(&format!("{label}, guard off"), &before);
        assert_eq!(names(&before), named, "{label}");
        assert!(before.report.partly_explained.is_empty(), "{label}");
        let id = identify_among(&data, true, library);
        print(&label, &id);
        let r = &id.report;
        assert_eq!(names(&id), named, "{label}");
        for (equation, rate) in [("innovation_tilt_1", "w_x"), ("innovation_tilt_2", "w_y")] {
            let flag = flag_on(&label, r, "gyro_misalignment", equation);
            let Trigger::Dynamics(values) = &flag.trigger else {
                panic!("{label}: {:?}", flag.trigger);
            };
            assert!(values.chi2 > values.threshold, "{label}: {values:?}");
            let z = values
                .parameters
                .iter()
                .position(|p| p == "gyro_misalignment.angles_rad[2]")
                .expect("the Z angle is tested");
            for (name, value, se) in &values.equations {
                let truth = match name.as_str() {
                    "torque_x" | "torque_y" => 0.0,
                    "innovations" => -0.005,
                    _ => continue,
                };
                assert!(
                    (value[z] - truth).abs() <= 3.0 * se[z],
                    "{label}: {name}: Z angle {} ± {} against {truth}",
                    value[z],
                    se[z]
                );
            }
            remainder_term(&label, r, equation, rate);
        }
        if let Some(constant) = r.causes.iter().find(|c| c.name == "constant_torque") {
            let at = |map: &serde_json::Map<String, serde_json::Value>, i: usize| {
                map["torque_nm"][i].as_f64().expect("a number")
            };
            for (i, truth) in [1.5e-3, -1.0e-3, 0.0].into_iter().enumerate() {
                let (v, se) = (at(&constant.parameters, i), at(&constant.stderr, i));
                assert!(
                    (v - truth).abs() <= 3.0 * se,
                    "{label}: axis {i}: {v} ± {se}"
                );
            }
        }
        assert!(r.remaining.residual_remains, "{label}");
    }
}

/// No new false positive: library causes alone (a constant torque about all three axes, as in
/// `tests/causes.rs`; beside it a centre-of-mass offset 20 µm below the pivot, whose `r_z` acts
/// about X and Y alike; a gyro scale error with a gyro misalignment, whose corrections the
/// dynamics must agree with) are named without a "partly" flag on each of 10 seeds, on records of the two
/// lengths the cases above use (`tests/causes.rs` checks the same for every cause of the
/// library on its three seeds).
#[test]
fn library_causes_alone_are_not_flagged_over_ten_seeds() {
    let mut flagged = Vec::new();
    for (effects, causes) in [
        (
            "[effects.constant_torque]\ntorque_nm = [1.5e-3, -1.0e-3, 2.0e-3]\n",
            &["constant_torque"][..],
        ),
        (
            "[effects.constant_torque]\ntorque_nm = [1.5e-3, -1.0e-3, 0.0]\n[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -20.0e-6]\n",
            &["com_offset", "constant_torque"][..],
        ),
        (
            "[effects.gyro_scale]\nppm = [500.0, -700.0, 900.0]\n[effects.gyro_misalignment]\nangles_rad = [1.0e-3, -0.8e-3, 1.5e-3]\n",
            &["gyro_misalignment", "gyro_scale"][..],
        ),
    ] {
        let t = truth(effects);
        for duration_s in [600.0, 1200.0] {
            for seed in 200..210 {
                let id = identify_blind(&t, seed, duration_s);
                println!(
                    "{causes:?}, {duration_s} s, seed {seed}: {} ; partly {:?}",
                    id.report.verdict,
                    id.report
                        .partly_explained
                        .iter()
                        .map(|p| &p.verdict)
                        .collect::<Vec<_>>()
                );
                assert_eq!(names(&id), causes, "{duration_s} s, seed {seed}");
                if !id.report.partly_explained.is_empty() {
                    flagged.push((causes, duration_s, seed));
                }
            }
        }
    }
    assert!(flagged.is_empty(), "flagged on {flagged:?}");
}

/// A clock the library has no cause for: `wheels.csv` stamped late (telemetry stamped on
/// arrival). The wheels' momentum then lags the rates as under a larger inertia, and the
/// selection chooses `inertia_error` (+1.2 % about X and Y for 0.1 s, seed 81) — but the model
/// extended with it predicts the held-out data worse than the nominal one (0.67×; 0.80× for
/// 0.05 s): the data refute it. Checked, for 0.1 s (seeds 81, 82) and 0.05 s (seed 83):
/// nothing named, `inertia_error` refuted, the gain below 1/1.01, no guard flag, the extended
/// model the configuration given, and the lag's torque left as unexplained terms in `w_x` and
/// `w_y`. Beside a true inertia error (seed 81, 0.1 s) the extension predicts better (1.41×)
/// and the cause is named, its Z fraction within 4 standard errors (X and Y carry the lag's
/// +1.2 %: a limit, documented).
#[test]
fn a_late_wheel_clock_is_refuted_as_an_inertia_error() {
    let inertia = "[effects.inertia_error]\nfraction = [0.03, -0.02, 0.01]\n";
    for (effects, seed, late_s) in [
        ("", 81, 0.1),
        ("", 82, 0.1),
        ("", 83, 0.05),
        (inertia, 81, 0.1),
    ] {
        let label = format!("wheels.csv {late_s} s late, {effects:?}, seed {seed}");
        let mut data = experiment_data(&truth(effects), seed, 600.0);
        for row in &mut data.wheels {
            row.t_s += late_s;
        }
        let id = identify_with(&data, true);
        print(&label, &id);
        let r = &id.report;
        if !effects.is_empty() {
            assert_eq!(names(&id), ["inertia_error"], "{label}");
            assert!(
                r.refuted.is_empty() && r.gain > 1.0,
                "{label}: gain {}",
                r.gain
            );
            let values = &r.causes[0].parameters["fraction"];
            let errors = &r.causes[0].stderr["fraction"];
            let (z, se) = (values[2].as_f64().unwrap(), errors[2].as_f64().unwrap());
            assert!(
                (z - 0.01).abs() < 4.0 * se,
                "{label}: Z fraction {z} ± {se}"
            );
            continue;
        }
        assert_eq!(r.verdict, "none", "{label}");
        let refuted: Vec<&str> = r.refuted.iter().map(|c| c.name).collect();
        assert_eq!(refuted, ["inertia_error"], "{label}");
        assert!(r.gain * 1.01 < 1.0, "{label}: gain {}", r.gain);
        assert!(r.partly_explained.is_empty(), "{label}");
        assert!(id.extended.effects.inertia_error.is_none(), "{label}");
        assert!(id.extended.effects.fitted_torque.is_none(), "{label}");
        for (equation, rate) in [("torque_x", "w_x"), ("torque_y", "w_y")] {
            remainder_term(&label, r, equation, rate);
        }
    }
}
