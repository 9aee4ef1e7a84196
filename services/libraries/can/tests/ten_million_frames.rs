//! Ten million arbitrary frames through the decoders: no panic, every frame counted exactly
//! once, in bounded time.
//!
//! Deterministic (xorshift64*, fixed seed). The mix: random identifiers anywhere in the 11-bit
//! space, random identifiers inside the map's blocks, extended and remote frames, random DLCs and
//! payloads; valid message streams from an encoder with frames dropped, repeated and reordered;
//! and valid frames mutated (bit flips, DLC, identifier, counter, out-of-range values).

use std::collections::VecDeque;
use std::time::Instant;
use testbed_can::*;

const FRAMES: u64 = 10_000_000;
const SEED: u64 = 0x5EED_CA11_0B0E_D7E5;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        ((u128::from(self.next() >> 32) * u128::from(n)) >> 32) as u64
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn sym(&mut self, range: f64) -> f64 {
        (2.0 * self.unit() - 1.0) * range
    }
}

fn random_message(rng: &mut Rng, l: &Limits) -> Message {
    let t = rng.next() as u32;
    let s = DeviceStatus((rng.next() & 0xEF) as u8);
    let mut v = [0.0f64; 8];
    match rng.below(8) {
        0 => {
            for x in &mut v[..3] {
                *x = rng.sym(l.wheel_torque_nm);
            }
            Message::WheelCommand(WheelCommandMsg {
                torque_nm: [v[0], v[1], v[2]],
            })
        }
        1 => Message::WheelTelemetry(WheelTelemetryMsg {
            node_time_us: t,
            status: s,
            speed_rad_s: [
                rng.sym(l.wheel_speed_rad_s),
                rng.sym(l.wheel_speed_rad_s),
                rng.sym(l.wheel_speed_rad_s),
            ],
            torque_nm: [
                rng.sym(l.wheel_torque_nm),
                rng.sym(l.wheel_torque_nm),
                rng.sym(l.wheel_torque_nm),
            ],
        }),
        2 => Message::CmgCommand(CmgCommandMsg {
            gimbal_rate_rad_s: [0; 4].map(|_| rng.sym(l.gimbal_rate_rad_s)),
        }),
        3 => Message::CmgTelemetry(CmgTelemetryMsg {
            node_time_us: t,
            status: s,
            gimbal_angle_rad: [0; 4].map(|_| rng.sym(40.0)),
            gimbal_rate_rad_s: [0; 4].map(|_| rng.sym(l.gimbal_rate_rad_s)),
        }),
        4 => Message::Gyro(GyroMsg {
            node_time_us: t,
            status: s,
            rate_rad_s: [0; 3].map(|_| rng.sym(l.gyro_range_rad_s)),
        }),
        5 => Message::Inclinometer(InclinometerMsg {
            node_time_us: t,
            status: s,
            tilt_rad: [rng.sym(l.tilt_range_rad), rng.sym(l.tilt_range_rad)],
        }),
        6 => Message::Magnetometer(MagnetometerMsg {
            node_time_us: t,
            status: s,
            field_t: [0; 3].map(|_| rng.sym(l.field_range_t)),
        }),
        _ => Message::NodeHeartbeat(NodeHeartbeatMsg {
            node_time_us: t,
            state: NodeState::from_wire(rng.below(4) as u8),
            links: DeviceSet((rng.next() & 0x1F) as u8),
            serial_errors: rng.next() as u8,
        }),
    }
}

fn random_frame(rng: &mut Rng, base: u16) -> CanFrame {
    let len = rng.below(9) as usize;
    let data = rng.next().to_le_bytes();
    let id = match rng.below(4) {
        0 => CanId::Standard(rng.below(0x800) as u16),
        1 | 2 => CanId::Standard(base + rng.below(0x60) as u16),
        _ => CanId::Extended(rng.below(0x2000_0000) as u32),
    };
    let frame = if rng.below(16) == 0 {
        CanFrame::remote(id, len as u8)
    } else {
        CanFrame::new(id, &data[..len])
    };
    frame.unwrap_or_default()
}

fn mutate(rng: &mut Rng, f: &CanFrame) -> CanFrame {
    let mut data = f.data_padded();
    let mut len = usize::from(f.dlc());
    let mut id = f.id();
    match rng.below(6) {
        0 => {
            let bit = rng.below(64);
            data[(bit / 8) as usize] ^= 1 << (bit % 8);
        }
        1 => len = rng.below(9) as usize,
        2 => {
            if let CanId::Standard(s) = id {
                id = CanId::Standard((s ^ (1 << rng.below(11))) & 0x7FF);
            }
        }
        3 => data[0] = rng.next() as u8,
        // Saturate a value field: 0x7FFFFF / 0x800000 at a random offset.
        4 => {
            let at = 1 + rng.below(5) as usize;
            let v: [u8; 3] = if rng.below(2) == 0 {
                [0xFF, 0xFF, 0x7F]
            } else {
                [0, 0, 0x80]
            };
            data[at..at + 3].copy_from_slice(&v);
        }
        _ => id = CanId::Extended(id.raw()),
    }
    CanFrame::new(id, &data[..len]).unwrap_or_default()
}

