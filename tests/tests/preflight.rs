//! The pre-flight check with the real executables on this computer, which has no CAN interface
//! (its kernel has no SocketCAN): `testbed run --profile platform` says in one message that
//! `can0` is missing and how to bring it up, exits with status 2 and starts and writes nothing;
//! and a process's own error (a gateway without its interface) is one line, without backtrace.

use std::os::unix::process::CommandExt as _;
use std::path::Path;
use std::process::{Command, Output, Stdio};

use testbed_e2e::{Scratch, binary};

/// Whether this computer has a network interface `name` (the test's premise).
fn has_interface(name: &str) -> bool {
    Path::new("/sys/class/net").join(name).exists()
}

/// `testbed run --profile platform` with `extra` arguments, from `dir` (where the profile's
/// relative log, `out/platform.mcap`, would go): its pid and what it printed.
fn run_platform(dir: &Path, extra: &[&str]) -> (u32, Output) {
    let child = Command::new(binary("testbed"))
        .args(["run", "--profile", "platform", "--duration", "5"])
        .args(extra)
        .current_dir(dir)
        // What would make a started launcher and its processes speak, and a backtrace print.
        .env("RUST_LOG", "info")
        .env("RUST_BACKTRACE", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("running testbed run");
    let pid = child.id();
    (
        pid,
        child.wait_with_output().expect("waiting for testbed run"),
    )
}

/// The entries of `dir` (recursively), as paths relative to it.
fn files_in(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir)
        .expect("reading the scratch directory")
        .flatten()
    {
        found.push(entry.path().display().to_string());
        if entry.path().is_dir() {
            found.extend(files_in(&entry.path()));
        }
    }
    found
}

/// The checks common to a run and its `--check`: status 2, one error naming can0 and the fix,
/// no launcher, no bus, no file.
fn assert_refused_before_anything_starts(scratch: &Path, pid: u32, out: &Output) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "exit status 2:\n{stderr}");
    assert_eq!(stderr.matches("error").count(), 1, "one message:\n{stderr}");
    let first = stderr.lines().next().unwrap_or_default();
    assert!(
        first.starts_with("error: profile platform needs what this computer lacks")
            && first.ends_with("nothing was started:"),
        "{stderr}"
    );
    // One problem, naming the interface, the five gateways and the fix with the bus's bit rate.
    let problems: Vec<&str> = stderr.lines().skip(1).collect();
    assert_eq!(problems.len(), 1, "one thing missing:\n{stderr}");
    let can0 = problems[0];
    assert!(
        can0.trim_start()
            .starts_with("can0: no such network interface"),
        "{stderr}"
    );
    for gateway in [
        "gyro-gateway",
        "inclinometer-gateway",
        "magnetometer-gateway",
        "wheel-gateway",
        "cmg-gateway",
    ] {
        assert!(can0.contains(gateway), "{gateway} named:\n{stderr}");
    }
    assert!(
        can0.contains("`sudo ip link set can0 up type can bitrate 500000`"),
        "the fix:\n{stderr}"
    );
    assert!(!stderr.to_lowercase().contains("backtrace"), "{stderr}");
    // Nothing started: the launcher said nothing (it logs `started "<process>"` at info), no
    // private bus of this run exists (`/tmp/tb<pid>_…`, made just before the launcher starts),
    // and no file was written (no log directory, no run configuration beside the log).
    assert!(!stderr.contains("started \""), "{stderr}");
    let bus_prefix = format!("tb{pid}_");
    let buses: Vec<String> = std::fs::read_dir("/tmp")
        .expect("/tmp")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&bus_prefix))
        .collect();
    assert!(buses.is_empty(), "a bus was made: {buses:?}");
    assert_eq!(files_in(scratch), Vec::<String>::new(), "nothing written");
}

#[test]
fn a_platform_run_without_can0_is_refused_in_one_message_before_anything_starts() {
    if has_interface("can0") {
        eprintln!("skipped: this computer has can0");
        return;
    }
    let scratch = Scratch::new("preflight-run");
    let (pid, out) = run_platform(scratch.path(), &[]);
    assert_refused_before_anything_starts(scratch.path(), pid, &out);
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
}

#[test]
fn check_reports_the_same() {
    if has_interface("can0") {
        eprintln!("skipped: this computer has can0");
        return;
    }
    let scratch = Scratch::new("preflight-check");
    let (pid, out) = run_platform(scratch.path(), &["--check"]);
    assert_refused_before_anything_starts(scratch.path(), pid, &out);
}

#[test]
fn a_gateways_own_error_is_one_line_without_backtrace() {
    // The gateway role started by hand, as the launcher would, on a bus of its own: the default run
    // configuration has it open can0, which this computer lacks.
    let scratch = Scratch::new("preflight-role");
    let bus = testbed_bus::BusConfig::new(
        format!("pf{}_", std::process::id()),
        // Short: Unix socket paths below the root are limited to 108 bytes.
        format!("/tmp/pfr-{}/", std::process::id()),
    );
    let config = scratch.path().join("default.run.toml");
    std::fs::write(&config, "").expect("an empty run configuration: the defaults");
    // The role is the name `testbed` is started under (as through the launcher's role link).
    let out = Command::new(binary("testbed"))
        .arg0("gyro-gateway")
        .env("TESTBED_RUN_CONFIG", &config)
        .env("TESTBED_BUS_PREFIX", &bus.prefix)
        .env("TESTBED_BUS_ROOT", bus.root_string())
        .env("TESTBED_RUN_MODE", "paced")
        .env("RUST_LOG", "warn")
        .env("RUST_BACKTRACE", "1")
        .env("RUST_LIB_BACKTRACE", "1")
        .stdin(Stdio::null())
        .output()
        .expect("running gyro-gateway");
    let _ = testbed_bus::remove_all(&bus);
    let _ = std::fs::remove_dir_all(&bus.root);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "one line:\n{stderr}");
    assert!(
        lines[0].starts_with("error: gyro-gateway: starting: ") && lines[0].contains("can0"),
        "{stderr}"
    );
    assert!(stderr.ends_with('\n'), "the line is ended: {stderr:?}");
    for word in ["backtrace", "Caused by", "Error:"] {
        assert!(!stderr.contains(word), "no {word:?}:\n{stderr}");
    }
}
