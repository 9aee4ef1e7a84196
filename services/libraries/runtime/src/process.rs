//! What every process of the pipeline does first: logging, arguments, run configuration, bus.

use crate::run_config::RunConfig;
use anyhow::Context;
use ipc_types::{Heartbeat, ProcessState};
use std::collections::BTreeSet;
use std::time::Instant;
use testbed_bus::{EventLoop, Flow, LoopExit, SubscriberOptions, Waiter};
use std::path::PathBuf;
use std::time::Duration;
use testbed_bus::{Bus, BusConfig};

/// How long the participants of a run have to come up.
pub const START_TIMEOUT: Duration = Duration::from_secs(60);

/// Heartbeat period of every process.
pub const HEARTBEAT_PERIOD: Duration = Duration::from_millis(500);

/// Command line shared by the pipeline's processes.
#[derive(Debug, clap::Parser)]
pub struct ProcessArgs {
    /// Run configuration (TOML); default: the path in `TESTBED_RUN_CONFIG`.
    #[arg(long)]
    pub config: Option<PathBuf>,
}

/// Logging from `RUST_LOG`, the run configuration, and this process's bus node.
pub fn start(name: &str) -> anyhow::Result<(RunConfig, Bus)> {
    testbed_bus::init_logging();
    let args = <ProcessArgs as clap::Parser>::parse();
    let (config, path) = RunConfig::from_arg_or_env(args.config.as_deref()).with_context(|| format!("{name}: loading the run configuration"))?;
    let bus_config = BusConfig::from_env().with_context(|| format!("{name}: bus configuration"))?;
    let bus = Bus::open(name, &bus_config).with_context(|| format!("{name}: opening the bus"))?;
    tracing::info!(config = %path.display(), mode = ?config.run.mode, seed = config.run.seed, "{name} starting");
    Ok((config, bus))
}

/// Keeps the first error raised inside an event-loop callback, so the callback can stop the
/// loop and `main` can report it with its context.
#[derive(Default)]
pub struct FirstError(Option<anyhow::Error>);

impl FirstError {
    /// Record `result`'s error (if it is the first); true if the loop should stop.
    pub fn failed<T>(&mut self, result: anyhow::Result<T>) -> bool {
        match result {
            Ok(_) => false,
            Err(e) => {
                self.0.get_or_insert(e);
                true
            }
        }
    }

    pub fn into_result(self) -> anyhow::Result<()> {
        self.0.map_or(Ok(()), Err)
    }
}

/// The loop of a simulated gateway. On every wake-up the truth samples are taken first, then
/// `drain_commands` reads the commands that preceded them (in lockstep a command of tick k−1
/// always precedes the truth of tick k, so telemetry reports the command in effect
/// deterministically), then `sample` turns each truth into at most one output sample.
pub fn run_sim_gateway<T: ipc_types::Topic>(
    bus: &Bus,
    mut drain_commands: impl FnMut() -> anyhow::Result<()>,
    mut sample: impl FnMut(&ipc_types::SimTruth) -> Option<T>,
) -> anyhow::Result<()> {
    let truth = bus.subscriber::<ipc_types::SimTruth>()?;
    let output = bus.publisher::<T>()?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;
    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    events.on_data(&truth)?;
    events.with_heartbeat(&heartbeat)?;
    heartbeat.set_state(ipc_types::ProcessState::Running);
    let mut error = FirstError::default();
    let mut truths = Vec::new();
    events.run(|_| {
        truths.clear();
        if error.failed(truth.drain_into(&mut truths).map_err(anyhow::Error::from)) || error.failed(drain_commands()) {
            return Flow::Stop;
        }
        for t in &truths {
            heartbeat.add_samples_in(1);
            heartbeat.set_time_ns(t.header.time_ns);
            if let Some(s) = sample(t) {
                if error.failed(output.publish(&s).map_err(anyhow::Error::from)) {
                    return Flow::Stop;
                }
                heartbeat.add_samples_out(1);
            }
        }
        Flow::Continue
    })?;
    heartbeat.set_state(ipc_types::ProcessState::Stopping);
    error.into_result()
}

/// The start barrier of a clock owner (plant, replay): block until every process named in
/// `participants` has published a `Running` heartbeat, so every subscriber exists before the
/// first sample.
pub fn wait_for_participants(bus: &Bus, participants: &[String]) -> anyhow::Result<LoopExit> {
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
