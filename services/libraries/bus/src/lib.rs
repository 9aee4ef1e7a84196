//! Process-pipeline plumbing of the test bed over iceoryx2.
//!
//! Every process of the pipeline is a thin shell: open a [`Bus`], create typed ports for the
//! [`Topic`]s it reads and writes, and run an [`EventLoop`] that calls back when data arrives,
//! when an interval elapses or when a deadline is missed, until the process is asked to stop
//! (SIGINT/SIGTERM):
//!
//! ```no_run
//! use std::time::Duration;
//! use ipc_types::{GyroSample, AttitudeEstimate, ProcessState};
//! use testbed_bus::{Bus, BusConfig, EventLoop, Flow, Waiter, Wake};
//!
//! # fn main() -> Result<(), testbed_bus::BusError> {
//! let bus = Bus::open("estimator", &BusConfig::from_env()?)?;
//! let gyro = bus.subscriber::<GyroSample>()?;
//! let estimate = bus.publisher::<AttitudeEstimate>()?;
//! let heartbeat = bus.heartbeat(Duration::from_millis(500))?;
//!
//! let waiter = Waiter::new()?;
//! let mut events = EventLoop::new(&waiter);
//! let on_gyro = events.on_data_with_deadline(&gyro, Duration::from_millis(150))?;
//! events.with_heartbeat(&heartbeat)?;
//! heartbeat.set_state(ProcessState::Running);
//! let mut misses = 0_u64;
//! let exit = events.run(|wake| {
//!     match wake {
//!         Wake::Data(src) if src == on_gyro => {
//!             let _ = gyro.drain(|sample| {
//!                 heartbeat.add_samples_in(1);
//!                 let _ = estimate.publish(&AttitudeEstimate::default());
//!                 let _ = sample;
//!             });
//!         }
//!         Wake::DeadlineMissed(_) => misses += 1,
//!         _ => {}
//!     }
//!     Flow::Continue
//! })?;
//! # let _ = exit;
//! # Ok(())
//! # }
//! ```
//!
//! # Pieces
//!
//! - [`BusConfig`]: the iceoryx2 prefix and root path a run uses (from `TESTBED_BUS_PREFIX` /
//!   `TESTBED_BUS_ROOT`, set by the launcher), the run's [`Delivery`] mode
//!   (`TESTBED_BUS_DELIVERY`) and the [`ServiceLimits`] all processes share.
//! - [`Bus`]: one iceoryx2 node per process, named after the process.
//! - [`TopicPublisher`] / [`TopicSubscriber`]: one data service per topic (`T::NAME`).
//!   Zero-copy both ways: [`TopicPublisher::publish_with`] fills a sample loaned in shared
//!   memory in place, [`TopicSubscriber::drain`] hands out every pending sample by reference and
//!   releases it after the visit. After sending, a publisher rings the *doorbell* of every
//!   process waiting for the topic (one futex word per process in shared memory, see the
//!   `doorbell` module): one wake-up per consumer, however many of its topics were published.
//!   A subscriber counts as waiting only while it is attached to an event loop
//!   ([`EventLoop::on_data`]); one drained along with another source, or on a timer, never
//!   wakes its process. A subscriber that needs only some samples of its stream to act asks to
//!   be woken only from a time stamp on ([`TopicSubscriber::wake_from`]).
//! - [`EventLoop`]: waits on the process's doorbell with its subscribers, intervals and
//!   deadlines; returns [`LoopExit::TerminationRequested`] on SIGINT/SIGTERM. How it waits is its
//!   [`ipc_types::WaitStrategy`]: sleep until rung (default), or also poll the subscribers in
//!   short windows where a sample is expected ([`ipc_types::ENV_WAIT`], [`WaitFromEnv`]).
//! - [`HeartbeatPublisher`]: the periodic [`ipc_types::Heartbeat`] of a process. An event loop
//!   sends it with the first wake-up from [`HEARTBEAT_EARLY`] of a period before it is due,
//!   and wakes for it alone only [`HEARTBEAT_SLACK`] of a period after; the next is due a
//!   period after it went out.
//! - [`cleanup_dead_nodes`] (launcher, before a run) and [`remove_all`] (tests, after a run).
//!
//! # Threads
//!
//! iceoryx2 `ipc::Service` ports are not `Send`: create and use all ports of a process on one
//! thread (the event loop's).
//!
//! # Signals
//!
//! iceoryx2 installs a catching handler for SIGINT, SIGTERM and the other non-fatal signals
//! the first time anything waits; [`Bus::open`] does so at once, so a SIGINT arriving after
//! `open` always ends up as a termination request instead of killing the process. A signal
//! interrupting the loop's sleep (a futex wait) ends it at once; one landing in the instant
//! between the loop's termination check and its sleep is seen at the next wake-up, at most
//! [`MAX_SLEEP`] later (the launcher follows up with SIGTERM).

