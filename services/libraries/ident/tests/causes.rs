//! Every cause of the library, hidden one at a time at a realistic magnitude in simulated data of
//! the identification experiment, identified blind against the nominal model: it must be named
//! (alone), its parameters recovered within the stated tolerance, and the extended model must
//! predict the held-out data better than the nominal by at least the stated gain. Three seeds
//! each. Clean data must give `none`; two hidden effects must both be found.
//!
//! Durations: 600 s of the experiment, 1200 s where an effect is weakly excited (drag, gyro
//! scale and misalignment, friction near zero speed).
//!
//! Gains are overall held-out gains (RMS over the 11 measurement components of the prediction
//! error normalised by each sensor's noise, nominal / extended). Sensor-side effects of a few
//! hundred ppm or µrad barely move the multi-step prediction error, which is dominated by the
//! sensors' own noise; their thresholds are accordingly small but above 1.

mod common;
use common::*;
use testbed_ident::Cause;

const SEEDS: [u64; 3] = [21, 22, 23];

#[test]
fn com_offset() {
    // 2.5 µm and 1.5 µm horizontal, 1 µm pendulous: 10 mNm of gravity torque, more than the
    // wheels can hold for long (they saturate and the platform reaches the tilt stop).
    let truth = truth("[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 10 % or 0.2 µm, whichever is larger.
        check_single(
            &format!("com_offset seed {seed}"),
            &truth,
            Cause::ComOffset,
            &id,
            10.0,
            |_, t| (0.1 * t.abs()).max(0.2e-6),
        );
    }
}

#[test]
fn earth_rate() {
    let truth = truth("[effects.earth_rate]\nlatitude_deg = 43.88\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        check_single(
            &format!("earth_rate seed {seed}"),
            &truth,
            Cause::EarthRate,
            &id,
            1.5,
            |_, _| 3.0,
        );
    }
}

#[test]
fn aero_drag() {
    // Linear and quadratic drag; the Z axis (heading slews, 10 mrad/s) is excited far more than
    // X and Y (tilt steps, a few mrad/s), so the check is on the drag torque at each axis's RMS
    // rate in the data, which is what the data determine.
    let truth = truth("[effects.aero_drag]\nc1 = [0.01, 0.01, 0.03]\nc2 = [0.3, 0.3, 1.0]\n");
    for seed in SEEDS {
        let data = experiment_data(&truth, seed, 1200.0);
        let id =
            testbed_ident::identify(&data, &nominal(), &options()).expect("identification runs");
        let label = format!("aero_drag seed {seed}");
        assert_eq!(
            names(&id),
            vec!["aero_drag"],
            "{label}: {:?}",
            id.report.steps
        );
        let fitted = Cause::AeroDrag.values(&id.extended);
        let hidden = Cause::AeroDrag.values(&truth);
        for axis in 0..3 {
            let n = data.gyro.len() as f64;
            let rms = (data
                .gyro
                .iter()
                .map(|r| r.rate_rad_s[axis].powi(2))
                .sum::<f64>()
                / n)
                .sqrt();
            let torque = |v: &[f64]| v[axis] * rms + v[3 + axis] * rms * rms;
            let (f, t) = (torque(&fitted), torque(&hidden));
            println!(
                "{label}: axis {axis}: drag at the RMS rate {rms:.2e} rad/s: {f:.3e} Nm (true {t:.3e})"
            );
            // Within 30 % on X and Y, 10 % on Z.
            let allowed = if axis == 2 { 0.1 } else { 0.3 };
            assert!(
                (f - t).abs() <= allowed * t,
                "{label}: axis {axis}: drag torque {f} vs {t}"
            );
        }
        println!("{label}: held-out gain {:.3}", id.report.gain);
        assert!(id.report.gain > 1.05, "{label}: gain {}", id.report.gain);
        assert!(
            !id.report.remaining.residual_remains,
            "{label}: {}",
            id.report.remaining.message
        );
        assert_eq!(extended_round_trip(&id, &label), id.extended);
    }
}

#[test]
fn constant_torque() {
    // Cable and exhaust torque of 1–2 mNm, about the wheels' Coulomb friction.
    let truth = truth("[effects.constant_torque]\ntorque_nm = [1.5e-3, -1.0e-3, 2.0e-3]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 2 %.
        check_single(
            &format!("constant_torque seed {seed}"),
            &truth,
            Cause::ConstantTorque,
            &id,
            5.0,
            |_, t| 0.02 * t.abs(),
        );
    }
}

