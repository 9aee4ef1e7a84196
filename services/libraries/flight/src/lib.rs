//! Flight software of the test bed: what runs on the platform's computer. No simulation code.
//!
//! * [`mekf`]: the multiplicative EKF of Lefferts, Markley and Shuster (gyro propagation,
//!   inclinometer + magnetometer vector updates, innovation gating).
//! * [`estimators`]: the attitude filters behind one interface, chosen by name
//!   (`estimator.filter`).
//! * [`laws`]: the control laws behind one interface, chosen by name (`controller.law`).
//! * [`control`]: PD attitude control on the reaction wheels with friction compensation.
//! * [`safe_mode`]: when the controller stops trusting its inputs, and what it commands then.
//! * [`cmg_steering`]: singularity-robust steering of the four-CMG pyramid and a slew law.
//! * [`tasks`]: the estimator and controller as tasks — each tick's samples in, its estimate or
//!   commands out, on the tick [`schedule`]; the processes wrap them, the in-process closed
//!   loop shares their code.
//! * [`choice`]: a component chosen by name with its parameter table (laws, filters).
//! * [`stats`]: the chi-square distribution (the MEKF's gate thresholds, consistency checks).
//! * [`lqr`]: the continuous-time LQR (Riccati equation by Newton–Kleinman).
//! * [`manoeuvre`]: the experiment programme (initial condition, target).
//! * [`convert`]: sample arrays to and from nalgebra types.
//! * [`thruster_control`]: pulse modulator, momentum dumping and rate damping on the six
//!   thrusters (off unless configured).

#![forbid(unsafe_code)]

pub mod choice;
pub mod cmg_steering;
pub mod control;
pub mod convert;
pub mod estimators;
pub mod laws;
pub mod lqr;
pub mod manoeuvre;
pub mod mekf;
pub mod safe_mode;
pub mod schedule;
pub mod stats;
pub mod tasks;
pub mod thruster_control;
