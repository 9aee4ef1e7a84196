//! Experiment design: choose the identification programme's amplitudes and timing
//! ([`ExperimentOptions`]) to maximise the information the data will carry on the candidate
//! causes, within the tilt and wheel-speed limits, at a fixed duration.
//!
//! **Criterion (D-optimal).** A candidate programme is simulated in closed loop on the user's
//! model (the nominal model: the causes are not known yet, their parameters are evaluated at
//! the model's values). From its data the same estimated state and channels `identify` builds
//! give the Fisher information `F` of the target causes' parameters: the `XᵀX` of the
//! whitened normal equations the torque and wheel fits solve, and for the sensor causes `JᵀJ`
//! of the sensor fit's finite-difference Jacobian of the filter's whitened innovations
//! ([`Problem::information`]), on the ticks the fits use (identify's held-out blocks left out). Each parameter is scaled by a typical magnitude
//! ([`typical_magnitude`]: 1 µm of centre-of-mass offset, 0.1 mNm of constant torque, 1 % of a
//! moment of inertia, …), `F_s = D F D` with `D = diag(typical)`, so `F_s⁻¹` is the covariance
//! in units of those magnitudes. The design maximises `log det F_s` (the volume of the
//! confidence ellipsoid shrinks as `det F_s^{-1/2}`). The scaling moves every design's
//! `log det` by the same constant, so it does not change which design wins; it makes the
//! number readable (`−log det / p / 2` is the mean log standard error in typical magnitudes)
//! and keeps the eigenvalues within a few decades, so that their decomposition is accurate.
//!
//! **Unidentifiable parameters.** An eigenvalue of `F_s` at or below `1e-12` of the largest
//! (the threshold at which the fits' own normal equations refuse to solve) is a direction the
//! programme does not determine. Designs are ranked first by the number of such directions
//! (fewer is better), then by the sum of the log-eigenvalues of the determined ones: a
//! programme that identifies every parameter always beats one that does not, however large
//! the latter's information on the rest. The predicted standard error of a parameter with a
//! component in an undetermined direction is NaN.
//!
//! **Limits.** A candidate is rejected if its simulation strikes the tilt stop, tilts to within
//! `tilt_margin_deg` of the stop, or runs a wheel faster than `wheel_speed_fraction` of the
//! drives' limit ([`DesignLimits`]), on the model or with `com_allowance_m` more horizontal
//! centre-of-mass offset along ±X or ±Y (an optimal design sits on its limits; without the
//! allowance the best design saturated a wheel with 0.1 µm of unmodelled offset). The duration and seed are those of the baseline
//! programme.
//!
//! **Search.** Coordinate search over a grid per design variable ([`DesignSpace`]): from the
//! baseline, each variable in turn is set to every value of its grid with the others held, and
//! the best admissible candidate is kept; passes repeat until one changes nothing (or
//! `passes` is reached). Every candidate is a full closed-loop simulation of the programme at
//! its duration (no shortening or decimation), four more with the centre-of-mass allowance,
//! one filter run over its data and one more per sensor parameter targeted: about 0.5 s per
//! 600-s candidate in a release build, so a search of about 50 candidates takes 25–30 s;
//! evaluated candidates are cached. The search finds a coordinate-wise optimum on the grid,
//! not necessarily the global one.
//!
//! Covered causes ([`information_supported`]): the torque causes (centre-of-mass offset,
//! constant torque, drag, inertia error), `wheel_torque_scale` and the linear levels of
//! `wheel_friction` (from the fits' normal equations), and the sensor causes (gyro scale and
//! misalignment, Earth rate, hard iron, inclinometer offset and scale: from the Jacobian of the
//! filter's innovations by forward differences, one more filter run per parameter and
//! candidate).

mod criterion;

pub(crate) use criterion::d_criterion_eigen;
pub use criterion::{Criterion, d_criterion};

