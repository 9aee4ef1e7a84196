//! Replay process: feeds a recorded run's sensor and actuator telemetry (and its truth and clock,
//! for the log) back into the estimator and controller, one tick at a time, waiting for the
//! controller's commands of each tick as the plant does in lockstep. Exits after the last tick.

use anyhow::Context;
use ipc_types::*;
use testbed_bus::{EventLoop, Flow, LoopExit, SubscriberOptions, Waiter};
use testbed_runtime::process::{self, FirstError, HEARTBEAT_PERIOD};
use testbed_processes::replay_node::{self, ReplayTick};

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("replay")?;
    let source = config.run.replay.clone().context("run.replay names no log to replay")?;
    let ticks = replay_node::load(&source).with_context(|| format!("reading {}", source.display()))?;
    anyhow::ensure!(!ticks.is_empty(), "{} holds no gyro samples to replay", source.display());
    tracing::info!(log = %source.display(), ticks = ticks.len(), "replaying");

    let truth = bus.publisher::<SimTruth>()?;
    let clock = bus.publisher::<SimClockTick>()?;
    let gyro = bus.publisher::<GyroSample>()?;
    let inclinometer = bus.publisher::<InclinometerSample>()?;
    let magnetometer = bus.publisher::<MagnetometerSample>()?;
    let wheels = bus.publisher::<WheelTelemetry>()?;
    let cmg = bus.publisher::<CmgTelemetry>()?;
    let wheel_command = bus.subscriber_with::<WheelCommand>(SubscriberOptions::buffer(64))?;
    let cmg_command = bus.subscriber_with::<CmgCommand>(SubscriberOptions::buffer(64))?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;
    if process::wait_for_participants(&bus, &config.run.participants)? == LoopExit::TerminationRequested {
        return Ok(());
    }

    let publish = |t: &ReplayTick| -> anyhow::Result<()> {
        // Truth and clock first: the logger takes a clock sample as the end of the tick before.
        if let Some(s) = &t.truth {
            truth.publish(s)?;
        }
        if let Some(s) = &t.clock {
            clock.publish(s)?;
        }
        if let Some(s) = &t.gyro {
            gyro.publish(s)?;
        }
        if let Some(s) = &t.inclinometer {
            inclinometer.publish(s)?;
        }
        if let Some(s) = &t.magnetometer {
            magnetometer.publish(s)?;
        }
        if let Some(s) = &t.wheels {
            wheels.publish(s)?;
        }
        if let Some(s) = &t.cmg {
            cmg.publish(s)?;
        }
        Ok(())
    };
    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    events.on_data(&wheel_command)?;
    events.on_data(&cmg_command)?;
    events.with_heartbeat(&heartbeat)?;
    heartbeat.set_state(ProcessState::Running);
    let mut error = FirstError::default();
    let mut index = 0;
    let (mut wheel_answered, mut cmg_answered) = (false, false);
    if error.failed(publish(&ticks[0])) {
        return error.into_result();
    }
    events.run(|_| {
        let now = ticks[index].time_ns;
        let drained = wheel_command
            .drain(|c| wheel_answered |= c.header.time_ns == now)
            .and_then(|_| cmg_command.drain(|c| cmg_answered |= c.header.time_ns == now));
        if error.failed(drained.map_err(anyhow::Error::from)) {
            return Flow::Stop;
        }
        if !(wheel_answered && cmg_answered) {
            return Flow::Continue;
        }
        index += 1;
        (wheel_answered, cmg_answered) = (false, false);
        if index == ticks.len() {
            return Flow::Stop;
        }
        heartbeat.set_time_ns(ticks[index].time_ns);
        if error.failed(publish(&ticks[index])) { Flow::Stop } else { Flow::Continue }
    })?;
    tracing::info!(ticks = index, "replay done");
    heartbeat.set_state(ProcessState::Stopping);
    error.into_result()
}
