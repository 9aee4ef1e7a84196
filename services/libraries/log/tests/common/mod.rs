//! Shared helpers of the integration tests: synthetic runs, temp paths, MCAP framing.

#![allow(dead_code)] // each test binary uses a subset

use ipc_types::{
    AppliedCmgCommand, AppliedThrusterCommand, AppliedWheelCommand, AttitudeEstimate, CanBusFrame,
    CanLinkStatus, CmgCommand, CmgTelemetry, ControllerMode, ControllerStatus, GyroSample,
    HealthEvent, HealthEventKind, Heartbeat, InclinometerSample, MagnetometerSample, ProcessState,
    SampleHeader, SimClockTick, SimTruth, ThrusterCommand, ThrusterStatus, WheelCommand,
    WheelTelemetry,
};
use ipc_types::{GroundAckStatus, GroundCommand, GroundCommandAck};
use std::collections::BTreeMap;
use std::path::PathBuf;
use testbed_log::{LogRecord, RunInfo};

/// Step of the synthetic runs, ns (100 Hz).
pub const STEP_NS: u64 = 10_000_000;

/// Small deterministic generator (xorshift64*).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A float spanning many magnitudes and both signs (finite).
    pub fn f64(&mut self) -> f64 {
        let mantissa = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let exponent = (self.next_u64() % 40) as i32 - 30;
        let sign = if self.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
        sign * mantissa * 10f64.powi(exponent)
    }

    pub fn array<const N: usize>(&mut self) -> [f64; N] {
        core::array::from_fn(|_| self.f64())
    }

    /// Index in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

fn header(t: u64, seq: u64, rng: &mut Rng) -> SampleHeader {
    let flags = SampleHeader::VALID
        | SampleHeader::SIMULATED
        | if matches!(rng.next_u64() % 7, 0) {
            SampleHeader::SATURATED_Y
        } else {
            0
        };
    SampleHeader::new(t, seq, flags)
}

