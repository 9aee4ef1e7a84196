//! Plant process (simulation only): integrates the platform and owns the clock. It waits until
//! every participant of the run reports `Running`, then publishes truth and tick for t = 0.
//! Lockstep: it advances as soon as the tick's wheel and CMG commands are in. Paced: it advances
//! every period of wall time, holding the last command when an answer is late. It exits when the
//! run's duration is reached; the launcher then stops the rest.

use anyhow::Context;
use ipc_types::{CmgCommand, Heartbeat, ProcessState, SimClockTick, SimTruth, WheelCommand};
use std::collections::BTreeSet;
use std::time::{Duration, Instant};
use testbed_bus::{Bus, EventLoop, Flow, LoopExit, SubscriberOptions, Waiter, Wake};
use testbed_pipeline::plant_node::PlantNode;
use testbed_pipeline::process::{self, FirstError, HEARTBEAT_PERIOD};
use testbed_pipeline::ClockMode;

/// How long the participants have to come up.
const START_TIMEOUT: Duration = Duration::from_secs(60);

fn main() -> anyhow::Result<()> {
    let (config, bus) = process::start("plant")?;
    let mut node = PlantNode::new(&config)?;
    let truth = bus.publisher::<SimTruth>()?;
    let clock = bus.publisher::<SimClockTick>()?;
    let wheel_command = bus.subscriber_with::<WheelCommand>(SubscriberOptions::buffer(64))?;
    let cmg_command = bus.subscriber_with::<CmgCommand>(SubscriberOptions::buffer(64))?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;

    if wait_for_participants(&bus, &config.run.participants)? == LoopExit::TerminationRequested {
        return Ok(());
    }
    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    events.on_data(&wheel_command)?;
    events.on_data(&cmg_command)?;
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
        let drained = wheel_command
            .drain(|c| node.on_wheel_command(&c))
            .and_then(|_| cmg_command.drain(|c| node.on_cmg_command(&c)));
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

/// Block until every process named in `participants` has published a `Running` heartbeat.
fn wait_for_participants(bus: &Bus, participants: &[String]) -> anyhow::Result<LoopExit> {
    let mut waiting: BTreeSet<&str> = participants.iter().map(String::as_str).collect();
    if waiting.is_empty() {
        return Ok(LoopExit::Stopped);
    }
    // Dropped on return: nothing subscribes to heartbeats during the run, so a heartbeat can
    // never block a lossless publisher.
    let heartbeats = bus.subscriber_with::<Heartbeat>(SubscriberOptions::buffer(64))?;
    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    events.on_data(&heartbeats)?;
    let deadline = Instant::now() + START_TIMEOUT;
    while !waiting.is_empty() {
        let left = deadline.saturating_duration_since(Instant::now());
        anyhow::ensure!(!left.is_zero(), "participants never reported Running: {waiting:?}");
        let mut seen = Vec::new();
        let exit = events.run_once(left, |_| {
            let _ = heartbeats.drain(|h| {
                if h.state() == Some(ProcessState::Running) {
                    seen.push(h.name().to_string());
                }
            });
            Flow::Continue
        });
        if let Some(exit) = exit.context("waiting for the participants")? {
            return Ok(exit);
        }
        for name in &seen {
            waiting.remove(name.as_str());
        }
    }
    tracing::info!(participants = participants.len(), "all participants running; starting the clock");
    Ok(LoopExit::Stopped)
}
