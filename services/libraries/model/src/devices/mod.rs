//! Device models: what the sensors report and what the actuator drives can realise, given the
//! true state. Noise, bias, quantisation and range are modelled here; the dynamics are in
//! [`crate::physics`].
//!
//! Every noisy device owns its own [`ChaCha8Rng`], keyed by the run seed and placed on a ChaCha
//! stream chosen by its [`DeviceId`] (see [`device_rng`]). Streams of one key never overlap, so a
//! device's noise depends only on (run seed, device id) and on how often it was sampled: adding,
//! removing or re-ordering another device never changes it.
//!
//! Units are SI (rad, rad/s, tesla) and vectors are in body axes unless a name says otherwise;
//! the attitude convention is that of [`crate::attitude`].

pub mod cmg_encoder;
pub mod cmg_stepper;
pub mod fitted_field;
pub mod gyro;
pub mod inclinometer;
pub mod magnetometer;
pub mod tachometer;

pub use cmg_encoder::CmgEncoder;
pub use cmg_stepper::{CmgStepperDrive, StepperOutput};
pub use gyro::{Gyro, GyroReading};
pub use inclinometer::{Inclinometer, InclinometerReading};
pub use magnetometer::{Magnetometer, MagnetometerReading};
pub use tachometer::WheelTachometer;

use crate::config::ModelConfig;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Identity of a noisy device: the ChaCha stream its noise is drawn from.
///
/// The numbers are part of the reproducibility contract (a recorded run is replayed from its seed),
/// so an existing device never changes number; a new device takes a new one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u64)]
pub enum DeviceId {
    Gyro = 1,
    Inclinometer = 2,
    Magnetometer = 3,
    WheelTachometer = 4,
}

/// The random number generator of device `id` in the run seeded `seed`.
///
/// `seed_from_u64` expands the run seed to a ChaCha key; the device id selects the 64-bit stream,
/// which ChaCha keeps disjoint from every other stream of the same key.
pub fn device_rng(seed: u64, id: DeviceId) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(id as u64);
    rng
}

/// Why a device refused a request.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DeviceError {
    #[error("sample interval must be a finite number of seconds > 0, got {dt_s}")]
    InvalidInterval { dt_s: f64 },
}

/// Round `x` to the nearest multiple of `quantum` (same unit); `quantum <= 0` means no
/// quantisation. Rounding to nearest keeps the quantisation error zero-mean.
pub(crate) fn quantise(x: f64, quantum: f64) -> f64 {
    if quantum > 0.0 {
        (x / quantum).round() * quantum
    } else {
        x
    }
}

/// Clamp `x` to `±range`; the flag is true if `x` was outside (or not a number), so the reading
/// is the range limit rather than the true value.
pub(crate) fn saturate(x: f64, range: f64) -> (f64, bool) {
    if x.is_nan() {
        (x, true)
    } else if x.abs() > range {
        (range.copysign(x), true)
    } else {
        (x, false)
    }
}

/// All device models of the test bed, built from one configuration and one run seed.
#[derive(Debug, Clone)]
pub struct DeviceSet {
    pub gyro: Gyro,
    pub inclinometer: Inclinometer,
    pub magnetometer: Magnetometer,
    pub tachometer: WheelTachometer,
    pub cmg_encoder: CmgEncoder,
    pub cmg_stepper: CmgStepperDrive,
}

impl DeviceSet {
    /// Every device of `config`, each noisy one on its own stream of `seed`.
    pub fn new(config: &ModelConfig, seed: u64) -> Self {
        Self {
            gyro: Gyro::new(config, seed),
            inclinometer: Inclinometer::new(config, seed),
            magnetometer: Magnetometer::new(config, seed),
            tachometer: WheelTachometer::new(config, seed),
            cmg_encoder: CmgEncoder::new(&config.cmg),
            cmg_stepper: CmgStepperDrive::new(&config.cmg),
        }
    }
}

