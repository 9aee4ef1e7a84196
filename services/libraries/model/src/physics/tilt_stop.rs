//! Mechanical tilt stop of the air bearing: ±`platform.tilt_limit_deg` for the elevation of body X
//! (θ) and of body Y (φ) against the level plane, the angles of [`attitude::tilt_angles`].
//!
//! Model: a rigid, frictionless, perfectly inelastic contact. When a step ends with an angle past
//! the stop, the attitude is rotated back onto the stop and an impulsive torque removes the rate
//! component driving further into it, leaving the rest of the motion alone:
//!
//! * θ' = w · û with `û = (e_X × G_B)/cos θ` (likewise φ with e_Y), so the stop constrains the
//!   rate along û, a horizontal axis: the contact impulse has no vertical component and the
//!   momentum about the vertical survives the impact.
//! * The impulse `−λ û` acts on the platform structure: `Δw = −(û·w / ûᵀKû) K û`. A sliding
//!   wheel's bearing carries no impulsive torque about its spin axis, so a sliding wheel keeps its
//!   absolute speed (`n_i + w_i`) and its spin inertia is not in K; a stuck wheel is taken to
//!   follow the platform (its static friction is assumed to hold through the impact, which at
//!   worst misplaces `J Δw_i`, ~1e-4 Nms, for the fraction of a second friction would need to
//!   re-stick it). So `K = (I − J·P_sliding)⁻¹`. Treating stuck wheels so also keeps resting
//!   contact from kicking them into micro-slips every step.
//! * Resting contact (a torque pressing into the stop) is the same impact repeated every
//!   integration step, which keeps the platform on the stop with no rate into it.

use super::state::PlatformState;
use crate::attitude::{self, Attitude};
use nalgebra::{Matrix3, Vector3};

/// Which tilt angle reached the stop: `X` is θ, the elevation of body X (reached by rotating
/// about body Y); `Y` is φ, the elevation of body Y (reached by rotating about body X).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TiltAxis {
    X,
    Y,
}

impl TiltAxis {
    /// Index into [`attitude::tilt_angles`] (X = 0).
    pub fn index(self) -> usize {
        self as usize
    }
}

/// The platform struck its tilt stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TiltStopEvent {
    /// Plant time at the end of the integration step that crossed the stop, s.
    pub time_s: f64,
    pub axis: TiltAxis,
    /// Tilt angle found at that instant, before the contact put it back on the stop, rad.
    pub angle_rad: f64,
}

/// Unit vector û (body axes) along which a rate changes the tilt angle of `axis` at unit rate;
/// `None` at a 90° tilt, where the angle is not differentiable.
fn tilt_rate_axis(q: &Attitude, axis: TiltAxis) -> Option<Vector3<f64>> {
    let e = Vector3::ith(axis.index(), 1.0);
    let u = e.cross(&attitude::gravity_b(q));
    let norm = u.norm();
    (norm > 1e-12).then(|| u / norm)
}

