//! TRIAD initialisation: the attitude (level frame L to body frame B) from two vector pairs
//! measured in body axes and known in the level frame, e.g. the inclinometer's down vector and
//! the magnetometer's field; inputs need not be unit vectors.

use super::MekfError;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use testbed_model::attitude::Attitude;

/// Smallest `|G × M| / (|G| |M|)` TRIAD accepts (vectors at least 0.57° apart).
const TRIAD_MIN_SINE: f64 = 1e-2;

/// TRIAD attitude (L→B) from two vector pairs, the first (`primary`) matched exactly:
/// `A = [b₁ b₂ b₃][r₁ r₂ r₃]ᵀ` with `x₁ = x̂_p`, `x₂ = (x_p × x_s)/|x_p × x_s|`, `x₃ = x₁ × x₂`.
/// Inputs need not be unit. Refused if any is zero or non-finite, or a pair is closer than 0.57°
/// to parallel.
pub fn triad(
    primary_b: &Vector3<f64>,
    secondary_b: &Vector3<f64>,
    primary_l: &Vector3<f64>,
    secondary_l: &Vector3<f64>,
) -> Result<Attitude, MekfError> {
    fn frame(p: &Vector3<f64>, s: &Vector3<f64>) -> Result<Matrix3<f64>, MekfError> {
        if !(p.iter().chain(s.iter()).all(|x| x.is_finite())) {
            return Err(MekfError::NonFinite {
                what: "TRIAD vector",
            });
        }
        let (np, ns) = (p.norm(), s.norm());
        if np <= 0.0 || ns <= 0.0 {
            return Err(MekfError::Degenerate("zero vector"));
        }
        let c = p.cross(s);
        if c.norm() < TRIAD_MIN_SINE * np * ns {
            return Err(MekfError::Degenerate("vectors (nearly) parallel"));
        }
        let t1 = p / np;
        let t2 = c.normalize();
        let t3 = t1.cross(&t2);
        Ok(Matrix3::from_columns(&[t1, t2, t3]))
    }
    let mb = frame(primary_b, secondary_b)?;
    let ml = frame(primary_l, secondary_l)?;
    let a = mb * ml.transpose();
    let mut q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(a));
    q.renormalize();
    Ok(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mekf::Mekf;
    use crate::mekf::truth::{Truth, config, model, triad_start};
    use testbed_model::attitude;
    use testbed_model::config::DEG;

    // (g) ------------------------------------------------------------------------------------

    /// TRIAD recovers a known attitude exactly from exact vectors (to 1e-12 rad) and, from
    /// noisy ones, to the accuracy the sensors allow: the down vector (primary, matched exactly)
    /// within 5 inclinometer σ, heading (rotation about the down vector) within
    /// 5 × (largest magnetometer σ / horizontal field) ≈ 0.8°. Parallel vectors are refused.
    #[test]
    fn triad_recovers_known_attitude() {
        let cfg = config();
        let field_l = Vector3::from(cfg.field_l_t);
        let g_l = attitude::gravity_l();
        for (hdg, pitch, roll) in [(123.0, 4.0, -7.0), (-45.0, -20.0, 15.0), (0.0, 0.0, 0.0)] {
            let q = attitude::from_heading_pitch_roll(hdg * DEG, pitch * DEG, roll * DEG);
            let est = triad(&(q * g_l), &(q * field_l), &g_l, &field_l).expect("triad");
            assert!(
                attitude::attitude_error(&q, &est).norm() < 1e-12,
                "{hdg} {pitch} {roll}"
            );
            let f = Mekf::initialise_from_vectors(cfg.clone(), 7, &(q * g_l), &(q * field_l))
                .expect("init");
            assert!(attitude::attitude_error(&q, &f.attitude()).norm() < 1e-12);
            assert_eq!(f.time_ns(), 7);
        }
        let q = attitude::from_heading_pitch_roll(2.0, 0.1, 0.05);
        let mut truth = Truth::new(44, q);
        let m = model();
        let horizontal = Vector3::new(field_l.x, field_l.y, 0.0).norm();
        let heading_sigma = m.magnetometer.noise_t().max() / horizontal;
        for _ in 0..20 {
            let f = triad_start(&mut truth, cfg.clone());
            let e = attitude::attitude_error(&q, &f.attitude());
            let [st, _] = m.inclinometer.noise_rad();
            let down_b = q * g_l;
            let tilt_error = (f.attitude() * g_l).angle(&down_b);
            assert!(tilt_error < 5.0 * st, "{tilt_error:e}");
            assert!(
                e.dot(&down_b).abs() < 5.0 * heading_sigma,
                "{e:?} vs {heading_sigma}"
            );
        }
        assert!(matches!(
            triad(&g_l, &(g_l * 2.0), &g_l, &field_l),
            Err(MekfError::Degenerate(_))
        ));
        assert!(matches!(
            triad(&Vector3::zeros(), &field_l, &g_l, &field_l),
            Err(MekfError::Degenerate(_))
        ));
    }
}
