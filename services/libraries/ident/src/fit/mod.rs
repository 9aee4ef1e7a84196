//! Fitting a set of candidate causes to the data, jointly, with standard errors: the shared
//! problem (data, held-out ticks, the cache of filter runs keyed by [`SensorKey`]) and the joint
//! fit of a set; each kind of cause has its own module.
//!
//! Each cause acts on one channel directly ([`Kind`]):
//! * **sensor** causes (gyro scale and misalignment, Earth rate, hard and soft iron,
//!   inclinometer offset and scale) change the readings the attitude filter sees; they are
//!   fitted by Gauss–Newton on the filter's whitened innovations (the prediction-error method),
//!   with Jacobians by finite differences through the filter, started for the hard iron from a
//!   sphere fit of the field readings, for the soft iron from an ellipsoid fit;
//! * **torque** causes (centre-of-mass offset, constant torque, drag, inertia error) are linear
//!   in the torque channel: weighted least squares, with `aero_drag`'s coefficients kept ≥ 0;
//! * **wheel** causes are linear in the wheel channel for a given delay and Stribeck speed
//!   (`wheel_torque_scale`, `wheel_friction` levels); the delay and each wheel's Stribeck speed
//!   are found by 1-D search, their standard errors from the curvature of the residual sum.
//!
//! The sensor fit comes first (it changes the state the other channels are computed from). Every
//! fit reports the whitened residual sum of squares of each channel on the fit data and on the
//! held-out data.
//!
//! * `sensors`: Gauss–Newton of the sensor causes through the filter, and their screens;
//! * `hard_iron`: the hard and soft iron's starting values (sphere and ellipsoid fits of the
//!   field readings);
//! * `torque`: weighted least squares of the torque causes;
//! * `wheels`: per-wheel least squares, delay and Stribeck-speed searches, [`WheelModel`];
//! * `information`: the Fisher information of torque and wheel causes on a state (the normal
//!   equations the fits solve), for experiment design;
//! * `jacobian`: the one finite-difference Jacobian (and its normal equations) the fits use.

mod hard_iron;
mod information;
mod jacobian;
mod sensors;
mod torque;
mod wheels;

pub use hard_iron::{ellipsoid_fit, ellipsoid_fit_pairs, sphere_fit};
pub use information::{Information, information_params, information_supported};
pub use wheels::WheelModel;

