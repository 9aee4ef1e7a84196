//! Layout pins, naming and helper tests.

use crate::*;
use core::mem::{align_of, offset_of, size_of};
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;
use std::collections::HashSet;

fn field_size<T, F>(_: fn(&T) -> &F) -> usize {
    size_of::<F>()
}

/// Pins size, alignment and every field offset of `$ty`, and checks that the fields' sizes add
/// up to the type's size (no implicit padding). List every field, in declaration order.
macro_rules! pin_layout {
    ($ty:ty, size $size:expr, align $align:expr, { $($field:ident: $off:expr),+ $(,)? }) => {{
        let name = stringify!($ty);
        assert_eq!(size_of::<$ty>(), $size, "size_of {name}");
        assert_eq!(align_of::<$ty>(), $align, "align_of {name}");
        $(assert_eq!(offset_of!($ty, $field), $off, "offset_of {name}::{}", stringify!($field));)+
        let fields = 0 $(+ field_size(|s: &$ty| &s.$field))+;
        assert_eq!(fields, size_of::<$ty>(), "implicit padding in {name}");
    }};
}

#[test]
fn layouts_are_pinned() {
    pin_layout!(SampleHeader, size 24, align 8, {
        time_ns: 0, sequence: 8, flags: 16, source_id: 20,
    });
    pin_layout!(GyroSample, size 48, align 8, { header: 0, rate: 24 });
    pin_layout!(InclinometerSample, size 40, align 8, { header: 0, tilt: 24 });
    pin_layout!(MagnetometerSample, size 48, align 8, { header: 0, field: 24 });
    pin_layout!(WheelTelemetry, size 72, align 8, { header: 0, speed: 24, torque: 48 });
    pin_layout!(WheelCommand, size 48, align 8, { header: 0, torque: 24 });
    pin_layout!(CmgTelemetry, size 88, align 8, {
        header: 0, gimbal_angle: 24, gimbal_rate: 56,
    });
    pin_layout!(CmgCommand, size 56, align 8, { header: 0, gimbal_rate: 24 });
    pin_layout!(AttitudeEstimate, size 480, align 8, {
        header: 0, quaternion: 24, rate: 56, gyro_bias: 80, covariance: 104, innovation: 392,
        innovation_time_ns: 440, innovation_mask: 448, _pad0: 452, updates_applied: 456,
        updates_skipped: 464, updates_rejected: 472,
    });
    pin_layout!(ControllerStatus, size 104, align 8, {
        header: 0, mode: 24, _pad0: 28, attitude_error: 32, torque_command: 56,
        deadline_misses: 80, loop_period_ns: 88, compute_time_ns: 96,
    });
    pin_layout!(SimTruth, size 200, align 8, {
        header: 0, quaternion: 24, rate: 56, wheel_speed: 80, gimbal_angle: 104, gyro_bias: 136,
        angular_momentum: 160, kinetic_energy: 184, tilt_stop: 192, _pad0: 196,
    });
    pin_layout!(SimClockTick, size 48, align 8, {
        header: 0, tick: 24, sim_time_ns: 32, step_ns: 40,
    });
    pin_layout!(Heartbeat, size 104, align 8, {
        header: 0, name: 24, pid: 56, state: 60, samples_in: 64, samples_out: 72, errors: 80,
        frames_ok: 88, frames_bad: 96,
    });
    pin_layout!(CanBusFrame, size 48, align 8, {
        header: 0, can_id: 24, len: 28, _pad0: 29, _pad1: 30, data: 32, check: 40, _pad2: 44,
    });
    pin_layout!(AppliedWheelCommand, size 48, align 8, { header: 0, torque: 24 });
    pin_layout!(AppliedCmgCommand, size 56, align 8, { header: 0, gimbal_rate: 24 });
    pin_layout!(CanLinkStatus, size 208, align 8, {
        header: 0, frames_ok: 24, frames_bad: 32, crc_errors: 40, wrong_dlc: 48, unknown_id: 56,
        duplicates: 64, lost_frames: 72, incomplete_samples: 80, late_frames: 88,
        out_of_range: 96, stale_samples: 104, frames_sent: 112, commands_clamped: 120,
        commands_refused: 128, transport_errors: 136, injected_tx_drop: 144,
        injected_tx_corrupt: 152, injected_tx_delay: 160, injected_tx_duplicate: 168,
        injected_rx_drop: 176, injected_rx_corrupt: 184, injected_rx_delay: 192,
        injected_rx_duplicate: 200,
    });
    pin_layout!(HealthEvent, size 104, align 8, {
        header: 0, reporter: 24, subject: 56, kind: 88, detail: 92, value: 96,
    });
    assert_eq!(size_of::<ControllerMode>(), 4);
    assert_eq!(size_of::<ProcessState>(), 4);
}

