//! Changes within the record: a sensor that stepped while the record ran (a bias that jumped,
//! a magnet or a motor brought near the platform). Every cause of the library is constant over
//! a record, so such a change leaves the attitude filter's innovations at another level after
//! it than before; this test says when, on which component and by how much.
//!
//! Each whitened innovation component is cut into blocks of the prediction window
//! ([`super::Options::horizon_s`], 10 s) and taken as its block means, nearly independent under
//! a correct model whatever the series does within a block. The programme changes the state
//! over the record (headings, tilts, rates), and an error that depends on the state (a field
//! error at the heading) then moves the level in time as well; so the step is tested beside
//! [`STATE_FUNCTIONS`] of the state, each also averaged over the block: the statistic is the
//! largest t of a step's coefficient over the splits of the blocks into a before and an after
//! (at least [`MIN_SIDE_BLOCKS`] each), the block means regressed on the state functions and the
//! step. Its null law is a permutation one (Freedman–Lane): the block residuals of the fit
//! without a step are shuffled, and the largest t over every split is taken again; the
//! share of [`PERMUTATIONS`] shuffles from a fixed seed that reach the observed one, times the
//! components tested (Bonferroni), below [`CHANGE_ALPHA`] is a change. A slow drift also splits
//! well: when a straight line in time fits better than the step, the component is left to the
//! report's trend column, not called a change. The change's time is refined within the two
//! blocks around the split to the sample that best separates the two levels.
//!
//! Not tested: the torque and wheel channels (a torque does not reach the innovations), and
//! what the filter takes into its state (a step in the inclinometer reads as the platform
//! tilting, a gyro bias jump is followed as bias and shows only while the filter catches up).

use crate::data::Aligned;
use crate::reconstruct::{INNOVATION_LEN, Innovation, Reconstruction};
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;
use testbed_model::attitude;

/// Level of the test per record (Bonferroni over the components).
pub const CHANGE_ALPHA: f64 = 1e-3;

/// Fewest blocks on either side of a split.
pub const MIN_SIDE_BLOCKS: usize = 2;

/// Shuffles per component: resolves p down to `1 / (PERMUTATIONS + 1)`, a twentieth of
/// [`CHANGE_ALPHA`] over the five components (one far from significant stops after a few).
pub const PERMUTATIONS: usize = 100_000;

/// The state functions a step is tested beside: `1`, `cos ψ`, `sin ψ`, `cos 2ψ`, `sin 2ψ`
/// (heading), the down vector's body X and Y (tilt), the body rates.
pub const STATE_FUNCTIONS: [&str; 10] = [
    "1",
    "cos ψ",
    "sin ψ",
    "cos 2ψ",
    "sin 2ψ",
    "sin tilt_x",
    "sin tilt_y",
    "w_x",
    "w_y",
    "w_z",
];

/// Seed of the shuffles: the test repeats exactly.
const SEED: u64 = 0x5eed_c4a6;

/// An innovation component whose level changed within the record.
#[derive(Debug, Clone, Serialize)]
pub struct Change {
    /// `innovation_tilt_1` … `innovation_field_z`.
    pub channel: String,
    /// When, s from the record's start (the sample that best separates the two levels).
    pub time_s: f64,
    /// The step's coefficient beside the state functions, whitened innovation (1 is the
    /// predicted standard deviation of one innovation).
    pub step: f64,
    /// The same step in the field residual (corrected reading minus the one predicted from the
    /// prior attitude), tesla, body axes; `None` for the tilt components.
    pub step_t: Option<f64>,
    /// The largest t over the splits, and its permutation p value times the components tested,
    /// at most 1.
    pub t: f64,
    pub p: f64,
    /// Blocks of the component.
    pub blocks: usize,
}

/// The change test of a record's innovations.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ChangeReport {
    pub alpha: f64,
    pub block_s: f64,
    /// Components tested (those with enough blocks for a split beside the state functions).
    pub series: usize,
    /// The changes found, in time order.
    pub changes: Vec<Change>,
}

