//! One lifecycle for every process of the pipeline.
//!
//! A process is a [`Node`]: a small struct holding its state, with its bus ports in a separate
//! struct ([`Node::Ports`]) so that the event loop can borrow the ports while the node changes.
//! [`run`] does everything around it, the same way for every process:
//!
//! 1. logging, command line and run configuration, the process's bus node
//!    ([`process::start`]);
//! 2. [`open`](run): the node and its ports from the run configuration;
//! 3. the heartbeat; for a clock owner, the start barrier (every participant `Running`);
//! 4. [`Node::wake_on`]: which ports wake the node, with wall-clock deadlines in paced runs
//!    only (in lockstep time stands still while anything waits);
//! 5. `Running`, [`Node::start`], then [`Node::on_wake`] for every wake-up until the node
//!    returns [`Flow::Stop`], an error occurs, or SIGINT/SIGTERM arrives;
//! 6. `Stopping`, [`Node::stop`] (always, also after an error: a logger still finalises its
//!    file), and the first error, with the process name, as the process's result.
//!
//! ```ignore
//! fn main() -> std::process::ExitCode {
//!     testbed_runtime::exit_status(testbed_runtime::run("estimator", EstimatorProcess::open))
//! }
//! ```

use crate::health::{HealthReporter, InputWatch, LOST_AFTER_PERIODS};
use crate::process::{self, HEARTBEAT_PERIOD};
use anyhow::Context as _;
use ipc_types::{ClockMode, ProcessState, Topic, WaitStrategy};
use std::cell::Cell;
use std::process::ExitCode;
use std::time::{Duration, Instant};
use testbed_bus::{
    Bus, BusError, EventLoop, Flow, HeartbeatPublisher, LoopExit, SourceId, TopicSubscriber,
    Waiter, Wake,
};
use testbed_config::RunConfig;

/// What a node is opened with.
pub struct Context<'a> {
    /// The process name (bus node, heartbeat, log messages).
    pub name: &'a str,
    /// The run configuration.
    pub config: &'a RunConfig,
    /// The process's bus node, to create ports on.
    pub bus: &'a Bus,
}

/// What a running node reaches besides its own state and ports.
pub struct Io<'a> {
    /// The process name.
    pub name: &'a str,
    /// Who owns time in this run.
    pub mode: ClockMode,
    /// The process's heartbeat: its state and counters go out every heartbeat period.
    pub heartbeat: &'a HeartbeatPublisher,
    /// The process's health events (faults and recoveries it sees).
    pub health: &'a HealthReporter,
}

/// Where a node says what wakes it ([`Node::wake_on`]).
pub struct WakeOn<'l, 'w, 'a> {
    events: &'l mut EventLoop<'w, 'a>,
    mode: ClockMode,
    watch: &'l mut InputWatch<'a>,
}

impl<'a> WakeOn<'_, '_, 'a> {
    /// Wake with [`Wake::Data`] when `subscriber` receives a sample.
    pub fn data<T: Topic>(
        &mut self,
        subscriber: &'a TopicSubscriber<T>,
    ) -> Result<SourceId, BusError> {
        self.events.on_data(subscriber)
    }

    /// Like [`data`](Self::data), and in a paced run also [`Wake::DeadlineMissed`] when
    /// nothing arrived for `deadline` (from the stream's first sample on). In lockstep no
    /// wall-clock deadline applies: time stands still while anything waits.
    pub fn data_within<T: Topic>(
        &mut self,
        subscriber: &'a TopicSubscriber<T>,
        deadline: Duration,
    ) -> Result<SourceId, BusError> {
        match self.mode {
            ClockMode::Lockstep => self.events.on_data(subscriber),
            ClockMode::Paced => self.events.on_data_with_deadline(subscriber, deadline),
        }
    }

