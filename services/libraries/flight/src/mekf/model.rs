//! The filter's model matrices, pure functions of their arguments: the error-state transition
//! matrix and discrete process noise of the gyro propagation, the inclinometer's measurement
//! covariance, the measurement sensitivity (with measurement lag) and the tangent basis of the
//! gravity block. Error state `[δθ (rad, body axes), δb (rad/s, body axes)]`; vectors in body
//! axes unless named `_l` (level frame); times in seconds.

use nalgebra::{Matrix3, Matrix3x2, Matrix3x6, Matrix6, UnitQuaternion, Vector3};
use testbed_model::attitude::{self, Attitude};

/// Smallest `|G_z|` of an inclinometer reading (|tilt| up to about 89.9°). `R_G` grows as
/// `1/|G_z|`; readings beyond this are treated as invalid.
pub(super) const MIN_GRAVITY_Z: f64 = 1e-3;

/// Transition matrix `Φ(Δt)` of the error state for `δθ' = −[ŵ×]δθ − δb`, `δb' = 0`, with the
/// body rate estimate `w_hat` (rad/s) constant over `dt_s` (closed form, Markley & Crassidis
/// 2014 eq. 6.83 in this sign convention):
///
/// `Φ11 = exp(−[ŵ×]Δt) = I − [ŵ×] sin(wΔt)/w + [ŵ×]² (1 − cos wΔt)/w²`,
/// `Φ12 = −∫₀^Δt exp(−[ŵ×]s) ds = [ŵ×](1 − cos wΔt)/w² − I Δt − [ŵ×]²(wΔt − sin wΔt)/w³`,
/// `Φ21 = 0`, `Φ22 = I`; Taylor series below `wΔt = 1e-2` (truncation < 1e-13 relative).
pub fn transition_matrix(w_hat: &Vector3<f64>, dt_s: f64) -> Matrix6<f64> {
    let w = w_hat.norm();
    let s = w * dt_s;
    let s2 = s * s;
    // a = sin(s)/w, b = (1 − cos s)/w², c = (s − sin s)/w³.
    let (a, b, c) = if s < 1e-2 {
        (
            dt_s * (1.0 - s2 / 6.0 + s2 * s2 / 120.0),
            dt_s * dt_s * (0.5 - s2 / 24.0 + s2 * s2 / 720.0),
            dt_s.powi(3) * (1.0 / 6.0 - s2 / 120.0 + s2 * s2 / 5040.0),
        )
    } else {
        (
            s.sin() / w,
            (1.0 - s.cos()) / (w * w),
            (s - s.sin()) / (w * w * w),
        )
    };
    let k = w_hat.cross_matrix();
    let k2 = k * k;
    let phi11 = Matrix3::identity() - k * a + k2 * b;
    let phi12 = k * b - Matrix3::identity() * dt_s - k2 * c;
    let mut phi = Matrix6::identity();
    phi.fixed_view_mut::<3, 3>(0, 0).copy_from(&phi11);
    phi.fixed_view_mut::<3, 3>(0, 3).copy_from(&phi12);
    phi
}

/// Discrete process noise for a step `dt_s` with per-axis rate noise density `σv` (rad/s^½) and
/// bias random walk `σu` (rad/s^(3/2)): `Q11 = diag(σv² Δt + σu² Δt³/3)`,
/// `Q12 = Q21 = −diag(σu² Δt²/2)`, `Q22 = diag(σu² Δt)` (digest; the `−` because `δθ' = … − δb`).
pub fn process_noise(sigma_v: &Vector3<f64>, sigma_u: &Vector3<f64>, dt_s: f64) -> Matrix6<f64> {
    let mut q = Matrix6::zeros();
    for i in 0..3 {
        let v2 = sigma_v[i] * sigma_v[i];
        let u2 = sigma_u[i] * sigma_u[i];
        q[(i, i)] = v2 * dt_s + u2 * dt_s.powi(3) / 3.0;
        q[(i, i + 3)] = -u2 * dt_s * dt_s / 2.0;
        q[(i + 3, i)] = q[(i, i + 3)];
        q[(i + 3, i + 3)] = u2 * dt_s;
    }
    q
}

