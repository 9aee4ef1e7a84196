//! Property tests of the codec: round trips over every message's whole range, and arbitrary
//! frames, byte streams and log lines never panic and are always classified.

use proptest::prelude::*;
use std::f64::consts::TAU;
use testbed_can::transport::parse_candump_line;
use testbed_can::transport::serial::{Deframer, MAX_WIRE, encode_packet};
use testbed_can::*;

fn protocol() -> Protocol {
    Protocol::default()
}

/// A value in [−range, range], endpoints included often.
fn in_range(range: f64) -> impl Strategy<Value = f64> {
    prop_oneof![1 => Just(range), 1 => Just(-range), 1 => Just(0.0), 12 => -range..=range]
}

fn values<const N: usize>(range: f64) -> impl Strategy<Value = [f64; N]> {
    proptest::collection::vec(in_range(range), N).prop_map(|v| {
        let mut a = [0.0; N];
        a.copy_from_slice(&v);
        a
    })
}

fn angles() -> impl Strategy<Value = [f64; 4]> {
    proptest::collection::vec(-5.0 * TAU..=5.0 * TAU, 4).prop_map(|v| [v[0], v[1], v[2], v[3]])
}

fn any_message() -> impl Strategy<Value = Message> {
    let l = *protocol().limits();
    let status = any::<u8>().prop_map(DeviceStatus);
    // On-times are never negative; the field's range is symmetric like every other.
    let on_times = || values::<6>(l.valve_on_time_s).prop_map(|v| v.map(f64::abs));
    prop_oneof![
        (on_times(), any::<bool>()).prop_map(|(on, latch)| {
            Message::ThrusterCommand(ThrusterCommandMsg {
                on_time_s: on,
                latch_shut: latch,
            })
        }),
        (
            any::<u32>(),
            status.clone(),
            on_times(),
            0u8..64,
            any::<bool>()
        )
            .prop_map(|(t, s, on, valves, latch)| {
                Message::ThrusterStatus(ThrusterStatusMsg {
                    node_time_us: t,
                    status: s,
                    applied_on_time_s: on,
                    valves_open: valves,
                    latch_shut: latch,
                })
            }),
        values::<3>(l.wheel_torque_nm)
            .prop_map(|t| Message::WheelCommand(WheelCommandMsg { torque_nm: t })),
        (
            any::<u32>(),
            status.clone(),
            values::<3>(l.wheel_speed_rad_s),
            values::<3>(l.wheel_torque_nm)
        )
            .prop_map(|(t, s, w, q)| Message::WheelTelemetry(WheelTelemetryMsg {
                node_time_us: t,
                status: s,
                speed_rad_s: w,
                torque_nm: q
            })),
        values::<4>(l.gimbal_rate_rad_s).prop_map(|r| Message::CmgCommand(CmgCommandMsg {
            gimbal_rate_rad_s: r
        })),
        (
            any::<u32>(),
            status.clone(),
            angles(),
            values::<4>(l.gimbal_rate_rad_s)
        )
            .prop_map(|(t, s, a, r)| {
                Message::CmgTelemetry(CmgTelemetryMsg {
                    node_time_us: t,
                    status: s,
                    gimbal_angle_rad: a,
                    gimbal_rate_rad_s: r,
                })
            }),
        (
            any::<u32>(),
            status.clone(),
            values::<3>(l.gyro_range_rad_s)
        )
            .prop_map(|(t, s, w)| {
                Message::Gyro(GyroMsg {
                    node_time_us: t,
                    status: s,
                    rate_rad_s: w,
                })
            }),
        (any::<u32>(), status.clone(), values::<2>(l.tilt_range_rad)).prop_map(|(t, s, a)| {
            Message::Inclinometer(InclinometerMsg {
                node_time_us: t,
                status: s,
                tilt_rad: a,
            })
        }),
        (any::<u32>(), status, values::<3>(l.field_range_t)).prop_map(|(t, s, b)| {
            Message::Magnetometer(MagnetometerMsg {
                node_time_us: t,
                status: s,
                field_t: b,
            })
        }),
        (any::<u32>(), 0u8..4, any::<u8>(), any::<u8>()).prop_map(|(t, st, links, e)| {
            Message::NodeHeartbeat(NodeHeartbeatMsg {
                node_time_us: t,
                state: NodeState::from_wire(st),
                links: DeviceSet(links),
                serial_errors: e,
            })
        }),
    ]
}