/// The records of tick `k` of a synthetic lockstep run: every topic at 100 Hz, the
/// inclinometer and magnetometer at 25 Hz, heartbeats of two processes every 10 ticks (same
/// time, sequence and source: only their content orders them).
pub fn tick_records(k: u64, rng: &mut Rng) -> Vec<LogRecord> {
    let t = k * STEP_NS;
    let mut out: Vec<LogRecord> = Vec::new();
    out.push(SimClockTick::new(k, t, STEP_NS).into());
    out.push(
        SimTruth {
            header: header(t, k, rng),
            quaternion: rng.array(),
            rate: rng.array(),
            wheel_speed: rng.array(),
            gimbal_angle: rng.array(),
            gyro_bias: rng.array(),
            angular_momentum: rng.array(),
            kinetic_energy: rng.f64().abs(),
            tilt_stop: (k % 4) as u32,
            _pad0: 0,
        }
        .into(),
    );
    out.push(GyroSample::new(header(t, k, rng), rng.array()).into());
    if matches!(k % 4, 0) {
        out.push(InclinometerSample::new(header(t, k / 4, rng), rng.array()).into());
        out.push(MagnetometerSample::new(header(t, k / 4, rng), rng.array()).into());
    }
    out.push(WheelTelemetry::new(header(t, k, rng), rng.array(), rng.array()).into());
    out.push(CmgTelemetry::new(header(t, k, rng), rng.array(), rng.array()).into());
    out.push(
        AttitudeEstimate {
            header: header(t, k, rng),
            quaternion: rng.array(),
            rate: rng.array(),
            gyro_bias: rng.array(),
            covariance: rng.array(),
            innovation: rng.array(),
            innovation_time_ns: t - t % (4 * STEP_NS),
            innovation_mask: (k % 64) as u32,
            _pad0: 0,
            updates_applied: k / 4,
            updates_skipped: k / 40,
            updates_rejected: k / 400,
        }
        .into(),
    );
    let mut status = ControllerStatus {
        header: header(t, k, rng),
        attitude_error: rng.array(),
        torque_command: rng.array(),
        deadline_misses: k / 100,
        loop_period_ns: STEP_NS,
        compute_time_ns: 0,
        ..ControllerStatus::default()
    };
    status.set_mode(ControllerMode::WheelPointing);
    out.push(status.into());
    out.push(WheelCommand::new(header(t, k, rng), rng.array()).into());
    out.push(CmgCommand::new(header(t, k, rng), rng.array()).into());
    for i in 0..3u64 {
        let len = (rng.next_u64() % 9) as u8;
        let mut data = [0u8; 8];
        for b in data.iter_mut().take(usize::from(len)) {
            *b = rng.next_u64() as u8;
        }
        out.push(
            CanBusFrame {
                header: header(t, 3 * k + i, rng).with_source(1 + (i as u32)),
                can_id: 0x100 + (rng.next_u64() % 0x60) as u32,
                len,
                data,
                check: (rng.next_u64() & 0x7FFF) as u32,
                ..CanBusFrame::default()
            }
            .into(),
        );
    }
    out.push(
        AppliedWheelCommand {
            header: header(t, k, rng),
            torque: rng.array(),
        }
        .into(),
    );
    out.push(
        AppliedCmgCommand {
            header: header(t, k, rng),
            gimbal_rate: rng.array(),
        }
        .into(),
    );
    if matches!(k % 10, 0) {
        out.push(
            CanLinkStatus {
                header: SampleHeader::new(t, k / 10, SampleHeader::VALID).with_source(2),
                frames_ok: 2 * k,
                frames_bad: k / 50,
                lost_frames: k / 70,
                injected_rx_duplicate: u64::MAX - k,
                ..CanLinkStatus::default()
            }
            .into(),
        );
    }
    if matches!(k % 10, 0) {
        for name in ["estimator", "controller"] {
            let mut hb = Heartbeat::new(name, 0);
            hb.header = SampleHeader::new(t, k / 10, SampleHeader::VALID);
            hb.set_state(ProcessState::Running);
            hb.samples_in = k * 3;
            hb.samples_out = k;
            out.push(hb.into());
        }
    }
    if matches!(k % 20, 5) {
        out.push(
            HealthEvent::new(
                SampleHeader::new(t, k / 20, SampleHeader::VALID),
                "controller",
                "testbed/gnc/attitude_estimate",
                HealthEventKind::InputLost,
                0,
                0.2,
            )
            .into(),
        );
    }
    if matches!(k % 20, 7) {
        let header = SampleHeader::new(t, k / 20, SampleHeader::VALID);
        out.push(
            GroundCommand {
                header,
                kind: 2,
                target_heading_rad: 0.25,
                target_pitch_rad: -0.05,
                target_roll_rad: 1e-3,
                command_id: k,
                client_id: 3,
                ..GroundCommand::default()
            }
            .into(),
        );
        out.push(
            GroundCommandAck::new(
                header,
                k,
                2,
                GroundAckStatus::Applied,
                3,
                GroundCommandAck::BY_CONTROLLER,
                "target set",
            )
            .into(),
        );
    }
    let seq = k;
    out.push(
        ThrusterCommand {
            header: SampleHeader::new(t, seq, SampleHeader::VALID),
            on_time: [0.0, 0.025 * (k % 3) as f64, 0.0, 0.0, 0.1, 1e-3 * k as f64],
        }
        .into(),
    );
    out.push(
        ThrusterStatus {
            header: SampleHeader::new(t, seq, SampleHeader::VALID),
            applied_on_time: [0.0, 0.025 * (k % 3) as f64, 0.0, 0.0, 0.1, 0.0],
            valves_open: (k % 64) as u32,
            disabled: u32::from(k > 30),
            refused: k / 7,
            propellant_used: 1.5e-5 * k as f64,
        }
        .into(),
    );
    out.push(
        AppliedThrusterCommand {
            header: SampleHeader::new(t, seq, SampleHeader::VALID),
            on_time: [0.0, 0.0, 0.012_34 * (k % 2) as f64, 0.0, 0.0, 0.1],
            latch_shut: u32::from(k > 40),
            _pad0: 0,
        }
        .into(),
    );
    out
}

/// `ticks` ticks of a synthetic run, per tick.
pub fn run_records(ticks: u64, seed: u64) -> Vec<Vec<LogRecord>> {
    let mut rng = Rng::new(seed);
    (0..ticks).map(|k| tick_records(k, &mut rng)).collect()
}

/// Run information of the synthetic runs.
pub fn run_info() -> RunInfo {
    RunInfo {
        profile: "simulation".into(),
        seed: 0xDEAD_BEEF_0123_4567,
        mode: "lockstep".into(),
        config_toml: "# test configuration\n[plant]\ninertia = [1.2, 1.3, 0.9] # kg m²\n\n\
                      [estimator]\ngyro_noise = 1e-6\n"
            .into(),
        // 2026-11-24T07:00:00Z: message times on a real epoch.
        start_time_ns: 1_795_503_600_000_000_000,
        extra: BTreeMap::from([("git".to_owned(), "abc123".to_owned())]),
    }
}