#[test]
fn inertia_error() {
    let truth = truth("[effects.inertia_error]\nfraction = [0.03, -0.02, 0.04]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 0.3 % of the moment (a tenth of the smallest error); the products (none
        // hidden) within 0.1 kg m² (0.2 % of the smallest moment).
        check_single(
            &format!("inertia_error seed {seed}"),
            &truth,
            Cause::InertiaError,
            &id,
            2.0,
            |i, _| if i < 3 { 0.003 } else { 0.1 },
        );
    }
}

#[test]
fn inertia_products() {
    // Products of inertia of 0.5–0.8 kg m² (1–2 % of the moments: a platform balanced in
    // position but not in its mass distribution), the moments right.
    let truth = truth(
        "[effects.inertia_error]\nfraction = [0.0, 0.0, 0.0]\nproducts_kgm2 = [0.8, -0.5, 0.6]\n",
    );
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Products within 0.1 kg m², moments within 0.3 %; explained to the noise (no
        // residual remains, checked by `check_single`).
        check_single(
            &format!("inertia_products seed {seed}"),
            &truth,
            Cause::InertiaError,
            &id,
            1.05,
            |i, _| if i < 3 { 0.003 } else { 0.1 },
        );
    }
}

#[test]
fn gyro_scale() {
    let truth = truth("[effects.gyro_scale]\nppm = [500.0, -700.0, 900.0]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 1200.0);
        // Within 250 ppm (about 3 standard errors on 1200 s).
        check_single(
            &format!("gyro_scale seed {seed}"),
            &truth,
            Cause::GyroScale,
            &id,
            1.02,
            |_, _| 250.0,
        );
    }
}

#[test]
fn gyro_misalignment() {
    let truth = truth("[effects.gyro_misalignment]\nangles_rad = [5e-4, -3e-4, 8e-4]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 1200.0);
        // Within 0.2 mrad.
        check_single(
            &format!("gyro_misalignment seed {seed}"),
            &truth,
            Cause::GyroMisalignment,
            &id,
            1.05,
            |_, _| 2e-4,
        );
    }
}

#[test]
fn gyro_bias_drift() {
    // A gyro warming up: the bias moves by 6e-5 rad/s (12 °/h) over the 600-s record, some 500
    // times what the random walk of the model allows it.
    let truth = truth("[effects.gyro_bias_drift]\nrate_rad_s2 = [1e-7, -7e-8, 5e-8]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 1e-8 rad/s² (about three standard errors on Z, seven on X and Y).
        check_single(
            &format!("gyro_bias_drift seed {seed}"),
            &truth,
            Cause::GyroBiasDrift,
            &id,
            1.5,
            |_, _| 1e-8,
        );
    }
}

/// A drifting gyro bias beside a torque cause (the drift tilts the estimated attitude the
/// gravity torque is computed from) and beside the gyro's scale (both correct the rate
/// readings): both named, each within three of its reported standard errors.
#[test]
fn a_gyro_bias_drift_beside_another_cause_names_both() {
    const DRIFT: &str = "[effects.gyro_bias_drift]\nrate_rad_s2 = [1e-7, -7e-8, 5e-8]\n";
    for (other, effect) in [
        (
            Cause::ComOffset,
            "[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n",
        ),
        (
            Cause::GyroScale,
            "[effects.gyro_scale]\nppm = [500.0, -700.0, 900.0]\n",
        ),
    ] {
        let truth = truth(&format!("{DRIFT}{effect}"));
        let id = identify_blind(&truth, 21, 600.0);
        let mut found = names(&id);
        found.sort();
        let mut want = vec!["gyro_bias_drift", other.name()];
        want.sort();
        assert_eq!(found, want, "{:?}", id.report.steps);
        for cause in [other, Cause::GyroBiasDrift] {
            check_within(other.name(), &id, &truth, cause, 3.0, f64::INFINITY);
        }
    }
}

#[test]
fn gyro_delay() {
    // 50 ms: the gyros' output filter and a serial link, stamped on arrival.
    let truth = truth("[effects.gyro_delay]\ndelay_s = 0.05\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 3 ms (about 3.5 standard errors on 600 s).
        check_single(
            &format!("gyro_delay seed {seed}"),
            &truth,
            Cause::GyroDelay,
            &id,
            1.2,
            |_, _| 3e-3,
        );
    }
}

