//! The hard iron's starting value: a sphere fit of the field readings against the lab field,
//! kept when it explains the innovations better than no hard iron.

use super::Problem;
use crate::data::Aligned;
use crate::effects::Cause;
use crate::error::IdentError;
use crate::stats::NormalEquations;
use nalgebra::Vector3;
use testbed_model::ModelConfig;
use testbed_model::attitude;
use testbed_model::config::GAUSS;

impl Problem<'_> {
    /// Starting values of a sensor cause absent from the base: its neutral values, for the hard
    /// iron the better of zero and a sphere fit of the field readings.
    pub(super) fn initial_sensor_values(&self, cause: Cause) -> Result<Vec<f64>, IdentError> {
        let neutral = cause.values(&self.base);
        if cause != Cause::MagneticDisturbance || cause.present(&self.base) {
            return Ok(neutral);
        }
        let guess = {
            let mut cached = self.sphere.borrow_mut();
            *cached.get_or_insert_with(|| sphere_fit(self.data, &self.base))
        };
        let Some(h) = guess else { return Ok(neutral) };
        let rss_of = |v: &[f64]| -> Result<f64, IdentError> {
            let mut c = self.base.clone();
            Cause::MagneticDisturbance.apply(&mut c, v);
            Ok(self
                .fit_innovations(&*self.recon(&c)?)
                .iter()
                .map(|x| x * x)
                .sum())
        };
        Ok(if rss_of(&h)? < rss_of(&neutral)? {
            h.to_vec()
        } else {
            neutral
        })
    }
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
    let mut i = 0;
    let sigma = 1e-7; // T, weights both kinds of rows alike
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
        let Some(g) = attitude::gravity_from_tilt(tilt[0], tilt[1]) else {
            continue;
        };
        ne.add(
            &[g.x / sigma, g.y / sigma, g.z / sigma, 0.0],
            (m.dot(&g) - vertical) / sigma,
        );
        let k = 1.0 / (2.0 * r * sigma);
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