    /// An input stream with period `period`: wakes with [`Wake::Data`], and in a paced run is
    /// watched for liveness (lost after 1.5 periods without a sample:
    /// reported, heartbeat `Degraded`) and wakes with [`Wake::DeadlineMissed`] then and after
    /// every further such silence, so a node can act on the loss (an actuator gateway
    /// commands zero). In lockstep, data only.
    pub fn input<T: Topic>(
        &mut self,
        subscriber: &'a TopicSubscriber<T>,
        period: Duration,
    ) -> Result<SourceId, BusError> {
        match self.mode {
            ClockMode::Lockstep => self.events.on_data(subscriber),
            ClockMode::Paced => {
                self.watch.watch(subscriber, period);
                self.events
                    .on_data_with_deadline(subscriber, period * LOST_AFTER_PERIODS)
            }
        }
    }

    /// Watches the liveness of `subscriber` (period `period`) in a paced run, as
    /// [`input`](Self::input) does, without attaching it: for a subscriber already attached
    /// with [`data_within`](Self::data_within), or one the node polls.
    pub fn watch<T: Topic>(&mut self, subscriber: &'a TopicSubscriber<T>, period: Duration) {
        if self.mode == ClockMode::Paced {
            self.watch.watch(subscriber, period);
        }
    }

    /// Wake with [`Wake::Tick`] every `period` of wall time.
    pub fn interval(&mut self, period: Duration) -> Result<SourceId, BusError> {
        self.events.on_interval(period)
    }

    /// Wake with [`Wake::Tick`] every `period` of wall time, read anew at each tick: the node
    /// changes it in `on_wake` (see [`EventLoop::on_variable_interval`]).
    pub fn variable_interval(
        &mut self,
        period: &'a std::cell::Cell<Duration>,
    ) -> Result<SourceId, BusError> {
        self.events.on_variable_interval(period)
    }

    /// Who owns time in this run.
    pub fn mode(&self) -> ClockMode {
        self.mode
    }
}

/// A process of the pipeline (see the [module](self) for the lifecycle [`run`] gives it).
pub trait Node {
    /// The node's publishers and subscribers, created when the node is opened.
    type Ports;

    /// The processes this node waits for (heartbeat `Running`) before its first wake-up: the
    /// start barrier of a clock owner, so that every subscriber exists before the first sample.
    /// `None` (the default) for every other process.
    fn start_barrier(&self, _config: &RunConfig) -> Option<Vec<String>> {
        None
    }

    /// Attaches the ports that wake the node.
    fn wake_on<'a>(
        &mut self,
        ports: &'a Self::Ports,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()>;

    /// Called once, `Running`, before the first wake-up (a clock owner publishes its first
    /// tick here). [`Flow::Stop`] ends the run at once.
    fn start(&mut self, _ports: &Self::Ports, _io: &Io) -> anyhow::Result<Flow> {
        Ok(Flow::Continue)
    }

    /// Called for every wake-up.
    fn on_wake(&mut self, ports: &Self::Ports, wake: Wake, io: &Io) -> anyhow::Result<Flow>;

    /// How many more input samples must arrive before a wake-up for data can do anything;
    /// asked after every wake-up. The node then sleeps through the rings of fewer samples
    /// ([`EventLoop::wake_after_rings`]); intervals, deadlines and the heartbeat still wake it.
    /// 1 (the default) wakes it for every sample. Never more than it needs: every sample
    /// counted must be one that wakes it ([`WakeOn::data`], [`WakeOn::input`], ...).
    fn samples_awaited(&self) -> u32 {
        1
    }

    /// Called once when the loop has ended, also after an error (`Stopping`): last writes and
    /// the process's report.
    fn stop(&mut self, _ports: &Self::Ports, _io: &Io, _exit: LoopExit) -> anyhow::Result<()> {
        Ok(())
    }
}

/// The exit status of a process's result; an error is printed as `error: <what failed>: <its
/// causes>` on one line of stderr, written at once, so that the errors of processes failing
/// together (five gateways without their CAN interface) do not run into each other's lines.
/// No backtrace, even with `RUST_BACKTRACE` set (which `anyhow`'s `{:?}`, and so a `main`
/// returning `anyhow::Result`, would print): these are the run's or the user's errors, not
/// bugs. A panic keeps its backtrace.
pub fn exit_status(result: anyhow::Result<()>) -> ExitCode {
    use std::io::Write as _;
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let _ = std::io::stderr().write_all(error_line(&e).as_bytes());
            ExitCode::FAILURE
        }
    }
}

