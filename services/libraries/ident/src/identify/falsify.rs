//! Falsification of the named causes: a cause is kept only if it survives these tests.
//!
//! 1. **Consistency across time blocks.** The record is cut into `blocks` disjoint blocks of
//!    equal duration; in each, the named torque causes and the unexplained torque terms are
//!    fitted jointly (weighted least squares on the torque channel, the residual variance
//!    estimated in the block). Null: the cause's parameters are the same in every block. The
//!    statistic `χ² = Σ_b (θ_b − θ̄)ᵀ C_b⁻¹ (θ_b − θ̄)` (θ̄ the precision-weighted mean) has
//!    `(blocks − 1)·k` degrees of freedom under the null; the cause fails at `p < alpha`. A
//!    time- or state-dependent effect absorbed into a constant cause makes its blocks disagree.
//! 2. **Significance beside the unexplained effect.** The cause must still beat the selection's
//!    threshold (`max(k ln N, χ²_k(1 − alpha))` on the likelihood ratio of the fit data) when
//!    the unexplained terms are in the model: a library cause that only stood in for an
//!    effect of another form is dropped. Torque causes must beat it by the likelihood ratio
//!    (independent residuals) and by the cluster-robust Wald statistic of their parameters
//!    (residuals correlated within a segment of the torque channel, as the search assumes).
//! 3. **No explanation of another kind** (torque and wheel causes). The channel's search (the
//!    torque search, or the wheel search for a wheel cause) is redone without the cause and
//!    without the candidate functions of its own form. The cause is dropped if
//!    that search's cross-validated residual sum is more than 1 % below the one with it, or if
//!    that sum is not above it and the cause is not significant (the same threshold,
//!    likelihood ratio and cluster-robust Wald) beside the terms that search finds (a search
//!    that predicts worse may have found a mimic of the cause's form: a true constant torque
//!    was lost so): the terms of test 2 were found with the cause
//!    in the model, and a cause that stood in for part of an effect shapes them (a constant
//!    torque takes the offset of a heading torque, and the search then settles on the wrong
//!    harmonic, which leaves a trade between the constant torque and a centre-of-mass offset
//!    that grows significant with the rows of the fit).
//!
//! Torque causes are linear in the torque channel; sensor causes are linearised through the
//! attitude filter (forward differences, one filter run per parameter) and tested on the
//! innovations the same way. Wheel causes are linear (or linearised, the delay) in the wheel
//! equation and are tested there, with the whiteness of that equation's residuals as a fourth
//! test (see `wheel`). [`significance_beside`] and [`compete`] are shared by the torque and
//! wheel channels.

use super::unexplained::UnexplainedEffect;
use crate::effects::Cause;
use crate::sparse::SparseOptions;
use crate::stats::{LsFit, NormalEquations, chi_square_cdf, chi_square_quantile};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Outcome of the tests of one named cause.
#[derive(Debug, Clone, Serialize)]
pub struct CauseTest {
    pub name: &'static str,
    pub kept: bool,
    /// Consistency across time blocks (`None`: not tested for this kind of cause, or not
    /// determined in every block).
    pub consistency: Option<Consistency>,
    /// Likelihood ratio of the cause beside the unexplained terms, and its threshold (`None`:
    /// no unexplained torque term, the selection's test stands).
    pub joint_lr: Option<f64>,
    /// The cluster-robust Wald statistic of the cause's parameters in the same joint fit
    /// (torque causes; clusters are the torque channel's segments): the likelihood ratio
    /// assumes independent residuals, and the cause must beat the threshold by both.
    pub joint_wald: Option<f64>,
    pub joint_threshold: Option<f64>,
    /// Whiteness of the extended equation's residuals (wheel causes: the wheel equation with
    /// the named causes and the unexplained wheel terms; `None` for other causes).
    pub whiteness: Option<Whiteness>,
    /// The competing explanation (torque and wheel causes; `None`: not run, e.g. the cause had
    /// failed an earlier test, or the channel is too short).
    pub competitor: Option<Competitor>,
    /// The test that failed: `consistency`, `joint` (significance beside the others and the
    /// unexplained effects), `competitor` (a generic form explains its part better),
    /// `whiteness`; `None` when kept.
    pub failed: Option<&'static str>,
    /// In words: kept, or which test failed.
    pub verdict: String,
}

