//! The thruster gateway: the controller's valve commands checked (`ThrusterGuard`) and encoded
//! onto the CAN link; the node's thruster status decoded, completed (refusals, propellant,
//! disabled) and published; a stuck-open valve disables the thrusters (see
//! `testbed_processes::can_gateway`).

use testbed_gateways::GatewayDevice;
use testbed_gateways::gateway::Served;
use testbed_processes::can_gateway::CanGateway;

fn main() -> anyhow::Result<()> {
    let served = Served::Thrusters;
    testbed_runtime::run(served.process_name(), |cx| CanGateway::open(cx, served))
}