use crate::channels::{Regressors, TORQUE_COLUMNS, TorqueChannel, WheelChannel};
use crate::data::{Aligned, block_index};
use crate::effects::{Cause, Kind};
use crate::error::IdentError;
use crate::reconstruct::{Reconstruction, reconstruct, reconstruct_with_sensitivities};
use crate::stats::NormalEquations;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use testbed_model::ModelConfig;

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
    /// Add the sums of `other` (e.g. the held-out sums of the folds of a cross-validation).
    pub fn add(&mut self, other: &ChannelRss) {
        for c in 0..3 {
            self.rss[c] += other.rss[c];
            self.n[c] += other.n[c];
        }
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

impl FittedCause {
    /// A cause whose parameters with a finite standard error were estimated (and count as free).
    pub fn estimated(cause: Cause, values: Vec<f64>, stderr: Vec<f64>) -> Self {
        let free = stderr.iter().filter(|s| s.is_finite()).count();
        Self {
            cause,
            values,
            stderr,
            free,
            note: String::new(),
        }
    }
}

/// The estimated state and the channels built on it, for one sensor configuration.
#[derive(Debug)]
pub struct State {
    pub recon: Arc<Reconstruction>,
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
    pub state: Arc<State>,
    /// Torque-channel parameter change from the base, per column.
    pub torque_delta: [f64; TORQUE_COLUMNS],
    /// The sensor fit's last linearisation (none without sensor causes fitted here): the folds
    /// of a cross-validation fit the same set from it ([`Problem::fit_from`]).
    pub sensor_linearisation: Option<Arc<SensorLinearisation>>,
}

/// Where a sensor fit last linearised the filter's whitened innovations: the parameters, and
/// per row of its fit data the row's tick, the innovation and its derivatives.
#[derive(Debug)]
pub struct SensorLinearisation {
    layout: Vec<(Cause, usize)>,
    theta: Vec<f64>,
    ticks: Vec<usize>,
    residual: Vec<f64>,
    /// `∂r/∂θ_j` per parameter, each over the rows.
    columns: Vec<Vec<f64>>,
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
    /// This problem's states, and those of its folds ([`Problem::with_held_out`]).
    states: Segmented,
    fold_states: Segmented,
    /// Filter runs, shared with the problems made by [`Problem::with_held_out`] (a filter run
    /// does not depend on which ticks are held out).
    recons: Arc<Mutex<HashMap<SensorKey, Arc<Reconstruction>>>>,
    /// Filter runs so far (for the benchmark and the report).
    filter_runs: AtomicUsize,
    /// Jacobian columns on the fit ticks by the filter's sensitivities
    /// ([`Problem::tangent_columns`]), by start and directions.
    tangents: Mutex<HashMap<TangentKey, Vec<Vec<f64>>>>,
    sphere: Mutex<Option<Option<[f64; 3]>>>,
    ellipsoid: Mutex<Option<Option<HardAndSoftIron>>>,
}

/// Where the torque channel's segments end (they do not cross a change of `split`, a label per
/// tick), and the states built so: shared by the problems that segment alike.
#[derive(Clone)]
struct Segmented {
    split: Arc<Vec<usize>>,
    states: Arc<Mutex<HashMap<SensorKey, Arc<State>>>>,
}

impl Segmented {
    fn new(split: Vec<usize>) -> Self {
        Self {
            split: Arc::new(split),
            states: Arc::new(Mutex::new(HashMap::new())),
        }
    }
}

/// A tangent run's key: its start's key and its directions' keys.
type TangentKey = (SensorKey, Vec<SensorKey>);

/// A filter run with its sensitivities to sensor parameters ([`crate::tangent`]): the
/// configuration it linearises at, and one direction per parameter (the configuration with it
/// stepped, and the step). A sensor candidate's screen, and the information of sensor causes.
#[derive(Debug, Clone)]
pub struct TangentRun {
    pub start: ModelConfig,
    pub directions: Vec<(ModelConfig, f64)>,
}

impl TangentRun {
    /// The run at `theta` (`build` makes a configuration of parameter values) with a direction
    /// per parameter of `which`: that parameter stepped by its `steps` entry away from the
    /// nearer of its `bounds`, as a finite-difference Jacobian steps it.
    fn stepped(
        theta: &[f64],
        which: &[usize],
        steps: &[f64],
        bounds: impl Fn(usize) -> (f64, f64),
        build: impl Fn(&[f64]) -> ModelConfig,
    ) -> Self {
        let stepped = jacobian::perturbations(theta, which, steps, bounds);
        Self {
            start: build(theta),
            directions: which
                .iter()
                .zip(&stepped)
                .map(|(&j, t)| (build(t), t[j] - theta[j]))
                .collect(),
        }
    }

    fn key(&self) -> TangentKey {
        (
            SensorKey::of(&self.start),
            self.directions
                .iter()
                .map(|(c, _)| SensorKey::of(c))
                .collect(),
        )
    }
}

/// Hard iron (gauss) and the soft iron's six values, from [`ellipsoid_fit`].
type HardAndSoftIron = ([f64; 3], [f64; 6]);

/// Cache key of a filter run: the sensor causes present in a configuration at other than
/// their neutral values ([`Cause::neutral`]) and those values, exactly (bit patterns), in
/// [`Cause::ALL`] order, and the fitted field error's terms (`effects.fitted_field`, which the
/// filter takes out of the readings). Configurations with equal keys give the same filter run:
/// a candidate screened at its neutral start is the run without it.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Default)]
pub struct SensorKey(Vec<(Cause, Vec<u64>)>, Vec<(String, String, u64)>);

impl SensorKey {
    pub fn of(config: &ModelConfig) -> Self {
        Self(
            Cause::ALL
                .into_iter()
                .filter(|c| c.kind() == Kind::Sensor && c.present(config))
                .map(|c| (c, c.values(config)))
                .filter(|(c, values)| !c.neutral(values))
                .map(|(c, values)| (c, values.iter().map(|x| x.to_bits()).collect()))
                .collect(),
            config
                .effects
                .fitted_field
                .iter()
                .flat_map(|f| &f.terms)
                .map(|t| (t.axis.clone(), t.function.clone(), t.coefficient.to_bits()))
                .collect(),
        )
    }

    /// No sensor cause present (the filter run of the base configuration, which is where a
    /// fitted field error comes from).
    pub fn is_nominal(&self) -> bool {
        self.0.is_empty()
    }
}

impl<'a> Problem<'a> {
    /// The problem of fitting `data` with `held_out` ticks left out; a fold of its
    /// cross-validation ([`Problem::with_held_out`]) holds out whole blocks of `block_s`
    /// ([`block_index`]). The torque channel's segments end where `held_out` changes; a fold's
    /// at every block boundary, so that the folds share their states.
    pub fn new(
        data: &'a Aligned,
        base: ModelConfig,
        held_out: Vec<bool>,
        block_s: f64,
        options: FitOptions,
    ) -> Self {
        let split = held_out.iter().map(|&h| usize::from(h)).collect();
        let blocks = data.t.iter().map(|&t| block_index(t, block_s)).collect();
        Self {
            data,
            base,
            held_out,
            options,
            states: Segmented::new(split),
            fold_states: Segmented::new(blocks),
            recons: Arc::new(Mutex::new(HashMap::new())),
            filter_runs: AtomicUsize::new(0),
            tangents: Mutex::new(HashMap::new()),
            sphere: Mutex::new(None),
            ellipsoid: Mutex::new(None),
        }
    }

    /// The same data and configuration with other whole blocks held out (a fold of the
    /// cross-validation): it shares this problem's filter runs, and its states with the other
    /// folds.
    pub fn with_held_out(&self, held_out: Vec<bool>) -> Problem<'a> {
        // The folds share states whose segments end at block boundaries: only right when
        // every fold's held-out ticks are whole blocks.
        assert!(
            held_out
                .windows(2)
                .zip(self.fold_states.split.windows(2))
                .all(|(h, b)| h[0] == h[1] || b[0] != b[1]),
            "a fold must hold out whole blocks"
        );
        Problem {
            data: self.data,
            base: self.base.clone(),
            held_out,
            options: self.options.clone(),
            states: self.fold_states.clone(),
            fold_states: self.fold_states.clone(),
            recons: Arc::clone(&self.recons),
            filter_runs: AtomicUsize::new(0),
            tangents: Mutex::new(HashMap::new()),
            sphere: Mutex::new(*lock(&self.sphere)),
            ellipsoid: Mutex::new(*lock(&self.ellipsoid)),
        }
    }

    /// Filter runs so far, this problem's (for the benchmark and the report).
    pub fn filter_runs(&self) -> usize {
        self.filter_runs.load(Ordering::Relaxed)
    }

    /// Count `runs` more filter runs.
    pub(crate) fn count_filter_runs(&self, runs: usize) {
        self.filter_runs.fetch_add(runs, Ordering::Relaxed);
    }

    /// The filter run for the sensor effects of `config` (cached: fits on two threads asking
    /// for it at once may both run it; one run is kept and counted).
    pub(crate) fn recon(&self, config: &ModelConfig) -> Result<Arc<Reconstruction>, IdentError> {
        let key = SensorKey::of(config);
        if let Some(r) = lock(&self.recons).get(&key) {
            return Ok(r.clone());
        }
        let r = Arc::new(reconstruct(self.data, config)?);
        let mut recons = lock(&self.recons);
        let kept = recons.entry(key).or_insert_with(|| {
            self.count_filter_runs(1);
            r
        });
        Ok(kept.clone())
    }

    /// Filter runs that are not worth keeping (finite-difference steps), one per configuration.
    /// Those not cached run across the machine's cores: each is independent of the others and
    /// deterministic, so the result does not depend on how many cores there are.
    pub(crate) fn run_filters(
        &self,
        configs: &[ModelConfig],
    ) -> Result<Vec<Reconstruction>, IdentError> {
        let cached: Vec<Option<Reconstruction>> = {
            let recons = lock(&self.recons);
            configs
                .iter()
                .map(|c| recons.get(&SensorKey::of(c)).map(|r| (**r).clone()))
                .collect()
        };
        let runs = cached.iter().filter(|c| c.is_none()).count();
        self.count_filter_runs(runs);
        let data = self.data;
        configs
            .par_iter()
            .zip(cached)
            .map(|(config, cached)| cached.map_or_else(|| reconstruct(data, config), Ok))
            .collect()
    }

    /// The fit ticks' whitened innovations of a filter run per configuration
    /// ([`Problem::run_filters`]).
    pub(crate) fn perturbed_innovations(
        &self,
        configs: &[ModelConfig],
    ) -> Result<Vec<Vec<f64>>, IdentError> {
        Ok(self
            .run_filters(configs)?
            .iter()
            .map(|r| self.fit_innovations(r))
            .collect())
    }

    /// The linearised least-squares problem of a tangent run on the fit ticks: its columns
    /// ([`Problem::tangent_columns`]) against the whitened innovations of its start (the same
    /// filter run).
    pub(crate) fn tangent_normal_equations(
        &self,
        run: &TangentRun,
    ) -> Result<NormalEquations, IdentError> {
        let columns = self.tangent_columns(run)?;
        let r0 = self.fit_innovations(&*self.recon(&run.start)?);
        Ok(jacobian::normal_equations(&columns, &r0))
    }

    /// The Jacobian columns of a tangent run on the fit ticks: the whitened innovations'
    /// sensitivities to each direction, from one filter run beside its tangent
    /// ([`crate::tangent`]; kept with the run of the start), or made ahead
    /// ([`Problem::prefetch_tangents`]).
    pub fn tangent_columns(&self, run: &TangentRun) -> Result<Vec<Vec<f64>>, IdentError> {
        let key = run.key();
        if let Some(columns) = lock(&self.tangents).get(&key) {
            return Ok(columns.clone());
        }
        self.prefetch_tangents(std::slice::from_ref(run))?;
        lock(&self.tangents)
            .get(&key)
            .cloned()
            .ok_or_else(|| IdentError::Failed("a tangent run was not kept".into()))
    }

    /// Run ahead, in one batch across the cores, several tangent runs (the screens of a
    /// selection step's candidates, [`Problem::screen_request`]): each one filter run beside
    /// its tangent, whose run is kept like any other and whose columns wait for
    /// [`Problem::tangent_columns`].
    pub fn prefetch_tangents(&self, runs: &[TangentRun]) -> Result<(), IdentError> {
        let mut todo: Vec<(TangentKey, &TangentRun)> = Vec::new();
        {
            let tangents = lock(&self.tangents);
            for r in runs {
                let key = r.key();
                if !tangents.contains_key(&key) && !todo.iter().any(|(k, _)| *k == key) {
                    todo.push((key, r));
                }
            }
        }
        let data = self.data;
        let runs: Vec<_> = todo
            .par_iter()
            .map(|(_, r)| reconstruct_with_sensitivities(data, &r.start, &r.directions))
            .collect();
        let (mut recons, mut tangents) = (lock(&self.recons), lock(&self.tangents));
        for ((key, _), run) in todo.into_iter().zip(runs) {
            let (recon, sensitivities) = run?;
            let columns =
                recon.sensitivity_columns(&sensitivities, key.1.len(), |k| !self.held_out[k]);
            recons
                .entry(key.0.clone())
                .or_insert_with(|| Arc::new(recon));
            tangents.entry(key).or_insert_with(|| {
                self.count_filter_runs(1);
                columns
            });
        }
        Ok(())
    }

    /// The state and channels for the sensor effects of `config` (cached).
    pub fn state(&self, config: &ModelConfig) -> Result<Arc<State>, IdentError> {
        let key = SensorKey::of(config);
        if let Some(s) = lock(&self.states.states).get(&key) {
            return Ok(s.clone());
        }
        let state = Arc::new(self.build_state(config, Regressors::Built)?);
        Ok(lock(&self.states.states)
            .entry(key)
            .or_insert(state)
            .clone())
    }

    /// The state of `config` to evaluate it as it is: the cached one, else one whose torque
    /// channel has no regressors (not cached: [`Problem::state`] would return it to a fit).
    fn state_to_evaluate(&self, config: &ModelConfig) -> Result<Arc<State>, IdentError> {
        if let Some(s) = lock(&self.states.states).get(&SensorKey::of(config)) {
            return Ok(s.clone());
        }
        Ok(Arc::new(self.build_state(config, Regressors::Skipped)?))
    }

    fn build_state(
        &self,
        config: &ModelConfig,
        regressors: Regressors,
    ) -> Result<State, IdentError> {
        let recon = self.recon(config)?;
        let torque = TorqueChannel::new(
            self.data,
            &recon,
            &self.base,
            self.options.torque_segment_s,
            &self.states.split,
            regressors,
        );
        let wheel = WheelChannel::new(self.data, &recon, &self.base);
        Ok(State {
            recon,
            torque,
            wheel,
        })
    }

    /// The torque channel's momentum residuals on the estimate `recon` (another filter run on
    /// this problem's data), segmented as this problem's states, without regressors.
    pub(crate) fn torque_residuals(&self, recon: &Reconstruction) -> TorqueChannel {
        TorqueChannel::new(
            self.data,
            recon,
            &self.base,
            self.options.torque_segment_s,
            &self.states.split,
            Regressors::Skipped,
        )
    }

    /// Forget cached states and filter runs (memory) except the base's and those of `keep`.
    pub fn trim_cache(&self, keep: &[&ModelConfig]) {
        lock(&self.tangents).clear();
        let keys: Vec<SensorKey> = keep.iter().map(|c| SensorKey::of(c)).collect();
        lock(&self.states.states).retain(|k, _| k.is_nominal() || keys.contains(k));
        lock(&self.recons).retain(|k, _| k.is_nominal() || keys.contains(k));
    }

    /// Innovation rows on the fit ticks.
    pub(crate) fn fit_innovations(&self, recon: &Reconstruction) -> Vec<f64> {
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
        self.fit_with(set, warm, screen, None)
    }

    /// [`Problem::fit`] of a fold of a cross-validation: the sensor causes of `set`, when
    /// `from` (the fit of the same set on all the data) linearised them, take one Gauss–Newton
    /// step from there on this problem's fit rows, one filter run instead of a fit's many. The
    /// fold's data differ from all the data by a fifth, so the step lands where the fold's own
    /// fit would converge, to within the curvature the step neglects.
    pub fn fit_from(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
        from: Option<&SensorLinearisation>,
    ) -> Result<SetFit, IdentError> {
        self.fit_with(set, warm, None, from)
    }

    /// The configuration of the one-step fold fit of [`Problem::fit_from`], to run its filter
    /// ahead ([`Problem::prefetch`]); `None` when the step cannot be taken.
    pub fn step_config(&self, from: &SensorLinearisation) -> Option<ModelConfig> {
        let (theta, _, _) = self.linear_step(from).ok()?;
        Some(build_sensors(&self.base, &from.layout, &theta))
    }

    /// Run the filters of `configs` not run yet, across the machine's cores, and keep them.
    pub fn prefetch(&self, configs: &[ModelConfig]) -> Result<(), IdentError> {
        let mut todo: Vec<(SensorKey, &ModelConfig)> = Vec::new();
        {
            let recons = lock(&self.recons);
            for c in configs {
                let key = SensorKey::of(c);
                if !recons.contains_key(&key) && !todo.iter().any(|(k, _)| *k == key) {
                    todo.push((key, c));
                }
            }
        }
        let data = self.data;
        let runs: Vec<Reconstruction> = todo
            .par_iter()
            .map(|(_, c)| reconstruct(data, c))
            .collect::<Result<_, _>>()?;
        let mut recons = lock(&self.recons);
        for ((key, _), r) in todo.into_iter().zip(runs) {
            recons.entry(key).or_insert_with(|| {
                self.count_filter_runs(1);
                Arc::new(r)
            });
        }
        Ok(())
    }

    fn fit_with(
        &self,
        set: &[Cause],
        warm: &HashMap<Cause, FittedCause>,
        screen: Option<(f64, f64)>,
        from: Option<&SensorLinearisation>,
    ) -> Result<SetFit, IdentError> {
        let mut config = self.base.clone();
        let mut fitted: Vec<FittedCause> = Vec::new();
        let mut sensor_linearisation = None;

        let sensor: Vec<Cause> = set
            .iter()
            .copied()
            .filter(|c| c.kind() == Kind::Sensor)
            .collect();
        if !sensor.is_empty() {
            let (c, f, lin) = self.fit_sensors(&sensor, warm, screen, from)?;
            config = c;
            fitted.extend(f);
            sensor_linearisation = lin.map(Arc::new);
        }
        // A fold's fit of sensor causes alone is only evaluated: no torque fit on its state.
        let state = if from.is_some() && set.iter().all(|c| c.kind() == Kind::Sensor) {
            self.state_to_evaluate(&config)?
        } else {
            self.state(&config)?
        };

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
            sensor_linearisation,
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
}

/// The value behind `mutex`: a cache, whole even if a thread panicked while holding it (it
/// only ever inserts or removes whole entries).
fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

/// `base` with the sensor causes of `layout` set to `theta` (their values in order).
fn build_sensors(base: &ModelConfig, layout: &[(Cause, usize)], theta: &[f64]) -> ModelConfig {
    let mut config = base.clone();
    let mut i = 0;
    for &(cause, len) in layout {
        cause.apply(&mut config, &theta[i..i + len]);
        i += len;
    }
    config
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
