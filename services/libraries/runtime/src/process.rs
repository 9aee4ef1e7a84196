//! What every process of the pipeline does first: logging, arguments, run configuration, bus.

use crate::run_config::RunConfig;
use anyhow::Context;
use ipc_types::{Heartbeat, ProcessState};
use std::collections::BTreeSet;
use std::path::PathBuf;
use std::time::Duration;
use std::time::Instant;
use testbed_bus::{Bus, BusConfig, EventLoop, Flow, LoopExit, SubscriberOptions, Waiter};

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
    let (config, path) = RunConfig::from_arg_or_env(args.config.as_deref())
        .with_context(|| format!("{name}: loading the run configuration"))?;
    let bus_config = BusConfig::from_env().with_context(|| format!("{name}: bus configuration"))?;
    let bus = Bus::open(name, &bus_config).with_context(|| format!("{name}: opening the bus"))?;
    tracing::info!(config = %path.display(), mode = ?config.run.mode, seed = config.run.seed, "{name} starting");
    Ok((config, bus))
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
        anyhow::ensure!(
            !left.is_zero(),
            "participants never reported Running: {waiting:?}"
        );
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
    tracing::info!(
        participants = participants.len(),
        "all participants running; starting the clock"
    );
    Ok(LoopExit::Stopped)
}
