//! The flight software's two jobs as tasks: the estimator and the controller, each a state
//! machine with its I/O-free logic between the processes (which own the bus ports) and the
//! maths ([`crate::mekf`], the control laws). The pipeline's processes feed them samples; the
//! in-process closed loop feeds the same tasks (the estimator) or the same law (the controller)
//! directly, so both run identical code.
//!
//! * [`EstimatorTask`] (`estimator`): the tick's samples assembled, the filter chosen by name
//!   ([`crate::estimators`], the MEKF by default) with its start-up, one [`ipc_types::AttitudeEstimate`] per tick.
//! * [`ControllerTask`] (`controller`): one [`ControlCycle`] per tick from the estimate and the
//!   actuators' telemetry, with safe mode and ground commands, its configuration
//!   ([`ControllerConfig`]) and its law ([`GuardedLaw`]: the law chosen by name,
//!   [`crate::laws`], inside the actuators' limits; inputs [`ActuatorTelemetry`], output
//!   [`ControlOutput`]).

mod controller;
mod estimator;

pub use crate::laws::{ActuatorTelemetry, ControlOutput};
pub use controller::{ControlCycle, ControllerConfig, ControllerTask, GuardedLaw};
pub use estimator::{EstimatorCounters, EstimatorTask};
