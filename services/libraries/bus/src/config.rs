//! Bus configuration: which iceoryx2 "domain" (file prefix + root path) a run uses, and the
//! run-wide delivery mode and service limits every process must agree on.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::atomic::{AtomicU32, Ordering};

use iceoryx2::config::Config;
use iceoryx2::prelude::{FileName, SemanticString};

use crate::BusError;

/// Environment variable naming the iceoryx2 file prefix of a run ([`BusConfig::prefix`]).
pub const ENV_PREFIX: &str = "TESTBED_BUS_PREFIX";
/// Environment variable naming the iceoryx2 root directory of a run ([`BusConfig::root`]).
pub const ENV_ROOT: &str = "TESTBED_BUS_ROOT";
/// Environment variable selecting the run's [`Delivery`] (`overflow` or `lossless`).
pub const ENV_DELIVERY: &str = "TESTBED_BUS_DELIVERY";

/// Prefix used when [`ENV_PREFIX`] is not set.
pub const DEFAULT_PREFIX: &str = "testbed_";
/// Root directory used when [`ENV_ROOT`] is not set (iceoryx2's own default).
pub const DEFAULT_ROOT: &str = "/tmp/iceoryx2/";

/// Longest accepted root path. iceoryx2 places Unix domain sockets below the root, and a socket
/// path longer than 108 bytes cannot be bound, so the root must leave room for the file names.
pub const MAX_ROOT_LEN: usize = 40;
/// Longest accepted prefix (it is part of every file name, including socket names).
pub const MAX_PREFIX_LEN: usize = 24;

/// What a publisher does when a subscriber's buffer is full.
///
/// The heartbeat and health topics always use [`Delivery::Overflow`], whatever the run's mode.
///
/// This is a property of the iceoryx2 *service* (`enable_safe_overflow`), so every process of a
/// run must use the same value: a mismatch is refused by iceoryx2 when the second process opens
/// the service ([`BusError::Service`] naming the topic). The launcher sets [`ENV_DELIVERY`] for
/// all processes from the run mode (lockstep → lossless, paced → overflow).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Delivery {
    /// The oldest unread sample in the full buffer is replaced (iceoryx2 safe overflow). A
    /// publisher never blocks; a slow subscriber loses old samples. For hardware runs, where a
    /// stuck consumer must not stall a device gateway.
    #[default]
    Overflow,
    /// No sample is ever lost: safe overflow is off and publishers use
    /// `BackpressureStrategy::RetryUntilDelivered`, so `publish` blocks while any connected
    /// subscriber's buffer is full. For lockstep simulation and the logger.
    ///
    /// While blocked, iceoryx2 waits adaptively inside `send` (spin, then yield, then sleeps of
    /// 100 µs growing to 10 ms) until the subscriber takes a sample: size buffers so that this
    /// is the exception (bursts), not the way the pipeline is paced. A subscriber that stops
    /// reading while staying connected blocks its publishers for as long.
    ///
    /// Topics that form a cycle (plant → sensors → estimator → controller → plant) deadlock
    /// if a burst fills the buffers all around the cycle: each process blocks in `publish` and
    /// stops reading. Keep fewer samples in flight than the buffers hold (lockstep keeps one
    /// tick in flight). Samples sent before a new subscriber has attached are queued up to its
    /// buffer size only (see [`crate::TopicPublisher::publish`]).
    Lossless,
}

impl Delivery {
    /// The value's name as used in [`ENV_DELIVERY`].
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Overflow => "overflow",
            Self::Lossless => "lossless",
        }
    }
}

impl fmt::Display for Delivery {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Delivery {
    type Err = BusError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "overflow" => Ok(Self::Overflow),
            "lossless" => Ok(Self::Lossless),
            other => Err(BusError::Config {
                key: ENV_DELIVERY,
                value: other.to_owned(),
                reason: "expected \"overflow\" or \"lossless\"".to_owned(),
            }),
        }
    }
}

/// Service-level limits, fixed by whichever process creates a service first and verified by
/// iceoryx2 when the others open it. Every process of a run must use the same values; leave
/// them at their defaults unless a test needs otherwise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ServiceLimits {
    /// Publishers per shared topic: one that every process or CAN sender publishes on
    /// (heartbeats, health events, the software CAN bus and its link counters).
    pub max_publishers: usize,
    /// Publishers per other topic: one in a run, with room for a restarted process's port
    /// before its dead predecessor's is freed and for a test's injector. Kept small because
    /// every receive visits every publisher slot of its service (iceoryx2 0.10), these and the
    /// departed publishers' (`max_publishers` of them, [`BusConfig::to_iceoryx2`]).
    pub max_data_publishers: usize,
    /// Subscribers per topic.
    pub max_subscribers: usize,
    /// Nodes (processes) per service.
    pub max_nodes: usize,
    /// Largest subscriber buffer a port may ask for ([`crate::SubscriberOptions::buffer_size`]).
    pub max_buffer_size: usize,
    /// Samples each publisher keeps for late-joining subscribers; a subscriber receives up to
    /// [`crate::SubscriberOptions::history`] of them when it connects.
    pub history_size: usize,
}

