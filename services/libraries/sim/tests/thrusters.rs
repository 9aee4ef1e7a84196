//! The thruster shows in the in-process closed loop (MEKF in the loop, seed 1).
//! `cargo test --release -p testbed-sim --test thrusters -- --nocapture` prints the summaries.

use testbed_sim::closed_loop;
use testbed_sim::thruster_shows::{
    momentum_dumping_scenario, rate_damping_scenario, run_and_summarise,
};

/// Two hours against a constant disturbance: without thrusters a wheel saturates; with
/// momentum dumping every wheel stays below 80 % of its speed limit and the attitude within
/// 0.05° per axis outside the dump windows (from 100 s on: the estimator's start-up).
#[test]
fn momentum_dumping_keeps_the_wheels_below_80_percent_for_two_hours() {
    let without = momentum_dumping_scenario(false, 7200.0, 1);
    let (_, _, s) = run_and_summarise(&without, 100.0, 0.01).unwrap();
    println!("without thrusters:\n{s}");
    assert!(
        s.wheel_saturated_at_s.is_some(),
        "the disturbance must saturate a wheel without thrusters: {s:?}"
    );
    let with = momentum_dumping_scenario(true, 7200.0, 1);
    let (_, thrusters, s) = run_and_summarise(&with, 100.0, 0.01).unwrap();
    println!("with momentum dumping:\n{s}");
    assert!(s.wheel_saturated_at_s.is_none(), "{s:?}");
    assert!(s.peak_wheel_fraction.iter().all(|f| *f < 0.8), "{s:?}");
    assert!(
        s.max_error_outside_dumps_deg.iter().all(|e| *e < 0.05),
        "{s:?}"
    );
    assert!(s.dumps >= 1 && s.propellant_used_kg > 0.0, "{s:?}");
    // The centre of mass moved by the propellant used times the tank's lever over the
    // remaining mass (closed form, model crate) and is reported.
    assert!(s.com_shift_m.norm() > 0.0);
    assert_eq!(s.com_shift_m, thrusters.com_shift_m);
}

/// Thruster-only rate damping from |w| = 2 °/s to below 0.01 °/s.
#[test]
fn thrusters_alone_damp_two_degrees_per_second_below_a_hundredth() {
    let r = 2.0 / 3f64.sqrt();
    let scenario = rate_damping_scenario([r, -r, r], 300.0, 1);
    let (trace, _, s) = run_and_summarise(&scenario, 0.0, 0.01).unwrap();
    println!("rate damping:\n{s}");
    let first = trace
        .ticks
        .first()
        .unwrap()
        .truth
        .rate_b
        .norm()
        .to_degrees();
    assert!((first - 2.0).abs() < 1e-9, "{first}");
    let settled = s
        .rate_settled_at_s
        .expect("the rate settles below 0.01 °/s");
    assert!(settled < 250.0, "{s:?}");
    assert!(s.final_rate_deg_s < 0.01);
    assert!(s.propellant_used_kg > 0.0);
    // The wheels were never used.
    assert!(
        trace
            .ticks
            .iter()
            .all(|t| t.command.wheel_torque_nm == nalgebra::Vector3::zeros())
    );
}

/// Same seed, same run, bit for bit, with the thrusters on (their noise is seeded too).
#[test]
fn runs_with_thrusters_are_deterministic() {
    let mut scenario = momentum_dumping_scenario(true, 300.0, 4);
    // Wheels spun up past the dump threshold: the run dumps from the start.
    scenario.manoeuvre.initial_wheel_speed_rpm = [3500.0, -3200.0, 3400.0];
    let a = closed_loop::run_with_thrusters(&scenario).unwrap();
    let b = closed_loop::run_with_thrusters(&scenario).unwrap();
    assert_eq!(a, b);
    assert!(a.2.pulses.iter().sum::<u64>() > 0, "{:?}", a.2.pulses);
}