/// Enforce the stop on `state` (see the module documentation). `impact_inverse` is
/// `(I − J·P_sliding)⁻¹`, 1/(kg m²); `sliding[i]` says wheel i slides (keeps its absolute speed).
/// Returns, per axis (X, Y), the angle (rad) found past the stop, if any.
pub fn enforce_tilt_stop(
    limit_rad: f64,
    impact_inverse: &Matrix3<f64>,
    sliding: &Vector3<bool>,
    state: &mut PlatformState,
) -> [Option<f64>; 2] {
    let mut engaged = [None, None];
    // In a corner each axis's correction disturbs the other slightly; a second pass settles it.
    for _ in 0..2 {
        for axis in [TiltAxis::X, TiltAxis::Y] {
            let angle = attitude::tilt_angles(&state.q)[axis.index()];
            if angle.abs() <= limit_rad {
                continue;
            }
            engaged[axis.index()].get_or_insert(angle);
            let side = angle.signum();
            let Some(u) = tilt_rate_axis(&state.q, axis) else {
                continue;
            };
            // A rotation about û (fixed in the plane-normal of e and G) changes the angle by
            // exactly its own amount, so one rotation lands on the stop.
            state.q = attitude::propagate(&state.q, &u, -(angle - side * limit_rad));
            let Some(u) = tilt_rate_axis(&state.q, axis) else {
                continue;
            };
            let into_stop = u.dot(&state.rate_b);
            if into_stop * side > 0.0 {
                let ku = impact_inverse * u;
                let dw = -ku * (into_stop / u.dot(&ku));
                state.rate_b += dw;
                for i in (0..3).filter(|i| sliding[*i]) {
                    state.wheel_speed[i] -= dw[i];
                }
            }
        }
    }
    engaged
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_heading_pitch_roll;
    use nalgebra::Vector4;

    fn inertia() -> Matrix3<f64> {
        Matrix3::new(45.2, 0.3, -0.2, 0.3, 46.1, 0.4, -0.2, 0.4, 62.7)
    }

    #[test]
    fn impact_lands_on_the_stop_removes_inward_rate_and_keeps_vertical_momentum() {
        let j = 1.59e-3;
        let platform = inertia() - Matrix3::identity() * j;
        let k = platform.try_inverse().unwrap_or_else(Matrix3::zeros);
        let limit = 30f64.to_radians();
        // Pitched 31° (θ past +30°), rolling into it with some spin about Z.
        let mut s = PlatformState {
            q: from_heading_pitch_roll(0.4, 31f64.to_radians(), 5f64.to_radians()),
            rate_b: Vector3::new(0.01, 0.05, 0.2),
            wheel_speed: Vector3::new(10.0, -20.0, 30.0),
            gimbal: Vector4::zeros(),
        };
        let u0 = tilt_rate_axis(&s.q, TiltAxis::X).unwrap_or_else(Vector3::zeros);
        assert!(
            u0.dot(&s.rate_b) > 0.0,
            "test must start moving into the stop"
        );
        let momentum = |s: &PlatformState| inertia() * s.rate_b + s.wheel_speed * j;
        let momentum_before = momentum(&s);
        let wheel_absolute_before = s.wheel_speed + s.rate_b;
        let phi_before = attitude::tilt_angles(&s.q)[1];
        let energy = |s: &PlatformState| {
            0.5 * s.rate_b.dot(&(platform * s.rate_b))
                + 0.5 * j * (s.wheel_speed + s.rate_b).norm_squared()
        };
        let e_before = energy(&s);

        let engaged = enforce_tilt_stop(limit, &k, &Vector3::repeat(true), &mut s);

        let theta_found = engaged[0].unwrap_or(f64::NAN);
        assert!(
            (theta_found - 31f64.to_radians()).abs() < 1e-9,
            "{theta_found}"
        );
        assert_eq!(engaged[1], None);
        let [theta, phi] = attitude::tilt_angles(&s.q);
        assert!((theta - limit).abs() < 1e-12, "{theta}");
        // The correction rotates about û ⟂ e_X, which moves φ only to second order here.
        assert!((phi - phi_before).abs() < 2e-2);
        let u = tilt_rate_axis(&s.q, TiltAxis::X).unwrap_or_else(Vector3::zeros);
        assert!(u.dot(&s.rate_b).abs() < 1e-15);
        // The contact impulse is horizontal: momentum about the vertical is untouched.
        let down = attitude::gravity_b(&s.q);
        let impulse = momentum(&s) - momentum_before;
        assert!(impulse.norm() > 1e-3);
        assert!(
            impulse.dot(&down).abs() < 1e-14 * impulse.norm(),
            "{impulse}"
        );
        assert!(((s.wheel_speed + s.rate_b) - wheel_absolute_before).norm() < 1e-12);
        assert!(energy(&s) < e_before, "an inelastic impact dissipates");
    }

    #[test]
    fn leaving_the_stop_keeps_the_rate() {
        let k = inertia().try_inverse().unwrap_or_else(Matrix3::zeros);
        // Rolled by −30.5° about X: G_B = (0, sin 30.5°, −cos 30.5°), φ = +30.5°, and
        // φ' = w·û = −w_x (û = (G_z, 0, −G_x)/cos φ = −e_X), so a positive w_x leaves the stop.
        let mut s = PlatformState {
            q: from_heading_pitch_roll(0.0, 0.0, -30.5f64.to_radians()),
            rate_b: Vector3::new(0.02, 0.0, 0.01),
            ..Default::default()
        };
        assert!((attitude::tilt_angles(&s.q)[1] - 30.5f64.to_radians()).abs() < 1e-12);
        let rate = s.rate_b;
        let engaged = enforce_tilt_stop(30f64.to_radians(), &k, &Vector3::repeat(false), &mut s);
        assert!(engaged[1].is_some() && engaged[0].is_none());
        assert_eq!(s.rate_b, rate);
        assert!((attitude::tilt_angles(&s.q)[1] - 30f64.to_radians()).abs() < 1e-12);

        // The same state moving in: w_x < 0 is removed entirely (û = −e_X, K diagonal-dominant
        // but not diagonal, so other components move slightly too).
        s.rate_b = Vector3::new(-0.02, 0.0, 0.01);
        s.q = from_heading_pitch_roll(0.0, 0.0, -30.5f64.to_radians());
        enforce_tilt_stop(30f64.to_radians(), &k, &Vector3::repeat(false), &mut s);
        assert!(s.rate_b.x.abs() < 1e-15, "{}", s.rate_b);
    }
}
