//! Plant tests against closed forms and conservation laws.

use super::*;
use crate::attitude::{self, from_heading_pitch_roll};
use crate::config::{
    ActuatorDelay, AeroDrag, ComOffset, ConstantTorque, DEG, InertiaError, ModelConfig,
    WheelTorqueScale,
};
use nalgebra::{Vector3, Vector4};

const IXX: f64 = 45.2;
const IYY: f64 = 46.1;
const IZZ: f64 = 62.7;

/// Default configuration with the products of inertia removed, so single-axis motion stays on
/// one axis and has a closed form.
fn diagonal() -> ModelConfig {
    let mut c = ModelConfig::default();
    c.platform.inertia_kgm2 = [[IXX, 0.0, 0.0], [0.0, IYY, 0.0], [0.0, 0.0, IZZ]];
    c
}

fn frictionless(mut c: ModelConfig) -> ModelConfig {
    c.wheels.coulomb_nm = [0.0; 3];
    c.wheels.viscous_nm_per_rad_s = [0.0; 3];
    c
}

fn plant(config: &ModelConfig, initial: PlatformState) -> Plant {
    Plant::new(config, initial).expect("valid test plant")
}

fn step(p: &mut Plant, command: &ActuatorCommand, dt: f64) -> StepReport {
    p.step(command, dt).expect("valid step")
}

fn wheel_z(torque: f64) -> ActuatorCommand {
    ActuatorCommand {
        wheel_torque_nm: Vector3::new(0.0, 0.0, torque),
        ..Default::default()
    }
}

fn j() -> f64 {
    ModelConfig::default().wheels.inertia_kgm2
}

/// Run torque-free for 1000 s and return the largest relative drifts of the level-frame momentum
/// vector, its magnitude and the kinetic energy.
fn torque_free_drift(
    config: &ModelConfig,
    initial: PlatformState,
    command: &ActuatorCommand,
) -> [f64; 3] {
    let mut p = plant(config, initial);
    let h0 = p.angular_momentum_l();
    let e0 = p.kinetic_energy_j();
    let mut drift = [0.0f64; 3];
    for k in 0..10_000 {
        let report = step(&mut p, command, 0.1);
        let tilt = attitude::tilt_angles(&p.state().q);
        assert!(
            report.tilt_stop.is_none() && !report.at_tilt_stop,
            "t = {}: tilt {tilt:?}",
            p.time_s()
        );
        if k % 10 == 9 {
            let h = p.angular_momentum_l();
            drift[0] = drift[0].max((h - h0).norm() / h0.norm());
            drift[1] = drift[1].max((h.norm() - h0.norm()).abs() / h0.norm());
            drift[2] = drift[2].max((p.kinetic_energy_j() - e0).abs() / e0);
        }
    }
    assert!((p.time_s() - 1000.0).abs() < 1e-9);
    drift
}

/// A mostly-Z spin with a wobble, wheels spinning (never through zero), non-diagonal inertia.
fn tumbling() -> PlatformState {
    PlatformState {
        q: from_heading_pitch_roll(0.2, 0.03, -0.02),
        rate_b: Vector3::new(0.02, -0.015, 0.4),
        wheel_speed: Vector3::new(150.0, -80.0, 250.0),
        gimbal: Vector4::zeros(),
    }
}

#[test]
fn torque_free_motion_with_wheels_conserves_momentum_and_energy() {
    let config = frictionless(ModelConfig::default());
    let drift = torque_free_drift(&config, tumbling(), &ActuatorCommand::default());
    assert!(
        drift.iter().all(|d| *d < 1e-9),
        "drift H_L, |H|, E: {drift:?}"
    );
}

#[test]
fn torque_free_motion_with_cmg_momentum_at_fixed_gimbals_conserves_momentum_and_energy() {
    let config = frictionless(ModelConfig::default());
    let initial = PlatformState {
        gimbal: Vector4::new(0.3, -0.2, 0.5, 0.1),
        ..tumbling()
    };
    let h_cmg = CmgPyramid::from_config(&config.cmg).momentum(&initial.gimbal);
    assert!(
        h_cmg.norm() > 0.5,
        "the test needs real CMG momentum: {h_cmg}"
    );
    let drift = torque_free_drift(&config, initial, &ActuatorCommand::default());
    assert!(
        drift.iter().all(|d| *d < 1e-9),
        "drift H_L, |H|, E: {drift:?}"
    );
}

