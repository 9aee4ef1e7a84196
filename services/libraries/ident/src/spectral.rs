//! A spectral test for a coloured (first-order Gauss–Markov) component in a residual series,
//! and its size and correlation time: the Whittle likelihood of the pooled periodogram.
//!
//! The series `d_k` (one tick apart, `segments` of contiguous ticks) is modelled as stationary
//! with the spectral density (per radian per sample, times 2π)
//!
//! ```text
//! S(ω) = W + σ² · 2(1 − cos ω) + A · (1 − φ²) / (1 − 2φ cos ω + φ²)
//! ```
//!
//! `W` a white part, `σ²` the variance of a white noise differenced once (the momentum
//! residual's measurement noise seen in its increments), `A` the variance of an AR(1) process of
//! coefficient `φ = e^{−Δt/T}` (a Gauss–Markov torque of correlation time `T`, sampled at `Δt`).
//! Under the null, `A = 0` (white after this pre-whitening model); the periodogram ordinates
//! `I_j / S(ω_j)` are then independent unit exponentials (Whittle). The statistic is the
//! likelihood ratio `2 (ℓ₀ − ℓ₁)` of the two fits, referred to χ² with 2 degrees of freedom
//! (`A`, `φ`; the boundary `A = 0` makes this conservative). Linear coefficients are fitted by
//! iteratively reweighted least squares (the exponential family's identity link, weights
//! `1/S²`), kept non-negative; `φ` on a logarithmic grid of correlation times.

use crate::stats::chi_square_cdf;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

/// Periodogram ordinates `(ω_j, I_j)` of each segment (`I = |Σ x_t e^{−iω t}|² / n` at the
/// Fourier frequencies `ω_j = 2π j / n`, `0 < j < n/2`), pooled. Segments shorter than 16
/// samples are left out. The sums are one FFT per segment (`rustfft`, any length).
pub fn periodogram(segments: &[Vec<f64>]) -> Vec<(f64, f64)> {
    let mut planner = FftPlanner::<f64>::new();
    let mut out = Vec::new();
    let mut buffer: Vec<Complex<f64>> = Vec::new();
    for x in segments {
        let n = x.len();
        if n < 16 {
            continue;
        }
        buffer.clear();
        buffer.extend(x.iter().map(|&v| Complex::new(v, 0.0)));
        planner.plan_fft_forward(n).process(&mut buffer);
        out.extend((1..n.div_ceil(2)).map(|j| {
            let w = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
            (w, buffer[j].norm_sqr() / n as f64)
        }));
    }
    out
}

/// The Whittle fit of the null and the coloured model.
#[derive(Debug, Clone, PartialEq)]
pub struct ColourFit {
    /// Periodogram ordinates used.
    pub ordinates: usize,
    /// Likelihood ratio `2 (ℓ₀ − ℓ₁)` and its p value (χ², 2 degrees of freedom).
    pub lr: f64,
    pub p: f64,
    /// Coloured model: the AR(1) variance `A` (units of the series squared) and coefficient `φ`.
    pub ar_variance: f64,
    pub phi: f64,
    /// Coloured model: white part `W` and differenced-noise variance `σ²`.
    pub white_variance: f64,
    pub differenced_variance: f64,
}

impl ColourFit {
    /// Correlation time of the AR(1) part, s, for samples `dt_s` apart: `−Δt / ln φ`.
    pub fn correlation_time_s(&self, dt_s: f64) -> f64 {
        -dt_s / self.phi.ln()
    }
}

/// Spectral shape of a unit-variance AR(1) of coefficient `phi` at the frequency whose cosine
/// is `cos_w`.
fn ar1_shape(phi: f64, cos_w: f64) -> f64 {
    (1.0 - phi * phi) / (1.0 - 2.0 * phi * cos_w + phi * phi)
}

/// Most spectral shapes a fit combines (white, differenced, AR(1)).
const MAX_BASIS: usize = 3;

