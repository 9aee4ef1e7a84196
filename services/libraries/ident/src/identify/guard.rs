//! The misattribution guard: before a named cause is reported as the explanation of what it
//! absorbed, what it explains in each equation of its channel is set against what the
//! unrestricted candidate search explains there.
//!
//! An effect outside the library can resemble a library cause on part of the data (a torque
//! that follows the heading over ±60° is mostly a constant). The cause is then named, and its
//! channel's search, run *with* the cause in the model, may find nothing beside it: its bar for
//! a new term (1 % of the cross-validated residual sum) is high in a channel where the noise
//! dominates. So, per equation the cause acts in (a torque axis, a wheel, an innovation
//! component), on the same rows:
//!
//! - **with the cause**: the channel's search with every named cause forced (what the report
//!   already has), its cross-validated residual sum `cv_cause`;
//! - **the unrestricted search**: the cause's fitted part put back and its columns not forced,
//!   over the whole candidate library (its own form included), `cv_search` and its terms;
//! - **the trigger**: the search's terms include a function outside the cause's own form and
//!   predict better out of fold, `cv_search < cv_cause` (the selection's held-out likelihood
//!   ratio above zero); else, the one candidate outside the cause's own form that does most
//!   beside it (the unrestricted search loses to a cause whose law has no form among the
//!   candidates, such as a friction law's Stribeck term, and the search beside the cause adds
//!   a term only above 1 % of the cross-validated residual sum). Such a term is significant
//!   beside every cause of its equation: it is laid on one only where no cause of the
//!   equation is flagged otherwise, and on the first named;
//! - **the remainder**: those functions fitted beside the cause (and the terms found with it)
//!   must pass the test the selection names a cause by, beside the others: likelihood ratio on
//!   the equation's rows above `max(k ln N, χ²_k(1 − alpha))`, the cluster-robust Wald
//!   statistic above the same threshold (as the falsification's joint test), and a lower
//!   cross-validated residual sum than the cause's.
//!
//! A torque cause that acts about several axes is also judged across them
//! ([`across_equations`]), and a gyro cause against the dynamics, which check the rates it
//! corrects ([`across_channels`]).
//!
//! When all hold the cause **partly explains** that equation: it stays named, flagged with the
//! statistics ([`PartlyExplained`]), and the remainder is reported as an unexplained effect with
//! its regressors and coefficients (fitted beside the cause), so "no residual remains" is not
//! said. The search's terms passed its own Bonferroni threshold; the remainder's test beside the
//! cause is then one test of a given form.

use super::Options;
use super::equations::Candidates;
use super::falsify::Levels;
use super::innovation::{
    INNOVATION_LABELS, InnovationCandidates, SensorLinear, corrects_rates, innovation_designs,
};
use super::torque::{
    JointTorque, TorqueCandidates, joint_torque, own_form as torque_own_form, torque_designs,
    torque_equation,
};
use super::unexplained::{UnexplainedEffect, effect};
use super::wheel::{WheelCandidates, own_form as wheel_own_form, wheel_designs, wheel_equation};
use crate::effects::{Cause, Kind};
use crate::fit::{Problem, SetFit};
use crate::sparse::{Design, SparseOptions, SparseResult, determined_forced, result_for, search};
use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;

/// A named cause that explains only part of an equation (see the module documentation).
#[derive(Debug, Clone, Serialize)]
pub struct PartlyExplained {
    pub cause: &'static str,
    pub equation: String,
    /// Cross-validated residual sums of the equation (its unit squared): with the cause (and the
    /// terms the search found beside it), of the unrestricted search without it, and of the
    /// cause with the remainder. With `across` all three are the first: in one equation alone
    /// the cause's columns and the remainder's span the same functions. With `dynamics` all
    /// three are the search's with the cause held at the dynamics' values.
    pub cv_cause: f64,
    pub cv_search: f64,
    pub cv_with_remainder: f64,
    /// The unrestricted search's form (`equation ≈ …`).
    pub search_form: String,
    /// The remainder beside the cause (`equation ≈ …`), also an unexplained effect.
    pub remainder: String,
    /// The remainder's significance beside the cause: likelihood ratio (with `across` and
    /// `dynamics`, the χ² of the values' disagreement), cluster-robust Wald statistic, the
    /// selection's threshold for its degrees of freedom.
    pub lr: f64,
    pub wald: f64,
    pub threshold: f64,
    pub dof: usize,
    /// In words.
    pub verdict: String,
    /// What raised the flag.
    pub trigger: Trigger,
}

/// The test that flagged a cause (in `report.json`, `trigger.test`).
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "test", rename_all = "lowercase")]
pub enum Trigger {
    /// The unrestricted search predicts better with a form of another kind.
    Search,
    /// A term of another form is significant beside the cause, below the search's 1 % bar.
    Beside,
    /// The cause's values differ between the equations it acts in (a torque cause acting
    /// about several axes): those values.
    Across(AcrossEquations),
    /// A sensor cause's values that the dynamics (the torque equations, on the rates it
    /// corrects) put elsewhere than the sensors do (the innovations, `innovations`): those
    /// values.
    Dynamics(AcrossEquations),
}

