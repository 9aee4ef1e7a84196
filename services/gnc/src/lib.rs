//! Attitude determination and control of the test bed, and the in-process closed loop.
//!
//! * [`mekf`]: the multiplicative EKF of Lefferts, Markley and Shuster (gyro propagation,
//!   inclinometer + magnetometer vector updates, innovation gating).
//! * [`control`]: PD attitude control on the reaction wheels with friction compensation.
//! * [`cmg_steering`]: singularity-robust steering of the four-CMG pyramid and a slew law.
//! * [`tasks`]: the estimator and controller as tasks, shared by the closed loop and the
//!   pipeline's processes.
//! * [`closed_loop`]: plant + devices + estimator + controller in one deterministic call.
//! * [`metrics`]: settling time, steady error, estimation accuracy and consistency.
//! * [`paper`]: the paper's results reproduced side by side with its numbers.

pub mod closed_loop;
pub mod cmg_steering;
pub mod control;
pub mod mekf;
pub mod paper;
pub mod metrics;
pub mod tasks;
