//! The cmg gateway: its link (software CAN bus, SocketCAN, candump file or serial line, from
//! the run configuration) in, `testbed_gateways::gateway` decoding, samples out.

fn main() -> anyhow::Result<()> {
    testbed_gateways::run::run_gateway(testbed_gateways::GatewayDevice::Cmg)
}