#[test]
fn moving_gimbals_exchange_momentum_but_conserve_the_total() {
    // Horizontal cluster momentum of a few Nms tilts the spin axis by ~h/(Izz − Ixx)ω ≈ 25°
    // plus nutation, so the stop is moved out of the way.
    let mut config = frictionless(ModelConfig::default());
    config.platform.tilt_limit_deg = 89.0;
    let command = ActuatorCommand {
        gimbal_rate_rad_s: Vector4::new(0.02, -0.03, 0.025, 0.01),
        ..Default::default()
    };
    let drift = torque_free_drift(&config, tumbling(), &command);
    assert!(
        drift[0] < 1e-9 && drift[1] < 1e-9,
        "drift H_L, |H|: {drift:?}"
    );
    // The servos do work on the platform: energy is not an integral here, and the check must
    // be able to tell.
    assert!(
        drift[2] > 1e-6,
        "energy should change with moving gimbals: {drift:?}"
    );
}

#[test]
fn gimbal_rate_is_clamped_and_cmg_torque_keeps_total_momentum() {
    let config = ModelConfig::default();
    let mut p = plant(&config, PlatformState::default());
    let command = ActuatorCommand {
        gimbal_rate_rad_s: Vector4::new(10.0, -10.0, 0.5, 0.0),
        ..Default::default()
    };
    let mut report = None;
    for _ in 0..10 {
        report = Some(step(&mut p, &command, 0.1));
    }
    let max = 90.0 * DEG;
    let expected = Vector4::new(max, -max, 0.5, 0.0);
    assert!(
        (p.state().gimbal - expected).norm() < 1e-12,
        "{}",
        p.state().gimbal
    );
    let applied = report
        .map(|r| r.applied.gimbal_rate_rad_s)
        .unwrap_or_else(Vector4::zeros);
    assert!((applied - Vector4::new(max, -max, 0.5, 0.0)).norm() < 1e-15);
    // The cluster now holds momentum; the platform carries the opposite.
    let cluster = CmgPyramid::from_config(&config.cmg).momentum(&p.state().gimbal);
    assert!(cluster.norm() > 0.5, "{cluster}");
    assert!(
        p.angular_momentum_l().norm() < 1e-9 * cluster.norm(),
        "{}",
        p.angular_momentum_l()
    );
    assert!(p.state().rate_b.norm() > 1e-3);
}

#[test]
fn coasting_wheel_spins_down_as_the_closed_form_and_the_platform_takes_its_momentum() {
    // Only the Z wheel spins; the platform is free about Z. Relative speed obeys
    // J_eff n' = −(T + K n), J_eff = J (Izz − J) / Izz, so for n > 0
    // n(t) = (n0 + T/K) e^{−K t / J_eff} − T/K, reaching 0 at t_s = (J_eff/K) ln(1 + K n0 / T).
    let config = diagonal();
    let (t_c, k) = (
        config.wheels.coulomb_nm[2],
        config.wheels.viscous_nm_per_rad_s[2],
    );
    let j = config.wheels.inertia_kgm2;
    let j_eff = j * (IZZ - j) / IZZ;
    let n0 = 600.0;
    let t_stop = j_eff / k * (1.0 + k * n0 / t_c).ln();
    let initial = PlatformState {
        wheel_speed: Vector3::new(0.0, 0.0, n0),
        ..Default::default()
    };
    let mut p = plant(&config, initial);
    let mut stopped_at = None;
    for step_index in 1..=5000 {
        step(&mut p, &ActuatorCommand::default(), 0.1);
        let t = step_index as f64 * 0.1;
        let s = p.state();
        let n = s.wheel_speed.z;
        if t < t_stop {
            let truth = (n0 + t_c / k) * (-k * t / j_eff).exp() - t_c / k;
            assert!(
                (n - truth).abs() < 1e-9 * n0,
                "t = {t}: n = {n}, closed form {truth}"
            );
        } else if stopped_at.is_none() && n == 0.0 {
            stopped_at = Some(t);
        }
        // Momentum about Z stays J n0: the platform picks up what the wheel loses.
        assert!((IZZ * s.rate_b.z - j * (n0 - n)).abs() < 1e-12, "t = {t}");
        // The X and Y wheels never move and the platform does not tilt.
        assert_eq!((s.wheel_speed.x, s.wheel_speed.y), (0.0, 0.0));
        assert!(s.rate_b.x.abs() < 1e-15 && s.rate_b.y.abs() < 1e-15);
    }
    let stopped_at = stopped_at.unwrap_or(f64::NAN);
    assert!(
        (stopped_at - t_stop).abs() <= 0.1 + 1e-9,
        "stopped at {stopped_at}, closed form {t_stop}"
    );
    // Stuck, not chattering: exactly zero to the end, platform spinning at J n0 / Izz.
    assert_eq!(p.state().wheel_speed.z, 0.0);
    assert!((p.state().rate_b.z - j * n0 / IZZ).abs() < 1e-15);
}

