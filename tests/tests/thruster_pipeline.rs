//! The thrusters in the process pipeline: the `thrusters` profile's controller
//! commands the valves every tick, the plant (the simulated thruster drive) checks and applies
//! them, and the logger records both. The processes must compute what the in-process loop
//! computes, bit for bit, and two lockstep runs must give the same bytes. The `thrusters-can`
//! profile sends the same commands through the thruster gateway and the CAN bus to the
//! simulated CAN board.

use ipc_types::{
    AppliedThrusterCommand, AttitudeEstimate, HealthEventKind, SampleHeader, ThrusterCommand,
    ThrusterStatus,
};
use std::path::Path;
use testbed_config::RunConfig;
use testbed_e2e::{
    Scratch, assert_estimates_equal_the_in_process_loop, profile, testbed_run, workspace_root,
};
use testbed_log::{LogEncode, RunLog};
use testbed_sim::closed_loop;

fn samples<T: LogEncode>(log: &RunLog) -> Vec<T> {
    log.samples::<T>().unwrap().map(Result::unwrap).collect()
}

/// Profile `name` with `extra` appended to a copy of its run configuration, written into `dir`.
fn profile_with(dir: &Path, name: &str, extra: &str) -> std::path::PathBuf {
    let run_config = workspace_root().join(format!("launch/run-configs/{name}.run.toml"));
    let config = std::fs::read_to_string(&run_config).unwrap() + extra;
    let config_path = dir.join(format!("{name}.run.toml"));
    std::fs::write(&config_path, config).unwrap();
    let text = std::fs::read_to_string(profile(name)).unwrap();
    let text = text
        .lines()
        .map(|line| {
            if line.starts_with("config = ") {
                format!("config = \"{}\"", config_path.display())
            } else {
                line.to_owned()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text + "\n").unwrap();
    path
}

#[test]
fn the_thrusters_profile_dumps_momentum_and_computes_exactly_the_in_process_loop() {
    let scratch = Scratch::new("thrusters-pipeline");
    let log_path = scratch.path().join("thrusters.mcap");
    let summary = testbed_run(&[
        "--profile",
        profile("thrusters").to_str().unwrap(),
        "--duration",
        "200",
        "--seed",
        "4",
        "--log",
        log_path.to_str().unwrap(),
    ]);
    assert_eq!(summary["log_complete"], true, "{summary}");
    assert_eq!(summary["deadline_misses"], 0, "{summary}");
    let thrusters = &summary["thrusters"];
    // The wheels start at 55 % of their limit, past the 50 % dump threshold: the thrusters fire
    // from the first seconds, and nothing the controller sends is refused.
    assert!(thrusters["firing_periods"].as_u64() > Some(50), "{summary}");
    assert_eq!(thrusters["refused"], 0, "{summary}");
    assert_eq!(thrusters["disabled"], false, "{summary}");
    let used = thrusters["propellant_used_kg"].as_f64().unwrap();
    assert!(used > 0.0, "{summary}");

    // The same run in one process, from the configuration the log carries.
    let log = RunLog::open(&log_path).unwrap();
    let config = RunConfig::from_toml_str(log.config_toml(), "log").unwrap();
    let (trace, _, thruster_trace) =
        closed_loop::run_with_thrusters(&closed_loop::Scenario::from_run(&config)).unwrap();
    let estimates: Vec<AttitudeEstimate> = samples(&log);
    let commands: Vec<ThrusterCommand> = samples(&log);
    let statuses: Vec<ThrusterStatus> = samples(&log);
    assert_eq!(commands.len(), thruster_trace.ticks.len());
    assert_eq!(
        statuses.len(),
        trace.ticks.len() - 1,
        "one status per integrated period"
    );
    // Same code, same inputs, same order: bit for bit.
    assert_estimates_equal_the_in_process_loop(&estimates, &trace);
    for (sample, tick) in commands.iter().zip(&thruster_trace.ticks) {
        assert_eq!(sample.on_time, tick.command.on_time_s, "t = {} s", tick.t_s);
    }
    assert_eq!(
        statuses.last().unwrap().propellant_used,
        thruster_trace.propellant_used_kg
    );
    assert_eq!(used, thruster_trace.propellant_used_kg);
    let shift: Vec<f64> = thrusters["com_shift_m"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(shift, thruster_trace.com_shift_m.as_slice());
    // The dump works: every wheel ends below the 10 % stop threshold's neighbourhood, far
    // under where it started (3300 rpm).
    let last = trace.ticks.last().unwrap();
    let rpm = last
        .truth
        .wheel_speed
        .map(|w| w.abs() * 30.0 / std::f64::consts::PI);
    assert!(
        rpm.iter().all(|w| *w < 1500.0),
        "wheels at the end: {rpm:?} rpm"
    );
}

#[test]
fn two_lockstep_runs_with_thrusters_give_byte_identical_logs() {
    let scratch = Scratch::new("thrusters-determinism");
    let log = scratch.path().join("run.mcap");
    let mut bytes = Vec::new();
    for _ in 0..2 {
        testbed_run(&[
            "--profile",
            profile("thrusters").to_str().unwrap(),
            "--duration",
            "40",
            "--seed",
            "12",
            // The log's times are the run's wall-clock start plus the run clock: pin the start.
            "--start-time-ns",
            "1795503600000000000",
            "--log",
            log.to_str().unwrap(),
        ]);
        bytes.push(std::fs::read(&log).unwrap());
    }
    let log_read = RunLog::open(&log).unwrap();
    let fired = samples::<ThrusterCommand>(&log_read)
        .iter()
        .filter(|c| c.on_time.iter().any(|t| *t > 0.0))
        .count();
    assert!(fired > 10, "the thrusters fired in {fired} periods");
    assert!(bytes[0] == bytes[1], "lockstep logs with thrusters differ");
}

/// Runs `name` with thruster 4 (+Z) stuck open from 20 s for `duration_s`, checks what both
/// paths must show, and returns the log and the time (ns) of the first status reporting the
/// thrusters disabled: its valve reads open in periods it was not commanded, and after
/// `stuck_open_confirm_periods` (3) such periods the thrusters are disabled, within 2 s (a dump
/// driving the valve through whole periods delays the confirmation), one `ThrustersDisabled`
/// event names thruster 4, and no later status reports a valve driven.
fn run_with_a_stuck_valve(scratch: &Scratch, name: &str, duration_s: f64) -> (RunLog, u64) {
    let profile = profile_with(
        scratch.path(),
        name,
        "\n[model.thrusters.stuck_open]\nthruster = 4\nfrom_s = 20.0\n",
    );
    // The stuck valve's torque may push the controller into safe mode (wheel near its limit):
    // that is the right response here, so the run's exit status is not asked for; the summary
    // is read from --json either way.
    let log_path = scratch.path().join("stuck.mcap");
    let out = std::process::Command::new(testbed_e2e::binary("testbed"))
        .args(["run", "--profile"])
        .arg(&profile)
        .args([
            "--duration",
            &duration_s.to_string(),
            "--seed",
            "2",
            "--json",
            "--log",
        ])
        .arg(&log_path)
        .output()
        .unwrap();
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "no JSON summary ({e}): {}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    assert_eq!(summary["thrusters"]["disabled"], true, "{summary}");
    let log = RunLog::open(&log_path).unwrap();
    let statuses: Vec<ThrusterStatus> = samples(&log);
    let first_disabled = statuses
        .iter()
        .find(|s| s.disabled != 0)
        .expect("a status with the thrusters disabled")
        .header
        .time_ns;
    let t = first_disabled as f64 * 1e-9;
    assert!((20.0..=22.0).contains(&t), "disabled at {t} s");
    assert!(
        statuses
            .iter()
            .filter(|s| s.header.time_ns > first_disabled)
            .all(|s| { s.disabled != 0 && s.applied_on_time == [0.0; 6] }),
        "once disabled, no valve is driven"
    );
    let events: Vec<ipc_types::HealthEvent> = samples(&log);
    let disabled: Vec<_> = events
        .iter()
        .filter(|e| e.kind() == Some(HealthEventKind::ThrustersDisabled))
        .collect();
    assert_eq!(disabled.len(), 1, "{events:?}");
    assert_eq!(disabled[0].detail, 4, "the stuck thruster is named");
    (log, first_disabled)
}

#[test]
fn a_stuck_open_valve_is_detected_and_the_thrusters_are_disabled() {
    // The plant's drive checks and senses the valves (direct actuation).
    let scratch = Scratch::new("thrusters-stuck");
    run_with_a_stuck_valve(&scratch, "thrusters", 60.0);
}

/// Half a least significant bit of the on-time field on the wire (10 µs LSB), s.
const HALF_LSB_S: f64 = 5e-6;

#[test]
fn over_can_the_node_applies_what_the_controller_commanded_and_runs_are_byte_identical() {
    let scratch = Scratch::new("thrusters-can");
    let log_path = scratch.path().join("run.mcap");
    let mut bytes = Vec::new();
    let mut summary = serde_json::Value::Null;
    for _ in 0..2 {
        summary = testbed_run(&[
            "--profile",
            profile("thrusters-can").to_str().unwrap(),
            "--duration",
            "60",
            "--seed",
            "3",
            "--start-time-ns",
            "1795503600000000000",
            "--log",
            log_path.to_str().unwrap(),
        ]);
        bytes.push(std::fs::read(&log_path).unwrap());
    }
    assert!(
        bytes[0] == bytes[1],
        "lockstep logs of thrusters-can differ"
    );
    assert_eq!(summary["log_complete"], true, "{summary}");
    assert_eq!(summary["deadline_misses"], 0, "{summary}");
    assert_eq!(summary["thrusters"]["refused"], 0, "{summary}");
    assert!(
        summary["thrusters"]["firing_periods"].as_u64() > Some(50),
        "{summary}"
    );

    let log = RunLog::open(&log_path).unwrap();
    let commands: Vec<ThrusterCommand> = samples(&log);
    let applied: Vec<AppliedThrusterCommand> = samples(&log);
    let statuses: Vec<ThrusterStatus> = samples(&log);
    // One command, one applied command and one status per tick (0 to 60 s in 0.1-s ticks, the
    // last tick answered too); the board's status at tick k reports the period before it.
    assert_eq!(commands.len(), 601);
    assert_eq!(applied.len(), commands.len());
    assert_eq!(statuses.len(), 601);
    assert_eq!(statuses[0].applied_on_time, [0.0; 6]);
    // What reaches the valves is what the controller asked, to half an LSB of the wire, and
    // never stale on a fault-free bus.
    for (c, a) in commands.iter().zip(&applied) {
        assert_eq!(c.header.time_ns, a.header.time_ns);
        assert_eq!(a.header.flags & SampleHeader::STALE, 0);
        for (want, got) in c.on_time.iter().zip(a.on_time) {
            assert!(
                (want - got).abs() <= HALF_LSB_S * (1.0 + 1e-9),
                "t = {} ns: {want} commanded, {got} applied",
                c.header.time_ns
            );
        }
    }
    // The board reports the period's applied on-times with the period's end, and the gateway
    // adds up the propellant: it grows exactly when a valve was driven.
    let mut last_used = 0.0;
    for (status, a) in statuses[1..].iter().zip(&applied) {
        assert_eq!(status.header.time_ns, a.header.time_ns + 100_000_000);
        assert_eq!(status.applied_on_time, a.on_time);
        let fired = a.on_time.iter().any(|t| *t > 0.0);
        assert_eq!(status.propellant_used > last_used, fired);
        last_used = status.propellant_used;
        assert_eq!(status.disabled, 0);
    }
}

#[test]
fn over_can_a_stuck_open_valve_is_detected_and_the_latch_valve_shut() {
    // The thruster gateway senses the valves through the board's status frames; from the next
    // command on every command carries the latch flag and no valve is driven.
    let scratch = Scratch::new("thrusters-can-stuck");
    let (log, first_disabled) = run_with_a_stuck_valve(&scratch, "thrusters-can", 40.0);
    let applied: Vec<AppliedThrusterCommand> = samples(&log);
    let after: Vec<_> = applied
        .iter()
        .filter(|a| a.header.time_ns >= first_disabled)
        .collect();
    assert!(!after.is_empty());
    assert!(
        after
            .iter()
            .all(|a| a.latch_shut == 1 && a.on_time == [0.0; 6]),
        "once disabled, the latch valve is shut and no valve is driven"
    );
}