/// Covariance `R_G` (3×3, rank 2) of `G_meas = [sin θm, sin φm, −sqrt(1 − sin²θm − sin²φm)]` for
/// independent angle noises `sigma_theta`, `sigma_phi` (rad), to first order, at the angles
/// `theta`, `phi` (rad). `None` outside the model's domain (`|G_z|` below 1e-3).
///
/// `R_G = J diag(σθ², σφ²) Jᵀ` with `J = ∂G/∂(θ, φ) = [[cos θ, 0], [0, cos φ], [u, v]]`,
/// `u = sin θ cos θ / sqrt(1 − Gx² − Gy²)`, `v = sin φ cos φ / sqrt(1 − Gx² − Gy²)`, which is the
/// paper's matrix. Sign check: `G_z = −sqrt(f)`, `f = 1 − sin²θ − sin²φ`, so
/// `∂G_z/∂θ = −f'_θ / (2 sqrt f) = +sin θ cos θ / sqrt f = +u`: the z-row terms are `+u σθ² cos θ`
/// and `+v σφ² cos φ`, as the digest writes them, consistent with the measurement model (and
/// checked against a numerical derivative in the tests).
pub fn inclinometer_covariance(
    theta: f64,
    phi: f64,
    sigma_theta: f64,
    sigma_phi: f64,
) -> Option<Matrix3<f64>> {
    let g = attitude::gravity_from_tilt(theta, phi)?;
    let root = g.z.abs(); // sqrt(1 − Gx² − Gy²)
    if root < MIN_GRAVITY_Z {
        return None;
    }
    let (ct, cp) = (theta.cos(), phi.cos());
    let u = theta.sin() * ct / root;
    let v = phi.sin() * cp / root;
    let j = Matrix3x2::new(ct, 0.0, 0.0, cp, u, v);
    let sigma = nalgebra::Matrix2::new(sigma_theta * sigma_theta, 0.0, 0.0, sigma_phi * sigma_phi);
    Some(j * sigma * j.transpose())
}

/// Predicted body vector of reference `r_l` (level frame) at a time `lag_s` seconds before the
/// state's time, and its sensitivity to the error state `[δθ, δb]` at the state's time.
///
/// The attitude is carried back with the rate estimate: `A_m = Δ A(q)`, `Δ = exp([φ×])`,
/// `φ = ŵ lag`, and `a = A_m r_l`. With the true rate `ŵ − δb`,
/// `exp([(φ − lag δb)×]) ≈ exp(−[lag J_l(φ) δb ×]) Δ` (`J_l` the left Jacobian of SO(3)), so
/// `A_true(t − lag) ≈ (I − [(Δ δθ + lag J_l δb)×]) A_m` and
/// `H = [a×] [Δ, lag·J_l(φ)]` (3×6). For `lag_s = 0`, `H = [[A r×], 0]`, the digest's
/// sensitivity, from `A_true r = A r + [A r×] δθ` ([`attitude`]'s error convention).
pub fn measurement_jacobian(
    q: &Attitude,
    r_l: &Vector3<f64>,
    w_hat: &Vector3<f64>,
    lag_s: f64,
) -> (Vector3<f64>, Matrix3x6<f64>) {
    let phi = w_hat * lag_s;
    let back = UnitQuaternion::from_scaled_axis(phi); // Δ = exp([φ×])
    let a = back * (q * r_l);
    let sa = a.cross_matrix();
    let mut h = Matrix3x6::zeros();
    h.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(sa * back.to_rotation_matrix().into_inner()));
    h.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(sa * left_jacobian(&phi) * lag_s));
    (a, h)
}

/// Left Jacobian of SO(3): `exp([(φ + ε)×]) ≈ exp([(J_l(φ) ε)×]) exp([φ×])`,
/// `J_l = I + (1 − cos θ)/θ² [φ×] + (θ − sin θ)/θ³ [φ×]²`, θ = |φ| (series below 1e-2).
fn left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let th = phi.norm();
    let t2 = th * th;
    let (b, c) = if th < 1e-2 {
        (
            0.5 - t2 / 24.0 + t2 * t2 / 720.0,
            1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0,
        )
    } else {
        ((1.0 - th.cos()) / t2, (th - th.sin()) / (t2 * th))
    };
    let k = phi.cross_matrix();
    Matrix3::identity() + k * b + k * k * c
}

