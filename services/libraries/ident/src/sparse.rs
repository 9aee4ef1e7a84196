//! Sparse regression of a residual on a library of candidate functions: which few terms carry
//! what the named causes leave, with blocked k-fold cross-validation and cluster-robust standard
//! errors. Pure functions on sufficient statistics.
//!
//! **Model.** One equation (a torque axis, a sensor channel): rows `y_i ≈ Σ_j θ_j x_ij + e_i`.
//! The first `forced` columns are always in the model (the named causes' own regressors, so
//! their parameters re-adjust jointly with any new term); the others are candidates.
//!
//! **Null hypothesis of every test here**: the residual has no component in the span of the
//! candidates; the errors may be correlated and heteroscedastic *within* a cluster (a segment of
//! the torque channel, a few seconds of filter innovations) but are independent *between*
//! clusters. Standard errors are therefore the cluster-robust (sandwich) ones, and a term's
//! statistic `z = θ/se` is compared with the normal quantile of a Bonferroni-corrected level
//! (the search looks at every candidate).
//!
//! **Search** (sequentially thresholded least squares, as in SINDy, with statistical rather
//! than magnitude thresholds):
//! 1. forward: add the candidate that most lowers the k-fold cross-validated residual sum;
//!    keep it only if it lowers it by at least `min_cv_gain` (relative) and its `|z|` beats the
//!    threshold; repeat;
//! 2. swaps: replace a term by another candidate while that lowers the cross-validated sum
//!    (a greedy step can pick a near-collinear stand-in);
//! 3. thresholding: refit, drop the weakest term if its `|z|` is below the threshold; repeat
//!    until every term passes.
//!
//! Folds are interleaved blocks of time (block b goes to fold `b mod k`), so a fold is held out
//! as whole clusters and a slow effect is interpolated, never fitted on its own samples.

use crate::stats::wald_statistic;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Sufficient statistics of one cluster of rows.
#[derive(Debug, Clone)]
struct Cluster {
    xtx: DMatrix<f64>,
    xty: DVector<f64>,
    yty: f64,
    n: usize,
    fold: usize,
    held_out: bool,
}

/// The rows of one equation: `x[i]` the regressors of row i, `y[i]` its residual,
/// `cluster[i]` its cluster (rows of a cluster need not be adjacent); the fold and the
/// held-out flag of a cluster are those of its first row.
#[derive(Debug, Clone, Copy)]
pub struct Rows<'a> {
    pub x: &'a [Vec<f64>],
    pub y: &'a [f64],
    pub cluster: &'a [usize],
    pub fold: &'a [usize],
    pub held_out: &'a [bool],
}

/// The rows of one equation, accumulated per cluster.
#[derive(Debug, Clone)]
pub struct Design {
    /// Column names (forced first).
    pub names: Vec<String>,
    /// Columns always in the model.
    pub forced: usize,
    /// RMS of each column over all rows (the scale the solver equilibrates with).
    scale: Vec<f64>,
    clusters: Vec<Cluster>,
    folds: usize,
    rows: usize,
    /// Sums over all clusters, over each fold's, and over the held-out ones (every solve reads
    /// these instead of summing the clusters again).
    total: Sums,
    per_fold: Vec<Sums>,
    held: Sums,
}

/// `XᵀX`, `Xᵀy`, `yᵀy` of a set of clusters (all columns).
#[derive(Debug, Clone)]
struct Sums {
    xtx: DMatrix<f64>,
    xty: DVector<f64>,
    yty: f64,
}

impl Sums {
    fn zero(p: usize) -> Self {
        Self {
            xtx: DMatrix::zeros(p, p),
            xty: DVector::zeros(p),
            yty: 0.0,
        }
    }
    fn add(&mut self, c: &Cluster) {
        self.xtx += &c.xtx;
        self.xty += &c.xty;
        self.yty += c.yty;
    }
}

/// The clusters a solve or a residual sum runs over.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Subset {
    All,
    Fold(usize),
    NotFold(usize),
    Held,
    NotHeld,
}