mod any_topic;
mod cleanup;
mod config;
mod doorbell;
mod event_loop;
mod heartbeat;
mod ports;
mod private;
mod wait;

use std::error::Error as StdError;
use std::time::Duration;

use iceoryx2::prelude::*;
use ipc_types::Topic;

pub use any_topic::{AnySubscriber, AnySubscribers};
pub use cleanup::{CleanupReport, cleanup_dead_nodes, remove_all};
pub use config::{
    BusConfig, DEFAULT_PREFIX, DEFAULT_ROOT, Delivery, ENV_DELIVERY, ENV_PREFIX, ENV_ROOT,
    MAX_PREFIX_LEN, MAX_ROOT_LEN, ServiceLimits,
};
pub use doorbell::{MAX_CONSUMERS, MAX_TOPICS};
pub use event_loop::{
    EventLoop, Flow, HEARTBEAT_EARLY, HEARTBEAT_SLACK, LoopExit, MAX_SLEEP, SourceId, Waiter, Wake,
};
pub use heartbeat::HeartbeatPublisher;
pub use ports::{SubscriberOptions, TopicPublisher, TopicSubscriber};
pub use private::{CollectReport, PrivateRun, collect_dead_runs};
pub use wait::{WaitFromEnv, WaitStats};

/// Boxed iceoryx2 error.
pub type Source = Box<dyn StdError + Send + Sync + 'static>;

/// Errors of this crate. Each names what was being done and on which topic or path.
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    /// An invalid configuration value.
    #[error("invalid bus configuration {key} = {value:?}: {reason}")]
    Config {
        /// The environment variable or field.
        key: &'static str,
        /// The offending value.
        value: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The process's iceoryx2 node could not be created.
    #[error("cannot create the iceoryx2 node {name:?}: {source}")]
    Node {
        /// The node (process) name.
        name: String,
        /// iceoryx2's error.
        source: Source,
    },
    /// A data or event service could not be opened or created.
    #[error("cannot open or create the service {service:?}: {source}")]
    Service {
        /// The service name.
        service: String,
        /// iceoryx2's error.
        source: Source,
    },
    /// A port could not be created.
    #[error("cannot create a {port} on {service:?}: {source}")]
    Port {
        /// The kind of port.
        port: &'static str,
        /// The service name.
        service: String,
        /// iceoryx2's error.
        source: Source,
    },
    /// Sending, notifying, receiving or draining failed.
    #[error("{operation} on {service:?} failed: {source}")]
    Io {
        /// What was done.
        operation: &'static str,
        /// The service name.
        service: String,
        /// iceoryx2's error.
        source: Source,
    },
    /// Something could not be attached to the event loop.
    #[error("event loop: {operation} failed: {source}")]
    EventLoop {
        /// What was done.
        operation: &'static str,
        /// Why.
        source: Source,
    },
    /// The doorbell table (`/dev/shm/<prefix>doorbells`) could not be opened or is full.
    #[error("doorbell table {path}: {reason}")]
    Doorbell {
        /// The table's file.
        path: String,
        /// What went wrong.
        reason: String,
    },
    /// Listing or cleaning up nodes failed.
    #[error("cleaning up the bus resources under {root:?} with prefix {prefix:?} failed: {source}")]
    Cleanup {
        /// The root path.
        root: String,
        /// The prefix.
        prefix: String,
        /// The cause.
        source: Source,
    },
}