/// A torque cause's parameters fitted to each equation they are determined in alone (see
/// [`across_equations`]): their values there, with cluster-robust standard errors, and the χ²
/// of their disagreement.
#[derive(Debug, Clone, Serialize)]
pub struct AcrossEquations {
    /// The parameters determined in more than one equation (`com_offset.r_m[2]` …).
    pub parameters: Vec<String>,
    /// Per equation: its name, and per parameter (in `parameters`' order; NaN where not
    /// determined there) its value fitted there alone and the standard error, in the
    /// parameter's unit.
    pub equations: Vec<(String, Vec<f64>, Vec<f64>)>,
    pub chi2: f64,
    pub dof: usize,
    /// The selection's threshold for `dof`.
    pub threshold: f64,
}

impl AcrossEquations {
    /// The values per equation in words (`torque_x: r_m[2] −2.870e-7 ± 1.4e-8; …`), the
    /// parameters' names without `prefix` (the cause's).
    fn values_text(&self, prefix: &str) -> String {
        self.equations
            .iter()
            .map(|(name, value, se)| {
                let v: Vec<String> = value
                    .iter()
                    .zip(se)
                    .zip(&self.parameters)
                    .filter(|((v, s), _)| v.is_finite() && s.is_finite())
                    .map(|((v, s), p)| {
                        format!("{} {v:+.3e} ± {s:.1e}", p.trim_start_matches(prefix))
                    })
                    .collect();
                format!("{name}: {}", v.join(", "))
            })
            .collect::<Vec<_>>()
            .join("; ")
    }

    /// The flag of `cause` on the remainder's equation raised by these values (`trigger`):
    /// the remainder's cross-validated residual sum `cv` stands for all three sums, the χ²
    /// for the likelihood ratio, with the remainder's Wald statistic, threshold and degrees
    /// of freedom.
    fn flag(
        self,
        cause: Cause,
        remainder: UnexplainedEffect,
        cv: f64,
        (wald, threshold, dof): (f64, f64, usize),
        verdict: String,
        trigger: fn(AcrossEquations) -> Trigger,
    ) -> (PartlyExplained, UnexplainedEffect) {
        (
            PartlyExplained {
                cause: cause.name(),
                equation: remainder.equation.clone(),
                cv_cause: cv,
                cv_search: cv,
                cv_with_remainder: cv,
                search_form: "none".to_string(),
                remainder: remainder.proposed.clone(),
                lr: self.chi2,
                wald,
                threshold,
                dof,
                verdict,
                trigger: trigger(self),
            },
            remainder,
        )
    }
}

/// One equation of a cause's channel: the design with every named cause forced (`with`) and
/// the one with the cause's fitted part put back and its columns not forced (`without`), both
/// over the whole candidate library.
pub(super) struct Equation<'a> {
    pub name: String,
    pub unit: &'static str,
    pub with: &'a Design,
    pub without: &'a Design,
}

