//! The misattribution guard (`identify::guard`): a library cause that explains only part of what
//! it absorbed is flagged as partly explaining, and the remainder is reported as an unexplained
//! effect with its form, instead of "no residual remains".
//!
//! Each case is first identified with the guard off (`Options::misattribution_guard`), which
//! reproduces the misattribution (the library cause named, no unexplained effect, no residual),
//! then with it on. Seeds are fixed; 600 s of the identification experiment each.

mod common;
use common::*;
use testbed_ident::Options;
use testbed_ident::identify::Identification;

/// A constant torque about X and Y (a library cause, truly acting).
const CONSTANT_XY: &str = "[effects.constant_torque]\ntorque_nm = [1.5e-3, -1.0e-3, 0.0]\n";

fn print(label: &str, id: &Identification) {
    println!("{label}: verdict {}", id.report.verdict);
    for line in &id.report.summary {
        println!("    {line}");
    }
}

fn identify_with(data: &testbed_ident::Dataset, guard: bool) -> Identification {
    let options = Options {
        misattribution_guard: guard,
        ..options()
    };
    testbed_ident::identify(data, &nominal(), &options).expect("identification runs")
}

/// A torque about Z of `amplitude · cos ψ` (out of the library) beside a constant torque about X
/// and Y. Over the experiment's ±60° of heading it is mostly a constant, and the constant
/// torque's Z value takes it: with the guard off, `constant_torque` is named alone, no
/// unexplained effect is found (the search beside the cause needs 1 % of the cross-validated
/// residual sum: the remainder is 0.5 % of it) and "no residual remains". With the guard on the
/// cause stays named, flagged as partly explaining `torque_z` (the unrestricted search,
/// `cos ψ`, predicts better out of fold; beside the constant the `cos ψ` term beats the
/// selection's threshold by the likelihood ratio and the cluster-robust Wald statistic), the
/// remainder is an unexplained effect with `cos ψ`, its coefficient within 3 standard errors of
/// the truth, and a residual is said to remain. Measured: seed 81 at 0.15 mNm, likelihood ratio
/// 34.7 and Wald 38.5 against 23.9; seed 82 at 0.12 mNm, 31.6 and 29.5.
#[test]
fn a_constant_torque_standing_in_for_a_heading_torque_partly_explains_it() {
    for (amplitude, seed) in [(1.5e-4, 81), (1.2e-4, 82)] {
        let label = format!("heading torque {amplitude:e} Nm + constant torque, seed {seed}");
        let t = truth(&format!(
            "{CONSTANT_XY}[effects.heading_torque]\ncos_nm = [0.0, 0.0, {amplitude:e}]\nsin_nm = [0.0, 0.0, 0.0]\n"
        ));
        let data = experiment_data(&t, seed, 600.0);
        let before = identify_with(&data, false);
        print(&format!("{label}, guard off"), &before);
        assert_eq!(names(&before), ["constant_torque"], "{label}");
        assert!(before.report.unexplained.is_empty(), "{label}");
        assert!(!before.report.remaining.residual_remains, "{label}");
        assert!(before.report.partly_explained.is_empty(), "{label}");

        let after = identify_with(&data, true);
        print(&format!("{label}, guard on"), &after);
        let r = &after.report;
        assert_eq!(names(&after), ["constant_torque"], "{label}");
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
        let remainder = r
            .unexplained
            .iter()
            .find(|e| e.equation == "torque_z")
            .unwrap_or_else(|| panic!("{label}: no remainder: {:?}", r.unexplained));
        let term = remainder
            .terms
            .iter()
            .find(|t| t.name == "cos ψ")
            .unwrap_or_else(|| panic!("{label}: {}", remainder.proposed));
        assert!(
            (term.value - amplitude).abs() <= 3.0 * term.stderr,
            "{label}: cos ψ coefficient {} ± {} against {amplitude}",
            term.value,
            term.stderr
        );
        assert!(r.remaining.residual_remains, "{label}");
        assert!(
            r.summary.iter().any(
                |l| l.starts_with("Partly explained: constant_torque partly explains torque_z")
            ),
            "{label}: {:?}",
            r.summary
        );
        // The constant torque's X and Y values are still the truth's, within 10 %.
        let fitted = testbed_ident::Cause::ConstantTorque.values(&after.extended);
        for (f, h) in fitted.iter().zip([1.5e-3, -1.0e-3]) {
            assert!((f - h).abs() <= 0.1 * h.abs(), "{label}: {fitted:?}");
        }
        // In report.json.
        let json = serde_json::to_value(r).expect("the report serialises");
        assert_eq!(
            json["partly_explained"][0]["equation"], "torque_z",
            "{label}"
        );
    }
}

/// No new false positive: a library cause alone (a constant torque about all three axes, as in
/// `tests/causes.rs`) is named without a "partly" flag on each of 10 seeds (`tests/causes.rs`
/// checks the same for every cause of the library on its three seeds).
#[test]
fn a_library_cause_alone_is_not_flagged_over_ten_seeds() {
    let t = truth("[effects.constant_torque]\ntorque_nm = [1.5e-3, -1.0e-3, 2.0e-3]\n");
    let mut flagged = Vec::new();
    for seed in 200..210 {
        let id = identify_blind(&t, seed, 600.0);
        println!(
            "seed {seed}: {} ; partly {:?}",
            id.report.verdict,
            id.report
                .partly_explained
                .iter()
                .map(|p| &p.verdict)
                .collect::<Vec<_>>()
        );
        assert_eq!(names(&id), ["constant_torque"], "seed {seed}");
        if !id.report.partly_explained.is_empty() {
            flagged.push(seed);
        }
    }
    assert!(flagged.is_empty(), "flagged on seeds {flagged:?}");
}

/// Known limit (ignored; run with `--ignored`): the guard flags a remainder only where it is
/// significant beside the cause, and at these sizes it is not, so the misattribution stands.
/// Beside the constant torque about X and Y:
/// - a magnetic dipole of 5 A m² along body Y in the lab field (`[effects.dipole_torque]`:
///   −0.24 mNm about X, −0.13 mNm × cos ψ about Z), seed 82: `constant_torque + com_offset`
///   named, no residual; the unrestricted search finds `torque_z ≈ −1.26e-4 Nm × cos ψ` and
///   predicts better out of fold (6.9227e-3 against 6.9286e-3), but beside the two causes its
///   likelihood ratio is 9.7 and its Wald statistic 6.8 against 23.9;
/// - a torque about X of 0.4 mNm per unit of `sin tilt_x`, seed 82: `constant_torque` named,
///   no residual; the unrestricted search without it finds no function but its own form.
#[test]
#[ignore]
fn a_dipole_in_the_lab_field_and_a_tilt_torque_known_limit() {
    for (label, effects, seed) in [
        (
            "dipole 5 A m² along Y",
            "[effects.dipole_torque]\nmoment_am2 = [0.0, 5.0, 0.0]\n",
            82,
        ),
        (
            "tilt torque 0.4 mNm",
            "[effects.fitted_torque]\nstart_time_s = 0.0\n[[effects.fitted_torque.terms]]\naxis = \"x\"\nfunction = \"sin tilt_x\"\ncoefficient = 4.0e-4\n",
            82,
        ),
    ] {
        let t = truth(&format!("{CONSTANT_XY}{effects}"));
        let data = experiment_data(&t, seed, 600.0);
        let id = identify_with(&data, true);
        print(label, &id);
        assert!(!id.report.partly_explained.is_empty(), "{label}");
    }
}
