//! Statistics: linear least squares with covariance, and the description of a residual series
//! (RMS, bias, trend, whiteness). Pure functions.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

pub use testbed_flight::stats::{chi_square_cdf, chi_square_quantile};

/// Accumulated normal equations of `y ≈ X θ` (rows added one at a time, already weighted).
#[derive(Debug, Clone)]
pub struct NormalEquations {
    xtx: DMatrix<f64>,
    xty: DVector<f64>,
    yty: f64,
    n: usize,
}

/// A least-squares solution.
#[derive(Debug, Clone)]
pub struct LsFit {
    /// Estimate θ̂.
    pub theta: DVector<f64>,
    /// `(XᵀX)⁻¹` (the covariance for unit-variance rows).
    pub cov_unit: DMatrix<f64>,
    /// Residual sum of squares at θ̂.
    pub rss: f64,
    /// Rows.
    pub n: usize,
}

impl LsFit {
    /// Residual variance estimate `RSS / (n − p)` (1 when there are no spare rows).
    pub fn sigma2(&self) -> f64 {
        let dof = self.n.saturating_sub(self.theta.len());
        if dof == 0 { 1.0 } else { self.rss / dof as f64 }
    }
    /// Covariance of θ̂ with the variance estimated from the residuals.
    pub fn cov(&self) -> DMatrix<f64> {
        &self.cov_unit * self.sigma2()
    }
    /// Standard errors (residual-scaled).
    pub fn stderr(&self) -> Vec<f64> {
        let s2 = self.sigma2();
        (0..self.theta.len())
            .map(|i| (self.cov_unit[(i, i)] * s2).max(0.0).sqrt())
            .collect()
    }

    /// Cluster-robust (sandwich) Wald statistic `θ_Sᵀ V_SS⁻¹ θ_S` of the parameters `idx`, with
    /// `V = A (Σ_c s_c s_cᵀ) A`, `A = (XᵀX)⁻¹` and `scores[c] = s_c = Σ_{r ∈ c} x_r e_r` the
    /// score of cluster c at θ̂ (rows in the fit's units). Under the null (those parameters
    /// zero) it is χ² on `|idx|` degrees of freedom when the residuals are independent between
    /// clusters, whatever their correlation within one.
    ///
    /// `None` when the clusters do not determine `V_SS`: the scores sum to zero at θ̂, so `G`
    /// clusters give a sandwich of rank at most `G − 1`, and `|idx|` parameters need more; and
    /// when [`wald_statistic`] finds it singular.
    pub fn cluster_robust_wald(&self, scores: &[DVector<f64>], idx: &[usize]) -> Option<f64> {
        let p = self.theta.len();
        if idx.is_empty() || idx.iter().any(|&j| j >= p) {
            return None;
        }
        let k = idx.len();
        let scores: Vec<&DVector<f64>> = scores.iter().filter(|s| s.len() == p).collect();
        if scores.len() <= k {
            return None;
        }
        let mut meat = DMatrix::<f64>::zeros(p, p);
        for s in scores {
            meat += s * s.transpose();
        }
        let v = &self.cov_unit * meat * &self.cov_unit;
        wald_statistic(&self.theta, &v, idx)
    }
}

/// Wald statistic `θ_Sᵀ V_SS⁻¹ θ_S` of the parameters `idx` of `theta` with covariance `v`, or
/// `None` when `V_SS` is not determined: a variance that is not positive, or, scaled to unit
/// diagonal, an eigenvalue below [`MIN_CORRELATION_EIGEN`] (its inverse would be rounding, of
/// either sign).
pub fn wald_statistic(theta: &DVector<f64>, v: &DMatrix<f64>, idx: &[usize]) -> Option<f64> {
    let k = idx.len();
    let scale: Vec<f64> = idx.iter().map(|&j| v[(j, j)].sqrt()).collect();
    if k == 0 || !scale.iter().all(|d| d.is_finite() && *d > 0.0) {
        return None;
    }
    let correlation = DMatrix::from_fn(k, k, |a, b| v[(idx[a], idx[b])] / (scale[a] * scale[b]));
    let z = DVector::from_fn(k, |a, _| theta[idx[a]] / scale[a]);
    let eigen = correlation.symmetric_eigen();
    if eigen
        .eigenvalues
        .iter()
        .any(|&l| l.is_nan() || l <= MIN_CORRELATION_EIGEN)
    {
        return None;
    }
    let w: f64 = eigen
        .eigenvalues
        .iter()
        .zip(eigen.eigenvectors.column_iter())
        .map(|(l, u)| u.dot(&z).powi(2) / l)
        .sum();
    w.is_finite().then_some(w)
}

