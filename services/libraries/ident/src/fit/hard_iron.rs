//! The magnetometer causes' starting values: for the hard iron a sphere fit of the field
//! readings against the lab field, for the soft iron an ellipsoid fit; each kept when it
//! explains the innovations better than the neutral value.

use super::Problem;
use crate::data::Aligned;
use crate::effects::{Cause, soft_iron_matrix};
use crate::error::IdentError;
use crate::stats::NormalEquations;
use nalgebra::{Matrix3, Vector3};
use testbed_model::ModelConfig;
use testbed_model::attitude;
use testbed_model::config::GAUSS;

/// Weight of both kinds of rows of the fits, tesla.
const SIGMA_T: f64 = 1e-7;

/// Most fixed-point passes of the ellipsoid fit: each shrinks the error of the terms the linear
/// rows leave out by about `|S| + |h| / |M_L|` (a quarter for 14 µT of hard iron), so 30 passes
/// reach rounding from any start the first pass gives; it stops earlier when a pass moves no
/// value by more than 1e-12 (relative to the field for `h`).
const ELLIPSOID_PASSES: usize = 30;

impl Problem<'_> {
    /// Starting values of a sensor cause absent from the base: its neutral values, for the hard
    /// iron the better of zero and a sphere fit of the field readings, for the soft iron the
    /// better of zero and an ellipsoid fit.
    pub(super) fn initial_sensor_values(&self, cause: Cause) -> Result<Vec<f64>, IdentError> {
        let neutral = cause.values(&self.base);
        if cause.present(&self.base) {
            return Ok(neutral);
        }
        let guess: Option<Vec<f64>> = match cause {
            Cause::MagneticDisturbance => {
                let mut cached = super::lock(&self.sphere);
                cached
                    .get_or_insert_with(|| sphere_fit(self.data, &self.base))
                    .map(|h| h.to_vec())
            }
            Cause::SoftIron => {
                let mut cached = super::lock(&self.ellipsoid);
                cached
                    .get_or_insert_with(|| ellipsoid_fit(self.data, &self.base))
                    .map(|(_, s)| s.to_vec())
            }
            _ => None,
        };
        let Some(guess) = guess else {
            return Ok(neutral);
        };
        let rss_of = |v: &[f64]| -> Result<f64, IdentError> {
            let mut c = self.base.clone();
            cause.apply(&mut c, v);
            Ok(self
                .fit_innovations(&*self.recon(&c)?)
                .iter()
                .map(|x| x * x)
                .sum())
        };
        Ok(if rss_of(&guess)? < rss_of(&neutral)? {
            guess
        } else {
            neutral
        })
    }
}

/// Field samples (tesla, body axes) paired with the down vector the inclinometer measured at
/// the same time stamp.
fn field_with_down(data: &Aligned) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    let mut out = Vec::with_capacity(data.field.len());
    let mut i = 0;
    for &(t, m) in &data.field {
        while i < data.tilt.len() && data.tilt[i].0 < t - 1e-6 {
            i += 1;
        }
        let Some(&(tt, tilt)) = data.tilt.get(i) else {
            break;
        };
        if (tt - t).abs() > 1e-6 {
            continue;
        }
        if let Some(g) = attitude::gravity_from_tilt(tilt[0], tilt[1]) {
            out.push((m, g));
        }
    }
    out
}

/// Hard-iron estimate (gauss, body axes) from the field readings alone: the readings minus the
/// hard iron have the lab field's magnitude and the lab field's component along the measured
/// down vector, `|m − h| = |M_L|`, `(m − h)·g = M_L·G_L`, linear in `(h, |h|²)` when `|h|²` is a
/// fourth unknown. `None` without paired tilt and field samples or without enough rotation.
pub fn sphere_fit(data: &Aligned, config: &ModelConfig) -> Option<[f64; 3]> {
    let field_l = config.platform.field_l_t();
    let r = field_l.norm();
    let vertical = field_l.dot(&attitude::gravity_l());
    let mut ne = NormalEquations::new(4);
    for (m, g) in field_with_down(data) {
        ne.add(
            &[g.x / SIGMA_T, g.y / SIGMA_T, g.z / SIGMA_T, 0.0],
            (m.dot(&g) - vertical) / SIGMA_T,
        );
        let k = 1.0 / (2.0 * r * SIGMA_T);
        ne.add(
            &[2.0 * m.x * k, 2.0 * m.y * k, 2.0 * m.z * k, -k],
            (m.norm_squared() - r * r) * k,
        );
    }
    if ne.rows() < 20 {
        return None;
    }
    let fit = ne.solve()?;
    let h = Vector3::new(fit.theta[0], fit.theta[1], fit.theta[2]) / GAUSS;
    h.iter().all(|x| x.is_finite()).then(|| [h.x, h.y, h.z])
}

/// Hard and soft iron (gauss; the six values of `soft_iron`) from the field readings alone, as
/// [`sphere_fit`] but with `b = (1 + S)⁻¹ (m − h)` for the field in body axes.
pub fn ellipsoid_fit(data: &Aligned, config: &ModelConfig) -> Option<([f64; 3], [f64; 6])> {
    let (h_t, s) = ellipsoid_fit_pairs(&field_with_down(data), &config.platform.field_l_t())?;
    let h = h_t / GAUSS;
    Some(([h.x, h.y, h.z], s))
}