/// Installs the process's `tracing` subscriber: human-readable lines on stderr, filtered by
/// `RUST_LOG` (comma-separated `target=level` directives and a bare default level, as
/// `tracing_subscriber::filter::Targets` reads them; default `info,iceoryx2=warn`; see
/// [`logging_directives`]; a value that does not parse gives the default),
/// without colours unless stderr is a terminal. iceoryx2's own messages (routed through
/// `tracing`) get the level of the `iceoryx2` directive: `warn` unless `RUST_LOG` names
/// iceoryx2 (`RUST_LOG=debug,iceoryx2=debug` for its debug output). Does nothing if a subscriber
/// is already installed.
pub fn init_logging() {
    use std::io::IsTerminal;
    use tracing_subscriber::filter::{LevelFilter, Targets};
    use tracing_subscriber::layer::SubscriberExt;
    use tracing_subscriber::util::SubscriberInitExt;

    let directives = logging_directives(std::env::var("RUST_LOG").ok().as_deref());
    let filter = directives
        .parse::<Targets>()
        .or_else(|_| DEFAULT_LOG_DIRECTIVES.parse())
        .unwrap_or_default();
    // iceoryx2's own logger follows its directive (`iceoryx2=…`), not the overall level: its
    // debug output is every expected "Unable to open …" miss of a service lookup.
    let iox_filter = logging_iceoryx2_level(&directives);
    let iox_level = match iox_filter {
        LevelFilter::TRACE => LogLevel::Trace,
        LevelFilter::DEBUG => LogLevel::Debug,
        LevelFilter::INFO => LogLevel::Info,
        LevelFilter::WARN => LogLevel::Warn,
        _ => LogLevel::Error,
    };
    set_log_level(iox_level);
    let lines = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal());
    let _ = tracing_subscriber::registry()
        .with(lines)
        .with(filter)
        .try_init();
}

/// The filter when `RUST_LOG` is not set: `info` for the test bed, only warnings from iceoryx2.
pub const DEFAULT_LOG_DIRECTIVES: &str = "info,iceoryx2=warn";

/// The filter directives for a `RUST_LOG` value: unset or empty gives
/// [`DEFAULT_LOG_DIRECTIVES`]; a value that does not name iceoryx2 gets `iceoryx2=warn` appended
/// (`RUST_LOG=debug` is `debug,iceoryx2=warn`), so its expected misses stay out of the debug
/// output unless asked for (`RUST_LOG=debug,iceoryx2=debug`).
pub fn logging_directives(rust_log: Option<&str>) -> String {
    match rust_log.map(str::trim) {
        None | Some("") => DEFAULT_LOG_DIRECTIVES.to_string(),
        Some(value) if value.contains("iceoryx2") => value.to_string(),
        Some(value) => format!("{value},iceoryx2=warn"),
    }
}

/// The level of the `iceoryx2` directive in `directives` (the last one naming it), else the
/// overall level (the last bare level), else `info`.
fn logging_iceoryx2_level(directives: &str) -> tracing_subscriber::filter::LevelFilter {
    use tracing_subscriber::filter::LevelFilter;
    let level = |text: &str| text.trim().parse::<LevelFilter>().ok();
    let named = directives
        .split(',')
        .filter_map(|d| d.split_once('='))
        .filter(|(target, _)| target.trim().starts_with("iceoryx2"))
        .filter_map(|(_, l)| level(l))
        .next_back();
    let bare = directives
        .split(',')
        .filter(|d| !d.contains('='))
        .filter_map(level)
        .next_back();
    named.or(bare).unwrap_or(LevelFilter::INFO)
}

/// One process's connection to the bus: an iceoryx2 node named after the process.
pub struct Bus {
    // Field order is drop order: the doorbell is freed before the table is unmapped.
    bell: std::rc::Rc<doorbell::Bell>,
    doorbells: std::rc::Rc<doorbell::Doorbells>,
    node: Node<ipc::Service>,
    config: BusConfig,
    name: String,
}

impl core::fmt::Debug for Bus {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Bus")
            .field("name", &self.name)
            .field("config", &self.config)
            .finish_non_exhaustive()
    }
}

