//! Fitting a set of candidate causes to the data, jointly, with standard errors.
//!
//! Each cause acts on one channel directly ([`Kind`]):
//! * **sensor** causes (gyro scale and misalignment, Earth rate, hard iron) change the readings
//!   the attitude filter sees; they are fitted by Gauss–Newton on the filter's whitened
//!   innovations (the prediction-error method), with Jacobians by finite differences through
//!   the filter, started for the hard iron from a sphere fit of the field readings;
//! * **torque** causes (centre-of-mass offset, constant torque, drag, inertia error) are linear
//!   in the torque channel: weighted least squares, with `aero_drag`'s coefficients kept ≥ 0;
//! * **wheel** causes are linear in the wheel channel for a given delay and Stribeck speed
//!   (`wheel_torque_scale`, `wheel_friction` levels); the delay and each wheel's Stribeck speed
//!   are found by 1-D search, their standard errors from the curvature of the residual sum.
//!
//! The sensor fit comes first (it changes the state the other channels are computed from). Every
//! fit reports the whitened residual sum of squares of each channel on the fit data and on the
//! held-out data.

use crate::channels::{
    TORQUE_COLUMNS, TorqueChannel, WheelChannel, WheelInterval, friction_integral,
    friction_regressors, torque_columns,
};
use crate::data::Aligned;
use crate::effects::{Cause, Kind};
use crate::error::IdentError;
use crate::reconstruct::{Reconstruction, reconstruct};
use crate::stats::{LsFit, NormalEquations, chi_square_quantile};
use nalgebra::{DVector, Vector3};
use serde::Serialize;
use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::rc::Rc;
use testbed_model::ModelConfig;
use testbed_model::attitude;
use testbed_model::config::GAUSS;
use testbed_model::physics::{Wheel, WheelFrictionModel};

/// The residual channels.
pub const CHANNELS: [&str; 3] = ["attitude", "torque", "wheel"];

/// Whitened residual sum of squares per channel ([`CHANNELS`] order) and the number of scalar
/// residuals in it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ChannelRss {
    pub rss: [f64; 3],
    pub n: [usize; 3],
}

impl ChannelRss {
    /// Likelihood-ratio statistic of `better` against `self` (Gaussian, each channel's variance
    /// estimated): `Σ n_c ln(RSS_c / RSS_c')`, positive when `better` fits better.
    pub fn log_ratio(&self, better: &ChannelRss) -> f64 {
        (0..3)
            .filter(|&c| self.n[c] > 0 && self.rss[c] > 0.0 && better.rss[c] > 0.0)
            .map(|c| self.n[c] as f64 * (self.rss[c] / better.rss[c]).ln())
            .sum()
    }
    /// Scalar residuals in all channels.
    pub fn total(&self) -> usize {
        self.n.iter().sum()
    }
    /// Root mean square of the whitened residuals of channel `c` (1 for noise as modelled).
    pub fn normalised_rms(&self, c: usize) -> f64 {
        if self.n[c] == 0 {
            f64::NAN
        } else {
            (self.rss[c] / self.n[c] as f64).sqrt()
        }
    }
}

/// Fit and held-out residual sums of one fitted configuration.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Evaluation {
    pub fit: ChannelRss,
    pub held_out: ChannelRss,
}

/// One fitted cause.
#[derive(Debug, Clone, PartialEq)]
pub struct FittedCause {
    pub cause: Cause,
    /// Values in [`Cause::values`] order (the configuration's units).
    pub values: Vec<f64>,
    /// Standard errors, same order; NaN where not estimated (held at a bound or not
    /// determined by the data).
    pub stderr: Vec<f64>,
    /// Parameters actually estimated (counted in the information criterion).
    pub free: usize,
    /// What the fit had to decide (e.g. friction model per wheel).
    pub note: String,
}

/// The estimated state and the channels built on it, for one sensor configuration.
#[derive(Debug)]
pub struct State {
    pub recon: Reconstruction,
    pub torque: TorqueChannel,
    pub wheel: WheelChannel,
}

/// A fitted set of causes.
#[derive(Debug, Clone)]
pub struct SetFit {
    /// Base configuration with the fitted effects.
    pub config: ModelConfig,
    pub causes: Vec<FittedCause>,
    pub evaluation: Evaluation,
    pub state: Rc<State>,
    /// Torque-channel parameter change from the base, per column.
    pub torque_delta: [f64; TORQUE_COLUMNS],
}

impl SetFit {
    /// Estimated parameters in the whole set.
    pub fn free(&self) -> usize {
        self.causes.iter().map(|c| c.free).sum()
    }
}

