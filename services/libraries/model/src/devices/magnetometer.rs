//! The three-axis magnetometer (CXM-539): `M_meas = A(q) M_L + M_hard + eta_M`; with
//! `effects.magnetometer_lag` the reading of the attitude the lag earlier.

use super::fitted_field::FittedFieldModel;
use super::{DeviceId, device_rng, saturate};
use crate::attitude::{Attitude, lagged};
use crate::config::{GAUSS, ModelConfig};
use nalgebra::{Matrix3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// One magnetometer reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MagnetometerReading {
    /// Measured flux density, body axes, tesla; an axis outside the range reads the range limit.
    pub field_t: Vector3<f64>,
    /// Per axis: the field lay outside the measurement range (or was not a number).
    pub saturated: [bool; 3],
}

impl MagnetometerReading {
    /// No axis is saturated, so the reading may be used as a measurement.
    pub fn valid(&self) -> bool {
        !self.saturated.iter().any(|&s| s)
    }
}

/// Magnetometer model: the lab field rotated into body axes, the body-fixed hard-iron field of
/// `effects.magnetic_disturbance` (motors, building), white noise per axis, then the range clamp.
#[derive(Debug, Clone)]
pub struct Magnetometer {
    period_s: f64,
    field_l_t: Vector3<f64>,
    hard_iron_b_t: Vector3<f64>,
    /// `1 + S` of `effects.soft_iron`; `None` without it (the reading is then bit-identical).
    soft_iron: Option<Matrix3<f64>>,
    /// `effects.field_heading_error`: amplitudes of the `cos 2ψ` and `sin 2ψ` parts, tesla,
    /// body axes; `None` without it.
    heading_error_t: Option<(Vector3<f64>, Vector3<f64>)>,
    /// `effects.fitted_field`, added to the reading (zero without it).
    fitted: FittedFieldModel,
    /// Lag of the readings, s (`effects.magnetometer_lag`; zero without it).
    lag_s: f64,
    noise_t: Vector3<f64>,
    range_t: f64,
    rng: ChaCha8Rng,
}

impl Magnetometer {
    /// The magnetometer of `config`, noise on the [`DeviceId::Magnetometer`] stream of `seed`.
    pub fn new(config: &ModelConfig, seed: u64) -> Self {
        let c = &config.magnetometer;
        let hard_iron_b_t = config
            .effects
            .magnetic_disturbance
            .as_ref()
            .map_or_else(Vector3::zeros, |d| Vector3::from(d.hard_iron_gauss) * GAUSS);
        Self {
            period_s: 1.0 / c.rate_hz,
            field_l_t: config.platform.field_l_t(),
            hard_iron_b_t,
            soft_iron: config
                .effects
                .soft_iron
                .as_ref()
                .map(|s| Matrix3::identity() + Matrix3::from_fn(|i, j| s.matrix[i][j])),
            heading_error_t: config.effects.field_heading_error.as_ref().map(|h| {
                (
                    Vector3::from(h.cos_2psi_gauss) * GAUSS,
                    Vector3::from(h.sin_2psi_gauss) * GAUSS,
                )
            }),
            fitted: FittedFieldModel::from_config(
                config.effects.fitted_field.as_ref(),
                &config.platform.field_l_t(),
            ),
            lag_s: config
                .effects
                .magnetometer_lag
                .as_ref()
                .map_or(0.0, |l| l.time_constant_s),
            noise_t: c.noise_t(),
            range_t: c.range_gauss * GAUSS,
            rng: device_rng(seed, DeviceId::Magnetometer),
        }
    }

    /// Sample interval, s (1 / `magnetometer.rate_hz`); the noise is white per sample.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// The noise-free reading at attitude `q`: lab field in body axes (times `1 + S` with soft
    /// iron) plus hard iron plus the heading error of `effects.field_heading_error` plus the
    /// fitted error of `effects.fitted_field`, tesla.
    pub fn expected_t(&self, q: &Attitude) -> Vector3<f64> {
        let body = q * self.field_l_t;
        let mut reading = match &self.soft_iron {
            Some(m) => m * body + self.hard_iron_b_t,
            None => body + self.hard_iron_b_t,
        };
        if let Some((c, s)) = &self.heading_error_t {
            let two_psi = 2.0 * crate::attitude::heading(q);
            reading += c * two_psi.cos() + s * two_psi.sin();
        }
        if self.fitted.is_active() {
            reading + self.fitted.error_t(q)
        } else {
            reading
        }
    }