impl Default for ServiceLimits {
    fn default() -> Self {
        Self {
            max_publishers: 16,
            max_data_publishers: 4,
            max_subscribers: 16,
            max_nodes: 32,
            max_buffer_size: 256,
            history_size: 1,
        }
    }
}

/// Which iceoryx2 resources a run uses, and how its services behave.
///
/// Two runs with different prefixes (or roots) never see each other's services or nodes, so the
/// launcher and tests isolate runs by giving each its own [`BusConfig`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BusConfig {
    /// iceoryx2 global prefix: starts the name of every file (shared memory, sockets, node and
    /// service files) the run creates. Letters, digits, `_` and `-`.
    pub prefix: String,
    /// iceoryx2 root directory holding the node and service directories and the event sockets.
    /// Keep it short (at most [`MAX_ROOT_LEN`] bytes).
    pub root: PathBuf,
    /// The run's delivery mode.
    pub delivery: Delivery,
    /// The run's service limits.
    pub limits: ServiceLimits,
}

impl Default for BusConfig {
    fn default() -> Self {
        Self::new(DEFAULT_PREFIX, DEFAULT_ROOT)
    }
}

impl BusConfig {
    /// A configuration with [`Delivery::Overflow`] and default limits.
    pub fn new(prefix: impl Into<String>, root: impl Into<PathBuf>) -> Self {
        Self {
            prefix: prefix.into(),
            root: root.into(),
            delivery: Delivery::default(),
            limits: ServiceLimits::default(),
        }
    }

    /// The same configuration with `delivery`.
    pub fn with_delivery(mut self, delivery: Delivery) -> Self {
        self.delivery = delivery;
        self
    }

    /// Reads [`ENV_PREFIX`], [`ENV_ROOT`] and [`ENV_DELIVERY`], each defaulting to
    /// [`DEFAULT_PREFIX`], [`DEFAULT_ROOT`] and [`Delivery::Overflow`] when unset or empty. The
    /// result is validated (see [`validate`](Self::validate)), and so is
    /// [`ENV_WAIT`](ipc_types::ENV_WAIT) if set (the event loops read it).
    pub fn from_env() -> Result<Self, BusError> {
        Self::from_lookup(|key| std::env::var(key).ok())
    }

    /// Like [`from_env`](Self::from_env), reading variables through `lookup`.
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> Result<Self, BusError> {
        let get = |key: &str| lookup(key).filter(|v| !v.is_empty());
        let mut config = Self::new(
            get(ENV_PREFIX).unwrap_or_else(|| DEFAULT_PREFIX.to_owned()),
            get(ENV_ROOT).unwrap_or_else(|| DEFAULT_ROOT.to_owned()),
        );
        if let Some(delivery) = get(ENV_DELIVERY) {
            config.delivery = delivery.parse()?;
        }
        // Read by every `EventLoop::new` of the process; refused here, with its name, so that
        // a process with an invalid value does not start.
        <ipc_types::WaitStrategy as crate::WaitFromEnv>::from_lookup(&lookup)?;
        config.validate()?;
        Ok(config)
    }

    /// A fresh configuration no other run or test uses: prefix `t<pid>x<n>_`, root
    /// `/tmp/ix-<pid>-<n>/`. Remove its files with [`crate::remove_all`] afterwards.
    pub fn isolated() -> Self {
        static COUNTER: AtomicU32 = AtomicU32::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let pid = std::process::id();
        Self::new(format!("t{pid}x{n}_"), format!("/tmp/ix-{pid}-{n}/"))
    }