/// Orthonormal basis `[t₁ t₂]` of the plane orthogonal to `a` (body axes): `t₁` is body X
/// projected onto the plane (body Y if `a` is within 37° of X), `t₂ = t₁ × â`. For `a` = down
/// (level platform) this is `[X, Y]`.
pub fn tangent_basis(a: &Vector3<f64>) -> Matrix3x2<f64> {
    let n = a.try_normalize(0.0).unwrap_or_else(|| -Vector3::z());
    let e = if n.x.abs() < 0.8 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let t1 = (e - n * e.dot(&n)).normalize();
    let t2 = t1.cross(&n);
    Matrix3x2::from_columns(&[t1, t2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector6;

    // (f) ------------------------------------------------------------------------------------

    /// `H` against central differences of the predicted vector with respect to `δθ` (through
    /// [`attitude::apply_error`]) and `δb`, with and without measurement lag. Step 1e-6 rad
    /// (rad/s): truncation ~1e-12, rounding ~1e-10, so 1e-8 absolute on unit-norm vectors
    /// catches any sign or transposition error (those are O(1)).
    #[test]
    fn jacobian_matches_numerical_derivative() {
        let q = attitude::from_heading_pitch_roll(0.7, -0.15, 0.3);
        let r = Vector3::new(0.3, -0.5, 0.8).normalize();
        let w_meas = Vector3::new(0.02, -0.01, 0.05);
        let b = Vector3::new(0.001, 0.002, -0.001);
        for lag in [0.0, 0.08] {
            let (a, h) = measurement_jacobian(&q, &r, &(w_meas - b), lag);
            let predict = |dx: &Vector6<f64>| {
                let q_i = attitude::apply_error(&q, &dx.fixed_rows::<3>(0).into_owned());
                let w_hat = w_meas - (b + dx.fixed_rows::<3>(3));
                measurement_jacobian(&q_i, &r, &w_hat, lag).0
            };
            assert!((predict(&Vector6::zeros()) - a).norm() < 1e-15);
            let eps = 1e-6;
            for j in 0..6 {
                let mut d = Vector6::zeros();
                d[j] = eps;
                let numeric = (predict(&d) - predict(&(-d))) / (2.0 * eps);
                let diff = (numeric - h.column(j)).norm();
                assert!(
                    diff < 1e-8,
                    "lag {lag}, column {j}: {numeric:?} vs {:?}",
                    h.column(j)
                );
            }
            if lag == 0.0 {
                // The digest's form: H = [[A r×], 0].
                let digest = (q * r).cross_matrix();
                assert!((h.fixed_view::<3, 3>(0, 0) - digest).abs().max() < 1e-15);
                assert!(h.fixed_view::<3, 3>(0, 3).abs().max() == 0.0);
            }
        }
    }

    /// The closed-form `Φ` equals the matrix exponential of `F Δt`, `F = [[−[ŵ×], −I], [0, 0]]`
    /// (Taylor series to convergence), on both branches of the closed form; and `Φ11` is the
    /// attitude propagation of [`attitude::propagate`] itself (δθ carried by the rotation).
    #[test]
    fn transition_matrix_is_exponential_of_error_dynamics() {
        for (w, dt) in [
            (Vector3::new(0.3, -0.2, 0.5), 0.1),
            (Vector3::new(1e-4, 2e-4, -1e-4), 0.1),
            (Vector3::zeros(), 0.4),
        ] {
            let mut f = Matrix6::zeros();
            f.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&(-w.cross_matrix()));
            f.fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&(-Matrix3::identity()));
            let fdt = f * dt;
            let mut term = Matrix6::identity();
            let mut exp = Matrix6::identity();
            for k in 1..30 {
                term = term * fdt / k as f64;
                exp += term;
            }
            let phi = transition_matrix(&w, dt);
            assert!(
                (phi - exp).abs().max() < 1e-14,
                "w = {w:?}: {}",
                (phi - exp).abs().max()
            );
            let rot = UnitQuaternion::from_scaled_axis(-w * dt)
                .to_rotation_matrix()
                .into_inner();
            assert!((phi.fixed_view::<3, 3>(0, 0) - rot).abs().max() < 1e-14);
        }
    }

    /// `R_G` equals `J diag(σθ², σφ²) Jᵀ` with `J` the numerical derivative of
    /// [`attitude::gravity_from_tilt`]: this confirms the `+u`, `+v` signs of the z row (see
    /// [`inclinometer_covariance`]); flipping them fails by O(1) relative. Also rank 2, with the
    /// null direction along `G`.
    #[test]
    fn inclinometer_covariance_matches_first_order_model() {
        let (st, sp) = (1.7e-5, 1.4e-5);
        for (theta, phi) in [(0.2, -0.3), (-0.35, 0.1), (0.0, 0.0)] {
            let r = inclinometer_covariance(theta, phi, st, sp).expect("in domain");
            let g = |a: f64, b: f64| attitude::gravity_from_tilt(a, b).expect("in domain");
            let h = 1e-6;
            let jt = (g(theta + h, phi) - g(theta - h, phi)) / (2.0 * h);
            let jp = (g(theta, phi + h) - g(theta, phi - h)) / (2.0 * h);
            let numeric = jt * jt.transpose() * st * st + jp * jp.transpose() * sp * sp;
            let scale = st * st;
            assert!((r - numeric).abs().max() < 1e-7 * scale, "{r} vs {numeric}");
            assert!((r * g(theta, phi)).norm() < 1e-12 * scale);
            if theta != 0.0 {
                assert!(
                    jt.z * theta.signum() > 0.0,
                    "dGz/dθ has the sign of sin θ cos θ"
                );
            }
        }
        assert!(inclinometer_covariance(1.2, 1.2, st, sp).is_none());
    }
}
