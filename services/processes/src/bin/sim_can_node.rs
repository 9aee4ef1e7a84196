//! The simulated smart CAN node (see `testbed_processes::can_node`).

fn main() -> anyhow::Result<()> {
    testbed_runtime::run(
        "sim-can-node",
        testbed_processes::can_node::CanNodeProcess::open,
    )
}