/// Whittle negative log-likelihood and non-negative coefficients of `S = Σ c_i b_i(ω)`, by
/// iteratively reweighted least squares from `start` (coefficients; the flat spectrum at the
/// mean power without). The fit is the same from any start; one near it needs fewer passes.
fn whittle_linear(basis: &[&[f64]], power: &[f64], start: Option<&[f64]>) -> (f64, Vec<f64>) {
    let k = basis.len();
    assert!(k <= MAX_BASIS, "at most {MAX_BASIS} spectral shapes");
    let n = power.len();
    let mean = power.iter().sum::<f64>() / n.max(1) as f64;
    let floor = mean.max(1e-300) * 1e-9;
    let mut s = vec![mean.max(1e-300); n];
    let mut coef = vec![0.0; k];
    if let Some(start) = start.filter(|c| c.len() == k && c.iter().all(|v| v.is_finite())) {
        coef = start.to_vec();
        for (j, s) in s.iter_mut().enumerate() {
            *s = (0..k)
                .map(|i| coef[i] * basis[i][j])
                .sum::<f64>()
                .max(floor);
        }
    }
    for _ in 0..60 {
        let mut active: Vec<usize> = (0..k).collect();
        let solved = loop {
            // The weighted normal equations, accumulated in fixed arrays (the hot loop), then
            // solved as a matrix.
            let m = active.len();
            let (mut a, mut b) = ([[0.0; MAX_BASIS]; MAX_BASIS], [0.0; MAX_BASIS]);
            let mut row = [0.0; MAX_BASIS];
            for j in 0..n {
                let w = 1.0 / (s[j] * s[j]);
                for (r, &i) in row.iter_mut().zip(&active) {
                    *r = basis[i][j];
                }
                for p in 0..m {
                    b[p] += w * row[p] * power[j];
                    for q in 0..m {
                        a[p][q] += w * row[p] * row[q];
                    }
                }
            }
            let a = DMatrix::from_fn(m, m, |p, q| a[p][q]);
            let b = DVector::from_fn(m, |p, _| b[p]);
            let Some(x) = a.lu().solve(&b) else {
                break None;
            };
            match (0..active.len())
                .filter(|&p| x[p] < 0.0)
                .min_by(|&p, &q| x[p].total_cmp(&x[q]))
            {
                Some(p) if active.len() > 1 => {
                    active.remove(p);
                }
                Some(_) => break None,
                None => break Some((active.clone(), x)),
            }
        };
        let Some((active, x)) = solved else {
            break;
        };
        let mut next = vec![0.0; k];
        for (p, &i) in active.iter().enumerate() {
            next[i] = x[p];
        }
        let change = next
            .iter()
            .zip(&coef)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let scale = next.iter().map(|c| c.abs()).fold(0.0, f64::max).max(1e-300);
        coef = next;
        for j in 0..n {
            s[j] = (0..k)
                .map(|i| coef[i] * basis[i][j])
                .sum::<f64>()
                .max(floor);
        }
        if change < 1e-10 * scale {
            break;
        }
    }
    let nll = (0..n).map(|j| s[j].ln() + power[j] / s[j]).sum();
    (nll, coef)
}

/// Correlation times of the grid, in samples: 1.5 to 10⁵, 24 per decade.
fn correlation_grid() -> impl Iterator<Item = f64> {
    (0..=((1e5_f64 / 1.5).log10() * 24.0).ceil() as usize)
        .map(|i| 1.5 * 10f64.powf(i as f64 / 24.0))
}

/// The coloured model at one point of the correlation grid: `φ`, the negative
/// log-likelihood, the coefficients `[W, σ², A]`.
type GridFit = (f64, f64, Vec<f64>);

/// The null fit's negative log-likelihood, and the coloured model's fit at every point of the
/// correlation grid; `None` with fewer than 32 ordinates.
fn grid_fits(ordinates: &[(f64, f64)]) -> Option<(f64, Vec<GridFit>)> {
    if ordinates.len() < 32 {
        return None;
    }
    let power: Vec<f64> = ordinates.iter().map(|o| o.1).collect();
    let cos_w: Vec<f64> = ordinates.iter().map(|o| o.0.cos()).collect();
    let ones = vec![1.0; ordinates.len()];
    let diff: Vec<f64> = cos_w.iter().map(|c| 2.0 * (1.0 - c)).collect();
    let (nll0, null) = whittle_linear(&[&ones, &diff], &power, None);
    // Each grid point starts from its neighbour's fit (the first from the null's).
    let mut start = [null, vec![0.0]].concat();
    let mut ar = vec![0.0; ordinates.len()];
    let fits = correlation_grid()
        .map(|c| {
            let phi = (-1.0 / c).exp();
            for (a, c) in ar.iter_mut().zip(&cos_w) {
                *a = ar1_shape(phi, *c);
            }
            let (nll, coef) = whittle_linear(&[&ones, &diff, &ar], &power, Some(&start));
            start.clone_from(&coef);
            (phi, nll, coef)
        })
        .collect();
    Some((nll0, fits))
}

