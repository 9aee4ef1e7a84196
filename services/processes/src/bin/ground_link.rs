//! The ground link process: the ground station's server (see `testbed_processes::ground_link`).

fn main() -> anyhow::Result<()> {
    testbed_runtime::run(
        "ground-link",
        testbed_processes::ground_link::GroundLinkProcess::open,
    )
}
