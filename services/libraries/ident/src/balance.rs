//! Balancing: the moves of the balance masses that bring an identified centre-of-mass offset to
//! the target (horizontal zero, vertical the chosen pendulous value), with the predicted
//! residual and its uncertainty.
//!
//! Mass `i` (`m_i`, moving along the unit vector `e_i`) moved by `Δs_i` shifts the centre of
//! mass of the platform of total mass `M` (balance masses included) by exactly
//! `Δr = Σ m_i Δs_i e_i / M`. With `A = [m_1 e_1 … m_n e_n]` (3 × n) the moves solve
//! `A Δs = M (r_target − r̂)`; with more than three masses, the smallest moves (minimum norm,
//! `Δs = Aᵀ (A Aᵀ)⁻¹ M (r_target − r̂)`). A move beyond a mass's travel holds that mass at its
//! limit and the others take the rest while they still reach every direction (active set);
//! when they cannot, the plan is refused with the partial move each mass can make.
//!
//! Uncertainty: given the estimate `r̂` with covariance `Σ`, the centre of mass after the moves
//! is `r + A (Δs + ε) / M`, `ε` the positioning errors (independent, `σ_i` per mass), so its
//! prediction is `r̂ + A Δs / M` with covariance `Σ + A diag(σ_i²) Aᵀ / M²`. The moves' own
//! standard errors follow from `∂Δs/∂r̂ = −M A_Fᵀ (A_F A_Fᵀ)⁻¹` over the free masses `F`.

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;
use testbed_model::balance_config::BalanceConfig;

/// The identified centre-of-mass offset and its covariance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ComEstimate {
    /// Offset from the bearing's centre of rotation, m, body axes.
    pub r_m: [f64; 3],
    /// Covariance, m².
    pub cov_m2: [[f64; 3]; 3],
    /// Where the covariance came from (`covariance` of the report, or its standard errors
    /// taken as independent).
    pub covariance_source: &'static str,
}

/// One mass's move.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Move {
    pub name: String,
    /// Move along the mass's axis, m.
    pub delta_m: f64,
    /// Its standard error from the estimate's covariance, m (0 for a mass held at a limit).
    pub delta_stddev_m: f64,
    /// Position along the axis from the travel's centre, before and after, m.
    pub from_m: f64,
    pub to_m: f64,
    /// Held at a travel limit (the other masses take the rest).
    pub at_limit: bool,
}

/// The balance plan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    pub estimate: ComEstimate,
    /// The offset the moves aim at, m, body axes.
    pub target_m: [f64; 3],
    pub moves: Vec<Move>,
    /// Predicted offset after the moves, m, its covariance, m², and standard deviations, m.
    pub predicted_m: [f64; 3],
    pub predicted_cov_m2: [[f64; 3]; 3],
    pub predicted_stddev_m: [f64; 3],
    /// RMS of the predicted horizontal offset, `sqrt(x̄² + ȳ² + σx² + σy²)`, m.
    pub horizontal_rms_m: f64,
    pub horizontal_tolerance_m: f64,
    /// `horizontal_rms_m <= horizontal_tolerance_m`.
    pub within_tolerance: bool,
}

/// A move beyond a mass's travel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TravelViolation {
    /// Index in `balance.masses`, and the mass's name.
    pub index: usize,
    pub name: String,
    /// The move the balance needs, m.
    pub needed_m: f64,
    /// How far past the limit it goes, m.
    pub excess_m: f64,
    /// The move its travel allows, m.
    pub possible_m: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum BalanceError {
    #[error("`{key}` = {value}: {reason}")]
    Invalid {
        key: String,
        value: String,
        reason: String,
    },
    #[error(
        "the identification names no com_offset (verdict: {verdict}): it found no \
         centre-of-mass offset the record resolves, so there is nothing to balance from it"
    )]
    NoComOffset { verdict: String },
    #[error("the identification report: {0}")]
    Report(String),
    #[error("{}", travel_message(violations, partial))]
    BeyondTravel {
        violations: Vec<TravelViolation>,
        /// The plan with every mass moved as far as its travel allows.
        partial: Box<Plan>,
    },
}

