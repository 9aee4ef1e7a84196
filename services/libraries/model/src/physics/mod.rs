//! Platform physics (rigid body on the air bearing, wheels, CMGs, effects).
//!
//! One module per physical model, each with its parameters documented and tested against a
//! closed-form truth:
//!
//! * [`dynamics`]: equations of motion of the platform with wheels and CMGs;
//! * [`friction`]: wheel bearing friction (paper eq. 3, or the asymmetric Stribeck effect);
//! * [`environment`]: external torques (centre-of-mass offset, drag, constant);
//! * [`fitted_torque`]: a torque fitted to data (identification's unexplained effect);
//! * [`fitted_wheel_torque`]: a torque between a wheel and the platform fitted to data
//!   (identification's unexplained effect in the wheel channel);
//! * [`gauss_markov`]: a slowly wandering (Gauss–Markov) external torque;
//! * [`tilt_stop`]: the bearing's ±30° mechanical stop;
//! * [`delay`]: actuator command delay;
//! * [`integrator`]: fixed-step RK4;
//! * [`thrusters`]: the six cold-gas thrusters, their valves, propellant and tank (off unless
//!   configured);
//! * [`plant`]: all of it stepped in time, with actuator limits and stick–slip.

pub mod cmg_pyramid;
pub mod delay;
pub mod dynamics;
pub mod environment;
pub mod error;
pub mod fitted_torque;
pub mod fitted_wheel_torque;
pub mod friction;
pub mod gauss_markov;
pub mod integrator;
pub mod plant;
pub mod state;
pub mod thrusters;
pub mod tilt_stop;

#[cfg(test)]
mod plant_tests;
#[cfg(test)]
mod thruster_plant_tests;

pub use cmg_pyramid::CmgPyramid;
pub use dynamics::{Dynamics, StepInput, WheelMode};
pub use environment::{ExternalTorque, ExternalTorqueModel, external_torque};
pub use error::PhysicsError;
pub use friction::{Wheel, WheelFrictionModel, wheel_breakaway_torque, wheel_friction_torque};
pub use integrator::rk4_step;
pub use plant::{AppliedActuation, IntegratorOptions, Plant, StepReport};
pub use state::{ActuatorCommand, PlatformState, StateVector};
pub use thrusters::{ThrusterBank, ThrusterCommand};
pub use tilt_stop::{TiltAxis, TiltStopEvent};
