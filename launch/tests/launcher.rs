//! The launcher with stand-in children (`launch-test-child`, `/bin/sh`).
//!
//! Each test writes a profile into its own directory, runs the launcher (`launch-test-child`
//! started as `testbed-launch`, through a link, as `testbed` is) on its own bus
//! (unique prefix, short root) and reads the launcher's log from stderr as it comes (blocking
//! reads, no polling). Time limits are upper bounds against hangs, never assertions of speed.

use std::io::{BufRead as _, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

const HANG_GUARD: Duration = Duration::from_secs(60);

fn child_bin() -> &'static str {
    env!("CARGO_BIN_EXE_launch-test-child")
}

struct Launch {
    dir: PathBuf,
    bus: testbed_bus::BusConfig,
    child: Option<Child>,
    lines: mpsc::Receiver<String>,
    log: Vec<String>,
}

impl Launch {
    /// Writes `profile` (with `{child}` and `{dir}` substituted) and starts the launcher.
    fn start(profile: &str, extra_args: &[&str]) -> Self {
        Self::start_with_env(profile, extra_args, &[])
    }

    /// As [`start`](Self::start), with extra environment variables for the launcher.
    fn start_with_env(
        profile: &str,
        extra_args: &[&str],
        env: &[(&str, &std::ffi::OsStr)],
    ) -> Self {
        static COUNTER: AtomicU32 = AtomicU32::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir = PathBuf::from(format!("/tmp/lt-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("test dir");
        let bus = testbed_bus::BusConfig::new(
            format!("l{}x{n}_", std::process::id()),
            format!("/tmp/ixl-{}-{n}/", std::process::id()),
        );
        let text = profile
            .replace("{child}", child_bin())
            .replace("{dir}", &dir.display().to_string());
        let path = dir.join("profile.toml");
        std::fs::write(&path, text).expect("write profile");
        let launcher = dir.join(testbed_launch::roles::LAUNCHER);
        std::os::unix::fs::symlink(child_bin(), &launcher).expect("link to the launcher");
        let mut child = Command::new(&launcher)
            .arg(&path)
            .args(extra_args)
            .env("TESTBED_BUS_PREFIX", &bus.prefix)
            .env("TESTBED_BUS_ROOT", bus.root_string())
            .env("RUST_LOG", "info")
            .envs(env.iter().copied())
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn testbed-launch");
        let stderr = child.stderr.take().expect("stderr");
        let (tx, lines) = mpsc::channel();
        thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Self {
            dir,
            bus,
            child: Some(child),
            lines,
            log: Vec::new(),
        }
    }

    fn pid(&self) -> libc::pid_t {
        libc::pid_t::try_from(self.child.as_ref().expect("running").id()).expect("pid")
    }

    /// Returns the first line (already read, or read now) that contains every needle.
    fn wait_for(&mut self, needles: &[&str]) -> String {
        if let Some(line) = self
            .log
            .iter()
            .find(|l| needles.iter().all(|n| l.contains(n)))
        {
            return line.clone();
        }
        let deadline = Instant::now() + HANG_GUARD;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    self.log.push(line.clone());
                    if needles.iter().all(|n| line.contains(n)) {
                        return line;
                    }
                }
                Err(_) => panic!("no line with {needles:?} in:\n{}", self.log.join("\n")),
            }
        }
    }

    fn signal(&self, signal: libc::c_int) {
        // SAFETY: plain kill(2) on our own child.
        assert_eq!(unsafe { libc::kill(self.pid(), signal) }, 0);
    }

    /// Waits for the launcher to exit; returns its exit code and whole log.
    fn finish(&mut self) -> (i32, Vec<String>) {
        let mut child = self.child.take().expect("running");
        let (tx, rx) = mpsc::channel();
        let pid = child.id();
        thread::spawn(move || {
            let _ = tx.send(child.wait());
        });
        let status = match rx.recv_timeout(HANG_GUARD) {
            Ok(status) => status.expect("wait"),
            Err(_) => {
                // SAFETY: plain kill(2) on our own child.
                unsafe { libc::kill(pid as libc::pid_t, libc::SIGKILL) };
                panic!("the launcher did not exit:\n{}", self.log.join("\n"));
            }
        };
        // The reader thread ends at EOF, which comes when the launcher (and any child still
        // holding stderr) is gone.
        while let Ok(line) = self.lines.recv_timeout(HANG_GUARD) {
            self.log.push(line);
        }
        let code = status.code().unwrap_or(-1);
        (code, std::mem::take(&mut self.log))
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }
}