impl Design {
    /// Build from `rows` (each `x` row `names.len()` long), with `folds` folds.
    pub fn new(names: Vec<String>, forced: usize, rows: Rows, folds: usize) -> Self {
        let Rows {
            x,
            y,
            cluster,
            fold,
            held_out,
        } = rows;
        let p = names.len();
        let mut scale = vec![0.0; p];
        for row in x {
            for j in 0..p {
                scale[j] += row[j] * row[j];
            }
        }
        let n = x.len().max(1) as f64;
        for s in &mut scale {
            *s = (*s / n).sqrt();
        }
        let mut index: std::collections::HashMap<usize, usize> = Default::default();
        let mut clusters: Vec<Cluster> = Vec::new();
        let mut scaled = vec![0.0; p];
        for (i, row) in x.iter().enumerate() {
            let c = *index.entry(cluster[i]).or_insert_with(|| {
                clusters.push(Cluster {
                    xtx: DMatrix::zeros(p, p),
                    xty: DVector::zeros(p),
                    yty: 0.0,
                    n: 0,
                    fold: fold[i] % folds.max(1),
                    held_out: held_out[i],
                });
                clusters.len() - 1
            });
            for j in 0..p {
                scaled[j] = if scale[j] > 0.0 {
                    row[j] / scale[j]
                } else {
                    0.0
                };
            }
            let cl = &mut clusters[c];
            for a in 0..p {
                if scaled[a] == 0.0 {
                    continue;
                }
                cl.xty[a] += scaled[a] * y[i];
                for b in 0..=a {
                    cl.xtx[(a, b)] += scaled[a] * scaled[b];
                }
            }
            cl.yty += y[i] * y[i];
            cl.n += 1;
        }
        for cl in &mut clusters {
            for a in 0..p {
                for b in 0..a {
                    cl.xtx[(b, a)] = cl.xtx[(a, b)];
                }
            }
        }
        let folds = folds.max(2);
        let mut total = Sums::zero(p);
        let mut per_fold = vec![Sums::zero(p); folds];
        let mut held = Sums::zero(p);
        for c in &clusters {
            total.add(c);
            per_fold[c.fold % folds].add(c);
            if c.held_out {
                held.add(c);
            }
        }
        Self {
            names,
            forced,
            scale,
            clusters,
            folds,
            rows: x.len(),
            total,
            per_fold,
            held,
        }
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn clusters(&self) -> usize {
        self.clusters.len()
    }

    /// Sums over the clusters of `subset`, restricted to `cols`.
    fn sums(&self, cols: &[usize], subset: Subset) -> (DMatrix<f64>, DVector<f64>, f64) {
        let p = cols.len();
        let pick = |s: &Sums, sign: f64, a: &mut DMatrix<f64>, b: &mut DVector<f64>| {
            for (i, &ci) in cols.iter().enumerate() {
                b[i] += sign * s.xty[ci];
                for (j, &cj) in cols.iter().enumerate() {
                    a[(i, j)] += sign * s.xtx[(ci, cj)];
                }
            }
            sign * s.yty
        };
        let mut a = DMatrix::zeros(p, p);
        let mut b = DVector::zeros(p);
        let c = match subset {
            Subset::All => pick(&self.total, 1.0, &mut a, &mut b),
            Subset::Fold(f) => pick(&self.per_fold[f], 1.0, &mut a, &mut b),
            Subset::Held => pick(&self.held, 1.0, &mut a, &mut b),
            Subset::NotFold(f) => {
                pick(&self.total, 1.0, &mut a, &mut b)
                    + pick(&self.per_fold[f], -1.0, &mut a, &mut b)
            }
            Subset::NotHeld => {
                pick(&self.total, 1.0, &mut a, &mut b) + pick(&self.held, -1.0, &mut a, &mut b)
            }
        };
        (a, b, c)
    }

    /// Least squares on the clusters of `subset`; `None` if `cols` are (nearly) collinear
    /// there. Returns θ (scaled columns) and `(XᵀX)⁻¹`.
    fn solve(&self, cols: &[usize], subset: Subset) -> Option<(DVector<f64>, DMatrix<f64>)> {
        if cols.is_empty() {
            return Some((DVector::zeros(0), DMatrix::zeros(0, 0)));
        }
        let (a, b, _) = self.sums(cols, subset);
        let d: Vec<f64> = (0..cols.len()).map(|i| a[(i, i)]).collect();
        if d.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return None;
        }
        let s: Vec<f64> = d.iter().map(|x| 1.0 / x.sqrt()).collect();
        let eq = DMatrix::from_fn(cols.len(), cols.len(), |i, j| a[(i, j)] * s[i] * s[j]);
        let eig = eq.clone().symmetric_eigen();
        let (lo, hi) = eig
            .eigenvalues
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), &x| {
                (lo.min(x), hi.max(x))
            });
        // Collinear with the terms already in (or with the forced columns): not a new term.
        if lo.is_nan() || lo <= hi * 1e-9 {
            return None;
        }
        let inv_eq = eq.cholesky()?.inverse();
        let inv = DMatrix::from_fn(cols.len(), cols.len(), |i, j| inv_eq[(i, j)] * s[i] * s[j]);
        let theta = &inv * b;
        Some((theta, inv))
    }

    /// Residual sum of the clusters of `subset` at θ on `cols`.
    fn rss(&self, cols: &[usize], theta: &DVector<f64>, subset: Subset) -> f64 {
        let (a, b, c) = self.sums(cols, subset);
        if cols.is_empty() {
            return c;
        }
        (c - 2.0 * theta.dot(&b) + (theta.transpose() * &a * theta)[(0, 0)]).max(0.0)
    }

    /// k-fold cross-validated residual sum of `cols` (`None`: not determined in some fold).
    pub fn cv_rss(&self, cols: &[usize]) -> Option<f64> {
        let mut total = 0.0;
        for f in 0..self.folds {
            let (theta, _) = self.solve(cols, Subset::NotFold(f))?;
            total += self.rss(cols, &theta, Subset::Fold(f));
        }
        Some(total)
    }

    /// Residual sum on the held-out clusters of `cols` fitted on the others.
    pub fn held_out_rss(&self, cols: &[usize]) -> Option<f64> {
        let (theta, _) = self.solve(cols, Subset::NotHeld)?;
        Some(self.rss(cols, &theta, Subset::Held))
    }

    /// Fit on all rows: θ in the columns' own units, cluster-robust standard errors.
    pub fn fit(&self, cols: &[usize]) -> Option<(Vec<f64>, Vec<f64>)> {
        let (theta, cov) = self.fit_cov(cols)?;
        let se = (0..cols.len())
            .map(|i| cov[(i, i)].max(0.0).sqrt())
            .collect();
        Some((theta.iter().copied().collect(), se))
    }

    /// Fit on all rows: θ and its cluster-robust covariance, both in the columns' own units.
    pub fn fit_cov(&self, cols: &[usize]) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let (theta, cov) = self.sandwich(cols)?;
        let s = |i: usize| self.scale[cols[i]];
        let p = cols.len();
        Some((
            DVector::from_fn(p, |i, _| theta[i] / s(i)),
            DMatrix::from_fn(p, p, |i, j| cov[(i, j)] / (s(i) * s(j))),
        ))
    }

    /// Correlation of columns `a` and `b` over all rows (uncentred: `⟨a, b⟩ / (|a| |b|)`).
    pub fn correlation(&self, a: usize, b: usize) -> f64 {
        let (g, _, _) = self.sums(&[a, b], Subset::All);
        g[(0, 1)] / (g[(0, 0)] * g[(1, 1)]).sqrt().max(1e-300)
    }

    /// Residual sum over all rows at the least-squares fit of `cols` (`None`: not determined).
    pub fn fit_rss(&self, cols: &[usize]) -> Option<f64> {
        let (theta, _) = self.solve(cols, Subset::All)?;
        Some(self.rss(cols, &theta, Subset::All))
    }

    /// Cluster-robust Wald statistic `θ_Sᵀ V_SS⁻¹ θ_S` of the columns `cols[i]`, `i ∈ idx`, in the
    /// fit of `cols` on all rows (χ² on `idx.len()` degrees of freedom under the null that they
    /// are zero, residuals independent between clusters); `None` if not determined: `G`
    /// clusters determine the covariance of at most `G − 1` parameters (their scores sum to
    /// zero), and [`wald_statistic`] refuses a singular one.
    pub fn wald(&self, cols: &[usize], idx: &[usize]) -> Option<f64> {
        if idx.iter().any(|&i| i >= cols.len()) || self.clusters.len() <= idx.len() {
            return None;
        }
        let (theta, cov) = self.sandwich(cols)?;
        wald_statistic(&theta, &cov, idx)
    }

    /// Least squares on all rows with the cluster-robust (sandwich) covariance, both in the
    /// equilibrated columns.
    fn sandwich(&self, cols: &[usize]) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let (theta, inv) = self.solve(cols, Subset::All)?;
        let p = cols.len();
        // Meat: Σ_c s_c s_cᵀ with the cluster scores s_c = X_cᵀ r_c = X_cᵀy_c − X_cᵀX_c θ.
        let mut meat = DMatrix::<f64>::zeros(p, p);
        for cl in &self.clusters {
            let s = DVector::from_fn(p, |i, _| {
                cl.xty[cols[i]]
                    - (0..p)
                        .map(|j| cl.xtx[(cols[i], cols[j])] * theta[j])
                        .sum::<f64>()
            });
            meat += &s * s.transpose();
        }
        let g = self.clusters.len() as f64;
        // Small-sample factor of the sandwich (G/(G − 1)).
        let cov = (&inv * meat * &inv) * (g / (g - 1.0).max(1.0));
        Some((theta, cov))
    }

    /// Coefficients of `cols` fitted on the clusters of `subset`, in the columns' own units.
    fn fit_on(&self, cols: &[usize], subset: Subset) -> Option<Vec<f64>> {
        let (theta, _) = self.solve(cols, subset)?;
        Some(
            (0..cols.len())
                .map(|i| theta[i] / self.scale[cols[i]])
                .collect(),
        )
    }

    /// Mean square of the residual with no term at all (for gains).
    pub fn total_rss(&self) -> f64 {
        self.total.yty
    }
}