impl CauseTest {
    /// A cause kept on its selection test alone: the falsification tests could not run
    /// (`why`).
    pub(crate) fn not_tested(cause: Cause, why: &str) -> Self {
        Self {
            name: cause.name(),
            kept: true,
            consistency: None,
            joint_lr: None,
            joint_wald: None,
            joint_threshold: None,
            whiteness: None,
            competitor: None,
            failed: None,
            verdict: format!("kept (selection test; {why})"),
        }
    }
}

/// The whiteness test of an equation's residuals (the worst of the wheels tested).
#[derive(Debug, Clone, Serialize)]
pub struct Whiteness {
    /// The worst wheel (0 = X).
    pub wheel: usize,
    /// Ljung–Box statistic and its lags.
    pub ljung_box: f64,
    pub lags: usize,
    /// Its p value, multiplied by the number of wheels tested (Bonferroni), at most 1.
    pub p: f64,
    /// Wheels tested.
    pub wheels: usize,
}

/// The competing-explanation test of one cause: its channel's sparse search redone without
/// the cause and without the candidate functions of its own form.
#[derive(Debug, Clone, Serialize)]
pub struct Competitor {
    /// Cross-validated residual sums of the search with the cause and without it (each
    /// channel's rows whitened by their noise).
    pub cv_with: f64,
    pub cv_without: f64,
    /// The terms the search without it found (`none`).
    pub form: String,
    /// The cause's significance beside those terms: likelihood ratio, cluster-robust Wald
    /// statistic and the selection's threshold (`None`: not computed, because the search
    /// without the cause predicts worse out of fold or the joint fit was not determined).
    pub lr: Option<f64>,
    pub wald: Option<f64>,
    pub threshold: Option<f64>,
}

impl CauseTest {
    /// How clearly the cause failed (for dropping the worst first): the consistency statistic
    /// as a normal score `(χ² − dof)/√(2 dof)`, else how far the likelihood ratio falls short of
    /// its threshold (relative); negative for a kept cause.
    pub fn severity(&self) -> f64 {
        if self.kept {
            return -1.0;
        }
        if let (Some("whiteness"), Some(w)) = (self.failed, &self.whiteness) {
            let dof = w.lags.max(1) as f64;
            return (w.ljung_box - dof) / (2.0 * dof).sqrt();
        }
        match (&self.consistency, self.joint_lr, self.joint_threshold) {
            (Some(c), _, _) if c.p < 1.0 && self.failed == Some("consistency") => {
                (c.chi2 - c.dof as f64) / (2.0 * c.dof as f64).sqrt()
            }
            (_, Some(lr), Some(th)) => {
                1.0 - lr.min(self.joint_wald.unwrap_or(f64::INFINITY)) / th.max(1e-300)
            }
            _ => 0.0,
        }
    }
}

/// The block-consistency test of one cause.
#[derive(Debug, Clone, Serialize)]
pub struct Consistency {
    pub blocks: usize,
    pub chi2: f64,
    pub dof: usize,
    pub p: f64,
    /// Per block: the cause's values (changes from the base configuration, per column) and
    /// standard errors.
    pub values: Vec<Vec<f64>>,
    pub stderr: Vec<Vec<f64>>,
    /// The same blocks against a linear trend in time (`None` with fewer than three blocks).
    pub trend: Option<Trend>,
    /// The terms of another form the blocks were fitted beside, when they disagreed without
    /// them (`equation: function` each, e.g. `torque_z: cos ψ`; empty: only the terms found
    /// with the cause).
    pub beside: Vec<String>,
}

/// The block values of a cause against a linear trend, `θ_b = a + ṙ (t_b − t̄)` (`t_b` the
/// blocks' mid-times), fitted by the same weights: when the constant fails and the trend fits
/// (`p` at or above the consistency level) with a rate significantly non-zero, the parameter
/// drifts (a trend, not a state-dependent effect).
#[derive(Debug, Clone, Serialize)]
pub struct Trend {
    pub chi2: f64,
    pub dof: usize,
    pub p: f64,
    /// Rate of each value per second (configuration units / s), and its standard error.
    pub rate_per_s: Vec<f64>,
    pub rate_stderr: Vec<f64>,
    /// Wald statistic of the rates (`k` degrees of freedom) and its p value.
    pub rate_wald: f64,
    pub rate_p: f64,
}

impl Trend {
    /// Whether the blocks say "a drift": the trend fits at `alpha` and its rate is non-zero at
    /// `alpha`.
    pub fn drifts(&self, alpha: f64) -> bool {
        self.p >= alpha && self.rate_p < alpha
    }
}

