//! What a dispersion draws (uniform, normal, one of a list), how the draw becomes the key's
//! value (set, added to the nominal, or scaling it), and the random stream of each draw.
//!
//! Run `k`'s draw for key `p` comes from its own ChaCha8 stream, seeded by (campaign seed, `k`,
//! a hash of `p`): a run is determined by the campaign seed and its index alone, whichever
//! shard or worker runs it, and adding or removing one dispersion leaves the others' draws as
//! they were.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution as _, StandardNormal};
use serde::{Deserialize, Serialize};

/// The distribution of one dispersed parameter, at the edge in the key's own unit.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Distribution {
    /// Every value in `[low, high]` equally likely.
    Uniform { low: f64, high: f64 },
    /// Gaussian with this mean and standard deviation.
    Normal { mean: f64, std: f64 },
    /// One of these values, each equally likely.
    Values(Vec<f64>),
}

/// How a draw becomes the key's value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Apply {
    /// The value is the draw.
    #[default]
    Set,
    /// The value is the nominal (the base configuration's) plus the draw: an error about it.
    Add,
    /// The value is the nominal times the draw: a relative error (`normal = { mean = 1.0, std
    /// = 0.2 }` is ±20 % at 1σ).
    Scale,
}

impl Apply {
    pub fn apply(self, nominal: f64, draw: f64) -> f64 {
        match self {
            Self::Set => draw,
            Self::Add => nominal + draw,
            Self::Scale => nominal * draw,
        }
    }
}

impl Distribution {
    /// Why the distribution cannot be drawn from, if it cannot.
    pub fn check(&self) -> Result<(), String> {
        match self {
            Self::Uniform { low, high } => {
                if !(low.is_finite() && high.is_finite()) {
                    Err(format!(
                        "uniform low = {low}, high = {high}: must be finite"
                    ))
                } else if low > high {
                    Err(format!("uniform low = {low} > high = {high}"))
                } else {
                    Ok(())
                }
            }
            Self::Normal { mean, std } => {
                if !(mean.is_finite() && std.is_finite()) {
                    Err(format!("normal mean = {mean}, std = {std}: must be finite"))
                } else if *std < 0.0 {
                    Err(format!(
                        "normal std = {std}: a standard deviation must be >= 0"
                    ))
                } else {
                    Ok(())
                }
            }
            Self::Values(values) => {
                if values.is_empty() {
                    Err("values = []: the list is empty".into())
                } else if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
                    Err(format!("values: {bad} is not finite"))
                } else {
                    Ok(())
                }
            }
        }
    }

    /// One draw from `rng`.
    pub fn draw(&self, rng: &mut ChaCha8Rng) -> f64 {
        match self {
            Self::Uniform { low, high } => low + (high - low) * rng.random::<f64>(),
            Self::Normal { mean, std } => {
                let z: f64 = StandardNormal.sample(rng);
                mean + std * z
            }
            Self::Values(values) => values[rng.random_range(0..values.len())],
        }
    }

    /// Draws to try against the run configuration before a campaign runs: the ends of a
    /// uniform interval, a normal's mean, every listed value.
    pub fn landmarks(&self) -> Vec<f64> {
        match self {
            Self::Uniform { low, high } => vec![*low, *high],
            Self::Normal { mean, .. } => vec![*mean],
            Self::Values(values) => values.clone(),
        }
    }

    /// Whether every draw is a whole number (what an integer key can take).
    pub fn draws_whole_numbers(&self) -> bool {
        match self {
            Self::Values(values) => values.iter().all(|v| v.fract() == 0.0),
            Self::Uniform { low, high } => low == high && low.fract() == 0.0,
            Self::Normal { mean, std } => *std == 0.0 && mean.fract() == 0.0,
        }
    }
}

