//! Helpers for end-to-end tests: find (building if needed) the workspace's binaries, in the same
//! profile as the running test, and give each test a scratch directory.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// Directory of the running test's profile (`target/release`, `target/debug`, `target/deploy`).
pub fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test knows its own path");
    // target/<profile>/deps/<test binary>
    exe.parent()
        .and_then(Path::parent)
        .expect("test binary lives in target/<profile>/deps")
        .to_path_buf()
}

/// The `cargo build` arguments that build into `profile_dir` (`target/debug` is the `dev`
/// profile, any other directory the profile of its name).
pub fn cargo_profile_args(profile_dir: &Path) -> Vec<String> {
    match profile_dir.file_name().and_then(|n| n.to_str()) {
        None | Some("debug") => Vec::new(),
        Some(name) => vec!["--profile".into(), name.into()],
    }
}

/// Path of a workspace binary, built once per test process with `cargo build --bins` in the
/// test's own profile (cargo does not build other packages' binaries for a test crate).
pub fn binary(name: &str) -> PathBuf {
    static BUILT: OnceLock<Result<(), String>> = OnceLock::new();
    let dir = profile_dir();
    let built = BUILT.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.args(["build", "--workspace", "--bins", "--quiet"])
            .args(cargo_profile_args(&dir));
        let status = cmd
            .status()
            .map_err(|e| format!("running cargo build: {e}"))?;
        status
            .success()
            .then_some(())
            .ok_or_else(|| format!("cargo build --bins failed: {status}"))
    });
    if let Err(e) = built {
        panic!("{e}");
    }
    let path = dir.join(name);
    assert!(path.exists(), "binary {} was not built", path.display());
    path
}

/// A fresh scratch directory for one test, removed when dropped.
pub struct Scratch(PathBuf);