fn colour_of(ordinates: usize, lr: f64, dof: f64, phi: f64, coef: &[f64]) -> ColourFit {
    ColourFit {
        ordinates,
        lr,
        p: (1.0 - chi_square_cdf(lr, dof)).clamp(0.0, 1.0),
        ar_variance: coef[2],
        phi,
        white_variance: coef[0],
        differenced_variance: coef[1],
    }
}

/// The coloured model at the grid point that fits best, against the null.
fn best_of(ordinates: usize, nll0: f64, fits: Vec<GridFit>) -> Option<ColourFit> {
    let (phi, nll1, coef) = fits.into_iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
    let lr = (2.0 * (nll0 - nll1)).max(0.0);
    Some(colour_of(ordinates, lr, 2.0, phi, &coef))
}

/// The null and coloured fits to each series' pooled periodogram ([`periodogram`]), and the
/// coloured model fitted to all of them at once with one correlation time (each its own variances): a disturbance that
/// wanders on every axis at the same pace is found from their joint evidence when no one axis
/// holds enough. The joint fit gives per series its fit at the shared `φ`; its likelihood
/// ratio and p value (χ², one degree of freedom per series plus the shared `φ`) are the same
/// in every element. `None` for a series, and for the joint fit, when a series has fewer than
/// 32 ordinates.
pub fn colour_fits(series: &[Vec<(f64, f64)>]) -> (Vec<Option<ColourFit>>, Option<Vec<ColourFit>>) {
    let grids: Vec<Option<(f64, Vec<GridFit>)>> = series.par_iter().map(|o| grid_fits(o)).collect();
    let joint = joint_of(series, &grids);
    let own = grids
        .into_iter()
        .zip(series)
        .map(|(g, o)| g.and_then(|(nll0, fits)| best_of(o.len(), nll0, fits)))
        .collect();
    (own, joint)
}