/// The guard on one equation of `cause` (own form `own` among the candidates): `None` when the
/// cause does not act there or explains it as well as the unrestricted search. Else the flag and
/// the remainder as an unexplained effect (its terms beside every named cause's columns and the
/// terms the search found with them).
pub(super) fn judge(
    cause: Cause,
    own: &[&str],
    eq: &Equation,
    sparse: &SparseOptions,
    levels: &Levels,
) -> Option<(PartlyExplained, UnexplainedEffect)> {
    let prefix = format!("{}.", cause.name());
    let with = eq.with;
    if !with.names[..with.forced]
        .iter()
        .any(|n| n.starts_with(&prefix))
    {
        return None;
    }
    let found = search(with, sparse);
    let free = search(eq.without, sparse);
    let (cv_cause, cv_search) = (found.cv_rss, free.cv_rss);
    let column = |name: &str| with.names.iter().position(|n| n == name);
    // The base: the determined forced columns and the terms found with the cause.
    let mut base = determined_forced(with);
    let nf = base.len();
    base.extend(found.terms.iter().filter_map(|t| column(&t.name)));
    let rows = with.rows() as f64;
    let rss_base = with.fit_rss(&base)?;
    // What the remainder may be. First the unrestricted search's functions of another form,
    // when that search predicts better held out (the selection's held-out likelihood ratio
    // above zero).
    let from_search: Vec<usize> = if cv_search < cv_cause {
        free.terms
            .iter()
            .filter(|t| !own.contains(&t.name.as_str()))
            .filter_map(|t| column(&t.name))
            .filter(|j| !base.contains(j))
            .collect()
    } else {
        Vec::new()
    };
    // Else the one candidate of another form that does most beside the cause. The unrestricted
    // search may lose to the cause where the cause's law has no form among the candidates (a
    // friction law's Stribeck term), and the search beside the cause adds a term only if it
    // lowers the cross-validated residual sum by 1 %: a remainder can pass the selection's
    // test and still be below that bar.
    let beside = from_search.is_empty();
    let extra = if beside {
        (with.forced..with.names.len())
            .filter(|j| !base.contains(j) && !own.contains(&with.names[*j].as_str()))
            .filter_map(|j| {
                let mut cols = base.clone();
                cols.push(j);
                let (lr, _) = levels.joint(rows, rss_base, with.fit_rss(&cols)?, 1);
                Some((j, lr))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(j, _)| vec![j])
            .unwrap_or_default()
    } else {
        from_search
    };
    if extra.is_empty() {
        return None;
    }
    let mut cols = base.clone();
    cols.extend(&extra);
    let idx: Vec<usize> = (base.len()..cols.len()).collect();
    // The remainder beside the cause: the selection's test of a cause beside those chosen
    // (likelihood ratio above its threshold on the fit data, better held out), with the
    // cluster-robust Wald statistic as in the falsification's joint test.
    let (lr, threshold) = levels.joint(rows, rss_base, with.fit_rss(&cols)?, idx.len());
    let wald = with.wald(&cols, &idx)?;
    let cv_with_remainder = with.cv_rss(&cols)?;
    if !(lr > threshold && wald > threshold && cv_with_remainder < cv_cause) {
        return None;
    }
    let base_cv = with.cv_rss(&cols[..nf]).unwrap_or(with.total_rss());
    let result = result_for(with, nf, &cols, found.z_threshold, base_cv);
    let remainder = effect(eq.name.clone(), eq.unit, result, with)?;
    let search_form = effect(eq.name.clone(), eq.unit, free, eq.without)
        .map_or_else(|| "none".to_string(), |e| e.proposed);
    let verdict = if beside {
        format!(
            "partly explains {}: beside it a term of another form is significant though below the search's bar for a new term (1 % of the cross-validated residual sum): {} (likelihood ratio {lr:.1}, cluster-robust Wald statistic {wald:.1}, threshold {threshold:.1}; cross-validated residual sum {cv_with_remainder:.4e} against {cv_cause:.4e} with the cause alone)",
            eq.name, remainder.proposed
        )
    } else {
        format!(
            "partly explains {}: the unrestricted search without it ({search_form}) predicts better out of fold (cross-validated residual sum {:.4e} against {cv_cause:.4e} with it); beside it remains {} (likelihood ratio {lr:.1}, cluster-robust Wald statistic {wald:.1}, threshold {threshold:.1}; cross-validated residual sum {cv_with_remainder:.4e})",
            eq.name, cv_search, remainder.proposed
        )
    };
    Some((
        PartlyExplained {
            cause: cause.name(),
            equation: eq.name.clone(),
            cv_cause,
            cv_search,
            cv_with_remainder,
            search_form,
            remainder: remainder.proposed.clone(),
            lr,
            wald,
            threshold,
            dof: idx.len(),
            verdict,
            trigger: if beside {
                Trigger::Beside
            } else {
                Trigger::Search
            },
        },
        remainder,
    ))
}

/// Values of some of `m` parameters observed in one equation: `theta[i]` is parameter
/// `parameter[i]`, with covariance `cov`.
struct Observed {
    theta: DVector<f64>,
    cov: DMatrix<f64>,
    parameter: Vec<usize>,
}

/// One value of each of `m` parameters from independent observations of them (generalised least
/// squares), and the disagreement: `χ² = Σ (θ − μ)ᵀ C⁻¹ (θ − μ)` on (observed values − seen
/// parameters) degrees of freedom. A parameter no observation sees takes 0. `None` if a
/// covariance or the combined information is singular.
fn one_value(observations: &[Observed], m: usize) -> Option<(DVector<f64>, f64, usize)> {
    let unseen: Vec<usize> = (0..m)
        .filter(|p| !observations.iter().any(|o| o.parameter.contains(p)))
        .collect();
    let mut information = DMatrix::<f64>::zeros(m, m);
    for &p in &unseen {
        information[(p, p)] = 1.0;
    }
    let mut weighted = DVector::<f64>::zeros(m);
    let mut blocks = Vec::with_capacity(observations.len());
    for o in observations {
        let w = o.cov.clone().try_inverse()?;
        let map = DMatrix::from_fn(o.theta.len(), m, |i, j| {
            if o.parameter[i] == j { 1.0 } else { 0.0 }
        });
        information += map.transpose() * &w * &map;
        weighted += map.transpose() * &w * &o.theta;
        blocks.push((w, map));
    }
    let common = information.try_inverse()? * weighted;
    let mut chi2 = 0.0;
    for (o, (w, map)) in observations.iter().zip(&blocks) {
        let d = &o.theta - map * &common;
        chi2 += (d.transpose() * w * &d)[(0, 0)];
    }
    let observed: usize = observations.iter().map(|o| o.theta.len()).sum();
    Some((common, chi2, observed.saturating_sub(m - unseen.len())))
}

/// Smallest correlation at which a candidate function is taken as a cause's column's form in
/// one equation (`com_offset.r_m[2]` about X is `m g` times `sin tilt_y`).
const SAME_FORM: f64 = 0.999;

/// One equation of [`across_equations`]: its design, the search with every named cause, the
/// fitted columns (the determined forced ones, then the terms found), and the positions among
/// them of the cause's parameters with their names.
struct Shared<'a> {
    design: &'a Design,
    name: String,
    found: SparseResult,
    cols: Vec<usize>,
    forced: usize,
    theta: DVector<f64>,
    cov: DMatrix<f64>,
    params: Vec<(usize, String)>,
}

