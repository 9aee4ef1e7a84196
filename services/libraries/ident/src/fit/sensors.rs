//! Sensor causes (gyro scale and misalignment, Earth rate, hard and soft iron, inclinometer
//! offset and scale): Gauss–Newton on the filter's whitened innovations (the prediction-error
//! method), with the Jacobian by finite differences through the filter ([`super::jacobian`]),
//! and damped steps within the causes' bounds. Before it, an optional first-order screen whose
//! Jacobian is the filter's sensitivities from one run ([`crate::tangent`]): a candidate whose
//! predicted fall of the residual sum is under half the selection's threshold is not fitted.

use super::jacobian::{forward_jacobian, normal_equations, perturbations};
use super::{FittedCause, Problem, SensorLinearisation, TangentRun, build_sensors};
use crate::effects::{Cause, Kind};
use crate::error::IdentError;
use crate::stats::LsFit;
use std::collections::HashMap;
use testbed_model::ModelConfig;

/// Each cause of `set` with its number of parameters: the layout of a sensor fit's parameter
/// vector.
fn layout_of(set: &[Cause]) -> Vec<(Cause, usize)> {
    set.iter().map(|&c| (c, c.len())).collect()
}

/// Where a sensor fit of a set of causes starts.
struct Start {
    layout: Vec<(Cause, usize)>,
    /// Starting values: the fitted values of the causes in `warm`, the others' initial guesses.
    theta: Vec<f64>,
    /// Finite-difference step of each parameter.
    steps: Vec<f64>,
    /// The parameters the screen linearises first (of the causes not fitted before).
    new_params: Vec<bool>,
}

impl Start {
    /// The parameters a screen linearises: the new ones, or all when every one is new.
    fn screened(&self) -> Vec<usize> {
        let p = self.theta.len();
        if self.new_params.iter().any(|n| !n) {
            (0..p).filter(|&j| self.new_params[j]).collect()
        } else {
            (0..p).collect()
        }
    }

    /// The screen at this start on `base`: a direction per screened parameter, its step away
    /// from the nearer bound.
    fn screen(&self, base: &ModelConfig) -> TangentRun {
        TangentRun::stepped(
            &self.theta,
            &self.screened(),
            &self.steps,
            |j| bound_of(&self.layout, j),
            |theta| build_sensors(base, &self.layout, theta),
        )
    }
}

