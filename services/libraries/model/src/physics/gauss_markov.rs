//! A slowly wandering external torque (`effects.gauss_markov_torque`): per body axis a
//! first-order Gauss–Markov (Ornstein–Uhlenbeck) process `dτ = −τ/T dt + σ √(2/T) dW`, stationary
//! with variance `σ²` and autocorrelation `e^{−|Δt|/T}` (air currents in the lab, a cable that
//! creeps, a bearing whose film wanders).
//!
//! It is sampled exactly on a fixed grid of [`GAUSS_MARKOV_STEP_S`] (`τ_{k+1} = a τ_k + σ √(1 − a²)
//! N(0, 1)`, `a = e^{−Δ/T}`, the first sample drawn from the stationary distribution) and held
//! between the grid points, from a seeded random stream: the same seed, the same torque.

use crate::config::GaussMarkovTorque;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Grid spacing of the process, s (well below any correlation time the configuration accepts).
pub const GAUSS_MARKOV_STEP_S: f64 = 0.01;

/// The process's state: its current grid sample and the random stream.
#[derive(Debug, Clone)]
pub struct GaussMarkovProcess {
    sigma: Vector3<f64>,
    a: f64,
    rng: ChaCha8Rng,
    /// Grid index of `value`.
    index: u64,
    value: Vector3<f64>,
}

impl GaussMarkovProcess {
    pub fn new(config: &GaussMarkovTorque) -> Self {
        let sigma = Vector3::from(config.rms_nm);
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed ^ 0x6761_7573_735f_6d6b);
        let value = Vector3::from_fn(|i, _| sigma[i] * rng.sample::<f64, _>(StandardNormal));
        Self {
            sigma,
            a: step_coefficient(GAUSS_MARKOV_STEP_S, config.correlation_time_s),
            rng,
            index: 0,
            value,
        }
    }

    /// The torque at plant time `t_s` (s, not before the last call's), Nm, body axes: the grid
    /// sample at or before `t_s`.
    pub fn torque_at(&mut self, t_s: f64) -> Vector3<f64> {
        let target = (t_s / GAUSS_MARKOV_STEP_S + 1e-9).floor().max(0.0) as u64;
        let b = (1.0 - self.a * self.a).max(0.0).sqrt();
        while self.index < target {
            let noise: Vector3<f64> =
                Vector3::from_fn(|_, _| self.rng.sample::<f64, _>(StandardNormal));
            self.value = self.value * self.a + self.sigma.component_mul(&noise) * b;
            self.index += 1;
        }
        self.value
    }
}

/// `a = e^{−Δ/T}`: the exact one-step coefficient of the process over `step_s`.
pub fn step_coefficient(step_s: f64, correlation_time_s: f64) -> f64 {
    (-step_s / correlation_time_s).exp()
}

/// Stationary autocorrelation of the process at lag `lag_s`: `e^{−|lag|/T}`.
pub fn autocorrelation(lag_s: f64, correlation_time_s: f64) -> f64 {
    (-lag_s.abs() / correlation_time_s).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed form: stationary variance σ² and autocorrelation e^{−τ/T}. 5 × 10⁵ grid samples
    /// (5000 s, 1000 correlation times of 5 s): the sample variance's relative standard error
    /// is about √(2 · 2T/span) ≈ 6 %, the autocorrelation's at lag T about 5 % of 1; bounds of
    /// 15 % and 0.1 (about 3 σ); seed fixed.
    #[test]
    fn stationary_variance_and_autocorrelation_follow_the_closed_form() {
        let config = GaussMarkovTorque {
            rms_nm: [5e-5, 1e-4, 0.0],
            correlation_time_s: 5.0,
            seed: 7,
        };
        let mut p = GaussMarkovProcess::new(&config);
        let n = 500_000;
        let x: Vec<Vector3<f64>> = (0..n)
            .map(|k| p.torque_at(k as f64 * GAUSS_MARKOV_STEP_S))
            .collect();
        for axis in 0..2 {
            let s = config.rms_nm[axis];
            let v: Vec<f64> = x.iter().map(|t| t[axis]).collect();
            let var = v.iter().map(|a| a * a).sum::<f64>() / n as f64;
            assert!(
                (var / (s * s) - 1.0).abs() < 0.15,
                "axis {axis}: variance {var:e} vs {:e}",
                s * s
            );
            for lag_s in [1.0, 5.0, 10.0] {
                let h = (lag_s / GAUSS_MARKOV_STEP_S).round() as usize;
                let c = v[..n - h]
                    .iter()
                    .zip(&v[h..])
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
                    / (n - h) as f64;
                let rho = c / var;
                let want = autocorrelation(lag_s, config.correlation_time_s);
                assert!(
                    (rho - want).abs() < 0.1,
                    "axis {axis}, lag {lag_s} s: {rho:.3} vs e^(-τ/T) = {want:.3}"
                );
            }
        }
        // An axis of zero rms stays zero.
        assert!(x.iter().all(|t| t.z == 0.0));
    }

    #[test]
    fn same_seed_same_torque_and_held_between_grid_points() {
        let config = GaussMarkovTorque {
            rms_nm: [5e-5; 3],
            correlation_time_s: 5.0,
            seed: 3,
        };
        let (mut a, mut b) = (
            GaussMarkovProcess::new(&config),
            GaussMarkovProcess::new(&config),
        );
        let t1 = a.torque_at(1.234);
        assert_eq!(t1, b.torque_at(1.234));
        assert_eq!(a.torque_at(1.2349), t1);
        assert_ne!(a.torque_at(1.25), t1);
    }
}
