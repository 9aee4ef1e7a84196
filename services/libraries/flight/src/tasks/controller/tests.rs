//! The controller task's tests.

use super::*;
use ipc_types::{GroundCommand, GroundCommandKind};
use testbed_model::ModelConfig;
use testbed_model::attitude::Attitude;

const TICK_NS: u64 = 100_000_000;

fn controller() -> ControllerTask {
    let model = ModelConfig::default();
    let config = ControllerConfig::default();
    ControllerTask::new(
        &config,
        &model,
        Attitude::identity(),
        Schedule::from_model(&model).unwrap(),
    )
    .unwrap()
}

fn header(k: u64) -> SampleHeader {
    SampleHeader::new(k * TICK_NS, k, SampleHeader::VALID)
}

fn estimate(k: u64) -> AttitudeEstimate {
    AttitudeEstimate {
        header: header(k),
        quaternion: [0.0, 0.0, 0.0, 1.0],
        ..AttitudeEstimate::default()
    }
}

fn telemetry(controller: &mut ControllerTask, k: u64, wheel_speed: f64) {
    controller.on_wheel_telemetry(&WheelTelemetry {
        header: header(k),
        speed: [wheel_speed; 3],
        torque: [0.0; 3],
    });
    controller.on_cmg_telemetry(&CmgTelemetry {
        header: header(k),
        ..CmgTelemetry::default()
    });
}

#[test]
fn only_telemetry_that_can_complete_or_judge_a_tick_needs_to_wake_the_controller() {
    let mut controller = controller();
    assert_eq!(
        controller.telemetry_wake_from_ns(),
        0,
        "before the first cycle: all"
    );
    for k in 0..=5 {
        controller.on_estimate(&estimate(k));
        telemetry(&mut controller, k, 0.0);
        assert_eq!(controller.ready().len(), 1);
        // Tick k+1 waits for its estimate: its telemetry cannot complete it; tick k+2's
        // telemetry would judge a missing estimate, and wakes.
        assert_eq!(controller.telemetry_wake_from_ns(), (k + 2) * TICK_NS);
    }
    // The estimate of tick 6 is in before its telemetry: the telemetry is awaited.
    controller.on_estimate(&estimate(6));
    assert!(controller.ready().is_empty());
    assert_eq!(controller.telemetry_wake_from_ns(), 0);
    telemetry(&mut controller, 6, 0.0);
    assert_eq!(controller.ready().len(), 1);
    assert_eq!(controller.telemetry_wake_from_ns(), 8 * TICK_NS);
    // The estimator stops: tick 8's telemetry finds the estimate lost, and from then on
    // every sample wakes (safe cycles run on the telemetry).
    telemetry(&mut controller, 7, 0.0);
    assert!(controller.ready().is_empty());
    telemetry(&mut controller, 8, 0.0);
    assert_eq!(controller.ready().len(), 1, "a safe cycle at tick 8");
    assert_eq!(controller.telemetry_wake_from_ns(), 0);
}

#[test]
fn a_lost_estimate_gives_rate_damping_on_the_gyro_at_the_second_silent_tick() {
    let mut controller = controller();
    for k in 0..=5 {
        controller.on_estimate(&estimate(k));
        telemetry(&mut controller, k, 0.0);
        let cycles = controller.ready();
        assert_eq!(cycles.len(), 1);
        assert_eq!(cycles[0].status.mode(), Some(ControllerMode::WheelPointing));
    }
    // The estimator stops after tick 5; the gyro and the actuators go on.
    let rate = [0.01, -0.02, 0.005];
    let mut safe_at = None;
    for k in 6..=9 {
        controller.on_gyro(&GyroSample::new(header(k), rate));
        telemetry(&mut controller, k, 0.0);
        for cycle in controller.ready() {
            let t = cycle.status.header.time_ns / TICK_NS;
            safe_at.get_or_insert(t);
            assert_eq!(cycle.status.mode(), Some(ControllerMode::Safe));
            assert_eq!(cycle.cmg.gimbal_rate, [0.0; 4], "gimbals held");
            // Platform torque −K·ω (K = 5 N m s): wheel motor torque +K·ω.
            assert_eq!(cycle.wheels.torque, rate.map(|w| 5.0 * w));
        }
    }
    // Tick 6 waits for its estimate; at tick 7 the estimate is two periods old: lost.
    assert_eq!(safe_at, Some(7));
    let transitions = controller.take_transitions();
    assert_eq!(transitions.len(), 1);
    assert!(matches!(
        transitions[0],
        (t, SafeTransition::Entered(r)) if t == 7 * TICK_NS && r.contains(SafeReason::EstimateLost)
    ));

    // Estimates again: safe mode is left after recovery_s (5 s) of healthy inputs.
    let mut left_at = None;
    for k in 10..=80 {
        controller.on_estimate(&estimate(k));
        telemetry(&mut controller, k, 0.0);
        controller.ready();
        if let Some((t, SafeTransition::Left)) = controller.take_transitions().first() {
            left_at = Some(t / TICK_NS);
        }
    }
    assert_eq!(left_at, Some(60), "healthy from tick 10, left 5 s later");
}