impl Drop for Launch {
    fn drop(&mut self) {
        // A failed test: let the launcher stop its children (SIGTERM, then SIGINT as the
        // second request that kills them at once) rather than killing the launcher itself,
        // which would leave children that ignore SIGTERM running.
        if let Some(child) = &mut self.child {
            if let Ok(pid) = libc::pid_t::try_from(child.id()) {
                // SAFETY: plain kill(2) on our own child.
                unsafe {
                    libc::kill(pid, libc::SIGTERM);
                    libc::kill(pid, libc::SIGINT);
                }
            }
            let _ = child.wait();
        }
        let _ = std::fs::remove_dir_all(&self.dir);
        let _ = testbed_bus::remove_all(&self.bus);
    }
}

fn pid_in(line: &str) -> libc::pid_t {
    let start = line.find("(pid ").expect("pid in line") + 5;
    let end = start + line[start..].find(')').expect("closing parenthesis");
    line[start..end].parse().expect("pid number")
}

fn is_gone(pid: libc::pid_t) -> bool {
    // SAFETY: kill with signal 0 only checks for existence.
    let rc = unsafe { libc::kill(pid, 0) };
    rc == -1 && std::io::Error::last_os_error().raw_os_error() == Some(libc::ESRCH)
}

fn is_zombie(pid: libc::pid_t) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
        stat.rsplit_once(')')
            .is_some_and(|(_, rest)| rest.trim_start().starts_with('Z'))
    })
}

fn position(log: &[String], needles: &[&str]) -> usize {
    log.iter()
        .position(|l| needles.iter().all(|n| l.contains(n)))
        .unwrap_or_else(|| panic!("no line with {needles:?} in:\n{}", log.join("\n")))
}

/// How long a child that says `Running` lives before it fails: longer than two of the
/// watchdog's looks at the heartbeats (every 0.5 s), so the launcher has seen it run.
const RAN_S: f64 = 1.2;

fn supervision(stop: f64, term: f64) -> String {
    format!(
        "[supervision]\nstop_timeout_s = {stop}\nterm_timeout_s = {term}\nrestart_delay_s = 0.05\n"
    )
}