impl Bus {
    /// Creates the process's node `name` with `config`, and installs iceoryx2's termination
    /// signal handler (see the crate documentation on signals).
    pub fn open(name: &str, config: &BusConfig) -> Result<Self, BusError> {
        let node_error = |source: Source| BusError::Node {
            name: name.to_owned(),
            source,
        };
        let iox_config = config.to_iceoryx2()?;
        let node_name = NodeName::new(name).map_err(|e| node_error(Box::new(e)))?;
        wait::set_process_name(name);
        let node = NodeBuilder::new()
            .name(&node_name)
            .config(&iox_config)
            .create::<ipc::Service>()
            .map_err(|e| node_error(Box::new(e)))?;
        // A zero wait registers iceoryx2's signal handler now rather than at the first real
        // wait. A termination request cannot be pending yet: before the handler existed, SIGINT
        // or SIGTERM would have ended the process.
        let _ = node.wait(Duration::ZERO);
        let doorbells = doorbell::Doorbells::open(&config.prefix)?;
        let bell = std::rc::Rc::new(doorbells.claim()?);
        tracing::debug!(node = name, prefix = %config.prefix, root = %config.root_string(),
            delivery = %config.delivery, "bus opened");
        Ok(Self {
            bell,
            doorbells,
            node,
            config: config.clone(),
            name: name.to_owned(),
        })
    }

    /// The doorbell table of the bus's prefix.
    pub(crate) fn doorbells(&self) -> &std::rc::Rc<doorbell::Doorbells> {
        &self.doorbells
    }

    /// This process's doorbell: every subscriber created from this bus has it rung.
    pub(crate) fn bell(&self) -> &std::rc::Rc<doorbell::Bell> {
        &self.bell
    }

    /// The process (node) name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The configuration the bus was opened with.
    pub fn config(&self) -> &BusConfig {
        &self.config
    }

    /// The underlying iceoryx2 node, for what this crate does not cover.
    pub fn node(&self) -> &Node<ipc::Service> {
        &self.node
    }

    /// A publisher on `T`'s topic. In [`Delivery::Lossless`] runs its `publish` blocks while a
    /// subscriber's buffer is full.
    pub fn publisher<T: Topic>(&self) -> Result<TopicPublisher<T>, BusError> {
        TopicPublisher::create(self)
    }

    /// A subscriber on `T`'s topic with [`SubscriberOptions::default`].
    pub fn subscriber<T: Topic>(&self) -> Result<TopicSubscriber<T>, BusError> {
        TopicSubscriber::create(self, SubscriberOptions::default())
    }

    /// A subscriber on `T`'s topic with `options`.
    pub fn subscriber_with<T: Topic>(
        &self,
        options: SubscriberOptions,
    ) -> Result<TopicSubscriber<T>, BusError> {
        TopicSubscriber::create(self, options)
    }

    /// A heartbeat publisher for this process (name = node name, pid = this process) with
    /// `period`; attach it to the event loop with [`EventLoop::with_heartbeat`].
    pub fn heartbeat(&self, period: Duration) -> Result<HeartbeatPublisher, BusError> {
        HeartbeatPublisher::new(self, period)
    }

    pub(crate) fn service_name(name: &str) -> Result<ServiceName, BusError> {
        ServiceName::new(name).map_err(|e| BusError::Service {
            service: name.to_owned(),
            source: Box::new(e),
        })
    }
}

#[cfg(test)]
mod logging_tests {
    use super::*;
    use tracing_subscriber::filter::LevelFilter;

    #[test]
    fn iceoryx2_stays_at_warn_unless_named() {
        assert_eq!(logging_directives(None), "info,iceoryx2=warn");
        assert_eq!(logging_directives(Some("debug")), "debug,iceoryx2=warn");
        assert_eq!(
            logging_directives(Some("debug,iceoryx2=debug")),
            "debug,iceoryx2=debug"
        );
        assert_eq!(
            logging_iceoryx2_level("debug,iceoryx2=warn"),
            LevelFilter::WARN
        );
        assert_eq!(
            logging_iceoryx2_level("warn,iceoryx2=trace"),
            LevelFilter::TRACE
        );
        assert_eq!(logging_iceoryx2_level("error"), LevelFilter::ERROR);
    }
}
