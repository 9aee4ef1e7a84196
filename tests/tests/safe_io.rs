//! With real processes: runs that cannot collide (log lock, signals forwarded, the pipeline and
//! its bus go with a killed `testbed`, private buses) and cut inputs reported (identification
//! CSV, replayed log) or repaired (a killed logger's log).

use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _};
use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use ipc_types::AttitudeEstimate;
use testbed_e2e::{Scratch, binary, profile, testbed_run};
use testbed_log::RunLog;

/// Processes whose bus prefix starts with `prefix` (`tb<pid>_`), with their profile names.
fn processes_on_bus(prefix: &str) -> Vec<(u32, String)> {
    let needle = format!("TESTBED_BUS_PREFIX={prefix}");
    std::fs::read_dir("/proc")
        .unwrap()
        .flatten()
        .filter_map(|e| e.file_name().to_str().and_then(|n| n.parse::<u32>().ok()))
        .filter_map(|pid| {
            let env = std::fs::read(format!("/proc/{pid}/environ")).ok()?;
            let vars: Vec<&[u8]> = env.split(|b| *b == 0).collect();
            if !vars.iter().any(|v| v.starts_with(needle.as_bytes())) {
                return None;
            }
            let name = vars
                .iter()
                .find_map(|v| v.strip_prefix(b"TESTBED_PROCESS_NAME="))
                .map(|n| String::from_utf8_lossy(n).into_owned())
                .unwrap_or_default();
            Some((pid, name))
        })
        .collect()
}

/// Whether `pid` is running (a zombie waiting for its parent counts as ended).
fn running(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
        stat.rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .is_some_and(|state| state != "Z" && state != "X")
    })
}

/// The children of `pid` (from /proc).
fn children(pid: u32) -> Vec<u32> {
    let parent = pid.to_string();
    std::fs::read_dir("/proc")
        .unwrap()
        .flatten()
        .filter_map(|e| e.file_name().to_str().and_then(|n| n.parse::<u32>().ok()))
        .filter(|p| {
            std::fs::read_to_string(format!("/proc/{p}/stat")).is_ok_and(|stat| {
                stat.rsplit_once(')')
                    .and_then(|(_, rest)| rest.split_whitespace().nth(1).map(|pp| pp == parent))
                    .unwrap_or(false)
            })
        })
        .collect()
}

/// Files of runs of `testbed` pid `pid`: its bus roots in /tmp and its shared memory.
fn bus_files(pid: u32) -> (Vec<PathBuf>, Vec<PathBuf>) {
    let prefix = format!("tb{pid}_");
    let list = |dir: &str| -> Vec<PathBuf> {
        std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
            .map(|e| e.path())
            .collect()
    };
    (list("/tmp"), list("/dev/shm"))
}

/// Every file below `dir`.
fn files_below(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            out.extend(files_below(&path));
        }
        out.push(path);
    }
    out
}

/// `testbed run --paced --duration 600 --json` on `log` (seed `seed`), output captured.
fn start_paced(log: &Path, seed: u64) -> Child {
    Command::new(binary("testbed"))
        .args(["run", "--paced", "--duration", "600", "--json", "--seed"])
        .arg(seed.to_string())
        .arg("--profile")
        .arg(profile("simulation"))
        .arg("--log")
        .arg(log)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()
        .expect("starting testbed run")
}