    /// The environment variables that make a child process use this configuration.
    pub fn env_vars(&self) -> [(&'static str, String); 3] {
        [
            (ENV_PREFIX, self.prefix.clone()),
            (ENV_ROOT, self.root_string()),
            (ENV_DELIVERY, self.delivery.as_str().to_owned()),
        ]
    }

    /// Checks the prefix and the root path.
    pub fn validate(&self) -> Result<(), BusError> {
        let prefix_ok = !self.prefix.is_empty()
            && self.prefix.len() <= MAX_PREFIX_LEN
            && self
                .prefix
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
        if !prefix_ok {
            return Err(BusError::Config {
                key: ENV_PREFIX,
                value: self.prefix.clone(),
                reason: format!("expected 1 to {MAX_PREFIX_LEN} characters from [A-Za-z0-9_-]"),
            });
        }
        let root = self.root_string();
        if !self.root.is_absolute() || root.len() > MAX_ROOT_LEN || root.contains("//") {
            return Err(BusError::Config {
                key: ENV_ROOT,
                value: root,
                reason: format!(
                    "expected an absolute path of at most {MAX_ROOT_LEN} bytes (Unix socket \
                     paths below it are limited to 108 bytes)"
                ),
            });
        }
        if root == "/" {
            return Err(BusError::Config {
                key: ENV_ROOT,
                value: root,
                reason: "the file system root cannot be the bus root".to_owned(),
            });
        }
        Ok(())
    }

    /// The root path as a string ending in `/`.
    pub fn root_string(&self) -> String {
        let mut root = self.root.to_string_lossy().into_owned();
        if !root.ends_with('/') {
            root.push('/');
        }
        root
    }

    /// The root directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The iceoryx2 configuration: default values with this prefix and root path.
    pub fn to_iceoryx2(&self) -> Result<Config, BusError> {
        self.validate()?;
        let mut config = Config::default();
        config.global.prefix =
            FileName::new(self.prefix.as_bytes()).map_err(|e| BusError::Config {
                key: ENV_PREFIX,
                value: self.prefix.clone(),
                reason: format!("not a valid iceoryx2 file name ({e:?})"),
            })?;
        let root = self.root_string();
        let path = iceoryx2::prelude::Path::new(root.as_bytes()).map_err(|e| BusError::Config {
            key: ENV_ROOT,
            value: root.clone(),
            reason: format!("not a valid iceoryx2 path ({e:?})"),
        })?;
        config.global.set_root_path(&path);
        // A subscriber keeps the connections of publishers that left with samples unread, so
        // that it can still take them; each receive visits every slot, kept and active. iceoryx2
        // keeps 128 by default, whose visits were 46 % of the estimator's and 29 % of the
        // controller's instructions a tick (bench/README.md).
        // No topic has more publishers than `max_publishers`, so that many departed ones fit:
        // a run's end, when every process leaves with its last health events unread by the
        // logger, loses none.
        config
            .defaults
            .publish_subscribe
            .subscriber_expired_connection_buffer = self.limits.max_publishers;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_when_environment_is_empty() {
        let config = BusConfig::from_lookup(|_| None).expect("defaults are valid");
        assert_eq!(config.prefix, DEFAULT_PREFIX);
        assert_eq!(config.root_string(), DEFAULT_ROOT);
        assert_eq!(config.delivery, Delivery::Overflow);
    }

    #[test]
    fn reads_all_three_variables() {
        let config = BusConfig::from_lookup(|key| {
            Some(
                match key {
                    ENV_PREFIX => "run7_",
                    ENV_ROOT => "/tmp/ix-run7",
                    ENV_DELIVERY => "lossless",
                    _ => return None,
                }
                .to_owned(),
            )
        })
        .expect("valid");
        assert_eq!(config.prefix, "run7_");
        assert_eq!(config.root_string(), "/tmp/ix-run7/");
        assert_eq!(config.delivery, Delivery::Lossless);
        let env = config.env_vars();
        assert_eq!(env[1], (ENV_ROOT, "/tmp/ix-run7/".to_owned()));
    }

    #[test]
    fn invalid_values_are_named() {
        let err = BusConfig::from_lookup(|key| (key == ENV_DELIVERY).then(|| "fast".to_owned()))
            .expect_err("invalid delivery");
        let msg = err.to_string();
        assert!(msg.contains(ENV_DELIVERY) && msg.contains("fast"), "{msg}");

        let err = BusConfig::new("bad/prefix", "/tmp/x")
            .validate()
            .expect_err("slash");
        assert!(err.to_string().contains("bad/prefix"), "{err}");

        let long = format!("/tmp/{}", "x".repeat(60));
        let err = BusConfig::new("ok_", long.as_str())
            .validate()
            .expect_err("too long");
        assert!(err.to_string().contains(ENV_ROOT), "{err}");

        let err = BusConfig::new("ok_", "relative/dir")
            .validate()
            .expect_err("relative");
        assert!(err.to_string().contains("relative/dir"), "{err}");
    }

    #[test]
    fn isolated_configs_differ() {
        let a = BusConfig::isolated();
        let b = BusConfig::isolated();
        assert_ne!(a.prefix, b.prefix);
        assert_ne!(a.root, b.root);
        a.validate().expect("valid");
        a.to_iceoryx2().expect("converts");
    }
}
