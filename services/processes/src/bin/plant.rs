//! Plant process (simulation only): integrates the platform and owns the clock. It waits until
//! every participant of the run reports `Running`, then publishes truth and tick for t = 0.
//! Lockstep: it advances as soon as the tick's wheel and CMG commands are in. Paced: it advances
//! every period of wall time, holding the last command when an answer is late. It exits when the
//! run's duration is reached; the launcher then stops the rest.
//!
//! The commands it integrates are the controller's (`run.actuation = "direct"`), or, with
//! `run.actuation = "can_node"`, the ones the smart CAN node applies after the wheel and CMG
//! gateways and the CAN bus (`AppliedWheelCommand`, `AppliedCmgCommand`, same time stamps).

use ipc_types::{
    AppliedCmgCommand, AppliedWheelCommand, CmgCommand, ProcessState, SimClockTick, SimTruth, WheelCommand,
};
use std::time::{Duration, Instant};
use testbed_bus::{EventLoop, Flow, LoopExit, SubscriberOptions, Waiter, Wake};
use testbed_sim::plant_node::PlantNode;
use testbed_runtime::process::{self, FirstError, HEARTBEAT_PERIOD};
use testbed_runtime::run_config::Actuation;
use testbed_runtime::ClockMode;

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("plant")?;
    let mut node = PlantNode::new(&config)?;
    let truth = bus.publisher::<SimTruth>()?;
    let clock = bus.publisher::<SimClockTick>()?;
    let direct = config.run.actuation == Actuation::Direct;
    let options = SubscriberOptions::buffer(64);
    let wheel_command = direct.then(|| bus.subscriber_with::<WheelCommand>(options)).transpose()?;
    let cmg_command = direct.then(|| bus.subscriber_with::<CmgCommand>(options)).transpose()?;
    let wheel_applied = (!direct).then(|| bus.subscriber_with::<AppliedWheelCommand>(options)).transpose()?;
    let cmg_applied = (!direct).then(|| bus.subscriber_with::<AppliedCmgCommand>(options)).transpose()?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;

    if process::wait_for_participants(&bus, &config.run.participants)? == LoopExit::TerminationRequested {
        return Ok(());
    }
    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    if let (Some(wheel), Some(cmg)) = (&wheel_command, &cmg_command) {
        events.on_data(wheel)?;
        events.on_data(cmg)?;
    }
    if let (Some(wheel), Some(cmg)) = (&wheel_applied, &cmg_applied) {
        events.on_data(wheel)?;
        events.on_data(cmg)?;
    }
    let pace = match config.run.mode {
        ClockMode::Paced => Some(events.on_interval(Duration::from_secs_f64(config.schedule()?.period_s()))?),
        ClockMode::Lockstep => None,
    };
    events.with_heartbeat(&heartbeat)?;
    heartbeat.set_state(ProcessState::Running);

    let mut error = FirstError::default();
    let publish = |node: &mut PlantNode| -> anyhow::Result<()> {
        let (t, c) = node.outputs();
        truth.publish(&t)?;
        clock.publish(&c)?;
        Ok(())
    };
    if error.failed(publish(&mut node)) {
        return error.into_result();
    }
    let started = Instant::now();
    let exit = events.run(|wake| {
        let mut drained = Ok(0);
        if let (Some(wheel), Some(cmg)) = (&wheel_command, &cmg_command) {
            drained = wheel.drain(|c| node.on_wheel_command(&c)).and_then(|_| cmg.drain(|c| node.on_cmg_command(&c)));
        }
        if let (Some(wheel), Some(cmg)) = (&wheel_applied, &cmg_applied) {
            drained = wheel
                .drain(|c| node.on_wheel_command(&WheelCommand::new(c.header, c.torque)))
                .and_then(|_| cmg.drain(|c| node.on_cmg_command(&CmgCommand::new(c.header, c.gimbal_rate))));
        }
        if error.failed(drained.map_err(anyhow::Error::from)) {
            return Flow::Stop;
        }
        let advance_now = match pace {
            None => node.answered(),
            Some(pace) => wake == Wake::Tick(pace),
        };
        if !advance_now {
            return Flow::Continue;
        }
        if node.at_end() {
            return Flow::Stop;
        }
        if error.failed(node.advance().map_err(anyhow::Error::from).and_then(|_| publish(&mut node))) {
            return Flow::Stop;
        }
        heartbeat.set_time_ns(node.time_ns());
        Flow::Continue
    })?;
    let wall = started.elapsed().as_secs_f64();
    let simulated = node.time_ns() as f64 * 1e-9;
    tracing::info!(
        ?exit,
        simulated_s = simulated,
        wall_s = wall,
        x_real_time = simulated / wall.max(1e-9),
        deadline_misses = node.deadline_misses(),
        "plant done"
    );
    heartbeat.set_state(ProcessState::Stopping);
    error.into_result()
}
