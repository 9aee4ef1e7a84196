//! The process runtime of the pipeline: one lifecycle for every process ([`Node`], [`run`]),
//! configured by the run file (`testbed_config::RunConfig`).

#![forbid(unsafe_code)]

pub mod health;
pub mod node;
pub mod process;

pub use health::{HealthReporter, InputWatch};
pub use node::{Context, Io, Node, WakeOn, exit_status, run};