fn travel_message(violations: &[TravelViolation], partial: &Plan) -> String {
    let each: Vec<String> = violations
        .iter()
        .map(|v| {
            format!(
                "balance.masses[{}] (\"{}\") needs {:+.3} mm, {:.3} mm beyond its travel; it can move {:+.3} mm",
                v.index,
                v.name,
                v.needed_m * 1e3,
                v.excess_m * 1e3,
                v.possible_m * 1e3
            )
        })
        .collect();
    let p = partial.predicted_m;
    format!(
        "the balance needs moves beyond the masses' travel: {}; with every mass moved as far as \
         it can, the centre of mass would be at [{:.3}, {:.3}, {:.3}] µm (target [{:.3}, {:.3}, {:.3}] µm)",
        each.join("; "),
        p[0] * 1e6,
        p[1] * 1e6,
        p[2] * 1e6,
        partial.target_m[0] * 1e6,
        partial.target_m[1] * 1e6,
        partial.target_m[2] * 1e6
    )
}

/// The centre-of-mass estimate of an `identify` report (its JSON form, as `testbed identify
/// --json` prints and `report.json` holds): the `com_offset` cause's `r_m`, with the cause's
/// `covariance.r_m` (3 × 3, m²) when present, else its standard errors taken as independent.
pub fn com_estimate(report: &serde_json::Value) -> Result<ComEstimate, BalanceError> {
    let causes = report
        .get("causes")
        .and_then(|c| c.as_array())
        .ok_or_else(|| BalanceError::Report("no `causes` list: not an identify report".into()))?;
    let cause = causes
        .iter()
        .find(|c| c.get("name").and_then(|n| n.as_str()) == Some("com_offset"))
        .ok_or_else(|| BalanceError::NoComOffset {
            verdict: report
                .get("verdict")
                .and_then(|v| v.as_str())
                .unwrap_or("?")
                .to_string(),
        })?;
    let vec3 = |v: Option<&serde_json::Value>, what: &str| -> Result<[f64; 3], BalanceError> {
        let a = v
            .and_then(|v| v.as_array())
            .filter(|a| a.len() == 3)
            .ok_or_else(|| BalanceError::Report(format!("com_offset: no `{what}` of 3 numbers")))?;
        let mut out = [f64::NAN; 3];
        for (o, x) in out.iter_mut().zip(a) {
            *o = x.as_f64().unwrap_or(f64::NAN);
        }
        if out.iter().any(|x| !x.is_finite()) {
            return Err(BalanceError::Report(format!(
                "com_offset: `{what}` = {out:?}: every component must be a finite number \
                 (one was not estimated)"
            )));
        }
        Ok(out)
    };
    let r_m = vec3(cause.pointer("/parameters/r_m"), "parameters.r_m")?;
    let (cov_m2, covariance_source) = match cause.pointer("/covariance/r_m") {
        Some(rows) => {
            let rows = rows.as_array().filter(|r| r.len() == 3).ok_or_else(|| {
                BalanceError::Report("com_offset: `covariance.r_m` is not 3 × 3".into())
            })?;
            let mut cov = [[0.0; 3]; 3];
            for (i, row) in rows.iter().enumerate() {
                cov[i] = vec3(Some(row), "covariance.r_m row")?;
            }
            (cov, "the report's covariance")
        }
        None => {
            let se = vec3(cause.pointer("/stderr/r_m"), "stderr.r_m")?;
            let mut cov = [[0.0; 3]; 3];
            for i in 0..3 {
                cov[i][i] = se[i] * se[i];
            }
            (cov, "the report's standard errors, taken as independent")
        }
    };
    Ok(ComEstimate {
        r_m,
        cov_m2,
        covariance_source,
    })
}