/// The guard across the equations of a torque cause (`designs`: per axis, every named cause
/// forced): a parameter that acts about several axes (a vertical centre-of-mass offset about X
/// and Y) must take one value in all of them. Each equation's own search fits the cause's
/// columns there alone, so an effect that has the cause's form in one equation only (a torque
/// about X per unit of `G_y` with no `G_x` torque about Y) is explained within the noise in
/// each, and the joint value is a compromise that explains neither. The test: the cause's
/// shared parameters fitted per equation beside the terms found there (cluster-robust
/// covariances), their disagreement `χ²` (generalised least squares about one common value,
/// equations independent) above the selection's threshold for its degrees of freedom. Each
/// equation whose own change from the joint value is significant by itself (cluster-robust
/// Wald statistic above the threshold) is then flagged, and its change reported as the
/// remainder: the candidate function of the cause's form there, fitted beside the cause held
/// at its joint value. Columns without a candidate of their form are not judged. `fitted`: the
/// cause's fitted values (its configuration's order and units).
pub(super) fn across_equations(
    cause: Cause,
    fitted: &[f64],
    designs: &[(usize, Design)],
    sparse: &SparseOptions,
    levels: &Levels,
) -> Vec<(PartlyExplained, UnexplainedEffect)> {
    let prefix = format!("{}.", cause.name());
    let equations: Vec<Shared> = designs
        .iter()
        .filter_map(|(axis, design)| {
            let found = search(design, sparse);
            let mut cols = determined_forced(design);
            let forced = cols.len();
            let column = |name: &str| design.names.iter().position(|n| n == name);
            cols.extend(found.terms.iter().filter_map(|t| column(&t.name)));
            let params: Vec<(usize, String)> = (0..forced)
                .filter(|&i| design.names[cols[i]].starts_with(&prefix))
                .map(|i| (i, design.names[cols[i]].clone()))
                .collect();
            if params.is_empty() {
                return None;
            }
            let (theta, cov) = design.fit_cov(&cols)?;
            Some(Shared {
                design,
                name: torque_equation(*axis),
                found,
                cols,
                forced,
                theta,
                cov,
                params,
            })
        })
        .collect();
    let mut parameters: Vec<String> = Vec::new();
    for e in &equations {
        for (_, p) in &e.params {
            let count = equations
                .iter()
                .filter(|o| o.params.iter().any(|(_, q)| q == p))
                .count();
            if count > 1 && !parameters.contains(p) {
                parameters.push(p.clone());
            }
        }
    }
    let m = parameters.len();
    if m == 0 {
        return Vec::new();
    }
    // Per equation: the shared parameters' positions among its columns and in `parameters`.
    let picks: Vec<Vec<(usize, usize)>> = equations
        .iter()
        .map(|e| {
            e.params
                .iter()
                .filter_map(|(i, p)| Some((*i, parameters.iter().position(|q| q == p)?)))
                .collect()
        })
        .collect();
    // Per equation: the values of the shared parameters there, their covariance, and which
    // parameter each is.
    let observations: Vec<Observed> = equations
        .iter()
        .zip(&picks)
        .filter(|(_, pick)| !pick.is_empty())
        .map(|(e, pick)| Observed {
            theta: DVector::from_fn(pick.len(), |i, _| e.theta[pick[i].0]),
            cov: DMatrix::from_fn(pick.len(), pick.len(), |i, j| e.cov[(pick[i].0, pick[j].0)]),
            parameter: pick.iter().map(|&(_, j)| j).collect(),
        })
        .collect();
    let Some((common, chi2, dof)) = one_value(&observations, m) else {
        return Vec::new();
    };
    let threshold = levels.threshold(dof);
    if !(dof > 0 && chi2 > threshold) {
        return Vec::new();
    }
    let across = AcrossEquations {
        parameters: parameters.clone(),
        equations: equations
            .iter()
            .zip(&picks)
            .map(|(e, pick)| {
                let mut value = vec![f64::NAN; m];
                let mut se = vec![f64::NAN; m];
                for &(i, j) in pick {
                    // The design's columns fit changes from the cause's fitted value.
                    let at = (0..fitted.len()).find(|&o| cause.value_name(o) == parameters[j]);
                    value[j] = at.map_or(f64::NAN, |o| fitted[o]) + e.theta[i];
                    se[j] = e.cov[(i, i)].max(0.0).sqrt();
                }
                (e.name.clone(), value, se)
            })
            .collect(),
        chi2,
        dof,
        threshold,
    };
    let values_text = across.values_text(&prefix);
    let mut out = Vec::new();
    for (e, pick) in equations.iter().zip(&picks) {
        if pick.is_empty() {
            continue;
        }
        // The cause's shared columns whose value here differs by itself from the common one
        // (a column this equation hardly determines, such as a centre-of-mass offset's
        // nearly constant torque beside a constant torque, is left as it is), replaced by the
        // candidates of their form.
        let alone = levels.threshold(1);
        let shared: Vec<usize> = pick
            .iter()
            .filter(|&&(i, j)| (e.theta[i] - common[j]).powi(2) > alone * e.cov[(i, i)])
            .map(|&(i, _)| e.cols[i])
            .collect();
        if shared.is_empty() {
            continue;
        }
        let form: Option<Vec<usize>> = shared
            .iter()
            .map(|&f| {
                (e.design.forced..e.design.names.len())
                    .filter(|j| !e.cols.contains(j))
                    .map(|j| (j, e.design.correlation(f, j).abs()))
                    .filter(|(_, r)| *r >= SAME_FORM)
                    .max_by(|x, y| x.1.total_cmp(&y.1))
                    .map(|(j, _)| j)
            })
            .collect();
        let Some(form) = form else {
            continue;
        };
        let mut cols: Vec<usize> = e.cols[..e.forced]
            .iter()
            .copied()
            .filter(|c| !shared.contains(c))
            .collect();
        let nf = cols.len();
        cols.extend(&e.cols[e.forced..]);
        cols.extend(&form);
        let idx: Vec<usize> = (cols.len() - form.len()..cols.len()).collect();
        let Some(wald) = e.design.wald(&cols, &idx) else {
            continue;
        };
        let threshold_here = levels.threshold(idx.len());
        if wald <= threshold_here {
            continue;
        }
        let cv = e.found.cv_rss;
        let base_cv = e.design.cv_rss(&cols[..nf]).unwrap_or(e.design.total_rss());
        let result = result_for(e.design, nf, &cols, e.found.z_threshold, base_cv);
        let Some(remainder) = effect(e.name.clone(), "Nm", result, e.design) else {
            continue;
        };
        let verdict = format!(
            "partly explains {}: its values differ between the equations it acts in (each fitted alone: {values_text}; χ² = {chi2:.1} on {dof} degrees of freedom, threshold {threshold:.1}), so one value does not explain them all; beside it remains {} (cluster-robust Wald statistic {wald:.1}, threshold {threshold_here:.1})",
            e.name, remainder.proposed
        );
        out.push(across.clone().flag(
            cause,
            remainder,
            cv,
            (wald, threshold_here, idx.len()),
            verdict,
            Trigger::Across,
        ));
    }
    out
}