    /// Read the magnetometer at true attitude `q` (L to B) and body rate `w` (rad/s): the
    /// reading of the attitude its lag earlier.
    pub fn sample(&mut self, q: &Attitude, w: &Vector3<f64>) -> MagnetometerReading {
        let truth = self.expected_t(&lagged(q, w, self.lag_s));
        let mut field_t = Vector3::zeros();
        let mut saturated = [false; 3];
        for i in 0..3 {
            let eta: f64 = self.rng.sample(StandardNormal);
            (field_t[i], saturated[i]) = saturate(truth[i] + self.noise_t[i] * eta, self.range_t);
        }
        MagnetometerReading { field_t, saturated }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_heading_pitch_roll;
    use crate::config::MagneticDisturbance;
    use crate::devices::stats::assert_white;

    /// A lag reads the field of the attitude `τ` earlier: its change from the present reading
    /// is about `−τ (M × w)` (a lab-fixed vector moves in body axes as `Ṁ = M × w`).
    #[test]
    fn a_lag_reads_the_field_a_time_constant_earlier() {
        let mut config = ModelConfig::default();
        config.magnetometer.noise_gauss = [0.0; 3];
        let tau = 0.2;
        config.effects.magnetometer_lag = Some(crate::config::MagnetometerLag {
            time_constant_s: tau,
        });
        let mut mag = Magnetometer::new(&config, 0);
        let q = from_heading_pitch_roll(0.7, 0.03, -0.02);
        let w = Vector3::new(1e-2, -2e-2, 5e-2);
        let now = mag.expected_t(&q);
        let change = mag.sample(&q, &w).field_t - now;
        let first_order = -tau * now.cross(&w);
        assert!(change.norm() > 1e-7);
        assert!((change - first_order).norm() < (w.norm() * tau).powi(2) * now.norm());
        assert_eq!(mag.sample(&q, &Vector3::zeros()).field_t, now);
    }

    #[test]
    fn soft_iron_multiplies_the_body_field() {
        use crate::config::SoftIron;
        let mut config = ModelConfig::default();
        let plain = Magnetometer::new(&config, 1);
        config.effects.soft_iron = Some(SoftIron {
            matrix: [[0.03, 0.02, 0.0], [0.02, -0.03, 0.0], [0.0, 0.0, 0.01]],
        });
        let soft = Magnetometer::new(&config, 1);
        let q = crate::attitude::from_heading_pitch_roll(0.8, 0.1, -0.05);
        let body = plain.expected_t(&q);
        let s = nalgebra::Matrix3::new(0.03, 0.02, 0.0, 0.02, -0.03, 0.0, 0.0, 0.0, 0.01);
        let want = body + s * body;
        assert!((soft.expected_t(&q) - want).norm() < 1e-18);
    }

    /// `effects.field_heading_error` adds `c cos 2ψ + s sin 2ψ` per body axis (gauss in the
    /// configuration, tesla in the reading).
    #[test]
    fn a_heading_error_adds_the_second_harmonic_of_the_heading() {
        use crate::config::FieldHeadingError;
        let mut config = ModelConfig::default();
        let plain = Magnetometer::new(&config, 1);
        config.effects.field_heading_error = Some(FieldHeadingError {
            cos_2psi_gauss: [0.004, -0.002, 0.0],
            sin_2psi_gauss: [0.0, 0.003, 0.001],
        });
        let with = Magnetometer::new(&config, 1);
        for psi in [0.0, 0.3, 1.2, -2.5] {
            let q = from_heading_pitch_roll(psi, 0.05, -0.03);
            let (c, s) = ((2.0 * psi).cos(), (2.0 * psi).sin());
            let want = plain.expected_t(&q)
                + Vector3::new(0.004 * c, -0.002 * c + 0.003 * s, 0.001 * s) * GAUSS;
            assert!((with.expected_t(&q) - want).norm() < 1e-18, "ψ = {psi}");
        }
    }

    /// `effects.fitted_field` adds its error, evaluated at the attitude, to the reading.
    #[test]
    fn a_fitted_field_is_added_to_the_reading() {
        use crate::devices::fitted_field::{FittedField, FittedFieldTerm};
        let mut config = ModelConfig::default();
        let plain = Magnetometer::new(&config, 1);
        config.effects.fitted_field = Some(FittedField {
            terms: vec![
                FittedFieldTerm {
                    axis: "x".into(),
                    function: "1".into(),
                    coefficient: 2e-7,
                },
                FittedFieldTerm {
                    axis: "z".into(),
                    function: "sin ψ".into(),
                    coefficient: -5e-7,
                },
            ],
        });
        let fitted = Magnetometer::new(&config, 1);
        let q = crate::attitude::from_heading_pitch_roll(0.8, 0.1, -0.05);
        let psi = crate::attitude::heading(&q);
        let want = plain.expected_t(&q) + Vector3::new(2e-7, 0.0, -5e-7 * psi.sin());
        assert!((fitted.expected_t(&q) - want).norm() < 1e-18);
    }

    #[test]
    fn noise_matches_configured_sigma_about_rotated_field_plus_hard_iron() {
        let mut config = ModelConfig::default();
        config.effects.magnetic_disturbance = Some(MagneticDisturbance {
            hard_iron_gauss: [0.02, -0.01, 0.005],
        });
        let mut mag = Magnetometer::new(&config, 5);
        let q = from_heading_pitch_roll(2.0, -0.1, 0.15);
        let truth = q * Vector3::from(config.platform.field_l_gauss) * GAUSS
            + Vector3::new(0.02, -0.01, 0.005) * GAUSS;
        let n = 20_000;
        let readings: Vec<_> = (0..n).map(|_| mag.sample(&q, &Vector3::zeros())).collect();
        assert!(readings.iter().all(MagnetometerReading::valid));
        for axis in 0..3 {
            let xs: Vec<f64> = readings.iter().map(|r| r.field_t[axis]).collect();
            let sigma = config.magnetometer.noise_gauss[axis] * GAUSS;
            assert_white(
                &format!("magnetometer axis {axis}"),
                &xs,
                truth[axis],
                sigma,
            );
        }
    }

    #[test]
    fn field_beyond_one_gauss_is_flagged() {
        let mut config = ModelConfig::default();
        config.magnetometer.noise_gauss = [0.0; 3];
        config.effects.magnetic_disturbance = Some(MagneticDisturbance {
            hard_iron_gauss: [0.0, 0.0, -0.7],
        });
        let mut mag = Magnetometer::new(&config, 0);
        // Level: z reads −0.48 − 0.7 = −1.18 G, past the ±1 G range.
        let r = mag.sample(&Attitude::identity(), &Vector3::zeros());
        assert_eq!(r.saturated, [false, false, true]);
        assert!(!r.valid());
        assert!((r.field_t.z + 1e-4).abs() < 1e-18);
        assert!((r.field_t.x - 0.255e-4).abs() < 1e-18);
    }
}