impl Scratch {
    pub fn new(test: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("testbed-e2e-{test}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("creating a scratch directory");
        Self(dir)
    }
    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() {
            // A failed test's files are the evidence: kept, and said where.
            eprintln!("scratch directory kept: {}", self.0.display());
            return;
        }
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The workspace root (where `launch/profiles` lives).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ sits in the workspace")
        .to_path_buf()
}

/// Path of a shipped launch profile.
pub fn profile(name: &str) -> PathBuf {
    workspace_root()
        .join("launch/profiles")
        .join(format!("{name}.toml"))
}

/// The simulation profile for fault tests, written to `dir/file_name`: run in `mode`
/// (`"paced"` or `"lockstep"`), safe mode tolerated, and every process but the plant (whose
/// exit ends the run) and the ground link (which has its own policy in the profile) restarted
/// on exit up to `max_restarts` times, half a second after it ends.
pub fn restarting_simulation_profile(
    dir: &Path,
    file_name: &str,
    mode: &str,
    max_restarts: u32,
) -> PathBuf {
    let text = std::fs::read_to_string(profile("simulation")).expect("simulation profile");
    let mut out = String::new();
    for line in text.lines() {
        if line.starts_with("mode = ") {
            out.push_str(&format!("mode = \"{mode}\"\n"));
            continue;
        }
        out.push_str(line);
        out.push('\n');
        if line == "[supervision]" {
            out.push_str("tolerate_safe_mode = true\nrestart_delay_s = 0.5\n");
        }
        if let Some(name) = line.strip_prefix("name = ")
            && name != "\"plant\""
            && name != "\"ground-link\""
        {
            out.push_str(&format!(
                "on_exit = \"restart\"\nmax_restarts = {max_restarts}\n"
            ));
        }
    }
    let path = dir.join(file_name);
    std::fs::write(&path, out).expect("writing the fault-test profile");
    path
}

/// A 40-simulated-s lockstep run of `profile` with `seed` and a pinned wall-clock start (the
/// log's times are the start plus the run clock), logged to `log`: for byte comparisons.
pub fn pinned_lockstep_run(profile: &Path, log: &Path, seed: u64) -> serde_json::Value {
    testbed_run(&[
        "--profile",
        profile.to_str().expect("UTF-8 path"),
        "--duration",
        "40",
        "--seed",
        &seed.to_string(),
        "--start-time-ns",
        "1795503600000000000",
        "--log",
        log.to_str().expect("UTF-8 path"),
    ])
}

/// Run `testbed run --json` with `args` and return its summary.
pub fn testbed_run(args: &[&str]) -> serde_json::Value {
    let out = Command::new(binary("testbed"))
        .arg("run")
        .args(args)
        .arg("--json")
        .output()
        .expect("running testbed run");
    assert!(
        out.status.success(),
        "testbed run {args:?} failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "testbed run --json printed no JSON ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// The CAN test VM of `tests/vm/run.sh`: Debian's kernel with SocketCAN and `vcan0` up, the
/// workspace shared read-only at its host path, a scratch directory shared read-write.
pub mod vm {
    use std::path::Path;
    use std::process::Command;

    /// What a command run in the VM gave.
    #[derive(Debug)]
    pub struct VmRun {
        /// The command's exit status inside the VM.
        pub status: i32,
        /// The serial console: the kernel's messages, then the command's stdout and stderr.
        pub console: String,
        /// The harness's own report (boot accelerator, time).
        pub harness: String,
    }

    /// Whether this machine can run the VM. `Err` says why not: the caller skips the test then,
    /// except under CI (`CI=true`), where a VM test that cannot run fails: a CI machine without
    /// KVM would otherwise pass the SocketCAN tests without running them.
    pub fn available() -> Result<(), String> {
        let kvm = Path::new("/dev/kvm");
        let tcg = std::env::var("TESTBED_VM_ACCEL").is_ok_and(|a| a == "tcg");
        if !tcg && !kvm.exists() {
            return Err("/dev/kvm is missing: no KVM on this machine".into());
        }
        let tools = ["qemu-system-x86_64", "busybox", "candump", "cangen"];
        for tool in tools {
            let found = Command::new("sh")
                .args(["-c", &format!("command -v {tool}")])
                .output()
                .is_ok_and(|o| o.status.success());
            if !found {
                return Err(format!(
                    "{tool} is not installed (.ci/run installs qemu-system-x86, linux-image-amd64, busybox-static, can-utils, iproute2)"
                ));
            }
        }
        Ok(())
    }

    /// True when the VM can run; otherwise says why on stderr and returns false, or panics
    /// under CI (see [`available`]).
    pub fn ready_or_skip(test: &str) -> bool {
        match available() {
            Ok(()) => true,
            Err(why) if std::env::var("CI").is_ok_and(|ci| ci == "true") => {
                panic!("{test}: CI=true and the CAN test VM cannot run here: {why}")
            }
            Err(why) => {
                eprintln!("SKIPPED {test}: the CAN test VM cannot run here: {why}");
                false
            }
        }
    }

    /// Runs `script` (busybox sh, working directory: the VM's view of `scratch`) in the VM,
    /// giving up after `timeout_s` seconds of the script's run time.
    ///
    /// One VM at a time per test binary: the VMs may be emulated (TCG, no KVM), and several at
    /// once on a 2-core machine starve each other's pipelines (a lockstep run over vcan0 then
    /// misses a frame's tick sync and is no longer bit for bit can-sim's; seen in CI).
    pub fn run(scratch: &Path, timeout_s: u32, script: &str) -> VmRun {
        static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let _turn = ONE_AT_A_TIME
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        // The project's binaries are run in the VM from the shared workspace: built first.
        let _ = super::binary("testbed");
        std::fs::write(scratch.join("script.sh"), script).expect("writing the VM script");
        let out = Command::new(super::workspace_root().join("tests/vm/run.sh"))
            .args([
                "--scratch",
                scratch.to_str().expect("scratch path is UTF-8"),
            ])
            .args(["--timeout", &timeout_s.to_string()])
            .args(["--", "sh", "/scratch/script.sh"])
            .output()
            .expect("running tests/vm/run.sh");
        let harness = String::from_utf8_lossy(&out.stderr).into_owned();
        let console = String::from_utf8_lossy(&out.stdout).into_owned();
        let status = out.status.code().unwrap_or(-1);
        assert_ne!(
            status, 77,
            "tests/vm/run.sh cannot run the VM here:\n{harness}"
        );
        assert!(
            status != 124 && status != 125,
            "the VM failed (status {status}):\n{harness}\n{console}"
        );
        eprintln!("{}", harness.trim_end());
        VmRun {
            status,
            console,
            harness,
        }
    }
}

/// The pid of a descendant of `root` (up to 8 generations down) running `program` (its
/// `/proc/<pid>/comm`), if any: the fault tests find the pipeline's processes under `testbed`.
pub fn descendant(root: u32, program: &str) -> Option<u32> {
    let parent_of = |pid: u32| -> Option<u32> {
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
        // pid (comm) state ppid …: comm may hold spaces, so split after the last ')'.
        let rest = &stat[stat.rfind(')')? + 2..];
        rest.split(' ').nth(1)?.parse().ok()
    };
    std::fs::read_dir("/proc")
        .ok()?
        .flatten()
        .find_map(|entry| {
            let pid: u32 = entry.file_name().to_str()?.parse().ok()?;
            let comm = std::fs::read_to_string(format!("/proc/{pid}/comm")).ok()?;
            if comm.trim_end() != program {
                return None;
            }
            let mut p = pid;
            for _ in 0..8 {
                p = parent_of(p)?;
                if p == root {
                    return Some(pid);
                }
            }
            None
        })
}

/// The attitude estimates a run's log holds, in their order.
pub fn logged_estimates(log: &testbed_log::RunLog) -> Vec<ipc_types::AttitudeEstimate> {
    log.samples::<ipc_types::AttitudeEstimate>()
        .expect("the log has the estimates' channel")
        .map(|sample| sample.expect("a readable estimate"))
        .collect()
}

/// Asserts that the logged `estimates` are, bit for bit, the in-process loop's `trace`: same
/// count, and at every tick the same attitude and gyro bias (same code, same inputs, same
/// order).
pub fn assert_estimates_equal_the_in_process_loop(
    estimates: &[ipc_types::AttitudeEstimate],
    trace: &testbed_sim::closed_loop::Trace,
) {
    assert_eq!(estimates.len(), trace.ticks.len());
    assert_eq!(
        trace.first_estimate_mismatch(estimates),
        None,
        "time (s) of the first estimate that is not the in-process loop's bit for bit"
    );
}

/// Asserts that a run's logged estimates are, bit for bit, what the in-process loop computes from
/// the run configuration the log keeps; returns that configuration.
pub fn assert_log_equals_the_in_process_loop(
    run_log: &testbed_log::RunLog,
) -> testbed_config::RunConfig {
    let config = testbed_config::RunConfig::from_toml_str(run_log.config_toml(), "log")
        .expect("the log keeps a valid run configuration");
    let trace =
        testbed_sim::closed_loop::run(&testbed_sim::closed_loop::Scenario::from_run(&config))
            .expect("the in-process loop runs the logged configuration");
    let estimates: Vec<ipc_types::AttitudeEstimate> = run_log
        .samples::<ipc_types::AttitudeEstimate>()
        .expect("the log has estimates")
        .map(|s| s.expect("a readable estimate"))
        .collect();
    assert_estimates_equal_the_in_process_loop(&estimates, &trace);
    config
}
