//! What every process of the pipeline does first: logging, arguments, run configuration, bus.

use anyhow::Context;
use ipc_types::{Heartbeat, ProcessState};
use std::collections::BTreeSet;
use std::path::PathBuf;
use std::time::Duration;
use std::time::Instant;
use testbed_bus::{
    Bus, BusConfig, EventLoop, Flow, LoopExit, SubscriberOptions, TopicSubscriber, Waiter,
};
use testbed_config::RunConfig;

/// How long the participants of a run have to come up.
pub const START_TIMEOUT: Duration = Duration::from_secs(60);

/// Heartbeat period of every process.
pub const HEARTBEAT_PERIOD: Duration = Duration::from_millis(500);

/// The period of a process's own interval while it has nothing frequent to do (a paced logger
/// between drains, a ground link nobody watches): a little under 1.5 heartbeat periods, so its
/// heartbeat goes out with every tick ([`testbed_bus::HEARTBEAT_SLACK`]) and the process wakes
/// 1.4 times a second, where a 1-s interval woke it twice (once more for the heartbeat alone).
/// The 50 ms short of 750 ms cover the tick's own work: a variable interval's next tick counts
/// from the end of its callback, the heartbeat's from the start of the wake-up that sent it.
pub const QUIET_PERIOD: Duration = Duration::from_millis(700);

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

/// Takes the pending heartbeats; the names of the processes running among them go to `seen`.
fn running(heartbeats: &TopicSubscriber<Heartbeat>, seen: &mut Vec<String>) {
    let _ = heartbeats.drain(|h| {
        // Degraded is running too (its ports exist): a CAN gateway that has not yet heard its
        // node, slow to start on a loaded machine, reports Degraded and must not hold the
        // barrier until the node (itself waiting for the barrier) speaks.
        if matches!(
            h.state(),
            Some(ProcessState::Running | ProcessState::Degraded)
        ) {
            seen.push(h.name().to_string());
        }
    });
}

/// The start barrier of a clock owner (plant, replay): block until every process named in
/// `participants` has published a `Running` (or `Degraded`) heartbeat, so every subscriber exists before the
/// first sample.
pub fn wait_for_participants(bus: &Bus, participants: &[String]) -> anyhow::Result<LoopExit> {
    let mut waiting: BTreeSet<&str> = participants.iter().map(String::as_str).collect();
    if waiting.is_empty() {
        return Ok(LoopExit::Stopped);
    }
    // Dropped on return: nothing subscribes to heartbeats during the run, so a heartbeat can
    // never block a lossless publisher. With the last heartbeat of every publisher already
    // there (history 1): a participant that said `Running` before this subscriber existed is
    // seen at once, not at its next heartbeat (a heartbeat period, 500 ms, of start-up).
    let heartbeats = bus.subscriber_with::<Heartbeat>(SubscriberOptions {
        history: 1,
        ..SubscriberOptions::buffer(64)
    })?;
    let waiter = Waiter::new()?;
    let mut events = EventLoop::new(&waiter);
    events.on_data(&heartbeats)?;
    // The history came with no notification: take it before waiting.
    let mut seen = Vec::new();
    running(&heartbeats, &mut seen);
    for name in &seen {
        waiting.remove(name.as_str());
    }
    let deadline = Instant::now() + START_TIMEOUT;
    while !waiting.is_empty() {
        let left = deadline.saturating_duration_since(Instant::now());
        anyhow::ensure!(
            !left.is_zero(),
            "participants never reported Running: {waiting:?}"
        );
        let mut seen = Vec::new();
        let exit = events.run_once(left, |_| {
            running(&heartbeats, &mut seen);
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    use testbed_bus::HeartbeatPublisher;

    /// A participant on its own thread and bus node publishing a heartbeat every 50 ms: state
    /// `first`, then `then` from `switch_after` on, until `stop` is set.
    fn participant(
        config: BusConfig,
        name: &'static str,
        (first, switch_after, then): (ProcessState, Duration, ProcessState),
        stop: Arc<AtomicBool>,
    ) -> std::thread::JoinHandle<()> {
        std::thread::spawn(move || {
            let bus = Bus::open(name, &config).expect("participant bus");
            let heartbeat =
                HeartbeatPublisher::new(&bus, Duration::from_millis(50)).expect("heartbeat");
            let started = Instant::now();
            while !stop.load(Ordering::Relaxed) {
                let state = if started.elapsed() < switch_after {
                    first
                } else {
                    then
                };
                heartbeat.set_state(state);
                heartbeat.publish().expect("publishing a heartbeat");
                std::thread::sleep(Duration::from_millis(50));
            }
        })
    }

    /// A participant that is up but degraded (a CAN gateway that has not heard its node yet)
    /// releases the barrier as a running one does; one still starting holds it until it runs.
    #[test]
    fn the_start_barrier_counts_running_and_degraded_participants_and_waits_for_starting_ones() {
        use ProcessState::{Degraded, Running, Starting};
        let config = BusConfig::isolated();
        let bus = Bus::open("plant", &config).expect("bus");
        let stop = Arc::new(AtomicBool::new(false));
        let now = Duration::ZERO;
        let late = Duration::from_millis(800);
        let threads = [
            participant(config.clone(), "a", (Running, now, Running), stop.clone()),
            participant(config.clone(), "b", (Degraded, now, Degraded), stop.clone()),
            participant(config.clone(), "c", (Starting, late, Running), stop.clone()),
        ];
        let started = Instant::now();
        let exit = wait_for_participants(&bus, &["a".into(), "b".into()]).expect("barrier");
        assert_eq!(exit, LoopExit::Stopped);
        // "c" says Starting for its first 800 ms: the barrier cannot pass before.
        wait_for_participants(&bus, &["a".into(), "c".into()]).expect("barrier with c");
        assert!(started.elapsed() >= late, "{:?}", started.elapsed());

        stop.store(true, Ordering::Relaxed);
        for handle in threads {
            handle.join().expect("participant thread");
        }
        drop(bus);
        testbed_bus::remove_all(&config).expect("removing the test's bus files");
    }

    #[test]
    fn a_quiet_interval_carries_every_heartbeat() {
        // A heartbeat rides on a wake-up from HEARTBEAT_EARLY of a period before it is due to
        // HEARTBEAT_SLACK after: a quiet interval must tick inside that window, with room for
        // a tick's work (20 ms here, some 0.2 ms measured), or it goes out every other tick.
        let earliest = HEARTBEAT_PERIOD.mul_f64(1.0 - testbed_bus::HEARTBEAT_EARLY);
        let latest = HEARTBEAT_PERIOD.mul_f64(1.0 + testbed_bus::HEARTBEAT_SLACK);
        assert!(
            QUIET_PERIOD >= earliest,
            "{QUIET_PERIOD:?} against {earliest:?}"
        );
        assert!(
            QUIET_PERIOD + Duration::from_millis(20) <= latest,
            "{QUIET_PERIOD:?} against {latest:?}"
        );
    }
}
