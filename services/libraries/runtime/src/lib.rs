//! The process runtime of the pipeline: the run configuration every process reads, and what
//! every process does to start.

pub mod process;
pub mod run_config;

pub use run_config::{ClockMode, ENV_RUN_CONFIG, RunConfig};
