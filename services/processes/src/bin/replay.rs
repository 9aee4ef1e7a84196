//! The replay process: a recorded run's inputs, tick by tick (see `testbed_processes::replay`).

fn main() -> anyhow::Result<()> {
    testbed_runtime::run("replay", testbed_processes::replay::ReplayProcess::open)
}
