//! Simulated wheel gateway: tachometer speeds every tick, with the motor torque command in effect.

use ipc_types::WheelCommand;
use std::cell::RefCell;
use testbed_runtime::process;
use testbed_sim::sim_devices::SimWheels;

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("sim-wheels")?;
    let device = RefCell::new(SimWheels::new(&config, config.schedule()?));
    let commands = bus.subscriber::<WheelCommand>()?;
    process::run_sim_gateway(
        &bus,
        || Ok(commands.drain(|c| device.borrow_mut().on_command(&c)).map(|_| ())?),
        |truth| device.borrow_mut().on_truth(truth),
    )
}
