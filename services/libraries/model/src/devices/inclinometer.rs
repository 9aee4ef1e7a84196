//! The two-axis inclinometer (LE-30): `theta_meas = (1 + s_theta) theta + b_theta + eta_theta`,
//! `phi_meas = (1 + s_phi) phi + b_phi + eta_phi`, angles as defined by
//! [`crate::attitude::tilt_angles`]; `b` is `effects.inclinometer_bias` and `s`
//! `effects.inclinometer_scale` (zero without them); with `effects.inclinometer_cross_axis`
//! each angle also reads `k` times the other; with `effects.inclinometer_lag` the angles are
//! those of the attitude the lag earlier ([`crate::attitude::lagged`]).

use super::{DeviceId, device_rng, saturate};
use crate::attitude::{Attitude, lagged, tilt_angles};
use crate::config::{DEG, ModelConfig};
use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// One inclinometer reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InclinometerReading {
    /// Measured tilt `[θ, φ]` of body X and body Y against the level plane, rad; an axis outside
    /// the range reads the range limit.
    pub tilt_rad: [f64; 2],
    /// Per axis: the tilt lay outside the measurement range (or was not a number).
    pub saturated: [bool; 2],
}

impl InclinometerReading {
    /// Both angles are inside the range, so the reading may be used as a measurement.
    pub fn valid(&self) -> bool {
        !self.saturated[0] && !self.saturated[1]
    }
}

/// Inclinometer model: white noise on each angle, then the range clamp. Range is judged on the
/// noisy angle, as the instrument itself sees it.
#[derive(Debug, Clone)]
pub struct Inclinometer {
    period_s: f64,
    noise_rad: [f64; 2],
    /// Mounting offset added to each angle, rad.
    offset_rad: [f64; 2],
    /// Gain of each angle, `1 + s`.
    gain: [f64; 2],
    /// Fraction of the other angle read in each, `k`.
    cross: [f64; 2],
    /// Lag of the angles, s.
    lag_s: f64,
    range_rad: f64,
    rng: ChaCha8Rng,
}

impl Inclinometer {
    /// The inclinometer of `config`, noise on the [`DeviceId::Inclinometer`] stream of `seed`.
    pub fn new(config: &ModelConfig, seed: u64) -> Self {
        let c = &config.inclinometer;
        Self {
            period_s: 1.0 / c.rate_hz,
            noise_rad: c.noise_rad(),
            offset_rad: config
                .effects
                .inclinometer_bias
                .as_ref()
                .map_or([0.0; 2], |b| b.offset_rad),
            gain: config
                .effects
                .inclinometer_scale
                .as_ref()
                .map_or([1.0; 2], |s| s.ppm.map(|p| 1.0 + p * 1e-6)),
            cross: config
                .effects
                .inclinometer_cross_axis
                .as_ref()
                .map_or([0.0; 2], |c| c.coupling),
            lag_s: config
                .effects
                .inclinometer_lag
                .as_ref()
                .map_or(0.0, |l| l.time_constant_s),
            range_rad: c.range_deg * DEG,
            rng: device_rng(seed, DeviceId::Inclinometer),
        }
    }