use crate::data::Aligned;
use crate::effects::Cause;
use crate::error::IdentError;
use crate::experiment::{self, ExperimentOptions};
use crate::fit::{Information, Problem, information_params, information_supported};
use crate::identify::{Options as IdentifyOptions, held_out_mask};
use crate::separability::{Confusion, unseparable};
use nalgebra::DMatrix;
use serde::Serialize;
use testbed_model::ModelConfig;
use testbed_model::attitude;

/// Why a design could not be made.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error(transparent)]
    Ident(#[from] IdentError),
    #[error("design options: `{key}` = {value}: {reason}")]
    Options {
        key: String,
        value: String,
        reason: String,
    },
    #[error("no candidate programme stays within the limits ({evaluated} simulated): {why}")]
    NoAdmissible { evaluated: usize, why: String },
}

/// Limits every candidate programme must keep in its simulation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignLimits {
    /// Largest tilt reached, degrees below the tilt stop (`platform.tilt_limit_deg`).
    pub tilt_margin_deg: f64,
    /// Largest wheel speed reached, fraction of the drives' speed limit.
    pub wheel_speed_fraction: f64,
    /// Unmodelled horizontal centre-of-mass offset the programme must survive within the
    /// limits, m: each candidate is also simulated with this much more offset along +X, −X, +Y
    /// and −Y (four more simulations). 0 disables the check.
    pub com_allowance_m: f64,
}

impl Default for DesignLimits {
    fn default() -> Self {
        Self {
            tilt_margin_deg: 5.0,
            wheel_speed_fraction: 0.85,
            // 0.2 µm: about 0.7 mNm of gravity torque on the default platform, the residual of a
            // good balance; the default programme keeps its wheels under 85 % with it.
            com_allowance_m: 0.2e-6,
        }
    }
}

/// Which limit a rejected candidate broke.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Limit {
    /// It struck the tilt stop.
    TiltStop,
    /// It tilted to within the margin of the stop.
    Tilt,
    /// A wheel ran faster than the allowed fraction of its limit.
    WheelSpeed,
    /// Its simulation or filter run failed.
    Failed,
}

/// A candidate the search rejected, and why.
#[derive(Debug, Clone, Serialize)]
pub struct Rejection {
    pub options: ExperimentOptions,
    pub limit: Limit,
    pub why: String,
}

/// The design variables and the values searched for each. Empty grid: the variable is held
/// at the baseline's value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignSpace {
    /// `heading_amplitude_deg`, degrees; up to 180 (±180°: a full turn, which tells a torque
    /// that varies with the heading from a constant one over every heading).
    pub heading_amplitude_deg: Vec<f64>,
    /// `heading_rate_deg_s`, °/s.
    pub heading_rate_deg_s: Vec<f64>,
    /// `tilt_deg`, degrees (at most 20, [`ExperimentOptions::validate`]).
    pub tilt_deg: Vec<f64>,
    /// `tilt_dwell_s`, s.
    pub tilt_dwell_s: Vec<f64>,
    /// Initial momentum of the X and Y wheels (both set to it; Z as in the baseline), Nms.
    pub wheel_momentum_nms: Vec<f64>,
}

impl Default for DesignSpace {
    fn default() -> Self {
        Self {
            heading_amplitude_deg: vec![20.0, 40.0, 60.0, 90.0, 120.0, 150.0, 180.0],
            heading_rate_deg_s: vec![0.2, 0.3, 0.45, 0.6, 0.75, 0.9],
            tilt_deg: vec![3.0, 5.0, 7.0, 10.0, 13.0, 16.0, 20.0],
            tilt_dwell_s: vec![10.0, 15.0, 20.0, 30.0, 45.0, 60.0],
            wheel_momentum_nms: vec![0.0, 0.1, 0.25, 0.4, 0.55],
        }
    }
}

/// A design variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Variable {
    HeadingAmplitude,
    HeadingRate,
    Tilt,
    TiltDwell,
    WheelMomentum,
}

impl Variable {
    const ALL: [Variable; 5] = [
        Variable::Tilt,
        Variable::TiltDwell,
        Variable::HeadingAmplitude,
        Variable::HeadingRate,
        Variable::WheelMomentum,
    ];