/// A gyro delay stands in for an inertia error when the library has no delay (its rates lag the
/// wheels' momentum, as a larger inertia's would): beside a true inertia error, and beside an
/// actuator delay, both are named, each value within 4 standard errors and within 3 ms (the
/// gyro delay), 2 ms (the actuator delay) or 0.02 (the inertia's fractions, and its products in
/// kg m², which these manoeuvres barely excite).
#[test]
fn a_gyro_delay_beside_an_inertia_error_or_an_actuator_delay_names_both() {
    let delay = "[effects.gyro_delay]\ndelay_s = 0.05\n";
    for (other, cause, abs, seed) in [
        (
            "[effects.inertia_error]\nfraction = [0.03, -0.02, 0.01]\n",
            Cause::InertiaError,
            0.02,
            21,
        ),
        (
            "[effects.actuator_delay]\ndelay_s = 0.15\n",
            Cause::ActuatorDelay,
            2e-3,
            22,
        ),
    ] {
        let truth = truth(&format!("{delay}{other}"));
        let id = identify_blind(&truth, seed, 600.0);
        let label = format!("gyro_delay beside {}, seed {seed}", cause.name());
        let mut found = names(&id);
        found.sort();
        let mut want = vec!["gyro_delay", cause.name()];
        want.sort();
        assert_eq!(found, want, "{label}: {:?}", id.report.steps);
        check_within(&label, &id, &truth, Cause::GyroDelay, 4.0, 3e-3);
        check_within(&label, &id, &truth, cause, 4.0, abs);
    }
}

/// A true wheel cause passes its competing-explanation test: the test ran (the wheel search
/// without the cause and its own form) and the cause was kept.
fn competitor_kept(label: &str, id: &testbed_ident::identify::Identification, cause: Cause) {
    let test = id
        .report
        .cause_tests
        .iter()
        .find(|t| t.name == cause.name())
        .unwrap_or_else(|| panic!("{label}: {} not tested", cause.name()));
    let c = test
        .competitor
        .as_ref()
        .unwrap_or_else(|| panic!("{label}: no competitor test: {test:?}"));
    println!(
        "{label}: competitor: cv {:.1} without, {:.1} with ({}); LR {:?}, Wald {:?}, threshold {:?}",
        c.cv_without, c.cv_with, c.form, c.lr, c.wald, c.threshold
    );
    assert!(
        test.kept && test.failed.is_none(),
        "{label}: {}",
        test.verdict
    );
}

#[test]
fn wheel_friction() {
    // Per-wheel levels, direction asymmetry on X and Z, a Stribeck spike on X and Z (Y none:
    // its breakaway equals its Coulomb level).
    let truth = truth(
        "[effects.wheel_friction]\n\
         coulomb_pos_nm = [1.2e-3, 1.5e-3, 1.8e-3]\n\
         coulomb_neg_nm = [1.8e-3, 1.5e-3, 1.3e-3]\n\
         viscous_nm_per_rad_s = [3e-6, 4e-6, 2.5e-6]\n\
         stribeck_nm = [3e-3, 1.5e-3, 3.5e-3]\n\
         stribeck_speed_rad_s = [0.8, 1.0, 1.5]\n",
    );
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 1200.0);
        let label = format!("wheel_friction seed {seed}");
        // Coulomb levels within 3 %, viscous within 5 %, Stribeck level within 20 % and speed
        // within 25 % on X and Z; on Y (no Stribeck term) the breakaway must equal the Coulomb
        // level within 3 % (its Stribeck speed is then immaterial).
        let tol = |i: usize, t: f64| match i {
            0..6 => 0.03 * t,
            6..9 => 0.05 * t,
            9 | 11 => 0.2 * t,
            10 => 0.03 * t,
            12 | 14 => 0.25 * t,
            _ => f64::INFINITY,
        };
        check_single(&label, &truth, Cause::WheelFriction, &id, 10.0, tol);
        competitor_kept(&label, &id, Cause::WheelFriction);
    }
}

#[test]
fn wheel_torque_scale() {
    let truth = truth("[effects.wheel_torque_scale]\nscale = [0.95, 1.04, 0.97]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 0.3 %.
        check_single(
            &format!("wheel_torque_scale seed {seed}"),
            &truth,
            Cause::WheelTorqueScale,
            &id,
            20.0,
            |_, _| 0.003,
        );
        competitor_kept(
            &format!("wheel_torque_scale seed {seed}"),
            &id,
            Cause::WheelTorqueScale,
        );
    }
}

#[test]
fn actuator_delay() {
    // 150 ms: CAN bus, smart node and drive.
    let truth = truth("[effects.actuator_delay]\ndelay_s = 0.15\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 2 ms.
        check_single(
            &format!("actuator_delay seed {seed}"),
            &truth,
            Cause::ActuatorDelay,
            &id,
            10.0,
            |_, _| 2e-3,
        );
        competitor_kept(
            &format!("actuator_delay seed {seed}"),
            &id,
            Cause::ActuatorDelay,
        );
    }
}