/// Waits until the nine processes of `testbed` pid `pid` are up.
fn wait_for_pipeline(pid: u32) -> Vec<(u32, String)> {
    let prefix = format!("tb{pid}_");
    let start = Instant::now();
    loop {
        let procs = processes_on_bus(&prefix);
        if procs.len() >= 9 {
            return procs;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the pipeline did not come up: {procs:?}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn signal(pid: u32, signal: libc::c_int) {
    // SAFETY: kill(2) on a process this test started.
    assert_eq!(unsafe { libc::kill(pid as libc::pid_t, signal) }, 0);
}

fn output_of(child: Child) -> (std::process::ExitStatus, String, String) {
    let out = child.wait_with_output().expect("waiting for testbed");
    (
        out.status,
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Python `mcap`'s `make_reader` (reads from the footer): the number of sample messages it
/// iterates, the channels derived from them ([`testbed_log::foxglove::DERIVED_TOPICS`], which
/// [`RunLog::message_count`] leaves out) left out; the statistics count every one.
fn python_make_reader_count(log: &Path) -> u64 {
    let script = "import sys\nfrom mcap.reader import make_reader\n\
                  derived = set(sys.argv[2:])\n\
                  with open(sys.argv[1], 'rb') as f:\n    r = make_reader(f)\n    \
                  topics = [ch.topic for _, ch, _ in r.iter_messages()]\n    \
                  assert r.get_summary().statistics.message_count == len(topics)\n    \
                  print(sum(1 for t in topics if t not in derived))\n";
    let out = Command::new("python3")
        .args(["-c", script])
        .arg(log)
        .args(testbed_log::foxglove::DERIVED_TOPICS)
        .output()
        .expect("python3 (with `pip install mcap`) is needed");
    assert!(
        out.status.success(),
        "make_reader refused {}:\n{}",
        log.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .trim()
        .parse()
        .expect("a count")
}

#[test]
fn a_second_run_on_the_same_log_is_refused_naming_it() {
    let scratch = Scratch::new("safeio-lock");
    let log = scratch.path().join("shared.mcap");
    let first = start_paced(&log, 5);
    wait_for_pipeline(first.id());

    let second = Command::new(binary("testbed"))
        .args(["run", "--duration", "2", "--seed", "6", "--profile"])
        .arg(profile("simulation"))
        .arg("--log")
        .arg(&log)
        .output()
        .expect("running the second testbed run");
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success(), "the second run was not refused");
    assert!(
        stderr.contains(&log.display().to_string()) && stderr.contains("another testbed run"),
        "{stderr}"
    );
    // The first run's configuration is untouched.
    let config = std::fs::read_to_string(log.with_extension("run.toml")).unwrap();
    assert!(config.contains("seed = 5"), "{config}");

    std::thread::sleep(Duration::from_secs(2));
    signal(first.id(), libc::SIGINT);
    let (status, stdout, stderr) = output_of(first);
    assert!(status.success(), "{stderr}");
    let summary: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(summary["seed"], 5, "{summary}");
    let run_log = RunLog::open(&log).unwrap();
    assert!(run_log.is_complete());
    assert_eq!(run_log.info().seed, 5);
    // The lock is gone with the run: the next run on the log goes ahead.
    testbed_run(&[
        "--profile",
        profile("simulation").to_str().unwrap(),
        "--duration",
        "2",
        "--seed",
        "6",
        "--log",
        log.to_str().unwrap(),
    ]);
    assert_eq!(RunLog::open(&log).unwrap().info().seed, 6);
}

#[test]
fn sigint_to_testbeds_pid_stops_the_run_cleanly_on_a_private_bus() {
    let scratch = Scratch::new("safeio-sigint");
    let log = scratch.path().join("paced.mcap");
    let child = start_paced(&log, 1);
    let pid = child.id();
    wait_for_pipeline(pid);
    std::thread::sleep(Duration::from_secs(2));

    // The bus: one root, /tmp/tb<pid>_<random>, the user's own, mode 0700; no file of the run
    // (root or /dev/shm) can be written by others or the group.
    let (roots, shm) = bus_files(pid);
    assert_eq!(roots.len(), 1, "{roots:?}");
    let root = &roots[0];
    let name = root.file_name().unwrap().to_string_lossy().into_owned();
    assert!(name.len() > format!("tb{pid}_").len() + 4, "{name}");
    let meta = std::fs::metadata(root).unwrap();
    assert_eq!(
        meta.permissions().mode() & 0o777,
        0o700,
        "{}",
        root.display()
    );
    assert_eq!(meta.uid(), std::fs::metadata("/proc/self").unwrap().uid());
    assert!(!shm.is_empty());
    // Not the links the processes are started by: a symbolic link's mode is always 0777 and
    // never checked (their directory is the user's only, like the root).
    let open: Vec<_> = files_below(root)
        .into_iter()
        .filter(|p| !p.is_dir() && !p.is_symlink())
        .chain(shm)
        .filter_map(|p| {
            let mode = std::fs::symlink_metadata(&p).ok()?.permissions().mode();
            (mode & 0o066 != 0).then(|| format!("{} {:o}", p.display(), mode & 0o777))
        })
        .collect();
    assert!(open.is_empty(), "files open to others: {open:?}");

    // SIGINT to testbed's pid only (not its group): forwarded to the launcher.
    signal(pid, libc::SIGINT);
    let (status, stdout, stderr) = output_of(child);
    assert!(status.success(), "{stderr}");
    let summary: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(summary["log_complete"], true, "{summary}");
    let run_log = RunLog::open(&log).unwrap();
    assert!(run_log.is_complete());
    assert!(run_log.samples::<AttitudeEstimate>().unwrap().count() > 10);
    assert!(processes_on_bus(&format!("tb{pid}_")).is_empty());
    assert_eq!(bus_files(pid), (vec![], vec![]), "the bus was left behind");
}

#[test]
fn kill_9_of_testbed_takes_the_pipeline_down_and_leaves_nothing_behind() {
    let scratch = Scratch::new("safeio-kill");
    let log = scratch.path().join("killed.mcap");
    let child = start_paced(&log, 1);
    let pid = child.id();
    let procs = wait_for_pipeline(pid);
    let launchers = children(pid);
    assert_eq!(launchers.len(), 1, "one launcher: {launchers:?}");
    assert!(
        bus_files(pid)
            .1
            .iter()
            .any(|f| f.to_string_lossy().ends_with("global_mgmt"))
    );
    std::thread::sleep(Duration::from_secs(2));

    signal(pid, libc::SIGKILL);
    let killed = Instant::now();
    let (status, _, stderr) = output_of(child);
    assert_eq!(status.code(), None, "killed by a signal");
    // The launcher outlives testbed: it stops the run and, its processes gone, removes the
    // run's bus root in /tmp and its files in /dev/shm.
    let everything: Vec<u32> = procs.iter().map(|(p, _)| *p).chain(launchers).collect();
    loop {
        let left: Vec<u32> = everything.iter().copied().filter(|p| running(*p)).collect();
        let on_bus = processes_on_bus(&format!("tb{pid}_"));
        let files = bus_files(pid);
        if left.is_empty() && on_bus.is_empty() && files == (vec![], vec![]) {
            break;
        }
        assert!(
            killed.elapsed() < Duration::from_secs(3),
            "3 s after kill -9 of testbed: still running {left:?} {on_bus:?}, bus files left \
             {files:?}\n{stderr}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let gone_after = killed.elapsed();
    // The launcher stopped the pipeline in order: the log was finalised.
    let end = RunLog::open(&log).unwrap().end();
    assert_eq!(end, testbed_log::LogEnd::Complete, "{stderr}");
    eprintln!("pipeline and bus gone {gone_after:?} after kill -9 of testbed");
}

#[test]
fn a_killed_loggers_log_is_repaired_for_standard_readers() {
    let scratch = Scratch::new("safeio-logger");
    let log = scratch.path().join("cut.mcap");
    let child = start_paced(&log, 1);
    let procs = wait_for_pipeline(child.id());
    std::thread::sleep(Duration::from_secs(3));
    let logger = procs
        .iter()
        .find(|(_, name)| name == "logger")
        .expect("a logger")
        .0;
    signal(logger, libc::SIGKILL);
    let (status, stdout, stderr) = output_of(child);
    // The logger is required: the run fails, and says that the log was repaired.
    assert!(!status.success(), "{stderr}");
    assert!(
        stderr.contains("not finalised") && stderr.contains(&log.display().to_string()),
        "{stderr}"
    );
    let summary: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let kept = summary["log_repaired"]["messages"]
        .as_u64()
        .unwrap_or_else(|| panic!("no log_repaired: {summary}"));
    assert!(kept > 100, "{summary}");
    let repaired = RunLog::open(&log).unwrap();
    assert!(repaired.is_complete());
    assert_eq!(repaired.message_count(), kept);
    assert_eq!(python_make_reader_count(&log), kept);
}

#[test]
fn a_cut_log_is_reported_by_replay_and_repaired_by_testbed_log_repair() {
    let scratch = Scratch::new("safeio-cutlog");
    let full = scratch.path().join("full.mcap");
    testbed_run(&[
        "--profile",
        profile("simulation").to_str().unwrap(),
        "--duration",
        "20",
        "--log",
        full.to_str().unwrap(),
    ]);
    let bytes = std::fs::read(&full).unwrap();
    let cut = scratch.path().join("cut.mcap");
    // Cut in the middle of the data, inside a record.
    std::fs::write(&cut, &bytes[..bytes.len() / 2 + 7]).unwrap();
    let cut_log = RunLog::open(&cut).unwrap();
    assert!(!cut_log.is_complete());
    let complete_records = cut_log.message_count();

    // Replay says how much it replayed and that the log was cut.
    let out = Command::new(binary("testbed"))
        .args(["run", "--json", "--replay"])
        .arg(&cut)
        .arg("--log")
        .arg(scratch.path().join("replayed.mcap"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning")
            && stderr.contains(&cut.display().to_string())
            && stderr.contains("was cut")
            && stderr.contains(&format!(
                "replayed its {complete_records} complete messages"
            )),
        "{stderr}"
    );
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(summary["replay_source_cut"].is_string(), "{summary}");

    // Python's make_reader refuses the cut file; `testbed log repair` makes it readable with
    // every complete record.
    let refused = Command::new("python3")
        .args([
            "-c",
            "import sys\nfrom mcap.reader import make_reader\nlist(make_reader(open(sys.argv[1], 'rb')).iter_messages())",
        ])
        .arg(&cut)
        .output()
        .unwrap();
    assert!(!refused.status.success(), "make_reader read a cut file");
    let repaired = scratch.path().join("repaired.mcap");
    let out = Command::new(binary("testbed"))
        .args(["log", "repair"])
        .arg(&cut)
        .arg(&repaired)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains(&format!("{complete_records} messages")),
        "{said}"
    );
    assert_eq!(python_make_reader_count(&repaired), complete_records);
    let repaired_log = RunLog::open(&repaired).unwrap();
    assert!(repaired_log.is_complete());
    let original: Vec<_> = cut_log.records().unwrap().map(|r| r.unwrap()).collect();
    let copied: Vec<_> = repaired_log
        .records()
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    assert!(original == copied, "the repaired log's records differ");
}

#[test]
fn a_cut_identification_csv_is_refused_naming_file_and_line() {
    let scratch = Scratch::new("safeio-csv");
    let data = scratch.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    // The last number, 0.1234, cut to 0.12: still a number, but the line has no newline.
    std::fs::write(
        data.join("gyro.csv"),
        "t_s,wx,wy,wz\n0,0.001,0.002,0.003\n0.1,0.001,0.002,0.12",
    )
    .unwrap();
    let model = scratch.path().join("model.toml");
    std::fs::write(&model, "").unwrap();
    let out = Command::new(binary("testbed"))
        .arg("identify")
        .arg(&data)
        .arg("--model")
        .arg(&model)
        .arg("--out")
        .arg(scratch.path().join("out"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "a cut CSV was accepted: {stderr}");
    assert!(
        stderr.contains("gyro.csv")
            && stderr.contains("line 3")
            && stderr.contains("`wz`")
            && stderr.contains("newline"),
        "{stderr}"
    );
}
