//! The test bed's physics and device models as plain library code: no I/O, no clock.
//!
//! * [`config`]: every parameter, with its source (paper, derived, assumed), loaded from TOML.
//! * [`attitude`]: frames and the quaternion convention, used everywhere.
//! * [`physics`]: the rigid platform on the air bearing with wheels and CMGs, the integrator,
//!   and the effects beyond the nominal model.
//! * [`devices`]: gyro, inclinometer, magnetometer, wheel and CMG device models (noise, bias,
//!   quantisation, range), seeded and reproducible.

#![forbid(unsafe_code)]

pub mod attitude;
pub mod balance_config;
pub mod config;
pub mod devices;
pub mod physics;
pub mod thruster_config;

pub use config::{ModelConfig, WheelConfig};