    fn grid(self, space: &DesignSpace) -> &[f64] {
        match self {
            Variable::HeadingAmplitude => &space.heading_amplitude_deg,
            Variable::HeadingRate => &space.heading_rate_deg_s,
            Variable::Tilt => &space.tilt_deg,
            Variable::TiltDwell => &space.tilt_dwell_s,
            Variable::WheelMomentum => &space.wheel_momentum_nms,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Variable::HeadingAmplitude => "heading_amplitude_deg",
            Variable::HeadingRate => "heading_rate_deg_s",
            Variable::Tilt => "tilt_deg",
            Variable::TiltDwell => "tilt_dwell_s",
            Variable::WheelMomentum => "wheel_momentum_nms",
        }
    }

    fn set(self, options: &mut ExperimentOptions, value: f64) {
        match self {
            Variable::HeadingAmplitude => options.heading_amplitude_deg = value,
            Variable::HeadingRate => options.heading_rate_deg_s = value,
            Variable::Tilt => options.tilt_deg = value,
            Variable::TiltDwell => options.tilt_dwell_s = value,
            Variable::WheelMomentum => {
                options.wheel_momentum_nms[0] = value;
                options.wheel_momentum_nms[1] = value;
            }
        }
    }
}

/// Settings of a design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignOptions {
    /// Causes whose parameters the programme should determine ([`information_supported`]);
    /// default: every cause the design covers (all but the actuator delay and the thrusters'
    /// causes; friction's linear levels).
    pub targets: Vec<Cause>,
    pub limits: DesignLimits,
    pub space: DesignSpace,
    /// Largest number of passes of the coordinate search.
    pub passes: usize,
    /// The identification settings the data will be analysed with (held-out blocks, torque
    /// segment length): the information counts the ticks those fits use.
    #[serde(skip)]
    pub identify: IdentifyOptions,
}

impl Default for DesignOptions {
    fn default() -> Self {
        Self {
            targets: Cause::ALL
                .into_iter()
                .filter(|c| information_supported(*c))
                .collect(),
            limits: DesignLimits::default(),
            space: DesignSpace::default(),
            passes: 2,
            identify: IdentifyOptions::default(),
        }
    }
}

impl DesignOptions {
    /// Refuse settings the design cannot use, naming the setting.
    pub fn validate(&self) -> Result<(), DesignError> {
        let bad = |key: &str, value: String, reason: &str| {
            Err(DesignError::Options {
                key: key.into(),
                value,
                reason: reason.into(),
            })
        };
        if self.targets.is_empty() {
            return bad("targets", "[]".into(), "name at least one cause");
        }
        if let Some(c) = self.targets.iter().find(|c| !information_supported(**c)) {
            return bad(
                "targets",
                c.name().into(),
                "not covered by the design (the thrusters' causes need the thruster programme; of the wheel causes only wheel_torque_scale and wheel_friction)",
            );
        }
        let l = &self.limits;
        if !(l.tilt_margin_deg.is_finite() && l.tilt_margin_deg >= 0.0) {
            return bad(
                "limits.tilt_margin_deg",
                l.tilt_margin_deg.to_string(),
                "must be >= 0",
            );
        }
        if !(l.wheel_speed_fraction > 0.0 && l.wheel_speed_fraction <= 1.0) {
            return bad(
                "limits.wheel_speed_fraction",
                l.wheel_speed_fraction.to_string(),
                "must be within (0, 1]",
            );
        }
        if !(l.com_allowance_m.is_finite() && (0.0..=1e-3).contains(&l.com_allowance_m)) {
            return bad(
                "limits.com_allowance_m",
                l.com_allowance_m.to_string(),
                "must be within [0, 1e-3] m",
            );
        }
        if self.passes == 0 {
            return bad("passes", "0".into(), "must be >= 1");
        }
        for v in Variable::ALL {
            if let Some(x) = v.grid(&self.space).iter().find(|x| !x.is_finite()) {
                return bad(v.name(), x.to_string(), "grid values must be finite");
            }
        }
        self.identify.validate()?;
        Ok(())
    }
}