#[cfg(feature = "zero-copy")]
#[test]
fn type_names_are_versioned_unique_and_the_tables_schema_names() {
    let all = topic::type_names();
    assert_eq!(all.len(), TopicId::ALL.len());
    let mut seen = HashSet::new();
    for (id, type_name) in &all {
        assert!(type_name.starts_with("testbed::"), "{type_name}");
        assert!(type_name.contains(".v"), "{type_name}");
        assert!(seen.insert(*type_name), "duplicate type name {type_name}");
        assert_eq!(*type_name, id.schema_name(), "{id:?}");
    }
    // SAFETY: `type_name` only returns the string given to `#[type_name]`.
    assert_eq!(
        unsafe { <GyroSample as ZeroCopySend>::type_name() },
        "testbed::GyroSample.v1"
    );
    // SAFETY: as above.
    assert_eq!(
        unsafe { <SampleHeader as ZeroCopySend>::type_name() },
        "testbed::SampleHeader.v1"
    );
}

#[test]
fn topic_names_are_unique_and_valid() {
    let mut seen = HashSet::new();
    for name in topic::ALL {
        assert!(seen.insert(*name), "duplicate service name {name}");
        assert!(name.starts_with("testbed/"), "{name}");
    }
}

#[cfg(feature = "zero-copy")]
#[test]
fn every_topic_is_a_service_with_one_sample_type() {
    for name in topic::ALL {
        ServiceName::new(name).unwrap_or_else(|e| panic!("{name}: {e:?}"));
    }
    let names: Vec<_> = TopicId::ALL.iter().map(|t| t.name()).collect();
    assert_eq!(names, topic::ALL);
    for (i, &t) in TopicId::ALL.iter().enumerate() {
        assert_eq!(t.index(), i);
        assert_eq!(TopicId::from_name(t.name()), Some(t));
    }
    assert_eq!(TopicId::from_name("testbed/no/such"), None);
    // The impls come from the same entries.
    assert_eq!(GyroSample::NAME, TopicId::Gyro.name());
    assert_eq!(Heartbeat::ROLE, TopicRole::Housekeeping);
    assert_eq!(CanBusFrame::ROLE, TopicRole::Shared);
    assert_eq!(AppliedThrusterCommand::NAME, topic::THRUSTER_APPLIED);
}

#[test]
fn defaults_are_zeroed() {
    assert_eq!(SampleHeader::default(), SampleHeader::new(0, 0, 0));
    let e = AttitudeEstimate::default();
    assert!(e.covariance.iter().chain(&e.quaternion).all(|&x| x == 0.0));
    assert_eq!(Heartbeat::default().name(), "");
    assert_eq!(
        ControllerStatus::default().mode(),
        Some(ControllerMode::Idle)
    );
}

#[test]
fn header_flags() {
    let mut h = SampleHeader::new(5, 7, SampleHeader::VALID).with_source(3);
    assert!(h.is_valid() && h.source_id == 3 && !h.has(SampleHeader::SIMULATED));
    h.set(SampleHeader::SATURATED_Y | SampleHeader::SIMULATED, true);
    assert!(h.has(SampleHeader::SIMULATED) && h.flags & SampleHeader::SATURATED_ANY != 0);
    h.set(SampleHeader::VALID | SampleHeader::SATURATED_Y, false);
    assert_eq!(h.flags, SampleHeader::SIMULATED);
    let all = [
        SampleHeader::VALID,
        SampleHeader::SATURATED_X,
        SampleHeader::SATURATED_Y,
        SampleHeader::SATURATED_Z,
        SampleHeader::SATURATED_4,
        SampleHeader::OUT_OF_RANGE,
        SampleHeader::STALE,
        SampleHeader::SIMULATED,
        SampleHeader::REPLAYED,
    ];
    assert_eq!(
        all.iter().fold(0, |acc, f| acc | f).count_ones() as usize,
        all.len()
    );
}

