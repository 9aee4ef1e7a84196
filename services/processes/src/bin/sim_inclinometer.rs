//! Simulated inclinometer gateway: tilt angles with noise and range, at the inclinometer's rate.

use testbed_runtime::process;
use testbed_sim::sim_devices::SimInclinometer;

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("sim-inclinometer")?;
    let mut device = SimInclinometer::new(&config, config.schedule()?);
    process::run_sim_gateway(&bus, || Ok(()), |truth| device.on_truth(truth))
}
