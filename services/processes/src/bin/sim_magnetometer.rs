//! Simulated magnetometer gateway: the lab field in body axes with noise, hard iron and range, at
//! the magnetometer's rate.

use testbed_runtime::process;
use testbed_sim::sim_devices::SimMagnetometer;

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("sim-magnetometer")?;
    let mut device = SimMagnetometer::new(&config, config.schedule()?);
    process::run_sim_gateway(&bus, || Ok(()), |truth| device.on_truth(truth))
}