#[test]
fn magnetic_disturbance() {
    // 14 µT of body-fixed field (motors, building): heading errors of tens of degrees for the
    // nominal model.
    let truth = truth("[effects.magnetic_disturbance]\nhard_iron_gauss = [0.08, -0.05, 0.1]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 0.001 G (0.1 µT).
        check_single(
            &format!("magnetic_disturbance seed {seed}"),
            &truth,
            Cause::MagneticDisturbance,
            &id,
            10.0,
            |_, _| 1e-3,
        );
    }
}

#[test]
fn inclinometer_bias() {
    // The inclinometer mounted 0.05° and −0.03° off level with the body axes (a tenth of a
    // millimetre over its base). Before the cause was in the library the same data named a
    // gyro misalignment of 0.9 mrad, falsified the hard iron and left unexplained field terms.
    let truth = truth("[effects.inclinometer_bias]\noffset_rad = [8.7e-4, -5.2e-4]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 0.1 mrad (about three of its standard errors, 3e-5 rad); the gain is that of a
        // sensor offset, which moves the 10-s prediction of the tilt only (measured 1.18×).
        check_single(
            &format!("inclinometer_bias seed {seed}"),
            &truth,
            Cause::InclinometerBias,
            &id,
            1.1,
            |_, _| 1e-4,
        );
    }
}

#[test]
fn inclinometer_cross_axis() {
    // Each angle reads a part of the other: 2 % of φ in θ and −1 % of θ in φ, a cross-axis
    // sensitivity that is not a rotation (that has the two equal and opposite,
    // `misattribution.rs`).
    let truth = truth("[effects.inclinometer_cross_axis]\ncoupling = [0.02, -0.01]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        check_single(
            &format!("inclinometer_cross_axis seed {seed}"),
            &truth,
            Cause::InclinometerCrossAxis,
            &id,
            2.0,
            |_, _| 3e-4,
        );
    }
}

#[test]
fn inclinometer_scale() {
    // The inclinometer's gain 2 % high on θ and 1 % low on φ (a calibration off). Before the
    // cause was in the library, a 3 % error was blamed on the magnetometer (the second pass's
    // correction in sin tilt) with a gyro scale error proposed and falsified.
    let truth = truth("[effects.inclinometer_scale]\nppm = [2.0e4, -1.0e4]\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 300 ppm, about three of its standard errors (measured ~100 ppm).
        check_single(
            &format!("inclinometer_scale seed {seed}"),
            &truth,
            Cause::InclinometerScale,
            &id,
            2.0,
            |_, _| 300.0,
        );
    }
}

#[test]
fn inclinometer_lag() {
    // The inclinometer's angles lag by 0.5 s (an electrolytic sensor's settling). Outside the
    // library, a first-order response of 0.5 s (a discrete filter on the recorded rows) had the
    // magnetometer blamed (the second pass's correction in the rates) and the tilt innovations
    // coloured at 7 times the noise.
    let truth = truth("[effects.inclinometer_lag]\ntime_constant_s = 0.5\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 10 ms, some ten of its standard errors (measured 1.1–1.9 ms).
        check_single(
            &format!("inclinometer_lag seed {seed}"),
            &truth,
            Cause::InclinometerLag,
            &id,
            2.0,
            |_, _| 0.01,
        );
    }
}

#[test]
fn magnetometer_lag() {
    // The magnetometer reads the field 0.2 s late (it averages its samples, or is stamped on
    // arrival). Its effect on the field is about the noise (0.1 µT at the experiment's rates),
    // so the bound is looser than the inclinometer's.
    let truth = truth("[effects.magnetometer_lag]\ntime_constant_s = 0.2\n");
    for seed in SEEDS {
        let id = identify_blind(&truth, seed, 600.0);
        // Within 30 ms, some five of its standard errors (measured 0.6–1.9 ms).
        check_single(
            &format!("magnetometer_lag seed {seed}"),
            &truth,
            Cause::MagnetometerLag,
            &id,
            1.0,
            |_, _| 0.03,
        );
    }
}