/// Settings of the fits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitOptions {
    /// Longest segment of the torque channel's integral form, s.
    pub torque_segment_s: f64,
    /// Largest actuator delay searched, s.
    pub max_delay_s: f64,
    /// Significance level of the tests inside the fits (Stribeck term per wheel), and the
    /// linearised screen of sensor causes.
    pub alpha: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            torque_segment_s: 15.0,
            max_delay_s: 1.0,
            alpha: 1e-6,
        }
    }
}

/// Everything the fits share: the data, the base configuration, which ticks are held out, and
/// the estimated states already computed.
pub struct Problem<'a> {
    pub data: &'a Aligned,
    pub base: ModelConfig,
    /// Per tick: held out from the fits.
    pub held_out: Vec<bool>,
    pub options: FitOptions,
    cache: RefCell<HashMap<String, Rc<State>>>,
    recons: RefCell<HashMap<String, Rc<Reconstruction>>>,
    /// Filter runs so far (for the benchmark and the report).
    pub filter_runs: Cell<usize>,
    sphere: RefCell<Option<Option<[f64; 3]>>>,
}

fn sensor_key(config: &ModelConfig) -> String {
    let mut key = String::new();
    for cause in Cause::ALL.into_iter().filter(|c| c.kind() == Kind::Sensor) {
        if cause.present(config) {
            key.push_str(&format!("{}={:?};", cause.name(), cause.values(config)));
        }
    }
    key
}

impl<'a> Problem<'a> {
    pub fn new(
        data: &'a Aligned,
        base: ModelConfig,
        held_out: Vec<bool>,
        options: FitOptions,
    ) -> Self {
        Self {
            data,
            base,
            held_out,
            options,
            cache: RefCell::new(HashMap::new()),
            recons: RefCell::new(HashMap::new()),
            filter_runs: Cell::new(0),
            sphere: RefCell::new(None),
        }
    }

    /// The filter run for the sensor effects of `config` (cached).
    fn recon(&self, config: &ModelConfig) -> Result<Rc<Reconstruction>, IdentError> {
        let key = sensor_key(config);
        if let Some(r) = self.recons.borrow().get(&key) {
            return Ok(r.clone());
        }
        self.filter_runs.set(self.filter_runs.get() + 1);
        let r = Rc::new(reconstruct(self.data, config)?);
        self.recons.borrow_mut().insert(key, r.clone());
        Ok(r)
    }

    /// A filter run that is not worth keeping (finite-difference steps).
    fn run_filter(&self, config: &ModelConfig) -> Result<Reconstruction, IdentError> {
        if let Some(r) = self.recons.borrow().get(&sensor_key(config)) {
            return Ok((**r).clone());
        }
        self.filter_runs.set(self.filter_runs.get() + 1);
        reconstruct(self.data, config)
    }

    /// The state and channels for the sensor effects of `config` (cached).
    pub fn state(&self, config: &ModelConfig) -> Result<Rc<State>, IdentError> {
        let key = sensor_key(config);
        if let Some(s) = self.cache.borrow().get(&key) {
            return Ok(s.clone());
        }
        let recon = (*self.recon(config)?).clone();
        let torque = TorqueChannel::new(
            self.data,
            &recon,
            &self.base,
            self.options.torque_segment_s,
            &self.held_out,
        );
        let wheel = WheelChannel::new(self.data, &recon, &self.base);
        let state = Rc::new(State {
            recon,
            torque,
            wheel,
        });
        self.cache.borrow_mut().insert(key, state.clone());
        Ok(state)
    }

    /// Forget cached states and filter runs (memory) except the base's and those of `keep`.
    pub fn trim_cache(&self, keep: &[&ModelConfig]) {
        let keys: Vec<String> = keep.iter().map(|c| sensor_key(c)).collect();
        self.cache
            .borrow_mut()
            .retain(|k, _| k.is_empty() || keys.contains(k));
        self.recons
            .borrow_mut()
            .retain(|k, _| k.is_empty() || keys.contains(k));
    }

    /// Innovation rows on the fit ticks.
    fn fit_innovations(&self, recon: &Reconstruction) -> Vec<f64> {
        recon.innovation_vector(|k| !self.held_out[k])
    }

    /// Fit the causes `set` jointly. Sensor causes in `warm` (fitted before) start from those
    /// values; when every sensor cause of the set is in `warm`, they are kept as they are (the
    /// other channels do not inform them).
    pub fn fit(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
    ) -> Result<SetFit, IdentError> {
        self.fit_screened(set, warm, None)
    }

