//! The experiment programme: the initial condition the simulation starts from and the attitude
//! the controller holds, given at the edge in degrees and rpm.

use nalgebra::{Vector3, Vector4};
use serde::{Deserialize, Serialize};
use testbed_model::attitude::{self, Attitude};
use testbed_model::config::DEG;
use testbed_model::physics::PlatformState;

/// Initial condition and target, at the edge in degrees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Manoeuvre {
    /// Initial heading, tilt about body Y (pitch) and about body X (roll), degrees
    /// (see [`attitude::from_heading_pitch_roll`]).
    pub initial_heading_deg: f64,
    pub initial_pitch_deg: f64,
    pub initial_roll_deg: f64,
    /// Initial body rate, °/s.
    pub initial_rate_deg_s: [f64; 3],
    /// Initial wheel speeds, rpm.
    pub initial_wheel_speed_rpm: [f64; 3],
    /// Target heading, pitch, roll, degrees.
    pub target_heading_deg: f64,
    pub target_pitch_deg: f64,
    pub target_roll_deg: f64,
}

impl Default for Manoeuvre {
    /// The paper's stabilisation test (Fig. 11–12): 5° tilt on X and Y and 20° heading, to level.
    fn default() -> Self {
        Self {
            initial_heading_deg: 20.0,
            initial_pitch_deg: 5.0,
            initial_roll_deg: 5.0,
            initial_rate_deg_s: [0.0; 3],
            initial_wheel_speed_rpm: [0.0; 3],
            target_heading_deg: 0.0,
            target_pitch_deg: 0.0,
            target_roll_deg: 0.0,
        }
    }
}

impl Manoeuvre {
    pub fn initial_state(&self) -> PlatformState {
        PlatformState {
            q: attitude::from_heading_pitch_roll(
                self.initial_heading_deg * DEG,
                self.initial_pitch_deg * DEG,
                self.initial_roll_deg * DEG,
            ),
            rate_b: Vector3::from(self.initial_rate_deg_s) * DEG,
            wheel_speed: Vector3::from(self.initial_wheel_speed_rpm) * testbed_model::config::RPM,
            gimbal: Vector4::zeros(),
        }
    }

    pub fn target(&self) -> Attitude {
        attitude::from_heading_pitch_roll(
            self.target_heading_deg * DEG,
            self.target_pitch_deg * DEG,
            self.target_roll_deg * DEG,
        )
    }
}
