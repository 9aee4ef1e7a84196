//! Replays a recorded `candump -L` file (`can.candump`) onto the software CAN bus, tick by tick
//! in lockstep with the estimator (`testbed_gateways::run::run_replay`).

fn main() -> anyhow::Result<()> {
    testbed_gateways::run::run_replay()
}