    /// [`Problem::fit`], but the sensor fit stops after its first linearisation when that
    /// predicts an attitude-channel residual (whitened, fit data) above `screen.1` minus half
    /// of `screen.0` (the candidate cannot be significant; saves filter runs). `screen.1` is
    /// the residual of the model the candidate is compared with.
    pub fn fit_screened(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
        screen: Option<(f64, f64)>,
    ) -> Result<SetFit, IdentError> {
        let mut config = self.base.clone();
        let mut fitted: Vec<FittedCause> = Vec::new();

        let sensor: Vec<Cause> = set
            .iter()
            .copied()
            .filter(|c| c.kind() == Kind::Sensor)
            .collect();
        if !sensor.is_empty() {
            let (c, f) = self.fit_sensors(&sensor, warm, screen)?;
            config = c;
            fitted.extend(f);
        }
        let state = self.state(&config)?;

        let torque: Vec<Cause> = set
            .iter()
            .copied()
            .filter(|c| c.kind() == Kind::Torque)
            .collect();
        let mut torque_delta = [0.0; TORQUE_COLUMNS];
        if !torque.is_empty() {
            let (delta, f) = self.fit_torque(&state, &torque)?;
            torque_delta = delta;
            for fc in &f {
                fc.cause.apply(&mut config, &fc.values);
            }
            fitted.extend(f);
        }

        let wheel: Vec<Cause> = set
            .iter()
            .copied()
            .filter(|c| c.kind() == Kind::Wheel)
            .collect();
        if !wheel.is_empty() {
            let f = self.fit_wheels(&state, &wheel)?;
            for fc in &f {
                fc.cause.apply(&mut config, &fc.values);
            }
            fitted.extend(f);
        }
        config.validate()?;
        let evaluation = self.evaluate(&state, &config, &torque_delta);
        // Order as the set was given.
        fitted.sort_by_key(|f| set.iter().position(|c| *c == f.cause));
        Ok(SetFit {
            config,
            causes: fitted,
            evaluation,
            state,
            torque_delta,
        })
    }

    /// Residual sums of every channel for a fitted configuration on `state`.
    pub fn evaluate(
        &self,
        state: &State,
        config: &ModelConfig,
        torque_delta: &[f64; TORQUE_COLUMNS],
    ) -> Evaluation {
        let mut e = Evaluation::default();
        for i in state.recon.innovations.iter() {
            let target = if self.held_out[i.tick] {
                &mut e.held_out
            } else {
                &mut e.fit
            };
            for c in 0..crate::reconstruct::INNOVATION_LEN {
                if i.mask & (1 << c) != 0 {
                    target.rss[0] += i.values[c] * i.values[c];
                    target.n[0] += 1;
                }
            }
        }
        for (i, &a) in state.torque.ticks.iter().enumerate() {
            let r = state.torque.whitened(i, torque_delta);
            let target = if self.held_out[a] {
                &mut e.held_out
            } else {
                &mut e.fit
            };
            target.rss[1] += r.norm_squared();
            target.n[1] += 3;
        }
        let wheel = WheelModel::from_config(config);
        for (w, rows) in state.wheel.rows.iter().enumerate() {
            for row in rows {
                let r = wheel.residual(self.data, &state.wheel, w, row) / state.wheel.sigma;
                let target = if self.held_out[row.k] {
                    &mut e.held_out
                } else {
                    &mut e.fit
                };
                target.rss[2] += r * r;
                target.n[2] += 1;
            }
        }
        e
    }

    // -----------------------------------------------------------------------------------------
    // Sensor causes: Gauss–Newton through the filter.
    // -----------------------------------------------------------------------------------------

