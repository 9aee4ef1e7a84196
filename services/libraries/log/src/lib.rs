//! The run log: one [MCAP](https://mcap.dev) file per run holding every topic of the pipeline,
//! the schemas of their messages and the run's full configuration.
//!
//! - [`RunLogWriter`] writes a log; [`RunLog`] reads one back into `ipc-types` samples
//!   ([`LogRecord`]) for replay and identification; [`LogTail`] follows one while it is
//!   written, reading only what was appended since its last look (a progress display).
//! - [`TickSorter`] (or [`RecordOrder::Sorted`]) makes the record order of a lockstep run
//!   independent of how its processes interleave, so two runs with the same seed give
//!   byte-identical files.
//!
//! # Encoding
//!
//! Standard MCAP, readable by the `mcap` CLI, Foxglove and the Python/C++/Go readers:
//!
//! - One channel per topic of the topic table ([`ipc_types::TopicId`]; topic = the iceoryx2
//!   service name), in table order ([`channel_id`]), message encoding `json`, schema encoding
//!   `jsonschema` (Foxglove's JSON convention).
//! - One schema per sample type, named after its versioned iceoryx2 type name
//!   (`testbed::GyroSample.v1`, …); field names are the Rust field names (padding fields left
//!   out), descriptions give units and frames.
//! - Messages are compact JSON with fields in declaration order; `f64` values in the shortest
//!   form that reads back to the same bits; non-finite values (NaN, ±infinity: JSON numbers
//!   cannot hold them) as `null`, which decodes to NaN (schema type `["number", "null"]`);
//!   [`Heartbeat::name`](ipc_types::Heartbeat::name) as a string (or as its 32 raw bytes if
//!   they are not NUL-padded UTF-8). Decoding gives back the exact sample, except that a
//!   non-finite value comes back as NaN (the sign of an infinity and NaN payloads are lost).
//! - `log_time = publish_time = start_time_ns + header.time_ns`: the run's wall-clock start
//!   ([`RunInfo::start_time_ns`]) plus the run clock, so viewers show the real date; the
//!   sample's header keeps the run clock.
//! - Attitude as Foxglove's well-known `foxglove.FrameTransform` (JSON), derived from the
//!   estimate and the simulation truth ([`foxglove`]), so the 3D panel shows the platform.
//! - Indexed when the run ends ([`index`]): zstd-compressed chunks, one per
//!   [`CHUNK_INTERVAL_NS`] (10 s) of log time, the flush interval: chunks do not overlap in
//!   time, so a viewer seeking to a time reads one chunk. Each has its message indexes, and
//!   the summary a chunk index. Within a chunk the messages are grouped by channel (it
//!   compresses better); readers that sort by log time give them back in time order.
//! - The configuration text is the attachment [`CONFIG_ATTACHMENT`] (`application/toml`),
//!   dated the run's start (`log_time` = `create_time` = [`RunInfo::start_time_ns`]); profile,
//!   seed and mode are the string map of the metadata record [`RUN_METADATA`].
//! - Every message is stamped with the time it describes: a sample's `header.time_ns`, a
//!   heartbeat's the newest sample time its process had handled.
//!
//! # Crash safety
//!
//! See [`RunLogWriter`]: during the run records are unchunked and uncompressed, so a file cut
//! at any byte keeps every complete record, and [`RunLog`] reports where the file was cut; the
//! indexed, compressed rewrite at the end replaces the file atomically.

pub mod foxglove;
mod json;
mod reader;
mod record;
mod repair;
mod sorter;
mod tail;
mod writer;

pub use json::DecodeError;
pub use reader::{LogEnd, Records, RunLog, Samples};
pub use record::{LogEncode, LogRecord, TopicJson};
pub use repair::{
    CHUNK_INTERVAL_NS, CHUNK_ZSTD_LEVEL, RepairReport, chunk_time_ranges, index, index_with_level,
    repair,
};
pub use sorter::{EncodedRecord, TickSorter};
pub use tail::LogTail;
pub use writer::{
    LogStats, RecordOrder, RunLogWriter, WriterOptions, channel_id, derived_channel_id,
};

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Wall-clock time, ns since the Unix epoch (0 if the clock is before it): the usual
/// [`RunInfo::start_time_ns`].
pub fn unix_time_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// Name of the attachment holding the run's configuration.
pub const CONFIG_ATTACHMENT: &str = "config.toml";
/// Media type of the configuration attachment.
pub const CONFIG_MEDIA_TYPE: &str = "application/toml";
/// Name of the metadata record holding [`RunInfo`]'s fields (keys in [`keys`]).
pub const RUN_METADATA: &str = "testbed.run";
/// Message encoding of every channel.
pub const MESSAGE_ENCODING: &str = "json";
/// Schema encoding of every schema.
pub const SCHEMA_ENCODING: &str = "jsonschema";
/// Value of the [`keys::FORMAT`] metadata entry: this crate's log format and its version.
pub const FORMAT: &str = "testbed-log/1";