/// The tests a cause failed, in the order its verdict names them: the first is the one it is
/// dropped for ([`CauseTest::failed`]), the others are named after it.
#[derive(Default)]
pub(super) struct Failures(Vec<(&'static str, String)>);

impl Failures {
    /// Whether no test has failed (so far).
    pub fn none(&self) -> bool {
        self.0.is_empty()
    }

    /// The test `test` failed; `text` says how, in words.
    pub fn add(&mut self, test: &'static str, text: String) {
        self.0.push((test, text));
    }
}

/// The statistics of a cause's tests, as [`CauseTest`] reports them (`None`: not run).
#[derive(Default)]
pub(super) struct Evidence {
    pub consistency: Option<Consistency>,
    pub joint_lr: Option<f64>,
    pub joint_wald: Option<f64>,
    pub joint_threshold: Option<f64>,
    pub whiteness: Option<Whiteness>,
    pub competitor: Option<Competitor>,
}

impl CauseTest {
    /// The verdict on `cause`, the same in every channel: kept when it failed no test, in the
    /// words of `consistent` (its block consistency, the channel's other tests passed); else
    /// dropped for its first failure, the others named after it.
    pub(super) fn verdict(
        cause: Cause,
        evidence: Evidence,
        failures: Failures,
        consistent: impl FnOnce(&Consistency) -> String,
    ) -> Self {
        let Evidence {
            consistency,
            joint_lr,
            joint_wald,
            joint_threshold,
            whiteness,
            competitor,
        } = evidence;
        let kept = failures.none();
        let failed = failures.0.first().map(|f| f.0);
        let verdict = match failures.0.split_first() {
            Some(((_, text), [])) => text.clone(),
            Some(((_, text), more)) => format!(
                "{text}; it also fails its {} test{}",
                more.iter().map(|f| f.0).collect::<Vec<_>>().join(" and "),
                if more.len() > 1 { "s" } else { "" }
            ),
            None => consistency.as_ref().map_or_else(
                || "kept (block consistency not determined)".into(),
                consistent,
            ),
        };
        Self {
            name: cause.name(),
            kept,
            consistency,
            joint_lr,
            joint_wald,
            joint_threshold,
            whiteness,
            competitor,
            failed,
            verdict,
        }
    }
}

/// How much better (relative drop of the cross-validated residual sum) a competing generic
/// form must explain a named cause's part for the cause to be dropped: ties go to the library
/// cause, the physical explanation.
const COMPETITOR_MARGIN: f64 = 0.01;

/// Settings of the tests.
pub(super) struct Levels<'a> {
    /// Disjoint time blocks of the consistency test.
    pub blocks: usize,
    /// Level of the consistency test.
    pub consistency: f64,
    /// The selection's level (its threshold is `max(k ln N, χ²_k(1 − selection))`).
    pub selection: f64,
    /// `N`: scalar residuals in the fit data.
    pub n_fit: f64,
    /// The unexplained-effect search's blocks and settings (for the competing explanation).
    pub block_s: f64,
    pub sparse: &'a SparseOptions,
}

impl<'a> Levels<'a> {
    /// The run's levels, from its options; `n_fit` scalar residuals in the fit data.
    pub(super) fn new(options: &'a super::Options, n_fit: f64) -> Self {
        Self {
            blocks: options.consistency_blocks,
            consistency: options.consistency_alpha,
            selection: options.alpha,
            n_fit,
            block_s: options.block_s,
            sparse: &options.sparse,
        }
    }

    /// The test of a cause beside the others: the likelihood ratio `n ln(RSS_without /
    /// RSS_with)` of `n` residuals, and the selection's threshold for its `k` parameters,
    /// `max(k ln N, χ²_k(1 − selection))`.
    pub(super) fn joint(&self, n: f64, rss_without: f64, rss_with: f64, k: usize) -> (f64, f64) {
        let lr = n * (rss_without / rss_with.max(1e-300)).ln();
        (lr, self.threshold(k))
    }

    /// The selection's threshold for `k` parameters, `max(k ln N, χ²_k(1 − selection))`.
    pub(super) fn threshold(&self, k: usize) -> f64 {
        (k as f64 * self.n_fit.ln())
            .max(chi_square_quantile(1.0 - self.selection, k as f64).unwrap_or(f64::INFINITY))
    }
}

pub(super) fn falsified_text(c: &Consistency, alpha: f64) -> String {
    let differ = format!(
        "falsified: its parameters differ between {} time blocks (χ² = {:.1} on {} degrees of freedom, p = {:.1e} < {:.0e})",
        c.blocks, c.chi2, c.dof, c.p, alpha
    );
    match &c.trend {
        Some(t) if t.drifts(alpha) => format!(
            "{differ}, and follow a linear trend (χ² = {:.1} on {} degrees of freedom, p = {:.2}): it drifts, at [{}] per second (a constant cause does not hold it)",
            t.chi2,
            t.dof,
            t.p,
            t.rate_per_s
                .iter()
                .zip(&t.rate_stderr)
                .map(|(r, se)| super::with_error(*r, *se))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        _ => format!("{differ}; a time- or state-dependent effect, not a constant one"),
    }
}

/// The rows of a linear equation, for [`significance_beside`]: calls `row(x, y, y_without,
/// cluster)` once per row of the fit data, with `x` the regressors of every column (whitened),
/// `y` the residual the columns are fitted to, `y_without` the residual with the tested cause's
/// part put back (its values at the base configuration; `y` itself where the columns carry the
/// whole cause) and `cluster` the row's cluster (residuals may be correlated within one).
pub(super) type EquationRows<'a> = dyn Fn(&mut RowSink) + 'a;

/// What [`EquationRows`] calls per row: `(x, y, y_without, cluster)`.
pub(super) type RowSink<'a> = dyn FnMut(&[f64], f64, f64, usize) + 'a;

/// How significant a cause is beside the other columns of a linear equation (`p` columns,
/// `rows`): `(likelihood ratio, the selection's threshold for `dof` degrees of freedom,
/// cluster-robust Wald statistic)`. The likelihood ratio sets the fit of every column to `y`
/// against the fit without the cause's columns `idx` to `y_without`; the Wald statistic tests
/// the cause's total change from its base values, `offset + θ_idx` (`offset`: the fitted values'
/// change from the base, zero where the columns carry the whole cause), with the sandwich
/// covariance over `rows`' clusters. `None` when a fit is not determined. Shared by the torque
/// and wheel channels' joint and competitor tests.
pub(super) fn significance_beside(
    rows: &EquationRows,
    p: usize,
    (dof, idx, offset): (usize, &[usize], &[f64]),
    levels: &Levels,
) -> Option<(f64, f64, Option<f64>)> {
    let others: Vec<usize> = (0..p).filter(|j| !idx.contains(j)).collect();
    let mut with = NormalEquations::new(p);
    let mut without = NormalEquations::new(others.len());
    let mut x_without = vec![0.0; others.len()];
    rows(&mut |x, y, y_without, _| {
        with.add(x, y);
        for (a, &j) in others.iter().enumerate() {
            x_without[a] = x[j];
        }
        without.add(&x_without, y_without);
    });
    let f = with.solve()?;
    let rss_without = rss_of(&without)?;
    let (lr, threshold) = levels.joint(with.rows() as f64, rss_without, f.rss, dof);
    // Scores per cluster at the joint solution.
    let mut scores: std::collections::BTreeMap<usize, DVector<f64>> = Default::default();
    rows(&mut |x, y, _, cluster| {
        let e = y - x
            .iter()
            .zip(f.theta.iter())
            .map(|(a, t)| a * t)
            .sum::<f64>();
        let s = scores.entry(cluster).or_insert_with(|| DVector::zeros(p));
        for j in 0..p {
            s[j] += x[j] * e;
        }
    });
    let scores: Vec<DVector<f64>> = scores.into_values().collect();
    let mut total = f.clone();
    for (&j, o) in idx.iter().zip(offset) {
        total.theta[j] += o;
    }
    let wald = total.cluster_robust_wald(&scores, idx);
    Some((lr, threshold, wald))
}

/// The competing explanation's verdict, the same in every channel: the cause is dropped if the
/// search without it (cross-validated residual sum `without`, terms `rival`) predicts more than
/// [`COMPETITOR_MARGIN`] better out of fold than the search with it (`with`), or if it predicts
/// at least as well and the cause is not significant beside its terms (`significance`, see
/// [`significance_beside`]: the likelihood ratio or the cluster-robust Wald statistic at or
/// below the selection's threshold). A search that predicts worse may have found a mimic of the
/// cause's form, so the cause is not tested beside it. Returns the test's outcome and, when the
/// cause is dropped, the verdict.
pub(super) fn compete(
    channel: &str,
    with: f64,
    without: f64,
    rival: &[UnexplainedEffect],
    significance: impl FnOnce() -> Option<(f64, f64, Option<f64>)>,
) -> (Competitor, Option<String>) {
    let form: Vec<&str> = rival.iter().map(|e| e.proposed.as_str()).collect();
    let form = if form.is_empty() {
        "none".to_string()
    } else {
        form.join("; ")
    };
    let mut out = Competitor {
        cv_with: with,
        cv_without: without,
        form,
        lr: None,
        wald: None,
        threshold: None,
    };
    if without < with * (1.0 - COMPETITOR_MARGIN) {
        let text = format!(
            "dropped: a form of another kind explains its part better ({channel} channel's cross-validated residual sum {without:.1} without it, {with:.1} with it: {}); it stood in for that form",
            out.form
        );
        return (out, Some(text));
    }
    if without > with {
        return (out, None);
    }
    // The explanation without it predicts at least as well out of fold: the cause must then
    // add something significant beside its terms.
    let Some((lr, threshold, wald)) = significance() else {
        return (out, None);
    };
    (out.lr, out.wald, out.threshold) = (Some(lr), wald, Some(threshold));
    if lr.min(wald.unwrap_or(f64::INFINITY)) > threshold {
        return (out, None);
    }
    let text = format!(
        "dropped: not significant beside the form of another kind found without it ({}; likelihood ratio {lr:.1}, cluster-robust Wald statistic {}, threshold {threshold:.1}); it stood in for that form",
        out.form,
        wald.map_or("not determined".to_string(), |w| format!("{w:.1}"))
    );
    (out, Some(text))
}

/// Residual sum at the least-squares solution (`Σ y²` with no unknowns).
pub(super) fn rss_of(ne: &NormalEquations) -> Option<f64> {
    if ne.params() == 0 {
        Some(ne.yty())
    } else {
        ne.solve().map(|f| f.rss)
    }
}

/// χ² consistency of the parameters `idx` across the block fits (`None` if a block does not
/// determine them), each block `block_s` long, and their linear trend.
pub(super) fn consistency(
    per_block: &[Option<LsFit>],
    idx: &[usize],
    block_s: f64,
) -> Option<Consistency> {
    let k = idx.len();
    let mut thetas = Vec::new();
    let mut weights = Vec::new();
    for f in per_block {
        let f = f.as_ref()?;
        let cov = f.cov();
        let c = DMatrix::from_fn(k, k, |a, b| cov[(idx[a], idx[b])]);
        let w = c.try_inverse()?;
        thetas.push(DVector::from_fn(k, |a, _| f.theta[idx[a]]));
        weights.push(w);
    }
    let wsum: DMatrix<f64> = weights.iter().fold(DMatrix::zeros(k, k), |a, w| a + w);
    let wt: DVector<f64> = weights
        .iter()
        .zip(&thetas)
        .fold(DVector::zeros(k), |a, (w, t)| a + w * t);
    let mean = wsum.try_inverse()? * wt;
    let chi2: f64 = weights
        .iter()
        .zip(&thetas)
        .map(|(w, t)| {
            let d = t - &mean;
            (d.transpose() * w * &d)[(0, 0)]
        })
        .sum();
    let dof = (per_block.len() - 1) * k;
    let p = 1.0 - chi_square_cdf(chi2, dof as f64);
    let trend = linear_trend(&thetas, &weights, block_s);
    Some(Consistency {
        blocks: per_block.len(),
        chi2,
        dof,
        p,
        values: thetas.iter().map(|t| t.iter().copied().collect()).collect(),
        stderr: per_block
            .iter()
            .map(|f| {
                f.as_ref()
                    .map(|f| {
                        let se = f.stderr();
                        idx.iter().map(|&j| se[j]).collect()
                    })
                    .unwrap_or_default()
            })
            .collect(),
        trend,
        beside: Vec::new(),
    })
}

/// Weighted fit of `θ_b = a + ṙ τ_b` to the block values (`τ_b` the block's mid-time from the
/// record's middle, blocks `block_s` long); `None` with fewer than three blocks or a singular
/// fit.
fn linear_trend(thetas: &[DVector<f64>], weights: &[DMatrix<f64>], block_s: f64) -> Option<Trend> {
    let blocks = thetas.len();
    let k = thetas.first()?.len();
    if blocks < 3 || block_s <= 0.0 {
        return None;
    }
    let tau = |b: usize| (b as f64 + 0.5 - blocks as f64 / 2.0) * block_s;
    let mut a = DMatrix::zeros(2 * k, 2 * k);
    let mut rhs = DVector::zeros(2 * k);
    for (b, (t, w)) in thetas.iter().zip(weights).enumerate() {
        let s = tau(b);
        let wt = w * t;
        for (i, j, scale) in [(0, 0, 1.0), (0, k, s), (k, 0, s), (k, k, s * s)] {
            let mut view = a.view_mut((i, j), (k, k));
            view += w * scale;
        }
        let mut top = rhs.rows_mut(0, k);
        top += &wt;
        let mut bottom = rhs.rows_mut(k, k);
        bottom += &wt * s;
    }
    let cov = a.try_inverse()?;
    let x = &cov * rhs;
    let (level, rate) = (x.rows(0, k).into_owned(), x.rows(k, k).into_owned());
    let chi2: f64 = thetas
        .iter()
        .zip(weights)
        .enumerate()
        .map(|(b, (t, w))| {
            let d = t - &level - &rate * tau(b);
            (d.transpose() * w * &d)[(0, 0)]
        })
        .sum();
    let dof = (blocks - 2) * k;
    let rate_cov = cov.view((k, k), (k, k)).into_owned();
    let rate_wald = (rate.transpose() * rate_cov.clone().try_inverse()? * &rate)[(0, 0)];
    Some(Trend {
        chi2,
        dof,
        p: 1.0 - chi_square_cdf(chi2, dof as f64),
        rate_per_s: rate.iter().copied().collect(),
        rate_stderr: (0..k).map(|i| rate_cov[(i, i)].max(0.0).sqrt()).collect(),
        rate_wald,
        rate_p: 1.0 - chi_square_cdf(rate_wald, k as f64),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Block fits of one parameter with values `theta` and standard error `se` each.
    fn blocks(theta: &[f64], se: f64) -> Vec<Option<LsFit>> {
        theta
            .iter()
            .map(|&t| {
                Some(LsFit {
                    theta: DVector::from_element(1, t),
                    cov_unit: DMatrix::from_element(1, 1, se * se),
                    rss: 1.0,
                    n: 2,
                })
            })
            .collect()
    }

    /// Closed form: four blocks of 100 s on the line `θ = 1 + 0.01 (t − 200)`, each ±0.1.
    /// The constant fails (χ² = Σ (θ_b − 1)² / 0.01 = 500), the trend fits exactly (χ² = 0) with
    /// rate 0.01 / s and its standard error `σ / √(Σ τ_b²)` = 0.1 / √50000.
    #[test]
    fn block_values_on_a_line_are_a_trend_with_its_rate() {
        let per_block = blocks(&[-0.5, 0.5, 1.5, 2.5], 0.1);
        let c = consistency(&per_block, &[0], 100.0).expect("determined");
        assert!((c.chi2 - 500.0).abs() < 1e-6, "{}", c.chi2);
        let t = c.trend.clone().expect("a trend with four blocks");
        assert!(t.chi2.abs() < 1e-9 && t.dof == 2, "{t:?}");
        assert!((t.rate_per_s[0] - 0.01).abs() < 1e-12, "{t:?}");
        assert!(
            (t.rate_stderr[0] - 0.1 / 50_000f64.sqrt()).abs() < 1e-12,
            "{t:?}"
        );
        assert!(t.drifts(1e-3));
        let text = falsified_text(&c, 1e-3);
        assert!(
            text.contains("it drifts, at [1.000e-2 ± 4.5e-4] per second"),
            "{text}"
        );
    }

    /// Values that jump about (not on a line) fail the trend as well: the verdict stays "a time-
    /// or state-dependent effect".
    #[test]
    fn block_values_off_a_line_are_no_trend() {
        let per_block = blocks(&[0.0, 2.0, 0.0, 2.0], 0.1);
        let c = consistency(&per_block, &[0], 100.0).expect("determined");
        let t = c.trend.clone().expect("a trend with four blocks");
        assert!(!t.drifts(1e-3), "{t:?}");
        let text = falsified_text(&c, 1e-3);
        assert!(
            text.ends_with("a time- or state-dependent effect, not a constant one"),
            "{text}"
        );
        // Two blocks cannot tell a trend from a step.
        assert!(
            consistency(&blocks(&[0.0, 2.0], 0.1), &[0], 100.0)
                .unwrap()
                .trend
                .is_none()
        );
    }
}