#[test]
fn heartbeat_name_round_trips_and_truncates() {
    let mut hb = Heartbeat::new("gyro-gateway", 42);
    assert_eq!((hb.name(), hb.pid), ("gyro-gateway", 42));
    assert!(hb.set_name(&"x".repeat(32)));
    assert_eq!(hb.name().len(), 32);
    // 31 ASCII bytes then a 2-byte character: cut before the character.
    assert!(!hb.set_name(&format!("{}é", "a".repeat(31))));
    assert_eq!(hb.name(), "a".repeat(31));
    hb.name[1] = 0xff;
    assert_eq!(hb.name(), "a");
    hb.set_state(ProcessState::Degraded);
    assert_eq!(hb.state(), Some(ProcessState::Degraded));
    hb.state = 99;
    assert_eq!(hb.state(), None);
}

#[test]
fn helpers() {
    let mut e = AttitudeEstimate::default();
    e.covariance[6 * 4 + 4] = 2.0;
    e.covariance[6 + 2] = 3.0; // P[1][2]
    assert_eq!(e.covariance_at(1, 2), 3.0);
    assert_eq!(e.covariance_diagonal(), [0.0, 0.0, 0.0, 0.0, 2.0, 0.0]);
    e.innovation_mask = AttitudeEstimate::INNOVATION_MAGNETIC;
    assert_eq!(e.innovation_count(), 3);
    let t = SimClockTick::new(3, 300, 100);
    assert_eq!((t.header.time_ns, t.header.sequence), (300, 3));
    assert!(t.header.has(SampleHeader::VALID | SampleHeader::SIMULATED));
    for v in 0..14 {
        assert_eq!(
            ControllerMode::from_u32(v).map(|m| m as u32),
            (v < 8).then_some(v)
        );
        assert_eq!(
            HealthEventKind::from_u32(v).map(|k| k as u32),
            (v < 12).then_some(v)
        );
        assert_eq!(
            ProcessState::from_u32(v).map(|s| s as u32),
            (v < 5).then_some(v)
        );
    }
}

#[cfg(feature = "zero-copy")]
/// The types work as iceoryx2 payloads (process-local service, no shared memory needed).
#[test]
fn iceoryx2_round_trip() -> Result<(), Box<dyn core::error::Error>> {
    let node = NodeBuilder::new().create::<local::Service>()?;
    let service = node
        .service_builder(&ServiceName::new(AttitudeEstimate::NAME)?)
        .publish_subscribe::<AttitudeEstimate>()
        .open_or_create()?;
    let publisher = service.publisher_builder().create()?;
    let subscriber = service.subscriber_builder().create()?;
    let mut sent = AttitudeEstimate {
        header: SampleHeader::new(1_000, 1, SampleHeader::VALID),
        quaternion: IDENTITY_QUATERNION,
        ..Default::default()
    };
    sent.covariance[35] = 1e-9;
    publisher.send_copy(sent)?;
    let received = subscriber.receive()?.expect("one sample");
    assert_eq!(*received.payload(), sent);
    Ok(())
}

#[test]
fn health_events_name_reporter_and_subject_without_the_topic_prefix() {
    let e = HealthEvent::new(
        SampleHeader::new(5, 1, SampleHeader::VALID),
        "controller",
        "testbed/actuators/wheels/telemetry",
        HealthEventKind::InputLost,
        0,
        0.25,
    );
    assert_eq!(e.reporter(), "controller");
    assert_eq!(e.subject(), "actuators/wheels/telemetry");
    assert_eq!(e.kind(), Some(HealthEventKind::InputLost));
    assert!(HealthEventKind::InputLost.is_fault());
    assert!(!HealthEventKind::InputRestored.is_fault());
}
