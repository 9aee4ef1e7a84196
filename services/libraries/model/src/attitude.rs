//! Attitude conventions, used by every model, the estimator and the controller.
//!
//! * Level frame L: x north, y west, z up. Body frame B fixed to the platform.
//! * The attitude is a nalgebra `UnitQuaternion` `q` that rotates L components into B
//!   components: `v_B = q * v_L`, so the attitude matrix of the paper is
//!   `A(q) = q.to_rotation_matrix()`. Stored scalar-last `[x, y, z, w]` (nalgebra's `coords`
//!   order), as `ipc-types` documents.
//! * Kinematics: `A' = −[ω×] A`, with ω the body rate relative to L in body axes; for a constant
//!   rate over Δt, `q(t+Δt) = exp(−ω Δt) ⊗ q(t)` (see [`propagate`]).
//! * Small attitude errors: `A_true = (I − [δθ×]) A_est`, the multiplicative error of the MEKF
//!   (Lefferts, Markley, Shuster), so `A_true r = A_est r + [A_est r ×] δθ` and the measurement
//!   sensitivity is `H = [A r ×]` as in the digest. [`apply_error`] and [`attitude_error`] are the
//!   two directions of that definition.

use nalgebra::{UnitQuaternion, Vector3};

/// Attitude quaternion, level frame to body frame (see the module documentation).
pub type Attitude = UnitQuaternion<f64>;

/// Unit down vector (gravity direction) in the level frame, `G_L`.
pub fn gravity_l() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, -1.0)
}

/// Propagate the attitude over `dt_s` seconds at a constant body rate `rate_b` (rad/s).
pub fn propagate(q: &Attitude, rate_b: &Vector3<f64>, dt_s: f64) -> Attitude {
    UnitQuaternion::from_scaled_axis(-rate_b * dt_s) * q
}

/// Correct an estimate by a small-angle error `dtheta` (rad, body axes):
/// returns `q` with `A(q) = exp(−[δθ×]) A(q_est)`.
pub fn apply_error(q_est: &Attitude, dtheta: &Vector3<f64>) -> Attitude {
    UnitQuaternion::from_scaled_axis(-dtheta) * q_est
}

/// The error angle `δθ` (rad, body axes) that takes `q_est` to `q_true`
/// (inverse of [`apply_error`]).
pub fn attitude_error(q_true: &Attitude, q_est: &Attitude) -> Vector3<f64> {
    -(q_true * q_est.inverse()).scaled_axis()
}

/// Body components of the unit down vector, `G_B = A(q) G_L`.
pub fn gravity_b(q: &Attitude) -> Vector3<f64> {
    q * gravity_l()
}

/// Tilt angles θ (of body X) and φ (of body Y) against the level plane, rad, as the inclinometer
/// defines them: `G_B = [sin θ, sin φ, −sqrt(1 − sin²θ − sin²φ)]`.
pub fn tilt_angles(q: &Attitude) -> [f64; 2] {
    let g = gravity_b(q);
    [g.x.clamp(-1.0, 1.0).asin(), g.y.clamp(-1.0, 1.0).asin()]
}

/// The attitude `lag_s` before `q` at body rate `w` (rad/s, body axes, relative to the level
/// frame), held over the lag: `exp(w τ) q`, as `q(t + dt) = exp(−w dt) q(t)`. What a sensor
/// that lags by `τ` reads (a first-order response at motions slow against `1/τ`, or a late
/// stamp); `q` itself when `lag_s` is zero.
pub fn lagged(q: &Attitude, w: &Vector3<f64>, lag_s: f64) -> Attitude {
    if lag_s == 0.0 {
        return *q;
    }
    Attitude::from_scaled_axis(w * lag_s) * q
}

/// The unit down vector in body axes from inclinometer angles (rad); `None` if
/// `sin²θ + sin²φ > 1` (no such attitude).
pub fn gravity_from_tilt(theta: f64, phi: f64) -> Option<Vector3<f64>> {
    let (sx, sy) = (theta.sin(), phi.sin());
    let zz = 1.0 - sx * sx - sy * sy;
    (zz >= 0.0).then(|| Vector3::new(sx, sy, -zz.sqrt()))
}

/// Heading: rotation angle about level z (up) of the body X axis, rad in (−π, π], measured from
/// north towards west.
pub fn heading(q: &Attitude) -> f64 {
    let x_l = q.inverse() * Vector3::x();
    x_l.y.atan2(x_l.x)
}

