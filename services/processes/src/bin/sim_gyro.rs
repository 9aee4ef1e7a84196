//! Simulated gyro gateway: the gyro model (bias, random walk, noise, quantisation, range) on the
//! plant's truth, every tick, published as the real gyro gateway would.

use testbed_runtime::process;
use testbed_sim::sim_devices::SimGyro;

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("sim-gyro")?;
    let mut device = SimGyro::new(&config, config.schedule()?);
    process::run_sim_gateway(&bus, || Ok(()), |truth| device.on_truth(truth))
}
