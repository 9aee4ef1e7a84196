//! Profile parsing and validation.

use std::path::{Path, PathBuf};

use testbed_launch::profile::{ClockMode, Device, Profile, Source};

fn profiles_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("profiles")
}

fn parse(text: &str) -> Result<Profile, String> {
    Profile::parse(text, Path::new("test-profile.toml")).map_err(|e| e.to_string())
}

fn names(profile: &Profile) -> Vec<&str> {
    profile.ordered().map(|p| p.name.as_str()).collect()
}

/// The error for `text`, checked to name the file and each of `needles`.
fn error(text: &str, needles: &[&str]) -> String {
    let message = parse(text).expect_err("profile must be refused");
    assert!(
        message.contains("test-profile.toml"),
        "no file name in: {message}"
    );
    for needle in needles {
        assert!(
            message.contains(needle),
            "{needle:?} missing from: {message}"
        );
    }
    message
}

const RUN: &str = "[run]\nmode = \"paced\"\n";

#[test]
fn shipped_profiles_are_valid() {
    for name in [
        "simulation",
        "simulation-grouped",
        "platform",
        "mixed",
        "replay",
        "can-sim",
        "can-replay",
    ] {
        let profile = Profile::load(&profiles_dir().join(format!("{name}.toml")))
            .unwrap_or_else(|e| panic!("{e}"));
        // Every dependency starts before its dependent.
        let order = names(&profile);
        for p in &profile.processes {
            let at = order.iter().position(|n| *n == p.name).expect("in order");
            for dep in &p.depends_on {
                let dep_at = order
                    .iter()
                    .position(|n| n == dep)
                    .expect("dependency in order");
                assert!(dep_at < at, "{name}: {dep} must start before {}", p.name);
            }
        }
        // A profile that serves devices lists and serves every one (replay serves none: its
        // inputs come from a log).
        let serves_devices = profile.processes.iter().any(|p| !p.device.is_empty());
        for device in Device::ALL.into_iter().filter(|_| serves_devices) {
            assert!(
                profile.devices.contains_key(&device),
                "{name}: {device:?} not listed"
            );
        }
        assert_eq!(
            order.first(),
            Some(&"logger"),
            "{name}: the logger starts first, stops last"
        );
    }
    let sim = Profile::load(&profiles_dir().join("simulation.toml")).expect("valid");
    assert_eq!(sim.run.mode, ClockMode::Lockstep);
    assert!(sim.devices.values().all(|s| *s == Source::Simulated));
    assert!(
        sim.processes
            .iter()
            .any(|p| p.name == "plant" && p.ends_run)
    );
    // The grouped simulation: one process serves the five simulated devices.
    let grouped = Profile::load(&profiles_dir().join("simulation-grouped.toml")).expect("valid");
    let serving: Vec<_> = grouped
        .processes
        .iter()
        .filter(|p| !p.device.is_empty())
        .collect();
    assert_eq!(serving.len(), 1);
    assert_eq!(serving[0].device, Device::ALL);
    assert_eq!(grouped.devices, sim.devices);
    let platform = Profile::load(&profiles_dir().join("platform.toml")).expect("valid");
    assert!(platform.devices.values().all(|s| *s == Source::Real));
    assert!(
        platform
            .processes
            .iter()
            .all(|p| !p.command.starts_with("sim-") && p.name != "plant")
    );
    let mixed = Profile::load(&profiles_dir().join("mixed.toml")).expect("valid");
    assert_eq!(mixed.devices[&Device::Gyro], Source::Real);
    assert_eq!(mixed.run.mode, ClockMode::Paced);
    assert_eq!(
        mixed
            .devices
            .values()
            .filter(|s| **s == Source::Simulated)
            .count(),
        4
    );
}