/// `(value, quantity)` pairs of a message, for the tolerance check.
fn channels(m: &Message) -> Vec<(f64, Quantity)> {
    let tag = |v: &[f64], q| v.iter().map(move |&x| (x, q)).collect::<Vec<_>>();
    match m {
        Message::WheelCommand(c) => tag(&c.torque_nm, Quantity::WheelTorque),
        Message::WheelTelemetry(t) => [
            tag(&t.speed_rad_s, Quantity::WheelSpeed),
            tag(&t.torque_nm, Quantity::WheelTorque),
        ]
        .concat(),
        Message::CmgCommand(c) => tag(&c.gimbal_rate_rad_s, Quantity::GimbalRate),
        Message::CmgTelemetry(t) => [
            tag(&t.gimbal_angle_rad, Quantity::GimbalAngle),
            tag(&t.gimbal_rate_rad_s, Quantity::GimbalRate),
        ]
        .concat(),
        Message::Gyro(g) => tag(&g.rate_rad_s, Quantity::GyroRate),
        Message::Inclinometer(i) => tag(&i.tilt_rad, Quantity::Tilt),
        Message::Magnetometer(b) => tag(&b.field_t, Quantity::Field),
        Message::NodeHeartbeat(_) => vec![],
        Message::ThrusterCommand(c) => tag(&c.on_time_s, Quantity::ValveOnTime),
        Message::ThrusterStatus(t) => tag(&t.applied_on_time_s, Quantity::ValveOnTime),
    }
}