/// Settings of the search.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SparseOptions {
    /// Folds of the cross-validation.
    pub folds: usize,
    /// Family-wise significance level of the whole search in one equation (Bonferroni over the
    /// candidates).
    pub alpha: f64,
    /// Smallest relative reduction of the cross-validated residual sum for a term to be added.
    pub min_cv_gain: f64,
    /// Most terms per equation.
    pub max_terms: usize,
}

impl Default for SparseOptions {
    fn default() -> Self {
        Self {
            folds: 5,
            alpha: 1e-4,
            min_cv_gain: 0.01,
            max_terms: 6,
        }
    }
}

/// One term found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Term {
    pub name: String,
    /// Coefficient, in the residual's unit per unit of the candidate function.
    pub value: f64,
    /// Cluster-robust standard error.
    pub stderr: f64,
    /// Coefficient fitted without the held-out clusters (what a held-out prediction may use);
    /// equal to `value` when none is held out.
    pub value_fit_blocks: f64,
    /// Per fold f of the search's cross-validation, the coefficient fitted without the
    /// clusters of fold f (what a prediction of fold f may use).
    #[serde(skip)]
    pub value_without_fold: Vec<f64>,
}

/// What the search found in one equation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SparseResult {
    /// Forced columns, then the terms found, in their fitted values.
    pub forced: Vec<Term>,
    pub terms: Vec<Term>,
    /// |z| threshold used (two-sided normal quantile of `alpha / candidates`).
    pub z_threshold: f64,
    /// Cross-validated RMS ratio, forced columns only / with the terms (1: nothing found).
    pub cv_gain: f64,
    /// Cross-validated residual sum with the terms (of the forced columns alone if none).
    pub cv_rss: f64,
    /// Held-out RMS ratio (fit on the fit blocks, evaluated on the held-out blocks); with no
    /// block held out, the cross-validated ratio `cv_gain`.
    pub held_out_gain: f64,
}