/// The torque designs with the given sensor columns forced (see [`across_channels`]).
type TorqueWith<'a> = dyn Fn(&[(String, &[Vector3<f64>])]) -> Option<Vec<(usize, Design)>> + 'a;
/// The innovation designs with a part of each innovation-vector row taken out and the cause's
/// columns not forced.
type InnovationsWithout<'a> = dyn Fn(&[f64]) -> Vec<(usize, Design)> + 'a;

/// The guard across channels for a sensor cause: a sensor cause changes the estimated rates,
/// and with them the torque equations' residuals (`SensorLinear::torque`). Its values are
/// fitted to the innovations; if it is what it is said to be, the dynamics agree: fitted to
/// each torque equation beside the named causes and the terms found there (cluster-robust
/// covariances), its change from the fitted values is zero within the errors. An inclinometer
/// turned about the vertical reads like a gyro triad turned the other way (the innovations see
/// only the sensors' relative alignment), but the gyro's correction then turns the rates
/// against the wheels and the inertia, which the torque equations see. The test: the changes
/// per torque equation and the innovations' (zero, with the fit's standard errors) about one
/// value, `χ²` (as [`across_equations`]) above the selection's threshold. The remainder: the
/// cause held at the dynamics' value (the torque equations' changes combined), the innovations'
/// search beside the other named causes (`innovations`: the designs with a part of each
/// innovation-vector row taken out and the cause's columns not forced); each innovation
/// equation where it finds terms whose cluster-robust Wald statistic passes the threshold is
/// flagged with them. `torque`: the torque designs with the given columns forced.
pub(super) fn across_channels(
    cause: Cause,
    fit: &SetFit,
    linear: &SensorLinear,
    (torque, innovations): (&TorqueWith, &InnovationsWithout),
    sparse: &SparseOptions,
    levels: &Levels,
) -> Vec<(PartlyExplained, UnexplainedEffect)> {
    let js: Vec<usize> = (0..linear.cols.len())
        .filter(|&j| linear.cols[j].0 == cause)
        .collect();
    let Some(fitted) = fit.causes.iter().find(|f| f.cause == cause) else {
        return Vec::new();
    };
    if js.is_empty()
        || js
            .iter()
            .any(|&j| linear.torque.get(j).is_none_or(Vec::is_empty))
    {
        return Vec::new();
    }
    let m = js.len();
    let parameters: Vec<String> = js.iter().map(|&j| linear.cols[j].2.clone()).collect();
    let sensor: Vec<(String, &[Vector3<f64>])> = js
        .iter()
        .zip(&parameters)
        .map(|(&j, name)| (name.clone(), &linear.torque[j][..]))
        .collect();
    let Some(designs) = torque(&sensor) else {
        return Vec::new();
    };
    let value = |p: usize| fitted.values[linear.cols[js[p]].1];
    let mut observations = Vec::new();
    let mut equations = Vec::new();
    for (axis, design) in &designs {
        let found = search(design, sparse);
        let mut cols = determined_forced(design);
        let column = |name: &str| design.names.iter().position(|n| n == name);
        cols.extend(found.terms.iter().filter_map(|t| column(&t.name)));
        let pick: Vec<(usize, usize)> = cols
            .iter()
            .enumerate()
            .filter_map(|(i, &c)| Some((i, parameters.iter().position(|p| *p == design.names[c])?)))
            .collect();
        if pick.is_empty() {
            continue;
        }
        let Some((theta, cov)) = design.fit_cov(&cols) else {
            continue;
        };
        let mut values = vec![f64::NAN; m];
        let mut se = vec![f64::NAN; m];
        for &(i, p) in &pick {
            values[p] = value(p) + theta[i];
            se[p] = cov[(i, i)].max(0.0).sqrt();
        }
        equations.push((torque_equation(*axis), values, se));
        observations.push(Observed {
            theta: DVector::from_fn(pick.len(), |k, _| theta[pick[k].0]),
            cov: DMatrix::from_fn(pick.len(), pick.len(), |a, b| cov[(pick[a].0, pick[b].0)]),
            parameter: pick.iter().map(|&(_, p)| p).collect(),
        });
    }
    if observations.is_empty() {
        return Vec::new();
    }
    // The dynamics' values: the torque equations' changes combined (0 where they see none).
    let Some((dynamics, _, _)) = one_value(&observations, m) else {
        return Vec::new();
    };
    // The sensors: no change from the fitted values, with the fit's standard errors.
    let se: Vec<f64> = (0..m)
        .map(|p| fitted.stderr[linear.cols[js[p]].1])
        .map(|s| {
            if s.is_finite() && s > 0.0 {
                s
            } else {
                f64::NAN
            }
        })
        .collect();
    let known: Vec<usize> = (0..m).filter(|&p| se[p].is_finite()).collect();
    if known.is_empty() {
        return Vec::new();
    }
    observations.push(Observed {
        theta: DVector::zeros(known.len()),
        cov: DMatrix::from_fn(known.len(), known.len(), |a, b| {
            if a == b { se[known[a]].powi(2) } else { 0.0 }
        }),
        parameter: known,
    });
    equations.push(("innovations".to_string(), (0..m).map(value).collect(), se));
    let Some((_, chi2, dof)) = one_value(&observations, m) else {
        return Vec::new();
    };
    let threshold = levels.threshold(dof);
    if !(dof > 0 && chi2 > threshold) {
        return Vec::new();
    }
    // The cause held at the dynamics' value: the innovations there, `r + J Δ`, are the
    // innovations less `−J Δ`.
    let part: Vec<f64> = linear
        .part_of_change(cause, dynamics.as_slice())
        .iter()
        .map(|v| -v)
        .collect();
    let across = AcrossEquations {
        parameters: parameters.clone(),
        equations,
        chi2,
        dof,
        threshold,
    };
    let values_text = across.values_text(&format!("{}.", cause.name()));
    let mut out = Vec::new();
    for (c, design) in innovations(&part) {
        let found = search(&design, sparse);
        if found.terms.is_empty() {
            continue;
        }
        let mut cols = determined_forced(&design);
        let nf = cols.len();
        let column = |name: &str| design.names.iter().position(|n| n == name);
        cols.extend(found.terms.iter().filter_map(|t| column(&t.name)));
        let idx: Vec<usize> = (nf..cols.len()).collect();
        let Some(wald) = design.wald(&cols, &idx) else {
            continue;
        };
        let threshold_here = levels.threshold(idx.len());
        if wald <= threshold_here {
            continue;
        }
        let name = INNOVATION_LABELS[c].to_string();
        let cv = found.cv_rss;
        let Some(remainder) = effect(name.clone(), "1 (whitened)", found, &design) else {
            continue;
        };
        let verdict = format!(
            "partly explains {name}: the dynamics put its values elsewhere than the sensors do (the torque equations on the rates it corrects, each fitted beside the named causes, and the innovations: {values_text}; χ² = {chi2:.1} on {dof} degrees of freedom, threshold {threshold:.1}); held at the dynamics' values, the innovations keep {} (cluster-robust Wald statistic {wald:.1}, threshold {threshold_here:.1})",
            remainder.proposed
        );
        out.push(across.clone().flag(
            cause,
            remainder,
            cv,
            (wald, threshold_here, idx.len()),
            verdict,
            Trigger::Dynamics,
        ));
    }
    out
}

