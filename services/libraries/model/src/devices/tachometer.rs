//! The reaction wheels' tachometers: wheel speed relative to the platform, with white noise and a
//! finite resolution.

use super::{DeviceId, device_rng, quantise};
use crate::config::{ModelConfig, RPM};
use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Tachometers of the three wheels (wheel `i` on body axis `i`). No range limit: the wheel's own
/// speed limit is the plant's business.
#[derive(Debug, Clone)]
pub struct WheelTachometer {
    period_s: f64,
    noise_rad_s: f64,
    resolution_rad_s: f64,
    rng: ChaCha8Rng,
}

impl WheelTachometer {
    /// The tachometers of `config.wheels`, noise on the [`DeviceId::WheelTachometer`] stream of
    /// `seed`.
    pub fn new(config: &ModelConfig, seed: u64) -> Self {
        let w = &config.wheels;
        Self {
            period_s: 1.0 / w.telemetry_rate_hz,
            noise_rad_s: w.speed_noise_rad_s(),
            resolution_rad_s: w.speed_resolution_rpm * RPM,
            rng: device_rng(seed, DeviceId::WheelTachometer),
        }
    }

    /// Sample interval, s (1 / `wheels.telemetry_rate_hz`); the noise is white per sample.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// Noise 1σ per reading, rad/s.
    pub fn noise_rad_s(&self) -> f64 {
        self.noise_rad_s
    }

    /// Measured wheel speeds, rad/s, from the true speeds `speed_rad_s` (relative to the
    /// platform, about each wheel's axis, rad/s).
    pub fn sample(&mut self, speed_rad_s: &Vector3<f64>) -> Vector3<f64> {
        speed_rad_s.map(|n| {
            let eta: f64 = self.rng.sample(StandardNormal);
            quantise(n + self.noise_rad_s * eta, self.resolution_rad_s)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::stats::assert_white;

    #[test]
    fn noise_matches_configured_sigma() {
        let config = ModelConfig::default();
        let mut tach = WheelTachometer::new(&config, 9);
        let truth = Vector3::new(600.0, -123.4, 0.0);
        let n = 20_000;
        let readings: Vec<_> = (0..n).map(|_| tach.sample(&truth)).collect();
        // The 0.01 rpm quantum adds variance q²/12, a relative 0.04 % of the 0.1 rpm noise's: well
        // inside the 2.8 % bound.
        let sigma = config.wheels.speed_noise_rad_s();
        for axis in 0..3 {
            let xs: Vec<f64> = readings.iter().map(|r| r[axis]).collect();
            assert_white(&format!("tachometer {axis}"), &xs, truth[axis], sigma);
        }
    }

    #[test]
    fn quantises_to_resolution() {
        let mut config = ModelConfig::default();
        config.wheels.speed_noise_rpm = 0.0;
        config.wheels.speed_resolution_rpm = 1.0;
        let mut tach = WheelTachometer::new(&config, 0);
        let r = tach.sample(&Vector3::new(1000.4 * RPM, -1000.6 * RPM, 0.2 * RPM));
        let rpm = r / RPM;
        assert!(
            (rpm - Vector3::new(1000.0, -1001.0, 0.0)).norm() < 1e-9,
            "{rpm:?}"
        );
    }
}