/// Smallest eigenvalue of a covariance scaled to unit diagonal that [`wald_statistic`] inverts: a condition number of about 1e10, far beyond any real correlation of the test bed's
/// parameters and far above rounding (1e-16).
pub const MIN_CORRELATION_EIGEN: f64 = 1e-10;

impl NormalEquations {
    pub fn new(p: usize) -> Self {
        Self {
            xtx: DMatrix::zeros(p, p),
            xty: DVector::zeros(p),
            yty: 0.0,
            n: 0,
        }
    }

    pub fn params(&self) -> usize {
        self.xty.len()
    }

    pub fn rows(&self) -> usize {
        self.n
    }

    /// Add the row `y ≈ x·θ`.
    pub fn add(&mut self, x: &[f64], y: f64) {
        let p = self.xty.len();
        debug_assert_eq!(x.len(), p);
        for i in 0..p {
            if x[i] == 0.0 {
                continue;
            }
            self.xty[i] += x[i] * y;
            for j in 0..=i {
                self.xtx[(i, j)] += x[i] * x[j];
            }
        }
        self.yty += y * y;
        self.n += 1;
    }

    /// Merge another accumulation of the same shape.
    pub fn merge(&mut self, other: &NormalEquations) {
        self.xtx += &other.xtx;
        self.xty += &other.xty;
        self.yty += other.yty;
        self.n += other.n;
    }

    /// `Σ y²` (the RSS at θ = 0).
    pub fn yty(&self) -> f64 {
        self.yty
    }