impl ChangeReport {
    /// The changes in words, those within three blocks of each other on one line; a component
    /// of `structured` (one that also carries an unexplained effect or is not white) is
    /// marked: an error that depends on the state in a way the state functions do not hold
    /// moves with the programme too.
    pub fn lines(&self, structured: &[&str]) -> Vec<String> {
        let mut out = Vec::new();
        let mut i = 0;
        while i < self.changes.len() {
            let first = self.changes[i].time_s;
            let mut j = i;
            while j < self.changes.len() && self.changes[j].time_s - first <= 3.0 * self.block_s {
                j += 1;
            }
            let group = &self.changes[i..j];
            let steps = group
                .iter()
                .map(|c| {
                    let tesla = c.step_t.map_or(String::new(), |s| format!("{s:+.2e} T, "));
                    format!(
                        "{} {tesla}{:+.2} whitened (t = {:.1}, p = {:.1e})",
                        c.channel, c.step, c.t, c.p
                    )
                })
                .collect::<Vec<_>>()
                .join(", ");
            let marked: Vec<&str> = group
                .iter()
                .map(|c| c.channel.as_str())
                .filter(|c| structured.contains(c))
                .collect();
            let caveat = if marked.is_empty() {
                String::new()
            } else {
                format!(
                    " {} also carr{} structure reported above: where that depends on the state, a change of the programme moves it too.",
                    marked.join(", "),
                    if marked.len() > 1 { "y" } else { "ies" }
                )
            };
            out.push(format!(
                "Changed within the record at t ≈ {:.0} s (from the record's start): {steps}. The library's causes are constant over a record: analyse the parts apart (`testbed identify --from-s/--to-s`).{caveat}",
                group.iter().map(|c| c.time_s).sum::<f64>() / group.len() as f64
            ));
            i = j;
        }
        out
    }
}

/// The change test of the innovations of the extended model's reconstruction `recon`.
pub(super) fn changes(data: &Aligned, recon: &Reconstruction, block_s: f64) -> ChangeReport {
    let tested: Vec<(usize, Vec<Sample>, Vec<Block>)> = (0..INNOVATION_LEN)
        .filter_map(|c| {
            let samples = component_samples(data, recon, c, |i| i.values[c]);
            let blocks = blocks_of(&samples, block_s);
            (blocks.len() >= 2 * MIN_SIDE_BLOCKS + STATE_FUNCTIONS.len())
                .then_some((c, samples, blocks))
        })
        .collect();
    let count = tested.len();
    let mut changes: Vec<Change> = tested
        .into_par_iter()
        .filter_map(|(c, samples, blocks)| {
            let test = StepTest::new(&blocks)?;
            let split = test.best(&test.null_residuals)?;
            if !test.step_beats_trend(split) {
                return None;
            }
            let p = test.permutation_p(split.t.abs(), CHANGE_ALPHA / count as f64);
            let p = (p * count as f64).min(1.0);
            // The field's step in tesla: the same test on the raw residual, at the same split.
            let step_t = || {
                let raw = component_samples(data, recon, c, |i| i.field_residual_t[c - FIELD]);
                StepTest::new(&blocks_of(&raw, block_s))?.step_at(split.at)
            };
            (p < CHANGE_ALPHA).then(|| Change {
                channel: super::innovation::INNOVATION_LABELS[c].to_string(),
                time_s: refine(&samples, &blocks, &test, split.at),
                step: split.step,
                step_t: if c >= FIELD { step_t() } else { None },
                t: split.t,
                p,
                blocks: blocks.len(),
            })
        })
        .collect();
    changes.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    ChangeReport {
        alpha: CHANGE_ALPHA,
        block_s,
        series: count,
        changes,
    }
}

/// First field component of the innovation (`[g_t1, g_t2, m_x, m_y, m_z]`).
const FIELD: usize = 2;

/// Component `c`'s innovations as samples, each valued by `value`.
fn component_samples(
    data: &Aligned,
    recon: &Reconstruction,
    c: usize,
    value: impl Fn(&Innovation) -> f64,
) -> Vec<Sample> {
    recon
        .innovations
        .iter()
        .filter(|i| i.mask & (1 << c) != 0)
        .map(|i| Sample {
            t: data.t[i.tick],
            value: value(i),
            state: state_functions(&recon.q[i.tick], &recon.rate[i.tick]),
        })
        .collect()
}

/// One innovation: time, value, state functions.
struct Sample {
    t: f64,
    value: f64,
    state: [f64; STATE_FUNCTIONS.len()],
}

/// [`STATE_FUNCTIONS`] at attitude `q` and body rate `w`.
fn state_functions(q: &attitude::Attitude, w: &nalgebra::Vector3<f64>) -> [f64; 10] {
    let psi = attitude::heading(q);
    let down = attitude::gravity_b(q);
    [
        1.0,
        psi.cos(),
        psi.sin(),
        (2.0 * psi).cos(),
        (2.0 * psi).sin(),
        down.x,
        down.y,
        w.x,
        w.y,
        w.z,
    ]
}

