//! Controller process: PD + friction compensation on the wheels (or the CMG slew law), one
//! command per tick from the estimate and the actuators' telemetry. Outside lockstep a tick
//! whose estimate is later than its period plus the configured slack is a missed deadline.

use ipc_types::{AttitudeEstimate, CmgCommand, CmgTelemetry, ControllerStatus, ProcessState, WheelCommand, WheelTelemetry};
use std::time::Duration;
use testbed_bus::{EventLoop, Flow, Waiter, Wake};
use testbed_flight::tasks::ControllerTask;
use testbed_flight::controller_node::ControllerNode;
use testbed_runtime::process::{self, FirstError, HEARTBEAT_PERIOD};
use testbed_runtime::ClockMode;

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("controller")?;
    let schedule = config.schedule()?;
    let task = ControllerTask::new(&config.controller, &config.model, config.manoeuvre.target())?;
    let mut node = ControllerNode::new(task, config.controller.actuators, schedule);
    let estimate = bus.subscriber::<AttitudeEstimate>()?;
    let wheels = bus.subscriber::<WheelTelemetry>()?;
    let cmg = bus.subscriber::<CmgTelemetry>()?;
    let status = bus.publisher::<ControllerStatus>()?;
    let wheel_command = bus.publisher::<WheelCommand>()?;
    let cmg_command = bus.publisher::<CmgCommand>()?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;

    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    let deadline = Duration::from_secs_f64(schedule.period_s() + config.run.deadline_slack_s);
    match config.run.mode {
        // In lockstep time stands still while anything waits: no wall-clock deadline applies.
        ClockMode::Lockstep => events.on_data(&estimate)?,
        ClockMode::Paced => events.on_data_with_deadline(&estimate, deadline)?,
    };
    events.on_data(&wheels)?;
    events.on_data(&cmg)?;
    events.with_heartbeat(&heartbeat)?;
    heartbeat.set_state(ProcessState::Running);
    let mut error = FirstError::default();
    events.run(|wake| {
        if let Wake::DeadlineMissed(_) = wake {
            node.count_deadline_miss();
            tracing::warn!(misses = node.deadline_misses(), "control cycle missed its deadline");
        }
        let received = estimate.drain(|e| node.on_estimate(&e)).and_then(|a| {
            Ok(a + wheels.drain(|t| node.on_wheel_telemetry(&t))? + cmg.drain(|t| node.on_cmg_telemetry(&t))?)
        });
        match received {
            Ok(n) => heartbeat.add_samples_in(n as u64),
            Err(e) => {
                error.failed::<()>(Err(e.into()));
                return Flow::Stop;
            }
        }
        for cycle in node.ready() {
            heartbeat.set_time_ns(cycle.status.header.time_ns);
            let sent = status
                .publish(&cycle.status)
                .and_then(|_| wheel_command.publish(&cycle.wheels))
                .and_then(|_| cmg_command.publish(&cycle.cmg));
            if error.failed(sent.map_err(anyhow::Error::from)) {
                return Flow::Stop;
            }
            heartbeat.add_samples_out(3);
        }
        Flow::Continue
    })?;
    tracing::info!(deadline_misses = node.deadline_misses(), errors = node.errors(), "controller stopping");
    heartbeat.set_state(ProcessState::Stopping);
    error.into_result()
}
