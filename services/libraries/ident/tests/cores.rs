//! Identification spreads its filter runs, a selection step's candidates and the folds of its
//! cross-validation across the cores: the report must not depend on how many there are, or on
//! the order in which the threads finish. Seeds fixed; 600 s of the identification experiment.

mod common;
use common::*;
use testbed_ident::{Identification, identify};

/// The report and the extended model of `data` identified on a pool of `threads`.
fn on_threads(data: &testbed_ident::Dataset, threads: usize) -> (String, String) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let id: Identification = pool
        .install(|| identify(data, &nominal(), &options()))
        .expect("identification runs");
    (
        serde_json::to_string(&id.report).expect("report serialises"),
        id.extended.to_toml_string(),
    )
}

/// A sensor cause (fitted through the filter, screened and cross-validated) beside a torque
/// cause: every report field, fitted values and filter-run count included, is the same on one
/// thread and on four (more threads than this machine's cores, so they interleave).
#[test]
fn the_report_is_the_same_on_one_thread_and_on_four() {
    let t = truth(
        "[effects.gyro_scale]\nppm = [800.0, -600.0, 500.0]\n\
         [effects.constant_torque]\ntorque_nm = [2e-4, -1e-4, 0.0]\n",
    );
    let data = experiment_data(&t, 7, 600.0);
    let one = on_threads(&data, 1);
    let four = on_threads(&data, 4);
    let report: serde_json::Value = serde_json::from_str(&one.0).expect("report parses");
    println!(
        "verdict {}, filter runs {}",
        report["verdict"], report["filter_runs"]
    );
    assert!(
        report["verdict"]
            .as_str()
            .is_some_and(|v| v.contains("gyro_scale")),
        "the case exercises a sensor fit: {}",
        report["verdict"]
    );
    assert!(
        one.0 == four.0,
        "the reports differ between one thread and four"
    );
    assert_eq!(one.1, four.1, "the extended models differ");
}