#[test]
fn motor_torque_below_breakaway_leaves_a_stopped_wheel_stuck_and_above_it_spins_up() {
    let config = diagonal();
    let (t_c, k) = (
        config.wheels.coulomb_nm[2],
        config.wheels.viscous_nm_per_rad_s[2],
    );
    let mut p = plant(&config, PlatformState::default());
    for _ in 0..100 {
        step(&mut p, &wheel_z(0.9 * t_c), 0.1);
    }
    assert_eq!(p.state().wheel_speed, Vector3::zeros());
    assert_eq!(p.state().rate_b, Vector3::zeros());
    // Above breakaway: J_eff n' = τ − T − K n from rest, n(t) = (τ − T)/K (1 − e^{−K t/J_eff}).
    let tau = 3.0e-3;
    let j_eff = j() * (IZZ - j()) / IZZ;
    for _ in 0..20 {
        step(&mut p, &wheel_z(tau), 0.1);
    }
    let truth = (tau - t_c) / k * (1.0 - (-k * 2.0 / j_eff).exp());
    assert!(
        (p.state().wheel_speed.z - truth).abs() < 1e-9 * truth,
        "{} vs {truth}",
        p.state().wheel_speed.z
    );
}

#[test]
fn wheel_torque_is_clamped_and_scaled() {
    let mut config = frictionless(diagonal());
    config.effects.wheel_torque_scale = Some(WheelTorqueScale {
        scale: [1.0, 1.0, 0.9],
    });
    let mut p = plant(&config, PlatformState::default());
    let command = ActuatorCommand {
        wheel_torque_nm: Vector3::new(-5.0, 0.0, 5.0),
        ..Default::default()
    };
    let mut report = None;
    for _ in 0..10 {
        report = Some(step(&mut p, &command, 0.1));
    }
    let applied = report
        .map(|r| r.applied.wheel_motor_torque_nm)
        .unwrap_or_else(Vector3::zeros);
    assert!(
        (applied - Vector3::new(-0.1, 0.0, 0.09)).norm() < 1e-15,
        "{applied}"
    );
    // Reaction on the platform: (I_ii − J) w_i' = −τ_i.
    let w = p.state().rate_b;
    assert!((w.x - 0.1 / (IXX - j())).abs() < 1e-14, "{w}");
    assert!((w.z + 0.09 / (IZZ - j())).abs() < 1e-14, "{w}");
    assert!(w.y.abs() < 1e-18, "{w}");
}

#[test]
fn wheel_speed_saturates_at_the_limit() {
    let config = diagonal();
    let n_max = config.wheels.max_speed_rad_s();
    let mut p = plant(&config, PlatformState::default());
    let mut fastest = 0.0f64;
    let mut report = None;
    for _ in 0..150 {
        report = Some(step(&mut p, &wheel_z(0.1), 0.1));
        fastest = fastest.max(p.state().wheel_speed.z);
    }
    assert!(fastest <= n_max * (1.0 + 1e-9), "{fastest} > {n_max}");
    assert!(
        p.state().wheel_speed.z >= n_max * (1.0 - 1e-6),
        "{}",
        p.state().wheel_speed.z
    );
    // At the limit the drive only holds the speed: its torque balances friction.
    let holding = wheel_friction_torque(&config, Wheel::Z, n_max);
    let applied = report
        .map(|r| r.applied.wheel_motor_torque_nm.z)
        .unwrap_or(f64::NAN);
    assert!((applied - holding).abs() < 1e-6, "{applied} vs {holding}");
}