    /// Solve by Cholesky after equilibrating the columns; `None` if a parameter is not
    /// determined by the rows (a column is zero, or the equilibrated `XᵀX` has a condition number
    /// beyond 1e12).
    pub fn solve(&self) -> Option<LsFit> {
        let p = self.xty.len();
        let mut a = self.xtx.clone();
        for i in 0..p {
            for j in 0..i {
                a[(j, i)] = a[(i, j)];
            }
        }
        let d: Vec<f64> = (0..p).map(|i| a[(i, i)]).collect();
        if d.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return None;
        }
        let s: Vec<f64> = d.iter().map(|x| 1.0 / x.sqrt()).collect();
        let scaled = DMatrix::from_fn(p, p, |i, j| a[(i, j)] * s[i] * s[j]);
        let eig = scaled.clone().symmetric_eigen();
        let (min, max) = eig
            .eigenvalues
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), &x| {
                (lo.min(x), hi.max(x))
            });
        if min.is_nan() || min <= max * 1e-12 {
            return None;
        }
        let inv_scaled = scaled.cholesky()?.inverse();
        let cov_unit = DMatrix::from_fn(p, p, |i, j| inv_scaled[(i, j)] * s[i] * s[j]);
        let theta = &cov_unit * &self.xty;
        let rss = (self.yty - theta.dot(&self.xty)).max(0.0);
        Some(LsFit {
            theta,
            cov_unit,
            rss,
            n: self.n,
        })
    }

    /// The whole symmetric `XᵀX` (for rows whitened to unit variance, the Fisher information of
    /// θ).
    pub fn information(&self) -> DMatrix<f64> {
        let p = self.xty.len();
        DMatrix::from_fn(p, p, |i, j| {
            if j <= i {
                self.xtx[(i, j)]
            } else {
                self.xtx[(j, i)]
            }
        })
    }

    /// Diagonal element `(XᵀX)_jj`: the weight of column j.
    pub fn diag(&self, j: usize) -> f64 {
        self.xtx[(j, j)]
    }

    /// The problem in the unknowns `free` with every other unknown held at its entry of
    /// `values` (moved to the observations' side).
    pub fn reduce(&self, free: &[usize], values: &[f64]) -> Option<NormalEquations> {
        let p = self.xty.len();
        let a = |i: usize, j: usize| {
            if j <= i {
                self.xtx[(i, j)]
            } else {
                self.xtx[(j, i)]
            }
        };
        let fixed: Vec<usize> = (0..p).filter(|j| !free.contains(j)).collect();
        let mut out = NormalEquations::new(free.len());
        for (r, &i) in free.iter().enumerate() {
            for (c, &j) in free.iter().enumerate().take(r + 1) {
                out.xtx[(r, c)] = a(i, j);
            }
            out.xty[r] = self.xty[i] - fixed.iter().map(|&f| a(i, f) * values[f]).sum::<f64>();
        }
        let mut yty = self.yty;
        for &f in &fixed {
            yty -= 2.0 * values[f] * self.xty[f];
            for &g in &fixed {
                yty += values[f] * a(f, g) * values[g];
            }
        }
        out.yty = yty.max(0.0);
        out.n = self.n;
        Some(out)
    }

    /// RSS at a given θ: `yᵀy − 2θᵀXᵀy + θᵀXᵀXθ`.
    pub fn rss_at(&self, theta: &DVector<f64>) -> f64 {
        let p = self.xty.len();
        let mut quad = 0.0;
        for i in 0..p {
            for j in 0..p {
                let a = if j <= i {
                    self.xtx[(i, j)]
                } else {
                    self.xtx[(j, i)]
                };
                quad += theta[i] * a * theta[j];
            }
        }
        (self.yty - 2.0 * theta.dot(&self.xty) + quad).max(0.0)
    }
}

/// Description of one residual series.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SeriesStats {
    /// Samples.
    pub n: usize,
    /// Root mean square (unit of the series).
    pub rms: f64,
    /// Mean (bias).
    pub mean: f64,
    /// Least-squares slope against time, unit per hour.
    pub trend_per_h: f64,
    /// Its standard error, unit per hour.
    pub trend_stderr_per_h: f64,
    /// Lag-1 autocorrelation (consecutive samples of the series).
    pub lag1: f64,
    /// Ljung–Box statistic over lags 1..=`lags`.
    ///
    /// Not in the report: the residuals described (multi-step prediction errors over a window,
    /// the integrated momentum residual, filter innovations) are serially correlated by
    /// construction, so the white-noise null is the wrong one for them (clean data gave
    /// `white_p` = 0). Structure is judged by the unexplained-effect search instead, and
    /// whiteness on what should be white (the increments of the momentum residual, the
    /// normalised innovations alone) by `identify`'s whiteness report.
    #[serde(skip)]
    pub ljung_box: f64,
    /// Lags of the Ljung–Box statistic.
    #[serde(skip)]
    pub lags: usize,
    /// Probability of a statistic at least this large for white noise (χ² with `lags` dof).
    #[serde(skip)]
    pub white_p: f64,
}

