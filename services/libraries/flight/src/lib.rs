//! Flight software of the test bed: what runs on the platform's computer. No simulation code.
//!
//! * [`mekf`]: the multiplicative EKF of Lefferts, Markley and Shuster (gyro propagation,
//!   inclinometer + magnetometer vector updates, innovation gating).
//! * [`control`]: PD attitude control on the reaction wheels with friction compensation.
//! * [`safe_mode`]: when the controller stops trusting its inputs, and what it commands then.
//! * [`cmg_steering`]: singularity-robust steering of the four-CMG pyramid and a slew law.
//! * [`tasks`]: the estimator and controller as tasks (maths only), shared by the in-process
//!   closed loop and the pipeline.
//! * [`estimator_node`], [`controller_node`]: those tasks fed with the pipeline's samples on the
//!   tick [`schedule`], returning samples; the processes wrap them.
//! * [`stats`]: the chi-square distribution (the MEKF's gate thresholds, consistency checks).
//! * [`manoeuvre`]: the experiment programme (initial condition, target).
//! * [`convert`]: sample arrays to and from nalgebra types.
//! * [`thruster_control`]: pulse modulator, momentum dumping and rate damping on the six
//!   thrusters (issue 14; off unless configured).

#![forbid(unsafe_code)]

pub mod cmg_steering;
pub mod control;
pub mod controller_node;
pub mod convert;
pub mod estimator_node;
pub mod manoeuvre;
pub mod mekf;
pub mod safe_mode;
pub mod schedule;
pub mod stats;
pub mod tasks;
pub mod thruster_control;
