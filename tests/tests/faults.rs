//! Fault injection into running pipelines (real processes): kill -9 and SIGSTOP of each process
//! kind, in paced and lockstep runs, with the outcome the profile's policy promises.
//!
//! The profile is the simulation profile with every process but the plant restarted on exit
//! (`on_exit = "restart"`) and safe mode tolerated, so a paced run must recover; in lockstep a
//! death or hang must end the run with its cause named, never freeze it.
//!
//! Checked for every paced fault: the launcher reports the fault (exit or hang) and the restart;
//! the wheels never exceed 80 % of their speed limit; a lost estimate puts the controller in safe
//! mode within three control periods of the last estimate (it is detected at two); a lost
//! controller gets zero commands at the plant within three periods; the run completes and exits
//! 0; the log reads with Python `mcap`'s `make_reader` and holds the estimates up to the fault.

use ipc_types::{AttitudeEstimate, HealthEvent, HealthEventKind, SimTruth, WheelCommand};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use testbed_e2e::{Scratch, binary, descendant, restarting_simulation_profile};
use testbed_log::RunLog;

/// The control period of the default configuration, s.
const PERIOD_S: f64 = 0.1;
/// The wheels' speed limit, rpm (model default).
const WHEEL_LIMIT_RPM: f64 = 6000.0;
/// Wall time after the start when the fault is injected, s.
const FAULT_AT_S: u64 = 10;
/// How much longer the fault waits for its target process to start on a loaded machine.
const TARGET_WAIT: Duration = Duration::from_secs(10);
/// A simulated duration, s, that no run reaches before its fault, however fast the machine
/// (lockstep has run at over 2000× real time).
const OUTLASTS_THE_FAULT_S: u32 = 10_000_000;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Paced,
    Lockstep,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Fault {
    /// kill -9.
    Kill,
    /// SIGSTOP (the process hangs), SIGCONT after 3 s if it still exists.
    Stop,
}

/// The simulation profile, every process but the plant restarted up to 3 times, safe mode
/// tolerated, in `mode`.
fn fault_profile(dir: &Path, mode: Mode) -> PathBuf {
    let mode = match mode {
        Mode::Paced => "paced",
        Mode::Lockstep => "lockstep",
    };
    restarting_simulation_profile(dir, "faults.toml", mode, 3)
}

struct Outcome {
    success: bool,
    stderr: String,
    summary: Option<serde_json::Value>,
    wall: Duration,
}

/// Runs `profile` for `duration_s`, injecting `fault` into `program` at [`FAULT_AT_S`].
fn run_with_fault(
    profile: &Path,
    log: &Path,
    duration_s: u32,
    program: &str,
    fault: Fault,
) -> Outcome {
    // Resolved first: `binary` may build the workspace, which is not the run's wall time.
    let testbed = binary("testbed");
    let started = Instant::now();
    let mut child = Command::new(testbed)
        .args(["run", "--json", "--seed", "5", "--max-wall", "120"])
        .arg("--profile")
        .arg(profile)
        .arg("--duration")
        .arg(duration_s.to_string())
        .arg("--log")
        .arg(log)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting testbed run");
    std::thread::sleep(Duration::from_secs(FAULT_AT_S));
    let target = find_program(&mut child, program);
    let signal = match fault {
        Fault::Kill => libc::SIGKILL,
        Fault::Stop => libc::SIGSTOP,
    };
    // SAFETY: kill has no memory-safety preconditions.
    assert_eq!(
        unsafe { libc::kill(target as i32, signal) },
        0,
        "signalling {program}"
    );
    if fault == Fault::Stop {
        std::thread::sleep(Duration::from_secs(3));
        // SAFETY: as above; the process may be gone (killed as hung): then this fails harmlessly.
        unsafe { libc::kill(target as i32, libc::SIGCONT) };
    }
    // Read both pipes while waiting (a full pipe would block the run).
    let out = std::thread::scope(|s| {
        let mut stdout = child.stdout.take().expect("piped");
        let mut stderr = child.stderr.take().expect("piped");
        let o = s.spawn(move || {
            let mut buf = String::new();
            std::io::Read::read_to_string(&mut stdout, &mut buf).ok();
            buf
        });
        let e = s.spawn(move || {
            let mut buf = String::new();
            std::io::Read::read_to_string(&mut stderr, &mut buf).ok();
            buf
        });
        let status = child.wait().expect("waiting for testbed run");
        (status, o.join().unwrap(), e.join().unwrap())
    });
    let (status, stdout, stderr) = out;
    Outcome {
        success: status.success(),
        stderr,
        summary: serde_json::from_str(&stdout).ok(),
        wall: started.elapsed(),
    }
}