/// A CAN link down silences every input: the deadlines alone enter safe mode, at the
/// second silent deadline, with zero wheel torque (speeds unknown) and gimbals held; data
/// again leave it after recovery_s.
#[test]
fn total_silence_enters_safe_mode_at_the_second_missed_deadline_with_zero_torque() {
    let mut controller = controller();
    assert!(
        controller.on_silence(5, u64::MAX).is_none(),
        "no cycle yet: nothing to hold"
    );
    for k in 0..=5 {
        controller.on_estimate(&estimate(k));
        telemetry(&mut controller, k, 10.0);
        controller.on_gyro(&GyroSample::new(header(k), [0.01, 0.0, 0.0]));
        assert_eq!(controller.ready().len(), 1);
    }
    assert!(
        controller.on_silence(1, u64::MAX).is_none(),
        "one missed deadline is not yet a loss"
    );
    let cycle = controller
        .on_silence(2, u64::MAX)
        .expect("a safe cycle at the second missed deadline");
    assert_eq!(cycle.status.header.time_ns, 6 * TICK_NS);
    assert_eq!(cycle.status.mode(), Some(ControllerMode::Safe));
    assert_eq!(
        cycle.wheels.torque, [0.0; 3],
        "wheel speeds unknown: no torque"
    );
    assert_eq!(cycle.cmg.gimbal_rate, [0.0; 4], "gimbals held");
    assert!(
        controller.on_silence(3, 7 * TICK_NS).is_none(),
        "the run's end silences everything: no fault"
    );
    let next = controller
        .on_silence(3, u64::MAX)
        .expect("one safe cycle per further deadline");
    assert_eq!(next.status.header.time_ns, 7 * TICK_NS);
    let transitions = controller.take_transitions();
    assert!(matches!(
        transitions.as_slice(),
        [(t, SafeTransition::Entered(r))] if *t == 6 * TICK_NS
            && r.contains(SafeReason::EstimateLost)
            && r.contains(SafeReason::WheelTelemetryLost)
    ));
    let mut left_at = None;
    for k in 9..=80 {
        controller.on_estimate(&estimate(k));
        telemetry(&mut controller, k, 10.0);
        controller.ready();
        if let Some((t, SafeTransition::Left)) = controller.take_transitions().first() {
            left_at = Some(t / TICK_NS);
        }
    }
    assert_eq!(left_at, Some(59), "healthy from tick 9, left 5 s later");
}

#[test]
fn with_thrusters_safe_mode_damps_on_the_thrusters_alone_and_dumping_is_reported() {
    use crate::thruster_control::ThrusterControlConfig;
    use testbed_model::thruster_config::ThrusterConfig;
    let model = ModelConfig {
        thrusters: Some(ThrusterConfig::default()),
        ..ModelConfig::default()
    };
    let mut config = ControllerConfig::default();
    config.thrusters = Some(ThrusterControlConfig::default());
    let mut controller = ControllerTask::new(
        &config,
        &model,
        Attitude::identity(),
        Schedule::from_model(&model).unwrap(),
    )
    .unwrap();
    // Wheels at 3500 rpm (0.58 Nms, past the 0.5 Nms dump threshold): a dump.
    let speed = 3500.0 * std::f64::consts::PI / 30.0;
    for k in 0..=5 {
        controller.on_estimate(&estimate(k));
        telemetry(&mut controller, k, speed);
        let cycles = controller.ready();
        assert_eq!(cycles.len(), 1);
        assert_eq!(cycles[0].status.mode(), Some(ControllerMode::MomentumDump));
        let thrust = cycles[0].thrusters.expect("a thruster command every cycle");
        // −k h on every axis: the − thrusters (1, 3, 5) fire, the + ones do not.
        if k == 0 {
            assert!(thrust.on_time[1] > 0.0 && thrust.on_time[3] > 0.0 && thrust.on_time[5] > 0.0);
        }
        assert_eq!(
            (thrust.on_time[0], thrust.on_time[2], thrust.on_time[4]),
            (0.0, 0.0, 0.0)
        );
    }
    // The estimator stops: safe mode damps the gyro's rate on the thrusters, wheels off.
    let rate = [0.01, -0.02, 0.0];
    for k in 6..=9 {
        controller.on_gyro(&GyroSample::new(header(k), rate));
        telemetry(&mut controller, k, speed);
        for cycle in controller.ready() {
            assert_eq!(
                cycle.status.mode(),
                Some(ControllerMode::ThrusterRateDamping)
            );
            assert_eq!(cycle.wheels.torque, [0.0; 3]);
            let thrust = cycle.thrusters.expect("thrusters in safe mode");
            // −K w: the − X thruster (1) and the + Y thruster (2), nothing about Z.
            assert!(
                thrust.on_time[1] > 0.0 && thrust.on_time[2] > 0.0,
                "{thrust:?}"
            );
            assert_eq!(
                thrust.on_time[0] + thrust.on_time[3] + thrust.on_time[4] + thrust.on_time[5],
                0.0
            );
        }
    }
}

