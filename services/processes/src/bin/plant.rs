//! The plant process, clock owner of a simulated run (see `testbed_processes::plant`).

fn main() -> anyhow::Result<()> {
    testbed_runtime::run("plant", testbed_processes::plant::PlantProcess::open)
}
