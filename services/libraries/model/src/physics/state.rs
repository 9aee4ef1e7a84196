//! The plant's state and the actuator command it receives.

use crate::attitude::Attitude;
use nalgebra::{Quaternion, SVector, UnitQuaternion, Vector3, Vector4};

/// Number of scalars in [`StateVector`].
pub const STATE_LEN: usize = 14;

/// The state as one vector for the integrator: quaternion coordinates `[x, y, z, w]` (0..4),
/// body rate (4..7), wheel speeds (7..10), gimbal angles (10..14).
pub type StateVector = SVector<f64, STATE_LEN>;

/// True state of the platform.
#[derive(Debug, Clone, PartialEq)]
pub struct PlatformState {
    /// Attitude, level frame L to body frame B (see [`crate::attitude`]).
    pub q: Attitude,
    /// Angular velocity of the body relative to L, body axes, rad/s.
    pub rate_b: Vector3<f64>,
    /// Speed of each reaction wheel relative to the platform, about body X, Y, Z, rad/s.
    pub wheel_speed: Vector3<f64>,
    /// CMG gimbal angles, rad (see [`super::CmgPyramid`]).
    pub gimbal: Vector4<f64>,
}

impl Default for PlatformState {
    /// Level, at rest, wheels stopped, gimbals at zero (zero cluster momentum).
    fn default() -> Self {
        Self {
            q: Attitude::identity(),
            rate_b: Vector3::zeros(),
            wheel_speed: Vector3::zeros(),
            gimbal: Vector4::zeros(),
        }
    }
}

impl PlatformState {
    pub fn to_vector(&self) -> StateVector {
        let mut y = StateVector::zeros();
        y.fixed_rows_mut::<4>(0).copy_from(&self.q.coords);
        y.fixed_rows_mut::<3>(4).copy_from(&self.rate_b);
        y.fixed_rows_mut::<3>(7).copy_from(&self.wheel_speed);
        y.fixed_rows_mut::<4>(10).copy_from(&self.gimbal);
        y
    }

    /// Inverse of [`PlatformState::to_vector`]; renormalises the quaternion, which RK4 lets drift
    /// off the unit sphere by O(h⁵) per step.
    pub fn from_vector(y: &StateVector) -> Self {
        Self {
            q: UnitQuaternion::new_normalize(Quaternion::from(y.fixed_rows::<4>(0).into_owned())),
            rate_b: y.fixed_rows::<3>(4).into_owned(),
            wheel_speed: y.fixed_rows::<3>(7).into_owned(),
            gimbal: y.fixed_rows::<4>(10).into_owned(),
        }
    }

    pub fn is_finite(&self) -> bool {
        self.to_vector().iter().all(|x| x.is_finite())
    }
}

/// What the flight computer asks of the actuators.
#[derive(Debug, Clone, PartialEq)]
pub struct ActuatorCommand {
    /// Motor torque on each reaction wheel (body X, Y, Z), Nm. Positive accelerates the wheel in
    /// the positive sense; the platform feels the opposite.
    pub wheel_torque_nm: Vector3<f64>,
    /// Commanded gimbal rate of each CMG, rad/s.
    pub gimbal_rate_rad_s: Vector4<f64>,
}

impl Default for ActuatorCommand {
    /// Motors off, gimbals held.
    fn default() -> Self {
        Self {
            wheel_torque_nm: Vector3::zeros(),
            gimbal_rate_rad_s: Vector4::zeros(),
        }
    }
}

impl ActuatorCommand {
    pub fn is_finite(&self) -> bool {
        self.wheel_torque_nm
            .iter()
            .chain(self.gimbal_rate_rad_s.iter())
            .all(|x| x.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_heading_pitch_roll;

    #[test]
    fn state_round_trips_through_the_vector() {
        let s = PlatformState {
            q: from_heading_pitch_roll(0.3, -0.2, 0.1),
            rate_b: Vector3::new(1.0, 2.0, 3.0),
            wheel_speed: Vector3::new(4.0, 5.0, 6.0),
            gimbal: Vector4::new(7.0, 8.0, 9.0, 10.0),
        };
        let back = PlatformState::from_vector(&s.to_vector());
        assert!((back.q.coords - s.q.coords).norm() < 1e-15);
        assert_eq!(
            (back.rate_b, back.wheel_speed, back.gimbal),
            (s.rate_b, s.wheel_speed, s.gimbal)
        );
    }
}
