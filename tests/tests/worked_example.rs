//! The README's worked example of a process (`services/processes/examples/estimate_watch.rs`)
//! runs as a real process on a bus: it is started as the launcher would start it, counts the
//! estimates published to it, and reports them when asked to stop.

use ipc_types::{AttitudeEstimate, Heartbeat, SampleHeader};
use std::io::Read;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use testbed_bus::{Bus, BusConfig, Delivery, SubscriberOptions, remove_all};
use testbed_config::RunConfig;
use testbed_e2e::{Scratch, cargo_profile_args, profile_dir, workspace_root};

/// The example binary, built in the test's own profile.
fn example_binary() -> std::path::PathBuf {
    let profile_dir = profile_dir();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut build = Command::new(cargo);
    build.current_dir(workspace_root()).args([
        "build",
        "--quiet",
        "-p",
        "testbed-processes",
        "--example",
        "estimate_watch",
    ]);
    build.args(cargo_profile_args(&profile_dir));
    assert!(
        build.status().expect("running cargo build").success(),
        "building the example failed"
    );
    profile_dir.join("examples/estimate_watch")
}

#[test]
fn the_worked_example_counts_estimates_and_reports_them_when_stopped() {
    let scratch = Scratch::new("worked-example");
    let id = std::process::id();
    // Lossless, as in a lockstep run: the burst below waits for the example rather than dropping.
    let bus_config = BusConfig::new(format!("twe{id}_"), format!("/tmp/twe{id}/"))
        .with_delivery(Delivery::Lossless);
    let run_config = scratch.path().join("run.toml");
    std::fs::write(&run_config, RunConfig::default().to_toml_string()).unwrap();

    let mut child = Command::new(example_binary())
        .envs(bus_config.env_vars())
        .env(testbed_config::ENV_RUN_CONFIG, &run_config)
        .env("RUST_LOG", "info")
        .env("NO_COLOR", "1")
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting the example");

    let bus = Bus::open("worked-example-test", &bus_config).unwrap();
    let estimates = bus.publisher::<AttitudeEstimate>().unwrap();
    let heartbeats = bus
        .subscriber_with::<Heartbeat>(SubscriberOptions::buffer(64))
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while estimates.subscriber_count() == 0 {
        assert!(Instant::now() < deadline, "the example never subscribed");
        std::thread::sleep(Duration::from_millis(20));
    }
    // 20 estimates, every fourth not valid. The first alone: a subscriber attaches to a new
    // publisher when it first reads (testbed-bus `TopicPublisher::publish`), so the burst waits
    // until the example's heartbeat shows that read.
    let estimate = |k: u64| {
        let flags = if k % 4 == 3 { 0 } else { SampleHeader::VALID };
        AttitudeEstimate {
            header: SampleHeader::new(k * 100_000_000, k, flags),
            ..Default::default()
        }
    };
    estimates.publish(&estimate(0)).unwrap();
    let mut read_one = false;
    while !read_one {
        assert!(
            Instant::now() < deadline,
            "the example never read its first estimate"
        );
        heartbeats
            .drain(|h| read_one |= h.name() == "estimate-watch" && h.samples_in >= 1)
            .unwrap();
        std::thread::sleep(Duration::from_millis(20));
    }
    for k in 1..20u64 {
        estimates.publish(&estimate(k)).unwrap();
    }
    std::thread::sleep(Duration::from_millis(500));
    // SAFETY: signalling our own child by its pid.
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let status = child.wait().expect("waiting for the example");
    let mut log = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut log)
        .unwrap();
    drop(estimates);
    drop(heartbeats);
    drop(bus);
    let _ = remove_all(&bus_config);
    assert!(status.success(), "the example failed ({status}):\n{log}");
    let report = log
        .lines()
        .find(|l| l.contains("estimate watch done"))
        .unwrap_or_else(|| panic!("no report:\n{log}"));
    assert!(
        report.contains("seen=20") && report.contains("invalid=5"),
        "wrong counts: {report}"
    );
}
