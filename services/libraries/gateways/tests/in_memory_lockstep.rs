//! The CAN path wired in memory, tick by tick, exactly as the processes pass frames and samples
//! in lockstep: plant → simulated CAN board → bus → five gateways → estimator → controller →
//! wheel and CMG gateways → bus → CAN board → plant. Faults included: no tick may go unanswered,
//! every injected fault must show up in exactly one receiver counter, and the platform must
//! still level.

use ipc_types::{CanLinkStatus, SampleHeader};
use testbed_can::Sample;
use testbed_config::{Actuation, CanFaults, RunConfig};
use testbed_flight::convert::quaternion_from_array;
use testbed_flight::tasks::{ControllerTask, EstimatorCounters, EstimatorTask};
use testbed_gateways::can_board::{self, SimCanBoard, TxFrame};
use testbed_gateways::gateway::Gateway;
use testbed_model::attitude;
use testbed_model::config::DEG;
use testbed_sim::metrics;
use testbed_sim::plant_task::PlantTask;

struct Outcome {
    /// (t, attitude error per axis, degrees)
    errors: Vec<(f64, [f64; 3])>,
    estimates: Vec<ipc_types::AttitudeEstimate>,
    gateways: Vec<(testbed_gateways::gateway::Served, CanLinkStatus)>,
    board: CanLinkStatus,
    estimator: EstimatorCounters,
    stale_applied: u64,
}

fn run(config: &RunConfig) -> Outcome {
    let schedule = config.schedule().unwrap();
    let protocol = can_board::protocol(config).unwrap();
    let mut plant = PlantTask::new(config).unwrap();
    let mut board = SimCanBoard::new(config).unwrap();
    let mut gateways: Vec<(Gateway, u64)> = ipc_types::Device::ALL
        .iter()
        .map(|&d| (Gateway::new(d, protocol, schedule, true), 0))
        .collect();
    let mut estimator = EstimatorTask::new(config.estimator_setup().unwrap(), schedule);
    let mut controller = ControllerTask::new(
        &config.controller,
        &config.model,
        config.manoeuvre.target(),
        schedule,
    )
    .unwrap();
    let target = config.manoeuvre.target();
    let mut out = Outcome {
        errors: Vec::new(),
        estimates: Vec::new(),
        gateways: Vec::new(),
        board: CanLinkStatus::default(),
        estimator: EstimatorCounters::default(),
        stale_applied: 0,
    };
    loop {
        let (truth, _) = plant.outputs();
        let q = quaternion_from_array(&truth.quaternion).unwrap();
        let e = attitude::attitude_error(&q, &target) / DEG;
        out.errors
            .push((truth.header.time_ns as f64 * 1e-9, [e.x, e.y, e.z]));
        // The board's frames reach every gateway in sending order.
        let frames = board.on_truth(&truth);
        let mut samples = Vec::new();
        for (gateway, check_errors) in &mut gateways {
            for frame in &frames {
                match frame {
                    TxFrame::Send(f) => samples.extend(gateway.on_frame(f).sample),
                    TxFrame::Corrupt(..) => {
                        *check_errors += 1;
                        gateway.set_link_check_errors(*check_errors);
                    }
                }
            }
        }
        for sample in &samples {
            match sample {
                Sample::Gyro(s) => estimator.on_gyro(s),
                Sample::Inclinometer(s) => estimator.on_inclinometer(s),
                Sample::Magnetometer(s) => estimator.on_magnetometer(s),
                Sample::WheelTelemetry(s) => controller.on_wheel_telemetry(s),
                Sample::CmgTelemetry(s) => controller.on_cmg_telemetry(s),
                other => panic!("a gateway published {other:?}"),
            }
        }
        for estimate in estimator.ready() {
            controller.on_estimate(&estimate);
            out.estimates.push(estimate);
        }
        let mut applied = None;
        for cycle in controller.ready() {
            let wheel_frames = gateways[3].0.wheel_command(&cycle.wheels).unwrap();
            let cmg_frames = gateways[4].0.cmg_command(&cycle.cmg).unwrap();
            // The CMG gateway's frames first: the board must not depend on the order.
            for f in cmg_frames.iter().chain(wheel_frames.iter()) {
                applied = board.on_frame(f).or(applied);
            }
        }
        let applied =
            applied.unwrap_or_else(|| panic!("tick {} not answered by the board", plant.tick()));
        assert_eq!(applied.wheel.header.time_ns, truth.header.time_ns);
        out.stale_applied += u64::from(applied.wheel.header.has(SampleHeader::STALE));
        let (wheel_command, cmg_command) = applied.commands();
        plant.on_wheel_command(&wheel_command);
        plant.on_cmg_command(&cmg_command);
        assert!(plant.answered(), "tick {} not answered", plant.tick());
        if plant.at_end() {
            break;
        }
        plant.advance().unwrap();
    }
    out.gateways = gateways
        .iter()
        .map(|(g, _)| (g.device(), g.status()))
        .collect();
    out.board = board.status();
    out.estimator = estimator.counters();
    out
}