/// Lags the simulator does not make: rows stamped late (a pure delay, not the effects'
/// reading of the attitude held at the present rate). The inclinometer's rows 0.2 s late are
/// named its lag of 0.2 s; both vector sensors' 0.1 s late, both lags of 0.1 s; the
/// magnetometer's alone 0.1 s late (no field sample then falls on a tilt sample: the filter
/// starts from a pair apart in time, where it once refused the record), its lag.
#[test]
fn vector_sensors_stamped_late_are_named_lags() {
    for (seed, tilt_s, field_s) in [
        (21, 0.2, 0.0),
        (22, 0.2, 0.0),
        (21, 0.1, 0.1),
        (65, 0.0, 0.1),
    ] {
        let label = format!("inclinometer {tilt_s} s, magnetometer {field_s} s late, seed {seed}");
        let mut data = experiment_data(&nominal(), seed, 600.0);
        for row in &mut data.inclinometer {
            row.t_s += tilt_s;
        }
        for row in &mut data.magnetometer {
            row.t_s += field_s;
        }
        let id = testbed_ident::identify(&data, &nominal(), &options()).expect("identifies");
        print_steps(&label, &id);
        let want: Vec<(Cause, f64, f64)> = [
            (Cause::InclinometerLag, tilt_s, 0.01),
            (Cause::MagnetometerLag, field_s, 0.03),
        ]
        .into_iter()
        .filter(|w| w.1 > 0.0)
        .collect();
        let mut expected: Vec<&str> = want.iter().map(|w| w.0.name()).collect();
        let mut found = names(&id);
        expected.sort();
        found.sort();
        assert_eq!(found, expected, "{label}");
        let se_bound = 5.0;
        for (cause, lag, allowed) in want {
            let fitted = cause.values(&id.extended)[0];
            let se = stderr(&id, cause)[0];
            println!("{label}: {} = {fitted:.4} ± {se:.1e} s", cause.name());
            assert!(
                (fitted - lag).abs() <= allowed,
                "{label}: {fitted} against {lag}"
            );
            assert!(
                (fitted - lag).abs() <= se_bound * se,
                "{label}: {fitted} ± {se}"
            );
        }
        // A field 0.1 s late is off by about its noise (the gain 1.01×); tilts by ten times it.
        let min_gain = if tilt_s > 0.0 { 2.0 } else { 1.0 };
        assert!(
            id.report.gain > min_gain,
            "{label}: gain {}",
            id.report.gain
        );
        assert!(
            !id.report.remaining.residual_remains,
            "{label}: {}",
            id.report.remaining.message
        );
    }
}

#[test]
fn an_inclinometer_bias_beside_another_cause_names_both() {
    // The tilt offset is also an error in the attitude the gravity torque is computed from and
    // in the attitude the magnetometer and the gyros are read against: each pair must be told
    // apart, not traded for each other.
    const TILT: &str = "[effects.inclinometer_bias]\noffset_rad = [8.7e-4, -5.2e-4]\n";
    for (other, effect, seed) in [
        (
            Cause::ComOffset,
            "[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n",
            33,
        ),
        (
            Cause::MagneticDisturbance,
            "[effects.magnetic_disturbance]\nhard_iron_gauss = [0.08, -0.05, 0.1]\n",
            5,
        ),
        (
            Cause::GyroMisalignment,
            "[effects.gyro_misalignment]\nangles_rad = [4e-4, -8e-4, 3e-4]\n",
            5,
        ),
        (
            Cause::InclinometerScale,
            "[effects.inclinometer_scale]\nppm = [2.0e4, -1.0e4]\n",
            6,
        ),
    ] {
        let truth = truth(&format!("{TILT}{effect}"));
        let id = identify_blind(&truth, seed, 600.0);
        let mut found = names(&id);
        found.sort();
        let mut want = vec!["inclinometer_bias", other.name()];
        want.sort();
        assert_eq!(found, want, "{:?}", id.report.steps);
        // Within three of its reported standard errors: the pair's errors are correlated, so
        // the bound is the one the report itself states.
        for cause in [other, Cause::InclinometerBias] {
            check_within(other.name(), &id, &truth, cause, 3.0, f64::INFINITY);
        }
    }
}

