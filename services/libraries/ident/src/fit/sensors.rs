//! Sensor causes (gyro scale and misalignment, Earth rate, hard and soft iron, inclinometer
//! offset and scale): Gauss–Newton on the filter's whitened innovations (the prediction-error method), with the Jacobian by finite
//! differences through the filter ([`super::jacobian`]), an optional first-order screen, and
//! damped steps within the causes' bounds.

use super::jacobian::{forward_jacobian, normal_equations};
use super::{FittedCause, Problem};
use crate::effects::Cause;
use crate::error::IdentError;
use crate::stats::LsFit;
use std::collections::HashMap;
use testbed_model::ModelConfig;

impl Problem<'_> {
    /// Fit the sensor causes `set` jointly (see [`Problem::fit_screened`] for `warm` and
    /// `screen`): the configuration with the fitted values, and the fitted causes.
    pub(super) fn fit_sensors(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
        screen: Option<(f64, f64)>,
    ) -> Result<(ModelConfig, Vec<FittedCause>), IdentError> {
        if set.iter().all(|c| warm.contains_key(c)) {
            let mut config = self.base.clone();
            let fitted: Vec<FittedCause> =
                set.iter().filter_map(|c| warm.get(c).cloned()).collect();
            for f in &fitted {
                f.cause.apply(&mut config, &f.values);
            }
            return Ok((config, fitted));
        }
        let mut theta: Vec<f64> = Vec::new();
        let mut layout: Vec<(Cause, usize)> = Vec::new();
        for &cause in set {
            let start = match warm.get(&cause) {
                Some(f) => f.values.clone(),
                None => self.initial_sensor_values(cause)?,
            };
            layout.push((cause, start.len()));
            theta.extend(start);
        }
        let build = |theta: &[f64]| {
            let mut config = self.base.clone();
            let mut i = 0;
            for &(cause, len) in &layout {
                cause.apply(&mut config, &theta[i..i + len]);
                i += len;
            }
            config
        };
        let clamp = |theta: &mut [f64]| {
            let mut i = 0;
            for &(cause, len) in &layout {
                for j in 0..len {
                    let (lo, hi) = cause.bounds(j);
                    theta[i + j] = theta[i + j].clamp(lo, hi);
                }
                i += len;
            }
        };
        let steps: Vec<f64> = layout
            .iter()
            .flat_map(|&(cause, _)| {
                cause
                    .params()
                    .iter()
                    .flat_map(|p| std::iter::repeat_n(p.step, p.len))
            })
            .collect();
        let p = theta.len();
        // Innovations at finite-difference steps (filter runs not worth caching).
        let perturbed = |ts: &[Vec<f64>]| -> Result<Vec<Vec<f64>>, IdentError> {
            self.perturbed_innovations(&ts.iter().map(|t| build(t)).collect::<Vec<_>>())
        };
        let mut r0 = self.fit_innovations(&*self.recon(&build(&theta))?);
        let rss = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
        let mut last: Option<LsFit> = None;
        // Screening with causes already fitted (warm): only the new causes' columns are
        // linearised first; the fitted ones sit at their optimum. Except the magnetometer's two:
        // a soft iron fitted alone takes up part of a hard iron (its column on the nearly
        // constant vertical field is one) and a hard iron part of a soft iron, so each is
        // screened with the other free, or the second would never be tried.
        let new_magnetometer = layout
            .iter()
            .any(|&(c, _)| c.magnetometer() && !warm.contains_key(&c));
        let new_params: Vec<bool> = layout
            .iter()
            .flat_map(|&(cause, len)| {
                let screened =
                    !warm.contains_key(&cause) || (new_magnetometer && cause.magnetometer());
                std::iter::repeat_n(screened, len)
            })
            .collect();
        if let Some((threshold, reference)) = screen.filter(|_| new_params.iter().any(|n| !n)) {
            let idx: Vec<usize> = (0..p).filter(|&j| new_params[j]).collect();
            let cols = forward_jacobian(
                &theta,
                &r0,
                &idx,
                &steps,
                |j| bound_of(&layout, j),
                perturbed,
            )?;
            let ne = normal_equations(&cols, &r0);
            let predicted = ne
                .solve()
                .map_or(0.0, |f| (reference - f.rss) / f.sigma2().max(1e-300));
            if predicted < 0.5 * threshold {
                return Ok(self.unchanged(&layout, &theta, &build(&theta)));
            }
        }
        for _iteration in 0..8 {
            // Jacobian by forward differences (steps away from the nearer bound).
            let all: Vec<usize> = (0..p).collect();
            let columns = forward_jacobian(
                &theta,
                &r0,
                &all,
                &steps,
                |j| bound_of(&layout, j),
                perturbed,
            )?;
            let ne = normal_equations(&columns, &r0);
            let Some(fit) = ne.solve() else {
                return Err(IdentError::Failed(format!(
                    "{}: the data do not determine the parameters (no excitation of this effect)",
                    set.iter().map(|c| c.name()).collect::<Vec<_>>().join(" + ")
                )));
            };
            let stderr = fit.stderr();
            let step: Vec<f64> = fit.theta.iter().copied().collect();
            let small = step
                .iter()
                .zip(&stderr)
                .all(|(d, s)| d.abs() <= 0.05 * s.max(1e-300));
            let rss0 = rss(&r0);
            if let Some((threshold, reference)) = screen.filter(|_| last.is_none()) {
                let predicted = (reference - fit.rss) / fit.sigma2().max(1e-300);
                if predicted < 0.5 * threshold {
                    last = Some(fit);
                    break;
                }
            }
            // Damped step: halve until the residual decreases.
            let mut scale = 1.0;
            let mut accepted = false;
            for _ in 0..6 {
                let mut t: Vec<f64> = theta
                    .iter()
                    .zip(&step)
                    .map(|(a, d)| a + scale * d)
                    .collect();
                clamp(&mut t);
                let r = self.fit_innovations(&*self.recon(&build(&t))?);
                if rss(&r) <= rss0 {
                    theta = t;
                    r0 = r;
                    accepted = true;
                    break;
                }
                scale *= 0.5;
            }
            last = Some(fit);
            if small || !accepted {
                break;
            }
        }
        let config = build(&theta);
        let fit = last.ok_or_else(|| IdentError::Failed("sensor fit did not run".into()))?;
        // Standard errors: residual-scaled Gauss–Newton covariance at the last linearisation.
        let stderr = fit.stderr();
        let mut out = Vec::new();
        let mut i = 0;
        for &(cause, len) in &layout {
            let values = theta[i..i + len].to_vec();
            let se: Vec<f64> = (0..len)
                .map(|j| {
                    let (lo, hi) = cause.bounds(j);
                    if values[j] <= lo || values[j] >= hi {
                        f64::NAN
                    } else {
                        stderr[i + j]
                    }
                })
                .collect();
            out.push(FittedCause::estimated(cause, values, se));
            i += len;
        }
        Ok((config, out))
    }

    /// A sensor fit that stopped at its starting values (screened out): the values, no standard
    /// errors, every value counted as estimated.
    fn unchanged(
        &self,
        layout: &[(Cause, usize)],
        theta: &[f64],
        config: &ModelConfig,
    ) -> (ModelConfig, Vec<FittedCause>) {
        let mut out = Vec::new();
        let mut i = 0;
        for &(cause, len) in layout {
            out.push(FittedCause {
                cause,
                values: theta[i..i + len].to_vec(),
                stderr: vec![f64::NAN; len],
                free: len,
                note: "screened out: not significant to first order".into(),
            });
            i += len;
        }
        (config.clone(), out)
    }
}

fn bound_of(layout: &[(Cause, usize)], index: usize) -> (f64, f64) {
    let mut i = index;
    for &(cause, len) in layout {
        if i < len {
            return cause.bounds(i);
        }
        i -= len;
    }
    (f64::NEG_INFINITY, f64::INFINITY)
}
