//! Several simulated gateways in one process: every device the launcher lists for it (the
//! profile's `device = [...]`), each publishing what its own gateway process would, woken
//! once per tick instead of once per device (see `testbed_processes::sim_gateway`).

use testbed_processes::sim_gateway::SimGateway;

fn main() -> anyhow::Result<()> {
    testbed_runtime::run("sim-devices", SimGateway::open_served)
}
