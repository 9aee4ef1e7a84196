//! The controller process (see `testbed_processes::controller`).

fn main() -> anyhow::Result<()> {
    testbed_runtime::run(
        "controller",
        testbed_processes::controller::ControllerProcess::open,
    )
}