#[derive(Default, Debug, PartialEq, Eq)]
struct Tally {
    ok: u64,
    unknown: u64,
    ignored: u64,
    dlc: u64,
    duplicate: u64,
    jump: u64,
    incomplete: u64,
    range: u64,
    lost: u64,
}

impl Tally {
    fn add(&mut self, class: FrameClass) {
        match class {
            FrameClass::Ok => self.ok += 1,
            FrameClass::UnknownId => self.unknown += 1,
            FrameClass::Ignored => self.ignored += 1,
            FrameClass::WrongDlc { .. } => self.dlc += 1,
            FrameClass::Duplicate => self.duplicate += 1,
            FrameClass::CounterJump { lost } => {
                self.jump += 1;
                self.lost += u64::from(lost);
            }
            FrameClass::IncompleteSample => self.incomplete += 1,
            FrameClass::OutOfRange => self.range += 1,
        }
    }

    fn matches(&self, s: &DecoderStats) -> bool {
        (
            self.ok,
            self.unknown,
            self.ignored,
            self.dlc,
            self.duplicate,
            self.jump,
            self.incomplete,
            self.range,
        ) == (
            s.ok,
            s.unknown_id,
            s.ignored,
            s.wrong_dlc,
            s.duplicate,
            s.counter_jump,
            s.incomplete,
            s.out_of_range,
        ) && self.lost == s.lost_frames
    }
}

#[test]
fn ten_million_arbitrary_frames() {
    let protocol = Protocol::default();
    let base = protocol.ids().base();
    let limits = *protocol.limits();
    let mut encoder = Encoder::new(protocol);
    let mut all = Decoder::new(protocol);
    let mut gyro_and_wheels =
        Decoder::with_devices(protocol, DeviceSet::of(&[Device::Gyro, Device::Wheels]));
    let (mut tally_all, mut tally_some) = (Tally::default(), Tally::default());
    let mut rng = Rng(SEED);
    let mut stream: VecDeque<CanFrame> = VecDeque::new();
    let mut last_valid = CanFrame::default();
    let mut messages = 0u64;

    let start = Instant::now();
    for _ in 0..FRAMES {
        let frame = match rng.below(10) {
            // 30 %: random frames.
            0..=2 => random_frame(&mut rng, base),
            // 10 %: mutated valid frames.
            3 => mutate(&mut rng, &last_valid),
            // 60 %: the valid stream, with loss, repeats and reordering.
            _ => {
                if stream.is_empty() {
                    let m = random_message(&mut rng, &limits);
                    let batch = encoder.encode(&m).expect("random in-range message encodes");
                    stream.extend(batch.iter());
                }
                match rng.below(100) {
                    0..=1 => {
                        stream.pop_front(); // lost
                        stream.pop_front().unwrap_or(last_valid)
                    }
                    2 => last_valid, // repeated
                    3 if stream.len() >= 2 => {
                        stream.swap(0, 1); // reordered
                        stream.pop_front().unwrap_or(last_valid)
                    }
                    _ => stream.pop_front().unwrap_or(last_valid),
                }
            }
        };
        last_valid = if frame.is_extended() {
            last_valid
        } else {
            frame
        };
        let d = all.decode(&frame);
        tally_all.add(d.class);
        messages += u64::from(d.message.is_some());
        tally_some.add(gyro_and_wheels.decode(&frame).class);
    }
    let elapsed = start.elapsed();

    let s = *all.stats();
    eprintln!(
        "10M frames through 2 decoders in {:.2} s ({:.0} ns/frame/decoder)\nall devices: {s:#?}",
        elapsed.as_secs_f64(),
        elapsed.as_nanos() as f64 / (2.0 * FRAMES as f64)
    );
    for (stats, tally) in [(&s, &tally_all), (gyro_and_wheels.stats(), &tally_some)] {
        assert_eq!(stats.frames, FRAMES);
        assert_eq!(
            stats.classified(),
            FRAMES,
            "every frame in exactly one class"
        );
        assert!(
            tally.matches(stats),
            "returned classes {tally:?} disagree with the counts {stats:?}"
        );
    }
    assert_eq!(s.messages, messages);
    // Every class occurs, so the mix exercises every path.
    for (name, n) in [
        ("ok", s.ok),
        ("unknown_id", s.unknown_id),
        ("wrong_dlc", s.wrong_dlc),
        ("duplicate", s.duplicate),
        ("counter_jump", s.counter_jump),
        ("incomplete", s.incomplete),
        ("out_of_range", s.out_of_range),
        ("messages", s.messages),
        ("clipped", s.clipped_values),
    ] {
        assert!(n > 0, "no {name} in the mix");
    }
    assert!(gyro_and_wheels.stats().ignored > 0);
    // Bounded time: CI runs this in release mode, where it takes well under the bound.
    if !cfg!(debug_assertions) {
        assert!(elapsed.as_secs_f64() < 20.0, "10M frames took {elapsed:?}");
    }
}
