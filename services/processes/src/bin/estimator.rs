//! Estimator process: the MEKF, propagating on every gyro sample and updating from the
//! inclinometer and magnetometer; one attitude estimate per tick.

use ipc_types::{AttitudeEstimate, GyroSample, InclinometerSample, MagnetometerSample, ProcessState};
use testbed_bus::{EventLoop, Flow, Waiter};
use testbed_flight::estimator_node::EstimatorNode;
use testbed_runtime::process::{self, FirstError, HEARTBEAT_PERIOD};

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("estimator")?;
    let mut node = EstimatorNode::new(config.estimator_config(), config.schedule()?);
    let gyro = bus.subscriber::<GyroSample>()?;
    let tilt = bus.subscriber::<InclinometerSample>()?;
    let field = bus.subscriber::<MagnetometerSample>()?;
    let estimate = bus.publisher::<AttitudeEstimate>()?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;

    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    events.on_data(&gyro)?;
    events.on_data(&tilt)?;
    events.on_data(&field)?;
    events.with_heartbeat(&heartbeat)?;
    heartbeat.set_state(ProcessState::Running);
    let mut error = FirstError::default();
    events.run(|_| {
        let received = gyro.drain(|s| node.on_gyro(&s)).and_then(|a| {
            Ok(a + tilt.drain(|s| node.on_inclinometer(&s))? + field.drain(|s| node.on_magnetometer(&s))?)
        });
        match received {
            Ok(n) => heartbeat.add_samples_in(n as u64),
            Err(e) => {
                error.failed::<()>(Err(e.into()));
                return Flow::Stop;
            }
        }
        for e in node.ready() {
            heartbeat.set_time_ns(e.header.time_ns);
            if error.failed(estimate.publish(&e).map_err(anyhow::Error::from)) {
                return Flow::Stop;
            }
            heartbeat.add_samples_out(1);
        }
        Flow::Continue
    })?;
    let counters = node.counters();
    tracing::info!(?counters, "estimator stopping");
    heartbeat.set_state(ProcessState::Stopping);
    error.into_result()
}