    fn fit_sensors(
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
        let mut r0 = self.fit_innovations(&*self.recon(&build(&theta))?);
        let rss = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
        let mut last: Option<LsFit> = None;
        // Screening with causes already fitted (warm): only the new causes' columns are
        // linearised first; the fitted ones sit at their optimum.
        let new_params: Vec<bool> = layout
            .iter()
            .flat_map(|&(cause, len)| std::iter::repeat_n(!warm.contains_key(&cause), len))
            .collect();
        if let Some((threshold, reference)) = screen.filter(|_| new_params.iter().any(|n| !n)) {
            let idx: Vec<usize> = (0..p).filter(|&j| new_params[j]).collect();
            let mut ne = NormalEquations::new(idx.len());
            let mut cols = Vec::with_capacity(idx.len());
            for &j in &idx {
                let mut t = theta.clone();
                let (lo, hi) = bound_of(&layout, j);
                let h = if theta[j] + steps[j] > hi {
                    -steps[j]
                } else {
                    steps[j]
                };
                t[j] = (theta[j] + h).clamp(lo, hi);
                let rj = self.fit_innovations(&self.run_filter(&build(&t))?);
                let hh = t[j] - theta[j];
                cols.push(
                    rj.iter()
                        .zip(&r0)
                        .map(|(a, b)| (a - b) / hh)
                        .collect::<Vec<f64>>(),
                );
            }
            let mut row = vec![0.0; idx.len()];
            for i in 0..r0.len() {
                for (c, col) in cols.iter().enumerate() {
                    row[c] = col[i];
                }
                ne.add(&row, -r0[i]);
            }
            let predicted = ne
                .solve()
                .map_or(0.0, |f| (reference - f.rss) / f.sigma2().max(1e-300));
            if predicted < 0.5 * threshold {
                return Ok(self.unchanged(&layout, &theta, &build(&theta)));
            }
        }
        for _iteration in 0..8 {
            // Jacobian by forward differences (steps away from the nearer bound).
            let mut columns: Vec<Vec<f64>> = Vec::with_capacity(p);
            for j in 0..p {
                let mut t = theta.clone();
                let (lo, hi) = bound_of(&layout, j);
                let h = if theta[j] + steps[j] > hi {
                    -steps[j]
                } else {
                    steps[j]
                };
                t[j] = (theta[j] + h).clamp(lo, hi);
                let rj = self.fit_innovations(&self.run_filter(&build(&t))?);
                let hh = t[j] - theta[j];
                columns.push(rj.iter().zip(&r0).map(|(a, b)| (a - b) / hh).collect());
            }
            let mut ne = NormalEquations::new(p);
            let mut row = vec![0.0; p];
            for i in 0..r0.len() {
                for j in 0..p {
                    row[j] = columns[j][i];
                }
                ne.add(&row, -r0[i]);
            }
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
            let free = se.iter().filter(|s| s.is_finite()).count();
            out.push(FittedCause {
                cause,
                values,
                stderr: se,
                free,
                note: String::new(),
            });
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

    /// Starting values of a sensor cause absent from the base: its neutral values, for the hard
    /// iron the better of zero and a sphere fit of the field readings.
    fn initial_sensor_values(&self, cause: Cause) -> Result<Vec<f64>, IdentError> {
        let neutral = cause.values(&self.base);
        if cause != Cause::MagneticDisturbance || cause.present(&self.base) {
            return Ok(neutral);
        }
        let guess = {
            let mut cached = self.sphere.borrow_mut();
            *cached.get_or_insert_with(|| sphere_fit(self.data, &self.base))
        };
        let Some(h) = guess else { return Ok(neutral) };
        let rss_of = |v: &[f64]| -> Result<f64, IdentError> {
            let mut c = self.base.clone();
            Cause::MagneticDisturbance.apply(&mut c, v);
            Ok(self
                .fit_innovations(&*self.recon(&c)?)
                .iter()
                .map(|x| x * x)
                .sum())
        };
        Ok(if rss_of(&h)? < rss_of(&neutral)? {
            h.to_vec()
        } else {
            neutral
        })
    }

    // -----------------------------------------------------------------------------------------
    // Torque causes: linear least squares on the torque channel.
    // -----------------------------------------------------------------------------------------

    fn fit_torque(
        &self,
        state: &State,
        set: &[Cause],
    ) -> Result<([f64; TORQUE_COLUMNS], Vec<FittedCause>), IdentError> {
        let ch = &state.torque;
        let columns: Vec<usize> = set
            .iter()
            .flat_map(|c| torque_columns(*c).into_iter().flatten())
            .collect();
        if ch.len() < 30 {
            return Err(IdentError::Failed(
                "too few usable torque-channel samples to fit".into(),
            ));
        }
        // Base values of the fitted columns (drag must stay ≥ 0 in total).
        let base_value = |col: usize| -> f64 {
            let (cause, off) = column_cause(col);
            cause.values(&self.base)[off]
        };
        let mut fixed: Vec<(usize, f64)> = Vec::new(); // (index into `columns`, delta)
        let mut ne = NormalEquations::new(columns.len());
        let mut row = vec![0.0; columns.len()];
        for (i, &a) in ch.ticks.iter().enumerate() {
            if self.held_out[a] {
                continue;
            }
            for axis in 0..3 {
                let s = ch.sigma[axis];
                for (j, &c) in columns.iter().enumerate() {
                    row[j] = ch.x[i][c][axis] / s;
                }
                ne.add(&row, ch.y[i][axis] / s);
            }
        }
        let (theta, stderr) = loop {
            let (theta, stderr) = solve_fixed(&ne, &fixed).ok_or_else(|| {
                IdentError::Failed(format!(
                    "{}: the data do not determine the parameters (no excitation of this effect)",
                    set.iter().map(|c| c.name()).collect::<Vec<_>>().join(" + ")
                ))
            })?;
            // Keep drag coefficients non-negative: hold the most negative at its bound, refit.
            let worst = columns
                .iter()
                .enumerate()
                .filter(|(j, c)| (6..12).contains(*c) && !fixed.iter().any(|(f, _)| f == j))
                .map(|(j, &c)| (j, base_value(c) + theta[j]))
                .filter(|(_, v)| *v < 0.0)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match worst {
                Some((j, _)) => fixed.push((j, -base_value(columns[j]))),
                None => break (theta, stderr),
            }
        };
        let mut delta = [0.0; TORQUE_COLUMNS];
        for (j, &c) in columns.iter().enumerate() {
            delta[c] = theta[j];
        }
        let mut out = Vec::new();
        for &cause in set {
            let range = torque_columns(cause).unwrap_or(0..0);
            let mut values = cause.values(&self.base);
            let mut se = vec![f64::NAN; values.len()];
            for (off, col) in range.clone().enumerate() {
                let j = columns.iter().position(|c| *c == col).unwrap_or(0);
                values[off] += theta[j];
                se[off] = stderr[j];
            }
            let free = se.iter().filter(|s| s.is_finite()).count();
            out.push(FittedCause {
                cause,
                values,
                stderr: se,
                free,
                note: String::new(),
            });
        }
        Ok((delta, out))
    }

    // -----------------------------------------------------------------------------------------
    // Wheel causes: per-wheel least squares, 1-D searches for delay and Stribeck speed.
    // -----------------------------------------------------------------------------------------

    fn fit_wheels(&self, state: &State, set: &[Cause]) -> Result<Vec<FittedCause>, IdentError> {
        let ch = &state.wheel;
        if ch.len() < 10 {
            return Err(IdentError::Failed(
                "too few usable wheel-channel intervals to fit".into(),
            ));
        }
        let fit_scale = set.contains(&Cause::WheelTorqueScale);
        let fit_friction = set.contains(&Cause::WheelFriction);
        let fit_delay = set.contains(&Cause::ActuatorDelay);
        let base = WheelModel::from_config(&self.base);
        let mut delay = base.delay_s;
        // Friction model per wheel: None = no Stribeck term.
        let mut stribeck: [Option<f64>; 3] = [None; 3];
        let mut result: [WheelSolve; 3] = Default::default();
        let mut delay_se = f64::NAN;
        let rounds = if fit_delay && fit_friction { 3 } else { 1 };
        for _ in 0..rounds {
            if fit_delay {
                let total = |d: f64| -> f64 {
                    (0..3)
                        .map(|w| {
                            self.solve_wheel(ch, &base, w, d, fit_scale, fit_friction, stribeck[w])
                                .map_or(0.0, |s| s.rss)
                        })
                        .sum()
                };
                let (d, se) = search_1d(total, 0.0, self.options.max_delay_s, 41);
                delay = d;
                delay_se = se;
            }
            for w in 0..3 {
                if fit_friction {
                    let none = self.solve_wheel(ch, &base, w, delay, fit_scale, true, None);
                    let rss_of = |ns: f64| {
                        self.solve_wheel(ch, &base, w, delay, fit_scale, true, Some(ns))
                            .map_or(f64::INFINITY, |s| s.rss)
                    };
                    let (log_ns, log_se) =
                        search_1d(|x: f64| rss_of(x.exp()), 0.02f64.ln(), 30.0f64.ln(), 31);
                    let with =
                        self.solve_wheel(ch, &base, w, delay, fit_scale, true, Some(log_ns.exp()));
                    let threshold = stribeck_threshold(ch.rows[w].len(), self.options.alpha);
                    let (choice, model) = match (none, with) {
                        (Some(a), Some(b)) if a.rss - b.rss > threshold && b.theta[3] > 0.0 => {
                            let mut b = b;
                            b.ns = Some((log_ns.exp(), log_ns.exp() * log_se));
                            (b, Some(log_ns.exp()))
                        }
                        (Some(a), _) => (a, None),
                        (None, Some(b)) => (b, Some(log_ns.exp())),
                        (None, None) => (WheelSolve::default(), None),
                    };
                    stribeck[w] = model;
                    result[w] = choice;
                } else {
                    result[w] = self
                        .solve_wheel(ch, &base, w, delay, fit_scale, false, None)
                        .unwrap_or_default();
                }
            }
        }

        let mut out = Vec::new();
        if fit_scale {
            let mut values = vec![0.0; 3];
            let mut se = vec![f64::NAN; 3];
            for w in 0..3 {
                values[w] = if result[w].valid {
                    result[w].theta[0]
                } else {
                    base.scale[w]
                };
                se[w] = if result[w].valid {
                    result[w].stderr[0]
                } else {
                    f64::NAN
                };
            }
            let free = se.iter().filter(|s| s.is_finite()).count();
            out.push(FittedCause {
                cause: Cause::WheelTorqueScale,
                values,
                stderr: se,
                free,
                note: String::new(),
            });
        }
        if fit_friction {
            let nominal = Cause::WheelFriction.values(&self.base);
            let mut values = nominal.clone();
            let mut se = vec![f64::NAN; 15];
            let mut notes = Vec::new();
            let mut free = 0;
            for w in 0..3 {
                let r = &result[w];
                if !r.valid {
                    notes.push(format!(
                        "wheel {}: no usable data, nominal kept",
                        "XYZ".as_bytes()[w] as char
                    ));
                    continue;
                }
                // theta: [scale, c_pos, c_neg, t_s, k]
                let (cp, cn, ts, k) = (r.theta[1], r.theta[2], r.theta[3], r.theta[4]);
                values[w] = cp;
                values[3 + w] = cn;
                values[6 + w] = k;
                se[w] = r.stderr[1];
                se[3 + w] = r.stderr[2];
                se[6 + w] = r.stderr[4];
                match r.ns {
                    Some((ns, ns_se)) => {
                        values[9 + w] = ts;
                        values[12 + w] = ns;
                        se[9 + w] = r.stderr[3];
                        se[12 + w] = ns_se;
                        notes.push(format!(
                            "wheel {}: asymmetric with Stribeck term",
                            "XYZ".as_bytes()[w] as char
                        ));
                    }
                    None => {
                        // No Stribeck term: breakaway at the larger Coulomb level, the Stribeck
                        // speed so small the term vanishes for any speed the data resolve.
                        values[9 + w] = cp.max(cn);
                        values[12 + w] = 1e-3;
                        notes.push(format!(
                            "wheel {}: asymmetric, no Stribeck term",
                            "XYZ".as_bytes()[w] as char
                        ));
                    }
                }
                free += r.free.saturating_sub(usize::from(fit_scale)) + usize::from(r.ns.is_some());
            }
            out.push(FittedCause {
                cause: Cause::WheelFriction,
                values,
                stderr: se,
                free,
                note: notes.join("; "),
            });
        }
        if fit_delay {
            let free = usize::from(delay_se.is_finite());
            out.push(FittedCause {
                cause: Cause::ActuatorDelay,
                values: vec![delay],
                stderr: vec![delay_se],
                free,
                note: String::new(),
            });
        }
        Ok(out)
    }

    /// Least squares of one wheel at delay `delay` with the chosen unknowns. The unknown vector
    /// is always reported as `[scale, coulomb_pos, coulomb_neg, stribeck, viscous]`, with the
    /// base values where not fitted.
    #[allow(clippy::too_many_arguments)]
    fn solve_wheel(
        &self,
        ch: &WheelChannel,
        base: &WheelModel,
        w: usize,
        delay: f64,
        fit_scale: bool,
        fit_friction: bool,
        ns: Option<f64>,
    ) -> Option<WheelSolve> {
        let rows = &ch.rows[w];
        // Unknown layout: [s, c_pos, c_neg, t_s, k]; the Stribeck column only with `ns`.
        let mut ne = NormalEquations::new(5);
        let mut x = [0.0; 5];
        let mut n = 0usize;
        let base_friction = &base.friction[w];
        for row in rows.iter().filter(|r| !self.held_out[r.k]) {
            let tau = self
                .data
                .wheel_cmd_integral(row.t0, row.t1, delay, ch.max_torque_nm)[w];
            let mut y = row.ja;
            if fit_scale {
                x[0] = tau;
            } else {
                x[0] = 0.0;
                y -= base.scale[w] * tau;
            }
            if fit_friction {
                let r = friction_regressors(row, ns);
                x[1] = -r[0];
                x[2] = -r[1];
                x[3] = if ns.is_some() { -r[2] } else { 0.0 };
                x[4] = -r[3];
            } else {
                x[1..].fill(0.0);
                y += friction_integral(base_friction, row);
            }
            let s = ch.sigma;
            ne.add(&x.map(|v| v / s), y / s);
            n += 1;
        }
        if n < 10 {
            return None;
        }
        // Undetermined columns (no data in that direction, no Stribeck term, not fitted) are
        // held at their base values.
        let base_theta = [
            base.scale[w],
            base_friction.coulomb_pos_nm,
            base_friction.coulomb_neg_nm,
            base_friction.breakaway_nm,
            base_friction.viscous_nm_per_rad_s,
        ];
        let mut fixed: Vec<(usize, f64)> = Vec::new();
        for j in 0..5 {
            let used = match j {
                0 => fit_scale,
                3 => fit_friction && ns.is_some(),
                _ => fit_friction,
            };
            if !used {
                fixed.push((j, 0.0));
            } else if !ne_diag_positive(&ne, j) || column_negligible(&ne, j) {
                fixed.push((j, base_theta[j]));
            }
        }
        // Active set for the bounds (friction ≥ 0, scale > 0).
        let (theta, stderr) = loop {
            let (theta, stderr) = solve_fixed(&ne, &fixed)?;
            let worst = (0..5)
                .filter(|j| !fixed.iter().any(|(f, _)| f == j))
                .filter(|&j| theta[j] < 0.0)
                .min_by(|a, b| theta[*a].total_cmp(&theta[*b]));
            match worst {
                Some(j) => fixed.push((j, 0.0)),
                None => break (theta, stderr),
            }
        };
        let rss = ne.rss_at(&DVector::from_column_slice(&theta));
        let mut full = theta;
        let mut se = stderr;
        for j in 0..5 {
            let fit_j = match j {
                0 => fit_scale,
                3 => fit_friction && ns.is_some(),
                _ => fit_friction,
            };
            if !fit_j {
                full[j] = base_theta[j];
                se[j] = f64::NAN;
            }
        }
        let free = se.iter().filter(|s| s.is_finite()).count();
        let theta: [f64; 5] = std::array::from_fn(|j| full[j]);
        let stderr: [f64; 5] = std::array::from_fn(|j| se[j]);
        Some(WheelSolve {
            valid: true,
            theta,
            stderr,
            rss,
            free,
            ns: None,
        })
    }
}

/// Result of one wheel's least squares.
#[derive(Debug, Clone, Default)]
struct WheelSolve {
    valid: bool,
    /// `[scale, coulomb_pos, coulomb_neg, stribeck, viscous]`.
    theta: [f64; 5],
    stderr: [f64; 5],
    rss: f64,
    free: usize,
    /// Stribeck speed and its standard error, when the Stribeck model was chosen.
    ns: Option<(f64, f64)>,
}

/// The wheels' drive and friction as a configuration has them.
#[derive(Debug, Clone)]
pub struct WheelModel {
    pub scale: [f64; 3],
    pub friction: [WheelFrictionModel; 3],
    pub delay_s: f64,
}

impl WheelModel {
    pub fn from_config(config: &ModelConfig) -> Self {
        Self {
            scale: config
                .effects
                .wheel_torque_scale
                .as_ref()
                .map_or([1.0; 3], |s| s.scale),
            friction: Wheel::ALL.map(|w| WheelFrictionModel::from_config(config, w)),
            delay_s: config
                .effects
                .actuator_delay
                .as_ref()
                .map_or(0.0, |d| d.delay_s),
        }
    }

    /// Wheel-channel residual of a row, Nms.
    pub fn residual(
        &self,
        data: &Aligned,
        ch: &WheelChannel,
        w: usize,
        row: &WheelInterval,
    ) -> f64 {
        let tau = data.wheel_cmd_integral(row.t0, row.t1, self.delay_s, ch.max_torque_nm)[w];
        row.ja - self.scale[w] * tau + friction_integral(&self.friction[w], row)
    }
}

/// Extra residual reduction the Stribeck term must bring (two more parameters): the larger of
/// the information criterion's `2 ln n` and the χ²₂ quantile at `1 − alpha`.
fn stribeck_threshold(n: usize, alpha: f64) -> f64 {
    let bic = 2.0 * (n.max(2) as f64).ln();
    bic.max(chi_square_quantile(1.0 - alpha, 2.0).unwrap_or(27.6))
}

fn ne_diag_positive(ne: &NormalEquations, j: usize) -> bool {
    let d = ne.diag(j);
    d.is_finite() && d > 0.0
}

/// A column whose weight is below 1e-12 of the largest is not determined by the data.
fn column_negligible(ne: &NormalEquations, j: usize) -> bool {
    let max = (0..ne.params()).map(|i| ne.diag(i)).fold(0.0, f64::max);
    ne.diag(j) <= 1e-12 * max
}

/// Solve with some unknowns held at given values; returns the full vector and standard errors
/// (NaN for the held ones).
fn solve_fixed(ne: &NormalEquations, fixed: &[(usize, f64)]) -> Option<(Vec<f64>, Vec<f64>)> {
    let p = ne.params();
    let free: Vec<usize> = (0..p)
        .filter(|j| !fixed.iter().any(|(f, _)| f == j))
        .collect();
    let mut values = vec![0.0; p];
    for (j, v) in fixed {
        values[*j] = *v;
    }
    if free.is_empty() {
        return Some((values, vec![f64::NAN; p]));
    }
    let reduced = ne.reduce(&free, &values)?;
    let fit = reduced.solve()?;
    let se_free = fit.stderr();
    let mut se = vec![f64::NAN; p];
    for (i, &j) in free.iter().enumerate() {
        values[j] = fit.theta[i];
        se[j] = se_free[i];
    }
    Some((values, se))
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

/// Cause and value offset of a torque column.
fn column_cause(col: usize) -> (Cause, usize) {
    match col {
        0..3 => (Cause::ComOffset, col),
        3..6 => (Cause::ConstantTorque, col - 3),
        6..12 => (Cause::AeroDrag, col - 6),
        _ => (Cause::InertiaError, col - 12),
    }
}

/// Minimise `f` on `[lo, hi]`: a grid of `points`, then golden-section refinement between the
/// best point's neighbours. Returns the minimiser and its standard error from the curvature,
/// `sqrt(2 s² / f'')` with `s² = 1` (f is a whitened residual sum); NaN when the minimum is on a
/// bound or flat.
fn search_1d(f: impl Fn(f64) -> f64, lo: f64, hi: f64, points: usize) -> (f64, f64) {
    let n = points.max(3);
    let xs: Vec<f64> = (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect();
    let fs: Vec<f64> = xs.iter().map(|&x| f(x)).collect();
    let best = (0..n).min_by(|a, b| fs[*a].total_cmp(&fs[*b])).unwrap_or(0);
    let (mut a, mut b) = (xs[best.saturating_sub(1)], xs[(best + 1).min(n - 1)]);
    let g = 0.618_033_988_749_895;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..20 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    let x = 0.5 * (a + b);
    // Curvature from a symmetric difference around the minimum.
    let h = (hi - lo) / (n - 1) as f64 * 0.25;
    let (fm, f0, fp) = (f(x - h), f(x), f(x + h));
    let curvature = (fp - 2.0 * f0 + fm) / (h * h);
    let at_bound = x - lo < 0.5 * h || hi - x < 0.5 * h;
    let se = if curvature > 0.0 && !at_bound {
        (2.0 / curvature).sqrt()
    } else {
        f64::NAN
    };
    (x, se)
}

/// Hard-iron estimate (gauss, body axes) from the field readings alone: the readings minus the
/// hard iron have the lab field's magnitude and the lab field's component along the measured
/// down vector, `|m − h| = |M_L|`, `(m − h)·g = M_L·G_L`, linear in `(h, |h|²)` when `|h|²` is a
/// fourth unknown. `None` without paired tilt and field samples or without enough rotation.
pub fn sphere_fit(data: &Aligned, config: &ModelConfig) -> Option<[f64; 3]> {
    let field_l = config.platform.field_l_t();
    let r = field_l.norm();
    let vertical = field_l.dot(&attitude::gravity_l());
    let mut ne = NormalEquations::new(4);
    let mut i = 0;
    let sigma = 1e-7; // T, weights both kinds of rows alike
    for &(t, m) in &data.field {
        while i < data.tilt.len() && data.tilt[i].0 < t - 1e-6 {
            i += 1;
        }
        let Some(&(tt, tilt)) = data.tilt.get(i) else {
            break;
        };
        if (tt - t).abs() > 1e-6 {
            continue;
        }
        let Some(g) = attitude::gravity_from_tilt(tilt[0], tilt[1]) else {
            continue;
        };
        ne.add(
            &[g.x / sigma, g.y / sigma, g.z / sigma, 0.0],
            (m.dot(&g) - vertical) / sigma,
        );
        let k = 1.0 / (2.0 * r * sigma);
        ne.add(
            &[2.0 * m.x * k, 2.0 * m.y * k, 2.0 * m.z * k, -k],
            (m.norm_squared() - r * r) * k,
        );
    }
    if ne.rows() < 20 {
        return None;
    }
    let fit = ne.solve()?;
    let h = Vector3::new(fit.theta[0], fit.theta[1], fit.theta[2]) / GAUSS;
    h.iter().all(|x| x.is_finite()).then(|| [h.x, h.y, h.z])
}
