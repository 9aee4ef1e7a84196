//! The estimator process (see `testbed_processes::estimator`).

fn main() -> anyhow::Result<()> {
    testbed_runtime::run(
        "estimator",
        testbed_processes::estimator::EstimatorProcess::open,
    )
}