/// One block of a series: its samples `[first, end)`, the mean of their values and of their
/// state functions.
#[derive(Debug, Clone, Copy)]
struct Block {
    first: usize,
    end: usize,
    mean: f64,
    state: [f64; STATE_FUNCTIONS.len()],
}

/// The blocks of `block_s` of the time-ordered `samples`, leaving out blocks with fewer than
/// half the median block's samples (the ends of the record, gaps).
fn blocks_of(samples: &[Sample], block_s: f64) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut i = 0;
    while i < samples.len() {
        let b = crate::data::block_index(samples[i].t, block_s);
        let first = i;
        let (mut sum, mut state) = (0.0, [0.0; STATE_FUNCTIONS.len()]);
        while i < samples.len() && crate::data::block_index(samples[i].t, block_s) == b {
            sum += samples[i].value;
            for (s, x) in state.iter_mut().zip(&samples[i].state) {
                *s += x;
            }
            i += 1;
        }
        let n = (i - first) as f64;
        blocks.push(Block {
            first,
            end: i,
            mean: sum / n,
            state: state.map(|s| s / n),
        });
    }
    let mut sizes: Vec<usize> = blocks.iter().map(|b| b.end - b.first).collect();
    sizes.sort_unstable();
    let median = sizes.get(sizes.len() / 2).copied().unwrap_or(0);
    blocks.retain(|b| 2 * (b.end - b.first) >= median);
    blocks
}

/// The step test of a series of block means beside the blocks' state functions, by
/// Frisch–Waugh: everything is projected off the state functions' column space (`Q`), where a
/// step's coefficient at split `k` is `hₖ·z / hₖᵀM hₖ` with `hₖ` the indicator of the blocks from
/// `k` on and `z` the projected means (`hₖ·z` a suffix sum).
struct StepTest {
    /// Orthonormal basis of the state functions' block means.
    q: DMatrix<f64>,
    /// Residuals of the block means on the state functions (the null model's).
    null_residuals: DVector<f64>,
    /// The null model's coefficients of [`STATE_FUNCTIONS`].
    coefficients: [f64; STATE_FUNCTIONS.len()],
    /// `hₖᵀ M hₖ` for every split `k` (index `k`; 0 where not a split or collinear).
    step_norm: Vec<f64>,
    /// Residual degrees of freedom beside a step.
    dof: f64,
}

/// The best split of a projected series.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Split {
    /// The first block after the split.
    at: usize,
    /// The step's coefficient and its t.
    step: f64,
    t: f64,
    /// Residual sum beside the step.
    rss: f64,
}

impl StepTest {
    fn new(blocks: &[Block]) -> Option<Self> {
        let n = blocks.len();
        let p = STATE_FUNCTIONS.len();
        // Columns scaled to unit norm, so the rank tolerance is relative.
        let mut x = DMatrix::from_fn(n, p, |r, c| blocks[r].state[c]);
        let mut scale = [0.0; STATE_FUNCTIONS.len()];
        for (mut col, s) in x.column_iter_mut().zip(scale.iter_mut()) {
            *s = col.norm();
            if *s > 0.0 {
                col /= *s;
            }
        }
        let svd = x.svd(true, true);
        let (u, v_t) = (svd.u?, svd.v_t?);
        let largest = svd.singular_values.max();
        let keep: Vec<usize> = (0..svd.singular_values.len())
            .filter(|&i| svd.singular_values[i] > 1e-8 * largest)
            .collect();
        let q = u.select_columns(&keep);
        let rank = keep.len();
        if n < rank + 1 + 2 * MIN_SIDE_BLOCKS {
            return None;
        }
        let y = DVector::from_iterator(n, blocks.iter().map(|b| b.mean));
        let project = |v: &DVector<f64>| v - &q * (q.transpose() * v);
        let null_residuals = project(&y);
        // The null fit's coefficients of the state functions, `V Σ⁻¹ Uᵀ y` on the kept
        // directions, back in the functions' own scale.
        let mut coefficients = [0.0; STATE_FUNCTIONS.len()];
        for &i in &keep {
            let along = u.column(i).dot(&y) / svd.singular_values[i];
            for (j, c) in coefficients.iter_mut().enumerate() {
                if scale[j] > 0.0 {
                    *c += v_t[(i, j)] * along / scale[j];
                }
            }
        }
        let step_norm = (0..n)
            .map(|k| {
                if k < MIN_SIDE_BLOCKS || k > n - MIN_SIDE_BLOCKS {
                    return 0.0;
                }
                let h = DVector::from_fn(n, |r, _| if r >= k { 1.0 } else { 0.0 });
                let norm = project(&h).norm_squared();
                // A step the state functions nearly reproduce is not testable.
                if norm > 1e-6 * (n - k) as f64 {
                    norm
                } else {
                    0.0
                }
            })
            .collect();
        Some(Self {
            q,
            null_residuals,
            coefficients,
            step_norm,
            dof: (n - rank - 1) as f64,
        })
    }

