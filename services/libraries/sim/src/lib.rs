//! The simulation side of the test bed.
//!
//! * [`plant_task`]: the platform physics as the clock owner of a run (truth and tick out,
//!   commands in), the plant process's logic.
//! * [`sim_devices`]: the device models on the plant's truth, publishing what the real gateways
//!   would.
//! * [`closed_loop`]: plant + devices + estimator + controller in one deterministic call.
//! * [`in_memory`]: the pipeline's tasks wired in memory (the reference for the processes).
//! * [`metrics`]: settling time, steady error, estimation accuracy and consistency.
//! * [`paper`]: the paper's results reproduced side by side with its numbers.

#![forbid(unsafe_code)]

pub mod closed_loop;
pub mod in_memory;
pub mod metrics;
pub mod paper;
pub mod plant_task;
pub mod sim_devices;
pub mod thruster_shows;
pub mod thruster_trace;
