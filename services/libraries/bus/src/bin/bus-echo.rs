//! Test helper for the two-process tests of `testbed-bus` (not part of the pipeline).
//!
//! Opens the bus from the environment as node `echo`, answers every [`GyroSample`] with an
//! [`AttitudeEstimate`] carrying the same header, publishes a heartbeat (state `Running` once
//! its ports exist) and runs until SIGINT/SIGTERM, then prints `exit: <LoopExit>` and the
//! number of samples echoed on stdout and exits 0.

use std::time::Duration;

use anyhow::Context as _;
use ipc_types::{AttitudeEstimate, GyroSample, ProcessState};
use testbed_bus::{Bus, BusConfig, EventLoop, Flow, Waiter, Wake};

fn main() -> anyhow::Result<()> {
    testbed_bus::init_logging();
    let config = BusConfig::from_env().context("reading the bus configuration")?;
    let bus = Bus::open("echo", &config).context("opening the bus")?;
    let gyro = bus
        .subscriber::<GyroSample>()
        .context("subscribing to gyro")?;
    let estimate = bus
        .publisher::<AttitudeEstimate>()
        .context("creating the estimate publisher")?;
    let heartbeat = bus
        .heartbeat(Duration::from_millis(200))
        .context("creating the heartbeat")?;

    let waiter = Waiter::new().context("creating the waiter")?;
    let mut events = EventLoop::new(&waiter);
    let on_gyro = events.on_data(&gyro).context("attaching gyro")?;
    heartbeat.set_state(ProcessState::Running);
    events
        .with_heartbeat(&heartbeat)
        .context("attaching the heartbeat")?;

    let mut failure = None;
    let exit = events
        .run(|wake| {
            if wake == Wake::Data(on_gyro) {
                let result = gyro.drain(|sample| {
                    let answer = AttitudeEstimate {
                        header: sample.header,
                        ..Default::default()
                    };
                    if let Err(e) = estimate.publish(&answer) {
                        failure.get_or_insert(e);
                    }
                });
                if let Err(e) = result {
                    failure.get_or_insert(e);
                }
                if failure.is_some() {
                    return Flow::Stop;
                }
            }
            Flow::Continue
        })
        .context("running the event loop")?;
    if let Some(e) = failure {
        return Err(e).context("echoing gyro samples");
    }
    println!("exit: {exit:?}");
    println!("echoed: {}", estimate.sent());
    Ok(())
}