    /// Sample interval, s (1 / `inclinometer.rate_hz`). The noise is white per sample, so it does
    /// not depend on the interval.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// Read the inclinometer at true attitude `q` (L to B) and body rate `w` (rad/s).
    pub fn sample(&mut self, q: &Attitude, w: &Vector3<f64>) -> InclinometerReading {
        let truth = tilt_angles(&lagged(q, w, self.lag_s));
        let mut tilt_rad = [0.0; 2];
        let mut saturated = [false; 2];
        for i in 0..2 {
            let eta: f64 = self.rng.sample(StandardNormal);
            (tilt_rad[i], saturated[i]) = saturate(
                self.gain[i] * truth[i]
                    + self.cross[i] * truth[1 - i]
                    + self.offset_rad[i]
                    + self.noise_rad[i] * eta,
                self.range_rad,
            );
        }
        InclinometerReading {
            tilt_rad,
            saturated,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_heading_pitch_roll;
    use crate::devices::stats::assert_white;

    #[test]
    fn noise_matches_configured_sigma_about_true_tilt() {
        let config = ModelConfig::default();
        let mut inc = Inclinometer::new(&config, 3);
        let q = from_heading_pitch_roll(1.2, 0.05, -0.08);
        let truth = tilt_angles(&q);
        let n = 20_000;
        let readings: Vec<_> = (0..n).map(|_| inc.sample(&q, &Vector3::zeros())).collect();
        assert!(readings.iter().all(InclinometerReading::valid));
        for (axis, &true_tilt) in truth.iter().enumerate() {
            let xs: Vec<f64> = readings.iter().map(|r| r.tilt_rad[axis]).collect();
            let sigma = config.inclinometer.noise_deg[axis] * DEG;
            assert_white(&format!("inclinometer axis {axis}"), &xs, true_tilt, sigma);
        }
    }

    /// Each angle reads the other's times its coupling: at θ = 0.03, φ = −0.02 and couplings
    /// `[0.01, −0.02]`, `θ + 0.01 φ` and `φ − 0.02 θ`.
    #[test]
    fn a_cross_axis_coupling_adds_the_other_angle() {
        let mut config = ModelConfig::default();
        config.inclinometer.noise_deg = [0.0; 2];
        let coupling = [0.01, -0.02];
        config.effects.inclinometer_cross_axis =
            Some(crate::config::InclinometerCrossAxis { coupling });
        let mut inc = Inclinometer::new(&config, 0);
        let q = from_heading_pitch_roll(0.7, 0.03, -0.02);
        let [theta, phi] = tilt_angles(&q);
        let r = inc.sample(&q, &Vector3::zeros());
        assert!((r.tilt_rad[0] - (theta + coupling[0] * phi)).abs() < 1e-15);
        assert!((r.tilt_rad[1] - (phi + coupling[1] * theta)).abs() < 1e-15);
    }

    #[test]
    fn a_mounting_offset_shifts_each_angle_by_its_value() {
        let mut config = ModelConfig::default();
        config.inclinometer.noise_deg = [0.0; 2];
        let offset_rad = [8.7e-4, -5.2e-4];
        config.effects.inclinometer_bias = Some(crate::config::InclinometerBias { offset_rad });
        let mut inc = Inclinometer::new(&config, 0);
        let q = from_heading_pitch_roll(0.7, 0.03, -0.02);
        let truth = tilt_angles(&q);
        let r = inc.sample(&q, &Vector3::zeros());
        for axis in 0..2 {
            assert!((r.tilt_rad[axis] - (truth[axis] + offset_rad[axis])).abs() < 1e-15);
        }
    }

    #[test]
    fn a_scale_error_and_an_offset_read_as_gain_times_tilt_plus_offset() {
        let mut config = ModelConfig::default();
        config.inclinometer.noise_deg = [0.0; 2];
        let offset_rad = [8.7e-4, -5.2e-4];
        config.effects.inclinometer_bias = Some(crate::config::InclinometerBias { offset_rad });
        config.effects.inclinometer_scale =
            Some(crate::config::InclinometerScale { ppm: [2e4, -1e4] });
        let mut inc = Inclinometer::new(&config, 0);
        let q = from_heading_pitch_roll(0.7, 0.03, -0.02);
        let truth = tilt_angles(&q);
        let r = inc.sample(&q, &Vector3::zeros());
        for (axis, gain) in [1.02, 0.99].into_iter().enumerate() {
            let expected = gain * truth[axis] + offset_rad[axis];
            assert!((r.tilt_rad[axis] - expected).abs() < 1e-15);
        }
    }

    /// A lag reads the angles of the attitude `τ` earlier, about `θ − τ θ̇`; at rest, the
    /// angles themselves.
    #[test]
    fn a_lag_reads_the_angles_a_time_constant_earlier() {
        let mut config = ModelConfig::default();
        config.inclinometer.noise_deg = [0.0; 2];
        let tau = 0.5;
        config.effects.inclinometer_lag = Some(crate::config::InclinometerLag {
            time_constant_s: tau,
        });
        let mut inc = Inclinometer::new(&config, 0);
        let q = from_heading_pitch_roll(0.7, 0.03, -0.02);
        let w = Vector3::new(2e-3, -3e-3, 1e-2);
        let r = inc.sample(&q, &w);
        let now = tilt_angles(&q);
        // The angles' rates by a central difference of the motion q(t + dt) = exp(−w dt) q.
        let dt = 1e-4;
        let at = |t: f64| tilt_angles(&(Attitude::from_scaled_axis(-w * t) * q));
        let second_order = (w.norm() * tau).powi(2);
        for (axis, angle) in now.iter().enumerate() {
            let rate = (at(dt)[axis] - at(-dt)[axis]) / (2.0 * dt);
            let first_order = angle - tau * rate;
            let off = (r.tilt_rad[axis] - first_order).abs();
            assert!(
                off < second_order,
                "axis {axis}: {off:e} ≥ {second_order:e}"
            );
            assert!((r.tilt_rad[axis] - angle).abs() > 1e-4, "axis {axis}");
        }
        assert_eq!(inc.sample(&q, &Vector3::zeros()).tilt_rad, now);
    }

    #[test]
    fn tilt_beyond_range_is_flagged_and_clamped() {
        let mut config = ModelConfig::default();
        config.inclinometer.noise_deg = [0.0; 2];
        let mut inc = Inclinometer::new(&config, 0);
        // Pitch tips body X: θ = 28° is past the ±25° range; φ stays inside.
        let r = inc.sample(
            &from_heading_pitch_roll(0.3, 28.0 * DEG, 0.0),
            &Vector3::zeros(),
        );
        assert_eq!(r.saturated, [true, false]);
        assert!(!r.valid());
        assert!((r.tilt_rad[0] - 25.0 * DEG).abs() < 1e-15);
        let r = inc.sample(
            &from_heading_pitch_roll(0.3, 24.0 * DEG, 0.0),
            &Vector3::zeros(),
        );
        assert!(r.valid());
        assert!((r.tilt_rad[0] - 24.0 * DEG).abs() < 1e-12);
    }
}