#[test]
fn actuator_delay_shifts_the_response_by_the_delay() {
    // Torque on the Z wheel from t = 1 s: w_z(t) = −τ (t − t_on)/(Izz − J) after it acts.
    let tau = 0.05;
    let delay = 0.35;
    let response = |t: f64, t_on: f64| -tau * (t - t_on).max(0.0) / (IZZ - j());
    for (delay_effect, t_on) in [(None, 1.0), (Some(delay), 1.0 + delay)] {
        let mut config = frictionless(diagonal());
        config.effects.actuator_delay = delay_effect.map(|delay_s| ActuatorDelay { delay_s });
        let mut p = plant(&config, PlatformState::default());
        for k in 1..=40 {
            let command = if k > 10 {
                wheel_z(tau)
            } else {
                ActuatorCommand::default()
            };
            step(&mut p, &command, 0.1);
            let t = k as f64 * 0.1;
            let w = p.state().rate_b.z;
            assert!(
                (w - response(t, t_on)).abs() < 1e-12,
                "delay {delay_effect:?}, t = {t}: {w}"
            );
        }
    }
}

#[test]
fn gravity_torque_of_a_pendulous_offset_oscillates_at_the_pendulum_frequency() {
    // Offset r = (0, 0, −c): M_x = m g c sin φ and φ' = −w_x near level, so
    // φ'' = −(m g c / Ixx) φ for small φ (the wheels stay stuck: full Ixx).
    let c = 20e-6;
    let mut config = diagonal();
    config.effects.com_offset = Some(ComOffset {
        r_m: [0.0, 0.0, -c],
    });
    let omega = (config.platform.mass_kg * config.platform.gravity_mps2 * c / IXX).sqrt();
    let period = 2.0 * std::f64::consts::PI / omega;
    let amplitude = 0.5 * DEG;
    let initial = PlatformState {
        q: from_heading_pitch_roll(0.0, 0.0, amplitude),
        ..Default::default()
    };
    let mut p = plant(&config, initial);
    let dt = 0.1;
    let mut crossings = Vec::new();
    let mut previous = attitude::tilt_angles(&p.state().q)[1];
    let mut peak = 0.0f64;
    while crossings.len() < 3 {
        step(&mut p, &ActuatorCommand::default(), dt);
        let phi = attitude::tilt_angles(&p.state().q)[1];
        peak = peak.max(phi.abs());
        if previous * phi < 0.0 {
            crossings.push(p.time_s() - dt * phi / (phi - previous));
        }
        previous = phi;
        assert!(p.time_s() < 3.0 * period, "no oscillation");
    }
    let measured = crossings[2] - crossings[0];
    // Finite amplitude lengthens the period by A²/16 ≈ 5e-6.
    assert!(
        (measured / period - 1.0).abs() < 1e-4,
        "period {measured} s, closed form {period} s"
    );
    assert!(
        (peak / amplitude - 1.0).abs() < 1e-3,
        "amplitude {peak} vs {amplitude}"
    );
    assert_eq!(p.state().wheel_speed, Vector3::zeros());
}

/// Spin about Z at 0.1 rad/s for 100 s under a torque `−c1 w_z`: the rate must follow
/// `w0 exp(−c1 t / Izz)` within 1e-9. The plant at the end.
fn spin_decays_exponentially(config: &ModelConfig, c1: f64) -> Plant {
    let w0 = 0.1;
    let mut p = plant(
        config,
        PlatformState {
            rate_b: Vector3::new(0.0, 0.0, w0),
            ..Default::default()
        },
    );
    for _ in 0..1000 {
        step(&mut p, &ActuatorCommand::default(), 0.1);
    }
    let truth = w0 * (-c1 * 100.0 / IZZ).exp();
    assert!(
        (p.state().rate_b.z / truth - 1.0).abs() < 1e-9,
        "{} vs {truth}",
        p.state().rate_b.z
    );
    p
}

#[test]
fn linear_drag_decays_the_spin_exponentially() {
    let c1 = 0.05;
    let mut config = diagonal();
    config.effects.aero_drag = Some(AeroDrag {
        c1: [0.0, 0.0, c1],
        c2: [0.0; 3],
    });
    let p = spin_decays_exponentially(&config, c1);
    let drag = p.external_torque_b().drag_b.z;
    assert!((drag + c1 * p.state().rate_b.z).abs() < 1e-15);
}

