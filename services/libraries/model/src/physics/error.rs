//! Why the plant refused a configuration, an initial state or a step.

use crate::config::ConfigError;

/// Errors of the platform physics. Every variant names the offending input.
#[derive(Debug, thiserror::Error)]
pub enum PhysicsError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// `I − J·1` (the platform without the wheels' spin inertia) must be symmetric positive
    /// definite, or the coupled wheel/platform equations have no solution.
    #[error(
        "platform inertia minus the wheel rotor inertia ({wheel_inertia_kgm2} kg m²) is not positive definite"
    )]
    InertiaNotPositiveDefinite { wheel_inertia_kgm2: f64 },
    #[error("{what} is not finite")]
    NonFinite { what: &'static str },
    #[error("step duration {dt_s} s must be finite and > 0")]
    InvalidStep { dt_s: f64 },
    #[error("integrator substep {max_substep_s} s must be finite and > 0")]
    InvalidSubstep { max_substep_s: f64 },
    #[error("initial tilt {angle_deg}° of body {axis:?} is beyond the tilt stop ±{limit_deg}°")]
    InitialTiltBeyondStop {
        axis: super::TiltAxis,
        angle_deg: f64,
        limit_deg: f64,
    },
}