impl Problem<'_> {
    /// Where a fit of the sensor causes `set` starts ([`Start`]).
    fn start(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
    ) -> Result<Start, IdentError> {
        let layout = layout_of(set);
        let mut theta: Vec<f64> = Vec::new();
        for &cause in set {
            theta.extend(match warm.get(&cause) {
                Some(f) => f.values.clone(),
                None => self.initial_sensor_values(cause)?,
            });
        }
        debug_assert_eq!(theta.len(), layout.iter().map(|l| l.1).sum::<usize>());
        let steps: Vec<f64> = layout
            .iter()
            .flat_map(|&(cause, _)| {
                cause
                    .params()
                    .iter()
                    .flat_map(|p| std::iter::repeat_n(p.step, p.len))
            })
            .collect();
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
        Ok(Start {
            layout,
            theta,
            steps,
            new_params,
        })
    }

    /// Where a screened fit of the sensor causes of `set` starts, or `None` when it would keep
    /// its warm values (or `set` has no sensor cause).
    fn sensor_start(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
    ) -> Result<Option<Start>, IdentError> {
        let sensor: Vec<Cause> = set
            .iter()
            .copied()
            .filter(|c| c.kind() == Kind::Sensor)
            .collect();
        if sensor.is_empty() || sensor.iter().all(|c| warm.contains_key(c)) {
            return Ok(None);
        }
        self.start(&sensor, warm).map(Some)
    }

    /// The screen a screened fit of the sensor causes of `set` begins with: linearised at its
    /// starting values, in the directions of the parameters not fitted before (all of them
    /// when none was). Run together ahead of the fits ([`Problem::prefetch_tangents`]), the
    /// screens of many candidates fill the cores. `None` when the fit would keep its warm
    /// values.
    pub fn screen_request(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
    ) -> Result<Option<TangentRun>, IdentError> {
        Ok(self.sensor_start(set, warm)?.map(|s| s.screen(&self.base)))
    }

    /// The screen of a sensor fit: whether the fall of the residual sum it predicts to first
    /// order, from the filter's sensitivities at the start (one run), reaches half the
    /// selection's threshold. `screen`: that threshold, and the residual sum the fall is from
    /// (the set chosen so far).
    pub fn screen_passes(
        &self,
        run: &TangentRun,
        (threshold, reference): (f64, f64),
    ) -> Result<bool, IdentError> {
        let predicted = self
            .tangent_normal_equations(run)?
            .solve()
            .map_or(0.0, |f| (reference - f.rss) / f.sigma2().max(1e-300));
        Ok(predicted >= 0.5 * threshold)
    }

    /// The filter runs of the first finite-difference Jacobian of a fit of the sensor causes of
    /// `set` (at its start, every parameter stepped): run ahead, in one batch, for the
    /// candidates whose screens pass.
    pub fn first_jacobian_runs(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
    ) -> Result<Vec<ModelConfig>, IdentError> {
        let Some(start) = self.sensor_start(set, warm)? else {
            return Ok(Vec::new());
        };
        let all: Vec<usize> = (0..start.theta.len()).collect();
        Ok(perturbations(&start.theta, &all, &start.steps, |j| {
            bound_of(&start.layout, j)
        })
        .iter()
        .map(|t| build_sensors(&self.base, &start.layout, t))
        .collect())
    }

    /// Fit the sensor causes `set` jointly (see [`Problem::fit_screened`] for `warm` and
    /// `screen`, [`Problem::fit_from`] for `from`): the configuration with the fitted values,
    /// the fitted causes, and the last linearisation (none when the values were kept or
    /// screened out).
    pub(super) fn fit_sensors(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
        screen: Option<(f64, f64)>,
        from: Option<&SensorLinearisation>,
    ) -> Result<SensorFit, IdentError> {
        if set.iter().all(|c| warm.contains_key(c)) {
            let mut config = self.base.clone();
            let fitted: Vec<FittedCause> =
                set.iter().filter_map(|c| warm.get(c).cloned()).collect();
            for f in &fitted {
                f.cause.apply(&mut config, &f.values);
            }
            return Ok((config, fitted, None));
        }
        let layout = layout_of(set);
        if let Some(from) = from.filter(|f| f.layout == layout) {
            let (theta, fit) = self.step_from(from)?;
            let config = build_sensors(&self.base, &layout, &theta);
            let fitted = fitted_causes(&layout, &theta, &fit.stderr());
            return Ok((config, fitted, None));
        }
        let start = self.start(set, warm)?;
        if let Some(screen) = screen {
            let request = start.screen(&self.base);
            if !self.screen_passes(&request, screen)? {
                let (config, fitted) = self.unchanged(&start.layout, &start.theta, &request.start);
                return Ok((config, fitted, None));
            }
        }
        let Start {
            layout,
            mut theta,
            steps,
            ..
        } = start;
        let build = |theta: &[f64]| build_sensors(&self.base, &layout, theta);
        let clamp = |theta: &mut [f64]| clamp_to_bounds(&layout, theta);
        let p = theta.len();
        // Innovations at finite-difference steps (filter runs not worth caching).
        let perturbed = |ts: &[Vec<f64>]| -> Result<Vec<Vec<f64>>, IdentError> {
            self.perturbed_innovations(&ts.iter().map(|t| build(t)).collect::<Vec<_>>())
        };
        let mut r0 = self.fit_innovations(&*self.recon(&build(&theta))?);
        let mut last: Option<LsFit> = None;
        let mut linearisation: Option<SensorLinearisation> = None;
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
            let fit = ne.solve().ok_or_else(|| undetermined(&layout))?;
            let stderr = fit.stderr();
            let step: Vec<f64> = fit.theta.iter().copied().collect();
            let small = step
                .iter()
                .zip(&stderr)
                .all(|(d, s)| d.abs() <= 0.05 * s.max(1e-300));
            let rss0 = rss(&r0);
            linearisation = Some(SensorLinearisation {
                layout: layout.clone(),
                theta: theta.clone(),
                ticks: Vec::new(),
                residual: r0.clone(),
                columns,
            });
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
        let fitted = fitted_causes(&layout, &theta, &fit.stderr());
        // The rows' ticks, from the filter run the linearisation was taken on (cached).
        if let Some(l) = &mut linearisation {
            l.ticks = self
                .recon(&build(&l.theta))?
                .innovation_ticks(|k| !self.held_out[k]);
            debug_assert_eq!(l.ticks.len(), l.residual.len());
        }
        Ok((config, fitted, linearisation))
    }

    /// One Gauss–Newton step from `from` on this problem's fit rows: the parameters (within
    /// their bounds) and the linearised fit. The step is kept when the filter run at its end
    /// fits these rows no worse than where it started; otherwise the parameters stay.
    fn step_from(&self, from: &SensorLinearisation) -> Result<(Vec<f64>, LsFit), IdentError> {
        let (mut theta, fit, rss_before) = self.linear_step(from)?;
        let config = build_sensors(&self.base, &from.layout, &theta);
        if rss(&self.fit_innovations(&*self.recon(&config)?)) > rss_before {
            theta = from.theta.clone();
        }
        Ok((theta, fit))
    }

    /// The parameters one Gauss–Newton step from `from` on this problem's fit rows (within
    /// their bounds; no filter run), the linearised fit, and the residual sum where it starts.
    pub(super) fn linear_step(
        &self,
        from: &SensorLinearisation,
    ) -> Result<(Vec<f64>, LsFit, f64), IdentError> {
        let rows: Vec<usize> = (0..from.ticks.len())
            .filter(|&i| !self.held_out[from.ticks[i]])
            .collect();
        let r: Vec<f64> = rows.iter().map(|&i| from.residual[i]).collect();
        let columns: Vec<Vec<f64>> = from
            .columns
            .iter()
            .map(|c| rows.iter().map(|&i| c[i]).collect())
            .collect();
        let fit = normal_equations(&columns, &r)
            .solve()
            .ok_or_else(|| undetermined(&from.layout))?;
        let mut theta: Vec<f64> = from
            .theta
            .iter()
            .zip(fit.theta.iter())
            .map(|(a, d)| a + d)
            .collect();
        clamp_to_bounds(&from.layout, &mut theta);
        Ok((theta, fit, rss(&r)))
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

/// A sensor fit's configuration, fitted causes and last linearisation.
pub(super) type SensorFit = (ModelConfig, Vec<FittedCause>, Option<SensorLinearisation>);

fn rss(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

fn undetermined(layout: &[(Cause, usize)]) -> IdentError {
    IdentError::Failed(format!(
        "{}: the data do not determine the parameters (no excitation of this effect)",
        layout
            .iter()
            .map(|(c, _)| c.name())
            .collect::<Vec<_>>()
            .join(" + ")
    ))
}

/// Each cause of `layout` with its values from `theta` and standard errors from `stderr` (NaN
/// for a value at a bound: not estimated).
fn fitted_causes(layout: &[(Cause, usize)], theta: &[f64], stderr: &[f64]) -> Vec<FittedCause> {
    let mut out = Vec::new();
    let mut i = 0;
    for &(cause, len) in layout {
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
    out
}

fn clamp_to_bounds(layout: &[(Cause, usize)], theta: &mut [f64]) {
    let mut i = 0;
    for &(cause, len) in layout {
        for j in 0..len {
            let (lo, hi) = cause.bounds(j);
            theta[i + j] = theta[i + j].clamp(lo, hi);
        }
        i += len;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Aligned;
    use crate::experiment::{self, ExperimentOptions};
    use crate::fit::FitOptions;

    /// A screen's columns from the filter's sensitivities (one run beside its tangent) against
    /// finite differences of whole filter runs at the same steps, for every sensor cause of the
    /// library, screened alone at its start on 600 s of the identification experiment with a
    /// gyro scale error and a hard iron hidden. Neither is exact (the differences carry the
    /// step's curvature, the sensitivities hold the gains), so the bounds are on their
    /// agreement: every column within 15 % in norm (measured: 2e-5 to 0.11, soft iron the
    /// largest), and the screen's quantity, the predicted fall of the residual sum, within 20 %
    /// or 2 (measured: under 1 % where it is large, 16 % for an inclinometer scale at 285, 1.3
    /// for a gyro misalignment at 11; the screen compares it with half the selection's
    /// threshold, at least 12).
    #[test]
    fn tangent_columns_are_the_finite_differences_of_filter_runs() {
        const PREDICTED_TOLERANCE: f64 = 0.2;
        const PREDICTED_FLOOR: f64 = 10.0;
        const COLUMN_TOLERANCE: f64 = 0.15;
        let truth = ModelConfig::from_toml_str(
            "[effects.gyro_scale]\nppm = [500.0, -700.0, 900.0]\n\
             [effects.magnetic_disturbance]\nhard_iron_gauss = [0.02, -0.01, 0.0]\n",
            "test truth",
        )
        .expect("truth parses");
        let options = ExperimentOptions {
            duration_s: 600.0,
            seed: 3,
            ..ExperimentOptions::default()
        };
        let (data, _) = experiment::run(&truth, &options).expect("experiment runs");
        let aligned = Aligned::new(&data);
        let held_out = vec![false; aligned.len()];
        let problem = Problem::new(
            &aligned,
            ModelConfig::default(),
            held_out,
            f64::INFINITY,
            FitOptions::default(),
        );
        for cause in Cause::ALL.into_iter().filter(|c| c.kind() == Kind::Sensor) {
            let Some(request) = problem
                .screen_request(&[cause], &HashMap::new())
                .expect("screen request")
            else {
                continue;
            };
            let columns = problem.tangent_columns(&request).expect("sensitivities");
            let r0 = problem.fit_innovations(&problem.recon(&request.start).expect("run"));
            let finite: Vec<Vec<f64>> = request
                .directions
                .iter()
                .map(|(config, step)| {
                    let run =
                        crate::reconstruct::reconstruct(&aligned, config).expect("filter run");
                    let r = problem.fit_innovations(&run);
                    r.iter().zip(&r0).map(|(a, b)| (a - b) / step).collect()
                })
                .collect();
            let predicted = |cols: &[Vec<f64>]| {
                normal_equations(cols, &r0)
                    .solve()
                    .map_or(0.0, |f| rss(&r0) - f.rss)
            };
            let (by_tangent, by_runs) = (predicted(&columns), predicted(&finite));
            println!(
                "{}: predicted fall of the residual sum {by_tangent:.4e} (sensitivities) against {by_runs:.4e} (finite differences)",
                cause.name()
            );
            assert!(
                (by_tangent - by_runs).abs()
                    <= PREDICTED_TOLERANCE * by_runs.abs().max(PREDICTED_FLOOR),
                "{}: {by_tangent} against {by_runs}",
                cause.name()
            );
            for (j, (t, f)) in columns.iter().zip(&finite).enumerate() {
                let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
                let diff: Vec<f64> = t.iter().zip(f).map(|(a, b)| a - b).collect();
                let relative = norm(&diff) / norm(f).max(1e-300);
                println!("    column {j}: relative difference {relative:.2e}");
                assert!(
                    relative < COLUMN_TOLERANCE,
                    "{} column {j}: {relative}",
                    cause.name()
                );
            }
        }
    }
}