/// A fresh path in the test's temporary directory.
pub fn temp_path(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("testbed-log");
    std::fs::create_dir_all(&dir).expect("create temp dir");
    let path = dir.join(name);
    let _ = std::fs::remove_file(&path);
    path
}

/// One record of an MCAP file's framing.
#[derive(Debug, Clone, Copy)]
pub struct Framed {
    pub opcode: u8,
    pub start: u64,
    pub end: u64,
    /// For a message record: its channel id.
    pub channel: Option<u16>,
}

impl Framed {
    /// A message on a sample channel (ids 1 to `topic::ALL.len()`; the derived Foxglove
    /// transforms follow them).
    pub fn is_sample_message(&self) -> bool {
        self.opcode == 0x05
            && self
                .channel
                .is_some_and(|c| usize::from(c) <= ipc_types::topic::ALL.len())
    }
}

/// The records of a complete MCAP file (independent of the crate's reader).
pub fn framing(bytes: &[u8]) -> Vec<Framed> {
    assert_eq!(&bytes[..8], b"\x89MCAP0\r\n", "magic");
    let mut out = Vec::new();
    let mut pos = 8usize;
    loop {
        let opcode = bytes[pos];
        let len = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().expect("8 bytes"));
        let end = pos + 9 + len as usize;
        out.push(Framed {
            opcode,
            start: pos as u64,
            end: end as u64,
            channel: (opcode == 0x05)
                .then(|| u16::from_le_bytes([bytes[pos + 9], bytes[pos + 10]])),
        });
        pos = end;
        if opcode == 0x02 {
            assert_eq!(&bytes[pos..], b"\x89MCAP0\r\n", "trailing magic");
            return out;
        }
    }
}

/// Runs the Python script `tests/read_log.py` with `args`, returning its JSON output.
/// Fails with instructions if `python3` or its `mcap` package is missing.
pub fn python_read_log(args: &[&str]) -> serde_json::Value {
    let check = std::process::Command::new("python3")
        .args(["-c", "import mcap, zstandard"])
        .output();
    match check {
        Err(e) => panic!("python3 is needed to check logs with a standard MCAP reader: {e}"),
        Ok(out) if !out.status.success() => panic!(
            "Python's `mcap` package is missing (needed to check logs with a standard MCAP \
             reader); install it with: python3 -m pip install 'mcap>=1.1,<2' zstandard\n{}",
            String::from_utf8_lossy(&out.stderr)
        ),
        Ok(_) => {}
    }
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/read_log.py");
    let out = std::process::Command::new("python3")
        .arg(script)
        .args(args)
        .output()
        .expect("run python3");
    assert!(
        out.status.success(),
        "read_log.py {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "read_log.py printed no JSON ({e}):\n{}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// `records` in the order an indexed log gives them back: by time, then by channel (topic
/// table order), each topic's records in the order written.
#[allow(dead_code)] // not every test file that includes this module uses it
pub fn in_log_order(records: &[LogRecord]) -> Vec<LogRecord> {
    let mut sorted = records.to_vec();
    sorted.sort_by_key(|r| (r.header().time_ns, testbed_log::channel_id(r.topic_id())));
    sorted
}

/// Messages per topic a log of `records` holds among those for which `inside(time_ns)`: each
/// record, and what it derives for Foxglove's panels (a transform per truth sample and valid
/// estimate, a pose per valid estimate, an event per health event, acknowledgement and mode
/// change; mode changes followed over all records).
pub fn expected_messages(
    records: &[LogRecord],
    inside: impl Fn(u64) -> bool,
) -> BTreeMap<&'static str, u64> {
    use testbed_log::foxglove::{self, Derived};
    let mut expected = BTreeMap::new();
    let mut modes = foxglove::events::ModeChanges::default();
    for r in records {
        let counted = inside(r.header().time_ns);
        let mut count = |topic: &'static str| {
            if counted {
                *expected.entry(topic).or_default() += 1;
            }
        };
        count(r.topic());
        match foxglove::derived_of(r) {
            Derived::Transform((topic, ..)) => {
                count(topic);
                if topic == foxglove::TF_ESTIMATE_TOPIC {
                    count(foxglove::POSE_ESTIMATE_TOPIC);
                }
            }
            Derived::Event(_) => count(foxglove::events::EVENTS_TOPIC),
            Derived::Mode(m) => {
                if modes.event(m).is_some() {
                    count(foxglove::events::EVENTS_TOPIC);
                }
            }
            Derived::Nothing => {}
        }
    }
    expected
}