/// The ellipsoid fit of field samples `m` (tesla) paired with down vectors `g` (body axes),
/// against the lab field `field_l` (tesla): `|b| = |M_L|` and `b·g = M_L·G_L` with
/// `b = (1 + S)⁻¹ (m − h)`, `S` symmetric. To first order in `S` both are linear in `h`, the six
/// values of `S` and `|h|²` (a tenth unknown):
/// `g·h + gᵀ S m = g·m − M_L·G_L` and `2 m·h + 2 mᵀ S m − |h|² = |m|² − |M_L|²`; the terms
/// left out are evaluated at the previous pass's estimate and moved to the right-hand side
/// ([`ELLIPSOID_PASSES`] passes, from zero). Returns `h` (tesla) and the six values; `None`
/// with fewer than 20 pairs or when the samples do not determine them (too little rotation).
pub fn ellipsoid_fit_pairs(
    pairs: &[(Vector3<f64>, Vector3<f64>)],
    field_l: &Vector3<f64>,
) -> Option<(Vector3<f64>, [f64; 6])> {
    if pairs.len() < 20 {
        return None;
    }
    let r = field_l.norm();
    let vertical = field_l.dot(&attitude::gravity_l());
    let k = 1.0 / (2.0 * r * SIGMA_T);
    let (mut h, mut s) = (Vector3::zeros(), [0.0; 6]);
    for _ in 0..ELLIPSOID_PASSES {
        let a = Matrix3::from(soft_iron_matrix(&s));
        let inv = (Matrix3::identity() + a).try_inverse()?;
        let mut ne = NormalEquations::new(10);
        for (m, g) in pairs {
            let b = inv * (m - h);
            // The exact left-hand sides at the current estimate minus their linear parts: what
            // the linear rows leave out.
            let rest_v = g.dot(&b) - (g.dot(m) - g.dot(&h) - g.dot(&(a * m)));
            let rest_m = b.norm_squared()
                - (m.norm_squared() - 2.0 * m.dot(&h) + h.norm_squared() - 2.0 * m.dot(&(a * m)));
            let gs = [
                g.x * m.x,
                g.y * m.y,
                g.z * m.z,
                g.x * m.y + g.y * m.x,
                g.y * m.z + g.z * m.y,
                g.z * m.x + g.x * m.z,
            ];
            let mut row = [0.0; 10];
            row[..3].copy_from_slice(&[g.x, g.y, g.z]);
            row[3..9].copy_from_slice(&gs);
            ne.add(
                &row.map(|x| x / SIGMA_T),
                (g.dot(m) - vertical + rest_v) / SIGMA_T,
            );
            let ms = [
                m.x * m.x,
                m.y * m.y,
                m.z * m.z,
                2.0 * m.x * m.y,
                2.0 * m.y * m.z,
                2.0 * m.z * m.x,
            ];
            let mut row = [0.0; 10];
            row[..3].copy_from_slice(&[2.0 * m.x, 2.0 * m.y, 2.0 * m.z]);
            for (x, y) in row[3..9].iter_mut().zip(ms) {
                *x = 2.0 * y;
            }
            row[9] = -1.0;
            ne.add(&row.map(|x| x * k), (m.norm_squared() - r * r + rest_m) * k);
        }
        let fit = ne.solve()?;
        let h_next = Vector3::new(fit.theta[0], fit.theta[1], fit.theta[2]);
        let s_next: [f64; 6] = std::array::from_fn(|i| fit.theta[3 + i]);
        let moved = ((h_next - h).amax() / r).max(
            s_next
                .iter()
                .zip(&s)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max),
        );
        (h, s) = (h_next, s_next);
        if moved < 1e-12 {
            break;
        }
    }
    (h.iter().chain(&s).all(|x| x.is_finite())).then_some((h, s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_model::attitude::from_heading_pitch_roll;

    /// Noise-free readings over the identification experiment's attitudes (headings within
    /// ±60°, tilts of ±7°) of a field distorted by a few percent of soft iron and 14 µT of hard
    /// iron: the fit returns both to 1e-9 (the passes converge on the exact solution).
    #[test]
    fn the_ellipsoid_fit_recovers_hard_and_soft_iron_from_noise_free_readings() {
        let config = ModelConfig::default();
        let field_l = config.platform.field_l_t();
        let s = [0.03, -0.03, 0.01, 0.02, -0.01, 0.015];
        let h = Vector3::new(0.08, -0.05, 0.1) * GAUSS;
        let map = Matrix3::identity() + Matrix3::from(soft_iron_matrix(&s));
        let mut pairs = Vec::new();
        for k in -12..=12 {
            let psi = (k as f64 * 5.0).to_radians();
            for (pitch, roll) in [(0.0, 0.0), (7.0, 0.0), (0.0, 7.0), (-7.0, 0.0), (0.0, -7.0)] {
                let q = from_heading_pitch_roll(psi, f64::to_radians(pitch), f64::to_radians(roll));
                pairs.push((map * (q * field_l) + h, attitude::gravity_b(&q)));
            }
        }
        let (h_fit, s_fit) = ellipsoid_fit_pairs(&pairs, &field_l).expect("determined");
        println!("h {h_fit:?} (true {h:?}), S {s_fit:?} (true {s:?})");
        assert!((h_fit - h).norm() < 1e-9 * GAUSS, "{h_fit:?} vs {h:?}");
        for (a, b) in s_fit.iter().zip(&s) {
            assert!((a - b).abs() < 1e-9, "{s_fit:?} vs {s:?}");
        }
    }
}
