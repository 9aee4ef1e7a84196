//! A chaos run: a paced simulation in which, once the platform has settled, a random non-plant
//! process is killed (kill -9) or hung (SIGSTOP) every 20–60 s, and restarted by the launcher.
//!
//! Checked: the platform never leaves a 1° band around its target after settling (the faults
//! put the controller in safe mode, which damps the rate, for a few seconds each); every
//! injected fault is in the log's health events and counted in the summary; nothing is left in
//! `/dev/shm` or `/tmp` by the run.
//!
//! Its own test binary, so no other test's files come and go in `/dev/shm` meanwhile. The chaos
//! lasts `TESTBED_CHAOS_S` seconds (default 600: ten minutes) after a 100 s settling phase.

use ipc_types::{HealthEvent, HealthEventKind, SimTruth};
use rand::{Rng, SeedableRng};
use std::collections::BTreeSet;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use testbed_e2e::{Scratch, binary, descendant, restarting_simulation_profile};
use testbed_flight::convert::quaternion_from_array;
use testbed_log::RunLog;
use testbed_model::attitude;
use testbed_model::config::DEG;

/// Simulated (and wall) time before the first fault: the default manoeuvre settles in ~80 s.
const SETTLE_S: u64 = 100;
/// Processes that may be hit.
const TARGETS: [&str; 7] = [
    "estimator",
    "controller",
    "sim-gyro",
    "sim-inclinometer",
    "sim-magnetometer",
    "sim-wheels",
    "sim-cmg",
];

fn entries(dir: &str, prefix: &str) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with(prefix))
                .collect()
        })
        .unwrap_or_default()
}

/// The simulation profile, paced, every process but the plant restarted up to 100 times.
fn chaos_profile(dir: &Path) -> std::path::PathBuf {
    restarting_simulation_profile(dir, "chaos.toml", "paced", 100)
}

#[test]
fn ten_minutes_of_random_kills_and_hangs_keep_the_platform_within_a_degree() {
    let chaos_s: u64 = std::env::var("TESTBED_CHAOS_S")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(600);
    let scratch = Scratch::new("chaos");
    let profile = chaos_profile(scratch.path());
    let log = scratch.path().join("chaos.mcap");
    let testbed = binary("testbed");
    let shm_before = entries("/dev/shm", "");
    let tmp_before = entries("/tmp", "tb");

    let duration = SETTLE_S + chaos_s;
    let child = Command::new(testbed)
        .args(["run", "--json", "--seed", "11"])
        .arg("--profile")
        .arg(&profile)
        .arg("--duration")
        .arg(duration.to_string())
        .arg("--max-wall")
        .arg((duration + 120).to_string())
        .arg("--log")
        .arg(&log)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting testbed run");
    let root = child.id();
    let started = Instant::now();
    // Fixed seed: the same fault programme every time.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    let mut next = Duration::from_secs(SETTLE_S);
    let mut injected: Vec<(&str, bool)> = Vec::new();
    let end = Duration::from_secs(duration.saturating_sub(10));
    while next < end {
        std::thread::sleep(next.saturating_sub(started.elapsed()));
        let program = TARGETS[rng.random_range(0..TARGETS.len())];
        let hang = rng.random_bool(0.5);
        if let Some(pid) = descendant(root, program) {
            let signal = if hang { libc::SIGSTOP } else { libc::SIGKILL };
            // SAFETY: kill has no memory-safety preconditions.
            if unsafe { libc::kill(pid as i32, signal) } == 0 {
                injected.push((program, hang));
            }
        }
        next += Duration::from_secs(rng.random_range(20..=60));
    }
    let out = child.wait_with_output().expect("waiting for the run");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "chaos run failed:\n{stderr}");
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON summary");
    assert_eq!(summary["interrupted"], false, "{summary}");
    assert!(!injected.is_empty());

    // Every fault is in the log and the summary.
    let run = RunLog::open(&log).unwrap();
    let events: Vec<HealthEvent> = run
        .samples::<HealthEvent>()
        .unwrap()
        .map(Result::unwrap)
        .collect();
    for kind_hang in [false, true] {
        let wanted = injected.iter().filter(|(_, h)| *h == kind_hang).count();
        let kind = if kind_hang {
            HealthEventKind::ProcessHung
        } else {
            HealthEventKind::ProcessExited
        };
        let seen = events.iter().filter(|e| e.kind() == Some(kind)).count();
        assert!(
            seen >= wanted,
            "{wanted} injected {kind:?}, {seen} in the log"
        );
    }
    let health = &summary["health"];
    let counted = health["hangs"].as_u64().unwrap() + health["process_exits"].as_u64().unwrap();
    assert!(counted as usize >= injected.len(), "{health}");
    assert!(health["restarts"].as_u64().unwrap() as usize >= injected.len());

    // Within 1° of the target from the settling time on.
    let config = testbed_config::RunConfig::from_toml_str(run.config_toml(), "log").unwrap();
    let target = config.manoeuvre.target();
    let worst = run
        .samples::<SimTruth>()
        .unwrap()
        .map(Result::unwrap)
        .filter(|t| t.header.time_ns >= SETTLE_S * 1_000_000_000)
        .filter_map(|t| quaternion_from_array(&t.quaternion))
        .map(|q| (attitude::attitude_error(&q, &target) / DEG).amax())
        .fold(0.0_f64, f64::max);
    assert!(
        worst < 1.0,
        "attitude error reached {worst:.3}° under chaos ({} faults)",
        injected.len()
    );
    eprintln!(
        "chaos: {} faults injected ({:?}), worst attitude error {worst:.4}°",
        injected.len(),
        injected
    );

    // Nothing left behind.
    let shm_after = entries("/dev/shm", "");
    let left: Vec<_> = shm_after.difference(&shm_before).collect();
    assert!(left.is_empty(), "left in /dev/shm: {left:?}");
    let tmp_after = entries("/tmp", "tb");
    let left: Vec<_> = tmp_after.difference(&tmp_before).collect();
    assert!(left.is_empty(), "bus roots left in /tmp: {left:?}");
}