/// Attitude from heading ψ about level z, then tilts: the body obtained by rotating L about z by
/// ψ, then about the new y by `pitch`, then about the new x by `roll` (all rad). Convenient for
/// initial conditions; returns the L→B quaternion.
pub fn from_heading_pitch_roll(heading: f64, pitch: f64, roll: f64) -> Attitude {
    // Active rotation taking L axes onto B axes, expressed in L; the L→B component map is its
    // inverse.
    let body_in_level = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), heading)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), pitch)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), roll);
    body_in_level.inverse()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// The lagged attitude is the one the motion reaches `τ` later: turned on by `exp(−w τ)`
    /// it is `q` again, and with no lag it is `q` exactly.
    #[test]
    fn a_lagged_attitude_is_the_attitude_a_lag_earlier() {
        let q = from_heading_pitch_roll(1.1, 0.2, -0.15);
        let w = Vector3::new(0.02, -0.03, 0.05);
        let earlier = lagged(&q, &w, 0.5);
        assert!(earlier.angle_to(&q) > 0.02);
        assert!((Attitude::from_scaled_axis(-w * 0.5) * earlier).angle_to(&q) < 1e-15);
        assert_eq!(lagged(&q, &w, 0.0), q);
    }

    #[test]
    fn quarter_turn_about_up_maps_north_to_body_minus_y() {
        // Body turned 90° about up (towards west): north now lies along body −Y.
        let q = from_heading_pitch_roll(FRAC_PI_2, 0.0, 0.0);
        let north_b = q * Vector3::x();
        assert!((north_b - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
        assert!((heading(&q) - FRAC_PI_2).abs() < 1e-12);
    }

    /// `cross_matrix` (which replaced a hand-written skew matrix here) is bit for bit the matrix
    /// `[[0, −a_z, a_y], [a_z, 0, −a_x], [−a_y, a_x, 0]]`, and `cross_matrix(a) b = a × b`.
    #[test]
    fn cross_matrix_is_the_skew_matrix_bit_for_bit() {
        for a in [
            Vector3::new(0.01, -0.02, 0.03),
            Vector3::new(-1.5e-300, 2.0, f64::MAX),
            Vector3::new(0.0, -0.0, 1.0 / 3.0),
        ] {
            let by_hand = nalgebra::Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0);
            let m = a.cross_matrix();
            for (x, y) in m.iter().zip(by_hand.iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
        let (a, b) = (Vector3::new(0.3, -0.5, 0.8), Vector3::new(-0.1, 0.2, 0.7));
        assert!((a.cross_matrix() * b - a.cross(&b)).norm() < 1e-15);
    }

    #[test]
    fn propagation_follows_a_dot_equals_minus_cross_matrix_w_a() {
        let q = from_heading_pitch_roll(0.3, 0.1, -0.2);
        let w = Vector3::new(0.01, -0.02, 0.03);
        let dt = 1e-6;
        let a0 = q.to_rotation_matrix().into_inner();
        let a1 = propagate(&q, &w, dt).to_rotation_matrix().into_inner();
        let derivative = (a1 - a0) / dt;
        assert!((derivative + w.cross_matrix() * a0).abs().max() < 1e-6);
    }

    #[test]
    fn error_is_first_order_sensitivity_of_observed_vector() {
        let q_est = from_heading_pitch_roll(1.0, 0.2, 0.1);
        let dtheta = Vector3::new(1e-5, -2e-5, 3e-5);
        let q_true = apply_error(&q_est, &dtheta);
        let r = Vector3::new(0.3, -0.5, 0.8);
        let predicted = q_est * r + (q_est * r).cross_matrix() * dtheta;
        assert!((q_true * r - predicted).norm() < 1e-9);
        assert!((attitude_error(&q_true, &q_est) - dtheta).norm() < 1e-15);
    }

    #[test]
    fn tilt_angles_round_trip_through_gravity_vector() {
        let q = from_heading_pitch_roll(0.7, 0.05, -0.08);
        let [theta, phi] = tilt_angles(&q);
        let g = gravity_from_tilt(theta, phi).unwrap();
        assert!((g - gravity_b(&q)).norm() < 1e-12);
        // A positive right-handed rotation about y tips body X below the level plane, so the
        // down vector has a positive X component: θ > 0.
        assert!(theta > 0.0);
    }
}