/// `error: {e:#}` with its newline: the error and its causes, `: `-separated, on one line.
pub fn error_line(e: &anyhow::Error) -> String {
    format!("error: {e:#}\n")
}

/// Runs the process `name`: the node `open` makes, through the lifecycle of the [module](self).
/// A process's `main` ends with [`exit_status`] of the result.
pub fn run<N: Node>(
    name: &str,
    open: impl FnOnce(&Context) -> anyhow::Result<(N, N::Ports)>,
) -> anyhow::Result<()> {
    let (config, bus) = process::start(name)?;
    let (mut node, ports) = open(&Context {
        name,
        config: &config,
        bus: &bus,
    })
    .with_context(|| format!("{name}: starting"))?;
    let heartbeat = bus.heartbeat(HEARTBEAT_PERIOD)?;
    let health = HealthReporter::new(&bus, name)?;
    if let Some(participants) = node.start_barrier(&config)
        && process::wait_for_participants(&bus, &participants)? == LoopExit::TerminationRequested
    {
        return Ok(());
    }
    let waiter = Waiter::new()?;
    let samples_awaited = Cell::new(node.samples_awaited());
    let mut events = EventLoop::new(&waiter);
    events.wake_after_rings(&samples_awaited);
    if config.run.mode == ClockMode::Lockstep && !WaitStrategy::set_in_env() {
        // Validated with the configuration: a bad value never gets this far.
        events.set_wait_strategy(config.lockstep_wait().map_err(anyhow::Error::msg)?);
    }
    let mut watch = InputWatch::default();
    node.wake_on(
        &ports,
        &mut WakeOn {
            events: &mut events,
            mode: config.run.mode,
            watch: &mut watch,
        },
    )?;
    // Running before the first heartbeat goes out (`with_heartbeat` publishes one at once): a
    // clock owner's start barrier then passes as soon as the last participant is attached,
    // not a heartbeat period (500 ms) later.
    heartbeat.set_state(ProcessState::Running);
    events.with_heartbeat(&heartbeat)?;
    let io = Io {
        name,
        mode: config.run.mode,
        heartbeat: &heartbeat,
        health: &health,
    };

    let mut error = None;
    let mut exit = LoopExit::Stopped;
    let mut step = |result: anyhow::Result<Flow>| match result {
        Ok(flow) => flow,
        Err(e) => {
            error.get_or_insert(e);
            Flow::Stop
        }
    };
    if step(node.start(&ports, &io)) == Flow::Continue {
        let on_wake = |wake| {
            watch.check(Instant::now(), &heartbeat, &health);
            let flow = step(node.on_wake(&ports, wake, &io));
            samples_awaited.set(node.samples_awaited());
            flow
        };
        match events.run(on_wake) {
            Ok(e) => exit = e,
            Err(e) => {
                error.get_or_insert(e.into());
            }
        }
    }
    // Said at once, not at the next interval: the launcher stops watching a stopping process,
    // whose stop and exit may take longer than the heartbeat timeout on a loaded machine.
    heartbeat.set_state(ProcessState::Stopping);
    heartbeat.publish_or_count();
    let stopped = node.stop(&ports, &io, exit);
    match (error, stopped) {
        (Some(e), _) => Err(e.context(format!("{name} failed"))),
        (None, Err(e)) => Err(e.context(format!("{name}: stopping"))),
        (None, Ok(())) => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_is_one_line_with_its_causes_and_no_backtrace() {
        let io = std::io::Error::from_raw_os_error(97);
        let e = anyhow::Error::new(io)
            .context("can.interface = \"can0\"")
            .context("gyro-gateway: starting");
        let line = error_line(&e);
        assert!(line.starts_with("error: gyro-gateway: starting: can.interface = \"can0\": "));
        assert!(line.ends_with("(os error 97)\n"), "{line}");
        assert_eq!(line.lines().count(), 1, "{line}");
        assert!(!line.to_lowercase().contains("backtrace"), "{line}");
    }
}