/// Uniform in [−1, 1), a fixed sequence (a linear congruential generator): the same jitter and
/// the same lost rows on every run.
fn uniform(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

#[test]
fn lost_rows_and_jittered_time_stamps_still_name_a_hidden_cause() {
    // Real records lose frames and stamp samples on arrival. Before vector samples were applied
    // at their own time, either made identification refuse the record ("vector sample older
    // than the filter state by more than 100 ms").
    let truth = truth("[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n");
    for (label, lose, jitter_s) in [
        ("5 % of rows lost", 0.05, 0.0),
        ("gyro stamps ±3 ms", 0.0, 3e-3),
    ] {
        let mut data = experiment_data(&truth, 21, 600.0);
        let mut state = 7;
        let keep = |state: &mut u64| uniform(state) * 0.5 + 0.5 >= lose;
        data.gyro.retain(|_| keep(&mut state));
        data.inclinometer.retain(|_| keep(&mut state));
        data.magnetometer.retain(|_| keep(&mut state));
        data.wheels.retain(|_| keep(&mut state));
        for row in &mut data.gyro {
            row.t_s += jitter_s * uniform(&mut state);
        }
        // The wheel rows keep their stamps: ±3 ms there is ±0.2 rad/s of wheel speed at full
        // torque, twenty times the tachometer's noise, which the report rightly calls a residual
        // in the wheel channel.
        let id = testbed_ident::identify(&data, &nominal(), &options())
            .unwrap_or_else(|e| panic!("{label}: {e}"));
        // The same bounds as the com_offset test on the whole record.
        check_single(label, &truth, Cause::ComOffset, &id, 10.0, |_, t| {
            (0.1 * t.abs()).max(0.2e-6)
        });
    }
}

/// Silences: a record whose devices lose every row for a while (a logger that stalled, a
/// link that dropped). Over 20 s of the gyro's silence the attitude filter carried its attitude
/// on the rates at the silence's two ends, and what the platform did in between came out as
/// physics: a `magnetic_disturbance` named (seed 1, 200–220 s), a magnetometer correction
/// fitted (450–470 s), coloured tilt innovations at 5–27 times the noise; a silence of the gyro
/// alone refused the record ("vector sample … older than the filter state"), and one of the
/// wheels alone left predictions driven by unknown commands at 48 times the tilt noise. Now
/// each is a break: the filter starts again after the gyro's, and no equation or prediction
/// spans one. Checked: the clean record (seed 1) gives `none`, no unexplained effect, no
/// coloured residual and no residual said to remain, with the silences listed; beside a hidden
/// centre-of-mass offset (seed 21) it is named within the bounds of the whole record.
#[test]
fn silences_break_the_record_rather_than_look_like_physics() {
    let offset = truth("[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n");
    let all = ["gyro", "inclinometer", "magnetometer", "wheels"];
    for (label, truth, seed, from_s, devices) in [
        ("all, 200 s", nominal(), 1, 200.0, &all[..]),
        ("all, 450 s", nominal(), 1, 450.0, &all[..]),
        ("gyro, 300 s", nominal(), 1, 300.0, &["gyro"][..]),
        ("wheels, 300 s", nominal(), 1, 300.0, &["wheels"][..]),
        ("all beside an offset", offset, 21, 300.0, &all[..]),
    ] {
        let mut data = experiment_data(&truth, seed, 600.0);
        let silent = |t: f64| (from_s..from_s + 20.0).contains(&t);
        for device in devices {
            match *device {
                "gyro" => data.gyro.retain(|r| !silent(r.t_s)),
                "inclinometer" => data.inclinometer.retain(|r| !silent(r.t_s)),
                "magnetometer" => data.magnetometer.retain(|r| !silent(r.t_s)),
                _ => data.wheels.retain(|r| !silent(r.t_s)),
            }
        }
        let id = testbed_ident::identify(&data, &nominal(), &options())
            .unwrap_or_else(|e| panic!("{label}: {e}"));
        let report = &id.report;
        println!("{label}: {}", report.summary.join("\n  "));
        let silences: Vec<&str> = report.data.silences.iter().map(|s| s.device).collect();
        let expected: Vec<&str> = ["gyro", "wheels"]
            .into_iter()
            .filter(|d| devices.contains(d))
            .collect();
        assert_eq!(silences, expected, "{label}");
        for s in &report.data.silences {
            assert!((s.to_s - s.from_s - 20.1).abs() < 1e-6, "{label}: {s:?}");
        }
        assert!(
            report.summary[0].starts_with("Breaks in the record"),
            "{label}"
        );
        if seed == 1 {
            assert_eq!(report.verdict, "none", "{label}");
            assert!(
                report.unexplained.is_empty(),
                "{label}: {:?}",
                report.unexplained
            );
            assert!(
                !report.remaining.residual_remains,
                "{label}: {}",
                report.remaining.message
            );
        } else {
            check_single(label, &truth, Cause::ComOffset, &id, 10.0, |_, t| {
                (0.1 * t.abs()).max(0.2e-6)
            });
        }
        assert!(
            report.whiteness.lines().is_empty(),
            "{label}: {:?}",
            report.whiteness.lines()
        );
    }
}

/// Adds ±`size` (the sign drawn from `state`) to one column, in turn, of every `every`-th row
/// from the middle of the first `every`: the readings spoilt, as (time, column).
fn spoil<'a>(
    rows: impl Iterator<Item = (f64, &'a mut [f64])>,
    columns: &[&'static str],
    every: usize,
    size: f64,
    state: &mut u64,
) -> Vec<(f64, &'static str)> {
    let mut spoilt = Vec::new();
    for (k, (t_s, values)) in rows.enumerate().skip(every / 2).step_by(every) {
        let axis = k % columns.len();
        values[axis] += if uniform(state) < 0.0 { -size } else { size };
        spoilt.push((t_s, columns[axis]));
    }
    spoilt
}

/// Isolated spikes (corrupted frames): every 200th gyro row off by ±0.01 rad/s on one axis
/// (some 500 times its noise), every 50th inclinometer row by ±0.01 rad, magnetometer row by
/// ±2 µT and wheel row's speed by ±1 rad/s (some 95 times the tachometer's noise). Without the
/// screening 0.5 % of such gyro rows made a clean record name a `gyro_delay` of 25 ms, and the
/// wheel speeds' left the wheel channel at 4.3 times its noise. Checked: the report lists
/// exactly the readings spoilt (file, time, column), nothing is named on the clean record
/// (seed 22), and beside a hidden centre-of-mass offset (seed 21) or wheel torque scale
/// (seed 23) it is named within the bounds of the whole, unspoilt record.
#[test]
fn isolated_spikes_are_left_out_and_listed() {
    let offset = truth("[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n");
    let torque_scale = truth("[effects.wheel_torque_scale]\nscale = [0.95, 1.04, 0.97]\n");
    for (label, truth, seed) in [
        ("clean", nominal(), 22),
        ("centre-of-mass offset", offset, 21),
        ("wheel torque scale", torque_scale, 23),
    ] {
        let mut data = experiment_data(&truth, seed, 600.0);
        let mut state = 5;
        let mut spoilt = spoil(
            data.gyro
                .iter_mut()
                .map(|r| (r.t_s, r.rate_rad_s.as_mut_slice())),
            &["wx", "wy", "wz"],
            200,
            0.01,
            &mut state,
        );
        spoilt.extend(spoil(
            data.inclinometer
                .iter_mut()
                .map(|r| (r.t_s, &mut r.tilt_rad[..])),
            &["tilt_x", "tilt_y"],
            50,
            0.01,
            &mut state,
        ));
        spoilt.extend(spoil(
            data.magnetometer
                .iter_mut()
                .map(|r| (r.t_s, r.field_t.as_mut_slice())),
            &["bx", "by", "bz"],
            50,
            2e-6,
            &mut state,
        ));
        spoilt.extend(spoil(
            data.wheels
                .iter_mut()
                .map(|r| (r.t_s, r.speed_rad_s.as_mut_slice())),
            &["speed_x", "speed_y", "speed_z"],
            50,
            1.0,
            &mut state,
        ));
        let id = testbed_ident::identify(&data, &nominal(), &options())
            .unwrap_or_else(|e| panic!("{label}: {e}"));
        println!("{label}: {}", id.report.summary[0]);
        let mut found: Vec<(f64, &str)> = id
            .report
            .data
            .spikes
            .iter()
            .map(|s| (s.t_s, s.column))
            .collect();
        found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(b.1)));
        spoilt.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(b.1)));
        assert_eq!(found, spoilt, "{label}");
        assert!(id.report.summary[0].starts_with("Left out: "), "{label}");
        match label {
            "clean" => assert_eq!(id.report.verdict, "none", "{label}"),
            "centre-of-mass offset" => {
                check_single(label, &truth, Cause::ComOffset, &id, 10.0, |_, t| {
                    (0.1 * t.abs()).max(0.2e-6)
                })
            }
            _ => check_single(label, &truth, Cause::WheelTorqueScale, &id, 20.0, |_, _| {
                0.003
            }),
        }
    }
}