/// The guard on every named cause, per equation of its channel (body axis, wheel, innovation
/// component); the channels' candidate libraries `torque`, `wheel` and `sensor` (with the
/// named sensor causes' linearisation; `None`: no sensor cause named, or not linearised). A
/// cause flagged on several equations has one entry per equation.
pub(super) fn causes(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    (torque, wheel, sensor): (
        &TorqueCandidates,
        &WheelCandidates,
        Option<(&InnovationCandidates, &SensorLinear)>,
    ),
    (block_s, sparse): (f64, &SparseOptions),
    levels: &Levels,
) -> Vec<(PartlyExplained, UnexplainedEffect)> {
    let blocks = (block_s, sparse.folds);
    let mut out = Vec::new();
    let guard =
        |cause: Cause, own: &[&str], name: String, unit, with: &Design, without: &Design| {
            let eq = Equation {
                name,
                unit,
                with,
                without,
            };
            judge(cause, own, &eq, sparse, levels)
        };
    let torque_with = torque_designs(problem, fit, named, torque, blocks, None, &[], &[]);
    let wheel_with = wheel_designs(problem, fit, named, wheel, blocks, None, &[]);
    let mut sensor_with = None;
    for &cause in named {
        match cause.kind() {
            Kind::Torque => {
                let (Some(with), Some(without)) = (
                    &torque_with,
                    torque_designs(problem, fit, named, torque, blocks, Some(cause), &[], &[]),
                ) else {
                    continue;
                };
                for ((axis, w), (_, wo)) in with.iter().zip(&without) {
                    let own = torque_own_form(cause);
                    out.extend(guard(cause, own, torque_equation(*axis), "Nm", w, wo));
                }
                let fitted = fit
                    .causes
                    .iter()
                    .find(|f| f.cause == cause)
                    .map_or(&[][..], |f| &f.values);
                out.extend(across_equations(cause, fitted, with, sparse, levels));
            }
            Kind::Wheel => {
                let without = wheel_designs(problem, fit, named, wheel, blocks, Some(cause), &[]);
                for ((w, with), (_, wo)) in wheel_with.iter().zip(&without) {
                    let own = wheel_own_form(cause);
                    out.extend(guard(cause, own, wheel_equation(*w), "Nm", with, wo));
                }
            }
            Kind::Sensor => {
                let Some((candidates, linear)) = sensor else {
                    continue;
                };
                let designs = |removed: Option<(Cause, &[f64])>| {
                    innovation_designs(problem, fit, (candidates, Some(linear)), blocks, removed)
                };
                let with = sensor_with.get_or_insert_with(|| designs(None));
                let Some(part) = linear.part_of(cause) else {
                    continue;
                };
                for ((c, w), (_, wo)) in with.iter().zip(&designs(Some((cause, &part)))) {
                    let name = INNOVATION_LABELS[*c].to_string();
                    // No candidate is a sensor cause's own form: its effect through the filter
                    // has none of their shapes exactly.
                    out.extend(guard(cause, &[], name, "1 (whitened)", w, wo));
                }
                if !corrects_rates(cause) {
                    continue;
                }
                let torque_with = |sensor: &[(String, &[Vector3<f64>])]| {
                    torque_designs(problem, fit, named, torque, blocks, None, &[], sensor)
                };
                let innovations_without = |part: &[f64]| designs(Some((cause, part)));
                out.extend(across_channels(
                    cause,
                    fit,
                    linear,
                    (&torque_with, &innovations_without),
                    sparse,
                    levels,
                ));
            }
        }
    }
    out
}