/// Typical magnitude of a parameter (configuration units): the unit the design's information
/// is expressed in. 1 µm of centre-of-mass offset (about 1 mNm of gravity torque on the default
/// platform), 1.7 nm/s of centre-of-mass drift (1 µm in 10 min, thermal), 0.1 mNm of constant
/// torque, 1e-3 Nm/(rad/s) and 1e-2 Nm/(rad/s)² of drag, 1 % of a principal moment and 0.5 kg
/// m² of product of inertia (1 % of the default moments), 1 % of wheel torque scale, 0.1 mNm of Coulomb friction and 1e-7 Nm/(rad/s) of viscous friction
/// (7 % and 3 % of the default wheels'), 100 ppm of gyro scale, 0.1 mrad of gyro
/// misalignment, 10 ms of gyro delay, 1e-8 rad/s² of gyro bias drift (7 °/h in an hour), 1° of latitude (Earth rate), 0.01 G (1 µT) of hard iron, 1 % of soft iron, 1 mrad (0.06°) of
/// inclinometer offset, 1000 ppm of inclinometer scale; 1 for anything else.
pub fn typical_magnitude(cause: Cause, i: usize) -> f64 {
    match cause {
        Cause::ComOffset => 1e-6,
        Cause::ComDrift => 1.7e-9,
        Cause::ConstantTorque => 1e-4,
        Cause::AeroDrag => {
            if i < 3 {
                1e-3
            } else {
                1e-2
            }
        }
        Cause::InertiaError => {
            if i < 3 {
                0.01
            } else {
                0.5
            }
        }
        Cause::WheelTorqueScale => 0.01,
        Cause::GyroScale => 100.0,
        Cause::GyroMisalignment => 1e-4,
        Cause::GyroDelay => 0.01,
        Cause::GyroBiasDrift => 1e-8,
        Cause::EarthRate => 1.0,
        Cause::MagneticDisturbance => 0.01,
        Cause::SoftIron => 0.01,
        Cause::InclinometerBias => 1e-3,
        Cause::InclinometerScale => 1e3,
        Cause::InclinometerCrossAxis => 1e-3,
        Cause::InclinometerLag | Cause::MagnetometerLag => 0.2,
        Cause::WheelFriction => {
            if i < 6 {
                1e-4
            } else {
                1e-7
            }
        }
        _ => 1.0,
    }
}

/// One candidate programme, simulated and evaluated.
#[derive(Debug, Clone, Serialize)]
pub struct Evaluation {
    pub options: ExperimentOptions,
    /// Largest tilt of the simulated platform (truth), degrees.
    pub max_tilt_deg: f64,
    /// Tilt-stop strikes in the simulation.
    pub tilt_stop_strikes: usize,
    /// Largest wheel speed reached, fraction of the drives' limit.
    pub max_wheel_speed_fraction: f64,
    /// The worst tilt, strikes and wheel speed over the simulations with the centre-of-mass
    /// allowance ([`DesignLimits::com_allowance_m`]) and without.
    pub worst_with_allowance: Extremes,
    /// The limit the programme breaks (`None`: admissible).
    pub limit: Option<Limit>,
    /// Why the programme breaks it (`None`: admissible).
    pub rejected: Option<String>,
    /// D-criterion of the scaled information.
    pub criterion: Criterion,
    /// Predicted standard error of each parameter, configuration units (noise as modelled).
    pub stderr: Vec<f64>,
    /// The information (configuration units).
    #[serde(skip)]
    pub information: Option<Information>,
}

impl Evaluation {
    pub fn admissible(&self) -> bool {
        self.rejected.is_none()
    }

    /// Ranking: admissible first, then by [`Criterion::better_than`].
    fn better_than(&self, other: &Evaluation) -> bool {
        match (self.admissible(), other.admissible()) {
            (true, false) => true,
            (false, true) => false,
            _ => self.criterion.better_than(&other.criterion),
        }
    }
}

