//! The candump replay onto the software CAN bus (see `testbed_processes::can_replay`).

fn main() -> anyhow::Result<()> {
    testbed_runtime::run(
        "can-replay",
        testbed_processes::can_replay::CanReplayProcess::open,
    )
}