/// Sample statistics for the device tests.
#[cfg(test)]
pub(crate) mod stats {
    /// Mean and sample standard deviation (n − 1 denominator).
    pub fn mean_std(xs: &[f64]) -> (f64, f64) {
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var.sqrt())
    }

    /// Assert that `xs` look like white noise of standard deviation `sigma` around `mean`.
    ///
    /// For N Gaussian samples the sample standard deviation has relative standard deviation
    /// ≈ 1/sqrt(2N), and the sample mean has standard deviation sigma/sqrt(N). A 4σ band makes a
    /// false failure about a 1-in-16000 event for a fresh seed; the seeds are fixed, so a pass is
    /// reproducible and a real modelling error (wrong unit, wrong sqrt(dt)) is far outside it.
    pub fn assert_white(label: &str, xs: &[f64], mean: f64, sigma: f64) {
        let n = xs.len() as f64;
        let (m, s) = mean_std(xs);
        let rel_bound = 4.0 / (2.0 * n).sqrt();
        println!(
            "{label}: N = {n}, std {s:.4e} vs {sigma:.4e} ({:+.4}, bound ±{rel_bound:.4}), mean error {:+.2} σ/√N",
            s / sigma - 1.0,
            (m - mean) / (sigma / n.sqrt())
        );
        assert!(
            (s / sigma - 1.0).abs() < rel_bound,
            "{label}: sample std {s:e} vs sigma {sigma:e}: relative error {:.4} > {rel_bound:.4}",
            s / sigma - 1.0
        );
        let mean_bound = 4.0 * sigma / n.sqrt();
        assert!(
            (m - mean).abs() < mean_bound,
            "{label}: sample mean {m:e} vs {mean:e}: |error| > {mean_bound:e}"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_heading_pitch_roll;
    use nalgebra::Vector3;

    fn run(set: &mut DeviceSet, n: usize) -> Vec<f64> {
        let q = from_heading_pitch_roll(0.4, 0.02, -0.03);
        let w = Vector3::new(1e-3, -2e-3, 3e-3);
        let mut out = Vec::new();
        for _ in 0..n {
            out.extend(set.gyro.sample(&q, &w).rate_rad_s.iter());
            out.extend(set.inclinometer.sample(&q, &w).tilt_rad.iter());
            out.extend(set.magnetometer.sample(&q, &w).field_t.iter());
            out.extend(
                set.tachometer
                    .sample(&Vector3::new(100.0, -50.0, 0.0))
                    .iter(),
            );
        }
        out
    }

    #[test]
    fn same_seed_reproduces_exactly_and_different_seeds_differ() {
        let config = ModelConfig::default();
        let a = run(&mut DeviceSet::new(&config, 42), 50);
        let b = run(&mut DeviceSet::new(&config, 42), 50);
        let c = run(&mut DeviceSet::new(&config, 43), 50);
        assert_eq!(a, b);
        let differing = a.iter().zip(&c).filter(|(x, y)| x != y).count();
        // Every gyro, inclinometer, magnetometer and tachometer channel carries noise; only an
        // occasional coincidence after quantisation may agree.
        assert!(
            differing > a.len() * 9 / 10,
            "only {differing} of {} differ",
            a.len()
        );
    }

    #[test]
    fn a_device_stream_does_not_depend_on_other_devices() {
        let config = ModelConfig::default();
        let q = from_heading_pitch_roll(0.0, 0.0, 0.0);
        let w = Vector3::zeros();
        let mut alone = Gyro::new(&config, 7);
        let mut set = DeviceSet::new(&config, 7);
        for _ in 0..20 {
            // Sampling the other devices in between must not shift the gyro's noise.
            set.magnetometer.sample(&q, &w);
            set.inclinometer.sample(&q, &w);
            assert_eq!(alone.sample(&q, &w), set.gyro.sample(&q, &w));
        }
    }

    #[test]
    fn streams_of_different_devices_differ() {
        use rand::Rng;
        let a: u64 = device_rng(1, DeviceId::Gyro).random();
        let b: u64 = device_rng(1, DeviceId::Magnetometer).random();
        assert_ne!(a, b);
    }

    #[test]
    fn quantise_and_saturate_helpers() {
        assert_eq!(quantise(0.26, 0.1), 0.30000000000000004);
        assert_eq!(quantise(-0.24, 0.1), -0.2);
        assert_eq!(quantise(0.123, 0.0), 0.123);
        assert_eq!(saturate(3.0, 2.0), (2.0, true));
        assert_eq!(saturate(-3.0, 2.0), (-2.0, true));
        assert_eq!(saturate(1.5, 2.0), (1.5, false));
        assert!(saturate(f64::NAN, 2.0).1);
    }
}