/// What a simulated programme reached, against the limits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Extremes {
    /// Largest tilt of the simulated platform (truth), degrees.
    pub tilt_deg: f64,
    /// Tilt-stop strikes.
    pub strikes: usize,
    /// Largest wheel speed, fraction of the drives' limit.
    pub wheel_fraction: f64,
}

impl Extremes {
    fn of(trace: &testbed_sim::closed_loop::Trace, model: &ModelConfig) -> Self {
        let tilt = trace
            .ticks
            .iter()
            .map(|t| {
                let [a, b] = attitude::tilt_angles(&t.truth.q);
                a.abs().max(b.abs())
            })
            .fold(0.0, f64::max);
        let wheel = trace
            .ticks
            .iter()
            .map(|t| t.truth.wheel_speed.amax())
            .fold(0.0, f64::max);
        Self {
            tilt_deg: tilt.to_degrees(),
            strikes: trace.tilt_stops.len(),
            wheel_fraction: wheel / model.wheels.max_speed_rad_s(),
        }
    }

    fn max(&self, other: &Extremes) -> Extremes {
        Extremes {
            tilt_deg: self.tilt_deg.max(other.tilt_deg),
            strikes: self.strikes.max(other.strikes),
            wheel_fraction: self.wheel_fraction.max(other.wheel_fraction),
        }
    }

    /// The first limit broken and why (`context` appended to the reason), if any.
    fn broken(
        &self,
        model: &ModelConfig,
        limits: &DesignLimits,
        context: &str,
    ) -> Option<(Limit, String)> {
        let tilt_allowed_deg = model.platform.tilt_limit_deg - limits.tilt_margin_deg;
        if self.strikes > 0 {
            Some((
                Limit::TiltStop,
                format!("strikes the tilt stop {} time(s){context}", self.strikes),
            ))
        } else if self.tilt_deg > tilt_allowed_deg {
            Some((
                Limit::Tilt,
                format!(
                    "tilts to {:.1}° (limit {tilt_allowed_deg:.1}°){context}",
                    self.tilt_deg
                ),
            ))
        } else if self.wheel_fraction > limits.wheel_speed_fraction {
            Some((
                Limit::WheelSpeed,
                format!(
                    "runs a wheel at {:.0} % of its speed limit (limit {:.0} %){context}",
                    100.0 * self.wheel_fraction,
                    100.0 * limits.wheel_speed_fraction
                ),
            ))
        } else {
            None
        }
    }
}

/// Parameters of the targets in information order: (cause, offset in [`Cause::values`]).
pub fn parameters(targets: &[Cause]) -> Vec<(Cause, usize)> {
    let mut out: Vec<(Cause, usize)> = Vec::new();
    for &c in targets {
        if out.iter().any(|(p, _)| *p == c) {
            continue;
        }
        out.extend(information_params(c).map(|i| (c, i)));
    }
    out
}

/// Simulate the programme `options` on `model` and evaluate it: limits, information, criterion
/// and predicted standard errors of the targets' parameters.
pub fn evaluate(
    model: &ModelConfig,
    options: &ExperimentOptions,
    settings: &DesignOptions,
) -> Result<Evaluation, DesignError> {
    settings.validate()?;
    let (data, trace) = experiment::run(model, options)?;
    let nominal = Extremes::of(&trace, model);
    let mut broken = nominal.broken(model, &settings.limits, "");
    // The same programme with an unmodelled horizontal centre-of-mass offset of the allowance
    // along ±X and ±Y: the worst of these must keep the limits too.
    let mut worst = nominal;
    let a = settings.limits.com_allowance_m;
    if a > 0.0 {
        for (dir, name) in [
            ([a, 0.0], "+X"),
            ([-a, 0.0], "−X"),
            ([0.0, a], "+Y"),
            ([0.0, -a], "−Y"),
        ] {
            let mut shifted = model.clone();
            let mut r = Cause::ComOffset.values(model);
            r[0] += dir[0];
            r[1] += dir[1];
            Cause::ComOffset.apply(&mut shifted, &r);
            let (_, t) = experiment::run(&shifted, options)?;
            let e = Extremes::of(&t, model);
            if broken.is_none() {
                broken = e.broken(
                    model,
                    &settings.limits,
                    &format!(
                        " with {:.2} µm more centre-of-mass offset along {name}",
                        a * 1e6
                    ),
                );
            }
            worst = worst.max(&e);
        }
    }
    let (limit, rejected) = match broken {
        Some((l, why)) => (Some(l), Some(why)),
        None => (None, None),
    };
    data.check().map_err(IdentError::from)?;
    let aligned = Aligned::new(&data);
    let held_out = held_out_mask(&aligned, &settings.identify);
    let problem = Problem::new(
        &aligned,
        model.clone(),
        held_out,
        settings.identify.block_s,
        settings.identify.fit.clone(),
    );
    let state = problem.state(model)?;
    let information = problem.information(&state, &settings.targets)?;
    let (scale, scaled) = scaled_information(&information);
    let (criterion, se_scaled) = d_criterion(&scaled);
    let stderr = se_scaled.iter().zip(&scale).map(|(s, d)| s * d).collect();
    Ok(Evaluation {
        options: options.clone(),
        max_tilt_deg: nominal.tilt_deg,
        tilt_stop_strikes: nominal.strikes,
        max_wheel_speed_fraction: nominal.wheel_fraction,
        worst_with_allowance: worst,
        limit,
        rejected,
        criterion,
        stderr,
        information: Some(information),
    })
}