/// The guard on the fit `fit` of the named causes `named` after their falsification, on the
/// candidates and sensor linearisation its last round built (`candidates`): each cause
/// flagged, its remainder put among the unexplained `effects` (in place of an effect the search
/// found in that equation, whose terms it includes; one per equation), and the joint fit of the
/// torque causes redone beside the new torque terms.
pub(super) fn apply(
    problem: &Problem,
    (fit, named, candidates): (&SetFit, &[Cause], &Candidates),
    (options, n_fit): (&Options, f64),
    effects: &mut Vec<UnexplainedEffect>,
    joint: &mut Option<JointTorque>,
) -> Vec<PartlyExplained> {
    if named.is_empty() {
        return Vec::new();
    }
    let levels = Levels::new(options, n_fit);
    let sensor = candidates
        .linear
        .as_ref()
        .map(|linear| (&candidates.innovation, linear));
    let found = causes(
        problem,
        fit,
        named,
        (&candidates.torque, &candidates.wheel, sensor),
        (options.block_s, &options.sparse),
        &levels,
    );
    // A term significant beside a cause is significant beside every cause of its equation: it
    // is laid on one only where no cause of the equation is flagged otherwise (the one that
    // stood in for it), and on the first named.
    let keep: Vec<bool> = found
        .iter()
        .enumerate()
        .map(|(i, (f, _))| {
            !matches!(f.trigger, Trigger::Beside)
                || !found.iter().enumerate().any(|(j, (g, _))| {
                    j != i
                        && g.equation == f.equation
                        && (!matches!(g.trigger, Trigger::Beside) || j < i)
                })
        })
        .collect();
    let found = found
        .into_iter()
        .zip(keep)
        .filter_map(|(f, keep)| keep.then_some(f));
    let mut out = Vec::new();
    let mut torque_terms = false;
    for (flag, remainder) in found {
        if !out
            .iter()
            .any(|p: &PartlyExplained| p.equation == flag.equation)
        {
            // A remainder across equations is relative to the cause's joint value: a refit
            // beside it would take it back into the cause.
            torque_terms |= remainder.equation.starts_with("torque_")
                && !matches!(flag.trigger, Trigger::Across(_));
            effects.retain(|e| e.equation != remainder.equation);
            effects.push(remainder);
        }
        out.push(flag);
    }
    if torque_terms {
        *joint = joint_torque(problem, fit, named, effects, &candidates.torque);
    }
    out
}