/// FNV-1a, 64 bit: a hash of a key's name that does not change between builds or platforms
/// (std's hasher promises neither).
pub fn stable_hash(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The random stream of run `index`'s draw for `key` in a campaign seeded by `campaign_seed`.
pub fn stream(campaign_seed: u64, index: u64, key: &str) -> ChaCha8Rng {
    let mut seed = [0u8; 32];
    seed[..8].copy_from_slice(&campaign_seed.to_le_bytes());
    seed[8..16].copy_from_slice(&index.to_le_bytes());
    seed[16..24].copy_from_slice(&stable_hash(key).to_le_bytes());
    ChaCha8Rng::from_seed(seed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_what_cannot_be_drawn() {
        let reason = |d: Distribution| d.check().unwrap_err();
        assert!(
            reason(Distribution::Normal {
                mean: 0.0,
                std: -1.0
            })
            .contains("std = -1")
        );
        assert!(
            reason(Distribution::Uniform {
                low: 2.0,
                high: 1.0
            })
            .contains("low = 2 > high = 1")
        );
        assert!(reason(Distribution::Values(vec![])).contains("empty"));
        assert!(reason(Distribution::Values(vec![1.0, f64::NAN])).contains("NaN"));
        assert!(
            Distribution::Uniform {
                low: 1.0,
                high: 1.0
            }
            .check()
            .is_ok()
        );
    }

    /// 20 000 draws, seed fixed: a sample mean and standard deviation within 4 standard
    /// errors of the distribution's (a false alarm about once in 15 000 seeds), every uniform
    /// draw inside its interval, every list entry drawn.
    #[test]
    fn draws_follow_their_distribution() {
        let n = 20_000;
        let mut rng = stream(42, 0, "test");
        let normal = Distribution::Normal {
            mean: 3.0,
            std: 2.0,
        };
        let xs: Vec<f64> = (0..n).map(|_| normal.draw(&mut rng)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        assert!(
            (mean - 3.0).abs() < 4.0 * 2.0 / (n as f64).sqrt(),
            "mean {mean}"
        );
        // Standard error of a normal sample's standard deviation: σ / sqrt(2 (n − 1)).
        assert!(
            (sd - 2.0).abs() < 4.0 * 2.0 / (2.0 * (n - 1) as f64).sqrt(),
            "sd {sd}"
        );

        let uniform = Distribution::Uniform {
            low: -1.0,
            high: 3.0,
        };
        let us: Vec<f64> = (0..n).map(|_| uniform.draw(&mut rng)).collect();
        assert!(us.iter().all(|u| (-1.0..=3.0).contains(u)));
        let mean = us.iter().sum::<f64>() / n as f64;
        // Uniform on [a, b]: σ = (b − a) / sqrt(12).
        assert!(
            (mean - 1.0).abs() < 4.0 * (4.0 / 12f64.sqrt()) / (n as f64).sqrt(),
            "{mean}"
        );

        let list = Distribution::Values(vec![1.0, 2.0, 5.0]);
        let mut seen = [0usize; 3];
        for _ in 0..3000 {
            let v = list.draw(&mut rng);
            seen[[1.0, 2.0, 5.0].iter().position(|x| *x == v).unwrap()] += 1;
        }
        assert!(seen.iter().all(|&c| c > 800), "{seen:?}");
    }

    #[test]
    fn a_stream_depends_on_the_seed_the_run_and_the_key_only() {
        let draw = |seed, index, key| stream(seed, index, key).random::<u64>();
        assert_eq!(draw(1, 5, "a.b"), draw(1, 5, "a.b"));
        assert_ne!(draw(1, 5, "a.b"), draw(2, 5, "a.b"));
        assert_ne!(draw(1, 5, "a.b"), draw(1, 6, "a.b"));
        assert_ne!(draw(1, 5, "a.b"), draw(1, 5, "a.c"));
        // FNV-1a's published test vector.
        assert_eq!(stable_hash("a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(Apply::Scale.apply(2.0, 1.5), 3.0);
        assert_eq!(Apply::Add.apply(2.0, 1.5), 3.5);
    }
}
