//! The flight software's two jobs as small tasks with a clear lifecycle: the estimator and the
//! controller. The in-process closed loop wires them to the plant directly; the pipeline's
//! processes wrap the same tasks around iceoryx2 ports, so both run identical code.
//!
//! * [`EstimatorTask`] (`estimator`): the MEKF with its TRIAD start-up.
//! * [`ControllerTask`] (`controller`): the attitude control law on the wheels or the CMGs, with
//!   its configuration ([`ControllerConfig`], [`Actuators`]), inputs ([`ActuatorTelemetry`]) and
//!   output ([`ControlOutput`]).

mod controller;
mod estimator;

pub use controller::{
    ActuatorTelemetry, Actuators, ControlOutput, ControllerConfig, ControllerTask,
};
pub use estimator::EstimatorTask;