/// Two-sided normal quantile: `z` with `P(|N(0,1)| > z) = p`.
pub fn normal_two_sided_quantile(p: f64) -> f64 {
    // Bisection on the complementary error function (monotone; 60 halvings).
    let tail = |z: f64| erfc(z / std::f64::consts::SQRT_2);
    let (mut lo, mut hi) = (0.0, 40.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if tail(mid) > p { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

/// Complementary error function (W. J. Cody's rational approximations via the continued
/// fraction for large x; relative error < 1e-12 over the range used here).
fn erfc(x: f64) -> f64 {
    if x < 0.0 {
        return 2.0 - erfc(-x);
    }
    if x < 3.0 {
        // Series of erf.
        let mut sum = x;
        let mut term = x;
        let x2 = x * x;
        for n in 1..200 {
            term *= -x2 / n as f64;
            let add = term / (2 * n + 1) as f64;
            sum += add;
            if add.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        1.0 - 2.0 / std::f64::consts::PI.sqrt() * sum
    } else {
        // Continued fraction (Lentz), converges fast for x ≥ 3.
        let mut f = x;
        let tiny = 1e-300;
        let mut c = x;
        let mut d = 0.0;
        for n in 1..200 {
            let a = n as f64 / 2.0;
            d = x + a * d;
            d = if d.abs() < tiny { tiny } else { d };
            c = x + a / c;
            c = if c.abs() < tiny { tiny } else { c };
            d = 1.0 / d;
            let delta = c * d;
            f *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (-x * x).exp() / f / std::f64::consts::PI.sqrt()
    }
}

/// The forced columns of `design` determined beside each other in this one equation (two
/// causes' columns proportional on a torque axis: the later one is left out).
pub fn determined_forced(design: &Design) -> Vec<usize> {
    let mut forced: Vec<usize> = Vec::new();
    for j in 0..design.forced {
        let mut cols = forced.clone();
        cols.push(j);
        if design.solve(&cols, Subset::All).is_some() {
            forced = cols;
        }
    }
    forced
}

/// Search one equation (see the module documentation).
pub fn search(design: &Design, options: &SparseOptions) -> SparseResult {
    let p = design.names.len();
    let forced = determined_forced(design);
    let nf = forced.len();
    let candidates = p - design.forced;
    let z_threshold = normal_two_sided_quantile(options.alpha / candidates.max(1) as f64);
    let base_cv = design.cv_rss(&forced).unwrap_or(design.total_rss());
    let mut active = forced.clone();
    let mut current = base_cv;
    let z_of = |cols: &[usize], j: usize| -> f64 {
        design
            .fit(cols)
            .and_then(|(v, s)| {
                let i = cols.iter().position(|c| *c == j)?;
                Some(v[i] / s[i])
            })
            .unwrap_or(0.0)
    };
    while active.len() - nf < options.max_terms {
        let best = (design.forced..p)
            .filter(|j| !active.contains(j))
            .filter_map(|j| {
                let mut cols = active.clone();
                cols.push(j);
                design.cv_rss(&cols).map(|cv| (j, cv))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((j, cv)) = best else { break };
        if cv > current * (1.0 - options.min_cv_gain) {
            break;
        }
        let mut cols = active.clone();
        cols.push(j);
        if z_of(&cols, j).abs() < z_threshold {
            break;
        }
        active = cols;
        current = cv;
    }
    // Swaps: greedy forward steps can pick a near-collinear stand-in (sin 2ψ for sin ψ over a
    // limited heading range); replace a term by another candidate while that lowers the
    // cross-validated residual sum.
    for _ in 0..10 {
        let mut best: Option<(usize, usize, f64)> = None;
        for i in nf..active.len() {
            for j in (design.forced..p).filter(|j| !active.contains(j)) {
                let mut cols = active.clone();
                cols[i] = j;
                if let Some(cv) = design.cv_rss(&cols)
                    && cv < current * (1.0 - 1e-9)
                    && best.is_none_or(|b| cv < b.2)
                {
                    best = Some((i, j, cv));
                }
            }
        }
        let Some((i, j, cv)) = best else { break };
        active[i] = j;
        current = cv;
    }
    // Thresholding: drop the weakest term while it is below the threshold.
    loop {
        let Some((values, se)) = design.fit(&active) else {
            active.truncate(nf);
            break;
        };
        let weakest = (nf..active.len())
            .map(|i| (i, (values[i] / se[i]).abs()))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match weakest {
            // A NaN statistic (undetermined term) is dropped too.
            Some((i, z)) if z.partial_cmp(&z_threshold) != Some(std::cmp::Ordering::Greater) => {
                active.remove(i);
            }
            _ => break,
        }
    }
    result_for(design, nf, &active, z_threshold, base_cv)
}

/// The search's result for the columns `active` (the first `nf` of them forced), with the
/// search's `z_threshold` and the cross-validated residual sum of the forced columns alone,
/// `base_cv`: every term's fit on all rows, without the held-out clusters and without each
/// fold, and the gains.
pub fn result_for(
    design: &Design,
    nf: usize,
    active: &[usize],
    z_threshold: f64,
    base_cv: f64,
) -> SparseResult {
    let forced = &active[..nf.min(active.len())];
    let (values, se) = design
        .fit(active)
        .unwrap_or((vec![f64::NAN; active.len()], vec![f64::NAN; active.len()]));
    let fit_blocks = design
        .fit_on(active, Subset::NotHeld)
        .unwrap_or_else(|| values.clone());
    let without_fold: Vec<Vec<f64>> = (0..design.folds)
        .map(|f| {
            design
                .fit_on(active, Subset::NotFold(f))
                .unwrap_or_else(|| values.clone())
        })
        .collect();
    let term = |i: usize| Term {
        name: design.names[active[i]].clone(),
        value: values[i],
        stderr: se[i],
        value_fit_blocks: fit_blocks[i],
        value_without_fold: without_fold.iter().map(|v| v[i]).collect(),
    };
    let cv = design.cv_rss(active).unwrap_or(base_cv);
    let cv_gain = if cv > 0.0 { (base_cv / cv).sqrt() } else { 1.0 };
    // No cluster held out (the selection uses all the data): the held-out gain is the
    // cross-validated one.
    let held_out_gain = if !design.clusters.iter().any(|c| c.held_out) {
        cv_gain
    } else {
        match (design.held_out_rss(forced), design.held_out_rss(active)) {
            (Some(a), Some(b)) if b > 0.0 => (a / b).sqrt(),
            _ => 1.0,
        }
    };
    SparseResult {
        forced: (0..nf).map(term).collect(),
        terms: (nf..active.len()).map(term).collect(),
        z_threshold,
        cv_gain,
        cv_rss: cv,
        held_out_gain,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Standard normal samples from a fixed seed (xorshift64* and Box–Muller; enough for a
    /// test's noise).
    struct Normal(u64);
    impl Normal {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn sample(&mut self) -> f64 {
            let (u, v) = (self.uniform(), self.uniform());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        }
    }

    #[test]
    fn normal_quantile_matches_tables() {
        // Two-sided 5 % → 1.959964; 1e-6 → 4.891638 (standard tables).
        assert!((normal_two_sided_quantile(0.05) - 1.959_964).abs() < 1e-5);
        assert!((normal_two_sided_quantile(1e-6) - 4.891_638).abs() < 1e-5);
    }

    /// Rows with `y = 2 x1 − 0.5 x1·t + noise` among 12 candidates: the search must find
    /// exactly those two terms, within 4 standard errors; on pure noise, none.
    #[test]
    fn finds_the_terms_that_carry_the_signal_and_none_in_noise() {
        let mut rng = Normal(0x9e37_79b9_7f4a_7c15);
        let n = 6000;
        let mut x = Vec::new();
        let mut y = Vec::new();
        let mut y0 = Vec::new();
        let mut cluster = Vec::new();
        let mut fold = Vec::new();
        for i in 0..n {
            let t = i as f64 / n as f64;
            let phase = i as f64 * 0.013;
            let row: Vec<f64> = (0..12)
                .map(|j| match j {
                    0 => phase.sin(),
                    1 => phase.sin() * t,
                    2 => t,
                    3 => 1.0,
                    _ => (phase * (j as f64) * 0.37).cos(),
                })
                .collect();
            let e = rng.sample();
            y.push(2.0 * row[0] - 0.5 * row[1] + 0.3 * e);
            y0.push(0.3 * e);
            x.push(row);
            cluster.push(i / 50);
            fold.push(i / 300);
        }
        let names: Vec<String> = (0..12).map(|j| format!("f{j}")).collect();
        let held: Vec<bool> = (0..n).map(|i| (i / 300) % 3 == 2).collect();
        let d = Design::new(
            names.clone(),
            0,
            Rows {
                x: &x,
                y: &y,
                cluster: &cluster,
                fold: &fold,
                held_out: &held,
            },
            5,
        );
        let r = search(&d, &SparseOptions::default());
        let mut found: Vec<&str> = r.terms.iter().map(|t| t.name.as_str()).collect();
        found.sort();
        assert_eq!(found, ["f0", "f1"], "{r:?}");
        for t in &r.terms {
            let truth = if t.name == "f0" { 2.0 } else { -0.5 };
            assert!((t.value - truth).abs() < 4.0 * t.stderr, "{t:?}");
        }
        assert!(r.held_out_gain > 2.0 && r.cv_gain > 2.0, "{r:?}");
        let d0 = Design::new(
            names,
            0,
            Rows {
                x: &x,
                y: &y0,
                cluster: &cluster,
                fold: &fold,
                held_out: &held,
            },
            5,
        );
        let r0 = search(&d0, &SparseOptions::default());
        assert!(r0.terms.is_empty(), "{r0:?}");
    }
}