/// RMS, bias, trend and whiteness of `x` sampled at times `t` (s).
pub fn series_stats(t: &[f64], x: &[f64], lags: usize) -> SeriesStats {
    let n = x.len();
    let nf = n.max(1) as f64;
    let mean = x.iter().sum::<f64>() / nf;
    let rms = (x.iter().map(|v| v * v).sum::<f64>() / nf).sqrt();
    let tm = t.iter().sum::<f64>() / nf;
    let stt: f64 = t.iter().map(|ti| (ti - tm).powi(2)).sum();
    let stx: f64 = t
        .iter()
        .zip(x)
        .map(|(ti, xi)| (ti - tm) * (xi - mean))
        .sum();
    let slope = if stt > 0.0 { stx / stt } else { 0.0 };
    let resid_var = if n > 2 {
        t.iter()
            .zip(x)
            .map(|(ti, xi)| (xi - mean - slope * (ti - tm)).powi(2))
            .sum::<f64>()
            / (n - 2) as f64
    } else {
        0.0
    };
    let slope_se = if stt > 0.0 {
        (resid_var / stt).sqrt()
    } else {
        f64::NAN
    };
    let var: f64 = x.iter().map(|v| (v - mean).powi(2)).sum();
    let acf = |k: usize| -> f64 {
        if var <= 0.0 || k >= n {
            return 0.0;
        }
        (0..n - k)
            .map(|i| (x[i] - mean) * (x[i + k] - mean))
            .sum::<f64>()
            / var
    };
    let lags = lags.min(n.saturating_sub(2)).max(1);
    let q: f64 = (1..=lags)
        .map(|k| acf(k).powi(2) / (nf - k as f64).max(1.0))
        .sum::<f64>()
        * nf
        * (nf + 2.0);
    SeriesStats {
        n,
        rms,
        mean,
        trend_per_h: slope * 3600.0,
        trend_stderr_per_h: slope_se * 3600.0,
        lag1: acf(1),
        ljung_box: q,
        lags,
        white_p: 1.0 - chi_square_cdf(q, lags as f64),
    }
}

/// Pearson correlation of two equally long series (0 if either is constant).
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if n < 2 {
        return 0.0;
    }
    let ma = a[..n].iter().sum::<f64>() / n as f64;
    let mb = b[..n].iter().sum::<f64>() / n as f64;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (da, db) = (a[i] - ma, b[i] - mb);
        sab += da * db;
        saa += da * da;
        sbb += db * db;
    }
    if saa <= 0.0 || sbb <= 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