/// Each parameter's typical magnitude ([`typical_magnitude`]) and the information in those
/// units (`F_s = D F D`, `D` the magnitudes): what the criterion and the separability read.
fn scaled_information(information: &Information) -> (Vec<f64>, DMatrix<f64>) {
    let scale: Vec<f64> = information
        .params
        .iter()
        .map(|(c, i)| typical_magnitude(*c, *i))
        .collect();
    let p = scale.len();
    let scaled = DMatrix::from_fn(p, p, |i, j| {
        information.matrix[(i, j)] * scale[i] * scale[j]
    });
    (scale, scaled)
}

/// The result of a design search.
#[derive(Debug, Clone, Serialize)]
pub struct Design {
    /// Names of the parameters (`cause.key[i]`), in the order of the standard errors.
    pub parameters: Vec<String>,
    /// Typical magnitude of each parameter (the information's unit), configuration units.
    pub typical: Vec<f64>,
    /// The baseline programme (the one the search starts from), evaluated.
    pub baseline: Evaluation,
    /// The best admissible programme found.
    pub chosen: Evaluation,
    /// Candidates simulated.
    pub evaluated: usize,
    /// Of those, rejected for a limit or because the evaluation failed.
    pub rejected: usize,
    /// The rejected candidates, in the order simulated.
    pub rejections: Vec<Rejection>,
    /// Passes of the coordinate search run.
    pub passes: usize,
    pub limits: DesignLimits,
    /// The pairs of target causes the chosen programme cannot separate
    /// ([`crate::separability`]).
    pub unseparable: Vec<Confusion>,
}

impl Design {
    /// Predicted standard error ratio chosen / baseline per parameter (below 1: better).
    pub fn stderr_ratio(&self) -> Vec<f64> {
        self.chosen
            .stderr
            .iter()
            .zip(&self.baseline.stderr)
            .map(|(c, b)| c / b)
            .collect()
    }
}

/// The candidates evaluated so far.
struct Search<'a> {
    model: &'a ModelConfig,
    settings: &'a DesignOptions,
    cache: Vec<Evaluation>,
    failures: usize,
    last_failure: String,
    failed: Vec<Rejection>,
}

impl Search<'_> {
    /// Evaluate a candidate (cached). `None` for options the schedule refuses and for a
    /// candidate whose simulation or filter run fails (counted as rejected).
    fn eval(&mut self, options: &ExperimentOptions) -> Result<Option<Evaluation>, DesignError> {
        if let Some(e) = self.cache.iter().find(|e| e.options == *options) {
            return Ok(Some(e.clone()));
        }
        if options.validate().is_err() {
            return Ok(None);
        }
        match evaluate(self.model, options, self.settings) {
            Ok(e) => {
                self.cache.push(e.clone());
                Ok(Some(e))
            }
            Err(DesignError::Ident(err)) => {
                self.failures += 1;
                self.last_failure = err.to_string();
                self.failed.push(Rejection {
                    options: options.clone(),
                    limit: Limit::Failed,
                    why: self.last_failure.clone(),
                });
                Ok(None)
            }
            Err(other) => Err(other),
        }
    }
}