#[test]
fn a_wheel_near_its_limit_enters_safe_mode_and_is_not_driven_further() {
    let mut controller = controller();
    let limit = 6000.0 * std::f64::consts::PI / 30.0;
    controller.on_gyro(&GyroSample::new(header(0), [0.01; 3]));
    controller.on_estimate(&estimate(0));
    telemetry(&mut controller, 0, 0.8 * limit);
    let cycle = controller.ready()[0];
    assert_eq!(cycle.status.mode(), Some(ControllerMode::Safe));
    // +K·ω would speed up the +0.8-limit wheels: refused.
    assert_eq!(cycle.wheels.torque, [0.0; 3]);
}

fn ground(kind: GroundCommandKind, mode: ControllerMode) -> GroundCommand {
    GroundCommand {
        kind: kind as u32,
        mode: mode as u32,
        ..GroundCommand::default()
    }
}

fn step(controller: &mut ControllerTask, k: u64, rate: [f64; 3]) -> ControlCycle {
    controller.on_estimate(&AttitudeEstimate {
        rate,
        ..estimate(k)
    });
    telemetry(controller, k, 0.0);
    let cycles = controller.ready();
    assert_eq!(cycles.len(), 1);
    cycles[0]
}

#[test]
fn ground_modes_replace_the_law_and_pointing_restores_it() {
    let mut controller = controller();
    let rate = [0.01, -0.02, 0.005];
    assert_eq!(
        step(&mut controller, 0, rate).status.mode(),
        Some(ControllerMode::WheelPointing)
    );
    controller
        .ground_command(&ground(GroundCommandKind::Mode, ControllerMode::Idle))
        .unwrap();
    let idle = step(&mut controller, 1, rate);
    assert_eq!(idle.status.mode(), Some(ControllerMode::Idle));
    assert_eq!(idle.wheels.torque, [0.0; 3]);

    controller
        .ground_command(&ground(
            GroundCommandKind::Mode,
            ControllerMode::RateDamping,
        ))
        .unwrap();
    let damping = step(&mut controller, 2, rate);
    assert_eq!(damping.status.mode(), Some(ControllerMode::RateDamping));
    // Platform torque −K·ω (K = 5 N m s from the safe-mode gain): wheel torque +K·ω.
    assert_eq!(damping.wheels.torque, rate.map(|w| 5.0 * w));

    controller
        .ground_command(&ground(GroundCommandKind::Mode, ControllerMode::Safe))
        .unwrap();
    assert_eq!(
        step(&mut controller, 3, rate).status.mode(),
        Some(ControllerMode::Safe)
    );
    controller
        .ground_command(&ground(
            GroundCommandKind::Mode,
            ControllerMode::WheelPointing,
        ))
        .unwrap();
    assert_eq!(
        step(&mut controller, 4, rate).status.mode(),
        Some(ControllerMode::WheelPointing)
    );
}

#[test]
fn ground_commands_the_controller_cannot_follow_are_refused_with_the_reason() {
    let mut controller = controller();
    let cmg = controller.ground_command(&ground(GroundCommandKind::Mode, ControllerMode::CmgSlew));
    assert!(
        cmg.unwrap_err()
            .contains("controller.law that drives the CMGs")
    );
    assert!(
        controller
            .ground_command(&ground(GroundCommandKind::Mode, ControllerMode::Fault))
            .is_err()
    );
    let start = controller.ground_command(&ground(
        GroundCommandKind::ExperimentStart,
        ControllerMode::Idle,
    ));
    assert!(start.unwrap_err().contains("experiment"));
    let bad_target = GroundCommand {
        kind: GroundCommandKind::Target as u32,
        target_pitch_rad: f64::NAN,
        ..GroundCommand::default()
    };
    assert!(controller.ground_command(&bad_target).is_err());
    assert_eq!(controller.ground_mode(), None);
}

#[test]
fn a_ground_target_moves_the_attitude_error() {
    let mut controller = controller();
    assert_eq!(
        step(&mut controller, 0, [0.0; 3]).status.attitude_error,
        [0.0; 3]
    );
    let target = GroundCommand {
        kind: GroundCommandKind::Target as u32,
        target_heading_rad: 0.1,
        ..GroundCommand::default()
    };
    controller.ground_command(&target).unwrap();
    let error = step(&mut controller, 1, [0.0; 3]).status.attitude_error;
    // Level attitude, target heading 0.1 rad: the error is about z only.
    assert!((error[2].abs() - 0.1).abs() < 1e-3, "{error:?}");
    assert!(error[0].abs() < 1e-12 && error[1].abs() < 1e-12);
}
