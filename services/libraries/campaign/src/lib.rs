//! Monte Carlo campaigns: N runs of a scenario on the in-process closed loop, with parameters
//! dispersed by key path in the run configuration, each run determined by the campaign seed and
//! its index.
//!
//! * [`file`]: the campaign file (runs, seed, base, dispersions, variants, metric options).
//! * [`key_path`]: run-configuration keys named by their path, read and set on its TOML value.
//! * [`distribution`]: uniform, normal, lists; set, add or scale; each draw's random stream.
//! * [`plan`]: the campaign checked against its base configuration; each run's configuration.
//! * [`execute`]: the runs on a pool of workers, each reduced to its row as it ends.
//! * [`metrics`]: what is kept of a run: its metrics and a decimated error and NEES series.
//! * [`summary`]: the distribution of each metric, consistency, envelope, worst runs.
//! * [`paired`]: A/B comparison of variants on the same runs.
//! * [`results`]: rows as CSV and JSON, read back bit for bit; the merge of shards.

#![forbid(unsafe_code)]

pub mod distribution;
pub mod error;
pub mod execute;
pub mod file;
pub mod key_path;
pub mod metrics;
pub mod paired;
pub mod plan;
pub mod results;
pub mod summary;

pub use error::CampaignError;
pub use file::CampaignFile;
pub use plan::{Job, Plan, RunSpec};