#[test]
fn start_order_follows_dependencies_then_file_order() {
    let profile = parse(&format!(
        "{RUN}
[[process]]
name = \"c\"
command = \"x\"
depends_on = [\"b\"]
[[process]]
name = \"d\"
command = \"x\"
[[process]]
name = \"b\"
command = \"x\"
depends_on = [\"a\"]
[[process]]
name = \"a\"
command = \"x\"
"
    ))
    .expect("valid");
    assert_eq!(names(&profile), ["d", "a", "b", "c"]);
}

#[test]
fn defaults_are_applied() {
    let profile = parse(&format!(
        "{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\n"
    ))
    .expect("valid");
    let p = &profile.processes[0];
    assert!(p.required && !p.ends_run && p.args.is_empty() && p.depends_on.is_empty());
    assert_eq!(p.on_exit, testbed_launch::profile::OnExit::StopAll);
    assert_eq!(profile.supervision.stop_timeout_s, 2.0);
    assert_eq!(profile.supervision.term_timeout_s, 2.0);
    assert_eq!(profile.run.seed, 0);
    assert_eq!(profile.platform.cpu_latency_us, None);
}

#[test]
fn a_cpu_latency_request_is_read_and_checked() {
    let body = "[[process]]\nname = \"a\"\ncommand = \"x\"\n";
    let profile = parse(&format!("{RUN}[platform]\ncpu_latency_us = 0\n{body}")).expect("valid");
    assert_eq!(profile.platform.cpu_latency_us, Some(0));
    error(
        &format!("{RUN}[platform]\ncpu_latency_us = 2000000001\n{body}"),
        &["platform.cpu_latency_us", "2000000001", "at most"],
    );
    error(
        &format!("{RUN}[platform]\ncpu_latency_us = -1\n{body}"),
        &["cpu_latency_us", "-1"],
    );
    error(
        &format!("{RUN}[platform]\ncpu_latency = 0\n{body}"),
        &["cpu_latency"],
    );
}

#[test]
fn unknown_keys_are_refused() {
    error(
        &format!("{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\ncolour = \"red\"\n"),
        &["colour"],
    );
    error(
        &format!("{RUN}speed = 2\n[[process]]\nname = \"a\"\ncommand = \"x\"\n"),
        &["speed"],
    );
    error(
        &format!("{RUN}[extra]\n[[process]]\nname = \"a\"\ncommand = \"x\"\n"),
        &["extra"],
    );
    error(&format!("{RUN}[devices]\nlidar = \"real\"\n"), &["lidar"]);
}

#[test]
fn bad_values_name_key_and_value() {
    error(
        &format!("{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\non_exit = \"bogus\"\n"),
        &["on_exit", "bogus"],
    );
    error("[run]\nmode = \"fast\"\n", &["mode", "fast"]);
    error(
        &format!("{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\nmax_restarts = -1\n"),
        &["max_restarts", "-1"],
    );
    error(
        &format!("{RUN}[devices]\ngyro = \"maybe\"\n"),
        &["gyro", "maybe"],
    );
    error(
        &format!(
            "{RUN}[supervision]\nstop_timeout_s = -1.0\n[[process]]\nname = \"a\"\ncommand = \"x\"\n"
        ),
        &["supervision.stop_timeout_s", "-1"],
    );
    error(
        "[run]\nmode = \"paced\"\nduration_s = 0.0\n[[process]]\nname = \"a\"\ncommand = \"x\"\n",
        &["run.duration_s", "0"],
    );
    error(
        &format!("{RUN}[[process]]\nname = \"has space\"\ncommand = \"x\"\n"),
        &["process[0].name", "has space"],
    );
    error(
        &format!("{RUN}[[process]]\nname = \"a\"\ncommand = \" \"\n"),
        &["process.a.command"],
    );
    error(RUN, &["process", "at least one"]);
    let process = format!("{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\n");
    error(
        &format!("{process}cpus = []\n"),
        &["process.a.cpus", "names no CPU"],
    );
    error(
        &format!("{process}cpus = [0, 1, 0]\n"),
        &["process.a.cpus", "CPU 0 is repeated"],
    );
    error(
        &format!("{process}cpus = \"hot\"\n"),
        &["cpus = \"hot\"", "hot-path", "background"],
    );
    error(
        &format!(
            "{RUN}[platform]\nhot_path_cpu = 5000\n{}",
            &process[RUN.len()..]
        ),
        &["platform.hot_path_cpu", "5000"],
    );
    error(
        &format!("{process}scheduling = {{ policy = \"fifo\", priority = 0 }}\n"),
        &["process.a.scheduling", "priority = 0", "1 ..= 99"],
    );
    error(
        &format!("{process}scheduling = {{ policy = \"other\", nice = 30 }}\n"),
        &["process.a.scheduling", "nice = 30"],
    );
    error(
        &format!("{process}scheduling = {{ policy = \"deadline\" }}\n"),
        &["scheduling", "deadline"],
    );
}

#[test]
fn dependency_errors_name_the_processes() {
    error(
        &format!("{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\ndepends_on = [\"nope\"]\n"),
        &[
            "process.a.depends_on",
            "\"nope\"",
            "no process has this name",
        ],
    );
    let message = error(
        &format!(
            "{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\ndepends_on = [\"b\"]\n\
             [[process]]\nname = \"b\"\ncommand = \"x\"\ndepends_on = [\"a\"]\n\
             [[process]]\nname = \"c\"\ncommand = \"x\"\n"
        ),
        &["dependency cycle"],
    );
    assert!(
        message.contains("a -> b -> a") || message.contains("b -> a -> b"),
        "{message}"
    );
    error(
        &format!("{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\ndepends_on = [\"a\"]\n"),
        &["dependency cycle: a -> a"],
    );
    error(
        &format!(
            "{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\n[[process]]\nname = \"a\"\ncommand = \"y\"\n"
        ),
        &["process[1].name", "duplicate"],
    );
}

#[test]
fn policies_must_be_consistent() {
    error(
        &format!("{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\non_exit = \"ignore\"\n"),
        &["process.a.on_exit", "ignore", "required"],
    );
    error(
        &format!("{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\non_exit = \"restart\"\n"),
        &["process.a.max_restarts", "at least 1"],
    );
    error(
        &format!("{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\nmax_restarts = 2\n"),
        &["process.a.max_restarts", "2"],
    );
    error(
        &format!(
            "{RUN}[[process]]\nname = \"a\"\ncommand = \"x\"\nenv = {{ TESTBED_BUS_PREFIX = \"x\" }}\n"
        ),
        &["process.a.env", "TESTBED_BUS_PREFIX"],
    );
}

#[test]
fn devices_must_match_their_processes() {
    let base = "[[process]]\nname = \"g\"\ncommand = \"x\"\ndevice = \"gyro\"\nsource = \"real\"\n";
    error(
        &format!("[run]\nmode = \"lockstep\"\n[devices]\ngyro = \"real\"\n{base}"),
        &["run.mode", "lockstep", "devices.gyro"],
    );
    error(
        &format!("{RUN}[devices]\ngyro = \"simulated\"\n{base}"),
        &["process.g.source", "real", "devices.gyro = \"simulated\""],
    );
    error(
        &format!("{RUN}{base}"),
        &["process.g.device", "gyro", "[devices]"],
    );
    error(
        &format!("{RUN}[devices]\ngyro = \"real\"\ncmg = \"real\"\n{base}"),
        &["devices.cmg", "no [[process]] serves"],
    );
    error(
        &format!(
            "{RUN}[devices]\ngyro = \"real\"\n{base}[[process]]\nname = \"h\"\ncommand = \"x\"\ndevice = \"gyro\"\nsource = \"real\"\n"
        ),
        &["process.h.device", "already serves"],
    );
    error(
        &format!("{RUN}[[process]]\nname = \"g\"\ncommand = \"x\"\ndevice = \"gyro\"\n"),
        &["process.g.source", "needs `source`"],
    );
    parse(&format!("{RUN}[devices]\ngyro = \"real\"\n{base}")).expect("consistent");
}

#[test]
fn a_process_may_serve_several_devices() {
    let two = "[[process]]\nname = \"g\"\ncommand = \"x\"\ndevice = [\"gyro\", \"cmg\"]\nsource = \"simulated\"\n";
    let devices = "[devices]\ngyro = \"simulated\"\ncmg = \"simulated\"\n";
    let profile = parse(&format!("{RUN}{devices}{two}")).expect("one process serves both");
    assert_eq!(profile.processes[0].device, [Device::Gyro, Device::Cmg]);
    // Each device of the list is checked as a single one is.
    error(
        &format!("{RUN}[devices]\ngyro = \"simulated\"\ncmg = \"real\"\n{two}"),
        &["process.g.source", "simulated", "devices.cmg = \"real\""],
    );
    error(
        &format!("{RUN}[devices]\ngyro = \"simulated\"\n{two}"),
        &["process.g.device", "cmg", "[devices] does not list cmg"],
    );
    error(
        &format!(
            "{RUN}{devices}{two}[[process]]\nname = \"h\"\ncommand = \"x\"\ndevice = \"cmg\"\nsource = \"simulated\"\n"
        ),
        &["process.h.device", "cmg", "process \"g\" already serves"],
    );
    error(
        &format!(
            "{RUN}{devices}[[process]]\nname = \"g\"\ncommand = \"x\"\ndevice = [\"gyro\", \"cmg\", \"gyro\"]\nsource = \"simulated\"\n"
        ),
        &["process.g.device", "gyro", "listed twice"],
    );
    error(
        &format!(
            "{RUN}[[process]]\nname = \"g\"\ncommand = \"x\"\ndevice = []\nsource = \"simulated\"\n"
        ),
        &["device", "an empty list"],
    );
    error(
        &format!(
            "{RUN}[[process]]\nname = \"g\"\ncommand = \"x\"\ndevice = [\"gyro\", \"lidar\"]\nsource = \"simulated\"\n"
        ),
        &["device", "unknown device \"lidar\"", "known: gyro"],
    );
}

#[test]
fn unreadable_file_is_named() {
    let err = Profile::load(Path::new("/nonexistent/profile.toml")).expect_err("missing");
    assert!(
        err.to_string().contains("/nonexistent/profile.toml"),
        "{err}"
    );
}
