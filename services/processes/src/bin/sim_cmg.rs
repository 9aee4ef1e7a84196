//! Simulated CMG gateway: encoder gimbal angles every tick, with the gimbal rate command in effect.

use ipc_types::CmgCommand;
use std::cell::RefCell;
use testbed_runtime::process;
use testbed_sim::sim_devices::SimCmg;

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("sim-cmg")?;
    let device = RefCell::new(SimCmg::new(&config, config.schedule()?));
    let commands = bus.subscriber::<CmgCommand>()?;
    process::run_sim_gateway(
        &bus,
        || Ok(commands.drain(|c| device.borrow_mut().on_command(&c)).map(|_| ())?),
        |truth| device.borrow_mut().on_truth(truth),
    )
}