#[test]
fn a_fitted_rate_term_is_linear_drag_and_a_fitted_time_term_ramps_the_rate() {
    use crate::physics::fitted_torque::{FittedTorque, FittedTorqueTerm};
    let term = |function: &str, coefficient: f64| FittedTorqueTerm {
        axis: "z".into(),
        function: function.into(),
        coefficient,
    };
    // M_z = −c1 w_z: the spin decays as exp(−c1 t / Izz), as with aero_drag.
    let c1 = 0.05;
    let mut config = diagonal();
    config.effects.fitted_torque = Some(FittedTorque {
        start_time_s: 0.0,
        terms: vec![term("w_z", -c1)],
    });
    config.validate().expect("valid fitted torque");
    spin_decays_exponentially(&config, c1);
    // M_z = a (t0 + t): w_z(T) = a (t0 T + T²/2) / Izz, less a h T / (2 Izz) because the
    // plant holds a time-dependent torque at its value at the start of each 0.01-s substep.
    let (a, t0) = (2e-6, 100.0);
    config.effects.fitted_torque = Some(FittedTorque {
        start_time_s: t0,
        terms: vec![term("t_s", a)],
    });
    let mut p = plant(&config, PlatformState::default());
    for _ in 0..500 {
        step(&mut p, &ActuatorCommand::default(), 0.1);
    }
    let big_t = 50.0;
    let continuous = a * (t0 * big_t + big_t * big_t / 2.0) / IZZ;
    let h = 0.01;
    let truth = continuous - a * h * big_t / (2.0 * IZZ);
    let w = p.state().rate_b.z;
    assert!(
        (w / truth - 1.0).abs() < 1e-9,
        "{w} vs {truth} (continuous: {continuous})"
    );
    // The torque reported is the one of the last substep (resolved at its start, T − h).
    assert!(
        (p.external_torque_b().fitted_b.z - a * (t0 + big_t - h)).abs() < 1e-12,
        "{}",
        p.external_torque_b().fitted_b.z
    );
}

#[test]
fn a_fitted_torque_with_an_unknown_function_or_axis_is_refused() {
    use crate::physics::fitted_torque::{FittedTorque, FittedTorqueTerm};
    let mut config = ModelConfig::default();
    config.effects.fitted_torque = Some(FittedTorque {
        start_time_s: 0.0,
        terms: vec![FittedTorqueTerm {
            axis: "z".into(),
            function: "dw_z/dt".into(),
            coefficient: 1.0,
        }],
    });
    let e = config.validate().unwrap_err().to_string();
    assert!(
        e.contains("effects.fitted_torque.terms[0].function") && e.contains("dw_z/dt"),
        "{e}"
    );
    config.effects.fitted_torque = Some(FittedTorque {
        start_time_s: 0.0,
        terms: vec![FittedTorqueTerm {
            axis: "w".into(),
            function: "1".into(),
            coefficient: 1.0,
        }],
    });
    let e = config.validate().unwrap_err().to_string();
    assert!(e.contains("effects.fitted_torque.terms[0].axis"), "{e}");
}

/// The Z wheel spinning at `n0` on a frictionless, diagonal platform with `terms` as its fitted
/// wheel torque, stepped `steps` × 0.1 s without commands.
fn fitted_wheel_run(terms: Vec<(&str, f64)>, start_time_s: f64, n0: f64, steps: usize) -> Plant {
    use crate::physics::fitted_wheel_torque::{FittedWheelTorque, FittedWheelTorqueTerm};
    let mut config = frictionless(diagonal());
    config.effects.fitted_wheel_torque = Some(FittedWheelTorque {
        start_time_s,
        terms: terms
            .into_iter()
            .map(|(function, coefficient)| FittedWheelTorqueTerm {
                wheel: "z".into(),
                function: function.into(),
                coefficient,
            })
            .collect(),
    });
    config.validate().expect("valid fitted wheel torque");
    let initial = PlatformState {
        wheel_speed: Vector3::new(0.0, 0.0, n0),
        ..Default::default()
    };
    let mut p = plant(&config, initial);
    for _ in 0..steps {
        step(&mut p, &ActuatorCommand::default(), 0.1);
    }
    p
}