/// The pid of `program` under the run `child`, waited for up to [`TARGET_WAIT`]; a run that
/// ended, or a program not found, fails the test with what the run said.
fn find_program(child: &mut std::process::Child, program: &str) -> u32 {
    let root = child.id();
    let deadline = Instant::now() + TARGET_WAIT;
    loop {
        if let Some(pid) = descendant(root, program) {
            return pid;
        }
        let ended = child.try_wait().expect("polling testbed run");
        if ended.is_some() || Instant::now() > deadline {
            child.kill().ok();
            let status = child.wait().expect("waiting for testbed run");
            let mut stderr = String::new();
            if let Some(mut pipe) = child.stderr.take() {
                std::io::Read::read_to_string(&mut pipe, &mut stderr).ok();
            }
            panic!("no {program} process under testbed (pid {root}, {status}):\n{stderr}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Every message of the log through Python `mcap`'s indexed reader; the count.
fn python_reads(log: &Path) -> usize {
    let script = "import sys\nfrom mcap.reader import make_reader\n\
                  with open(sys.argv[1], 'rb') as f:\n    \
                  print(sum(1 for _ in make_reader(f).iter_messages()))";
    let out = Command::new("python3")
        .args(["-c", script])
        .arg(log)
        .output()
        .expect("python3");
    assert!(
        out.status.success(),
        "Python mcap's make_reader cannot read {}: {}",
        log.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).trim().parse().unwrap()
}

fn samples<T: testbed_log::LogEncode>(log: &Path) -> Vec<T> {
    RunLog::open(log)
        .unwrap()
        .samples::<T>()
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

fn events(log: &Path, kind: HealthEventKind) -> Vec<HealthEvent> {
    samples::<HealthEvent>(log)
        .into_iter()
        .filter(|e| e.kind() == Some(kind))
        .collect()
}

fn seconds(t_ns: u64) -> f64 {
    t_ns as f64 * 1e-9
}

/// The latest time of `times` before `t_ns`.
fn last_before(times: impl Iterator<Item = u64>, t_ns: u64) -> Option<u64> {
    times.filter(|&t| t < t_ns).max()
}

fn paced(program: &str, fault: Fault) {
    let scratch = Scratch::new(&format!("fault-{program}-{fault:?}"));
    let profile = fault_profile(scratch.path(), Mode::Paced);
    let log = scratch.path().join("run.mcap");
    let outcome = run_with_fault(&profile, &log, 30, program, fault);
    let stderr = &outcome.stderr;
    assert!(
        outcome.success,
        "the run should recover from {fault:?} of {program}:\n{stderr}"
    );
    let summary = outcome.summary.expect("a JSON summary");

    // The launcher saw the fault and restarted the process.
    let subject = |e: &HealthEvent| e.subject() == program;
    let seen = match fault {
        Fault::Kill => events(&log, HealthEventKind::ProcessExited),
        Fault::Stop => events(&log, HealthEventKind::ProcessHung),
    };
    let logger = program == "logger";
    if !logger {
        // (A killed logger's own log lacks what happened while it was down: see the segment.)
        assert!(seen.iter().any(subject), "no {fault:?} event for {program}");
        assert!(
            events(&log, HealthEventKind::ProcessRestarted)
                .iter()
                .any(subject),
            "{program} not restarted"
        );
    }
    let hangs = summary["health"]["hangs"].as_u64().unwrap();
    let exits = summary["health"]["process_exits"].as_u64().unwrap();
    if !logger {
        assert!(hangs + exits >= 1, "{summary}");
        assert_eq!(summary["health"]["marked"], true);
    }

    // The wheels never beyond 80 % of their limit.
    let truths = samples::<SimTruth>(&log);
    let peak = truths
        .iter()
        .flat_map(|t| t.wheel_speed)
        .fold(0.0_f64, |m, w| m.max(w.abs()))
        * 60.0
        / (2.0 * std::f64::consts::PI);
    assert!(peak < 0.8 * WHEEL_LIMIT_RPM, "wheel at {peak:.0} rpm");

    // Safe torque within three periods of the last input.
    let estimates: Vec<u64> = samples::<AttitudeEstimate>(&log)
        .iter()
        .map(|e| e.header.time_ns)
        .collect();
    match program {
        "estimator" | "sim-gyro" => {
            let entered = events(&log, HealthEventKind::SafeModeEntered);
            let first = entered.first().expect("safe mode entered").header.time_ns;
            let last = last_before(estimates.iter().copied(), first).expect("an estimate first");
            let delay = seconds(first - last);
            assert!(
                delay <= 3.0 * PERIOD_S + 1e-6,
                "safe mode {delay:.2} s after the last estimate"
            );
            assert!(
                !events(&log, HealthEventKind::SafeModeLeft).is_empty(),
                "safe mode never left after the recovery"
            );
        }
        "controller" => {
            let zeroed = events(&log, HealthEventKind::CommandsZeroed);
            let first = zeroed.first().expect("commands zeroed").header.time_ns;
            let commands = samples::<WheelCommand>(&log);
            let last = last_before(commands.iter().map(|c| c.header.time_ns), first)
                .expect("a command first");
            let delay = seconds(first - last);
            assert!(
                delay <= 3.0 * PERIOD_S + 1e-6,
                "zero commands {delay:.2} s after the last command"
            );
            assert!(!events(&log, HealthEventKind::CommandsResumed).is_empty());
        }
        "sim-wheels" => {
            let entered = events(&log, HealthEventKind::SafeModeEntered);
            assert!(
                entered.iter().any(|e| e.detail & 4 != 0),
                "no safe mode for lost wheel telemetry"
            );
        }
        _ => {}
    }

    // The run went on to its end, and its log is readable and complete up to the fault.
    assert_eq!(summary["interrupted"], false, "{summary}");
    assert!(python_reads(&log) > 0);
    let fault_t = FAULT_AT_S as f64 - 3.0; // start-up takes well under 3 s
    assert!(
        estimates.iter().any(|&t| seconds(t) >= fault_t),
        "estimates up to the fault are missing"
    );
    if logger {
        let segments = summary["health"]["segments"].as_array().unwrap();
        assert_eq!(segments.len(), 1, "{summary}");
        assert!(python_reads(Path::new(segments[0].as_str().unwrap())) > 0);
    }
}

fn lockstep(program: &str, fault: Fault) {
    let scratch = Scratch::new(&format!("fault-ls-{program}-{fault:?}"));
    let profile = fault_profile(scratch.path(), Mode::Lockstep);
    let log = scratch.path().join("run.mcap");
    let outcome = run_with_fault(&profile, &log, OUTLASTS_THE_FAULT_S, program, fault);
    let stderr = &outcome.stderr;
    assert!(
        !outcome.success,
        "a lockstep run cannot go on without {program}:\n{stderr}"
    );
    assert!(
        outcome.wall < Duration::from_secs(FAULT_AT_S + 30),
        "the run took {:?}: frozen?",
        outcome.wall
    );
    assert!(
        stderr.contains(&format!("\"{program}\"")) && stderr.contains("lockstep"),
        "the cause is not named:\n{stderr}"
    );
    if program != "logger" {
        let aborted = events(&log, HealthEventKind::RunAborted);
        assert!(
            aborted.iter().any(|e| e.subject() == program),
            "no run-aborted event naming {program}"
        );
        assert!(python_reads(&log) > 0);
    }
}

macro_rules! fault_tests {
    ($($name:ident: $mode:ident, $program:literal, $fault:ident;)*) => {$(
        #[test]
        fn $name() {
            $mode($program, Fault::$fault);
        }
    )*};
}

fault_tests! {
    paced_kill_estimator: paced, "estimator", Kill;
    paced_stop_estimator: paced, "estimator", Stop;
    paced_kill_controller: paced, "controller", Kill;
    paced_stop_controller: paced, "controller", Stop;
    paced_kill_gyro_gateway: paced, "sim-gyro", Kill;
    paced_stop_gyro_gateway: paced, "sim-gyro", Stop;
    paced_kill_wheel_gateway: paced, "sim-wheels", Kill;
    paced_stop_wheel_gateway: paced, "sim-wheels", Stop;
    lockstep_kill_estimator: lockstep, "estimator", Kill;
    lockstep_stop_controller: lockstep, "controller", Stop;
    lockstep_kill_gyro_gateway: lockstep, "sim-gyro", Kill;
    lockstep_stop_wheel_gateway: lockstep, "sim-wheels", Stop;
    lockstep_kill_logger: lockstep, "logger", Kill;
}

/// The plant owns the clock: killed or hung, it ends the run with its name, in both modes.
#[test]
fn a_dead_or_hung_plant_ends_the_run_with_its_name() {
    for (mode, fault) in [(Mode::Paced, Fault::Stop), (Mode::Lockstep, Fault::Kill)] {
        let scratch = Scratch::new(&format!("fault-plant-{mode:?}"));
        let profile = fault_profile(scratch.path(), mode);
        let log = scratch.path().join("run.mcap");
        let outcome = run_with_fault(&profile, &log, OUTLASTS_THE_FAULT_S, "plant", fault);
        assert!(!outcome.success, "{mode:?}: {}", outcome.stderr);
        assert!(
            outcome.stderr.contains("\"plant\""),
            "{mode:?}: cause not named:\n{}",
            outcome.stderr
        );
        assert!(outcome.wall < Duration::from_secs(FAULT_AT_S + 30));
        assert!(python_reads(&log) > 0);
    }
}