fn arbitrary_frame() -> impl Strategy<Value = CanFrame> {
    let id = prop_oneof![3 => 0x100u32..0x170, 1 => 0u32..0x800, 1 => 0u32..0x2000_0000];
    (
        id,
        any::<bool>(),
        any::<bool>(),
        0usize..=8,
        any::<[u8; 8]>(),
    )
        .prop_map(|(id, ext, remote, len, data)| {
            let id = if ext {
                CanId::Extended(id)
            } else {
                CanId::Standard((id & 0x7FF) as u16)
            };
            let frame = if remote {
                CanFrame::remote(id, len as u8)
            } else {
                CanFrame::new(id, &data[..len])
            };
            frame.unwrap_or_default()
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// encode → decode gives back every field: status, time and counter exactly, values within
    /// half an LSB (gimbal angles modulo one turn).
    #[test]
    fn round_trip_within_half_an_lsb(m in any_message(), counter in any::<u8>()) {
        let enc = Encoder::new(protocol());
        let mut dec = Decoder::new(protocol());
        let batch = enc.encode_with_counter(&m, counter).expect("in-range message encodes");
        prop_assert_eq!(batch.len(), m.kind().parts());
        let mut got = None;
        for (i, f) in batch.iter().enumerate() {
            prop_assert_eq!(f.dlc(), m.kind().dlc(i).unwrap_or(0));
            let d = dec.decode(f);
            prop_assert_eq!(d.class, FrameClass::Ok);
            prop_assert_eq!(d.message.is_some(), i + 1 == batch.len());
            got = d.message.or(got);
        }
        let r = got.expect("complete");
        prop_assert_eq!(r.counter, counter);
        prop_assert_eq!(r.clipped, 0);
        prop_assert_eq!(r.message.kind(), m.kind());
        prop_assert_eq!(r.message.node_time_us(), m.node_time_us());
        prop_assert_eq!(r.message.status(), m.status());
        match (&r.message, &m) {
            (Message::NodeHeartbeat(a), Message::NodeHeartbeat(b)) => prop_assert_eq!(a, b),
            (Message::ThrusterCommand(a), Message::ThrusterCommand(b)) => {
                prop_assert_eq!(a.latch_shut, b.latch_shut)
            }
            (Message::ThrusterStatus(a), Message::ThrusterStatus(b)) => {
                prop_assert_eq!((a.valves_open, a.latch_shut), (b.valves_open, b.latch_shut))
            }
            _ => {}
        }
        for ((got, q), (want, _)) in channels(&r.message).into_iter().zip(channels(&m)) {
            let lsb = q.lsb_si();
            let mut err = got - want;
            if q.wraps() {
                err -= TAU * (err / TAU).round();
                prop_assert!((-TAU / 2.0..TAU / 2.0).contains(&got), "angle {} not wrapped", got);
            }
            let tol = 0.5 * lsb * (1.0 + 1e-9) + want.abs() * 4.0 * f64::EPSILON;
            prop_assert!(err.abs() <= tol, "{:?}: {} → {} (error {:e} > {:e})", q, want, got, err, tol);
        }
        let s = dec.stats();
        prop_assert_eq!((s.frames, s.classified(), s.messages), (batch.len() as u64, batch.len() as u64, 1));
    }

    /// Values beyond the range are refused by the encoder.
    #[test]
    fn out_of_range_commands_are_refused(excess in 1.000001f64..1e6, sign in prop_oneof![Just(1.0), Just(-1.0)], ch in 0usize..3) {
        let enc = Encoder::new(protocol());
        let mut t = [0.0; 3];
        t[ch] = sign * excess * protocol().limits().wheel_torque_nm;
        let r = enc.encode_with_counter(&Message::WheelCommand(WheelCommandMsg { torque_nm: t }), 0);
        let refused = matches!(r, Err(EncodeError::OutOfRange { channel, .. }) if channel == ch);
        prop_assert!(refused, "{:?}", r);
        let mut g = [0.0; 4];
        g[ch] = sign * excess * protocol().limits().gimbal_rate_rad_s;
        let r = enc.encode_with_counter(&Message::CmgCommand(CmgCommandMsg { gimbal_rate_rad_s: g }), 0);
        let refused = matches!(r, Err(EncodeError::OutOfRange { .. }));
        prop_assert!(refused, "{:?}", r);
    }

    /// Arbitrary frames never panic and each is counted in exactly one class; completed
    /// messages carry in-range values.
    #[test]
    fn arbitrary_frames_are_classified(frames in proptest::collection::vec(arbitrary_frame(), 1..200)) {
        let mut dec = Decoder::new(protocol());
        let l = *protocol().limits();
        for f in &frames {
            let d = dec.decode(f);
            if let Some(r) = d.message {
                for (v, q) in channels(&r.message) {
                    prop_assert!(v.is_finite());
                    if let Some(range) = l.range(q) {
                        prop_assert!(v.abs() <= range, "{:?} {} beyond {}", q, v, range);
                    }
                }
            }
        }
        let s = dec.stats();
        prop_assert_eq!(s.frames, frames.len() as u64);
        prop_assert_eq!(s.classified(), s.frames);
    }

    /// Serial framing: frames survive the byte stream, and arbitrary bytes never panic.
    #[test]
    fn serial_framing(frames in proptest::collection::vec(arbitrary_frame(), 0..20), noise in proptest::collection::vec(any::<u8>(), 0..300)) {
        let mut d = Deframer::new();
        for &b in &noise {
            let _ = d.push(b);
        }
        let _ = d.push(0); // resynchronise
        let mut sent = vec![];
        let mut got = vec![];
        for f in &frames {
            let mut out = [0u8; MAX_WIRE];
            if let Ok(n) = encode_packet(f, &mut out) {
                sent.push(*f);
                got.extend(out[..n].iter().filter_map(|&b| d.push(b)));
            }
        }
        let got: Vec<CanFrame> = got.into_iter().map(|r| r.expect("clean packet decodes")).collect();
        prop_assert_eq!(got, sent);
    }

    /// Arbitrary text never panics the candump parser.
    #[test]
    fn candump_parser_total(line in "\\PC{0,80}", ts in "\\([0-9]{0,12}\\.[0-9]{0,10}\\)", tail in "[0-9A-Fa-fR#_ .x]{0,24}") {
        let _ = parse_candump_line(&line);
        let _ = parse_candump_line(&format!("{ts} can0 {tail}"));
    }

    /// Frames written as candump lines parse back identically.
    #[test]
    fn candump_round_trip(f in arbitrary_frame(), t in 0u64..4_000_000_000_000_000_000) {
        let line = testbed_can::transport::format_candump_line(t, "can0", &f);
        let e = parse_candump_line(&line).expect("own output parses");
        prop_assert_eq!(e.frame, f);
        prop_assert_eq!(e.time_ns, t / 1000 * 1000);
    }
}
