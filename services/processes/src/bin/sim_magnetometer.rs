//! The simulated magnetometer gateway: the device model on the plant's truth, publishing what the real
//! gateway would (see `testbed_processes::sim_gateway`).

use ipc_types::Device;
use testbed_processes::sim_gateway::SimGateway;

fn main() -> anyhow::Result<()> {
    testbed_runtime::run("sim-magnetometer", |cx| {
        SimGateway::open(cx, &[Device::Magnetometer])
    })
}