/// Standard normal samples from a fixed linear congruential generator (Box–Muller): the same
/// noise on every run, for tests.
#[cfg(test)]
pub(crate) fn normals(n: usize, mut state: u64) -> Vec<f64> {
    let mut uniform = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let (a, b) = (uniform(), uniform());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_squares_recovers_a_line_with_its_covariance() {
        let mut ne = NormalEquations::new(2);
        // y = 2 + 3x exactly, badly scaled columns.
        for i in 0..100 {
            let x = i as f64 * 1e-6;
            ne.add(&[1.0, x], 2.0 + 3e6 * x);
        }
        let fit = ne.solve().unwrap();
        assert!(
            (fit.theta[0] - 2.0).abs() < 1e-9 && (fit.theta[1] - 3e6).abs() < 1e-3,
            "{:?}",
            fit.theta
        );
        assert!(fit.rss < 1e-9 * ne.yty(), "{}", fit.rss);
        assert!((ne.rss_at(&fit.theta) - fit.rss).abs() < 1e-9);
        // A column that is identically zero is not determined.
        let mut ne = NormalEquations::new(2);
        for i in 0..10 {
            ne.add(&[1.0, 0.0], i as f64);
        }
        assert!(ne.solve().is_none());
    }

    /// Rows repeated within a cluster carry no new information: the naive Wald statistic grows
    /// with the repetition, the cluster-robust one does not (it is the same as for the rows
    /// once, to rounding), and for independent rows it is close to the naive one.
    #[test]
    fn cluster_robust_wald_ignores_rows_repeated_within_a_cluster() {
        let mut state = 2024u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let rows: Vec<(f64, f64, f64)> = (0..400)
            .map(|_| {
                let (a, b) = (uniform(), uniform());
                (a, b, 0.05 * a + uniform())
            })
            .collect();
        // (naive Wald of θ_1, cluster-robust Wald of θ_1) with each row `m` times in its cluster.
        let wald = |m: usize| {
            let mut ne = NormalEquations::new(2);
            for &(a, b, y) in &rows {
                for _ in 0..m {
                    ne.add(&[a, b], y);
                }
            }
            let fit = ne.solve().expect("determined");
            let scores: Vec<DVector<f64>> = rows
                .iter()
                .map(|&(a, b, y)| {
                    let e = y - fit.theta[0] * a - fit.theta[1] * b;
                    DVector::from_vec(vec![a * e * m as f64, b * e * m as f64])
                })
                .collect();
            let naive = fit.theta[0] * fit.theta[0] / fit.cov()[(0, 0)];
            (
                naive,
                fit.cluster_robust_wald(&scores, &[0]).expect("invertible"),
            )
        };
        let (naive1, robust1) = wald(1);
        let (naive4, robust4) = wald(4);
        assert!((naive4 / naive1 - 4.0).abs() < 0.05, "{naive1} {naive4}");
        assert!(
            (robust4 / robust1 - 1.0).abs() < 1e-9,
            "{robust1} {robust4}"
        );
        assert!((robust1 / naive1 - 1.0).abs() < 0.3, "{robust1} {naive1}");
        assert!(fit_none_for_bad_index());
    }

    /// Two clusters cannot determine the covariance of two parameters (the scores sum to zero,
    /// so their sandwich has rank one): not determined, where inverting it gave rounding of
    /// either sign. With many clusters the statistic is the direct `θ_Sᵀ V_SS⁻¹ θ_S`.
    #[test]
    fn cluster_robust_wald_is_not_determined_by_too_few_clusters() {
        let mut ne = NormalEquations::new(2);
        let rows: Vec<([f64; 2], f64, usize)> = (0..40)
            .map(|i| {
                let a = (i as f64 * 0.37).sin();
                let b = (i as f64 * 1.3).cos();
                ([a, b], 0.2 * a - 0.1 * b + 0.05 * (i as f64 * 2.1).sin(), i)
            })
            .collect();
        for (x, y, _) in &rows {
            ne.add(x, *y);
        }
        let fit = ne.solve().expect("determined");
        let scores_of = |clusters: usize| -> Vec<DVector<f64>> {
            let mut s = vec![DVector::zeros(2); clusters];
            for (x, y, i) in &rows {
                let e = y - fit.theta[0] * x[0] - fit.theta[1] * x[1];
                s[i % clusters] += DVector::from_column_slice(x) * e;
            }
            s
        };
        assert_eq!(fit.cluster_robust_wald(&scores_of(2), &[0, 1]), None);
        assert!(fit.cluster_robust_wald(&scores_of(2), &[0]).is_some());
        let scores = scores_of(40);
        let mut meat = DMatrix::zeros(2, 2);
        for s in &scores {
            meat += s * s.transpose();
        }
        let v = &fit.cov_unit * meat * &fit.cov_unit;
        let direct =
            (fit.theta.transpose() * v.try_inverse().expect("invertible") * &fit.theta)[(0, 0)];
        let w = fit
            .cluster_robust_wald(&scores, &[0, 1])
            .expect("determined");
        assert!((w / direct - 1.0).abs() < 1e-9, "{w} against {direct}");
    }

    fn fit_none_for_bad_index() -> bool {
        let mut ne = NormalEquations::new(1);
        ne.add(&[1.0], 1.0);
        ne.add(&[1.0], 2.0);
        let fit = ne.solve().expect("determined");
        fit.cluster_robust_wald(&[], &[3]).is_none() && fit.cluster_robust_wald(&[], &[]).is_none()
    }

    #[test]
    fn white_noise_passes_and_a_trend_is_seen() {
        // A deterministic pseudo-random sequence (LCG) is white enough for the test.
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let t: Vec<f64> = (0..2000).map(|i| i as f64).collect();
        let x: Vec<f64> = (0..2000).map(|_| next()).collect();
        let s = series_stats(&t, &x, 10);
        assert!(s.white_p > 1e-3, "{s:?}");
        assert!(s.lag1.abs() < 0.1);
        let y: Vec<f64> = t.iter().zip(&x).map(|(ti, xi)| xi + 1e-3 * ti).collect();
        let s = series_stats(&t, &y, 10);
        assert!((s.trend_per_h - 3.6).abs() < 0.2, "{s:?}");
        assert!(s.white_p < 1e-6);
    }
}
