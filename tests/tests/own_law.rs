//! "Bring your own law" end to end (docs/control-laws.md): a law and a filter chosen by name in
//! the run configuration — the worked example `pd_deadband` and the `complementary` filter —
//! run through the real processes in lockstep, with no other code changed, and the processes
//! compute bit for bit what the in-process loop computes from the configuration the log keeps.

use ipc_types::ControllerStatus;
use testbed_config::RunConfig;
use testbed_e2e::{Scratch, assert_log_equals_the_in_process_loop, profile, testbed_run};
use testbed_log::RunLog;

#[test]
fn a_law_and_a_filter_chosen_by_name_run_through_the_processes() {
    let scratch = Scratch::new("own-law");
    let config = scratch.path().join("own-law.run.toml");
    std::fs::write(
        &config,
        "[controller]\nlaw = \"pd_deadband\"\n[controller.pd_deadband]\ndeadband_rad = 2e-4\n\
         [estimator]\nfilter = \"complementary\"\n",
    )
    .unwrap();
    let log = scratch.path().join("own-law.mcap");
    let summary = testbed_run(&[
        "--profile",
        profile("simulation").to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
        "--duration",
        "30",
        "--seed",
        "5",
        "--log",
        log.to_str().unwrap(),
    ]);
    let described = summary["controller"].as_str().unwrap();
    assert!(described.contains("dead band"), "{summary}");

    let run_log = RunLog::open(&log).unwrap();
    let recorded = RunConfig::from_toml_str(run_log.config_toml(), "log").unwrap();
    assert_eq!(recorded.controller.law, "pd_deadband");
    assert_eq!(recorded.estimator.filter, "complementary");

    // The law acts: from the default 5°/5°/20° start the error shrinks (the loop's ω_n is
    // 0.07 rad/s: after 30 s the tilt is well under half its start).
    let statuses: Vec<ControllerStatus> = run_log
        .samples::<ControllerStatus>()
        .unwrap()
        .map(Result::unwrap)
        .collect();
    // The tilt (X, Y) part of the reported attitude error, rad.
    let tilt = |s: &ControllerStatus| s.attitude_error[0].hypot(s.attitude_error[1]);
    let first = statuses.iter().find(|s| tilt(s) > 0.0).unwrap();
    let last = statuses.last().unwrap();
    assert!(
        tilt(last) < 0.5 * tilt(first),
        "{:?} → {:?}",
        first.attitude_error,
        last.attitude_error
    );

    // Same code, same inputs, same order: bit for bit the in-process loop.
    assert_log_equals_the_in_process_loop(&run_log);
}