#[test]
fn clean_data_gives_none_on_at_least_19_of_20_seeds() {
    let clean = nominal();
    let mut named = Vec::new();
    let mut coloured = Vec::new();
    for seed in 100..120 {
        let id = identify_blind(&clean, seed, 600.0);
        println!(
            "clean seed {seed}: {} (gain {:.4})",
            id.report.verdict, id.report.gain
        );
        // The whiteness test of the torque channel (1e-3 per record): no coloured disturbance.
        for c in id.report.whiteness.channels.iter().filter(|c| c.coloured) {
            coloured.push((seed, c.channel.clone(), c.p));
        }
        if !id.report.causes.is_empty() {
            named.push((seed, id.report.verdict.clone()));
        } else {
            assert_eq!(id.report.verdict, "none");
            assert_eq!(
                id.extended, clean,
                "nothing named: the extended model is the nominal"
            );
            assert!((id.report.gain - 1.0).abs() < 1e-12);
        }
    }
    println!("false positives: {named:?}; coloured disturbances: {coloured:?}");
    assert!(named.len() <= 1, "causes named on clean data: {named:?}");
    assert!(coloured.is_empty(), "coloured on clean data: {coloured:?}");
}

#[test]
fn two_hidden_effects_are_both_found() {
    // A dynamics effect and a sensor effect.
    let truth_a = truth(
        "[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n[effects.magnetic_disturbance]\nhard_iron_gauss = [0.08, -0.05, 0.1]\n",
    );
    // Two effects in the same channel (the wheels), fitted jointly.
    let truth_b = truth(
        "[effects.wheel_torque_scale]\nscale = [0.95, 1.04, 0.97]\n[effects.actuator_delay]\ndelay_s = 0.15\n",
    );
    for (label, truth, seed, expected) in [
        (
            "com + hard iron",
            &truth_a,
            31,
            ["com_offset", "magnetic_disturbance"],
        ),
        (
            "torque scale + delay",
            &truth_b,
            32,
            ["wheel_torque_scale", "actuator_delay"],
        ),
    ] {
        let id = identify_blind(truth, seed, 600.0);
        let mut found = names(&id);
        println!("{label}: {found:?}, gain {:.2}", id.report.gain);
        found.sort();
        let mut want = expected.to_vec();
        want.sort();
        assert_eq!(found, want, "{label}: {:?}", id.report.steps);
        for name in expected {
            let cause = Cause::from_name(name).expect("library cause");
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
        assert!(id.report.gain > 10.0, "{label}: gain {}", id.report.gain);
        assert!(
            !id.report.remaining.residual_remains,
            "{label}: {}",
            id.report.remaining.message
        );
    }
}

#[test]
fn residual_is_reported_when_the_cause_is_not_among_the_candidates() {
    // The centre-of-mass offset hidden, but left out of the candidates (so, for the analysis,
    // an effect outside its library). Formerly a constant torque was named for its
    // level part; now no library cause may stand in for it: a constant torque fails its
    // falsification tests, the effect is reported as unexplained in the torque channel with the
    // tilt terms that carry it, and the remaining residual still correlates most with the
    // missing effect's signal. (This offset drives the platform into the tilt stop, so its
    // tilt terms may come with time: `t·sin tilt_y`.)
    let truth = truth("[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n");
    let data = experiment_data(&truth, 41, 600.0);
    let options = testbed_ident::Options {
        candidates: Cause::ALL
            .into_iter()
            .filter(|c| *c != Cause::ComOffset)
            .collect(),
        ..options()
    };
    let id = testbed_ident::identify(&data, &nominal(), &options).expect("identification runs");
    let r = &id.report;
    for line in &r.summary {
        println!("{line}");
    }
    for c in &r.remaining.correlations {
        println!("  {} ~ {}: {:+.3}", c.residual, c.signal, c.r);
    }
    assert!(r.causes.is_empty(), "{:?}", r.cause_tests);
    assert!(r.remaining.residual_remains, "{}", r.remaining.message);
    assert!(
        r.remaining.message.contains("torque"),
        "{}",
        r.remaining.message
    );
    let tilt = r.unexplained.iter().any(|e| {
        e.equation.starts_with("torque_")
            && e.terms.iter().any(|t| t.name.contains("sin tilt_"))
            && e.held_out_gain > 1.5
    });
    assert!(tilt, "{:?}", r.unexplained);
    // With nothing named, the level part correlates as well with a constant torque as with the
    // offset (r = 1.00 both): the missing effect's signal must be among the top (within 0.01).
    let top = r
        .remaining
        .correlations
        .first()
        .expect("correlations reported");
    assert!(top.r.abs() > 0.5, "{top:?}");
    assert!(
        r.remaining
            .correlations
            .iter()
            .take_while(|c| c.r.abs() >= top.r.abs() - 0.01)
            .any(|c| c.signal.starts_with("com_offset.r_m")),
        "top correlations {:?}",
        r.remaining.correlations
    );
}

#[test]
fn a_model_that_already_has_the_effect_gives_none() {
    let truth = truth("[effects.constant_torque]\ntorque_nm = [1.5e-3, -1.0e-3, 2.0e-3]\n");
    let data = experiment_data(&truth, 42, 600.0);
    let id = testbed_ident::identify(&data, &truth, &options()).expect("identification runs");
    assert_eq!(id.report.verdict, "none", "{:?}", id.report.steps);
    assert_eq!(id.extended, truth);
}