fn joint_of(
    series: &[Vec<(f64, f64)>],
    grids: &[Option<(f64, Vec<GridFit>)>],
) -> Option<Vec<ColourFit>> {
    let fits: Vec<&(f64, Vec<GridFit>)> =
        grids.iter().map(Option::as_ref).collect::<Option<_>>()?;
    let points = fits.first()?.1.len();
    let total = |i: usize| fits.iter().map(|f| f.1[i].1).sum::<f64>();
    let best = (0..points).min_by(|&a, &b| total(a).total_cmp(&total(b)))?;
    let lr = fits
        .iter()
        .map(|(nll0, grid)| 2.0 * (nll0 - grid[best].1))
        .sum::<f64>()
        .max(0.0);
    let dof = series.len() as f64 + 1.0;
    Some(
        fits.iter()
            .zip(series)
            .map(|((_, grid), o)| colour_of(o.len(), lr, dof, grid[best].0, &grid[best].2))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    /// One series' own fit.
    fn colour_fit(ordinates: &[(f64, f64)]) -> Option<ColourFit> {
        colour_fits(&[ordinates.to_vec()]).0.pop().flatten()
    }

    /// The FFT's ordinates are the defining sums `|Σ x_t e^{−iωt}|² / n` (relative 1e-12) on
    /// segments of prime, odd and even length; a cosine of amplitude `a` at the Fourier frequency
    /// `j₀` has `I = n a² / 4` there and nothing elsewhere; short segments are left out.
    #[test]
    fn periodogram_is_the_defining_sum() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let segments: Vec<Vec<f64>> = [17, 120, 1201, 8]
            .iter()
            .map(|&n| (0..n).map(|_| rng.sample(StandardNormal)).collect())
            .collect();
        let got = periodogram(&segments);
        let mut want = Vec::new();
        for x in segments.iter().filter(|x| x.len() >= 16) {
            let n = x.len();
            for j in 1..n.div_ceil(2) {
                let w = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
                let (re, im) = x.iter().enumerate().fold((0.0, 0.0), |(re, im), (t, v)| {
                    (re + v * (w * t as f64).cos(), im - v * (w * t as f64).sin())
                });
                want.push((w, (re * re + im * im) / n as f64));
            }
        }
        assert_eq!(got.len(), want.len());
        for ((wg, ig), (ww, iw)) in got.iter().zip(&want) {
            assert_eq!(wg, ww);
            assert!(
                (ig - iw).abs() <= 1e-12 * iw.max(1.0),
                "{wg}: {ig} against {iw}"
            );
        }
        let (n, j0, a) = (64, 5, 0.3);
        let cosine: Vec<f64> = (0..n)
            .map(|t| a * (2.0 * std::f64::consts::PI * (j0 * t) as f64 / n as f64).cos())
            .collect();
        for (j, (_, i)) in periodogram(&[cosine])
            .iter()
            .enumerate()
            .map(|(k, o)| (k + 1, o))
        {
            let expected = if j == j0 { n as f64 * a * a / 4.0 } else { 0.0 };
            assert!((i - expected).abs() < 1e-12, "j = {j}: {i}");
        }
    }

    /// `e_k − e_{k−1}` (+ an AR(1) of variance `a`, coefficient `phi`), segments of `len`.
    fn series(seed: u64, segments: usize, len: usize, a: f64, phi: f64) -> Vec<Vec<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut n = || rng.sample::<f64, _>(StandardNormal);
        (0..segments)
            .map(|_| {
                let mut e0 = n();
                let mut u = a.sqrt() * n();
                (0..len)
                    .map(|_| {
                        let e1 = n();
                        u = phi * u + (a * (1.0 - phi * phi)).sqrt() * n();
                        let d = e1 - e0 + u;
                        e0 = e1;
                        d
                    })
                    .collect()
            })
            .collect()
    }

    /// Differenced white noise is not flagged: 40 seeds at the 1 % level, at most 3 alarms
    /// (binomial(40, 0.01): P(≥ 4) ≈ 8e-4); seeds fixed.
    #[test]
    fn differenced_white_noise_is_white() {
        let alarms = (0..40)
            .filter(|&s| {
                let f = colour_fit(&periodogram(&series(s, 5, 1200, 0.0, 0.0))).unwrap();
                f.p < 0.01
            })
            .count();
        assert!(alarms <= 3, "{alarms} alarms in 40");
    }

    /// An AR(1) of a tenth of the noise's variance and a correlation time of 50 samples: found
    /// (p < 1e-6), its variance within 30 % and its correlation time within a factor 1.5.
    #[test]
    fn a_gauss_markov_component_is_found_with_its_size_and_time() {
        let phi = (-1.0_f64 / 50.0).exp();
        for seed in 0..3 {
            let f = colour_fit(&periodogram(&series(100 + seed, 5, 1200, 0.1, phi))).unwrap();
            let t = f.correlation_time_s(1.0);
            assert!(f.p < 1e-6, "seed {seed}: {f:?}");
            assert!(
                (f.ar_variance / 0.1 - 1.0).abs() < 0.3,
                "seed {seed}: {f:?}"
            );
            assert!((t / 50.0).max(50.0 / t) < 1.5, "seed {seed}: T = {t}");
        }
    }

    /// Three copies of one series: the joint fit is each copy's own (same `φ` and variances)
    /// with three times its likelihood ratio, tested against χ² with 4 degrees of freedom.
    #[test]
    fn the_joint_fit_of_copies_is_the_single_fit_three_times() {
        let o = periodogram(&series(7, 5, 1200, 0.05, (-1.0_f64 / 20.0).exp()));
        let (own, joint) = colour_fits(&[o.clone(), o.clone(), o]);
        let joint = joint.expect("joint fit");
        let single = own[0].clone().expect("own fit");
        for (j, s) in joint.iter().zip(&own) {
            let s = s.as_ref().expect("own fit");
            assert_eq!(j.phi, s.phi);
            assert_eq!(j.ar_variance, s.ar_variance);
        }
        assert!((joint[0].lr - 3.0 * single.lr).abs() < 1e-9 * single.lr.max(1.0));
        let p4 = 1.0 - chi_square_cdf(joint[0].lr, 4.0);
        assert!((joint[0].p - p4).abs() < 1e-12);
    }
}