#[test]
fn a_fitted_wheel_torque_spins_the_wheel_up_and_down_as_the_closed_forms() {
    let j = j();
    let j_eff = j * (IZZ - j) / IZZ;
    let (n0, big_t) = (50.0, 20.0);
    // A constant torque c between wheel and platform: J_eff n' = c, n = n0 + c t / J_eff; the
    // platform takes the reaction, (Izz − J) w' = −c; total momentum Izz w + J n stays J n0.
    let c = 2.0e-3;
    let p = fitted_wheel_run(vec![("1", c)], 0.0, n0, 200);
    let s = p.state();
    let n_truth = n0 + c * big_t / j_eff;
    assert!(
        (s.wheel_speed.z - n_truth).abs() < 1e-12 * n_truth,
        "{} vs {n_truth}",
        s.wheel_speed.z
    );
    let w_truth = -c * big_t / (IZZ - j);
    assert!(
        (s.rate_b.z - w_truth).abs() < 1e-12 * w_truth.abs(),
        "{} vs {w_truth}",
        s.rate_b.z
    );
    assert!((IZZ * s.rate_b.z + j * s.wheel_speed.z - j * n0).abs() < 1e-12);
    // The frictionless X and Y wheels (breakaway 0) take only rounding (≈ 3e-20 rad/s).
    assert!(s.wheel_speed.x.abs() < 1e-15 && s.wheel_speed.y.abs() < 1e-15);
    // Quadratic drag −k n|n| (identification's `n·|n|` with coefficient −k): for n > 0
    // J_eff n' = −k n², n = n0 / (1 + k n0 t / J_eff) (RK4 at 0.01 s: error far below 1e-9).
    let k = 1.0e-5;
    let p = fitted_wheel_run(vec![("n·|n|", -k)], 0.0, n0, 200);
    let n_truth = n0 / (1.0 + k * n0 * big_t / j_eff);
    let n = p.state().wheel_speed.z;
    assert!(n < 0.9 * n0, "the drag must act: {n}");
    assert!((n - n_truth).abs() < 1e-9 * n0, "{n} vs {n_truth}");
    // A Coulomb level −d sign n with a torque in time a (t0 + t): n = n0 + (a (t0 T + T²/2) −
    // d T) / J_eff, less a h T / (2 J_eff) because the plant holds the time at the start of
    // each 0.01-s substep.
    let (a, t0, d) = (2.0e-5, 100.0, 1.0e-3);
    let p = fitted_wheel_run(vec![("t_s", a), ("sign n", -d)], t0, n0, 200);
    let h = 0.01;
    let n_truth =
        n0 + (a * (t0 * big_t + big_t * big_t / 2.0) - d * big_t - a * h * big_t / 2.0) / j_eff;
    let n = p.state().wheel_speed.z;
    assert!((n - n_truth).abs() < 1e-12 * n0, "{n} vs {n_truth}");
}

#[test]
fn a_fitted_wheel_torque_with_an_unknown_function_or_wheel_is_refused() {
    use crate::physics::fitted_wheel_torque::{FittedWheelTorque, FittedWheelTorqueTerm};
    let with = |wheel: &str, function: &str, coefficient: f64| {
        let mut config = ModelConfig::default();
        config.effects.fitted_wheel_torque = Some(FittedWheelTorque {
            start_time_s: 0.0,
            terms: vec![FittedWheelTorqueTerm {
                wheel: wheel.into(),
                function: function.into(),
                coefficient,
            }],
        });
        config
    };
    let e = with("y", "sin 2ψ", 1.0).validate().unwrap_err().to_string();
    assert!(
        e.contains("effects.fitted_wheel_torque.terms[0].function") && e.contains("sin 2ψ"),
        "{e}"
    );
    let e = with("4", "1", 1.0).validate().unwrap_err().to_string();
    assert!(
        e.contains("effects.fitted_wheel_torque.terms[0].wheel") && e.contains('4'),
        "{e}"
    );
    let e = with("x", "n", f64::NAN).validate().unwrap_err().to_string();
    assert!(
        e.contains("effects.fitted_wheel_torque.terms[0].coefficient"),
        "{e}"
    );
    with("x", "n·|n|", -1e-8).validate().expect("valid");
    // From TOML, as identification writes it.
    let text = "[effects.fitted_wheel_torque]\n[[effects.fitted_wheel_torque.terms]]\nwheel = \"y\"\nfunction = \"n·|n|\"\ncoefficient = -1.0e-8\n";
    let config = ModelConfig::from_toml_str(text, "test").expect("loads");
    let fitted = config.effects.fitted_wheel_torque.expect("present");
    assert_eq!(fitted.terms[0].coefficient, -1.0e-8);
    assert!(ModelConfig::from_toml_str(&text.replace("n·|n|", "n^3"), "test").is_err());
}

