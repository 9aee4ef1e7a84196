//! The simulated smart CAN node: the plant's truth through the device models onto the software
//! CAN bus, and the commands from the bus to the plant (`testbed_gateways::node`).

fn main() -> anyhow::Result<()> {
    testbed_gateways::run::run_node()
}