    /// The split with the largest |t| of the projected series `z`.
    fn best(&self, z: &DVector<f64>) -> Option<Split> {
        let total = z.norm_squared();
        let mut suffix = 0.0;
        let mut best: Option<Split> = None;
        for k in (1..z.len()).rev() {
            suffix += z[k];
            let norm = self.step_norm[k];
            if norm <= 0.0 {
                continue;
            }
            let step = suffix / norm;
            let rss = (total - suffix * suffix / norm).max(0.0);
            let se = (rss / self.dof / norm).sqrt();
            if se <= 0.0 || !se.is_finite() {
                continue;
            }
            let t = step / se;
            if best.is_none_or(|b| t.abs() > b.t.abs()) {
                best = Some(Split {
                    at: k,
                    step,
                    t,
                    rss,
                });
            }
        }
        best
    }

    /// The step's coefficient at split `k` on the null residuals (`None`: not a split).
    fn step_at(&self, k: usize) -> Option<f64> {
        let norm = *self.step_norm.get(k)?;
        (norm > 0.0).then(|| self.null_residuals.rows_range(k..).sum() / norm)
    }

    /// Whether the step beats a straight line in time beside the state functions.
    fn step_beats_trend(&self, split: Split) -> bool {
        let z = &self.null_residuals;
        let n = z.len();
        let line = DVector::from_fn(n, |r, _| r as f64);
        let line = &line - &self.q * (self.q.transpose() * &line);
        let norm = line.norm_squared();
        let rss_line = if norm > 0.0 {
            z.norm_squared() - line.dot(z).powi(2) / norm
        } else {
            z.norm_squared()
        };
        split.rss < rss_line
    }

    /// Share of shuffles of the null residuals whose largest |t| reaches `observed` (the
    /// observed order counted as one), stopping early once it cannot fall below `level`.
    fn permutation_p(&self, observed: f64, level: f64) -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(SEED);
        let mut shuffled = self.null_residuals.clone();
        let give_up = (level * (PERMUTATIONS + 1) as f64).ceil() as usize + 1;
        let (mut reached, mut drawn) = (1, 0);
        while drawn < PERMUTATIONS {
            shuffled.as_mut_slice().shuffle(&mut rng);
            drawn += 1;
            let z = &shuffled - &self.q * (self.q.transpose() * &shuffled);
            if self.best(&z).is_some_and(|s| s.t.abs() >= observed) {
                reached += 1;
                if reached >= give_up {
                    break;
                }
            }
        }
        reached as f64 / (drawn + 1) as f64
    }
}