/// The report's summary with a line after each flagged cause's own: `Partly explained: …`.
pub(super) fn annotate(summary: &mut Vec<String>, partly: &[PartlyExplained]) {
    for p in partly.iter().rev() {
        let own = format!("Named cause: {} (", p.cause);
        let at = summary
            .iter()
            .position(|l| l.starts_with(&own))
            .map_or(summary.len(), |i| i + 1);
        summary.insert(at, format!("Partly explained: {} {}.", p.cause, p.verdict));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn observed(theta: &[f64], se: &[f64], parameter: &[usize]) -> Observed {
        Observed {
            theta: DVector::from_column_slice(theta),
            cov: DMatrix::from_diagonal(&DVector::from_iterator(
                se.len(),
                se.iter().map(|s| s * s),
            )),
            parameter: parameter.to_vec(),
        }
    }

    /// Two observations of one parameter: the inverse-variance weighted mean, and `χ²` on one
    /// degree of freedom `(a − b)² / (σ_a² + σ_b²)`.
    #[test]
    fn one_parameter_is_the_weighted_mean_and_the_difference_over_its_variance() {
        let (a, sa, b, sb) = (-2.87e-7, 1.4e-8, 2.0e-8, 1.7e-8);
        let (common, chi2, dof) = one_value(
            &[observed(&[a], &[sa], &[0]), observed(&[b], &[sb], &[0])],
            1,
        )
        .expect("determined");
        let (wa, wb) = (1.0 / (sa * sa), 1.0 / (sb * sb));
        let mean = (wa * a + wb * b) / (wa + wb);
        assert!((common[0] - mean).abs() < 1e-12 * mean.abs());
        let want = (a - b).powi(2) / (sa * sa + sb * sb);
        assert!((chi2 - want).abs() < 1e-9 * want, "{chi2} against {want}");
        assert_eq!(dof, 1);
    }

    /// Observations that agree give `χ² = 0`; a parameter seen in one equation only adds no
    /// degree of freedom and takes that equation's value.
    #[test]
    fn agreeing_observations_and_a_parameter_seen_once() {
        let (common, chi2, dof) = one_value(
            &[
                observed(&[1.0, 5.0], &[0.1, 0.2], &[0, 1]),
                observed(&[1.0], &[0.3], &[0]),
            ],
            2,
        )
        .expect("determined");
        assert!((common[0] - 1.0).abs() < 1e-12 && (common[1] - 5.0).abs() < 1e-12);
        assert!(chi2.abs() < 1e-20);
        assert_eq!(dof, 1);
    }

    /// A parameter no observation sees takes 0 and adds no degree of freedom; the others are
    /// as without it.
    #[test]
    fn a_parameter_not_seen_takes_zero() {
        let (a, sa, b, sb) = (2.0, 0.5, 3.0, 0.5);
        let (common, chi2, dof) = one_value(
            &[observed(&[a], &[sa], &[1]), observed(&[b], &[sb], &[1])],
            3,
        )
        .expect("determined");
        assert_eq!((common[0], common[2]), (0.0, 0.0));
        assert!((common[1] - 2.5).abs() < 1e-12, "{common}");
        assert!((chi2 - 2.0).abs() < 1e-12, "{chi2}");
        assert_eq!(dof, 1);
    }
}
