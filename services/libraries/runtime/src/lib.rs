//! The process runtime of the pipeline: the run configuration every process reads, and one
//! lifecycle for every process ([`Node`], [`run`]).

#![forbid(unsafe_code)]

pub mod ground;
pub mod health;
pub mod node;
pub mod process;
pub mod run_config;

pub use health::{HealthReporter, InputWatch};
pub use node::{Context, Io, Node, WakeOn, run};
pub use run_config::{ClockMode, ENV_RUN_CONFIG, RunConfig};
