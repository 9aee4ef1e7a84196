//! The real platform path as it runs: the five CAN gateways on the software CAN bus, fed by the
//! simulated CAN board (`testbed run --profile can-sim`), with and without bus faults, and
//! a recorded bus replayed through the gateways.

use ipc_types::{
    AttitudeEstimate, CanLinkStatus, GyroSample, Heartbeat, InclinometerSample, MagnetometerSample,
    can_source,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use testbed_e2e::{Scratch, pinned_lockstep_run, profile, testbed_run};
use testbed_log::{LogEncode, RunLog};

fn number(json: &serde_json::Value, key: &str) -> f64 {
    json[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in {json}"))
}

/// The paper's bounds, as for the simulated gateways.
fn assert_stabilises(summary: &serde_json::Value) {
    assert!(number(summary, "settle_s") < 120.0, "{summary}");
    assert!(number(summary, "steady_xy_deg") < 0.02, "{summary}");
    assert!(number(summary, "steady_z_deg") < 0.05, "{summary}");
    assert_eq!(number(summary, "deadline_misses"), 0.0, "{summary}");
    assert_eq!(summary["log_complete"], true, "{summary}");
}

/// A copy of the can-sim profile in `dir` whose run configuration has these bus faults.
fn can_sim_with_faults(dir: &Path, drop: f64, corrupt: f64, delay: f64, duplicate: f64) -> PathBuf {
    let shipped = profile("can-sim");
    let text = std::fs::read_to_string(&shipped).unwrap();
    let copy = dir.join("can-faults.toml");
    std::fs::write(
        &copy,
        text.replace(
            "config = \"../run-configs/can-sim.run.toml\"",
            "config = \"can-faults.run.toml\"",
        ),
    )
    .unwrap();
    let run = std::fs::read_to_string(
        shipped
            .parent()
            .unwrap()
            .join("../run-configs/can-sim.run.toml"),
    )
    .unwrap();
    let run = run
        .replace("drop = 0.0\n", &format!("drop = {drop}\n"))
        .replace("corrupt = 0.0\n", &format!("corrupt = {corrupt}\n"))
        .replace("delay = 0.0\n", &format!("delay = {delay}\n"))
        .replace("duplicate = 0.0\n", &format!("duplicate = {duplicate}\n"));
    std::fs::write(dir.join("can-faults.run.toml"), run).unwrap();
    copy
}

fn samples<T: LogEncode>(log: &Path) -> Vec<T> {
    RunLog::open(log)
        .unwrap()
        .samples::<T>()
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

/// The last status of every CAN link in the log, by `can_source`.
fn last_status(log: &Path) -> BTreeMap<u32, CanLinkStatus> {
    samples::<CanLinkStatus>(log)
        .into_iter()
        .map(|s| (s.header.source_id, s))
        .collect()
}

/// Every line is a `candump -L` frame line: `(seconds.micros) iface ID#DATA`.
fn assert_candump_lines(path: &Path) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    for line in text.lines() {
        let mut parts = line.split(' ');
        let (time, iface, frame) = (
            parts.next().unwrap(),
            parts.next().unwrap_or(""),
            parts.next().unwrap_or(""),
        );
        assert!(parts.next().is_none(), "{line}");
        let digits = time.trim_start_matches('(').trim_end_matches(')');
        let (secs, micros) = digits.split_once('.').unwrap_or_else(|| panic!("{line}"));
        assert!(
            secs.len() == 10 && micros.len() == 6 && time.starts_with('(') && time.ends_with(')'),
            "{line}"
        );
        assert_eq!(iface, "can0", "{line}");
        let (id, data) = frame.split_once('#').unwrap_or_else(|| panic!("{line}"));
        assert!(
            id.len() == 3 && u16::from_str_radix(id, 16).is_ok_and(|id| id <= 0x7FF),
            "{line}"
        );
        assert!(
            data.len() % 2 == 0 && data.len() <= 16 && data.bytes().all(|b| b.is_ascii_hexdigit()),
            "{line}"
        );
    }
    text.lines().count()
}

#[test]
fn can_sim_gateways_on_the_simulated_can_board_stabilise_like_the_simulated_gateways() {
    let scratch = Scratch::new("can-sim150");
    let log = scratch.path().join("can.mcap");
    let can = testbed_run(&[
        "--profile",
        profile("can-sim").to_str().unwrap(),
        "--duration",
        "150",
        "--seed",
        "3",
        "--log",
        log.to_str().unwrap(),
    ]);
    assert_stabilises(&can);
    let sim_log = scratch.path().join("sim.mcap");
    let sim = testbed_run(&[
        "--profile",
        profile("simulation").to_str().unwrap(),
        "--duration",
        "150",
        "--seed",
        "3",
        "--log",
        sim_log.to_str().unwrap(),
    ]);
    // Same device models and seeds; the CAN path only adds the protocol's quantisation.
    assert!(
        (number(&can, "settle_s") - number(&sim, "settle_s")).abs() < 5.0,
        "{can}\n{sim}"
    );
    assert_eq!(number(&can, "ticks"), 1501.0);
    assert_eq!(number(&can, "estimates"), 1501.0);

    // Every link clean: every frame decoded, nothing stale, nothing lost.
    let status = last_status(&log);
    assert_eq!(
        status.keys().copied().collect::<Vec<_>>(),
        (can_source::NODE..=can_source::CMG).collect::<Vec<_>>()
    );
    for (source, s) in &status {
        assert_eq!(
            (
                s.frames_bad,
                s.lost_frames,
                s.stale_samples,
                s.transport_errors
            ),
            (0, 0, 0, 0),
            "link {source}: {s:?}"
        );
        assert!(s.frames_ok > 0, "link {source}: {s:?}");
    }
    // The sensor samples are the simulated gateways' (same topics, times and seeds), to the
    // protocol's resolution.
    let (can_gyro, sim_gyro) = (samples::<GyroSample>(&log), samples::<GyroSample>(&sim_log));
    assert_eq!(can_gyro.len(), sim_gyro.len());
    let lsb = 1e-5 * std::f64::consts::PI / 180.0;
    for (c, s) in can_gyro.iter().zip(&sim_gyro).take(10) {
        assert_eq!(c.header.time_ns, s.header.time_ns);
        assert!(
            c.rate
                .iter()
                .zip(&s.rate)
                .all(|(a, b)| (a - b).abs() <= lsb),
            "{c:?} vs {s:?}"
        );
    }
    assert_eq!(
        samples::<InclinometerSample>(&log).len(),
        samples::<InclinometerSample>(&sim_log).len()
    );
    assert_eq!(
        samples::<MagnetometerSample>(&log).len(),
        samples::<MagnetometerSample>(&sim_log).len()
    );
    // The bus went to a candump -L file as well.
    let lines = assert_candump_lines(&log.with_extension("candump.log"));
    assert!(lines > 1500 * 15, "{lines} frames");
}

#[test]
fn with_one_percent_of_frames_dropped_or_corrupted_the_loop_stabilises_and_every_fault_is_counted()
{
    let scratch = Scratch::new("can-faults");
    // 0.5 % dropped + 0.5 % corrupted, and a few delayed past their tick and duplicated.
    let profile = can_sim_with_faults(scratch.path(), 0.005, 0.005, 0.002, 0.002);
    let log = scratch.path().join("faults.mcap");
    let summary = testbed_run(&[
        "--profile",
        profile.to_str().unwrap(),
        "--duration",
        "150",
        "--seed",
        "4",
        "--log",
        log.to_str().unwrap(),
    ]);
    assert_stabilises(&summary);
    assert_eq!(number(&summary, "estimates"), 1501.0, "every tick answered");

    let status = last_status(&log);
    let board = status[&can_source::NODE];
    assert!(
        board.injected_tx_drop > 30 && board.injected_tx_corrupt > 30,
        "{board:?}"
    );
    assert!(
        board.injected_tx_delay > 0 && board.injected_tx_duplicate > 0,
        "{board:?}"
    );
    let gateways: Vec<&CanLinkStatus> = (can_source::GYRO..=can_source::CMG)
        .map(|s| &status[&s])
        .collect();
    let sum = |f: fn(&CanLinkStatus) -> u64| gateways.iter().map(|s| f(s)).sum::<u64>();
    // Frames from the board: every gateway's frame check catches every corrupted frame; the
    // gateway of the frame's device sees each dropped or corrupted frame as a rolling-counter
    // gap, each duplicate, and each frame delayed past its tick's sync.
    for s in &gateways {
        assert_eq!(s.crc_errors, board.injected_tx_corrupt, "{s:?}");
        assert_eq!(
            s.frames_bad,
            s.crc_errors + s.duplicates + s.late_frames + s.wrong_dlc + s.unknown_id,
            "{s:?}"
        );
    }
    assert_eq!(
        sum(|s| s.lost_frames),
        board.injected_tx_drop + board.injected_tx_corrupt
    );
    assert_eq!(sum(|s| s.duplicates), board.injected_tx_duplicate);
    assert_eq!(sum(|s| s.late_frames), board.injected_tx_delay);
    assert!(
        sum(|s| s.stale_samples) > 0,
        "incomplete samples were published stale"
    );
    // Frames to the board (commands), counted by the board's receiver.
    assert_eq!(board.crc_errors, board.injected_rx_corrupt, "{board:?}");
    assert_eq!(
        board.lost_frames,
        board.injected_rx_drop + board.injected_rx_corrupt,
        "{board:?}"
    );
    assert_eq!(board.duplicates, board.injected_rx_duplicate, "{board:?}");
    assert_eq!(board.late_frames, board.injected_rx_delay, "{board:?}");
    // Every stale gyro sample was propagated with the held rate, not skipped.
    assert_eq!(samples::<AttitudeEstimate>(&log).len(), 1501);
}

#[test]
fn can_sim_with_faults_is_byte_identical_run_to_run() {
    let scratch = Scratch::new("can-determinism");
    let profile = can_sim_with_faults(scratch.path(), 0.01, 0.01, 0.005, 0.005);
    let log = scratch.path().join("run.mcap");
    let mut runs = Vec::new();
    for _ in 0..2 {
        pinned_lockstep_run(&profile, &log, 12);
        runs.push((
            std::fs::read(&log).unwrap(),
            std::fs::read(log.with_extension("candump.log")).unwrap(),
        ));
    }
    assert!(runs[0].0.len() > 100_000 && runs[0].1.len() > 10_000);
    assert!(runs[0].0 == runs[1].0, "lockstep logs differ");
    assert!(runs[0].1 == runs[1].1, "candump files differ");
}

#[test]
fn replaying_a_recorded_candump_file_through_the_gateways_reproduces_the_estimates() {
    let scratch = Scratch::new("can-replay");
    // Record a run with bus faults, so the replay meets stale, late and duplicated frames too.
    let profile = can_sim_with_faults(scratch.path(), 0.01, 0.01, 0.005, 0.005);
    let recorded = scratch.path().join("recorded.mcap");
    testbed_run(&[
        "--profile",
        profile.to_str().unwrap(),
        "--duration",
        "40",
        "--seed",
        "21",
        "--log",
        recorded.to_str().unwrap(),
    ]);
    let candump = recorded.with_extension("candump.log");
    assert_candump_lines(&candump);

    // The replay: can-replay puts the file back on the software bus, the three sensor gateways
    // decode it, the estimator estimates; no plant, no board (`launch/profiles/can-replay.toml`).
    let replayed = scratch.path().join("replayed.mcap");
    let comparison = testbed_run(&[
        "--replay-candump",
        recorded.to_str().unwrap(),
        "--log",
        replayed.to_str().unwrap(),
    ]);
    assert_eq!(number(&comparison, "recorded"), 401.0);
    assert_eq!(number(&comparison, "replayed"), 401.0);
    assert_eq!(number(&comparison, "identical"), 401.0, "{comparison}");
    // A log without its bus recording is refused, naming the file it lacks.
    let refused = std::process::Command::new(testbed_e2e::binary("testbed"))
        .args(["run", "--replay-candump", replayed.to_str().unwrap()])
        .output()
        .unwrap();
    let message = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && message.contains("replayed.candump.log"),
        "{message}"
    );

    let original = samples::<AttitudeEstimate>(&recorded);
    let replay = samples::<AttitudeEstimate>(&replayed);
    assert_eq!(original.len(), 401);
    assert_eq!(replay.len(), original.len());
    for (r, o) in replay.iter().zip(&original) {
        assert_eq!(r, o, "t = {} s", o.header.time_ns as f64 * 1e-9);
    }
    assert_eq!(
        samples::<GyroSample>(&replayed),
        samples::<GyroSample>(&recorded)
    );
    assert_eq!(
        samples::<InclinometerSample>(&replayed),
        samples::<InclinometerSample>(&recorded)
    );
    assert_eq!(
        samples::<MagnetometerSample>(&replayed),
        samples::<MagnetometerSample>(&recorded)
    );
    // The recorded faults reached the replay: stale gyro samples are in both.
    assert!(
        samples::<GyroSample>(&recorded)
            .iter()
            .any(|g| !g.header.is_valid())
    );
}

#[test]
fn paced_can_sim_publishes_as_frames_arrive_and_reports_frame_counters_in_heartbeats() {
    let scratch = Scratch::new("can-paced");
    let log = scratch.path().join("paced.mcap");
    let summary = testbed_run(&[
        "--profile",
        profile("can-sim").to_str().unwrap(),
        "--paced",
        "--duration",
        "6",
        "--log",
        log.to_str().unwrap(),
    ]);
    assert_eq!(summary["log_complete"], true, "{summary}");
    assert!(number(&summary, "estimates") > 40.0, "{summary}");
    // Paced runs log heartbeats: the gateways' carry their frame counters.
    let heartbeats = samples::<Heartbeat>(&log);
    for name in [
        "gyro-gateway",
        "inclinometer-gateway",
        "magnetometer-gateway",
        "wheel-gateway",
        "cmg-gateway",
        "sim-can-node",
    ] {
        let last = heartbeats
            .iter()
            .rev()
            .find(|h| h.name() == name)
            .unwrap_or_else(|| panic!("no heartbeat of {name}"));
        assert!(last.frames_ok > 10, "{name}: {last:?}");
        assert_eq!(last.frames_bad, 0, "{name}: {last:?}");
    }
}