#[test]
fn tilt_stop_fires_once_and_holds_the_platform_on_the_stop() {
    // A constant torque about X from level rotates the platform about X only:
    // angle = ½ (M/Ixx) t², and φ (elevation of body Y) = −angle, reaching −30° at
    // t* = sqrt(2 · 30° · Ixx / M).
    let m = 0.5;
    let mut config = diagonal();
    config.effects.constant_torque = Some(ConstantTorque {
        torque_nm: [m, 0.0, 0.0],
    });
    let limit = config.platform.tilt_limit_rad();
    let t_hit = (2.0 * limit * IXX / m).sqrt();
    let mut p = plant(&config, PlatformState::default());
    let mut events = Vec::new();
    for k in 0..300 {
        let report = step(&mut p, &ActuatorCommand::default(), 0.1);
        events.extend(report.tilt_stop);
        let [theta, phi] = attitude::tilt_angles(&p.state().q);
        assert!(
            phi >= -limit - 1e-12 && theta.abs() < 1e-12,
            "step {k}: φ = {phi}, θ = {theta}"
        );
        if p.time_s() > t_hit + 0.1 {
            assert!(report.at_tilt_stop);
        }
    }
    assert_eq!(events.len(), 1, "{events:?}");
    let event = events[0];
    assert_eq!(event.axis, TiltAxis::Y);
    assert!(
        event.time_s >= t_hit && event.time_s <= t_hit + 0.01 + 1e-9,
        "{} vs {t_hit}",
        event.time_s
    );
    let rate_at_hit = m / IXX * t_hit;
    assert!(
        event.angle_rad < -limit && event.angle_rad > -limit - rate_at_hit * 0.011,
        "{}",
        event.angle_rad
    );
    // Resting on the stop: at most one substep of rate builds up before contact removes it.
    assert!(
        p.state().rate_b.x.abs() <= m / IXX * 0.01 * 1.01,
        "{}",
        p.state().rate_b
    );
}

#[test]
fn true_inertia_carries_the_inertia_error() {
    let mut config = diagonal();
    config.effects.inertia_error = Some(InertiaError {
        fraction: [0.0, 0.0, 0.1],
        products_kgm2: None,
    });
    let p = plant(
        &config,
        PlatformState {
            rate_b: Vector3::new(0.0, 0.0, 0.1),
            ..Default::default()
        },
    );
    assert!((p.angular_momentum_b().z - IZZ * 1.1 * 0.1).abs() < 1e-12);
    assert!((p.kinetic_energy_j() - 0.5 * IZZ * 1.1 * 0.01).abs() < 1e-12);
}

#[test]
fn bad_inputs_are_refused() {
    let config = ModelConfig::default();
    let beyond = PlatformState {
        q: from_heading_pitch_roll(0.0, 31.0 * DEG, 0.0),
        ..Default::default()
    };
    assert!(matches!(
        Plant::new(&config, beyond),
        Err(PhysicsError::InitialTiltBeyondStop {
            axis: TiltAxis::X,
            ..
        })
    ));
    let nan = PlatformState {
        rate_b: Vector3::new(f64::NAN, 0.0, 0.0),
        ..Default::default()
    };
    assert!(matches!(
        Plant::new(&config, nan),
        Err(PhysicsError::NonFinite { .. })
    ));
    let mut p = plant(&config, PlatformState::default());
    assert!(matches!(
        p.step(&ActuatorCommand::default(), 0.0),
        Err(PhysicsError::InvalidStep { .. })
    ));
    assert!(matches!(
        p.step(&wheel_z(f64::INFINITY), 0.1),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert_eq!(p.time_s(), 0.0);
    let mut bad = ModelConfig::default();
    bad.wheels.inertia_kgm2 = 50.0;
    assert!(matches!(
        Plant::new(&bad, PlatformState::default()),
        Err(PhysicsError::InertiaNotPositiveDefinite { .. })
    ));
}

#[test]
fn a_step_of_a_whole_number_of_substeps_takes_exactly_that_many() {
    // 0.1 s steps of at most 0.01 s: 10 substeps each, however the clock's sum rounds.
    let config = diagonal();
    let mut p = plant(&config, PlatformState::default());
    for k in 0..2000 {
        let report = step(&mut p, &ActuatorCommand::default(), 0.1);
        assert_eq!(report.substeps, 10, "step {k} at t = {} s", p.time_s());
    }
    // A step that is not a whole number of substeps rounds up.
    assert_eq!(
        step(&mut p, &ActuatorCommand::default(), 0.105).substeps,
        11
    );
}
