//! The simulated wheel gateway: the device model on the plant's truth, publishing what the real
//! gateway would (see `testbed_processes::sim_gateway`).

use testbed_processes::sim_gateway::SimGateway;
use testbed_sim::sim_devices::SimWheels;

fn main() -> anyhow::Result<()> {
    testbed_runtime::run("sim-wheels", SimGateway::<SimWheels>::open)
}