/// Search the programmes around `baseline` (its duration and seed fixed) for the best
/// admissible one by the D-criterion on the targets of `settings`. Each candidate is simulated
/// on `model` ([`evaluate`]). Fails if no candidate (the baseline included) is admissible.
pub fn design(
    model: &ModelConfig,
    baseline: &ExperimentOptions,
    settings: &DesignOptions,
) -> Result<Design, DesignError> {
    settings.validate()?;
    baseline.validate()?;
    if baseline.thrusters {
        return Err(DesignError::Options {
            key: "thrusters".into(),
            value: "true".into(),
            reason: "the design covers the wheel programme, not the thruster programme".into(),
        });
    }
    let mut search = Search {
        model,
        settings,
        cache: Vec::new(),
        failures: 0,
        last_failure: String::new(),
        failed: Vec::new(),
    };
    let Some(baseline_eval) = search.eval(baseline)? else {
        return Err(DesignError::NoAdmissible {
            evaluated: 1,
            why: format!(
                "the baseline programme could not be evaluated: {}",
                search.last_failure
            ),
        });
    };
    let mut best = baseline_eval.clone();
    let mut passes = 0;
    for _ in 0..settings.passes {
        passes += 1;
        let mut changed = false;
        for v in Variable::ALL {
            for &x in v.grid(&settings.space) {
                let mut candidate = best.options.clone();
                v.set(&mut candidate, x);
                if let Some(e) = search.eval(&candidate)?
                    && e.better_than(&best)
                {
                    best = e;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    let evaluated = search.cache.len() + search.failures;
    let mut rejections: Vec<Rejection> = search
        .cache
        .iter()
        .filter_map(|e| {
            Some(Rejection {
                options: e.options.clone(),
                limit: e.limit?,
                why: e.rejected.clone()?,
            })
        })
        .collect();
    rejections.extend(search.failed.iter().cloned());
    let rejected = rejections.len();
    if !best.admissible() {
        let why = best.rejected.clone().unwrap_or_default();
        return Err(DesignError::NoAdmissible {
            evaluated,
            why: format!("the best candidate {why}"),
        });
    }
    let params = parameters(&settings.targets);
    let unseparable = best.information.as_ref().map_or_else(Vec::new, |f| {
        unseparable(&f.params, &scaled_information(f).1)
    });
    Ok(Design {
        parameters: params.iter().map(|(c, i)| c.value_name(*i)).collect(),
        typical: params
            .iter()
            .map(|(c, i)| typical_magnitude(*c, *i))
            .collect(),
        baseline: baseline_eval,
        chosen: best,
        evaluated,
        rejected,
        rejections,
        passes,
        limits: settings.limits.clone(),
        unseparable,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn criterion_of_a_known_information_matrix() {
        // Straight-line regression y = a + b t at t = −1, 0, 1 with unit noise: XᵀX =
        // [[3, 0], [0, 2]], det 6, standard errors 1/√3 and 1/√2.
        let f = DMatrix::from_row_slice(2, 2, &[3.0, 0.0, 0.0, 2.0]);
        let (c, se) = d_criterion(&f);
        assert_eq!(c.unidentified, 0);
        assert!((c.log_det - 6.0f64.ln()).abs() < 1e-12);
        assert!((se[0] - 1.0 / 3.0f64.sqrt()).abs() < 1e-12);
        assert!((se[1] - 1.0 / 2.0f64.sqrt()).abs() < 1e-12);
        // At t = 1, 2, 3: XᵀX = [[3, 6], [6, 14]], det 6 again (a shift of t moves the
        // intercept's error, not the determinant); Var a = 14/6, Var b = 3/6.
        let g = DMatrix::from_row_slice(2, 2, &[3.0, 6.0, 6.0, 14.0]);
        let (c, se) = d_criterion(&g);
        assert_eq!(c.unidentified, 0);
        assert!((c.log_det - 6.0f64.ln()).abs() < 1e-10);
        assert!((se[0] - (14.0f64 / 6.0).sqrt()).abs() < 1e-10);
        assert!((se[1] - 0.5f64.sqrt()).abs() < 1e-10);
        // Spreading the samples to t = −2, 0, 2 quadruples the slope's information: log det
        // grows by ln 4 and the design is better.
        let h = DMatrix::from_row_slice(2, 2, &[3.0, 0.0, 0.0, 8.0]);
        let (ch, _) = d_criterion(&h);
        assert!((ch.log_det - c.log_det - 4.0f64.ln()).abs() < 1e-10);
        assert!(ch.better_than(&c) && !c.better_than(&ch));
    }

    #[test]
    fn an_undetermined_direction_is_counted_and_ranks_below() {
        // Two parameters that only enter as their sum (a column repeated): XᵀX = [[n, n], [n, n]].
        let f = DMatrix::from_row_slice(3, 3, &[4.0, 4.0, 0.0, 4.0, 4.0, 0.0, 0.0, 0.0, 1.0]);
        let (c, se) = d_criterion(&f);
        assert_eq!(c.unidentified, 1);
        // The determined eigenvalues are 8 and 1.
        assert!((c.log_det - 8.0f64.ln()).abs() < 1e-10);
        assert!(se[0].is_nan() && se[1].is_nan());
        assert!((se[2] - 1.0).abs() < 1e-12);
        // Any fully determined design beats it, even with far less information.
        let tiny = DMatrix::from_diagonal_element(3, 3, 1e-6);
        let (ct, _) = d_criterion(&tiny);
        assert!(ct.better_than(&c));
        assert!(ct.log_det < c.log_det);
        // No information at all.
        let (cz, sz) = d_criterion(&DMatrix::zeros(2, 2));
        assert_eq!(cz.unidentified, 2);
        assert_eq!(cz.log_det, f64::NEG_INFINITY);
        assert!(sz.iter().all(|s| s.is_nan()));
    }

    #[test]
    fn scaling_the_parameters_shifts_every_log_det_by_the_same_constant() {
        let a = DMatrix::from_row_slice(2, 2, &[5.0, 1.0, 1.0, 2.0]);
        let b = DMatrix::from_row_slice(2, 2, &[3.0, -1.0, -1.0, 4.0]);
        let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1e-6, 1e-2]));
        let (ca, _) = d_criterion(&a);
        let (cb, _) = d_criterion(&b);
        let (csa, _) = d_criterion(&(&d * &a * &d));
        let (csb, _) = d_criterion(&(&d * &b * &d));
        let shift = 2.0 * (1e-6f64.ln() + 1e-2f64.ln());
        // (To 1e-6: the eigenvalues of the badly scaled matrices span eight decades, so the
        // smaller carries a relative rounding error near 1e-8; the typical magnitudes are
        // there to avoid exactly this.)
        assert!((csa.log_det - ca.log_det - shift).abs() < 1e-6);
        assert!((csb.log_det - cb.log_det - shift).abs() < 1e-6);
        assert_eq!(ca.better_than(&cb), csa.better_than(&csb));
    }

    #[test]
    fn settings_are_validated() {
        let ok = DesignOptions::default();
        assert!(ok.validate().is_ok());
        let thrusters = DesignOptions {
            targets: vec![Cause::ThrusterTorqueScale],
            ..DesignOptions::default()
        };
        assert!(matches!(
            thrusters.validate(),
            Err(DesignError::Options { key, .. }) if key == "targets"
        ));
        let mut wheel = DesignOptions::default();
        wheel.limits.wheel_speed_fraction = 1.5;
        assert!(wheel.validate().is_err());
        let mut grid = DesignOptions::default();
        grid.space.tilt_deg.push(f64::NAN);
        assert!(grid.validate().is_err());
    }
}