/// The moves that bring `estimate` to `[0, 0, vertical_target_m]` with the masses of
/// `config` on a platform of `platform_mass_kg` (balance masses included). `config` must be
/// valid ([`BalanceConfig::validate`]).
pub fn plan(
    estimate: &ComEstimate,
    config: &BalanceConfig,
    platform_mass_kg: f64,
    vertical_target_m: f64,
) -> Result<Plan, BalanceError> {
    let moving: f64 = config.masses.iter().map(|m| m.mass_kg).sum();
    if !(platform_mass_kg.is_finite() && platform_mass_kg > moving) {
        return Err(BalanceError::Invalid {
            key: "model.platform.mass_kg".into(),
            value: platform_mass_kg.to_string(),
            reason: format!(
                "must exceed the balance masses' total ({moving} kg): they are part of it"
            ),
        });
    }
    if !vertical_target_m.is_finite() {
        return Err(BalanceError::Invalid {
            key: "vertical target".into(),
            value: vertical_target_m.to_string(),
            reason: "must be finite".into(),
        });
    }
    let m_total = platform_mass_kg;
    let cols = config.moment_columns();
    let n = cols.len();
    let r_hat = Vector3::from(estimate.r_m);
    let target = Vector3::new(0.0, 0.0, vertical_target_m);
    let moment = (target - r_hat) * m_total;
    let room: Vec<(f64, f64)> = config
        .masses
        .iter()
        .map(|m| (m.travel_m[0] - m.position_m, m.travel_m[1] - m.position_m))
        .collect();
    let excess = |d: f64, (lo, hi): (f64, f64)| (lo - d).max(d - hi).max(0.0);

    let unconstrained = min_norm(&cols, &vec![None; n], &moment)
        .ok_or_else(|| BalanceError::Invalid {
            key: "balance.masses".into(),
            value: format!("{n} masses"),
            reason: "they cannot move the centre of mass along every direction".into(),
        })?
        .0;
    // Active set: hold the mass furthest past its travel at its limit, solve for the rest.
    let mut fixed: Vec<Option<f64>> = vec![None; n];
    let solved = loop {
        let Some((delta, jac)) = min_norm(&cols, &fixed, &moment) else {
            break None;
        };
        let worst = (0..n)
            .filter(|&i| fixed[i].is_none())
            .map(|i| (i, excess(delta[i], room[i])))
            .filter(|&(_, e)| e > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        match worst {
            None => break Some((delta, jac)),
            Some((i, _)) => fixed[i] = Some(delta[i].clamp(room[i].0, room[i].1)),
        }
    };
    let build = |delta: &[f64], jac: Option<&Vec<Vector3<f64>>>, fixed: &[Option<f64>]| {
        assemble(estimate, config, &cols, m_total, target, delta, jac, fixed)
    };
    match solved {
        Some((delta, jac)) => Ok(build(&delta, Some(&jac), &fixed)),
        None => {
            let violations: Vec<TravelViolation> = (0..n)
                .filter(|&i| excess(unconstrained[i], room[i]) > 0.0)
                .map(|i| TravelViolation {
                    index: i,
                    name: config.masses[i].name.clone(),
                    needed_m: unconstrained[i],
                    excess_m: excess(unconstrained[i], room[i]),
                    possible_m: unconstrained[i].clamp(room[i].0, room[i].1),
                })
                .collect();
            let clamped: Vec<f64> = (0..n)
                .map(|i| unconstrained[i].clamp(room[i].0, room[i].1))
                .collect();
            let at_limit: Vec<Option<f64>> = (0..n)
                .map(|i| (excess(unconstrained[i], room[i]) > 0.0).then_some(clamped[i]))
                .collect();
            Err(BalanceError::BeyondTravel {
                violations,
                partial: Box::new(build(&clamped, None, &at_limit)),
            })
        }
    }
}

/// Minimum-norm moves of the masses not `fixed` (the fixed ones at their value) for the total
/// moment change `moment`, and per mass `∂Δs_i/∂r̂` divided by −M (zero for fixed masses);
/// `None` when the free masses do not reach every direction.
fn min_norm(
    cols: &[Vector3<f64>],
    fixed: &[Option<f64>],
    moment: &Vector3<f64>,
) -> Option<(Vec<f64>, Vec<Vector3<f64>>)> {
    let mut g = Matrix3::zeros();
    let mut rhs = *moment;
    for (c, f) in cols.iter().zip(fixed) {
        match f {
            None => g += c * c.transpose(),
            Some(d) => rhs -= c * *d,
        }
    }
    // Relative conditioning: a free set that misses a direction is singular to rounding.
    let eig = g.symmetric_eigenvalues();
    if !eig.max().is_finite() || eig.max() <= 0.0 || eig.min() <= 1e-9 * eig.max() {
        return None;
    }
    let g_inv = g.try_inverse()?;
    let lambda = g_inv * rhs;
    let delta = cols
        .iter()
        .zip(fixed)
        .map(|(c, f)| f.unwrap_or_else(|| c.dot(&lambda)))
        .collect();
    // Δs_i = c_iᵀ G⁻¹ (M (r_t − r̂) − …): ∂Δs_i/∂r̂ = −M G⁻¹ c_i.
    let jac = cols
        .iter()
        .zip(fixed)
        .map(|(c, f)| {
            if f.is_some() {
                Vector3::zeros()
            } else {
                g_inv * c
            }
        })
        .collect();
    Some((delta, jac))
}

/// The plan of the moves `delta` (`jac` from [`min_norm`]; `None`: no move uncertainty).
#[allow(clippy::too_many_arguments)]
fn assemble(
    estimate: &ComEstimate,
    config: &BalanceConfig,
    cols: &[Vector3<f64>],
    m_total: f64,
    target: Vector3<f64>,
    delta: &[f64],
    jac: Option<&Vec<Vector3<f64>>>,
    fixed: &[Option<f64>],
) -> Plan {
    let sigma = Matrix3::from(estimate.cov_m2).transpose();
    let mut shift = Vector3::zeros();
    let mut positioning = Matrix3::zeros();
    for ((c, d), m) in cols.iter().zip(delta).zip(&config.masses) {
        shift += c * *d / m_total;
        positioning += c * c.transpose() * (m.position_stddev_m / m_total).powi(2);
    }
    let predicted = Vector3::from(estimate.r_m) + shift;
    let cov = sigma + positioning;
    let moves = config
        .masses
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let sd = jac.map_or(0.0, |j| {
                let g = j[i] * m_total;
                (g.transpose() * sigma * g)[0].max(0.0).sqrt()
            });
            Move {
                name: m.name.clone(),
                delta_m: delta[i],
                delta_stddev_m: sd,
                from_m: m.position_m,
                to_m: m.position_m + delta[i],
                at_limit: fixed[i].is_some(),
            }
        })
        .collect();
    let horizontal_rms_m =
        (predicted.x.powi(2) + predicted.y.powi(2) + cov[(0, 0)] + cov[(1, 1)]).sqrt();
    let mut predicted_cov_m2 = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            predicted_cov_m2[i][j] = cov[(i, j)];
        }
    }
    Plan {
        estimate: estimate.clone(),
        target_m: target.into(),
        moves,
        predicted_m: predicted.into(),
        predicted_cov_m2,
        predicted_stddev_m: [0, 1, 2].map(|i| cov[(i, i)].max(0.0).sqrt()),
        horizontal_rms_m,
        horizontal_tolerance_m: config.horizontal_tolerance_m,
        within_tolerance: horizontal_rms_m <= config.horizontal_tolerance_m,
    }
}

#[cfg(test)]
#[path = "balance_tests.rs"]
mod tests;