#[test]
fn starts_in_dependency_order_and_stops_in_reverse() {
    let profile = format!(
        "[run]\nmode = \"paced\"\n{}
[[process]]
name = \"c\"
command = \"launch-test-child\"
depends_on = [\"b\"]
[[process]]
name = \"b\"
command = \"launch-test-child\"
depends_on = [\"a\"]
[[process]]
name = \"a\"
command = \"/bin/sh\"
args = [\"-c\", \"sleep 1000 & echo $! > {{dir}}/grandchild; wait\"]
",
        supervision(5.0, 5.0)
    );
    let mut launch = Launch::start(&profile, &[]);
    let mut pids = Vec::new();
    for name in ["\"a\"", "\"b\"", "\"c\""] {
        pids.push(pid_in(&launch.wait_for(&["started", name])));
    }
    launch.wait_for(&["b: ready"]);
    launch.wait_for(&["c: ready"]);
    // The shell writes its grandchild's pid after starting it: stop only once it has, or a
    // loaded machine can stop the shell first and leave no file to check.
    let grandchild_file = launch.path("grandchild");
    let started = std::time::Instant::now();
    while !std::fs::read_to_string(&grandchild_file)
        .is_ok_and(|pid| pid.trim().parse::<i32>().is_ok())
    {
        assert!(
            started.elapsed() < std::time::Duration::from_secs(30),
            "the shell never started its grandchild"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    launch.signal(libc::SIGINT);
    let (code, log) = launch.finish();
    assert_eq!(code, 0, "{}", log.join("\n"));
    let stops: Vec<usize> = ["\"c\"", "\"b\"", "\"a\""]
        .iter()
        .map(|n| position(&log, &["stopping", n, "SIGINT"]))
        .collect();
    assert!(
        stops.windows(2).all(|w| w[0] < w[1]),
        "stop order:\n{}",
        log.join("\n")
    );
    for name in ["\"a\"", "\"b\"", "\"c\""] {
        position(&log, &["reaped", name]);
    }
    position(&log, &["all children reaped"]);
    position(&log, &["received SIGINT"]);
    for pid in pids {
        assert!(is_gone(pid), "child {pid} still exists");
    }
    // The shell's own child was in the shell's process group and got the stop signal too.
    let grandchild: libc::pid_t = std::fs::read_to_string(grandchild_file)
        .expect("grandchild pid")
        .trim()
        .parse()
        .expect("pid");
    // It is not the launcher's child (whoever adopted it reaps it, or leaves a zombie): allow
    // it a moment to disappear.
    let deadline = Instant::now() + HANG_GUARD;
    while !is_gone(grandchild) && !is_zombie(grandchild) {
        assert!(
            Instant::now() < deadline,
            "grandchild {grandchild} survived"
        );
        thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn escalation_reaches_sigkill_for_a_child_ignoring_sigint_and_sigterm() {
    let profile = format!(
        "[run]\nmode = \"paced\"\n{}
[[process]]
name = \"stubborn\"
command = \"launch-test-child\"
args = [\"--ignore-signals\"]
[[process]]
name = \"polite\"
command = \"launch-test-child\"
",
        supervision(0.3, 0.3)
    );
    let started = Instant::now();
    let mut launch = Launch::start(&profile, &[]);
    let stubborn = pid_in(&launch.wait_for(&["started", "\"stubborn\""]));
    let polite = pid_in(&launch.wait_for(&["started", "\"polite\""]));
    launch.wait_for(&["stubborn: ready"]);
    launch.wait_for(&["polite: ready"]);
    launch.signal(libc::SIGTERM);
    let (code, log) = launch.finish();
    let all = log.join("\n");
    assert_eq!(code, 1, "a process had to be killed:\n{all}");
    let int = position(&log, &["stopping \"stubborn\"", "sending SIGINT"]);
    let term = position(
        &log,
        &[
            "\"stubborn\"",
            "did not stop",
            "after SIGINT; sending SIGTERM",
        ],
    );
    let kill = position(
        &log,
        &[
            "\"stubborn\"",
            "did not stop",
            "after SIGTERM; sending SIGKILL",
        ],
    );
    let reaped = position(
        &log,
        &["reaped \"stubborn\"", "was killed by signal SIGKILL"],
    );
    assert!(int < term && term < kill && kill < reaped, "{all}");
    position(&log, &["reaped \"polite\"", "exited with code 0"]);
    position(&log, &["all children reaped"]);
    assert!(is_gone(stubborn) && is_gone(polite));
    assert!(started.elapsed() < HANG_GUARD);
}

#[test]
fn a_second_stop_signal_kills_at_once() {
    let profile = format!(
        "[run]\nmode = \"paced\"\n{}
[[process]]
name = \"stubborn\"
command = \"launch-test-child\"
args = [\"--ignore-signals\"]
",
        supervision(30.0, 30.0)
    );
    let mut launch = Launch::start(&profile, &[]);
    launch.wait_for(&["stubborn: ready"]);
    launch.signal(libc::SIGINT);
    launch.wait_for(&["stopping \"stubborn\"", "sending SIGINT"]);
    launch.signal(libc::SIGINT);
    let (code, log) = launch.finish();
    let all = log.join("\n");
    assert_eq!(code, 1, "{all}");
    position(&log, &["received SIGINT while stopping"]);
    position(&log, &["\"stubborn\"", "sending SIGKILL at once"]);
    position(
        &log,
        &["reaped \"stubborn\"", "was killed by signal SIGKILL"],
    );
}

#[test]
fn a_failing_required_process_is_named_and_stops_the_rest() {
    for (args, how) in [
        (
            "[\"--sleep-s\", \"0.2\", \"--exit\", \"3\"]",
            "exited with code 3",
        ),
        (
            "[\"--sleep-s\", \"0.2\", \"--die-by\", \"11\"]",
            "was killed by signal SIGSEGV",
        ),
    ] {
        let profile = format!(
            "[run]\nmode = \"paced\"\n{}
[[process]]
name = \"worker\"
command = \"launch-test-child\"
[[process]]
name = \"crasher\"
command = \"{{child}}\"
args = {args}
",
            supervision(5.0, 5.0)
        );
        let mut launch = Launch::start(&profile, &[]);
        let (code, log) = launch.finish();
        let all = log.join("\n");
        assert_eq!(code, 1, "{all}");
        let failed = position(&log, &["required process \"crasher\"", how, "stopping all"]);
        let stopped = position(&log, &["stopping \"worker\"", "SIGINT"]);
        assert!(failed < stopped, "{all}");
        position(&log, &["reaped \"worker\"", "exited with code 0"]);
        position(&log, &["all children reaped"]);
    }
}

#[test]
fn restart_policy_restarts_up_to_max_restarts() {
    let profile = format!(
        "[run]\nmode = \"paced\"\n{}
[[process]]
name = \"worker\"
command = \"launch-test-child\"
[[process]]
name = \"flaky\"
command = \"launch-test-child\"
args = [\"--running\", \"--sleep-s\", \"{RAN_S}\", \"--exit\", \"4\", \"--mark\", \"{{dir}}/flaky\"]
on_exit = \"restart\"
max_restarts = 2
",
        supervision(5.0, 5.0)
    );
    let mut launch = Launch::start(&profile, &[]);
    let marks = launch.path("flaky");
    let (code, log) = launch.finish();
    let all = log.join("\n");
    assert_eq!(code, 1, "{all}");
    let starts = std::fs::read_to_string(marks).expect("marks");
    assert_eq!(
        starts.lines().count(),
        3,
        "first start and two restarts:\n{starts}"
    );
    let first = position(&log, &["\"flaky\"", "exited with code 4", "restart 1 of 2"]);
    let second = position(&log, &["\"flaky\"", "exited with code 4", "restart 2 of 2"]);
    let gave_up = position(
        &log,
        &[
            "required process \"flaky\"",
            "no restarts left (max_restarts = 2)",
        ],
    );
    assert!(first < second && second < gave_up, "{all}");
    position(&log, &["reaped \"worker\""]);
}

#[test]
fn a_start_up_that_fails_the_same_way_twice_is_not_restarted_again() {
    // Exits with 3 before it ever says Running (no heartbeat at all), every time: retried once
    // (a device may be slow to appear), then not again, whatever its budget.
    let profile = format!(
        "[run]\nmode = \"paced\"\n{}
[[process]]
name = \"worker\"
command = \"launch-test-child\"
[[process]]
name = \"broken\"
command = \"launch-test-child\"
args = [\"--exit\", \"3\", \"--sleep-s\", \"0\", \"--mark\", \"{{dir}}/broken\"]
on_exit = \"restart\"
max_restarts = 3
",
        supervision(5.0, 5.0)
    );
    let mut launch = Launch::start(&profile, &[]);
    let marks = launch.path("broken");
    let (code, log) = launch.finish();
    let all = log.join("\n");
    assert_eq!(
        code, 1,
        "a required process that cannot start fails the run:\n{all}"
    );
    let starts = std::fs::read_to_string(marks).expect("marks");
    assert_eq!(
        starts.lines().count(),
        2,
        "first start and one restart:\n{starts}"
    );
    let retried = position(
        &log,
        &["\"broken\"", "exited with code 3", "restart 1 of 3"],
    );
    let given_up = position(
        &log,
        &[
            "required process \"broken\"",
            "exited with code 3 before it ever ran, as its previous start did: not restarted",
            "stopping all",
        ],
    );
    assert!(retried < given_up, "{all}");
    assert!(!all.contains("restart 2 of 3"), "{all}");
}

#[test]
fn a_process_that_ran_before_failing_is_restarted_each_time() {
    // The same exit status every time, but after saying Running: not a start-up failure, so
    // the whole budget applies.
    let profile = format!(
        "[run]\nmode = \"paced\"\n{}
[[process]]
name = \"worker\"
command = \"launch-test-child\"
[[process]]
name = \"flaky\"
command = \"launch-test-child\"
args = [\"--running\", \"--sleep-s\", \"{RAN_S}\", \"--exit\", \"3\", \"--mark\", \"{{dir}}/flaky\"]
required = false
on_exit = \"restart\"
max_restarts = 3
",
        supervision(5.0, 5.0)
    );
    let mut launch = Launch::start(&profile, &[]);
    launch.wait_for(&[
        "\"flaky\"",
        "no restarts left (max_restarts = 3)",
        "left stopped",
    ]);
    let marks = launch.path("flaky");
    launch.signal(libc::SIGINT);
    let (code, log) = launch.finish();
    assert_eq!(code, 0, "{}", log.join("\n"));
    let starts = std::fs::read_to_string(marks).expect("marks");
    assert_eq!(
        starts.lines().count(),
        4,
        "first start and three restarts:\n{starts}"
    );
}

#[test]
fn an_optional_process_out_of_restarts_is_left_stopped() {
    let profile = format!(
        "[run]\nmode = \"paced\"\n{}
[[process]]
name = \"worker\"
command = \"launch-test-child\"
[[process]]
name = \"flaky\"
command = \"launch-test-child\"
args = [\"--running\", \"--sleep-s\", \"{RAN_S}\", \"--exit\", \"4\"]
required = false
on_exit = \"restart\"
max_restarts = 1
",
        supervision(5.0, 5.0)
    );
    let mut launch = Launch::start(&profile, &[]);
    launch.wait_for(&["\"flaky\"", "no restarts left", "left stopped"]);
    launch.signal(libc::SIGINT);
    let (code, log) = launch.finish();
    assert_eq!(code, 0, "{}", log.join("\n"));
    position(&log, &["reaped \"worker\"", "exited with code 0"]);
}

#[test]
fn the_process_that_ends_the_run_stops_everything_successfully() {
    let profile = format!(
        "[run]\nmode = \"lockstep\"\nseed = 42\nduration_s = 12.5\n{}
[[process]]
name = \"worker\"
command = \"launch-test-child\"
env = {{ EXTRA = \"yes\" }}
args = [\"--env-out\", \"{{dir}}/env\"]
[[process]]
name = \"plant\"
command = \"launch-test-child\"
args = [\"--sleep-s\", \"0.3\"]
ends_run = true
depends_on = [\"worker\"]
",
        supervision(5.0, 5.0)
    );
    let mut launch = Launch::start(&profile, &[]);
    let env_file = launch.path("env");
    let bus = launch.bus.clone();
    let (code, log) = launch.finish();
    let all = log.join("\n");
    assert_eq!(code, 0, "{all}");
    position(
        &log,
        &["\"plant\"", "exited with code 0", "it ends the run"],
    );
    position(
        &log,
        &["run ended", "\"plant\" completed the run", "exit status 0"],
    );
    let env = std::fs::read_to_string(env_file).expect("env dump");
    for expected in [
        format!("TESTBED_BUS_PREFIX={}", bus.prefix),
        format!("TESTBED_BUS_ROOT={}", bus.root_string()),
        "TESTBED_BUS_DELIVERY=lossless".to_owned(),
        "TESTBED_RUN_MODE=lockstep".to_owned(),
        "TESTBED_RUN_SEED=42".to_owned(),
        "TESTBED_RUN_DURATION_S=12.5".to_owned(),
        "TESTBED_PROCESS_NAME=worker".to_owned(),
        "RUST_LOG=info".to_owned(),
    ] {
        assert!(
            env.lines().any(|l| l == expected),
            "{expected} missing from:\n{env}"
        );
    }
}

#[test]
fn command_line_overrides_the_run_defaults() {
    let profile = "[run]\nmode = \"lockstep\"\nseed = 1\n
[[process]]
name = \"dump\"
command = \"launch-test-child\"
args = [\"--env-out\", \"{dir}/env\", \"--sleep-s\", \"0\"]
ends_run = true
";
    let mut launch = Launch::start(
        profile,
        &["--mode", "paced", "--seed", "9", "--duration-s", "3"],
    );
    let env_file = launch.path("env");
    let (code, log) = launch.finish();
    assert_eq!(code, 0, "{}", log.join("\n"));
    let env = std::fs::read_to_string(env_file).expect("env dump");
    for expected in [
        "TESTBED_RUN_MODE=paced",
        "TESTBED_BUS_DELIVERY=overflow",
        "TESTBED_RUN_SEED=9",
        "TESTBED_RUN_DURATION_S=3",
    ] {
        assert!(
            env.lines().any(|l| l == expected),
            "{expected} missing from:\n{env}"
        );
    }
}

#[test]
fn stale_bus_resources_of_a_killed_process_are_removed() {
    let profile = format!(
        "[run]\nmode = \"paced\"\n{}
[[process]]
name = \"victim\"
command = \"launch-test-child\"
args = [\"--open-bus\"]
",
        supervision(5.0, 5.0)
    );
    let mut launch = Launch::start(&profile, &[]);
    let victim = pid_in(&launch.wait_for(&["started", "\"victim\""]));
    launch.wait_for(&["victim: bus open"]);
    // SAFETY: plain kill(2) on a grandchild this test started through the launcher.
    assert_eq!(unsafe { libc::kill(victim, libc::SIGKILL) }, 0);
    let bus = launch.bus.clone();
    let (code, log) = launch.finish();
    let all = log.join("\n");
    assert_eq!(code, 1, "{all}");
    position(
        &log,
        &[
            "required process \"victim\"",
            "was killed by signal SIGKILL",
        ],
    );
    // The launcher's own bus node (its heartbeat watchdog) or its explicit cleanup removes the
    // dead node's resources after the run: nothing is left for a later cleanup to find.
    let report = testbed_bus::cleanup_dead_nodes(&bus).expect("cleanup");
    assert!(
        report.cleaned.is_empty() && report.failed.is_empty(),
        "dead nodes left after the run: {report:?}\n{all}"
    );
    let removed = testbed_bus::remove_all(&bus).expect("remove_all");
    assert!(!bus.root.exists(), "{removed} files removed, root left");
}

#[test]
fn invalid_profiles_and_missing_binaries_exit_with_status_2() {
    let mut launch = Launch::start(
        "[run]\nmode = \"paced\"\n[[process]]\nname = \"a\"\ncommand = \"x\"\ncolour = 1\n",
        &[],
    );
    let (code, log) = launch.finish();
    let all = log.join("\n");
    assert_eq!(code, 2, "{all}");
    assert!(
        all.contains("profile.toml") && all.contains("colour"),
        "{all}"
    );

    let mut launch = Launch::start(
        "[run]\nmode = \"paced\"\n[[process]]\nname = \"ghost\"\ncommand = \"no-such-binary\"\n",
        &[],
    );
    let (code, log) = launch.finish();
    let all = log.join("\n");
    assert_eq!(code, 2, "{all}");
    assert!(
        all.contains("\"ghost\"") && all.contains("no-such-binary"),
        "{all}"
    );
}

/// `cpus` and `scheduling` of a `[[process]]` are in force when the process runs: a shell
/// reads its own affinity (`/proc/<pid>/status`) and nice value, real-time priority and policy
/// (`/proc/<pid>/stat` fields 19, 40, 41).
#[test]
fn cpus_and_scheduling_of_a_process_are_applied_before_it_runs() {
    let probe = "grep Cpus_allowed_list /proc/$$/status > {dir}/placement; \
                 cut -d' ' -f19,40,41 /proc/$$/stat >> {dir}/placement";
    let profile = |scheduling: &str| {
        format!(
            "[run]\nmode = \"lockstep\"\nseed = 1\n{}
[[process]]
name = \"probe\"
command = \"/bin/sh\"
args = [\"-c\", \"{probe}\"]
ends_run = true
cpus = [0]
scheduling = {scheduling}
",
            supervision(5.0, 5.0)
        )
    };
    // Time-sharing at nice 5 needs no privilege.
    let mut launch = Launch::start(&profile("{ policy = \"other\", nice = 5 }"), &[]);
    let placement = launch.path("placement");
    let (code, log) = launch.finish();
    assert_eq!(code, 0, "{}", log.join("\n"));
    let text = std::fs::read_to_string(placement).expect("the probe wrote its placement");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0].split_whitespace().last(), Some("0"), "{text}");
    assert_eq!(
        lines[1], "5 0 0",
        "nice 5, no real-time priority, SCHED_OTHER: {text}"
    );

    // SCHED_RR priority 7: applied as root, refused with the reason otherwise.
    let mut launch = Launch::start(&profile("{ policy = \"rr\", priority = 7 }"), &[]);
    let placement = launch.path("placement");
    let (code, log) = launch.finish();
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } == 0 {
        assert_eq!(code, 0, "{}", log.join("\n"));
        let text = std::fs::read_to_string(placement).expect("placement");
        assert!(text.ends_with(" 7 2\n"), "priority 7, SCHED_RR (2): {text}");
    } else {
        assert_ne!(code, 0);
        position(&log, &["cannot start \"probe\"", "CAP_SYS_NICE"]);
    }
}

/// `cpus = "hot-path"` and `"background"` are shared out from the CPUs the launcher may use
/// (`[platform] hot_path_cpu`, else the first); `--unplaced` leaves both processes on every
/// CPU; a hot-path CPU the launcher may not use refuses the run before anything starts.
#[test]
fn cpu_roles_are_shared_out_from_the_launchers_cpus() {
    let available = testbed_launch::placement::available_cpus().expect("affinity");
    // Each writes its affinity; the hot one then waits to be stopped, the background one ends
    // the run once both are written.
    let probe = |name: &str, role: &str, then: &str| {
        format!(
            "[[process]]
name = \"{name}\"
command = \"/bin/sh\"
args = [\"-c\", \"grep Cpus_allowed_list /proc/$$/status | cut -f2 > {{dir}}/{name}.tmp; \
             mv {{dir}}/{name}.tmp {{dir}}/{name}; {then}\"]
cpus = \"{role}\"
"
        )
    };
    let profile = |platform: &str| {
        format!(
            "[run]\nmode = \"lockstep\"\nseed = 1\n{platform}{}\n{}{}ends_run = true\n",
            supervision(5.0, 5.0),
            probe("hot", "hot-path", "exec sleep 1000"),
            probe(
                "background",
                "background",
                "while [ ! -e {dir}/hot ]; do sleep 0.01; done"
            ),
        )
    };
    let allowed = |text: &str| -> Vec<usize> {
        // The kernel's list: "0-3,5".
        text.trim()
            .split(',')
            .flat_map(|range| {
                let (a, b) = range.split_once('-').unwrap_or((range, range));
                a.parse::<usize>().unwrap()..=b.parse::<usize>().unwrap()
            })
            .collect()
    };
    let run = |platform: &str, args: &[&str]| {
        let mut launch = Launch::start(&profile(platform), args);
        let (hot, background) = (launch.path("hot"), launch.path("background"));
        let (code, log) = launch.finish();
        assert_eq!(code, 0, "{}", log.join("\n"));
        (
            allowed(&std::fs::read_to_string(hot).expect("hot")),
            allowed(&std::fs::read_to_string(background).expect("background")),
        )
    };
    let others: Vec<usize> = available[1..].to_vec();
    let expected_background = if others.is_empty() {
        vec![available[0]]
    } else {
        others
    };
    assert_eq!(run("", &[]), (vec![available[0]], expected_background));
    let last = *available.last().unwrap();
    let (hot, background) = run(&format!("[platform]\nhot_path_cpu = {last}\n"), &[]);
    assert_eq!(hot, vec![last]);
    assert!(
        available.len() == 1 || !background.contains(&last),
        "{background:?}"
    );
    assert_eq!(
        run("", &["--unplaced"]),
        (available.clone(), available.clone())
    );

    let mut launch = Launch::start(&profile("[platform]\nhot_path_cpu = 1023\n"), &[]);
    let (code, log) = launch.finish();
    assert_eq!(code, 2, "{}", log.join("\n"));
    position(&log, &["platform.hot_path_cpu", "CPU 1023"]);
    assert!(!log.iter().any(|l| l.contains("started \"hot\"")));
}

#[test]
fn a_cpu_the_launcher_may_not_use_is_refused_before_anything_starts() {
    let profile = format!(
        "[run]\nmode = \"lockstep\"\nseed = 1\n{}
[[process]]
name = \"probe\"
command = \"/bin/sh\"
args = [\"-c\", \"true\"]
ends_run = true
cpus = [1023]
",
        supervision(5.0, 5.0)
    );
    let mut launch = Launch::start(&profile, &[]);
    let (code, log) = launch.finish();
    assert_eq!(code, 2, "{}", log.join("\n"));
    position(&log, &["process.probe.cpus names CPU 1023"]);
    assert!(!log.iter().any(|l| l.contains("started \"probe\"")));
}

/// `[platform] cpu_latency_us`: the launcher writes the request before any process starts and
/// holds it for the run; a device it cannot open stops the run before anything starts, named.
/// On a stand-in file (`TESTBED_CPU_LATENCY_DEVICE`), so that the test neither needs root nor
/// changes the machine's idle states under the other tests.
#[test]
fn a_cpu_latency_request_is_written_before_the_processes_start() {
    let dir = PathBuf::from(format!("/tmp/lt-qos-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let device = dir.join("device");
    std::fs::write(&device, b"").expect("stand-in device");
    let seen = dir.join("seen");
    let profile = format!(
        "[run]\nmode = \"lockstep\"\nseed = 1\n[platform]\ncpu_latency_us = 25\n{}
[[process]]
name = \"probe\"
command = \"/bin/sh\"
args = [\"-c\", \"od -An -tu4 {} > {}\"]
ends_run = true
",
        supervision(5.0, 5.0),
        device.display(),
        seen.display()
    );
    let run_on = |device: &std::path::Path| {
        Launch::start_with_env(
            &profile,
            &[],
            &[("TESTBED_CPU_LATENCY_DEVICE", device.as_os_str())],
        )
        .finish()
    };
    let (code, log) = run_on(&device);
    assert_eq!(code, 0, "{}", log.join("\n"));
    position(&log, &["holding CPU latency 25 µs", "device"]);
    let text = std::fs::read_to_string(&seen).expect("the probe read the device");
    assert_eq!(text.trim(), "25", "the request as a native s32: {text:?}");

    let (code, log) = run_on(&dir.join("no-such-device"));
    assert_eq!(code, 2, "{}", log.join("\n"));
    position(&log, &["platform.cpu_latency_us", "no-such-device"]);
    assert!(!log.iter().any(|l| l.contains("started \"probe\"")));
    let _ = std::fs::remove_dir_all(&dir);
}
