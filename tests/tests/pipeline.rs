//! The process pipeline as the platform runs it: `testbed run` launches the simulation profile
//! as separate processes over iceoryx2 and the tests read back what they logged.

use ipc_types::AttitudeEstimate;
use ipc_types::Topic as _;
use std::os::unix::process::CommandExt;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use testbed_e2e::{
    Scratch, assert_log_equals_the_in_process_loop, binary, pinned_lockstep_run, profile,
    testbed_run,
};
use testbed_log::{LogRecord, RunLog};

fn number(json: &serde_json::Value, key: &str) -> f64 {
    json[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in {json}"))
}

#[test]
fn simulation_profile_stabilises_and_its_estimates_equal_the_in_process_loop() {
    let scratch = Scratch::new("pipeline150");
    let log = scratch.path().join("sim.mcap");
    let sim = profile("simulation");
    let summary = testbed_run(&[
        "--profile",
        sim.to_str().unwrap(),
        "--duration",
        "150",
        "--seed",
        "3",
        "--log",
        log.to_str().unwrap(),
    ]);
    // The paper's bounds, as for the in-process loop: level within about 100 s (0.1° band),
    // steady error below 0.02° on X/Y and 0.05° on Z.
    assert!(number(&summary, "settle_s") < 120.0, "{summary}");
    assert!(number(&summary, "steady_xy_deg") < 0.02, "{summary}");
    assert!(number(&summary, "steady_z_deg") < 0.05, "{summary}");
    assert_eq!(number(&summary, "deadline_misses"), 0.0);
    assert_eq!(summary["log_complete"], true);

    // The same run in one process, from the configuration the log carries. Same code, same
    // inputs, same order: the processes compute bit for bit what the in-process loop computes.
    assert_log_equals_the_in_process_loop(&RunLog::open(&log).unwrap());
}

#[test]
fn two_lockstep_runs_with_the_same_seed_give_byte_identical_logs() {
    let scratch = Scratch::new("determinism");
    let sim = profile("simulation");
    // The log stores the run configuration, log path included: both runs write the same path.
    let log = scratch.path().join("run.mcap");
    let mut bytes = Vec::new();
    for _ in 0..2 {
        pinned_lockstep_run(&sim, &log, 11);
        bytes.push(std::fs::read(&log).unwrap());
    }
    assert!(bytes[0].len() > 10_000, "the log holds the run");
    // The log's times are on the pinned start (testbed-log's tests check the indexing).
    let opened = RunLog::open(&log).unwrap();
    assert_eq!(opened.info().start_time_ns, 1_795_503_600_000_000_000);
    assert!(opened.is_complete());
    assert!(
        bytes[0] == bytes[1],
        "lockstep logs differ ({} vs {} bytes)",
        bytes[0].len(),
        bytes[1].len()
    );
}

#[test]
fn the_simulated_gateways_in_one_process_publish_what_five_processes_do() {
    let scratch = Scratch::new("grouped");
    let mut runs = Vec::new();
    for name in ["simulation", "simulation-grouped"] {
        let log = scratch.path().join(format!("{name}.mcap"));
        pinned_lockstep_run(&profile(name), &log, 11);
        let opened = RunLog::open(&log).unwrap();
        assert!(opened.is_complete(), "{name}");
        // Heartbeats and health events name their process: the only records that may differ.
        let records: Vec<LogRecord> = opened
            .records()
            .unwrap()
            .map(Result::unwrap)
            .filter(|r| !matches!(r, LogRecord::Heartbeat(_) | LogRecord::Health(_)))
            .collect();
        runs.push(records);
    }
    let count =
        |records: &[LogRecord], topic: &str| records.iter().filter(|r| r.topic() == topic).count();
    // 40 s at 10 Hz: 400 gyro samples and 100 of each 2.5-Hz vector sensor, in both runs.
    for records in &runs {
        assert!(count(records, ipc_types::GyroSample::NAME) >= 400);
        assert!(count(records, ipc_types::MagnetometerSample::NAME) >= 100);
        assert!(count(records, ipc_types::CmgTelemetry::NAME) >= 400);
    }
    if let Some(i) = (0..runs[0].len().min(runs[1].len())).find(|&i| runs[0][i] != runs[1][i]) {
        panic!(
            "record {i} differs:\n  five processes: {:?}\n  one process:    {:?}",
            runs[0][i], runs[1][i]
        );
    }
    assert_eq!(runs[0].len(), runs[1].len(), "record counts");
}

/// Processes whose environment names a bus prefix starting with `prefix` (`tb<pid>_`: a run's
/// prefix is `tb<pid>_<random>_`).
fn processes_on_bus(prefix: &str) -> Vec<u32> {
    let needle = format!("TESTBED_BUS_PREFIX={prefix}");
    std::fs::read_dir("/proc")
        .unwrap()
        .flatten()
        .filter_map(|e| e.file_name().to_str().and_then(|n| n.parse::<u32>().ok()))
        .filter(|pid| {
            std::fs::read(format!("/proc/{pid}/environ")).is_ok_and(|env| {
                env.split(|b| *b == 0)
                    .any(|var| var.starts_with(needle.as_bytes()))
            })
        })
        .collect()
}

#[test]
fn sigint_stops_every_process_removes_the_bus_and_finalises_the_log() {
    let scratch = Scratch::new("sigint");
    let log = scratch.path().join("paced.mcap");
    let sim = profile("simulation");
    // Paced: the run would last 10 minutes; Ctrl-C (SIGINT to the foreground process group)
    // stops it after a few seconds.
    let child = Command::new(binary("testbed"))
        .args([
            "run",
            "--paced",
            "--duration",
            "600",
            "--json",
            "--profile",
            sim.to_str().unwrap(),
            "--log",
            log.to_str().unwrap(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()
        .unwrap();
    let prefix = format!("tb{}_", child.id());
    let start = Instant::now();
    while processes_on_bus(&prefix).len() < 9 {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the pipeline did not come up"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_secs(3));
    // SAFETY: kill(2) on the process group we created.
    assert_eq!(unsafe { libc::kill(-(child.id() as i32), libc::SIGINT) }, 0);
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    assert_eq!(
        processes_on_bus(&prefix),
        Vec::<u32>::new(),
        "processes survived the stop"
    );
    let shm: Vec<_> = std::fs::read_dir("/dev/shm")
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .map(|e| e.file_name())
        .collect();
    assert!(shm.is_empty(), "stale shared memory: {shm:?}");
    // The run's private bus root, /tmp/tb<pid>_<random>.
    let roots: Vec<_> = std::fs::read_dir("/tmp")
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .map(|e| e.path())
        .collect();
    assert!(roots.is_empty(), "the bus root was left behind: {roots:?}");
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(summary["log_complete"], true, "{summary}");
    let simulated = number(&summary, "simulated_s");
    assert!(
        simulated > 1.0 && simulated < 60.0,
        "a paced run of a few seconds: {summary}"
    );
    let run_log = RunLog::open(&log).unwrap();
    assert!(run_log.is_complete());
    assert!(run_log.samples::<AttitudeEstimate>().unwrap().count() > 10);
}

#[test]
fn a_paced_run_shows_its_progress_read_from_the_growing_log() {
    let scratch = Scratch::new("progress");
    let log = scratch.path().join("paced.mcap");
    let sim = profile("simulation");
    // stderr is not a terminal here: a plain line every 10 s of wall time.
    let out = Command::new(binary("testbed"))
        .args([
            "run",
            "--paced",
            "--duration",
            "14",
            "--json",
            "--profile",
            sim.to_str().unwrap(),
            "--log",
            log.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let line = stderr
        .lines()
        .find_map(|l| l.strip_prefix("testbed run: "))
        .unwrap_or_else(|| panic!("no progress line in {stderr}"));
    // "9.8 of 14 simulated s, 1.0× real time, true attitude error X +3.4° Y +4.9° Z +16.9°"
    let (time, rest) = line
        .split_once(" of 14 simulated s, ")
        .unwrap_or_else(|| panic!("{line}"));
    let t_s: f64 = time.parse().unwrap_or_else(|_| panic!("{line}"));
    // Ten seconds of wall time into a paced run that started ticking after its processes came
    // up: some simulated seconds, not the end.
    assert!((1.0..14.0).contains(&t_s), "{line}");
    let error = rest
        .split_once("true attitude error ")
        .unwrap_or_else(|| panic!("{line}"))
        .1;
    let degrees: Vec<f64> = error
        .split_whitespace()
        .filter_map(|w| w.trim_end_matches('°').parse().ok())
        .collect();
    assert_eq!(degrees.len(), 3, "{line}");
    // The run starts 20° off in heading and 5° in pitch and roll, and is still turning.
    assert!(degrees.iter().any(|d| d.abs() > 1.0), "{line}");

    // Every message is stamped with the time it describes. A paced log holds the heartbeats
    // (a lockstep one leaves them out): once its process has handled samples, none is stamped
    // 0, the logger's and the ground link's included.
    let run_log = RunLog::open(&log).unwrap();
    let mut stamped = std::collections::BTreeSet::new();
    for hb in run_log.samples::<ipc_types::Heartbeat>().unwrap() {
        let hb = hb.unwrap();
        if hb.header.sequence >= 3 {
            assert!(
                hb.header.time_ns > 0,
                "heartbeat {} of {} stamped 0",
                hb.header.sequence,
                hb.name()
            );
            stamped.insert(hb.name().to_owned());
        }
    }
    for process in ["logger", "ground-link"] {
        assert!(
            stamped.iter().any(|n| n.contains(process)),
            "no later heartbeat of {process}: {stamped:?}"
        );
    }
    // So the chunks are disjoint in time, within one flush interval each, none before the
    // run's start.
    let start = run_log.info().start_time_ns;
    let ranges = testbed_log::chunk_time_ranges(&log).unwrap();
    assert!(ranges.len() >= 2, "{ranges:?}");
    for (i, &(begin, end)) in ranges.iter().enumerate() {
        assert!(begin >= start, "chunk {i} before the start: {ranges:?}");
        assert!(
            end - begin < testbed_log::CHUNK_INTERVAL_NS,
            "chunk {i} longer than one interval: {ranges:?}"
        );
        assert!(
            i == 0 || begin > ranges[i - 1].1,
            "chunk {i} overlaps the one before: {ranges:?}"
        );
    }
}

#[test]
fn replaying_a_log_reproduces_its_estimates_and_commands() {
    let scratch = Scratch::new("replay");
    let original = scratch.path().join("original.mcap");
    let replayed = scratch.path().join("replayed.mcap");
    let sim = profile("simulation");
    testbed_run(&[
        "--profile",
        sim.to_str().unwrap(),
        "--duration",
        "60",
        "--seed",
        "21",
        "--log",
        original.to_str().unwrap(),
    ]);
    let replay = profile("replay");
    let summary = testbed_run(&[
        "--profile",
        replay.to_str().unwrap(),
        "--replay",
        original.to_str().unwrap(),
        "--log",
        replayed.to_str().unwrap(),
    ]);
    assert_eq!(summary["ticks"], 601, "{summary}");
    let read = |path: &std::path::Path| {
        let log = RunLog::open(path).unwrap();
        let estimates: Vec<AttitudeEstimate> = log.samples().unwrap().map(Result::unwrap).collect();
        let commands: Vec<ipc_types::WheelCommand> =
            log.samples().unwrap().map(Result::unwrap).collect();
        (estimates, commands)
    };
    let (estimates, commands) = read(&original);
    let (estimates_again, commands_again) = read(&replayed);
    assert_eq!(estimates.len(), 601);
    assert_eq!(
        estimates, estimates_again,
        "the replayed estimator computed something else"
    );
    assert_eq!(
        commands, commands_again,
        "the replayed controller computed something else"
    );
}