fn config(duration_s: f64, faults: CanFaults) -> RunConfig {
    let mut config = RunConfig::default();
    config.run.duration_s = duration_s;
    config.run.seed = 7;
    config.run.actuation = Actuation::CanNode;
    config.can.faults = faults;
    config
}

#[test]
fn without_faults_every_frame_is_good_and_the_platform_levels() {
    let out = run(&config(150.0, CanFaults::default()));
    for (device, s) in &out.gateways {
        assert_eq!(
            (s.frames_bad, s.lost_frames, s.stale_samples, s.late_frames),
            (0, 0, 0, 0),
            "{device:?}: {s:?}"
        );
        assert!(s.frames_ok > 1500, "{device:?}: {s:?}");
    }
    assert_eq!(
        (
            out.board.frames_bad,
            out.board.lost_frames,
            out.stale_applied
        ),
        (0, 0, 0)
    );
    assert_eq!(out.estimator.gyro_held, 0);
    let settle = metrics::settling_time(&out.errors, 0.1).expect("settles");
    let steady = metrics::steady_max(&out.errors, 50.0);
    assert!(settle < 120.0, "settling {settle} s");
    assert!(
        steady[0].max(steady[1]) < 0.02 && steady[2] < 0.05,
        "steady {steady:?}"
    );
}

#[test]
fn with_faults_every_tick_is_answered_every_fault_counted_and_the_platform_levels() {
    let faults = CanFaults {
        drop: 0.005,
        corrupt: 0.005,
        delay: 0.003,
        duplicate: 0.003,
    };
    let config = config(150.0, faults);
    let out = run(&config);
    let n = &out.board;
    let sum = |f: fn(&CanLinkStatus) -> u64| out.gateways.iter().map(|(_, s)| f(s)).sum::<u64>();
    println!("board {n:?}");
    for (d, s) in &out.gateways {
        println!("{d:?}: {s:?}");
    }
    assert!(
        n.injected_tx_drop > 20
            && n.injected_tx_corrupt > 20
            && n.injected_tx_delay > 10
            && n.injected_tx_duplicate > 10,
        "{n:?}"
    );
    // Sensor direction: every gateway sees every corrupted frame fail its check; a dropped or
    // corrupted frame is missed by the gateway of its device (a counter jump); duplicates and
    // late frames are seen by the gateway of their device.
    for (device, s) in &out.gateways {
        assert_eq!(s.crc_errors, n.injected_tx_corrupt, "{device:?}");
        assert_eq!(
            s.frames_bad,
            s.crc_errors + s.duplicates + s.late_frames,
            "{device:?}"
        );
    }
    assert_eq!(
        sum(|s| s.lost_frames),
        n.injected_tx_drop + n.injected_tx_corrupt
    );
    assert_eq!(sum(|s| s.duplicates), n.injected_tx_duplicate);
    assert_eq!(sum(|s| s.late_frames), n.injected_tx_delay);
    assert!(sum(|s| s.stale_samples) > 0);
    // Command direction, at the board.
    assert_eq!(n.crc_errors, n.injected_rx_corrupt);
    assert_eq!(n.lost_frames, n.injected_rx_drop + n.injected_rx_corrupt);
    assert_eq!(n.duplicates, n.injected_rx_duplicate);
    assert_eq!(n.late_frames, n.injected_rx_delay);
    assert!(out.stale_applied > 0);
    let gyro_stale = out.gateways[0].1.stale_samples;
    assert_eq!(out.estimator.gyro_held, gyro_stale);
    assert_eq!(
        out.estimates.len(),
        out.errors.len(),
        "one estimate per tick"
    );
    let settle = metrics::settling_time(&out.errors, 0.1).expect("settles");
    let steady = metrics::steady_max(&out.errors, 50.0);
    assert!(settle < 120.0, "settling {settle} s");
    assert!(
        steady[0].max(steady[1]) < 0.02 && steady[2] < 0.05,
        "steady {steady:?}"
    );
    // Seeded: the same run again gives the same estimates.
    assert_eq!(run(&config).estimates, out.estimates);
}
