//! The CMG gateway: its link (software CAN bus, SocketCAN, candump file or serial line, from
//! the run configuration) in, decoding, samples out (see `testbed_processes::can_gateway`).

use testbed_gateways::GatewayDevice;
use testbed_processes::can_gateway::CanGateway;

fn main() -> anyhow::Result<()> {
    let device = ipc_types::Device::Cmg;
    testbed_runtime::run(device.process_name(), |cx| CanGateway::open(cx, device))
}