/// The sample time in the blocks either side of the split `at` (blocks `at − 1` and `at`)
/// that best separates the two levels of the values less their state functions' part (least
/// squares over those samples, the levels the means of the blocks before and after).
fn refine(samples: &[Sample], blocks: &[Block], test: &StepTest, at: usize) -> f64 {
    // A value less its state functions' part, from the fit of the block means without a step.
    let adjust = |s: &Sample| {
        s.value
            - s.state
                .iter()
                .zip(&test.coefficients)
                .map(|(a, b)| a * b)
                .sum::<f64>()
    };
    let level = |range: &[Block]| {
        let (sum, n) = range.iter().fold((0.0, 0), |(s, n), b| {
            (
                s + samples[b.first..b.end].iter().map(adjust).sum::<f64>(),
                n + b.end - b.first,
            )
        });
        sum / n as f64
    };
    let (before, after) = (level(&blocks[..at]), level(&blocks[at..]));
    let span = &samples[blocks[at - 1].first..blocks[at].end];
    // Cost of a split before sample j: Σ_{i<j} (u − before)² + Σ_{i≥j} (u − after)²; its change
    // from one j to the next is (u_j − before)² − (u_j − after)².
    let mut cost: f64 = span.iter().map(|s| (adjust(s) - after).powi(2)).sum();
    let (mut best, mut best_cost) = (0, cost);
    for (j, s) in span.iter().enumerate() {
        let u = adjust(s);
        cost += (u - before).powi(2) - (u - after).powi(2);
        if cost < best_cost {
            (best, best_cost) = (j + 1, cost);
        }
    }
    span.get(best).map_or(span[span.len() - 1].t, |s| s.t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_distr::{Distribution, StandardNormal};

    fn noise(seed: u64, n: usize) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| StandardNormal.sample(&mut rng)).collect()
    }

    /// 600 s at 2.5 Hz (60 blocks of 10 s) of `values`, the heading turning once in 300 s and
    /// the state otherwise still.
    fn samples(values: &[f64]) -> Vec<Sample> {
        values
            .iter()
            .enumerate()
            .map(|(i, &value)| {
                let t = i as f64 * 0.4;
                let psi = std::f64::consts::TAU * t / 300.0;
                let mut state = [0.0; 10];
                state[0] = 1.0;
                state[1] = psi.cos();
                state[2] = psi.sin();
                state[3] = (2.0 * psi).cos();
                state[4] = (2.0 * psi).sin();
                Sample { t, value, state }
            })
            .collect()
    }

    fn test_of(values: &[f64]) -> (Vec<Sample>, Vec<Block>, StepTest) {
        let samples = samples(values);
        let blocks = blocks_of(&samples, 10.0);
        let test = StepTest::new(&blocks).expect("testable");
        (samples, blocks, test)
    }

    #[test]
    fn a_step_in_white_noise_is_found_where_it_is_with_its_size() {
        // Step of 1σ at 250 s: the block means' σ is 1/√25 = 0.2, so the step is 5 of them;
        // its size within 0.3 (3σ of a step between ~600-sample levels beside the heading
        // harmonics: about 0.1); its time within 5 s (12 samples, where the least-squares
        // location's error has a scale of (σ/step)² = 1 sample).
        let mut v = noise(1, 1500);
        for (i, x) in v.iter_mut().enumerate() {
            if i as f64 * 0.4 >= 250.0 {
                *x += 1.0;
            }
        }
        let (samples, blocks, test) = test_of(&v);
        let split = test.best(&test.null_residuals).unwrap();
        assert!(test.step_beats_trend(split));
        assert!((split.step - 1.0).abs() < 0.3, "{split:?}");
        let p = test.permutation_p(split.t.abs(), 1e-3);
        assert!(p < 1e-3, "p = {p}");
        let time = refine(&samples, &blocks, &test, split.at);
        assert!((time - 250.0).abs() < 5.0, "{time}");
    }

    #[test]
    fn an_error_at_the_heading_is_no_change() {
        // 1σ × cos ψ: large against the block means' 0.2, a level that moves in time as the
        // heading turns; the heading harmonics take it, and p stays above 1 %.
        let v: Vec<f64> = noise(3, 1500)
            .iter()
            .enumerate()
            .map(|(i, x)| x + (std::f64::consts::TAU * i as f64 * 0.4 / 300.0).cos())
            .collect();
        let (_, _, test) = test_of(&v);
        let split = test.best(&test.null_residuals).unwrap();
        let p = test.permutation_p(split.t.abs(), 0.01);
        assert!(p >= 0.01, "p = {p}, {split:?}");
    }

    #[test]
    fn white_noise_passes_at_the_stated_level_on_most_seeds() {
        // Exchangeable blocks: the permutation p is uniform, so at 1 % about 1 in 100 series is
        // flagged; over 50 seeds, more than 3 would be p < 0.002 by the binomial law.
        let flagged = (0..50)
            .filter(|&seed| {
                let (_, _, test) = test_of(&noise(100 + seed, 1500));
                let split = test.best(&test.null_residuals).unwrap();
                test.permutation_p(split.t.abs(), 0.01) < 0.01
            })
            .count();
        assert!(flagged <= 3, "{flagged} of 50 flagged at 1 %");
    }

    #[test]
    fn a_drift_is_not_called_a_step() {
        let v: Vec<f64> = noise(7, 1500)
            .iter()
            .enumerate()
            .map(|(i, x)| x + 2e-3 * i as f64)
            .collect();
        let (_, _, test) = test_of(&v);
        let split = test.best(&test.null_residuals).unwrap();
        assert!(!test.step_beats_trend(split));
    }
}