/// Keys of the [`RUN_METADATA`] record written from [`RunInfo`].
pub mod keys {
    /// Log format, [`FORMAT`](crate::FORMAT).
    pub const FORMAT: &str = "format";
    /// [`RunInfo::profile`](crate::RunInfo::profile).
    pub const PROFILE: &str = "profile";
    /// [`RunInfo::seed`](crate::RunInfo::seed), decimal.
    pub const SEED: &str = "seed";
    /// [`RunInfo::mode`](crate::RunInfo::mode).
    pub const MODE: &str = "mode";
    /// [`RunInfo::start_time_ns`](crate::RunInfo::start_time_ns), decimal (absent in logs
    /// written before it existed: read as 0).
    pub const START_TIME_NS: &str = "start_time_ns";
    /// The same start time in RFC 3339 (UTC), for people reading the metadata.
    pub const START_TIME: &str = "start_time";
}

const RESERVED_KEYS: &[&str] = &[
    keys::FORMAT,
    keys::PROFILE,
    keys::SEED,
    keys::MODE,
    keys::START_TIME_NS,
    keys::START_TIME,
];

/// What the log records about the run besides its samples.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RunInfo {
    /// Launch profile the run was started from (e.g. `"simulation"`).
    pub profile: String,
    /// Seed of the run's random number generators.
    pub seed: u64,
    /// Run mode (e.g. `"lockstep"`, `"paced"`, `"hardware"`).
    pub mode: String,
    /// The run's full configuration, as TOML text (stored verbatim).
    pub config_toml: String,
    /// Wall-clock start of the run, ns since the Unix epoch: every message's MCAP `log_time`
    /// and `publish_time` is this plus the sample's `header.time_ns` (run clock). 0: the log
    /// times are the run clock itself.
    pub start_time_ns: u64,
    /// Further metadata entries (keys must not be one of [`keys`]).
    pub extra: BTreeMap<String, String>,
}

/// Errors of writing and reading run logs.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// An I/O error on a file.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// An I/O error.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
    /// The MCAP library failed (writing).
    #[error("MCAP: {0}")]
    Mcap(#[from] mcap::McapError),
    /// The writer was already finished.
    #[error("the log writer is finished")]
    Finished,
    /// [`RunInfo::extra`] uses a key the log writes itself.
    #[error("metadata key {0:?} is reserved")]
    ReservedKey(String),
    /// In sorted order, a record arrived for a time already completed (not logged).
    #[error(
        "late record on {topic} at {time_ns} ns: times up to {completed_until_ns} ns are already written"
    )]
    LateRecord {
        /// Topic of the record.
        topic: &'static str,
        /// The record's `header.time_ns`.
        time_ns: u64,
        /// Latest completed time.
        completed_until_ns: u64,
    },
    /// The file does not start with the MCAP magic.
    #[error("not an MCAP file (bad magic)")]
    NotMcap,
    /// A record could not be parsed.
    #[error("corrupt record at byte {offset}: {source}")]
    Corrupt {
        /// Byte offset of the record.
        offset: u64,
        /// The parse error.
        source: mcap::McapError,
    },
    /// The file uses an MCAP feature this reader does not read.
    #[error("record at byte {offset}: {what} is not supported")]
    Unsupported {
        /// Byte offset of the record.
        offset: u64,
        /// What is not supported.
        what: &'static str,
    },
    /// A compressed chunk could not be decompressed.
    #[error("chunk at byte {offset}: zstd decompression failed: {source}")]
    Decompress {
        /// Byte offset of the chunk record.
        offset: u64,
        /// The decompressor's error.
        source: std::io::Error,
    },
    /// The log lacks the run information (configuration attachment or run metadata).
    #[error("no {missing} in the log ({end})")]
    MissingRunInfo {
        /// What is missing.
        missing: &'static str,
        /// Whether and where the file was cut.
        end: LogEnd,
    },
    /// The run metadata has an invalid entry.
    #[error("run metadata entry {key:?}: {problem}")]
    BadRunInfo {
        /// The key.
        key: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// A message is on a channel the log does not define.
    #[error("message at byte {offset} is on undefined channel {channel}")]
    UnknownChannel {
        /// Byte offset of the message record.
        offset: u64,
        /// The channel id.
        channel: u16,
    },
    /// A message is on a channel this reader cannot decode (unknown topic, other schema
    /// version or encoding).
    #[error("message at byte {offset} on {topic:?}: {problem}")]
    Undecodable {
        /// Byte offset of the message record.
        offset: u64,
        /// The channel's topic.
        topic: String,
        /// Why the channel cannot be decoded.
        problem: String,
    },
    /// A message could not be decoded.
    #[error("message at byte {offset} on {topic}: {source}")]
    Decode {
        /// Byte offset of the message record.
        offset: u64,
        /// The topic.
        topic: &'static str,
        /// The decoding error.
        source: DecodeError,
    },
}

impl LogError {
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        Self::File {
            path: path.to_owned(),
            source,
        }
    }
}
