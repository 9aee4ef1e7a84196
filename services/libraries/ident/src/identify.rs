//! The analysis of `testbed identify`.
//!
//! 1. **What the simulation gets wrong.** The nominal model (the configuration given) predicts
//!    every measurement channel — rates, tilt, field, wheel speeds — from the estimated state,
//!    re-initialised every `horizon_s` and driven by the recorded commands
//!    ([`crate::predict`]); and the data are checked against its equations of motion
//!    ([`crate::channels`]: the platform's momentum equation, the wheels' equation) and its
//!    sensor models (the attitude filter's innovations). Each residual is described by its RMS,
//!    bias, trend and whiteness.
//! 2. **Name the cause.** The data are split in time blocks; every `held_out_every`-th block is
//!    held out of the fits. Forward selection over the candidate library: at each step every
//!    remaining cause is fitted jointly with those already chosen ([`crate::fit`]); a candidate
//!    is significant when its likelihood ratio on the fit data beats both the information
//!    criterion (BIC, `k ln N`) and the χ² quantile at `1 − alpha`; among the significant ones
//!    whose held-out residuals improve, the one that improves them most is chosen. No candidate
//!    chosen: the cause is `none`.
//! 3. **Extend the model**: the configuration given plus the chosen effects with their fitted
//!    values (loadable by `ModelConfig::load`).
//! 4. **Measure the gain** on the held-out blocks: multi-step prediction error of the nominal and
//!    extended model per component and overall; gain = nominal / extended.
//!
//! What remains after the chosen causes is checked on the equation-error channels (RMS against
//! the noise the model expects, whiteness) and, if something remains, correlated with the
//! signals the candidate effects would produce.

use crate::channels::{TORQUE_COLUMNS, friction_regressors};
use crate::data::{Aligned, Dataset};
use crate::effects::{Cause, Kind};
use crate::error::IdentError;
use crate::fit::{CHANNELS, ChannelRss, Evaluation, FitOptions, Problem, SetFit, WheelModel};
use crate::predict::{self, COMPONENTS, ComponentRms, Predictions, UNITS};
use crate::reconstruct::INNOVATION_LEN;
use crate::stats::{SeriesStats, chi_square_quantile, correlation, series_stats};
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use testbed_model::ModelConfig;
use testbed_model::attitude;

/// Settings of the analysis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Options {
    pub fit: FitOptions,
    /// Prediction window: re-initialisation period of the multi-step predictions, s.
    pub horizon_s: f64,
    /// Length of the time blocks of the fit / held-out split, s.
    pub block_s: f64,
    /// Every this-many-th block is held out (3: a third of the data).
    pub held_out_every: usize,
    /// Most causes named.
    pub max_causes: usize,
    /// Significance level of a cause (per candidate and step).
    pub alpha: f64,
    /// Candidates considered (default: the whole library).
    pub candidates: Vec<Cause>,
    /// Normalised RMS of an equation-error channel above which residual is said to remain.
    pub remaining_rms: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            fit: FitOptions::default(),
            horizon_s: 10.0,
            block_s: 30.0,
            held_out_every: 3,
            max_causes: 4,
            alpha: 1e-6,
            candidates: Cause::ALL.to_vec(),
            remaining_rms: 1.3,
        }
    }
}

impl Options {
    fn validate(&self) -> Result<(), IdentError> {
        let bad = |key: &str, value: String, reason: &str| {
            Err(IdentError::Options {
                key: key.into(),
                value,
                reason: reason.into(),
            })
        };
        if !(self.horizon_s.is_finite() && self.horizon_s > 0.0) {
            return bad("horizon_s", self.horizon_s.to_string(), "must be > 0");
        }
        if !(self.block_s.is_finite() && self.block_s >= self.horizon_s) {
            return bad(
                "block_s",
                self.block_s.to_string(),
                "must be at least the prediction horizon",
            );
        }
        if self.held_out_every < 2 {
            return bad(
                "held_out_every",
                self.held_out_every.to_string(),
                "must be >= 2",
            );
        }
        if !(self.alpha > 0.0 && self.alpha < 0.5) {
            return bad("alpha", self.alpha.to_string(), "must be within (0, 0.5)");
        }
        if !(self.fit.torque_segment_s > 0.0 && self.fit.max_delay_s > 0.0) {
            return bad("fit", format!("{:?}", self.fit), "intervals must be > 0");
        }
        Ok(())
    }
}

/// Summary of the data analysed.
#[derive(Debug, Clone, Serialize)]
pub struct DataSummary {
    pub source: String,
    pub duration_s: f64,
    pub gyro_rows: usize,
    pub period_s: f64,
    pub devices: Vec<&'static str>,
    /// Fraction of the ticks held out of the fits.
    pub held_out_fraction: f64,
}

/// Statistics of one residual component.
#[derive(Debug, Clone, Serialize)]
pub struct ComponentReport {
    pub name: String,
    pub unit: &'static str,
    /// RMS divided by the noise the model expects (1 = as noisy as the sensors).
    pub normalised_rms: f64,
    #[serde(flatten)]
    pub stats: SeriesStats,
}

/// Residual report of one model.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualReport {
    /// Multi-step prediction residuals (measured − predicted) over the whole record.
    pub prediction: Vec<ComponentReport>,
    /// Equation-error residuals: platform momentum (the integral of the torque residual over each
    /// segment, Nms), wheel torque (Nm), filter innovations (whitened).
    pub equation_error: Vec<ComponentReport>,
    /// Whitened RMS of each equation-error channel (1 = noise as modelled), fit / held out.
    pub channel_rms_fit: BTreeMap<&'static str, f64>,
    pub channel_rms_held_out: BTreeMap<&'static str, f64>,
}

/// One candidate's evaluation in a selection step.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateRow {
    pub name: &'static str,
    /// Parameters estimated.
    pub k: usize,
    /// Likelihood ratio on the fit data, `Σ n ln(RSS/RSS')`.
    pub lr_fit: f64,
    /// Threshold it must beat: max(k ln N, χ²_k(1 − alpha)).
    pub threshold: f64,
    /// BIC change (negative: better).
    pub delta_bic: f64,
    /// Likelihood ratio on the held-out data (positive: predicts them better).
    pub lr_held_out: f64,
    pub significant: bool,
    pub chosen: bool,
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// One named cause.
#[derive(Debug, Clone, Serialize)]
pub struct CauseReport {
    pub name: &'static str,
    pub description: &'static str,
    /// Fitted values under the configuration's keys (the `[effects.<name>]` table).
    pub parameters: serde_json::Map<String, serde_json::Value>,
    /// Standard errors, same keys (`null`: not estimated).
    pub stderr: serde_json::Map<String, serde_json::Value>,
    pub units: serde_json::Map<String, serde_json::Value>,
    pub lr_fit: f64,
    pub delta_bic: f64,
    pub lr_held_out: f64,
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// A residual's correlation with a signal a candidate effect would produce.
#[derive(Debug, Clone, Serialize)]
pub struct Correlation {
    pub residual: String,
    pub signal: String,
    pub r: f64,
}

/// What is left after the chosen causes.
#[derive(Debug, Clone, Serialize)]
pub struct Remaining {
    pub residual_remains: bool,
    pub message: String,
    /// Whitened RMS per equation-error channel on the held-out data.
    pub channel_rms: BTreeMap<&'static str, f64>,
    /// Strongest correlations of the remaining residuals (when residual remains).
    pub correlations: Vec<Correlation>,
}

/// Prediction error of one model on the held-out data.
#[derive(Debug, Clone, Serialize)]
pub struct RmsReport {
    /// Root mean square of the components' normalised RMS (1 = sensor noise).
    pub overall: f64,
    /// Per component: RMS (its unit), normalised RMS, samples.
    pub components: BTreeMap<&'static str, ComponentRms>,
    /// Per channel group (rates, tilt, field, wheel speeds): normalised.
    pub groups: BTreeMap<&'static str, f64>,
}

/// The report of `identify`.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub data: DataSummary,
    pub options: Options,
    /// Item 1: the nominal model's residuals.
    pub nominal_residuals: ResidualReport,
    /// Forward selection, one entry per step.
    pub steps: Vec<Vec<CandidateRow>>,
    /// Named causes, strongest first (empty: none).
    pub causes: Vec<CauseReport>,
    /// `none`, or the causes joined by ` + `.
    pub verdict: String,
    pub remaining: Remaining,
    /// The extended model's residuals.
    pub extended_residuals: ResidualReport,
    pub baseline_rms: RmsReport,
    pub extended_rms: RmsReport,
    /// `baseline_rms.overall / extended_rms.overall`.
    pub gain: f64,
    pub gain_by_component: BTreeMap<&'static str, f64>,
    pub gain_by_group: BTreeMap<&'static str, f64>,
    /// Filter runs the analysis took.
    pub filter_runs: usize,
}

/// A labelled time series for figures.
#[derive(Debug, Clone)]
pub struct Curve {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// What the figures need.
#[derive(Debug, Clone, Default)]
pub struct FigureData {
    /// Nominal model, whole record: prediction residuals per component.
    pub nominal_prediction: Vec<Curve>,
    /// Equation-error residuals, nominal and extended: torque (Nm), wheel (Nm), innovations.
    pub nominal_equation: Vec<Curve>,
    pub extended_equation: Vec<Curve>,
    /// Held-out windows: normalised RMS per window and group, nominal and extended.
    pub held_out_nominal: Vec<Curve>,
    pub held_out_extended: Vec<Curve>,
}

/// The result of `identify`.
#[derive(Debug, Clone)]
pub struct Identification {
    pub report: Report,
    /// The extended model (the configuration given plus the named effects).
    pub extended: ModelConfig,
    pub figures: FigureData,
}

/// Identify what the model gets wrong in `data` (see the module documentation).
pub fn identify(
    data: &Dataset,
    model: &ModelConfig,
    options: &Options,
) -> Result<Identification, IdentError> {
    options.validate()?;
    model.validate()?;
    data.check()?;
    let aligned = Aligned::new(data);
    let block = |t: f64| (t / options.block_s).floor() as usize;
    let held_out: Vec<bool> = aligned
        .t
        .iter()
        .map(|&t| block(t) % options.held_out_every == options.held_out_every - 1)
        .collect();
    let held_fraction =
        held_out.iter().filter(|h| **h).count() as f64 / held_out.len().max(1) as f64;
    let problem = Problem::new(
        &aligned,
        model.clone(),
        held_out.clone(),
        options.fit.clone(),
    );

    // Baseline.
    let empty = HashMap::new();
    let nominal = problem.fit(&[], &empty)?;
    if nominal.state.recon.start >= aligned.len() {
        return Err(IdentError::Failed(format!(
            "{}: the attitude filter never started (no usable inclinometer/magnetometer sample pair)",
            data.source.display()
        )));
    }
    let n_fit = nominal.evaluation.fit.total().max(2) as f64;

    // Forward selection.
    let available: Vec<Cause> = options
        .candidates
        .iter()
        .copied()
        .filter(|c| available(*c, &problem, &nominal))
        .collect();
    let mut selected: Vec<Cause> = Vec::new();
    let mut current = nominal.clone();
    let mut steps = Vec::new();
    let mut chosen_rows: Vec<CandidateRow> = Vec::new();
    let mut warm: HashMap<Cause, crate::fit::FittedCause> = HashMap::new();
    for _ in 0..options.max_causes {
        let mut rows = Vec::new();
        let mut best: Option<(usize, SetFit)> = None;
        for &cause in available.iter().filter(|c| !selected.contains(c)) {
            let mut set = selected.clone();
            set.push(cause);
            let threshold_for = |k: usize| {
                (k as f64 * n_fit.ln()).max(
                    chi_square_quantile(1.0 - options.alpha, k.max(1) as f64)
                        .unwrap_or(f64::INFINITY),
                )
            };
            let screen = (cause.kind() == Kind::Sensor)
                .then(|| (threshold_for(cause.len()), current.evaluation.fit.rss[0]));
            match problem.fit_screened(&set, &warm, screen) {
                Ok(fit) => {
                    let lr = current.evaluation.fit.log_ratio(&fit.evaluation.fit);
                    let k = fit.free().saturating_sub(current.free());
                    let threshold = threshold_for(k);
                    let lr_held = current
                        .evaluation
                        .held_out
                        .log_ratio(&fit.evaluation.held_out);
                    let significant = k > 0 && lr > threshold;
                    let note = fit
                        .causes
                        .iter()
                        .find(|c| c.cause == cause)
                        .map(|c| c.note.clone())
                        .unwrap_or_default();
                    rows.push(CandidateRow {
                        name: cause.name(),
                        k,
                        lr_fit: lr,
                        threshold,
                        delta_bic: -lr + k as f64 * n_fit.ln(),
                        lr_held_out: lr_held,
                        significant,
                        chosen: false,
                        note,
                    });
                    if significant
                        && lr_held > 0.0
                        && best
                            .as_ref()
                            .is_none_or(|(i, _)| lr_held > rows[*i].lr_held_out)
                    {
                        best = Some((rows.len() - 1, fit));
                    }
                }
                Err(e) => rows.push(CandidateRow {
                    name: cause.name(),
                    k: 0,
                    lr_fit: 0.0,
                    threshold: f64::NAN,
                    delta_bic: f64::NAN,
                    lr_held_out: 0.0,
                    significant: false,
                    chosen: false,
                    note: e.to_string(),
                }),
            }
        }
        let Some((i, fit)) = best else {
            steps.push(rows);
            break;
        };
        rows[i].chosen = true;
        let cause = Cause::from_name(rows[i].name).unwrap_or(Cause::ComOffset);
        chosen_rows.push(rows[i].clone());
        steps.push(rows);
        selected.push(cause);
        warm = fit
            .causes
            .iter()
            .filter(|c| c.cause.kind() == Kind::Sensor)
            .map(|c| (c.cause, c.clone()))
            .collect();
        current = fit;
        problem.trim_cache(&[&current.config]);
    }

    let causes: Vec<CauseReport> = selected
        .iter()
        .zip(&chosen_rows)
        .filter_map(|(cause, row)| {
            let f = current.causes.iter().find(|c| c.cause == *cause)?;
            Some(CauseReport {
                name: cause.name(),
                description: cause.description(),
                parameters: cause.to_json(&f.values),
                stderr: cause.to_json(&f.stderr),
                units: cause.units_json(),
                lr_fit: row.lr_fit,
                delta_bic: row.delta_bic,
                lr_held_out: row.lr_held_out,
                note: f.note.clone(),
            })
        })
        .collect();
    let verdict = if causes.is_empty() {
        "none".to_string()
    } else {
        causes
            .iter()
            .map(|c| c.name)
            .collect::<Vec<_>>()
            .join(" + ")
    };
    let extended = current.config.clone();
    // The extended model must load as it is written.
    ModelConfig::from_toml_str(&extended.to_toml_string(), "extended model")?;

    // Residual reports, nominal and extended.
    let all_spans = [(nominal.state.recon.start, aligned.len())];
    let all_windows = predict::windows(&aligned, &all_spans, options.horizon_s);
    let nominal_prediction = predict::predict(&aligned, &nominal.state.recon, model, &all_windows)?;
    let (nominal_equation, nominal_report) =
        equation_error(&problem, &nominal, &nominal_prediction);
    let extended_prediction = if selected.is_empty() {
        nominal_prediction.clone()
    } else {
        predict::predict(&aligned, &current.state.recon, &extended, &all_windows)?
    };
    let (extended_equation, extended_report) =
        equation_error(&problem, &current, &extended_prediction);

    // Gain on the held-out blocks.
    let spans = held_out_spans(&held_out, nominal.state.recon.start);
    let windows = predict::windows(&aligned, &spans, options.horizon_s);
    let base_held = predict::predict(&aligned, &nominal.state.recon, model, &windows)?;
    let ext_held = if selected.is_empty() {
        base_held.clone()
    } else {
        predict::predict(&aligned, &current.state.recon, &extended, &windows)?
    };
    let base_rms = base_held.rms(|_| true);
    let ext_rms = ext_held.rms(|_| true);
    let baseline_rms = rms_report(&base_rms);
    let extended_rms = rms_report(&ext_rms);
    let gain = baseline_rms.overall / extended_rms.overall;
    let mut gain_by_component = BTreeMap::new();
    for c in 0..COMPONENTS.len() {
        if let (Some(a), Some(b)) = (base_rms[c], ext_rms[c]) {
            gain_by_component.insert(COMPONENTS[c], a.rms / b.rms);
        }
    }
    let gain_by_group = baseline_rms
        .groups
        .iter()
        .filter_map(|(g, a)| extended_rms.groups.get(g).map(|b| (*g, a / b)))
        .collect();

    let remaining = remaining(&problem, &current, options);
    let figures = FigureData {
        nominal_prediction: prediction_curves(&nominal_prediction),
        nominal_equation,
        extended_equation,
        held_out_nominal: window_curves(&base_held, &aligned),
        held_out_extended: window_curves(&ext_held, &aligned),
    };
    let devices = [
        (!data.gyro.is_empty(), "gyro"),
        (!data.inclinometer.is_empty(), "inclinometer"),
        (!data.magnetometer.is_empty(), "magnetometer"),
        (!data.wheels.is_empty(), "wheels"),
        (!data.cmg.is_empty(), "cmg"),
    ]
    .into_iter()
    .filter_map(|(p, n)| p.then_some(n))
    .collect();
    let report = Report {
        data: DataSummary {
            source: data.source.display().to_string(),
            duration_s: data.duration_s(),
            gyro_rows: data.gyro.len(),
            period_s: aligned.period_s,
            devices,
            held_out_fraction: held_fraction,
        },
        options: options.clone(),
        nominal_residuals: nominal_report,
        steps,
        causes,
        verdict,
        remaining,
        extended_residuals: extended_report,
        baseline_rms,
        extended_rms,
        gain,
        gain_by_component,
        gain_by_group,
        filter_runs: problem.filter_runs.get(),
    };
    Ok(Identification {
        report,
        extended,
        figures,
    })
}

/// Whether the data can say anything about a cause.
fn available(cause: Cause, problem: &Problem, nominal: &SetFit) -> bool {
    let s = &nominal.state;
    match cause.kind() {
        Kind::Sensor => {
            !s.recon.innovations.is_empty()
                && (cause != Cause::MagneticDisturbance || !problem.data.field.is_empty())
        }
        Kind::Torque => s.torque.len() >= 30,
        Kind::Wheel => s.wheel.len() >= 10,
    }
}

/// Contiguous runs of held-out ticks after `start`.
fn held_out_spans(held: &[bool], start: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut k = start;
    while k < held.len() {
        if held[k] {
            let a = k;
            while k < held.len() && held[k] {
                k += 1;
            }
            out.push((a, k));
        } else {
            k += 1;
        }
    }
    out
}

fn rms_report(rms: &[Option<ComponentRms>; 11]) -> RmsReport {
    let mut components = BTreeMap::new();
    let mut groups: BTreeMap<&'static str, (f64, usize)> = BTreeMap::new();
    for (c, r) in rms.iter().enumerate() {
        if let Some(r) = r {
            components.insert(COMPONENTS[c], *r);
            let g = groups.entry(predict::group(c)).or_insert((0.0, 0));
            g.0 += r.normalised * r.normalised;
            g.1 += 1;
        }
    }
    RmsReport {
        overall: Predictions::overall(rms),
        components,
        groups: groups
            .into_iter()
            .map(|(g, (s, n))| (g, (s / n as f64).sqrt()))
            .collect(),
    }
}

fn prediction_curves(p: &Predictions) -> Vec<Curve> {
    (0..COMPONENTS.len())
        .filter(|&c| !p.residuals[c].is_empty())
        .map(|c| Curve {
            label: COMPONENTS[c].to_string(),
            points: p.residuals[c].iter().map(|(t, r, _)| (*t, *r)).collect(),
        })
        .collect()
}

fn window_curves(p: &Predictions, data: &Aligned) -> Vec<Curve> {
    let per = p.per_window(data);
    let mut groups: BTreeMap<&'static str, BTreeMap<u64, (f64, f64, usize)>> = BTreeMap::new();
    for (c, series) in per.iter().enumerate() {
        for &(t, v) in series {
            let e = groups
                .entry(predict::group(c))
                .or_default()
                .entry(t.to_bits())
                .or_insert((t, 0.0, 0));
            e.1 += v * v;
            e.2 += 1;
        }
    }
    groups
        .into_iter()
        .map(|(g, m)| {
            let mut points: Vec<(f64, f64)> = m
                .into_values()
                .map(|(t, s, n)| (t, (s / n as f64).sqrt()))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            Curve {
                label: g.to_string(),
                points,
            }
        })
        .collect()
}

/// Equation-error residual series of a fitted set: torque (Nm), wheel torque (Nm), innovations
/// (whitened); and its residual report with the prediction residuals.
fn equation_error(
    problem: &Problem,
    fit: &SetFit,
    prediction: &Predictions,
) -> (Vec<Curve>, ResidualReport) {
    let data = problem.data;
    let s = &fit.state;
    let mut curves = Vec::new();
    // Torque channel: momentum residual (integral of the torque residual), Nms.
    let mut torque: [Vec<(f64, f64)>; 3] = Default::default();
    for (i, &k) in s.torque.ticks.iter().enumerate() {
        let r = s
            .torque
            .whitened(i, &fit.torque_delta)
            .component_mul(&s.torque.sigma);
        for axis in 0..3 {
            torque[axis].push((data.t[k], r[axis]));
        }
    }
    let torque_sigma = [s.torque.sigma.x, s.torque.sigma.y, s.torque.sigma.z];
    let wheel_model = WheelModel::from_config(&fit.config);
    let mut wheel: [Vec<(f64, f64)>; 3] = Default::default();
    let mut wheel_sigma = 0.0;
    for (w, rows) in s.wheel.rows.iter().enumerate() {
        for row in rows {
            let dt = row.t1 - row.t0;
            wheel[w].push((row.t0, wheel_model.residual(data, &s.wheel, w, row) / dt));
            wheel_sigma = s.wheel.sigma / dt;
        }
    }
    let mut innovations: [Vec<(f64, f64)>; INNOVATION_LEN] = Default::default();
    for i in &s.recon.innovations {
        for c in 0..INNOVATION_LEN {
            if i.mask & (1 << c) != 0 {
                innovations[c].push((data.t[i.tick], i.values[c]));
            }
        }
    }
    let mut equation = Vec::new();
    let names_t = ["momentum_x", "momentum_y", "momentum_z"];
    let names_w = ["wheel_torque_x", "wheel_torque_y", "wheel_torque_z"];
    let names_i = [
        "innovation_tilt_1",
        "innovation_tilt_2",
        "innovation_field_x",
        "innovation_field_y",
        "innovation_field_z",
    ];
    for (series, names, unit, sigma) in [
        (&torque[..], &names_t[..], "Nms", &torque_sigma[..]),
        (&wheel[..], &names_w[..], "Nm", &[wheel_sigma; 3][..]),
        (
            &innovations[..],
            &names_i[..],
            "1 (whitened)",
            &[1.0; 5][..],
        ),
    ] {
        for (c, xs) in series.iter().enumerate() {
            if xs.is_empty() {
                continue;
            }
            let t: Vec<f64> = xs.iter().map(|p| p.0).collect();
            let v: Vec<f64> = xs.iter().map(|p| p.1).collect();
            let stats = series_stats(&t, &v, 10);
            equation.push(ComponentReport {
                name: names[c].to_string(),
                unit,
                normalised_rms: stats.rms / sigma[c].max(1e-300),
                stats,
            });
            curves.push(Curve {
                label: names[c].to_string(),
                points: xs.clone(),
            });
        }
    }
    let mut pred = Vec::new();
    for c in 0..COMPONENTS.len() {
        let xs = &prediction.residuals[c];
        if xs.is_empty() {
            continue;
        }
        let t: Vec<f64> = xs.iter().map(|p| p.0).collect();
        let v: Vec<f64> = xs.iter().map(|p| p.1).collect();
        let stats = series_stats(&t, &v, 10);
        pred.push(ComponentReport {
            name: COMPONENTS[c].to_string(),
            unit: UNITS[c],
            normalised_rms: stats.rms / prediction.sigma[c],
            stats,
        });
    }
    let rms_map = |e: &ChannelRss| -> BTreeMap<&'static str, f64> {
        (0..3)
            .filter(|&c| e.n[c] > 0)
            .map(|c| (CHANNELS[c], e.normalised_rms(c)))
            .collect()
    };
    let Evaluation {
        fit: f,
        held_out: h,
    } = fit.evaluation;
    (
        curves,
        ResidualReport {
            prediction: pred,
            equation_error: equation,
            channel_rms_fit: rms_map(&f),
            channel_rms_held_out: rms_map(&h),
        },
    )
}

/// Is there residual left after the chosen causes, and what does it correlate with?
fn remaining(problem: &Problem, fit: &SetFit, options: &Options) -> Remaining {
    let e = &fit.evaluation.held_out;
    let channel_rms: BTreeMap<&'static str, f64> = (0..3)
        .filter(|&c| e.n[c] > 0)
        .map(|c| (CHANNELS[c], e.normalised_rms(c)))
        .collect();
    let high: Vec<&'static str> = channel_rms
        .iter()
        .filter(|(_, v)| **v > options.remaining_rms)
        .map(|(k, _)| *k)
        .collect();
    if high.is_empty() {
        return Remaining {
            residual_remains: false,
            message: format!(
                "no residual remains: every equation-error channel is within {:.2}× the noise the model expects on the held-out data",
                options.remaining_rms
            ),
            channel_rms,
            correlations: Vec::new(),
        };
    }
    let correlations = correlate(problem, fit);
    let top = correlations.first().map_or(String::new(), |c| {
        format!(
            "; strongest correlation: {} with {} (r = {:.2})",
            c.residual, c.signal, c.r
        )
    });
    Remaining {
        residual_remains: true,
        message: format!(
            "residual remains in the {} channel{} (RMS above {:.2}× the expected noise on held-out data){top}",
            high.join(", "),
            if high.len() > 1 { "s" } else { "" },
            options.remaining_rms
        ),
        channel_rms,
        correlations,
    }
}

/// Correlations of the equation-error residuals with the candidate effects' signals, strongest
/// first (top 8).
fn correlate(problem: &Problem, fit: &SetFit) -> Vec<Correlation> {
    let data = problem.data;
    let s = &fit.state;
    let mut out = Vec::new();
    // Torque channel: against every torque regressor and the rates.
    if !s.torque.is_empty() {
        for axis in 0..3 {
            let r: Vec<f64> = (0..s.torque.len())
                .map(|i| s.torque.whitened(i, &fit.torque_delta)[axis])
                .collect();
            for col in 0..TORQUE_COLUMNS {
                let x: Vec<f64> = s.torque.x.iter().map(|row| row[col][axis]).collect();
                let (cause, off) = match col {
                    0..3 => (Cause::ComOffset, col),
                    3..6 => (Cause::ConstantTorque, col - 3),
                    6..12 => (Cause::AeroDrag, col - 6),
                    _ => (Cause::InertiaError, col - 12),
                };
                out.push(Correlation {
                    residual: format!("momentum_{}", "xyz".as_bytes()[axis] as char),
                    signal: cause.value_name(off),
                    r: correlation(&r, &x),
                });
            }
            for c in 0..3 {
                let x: Vec<f64> = s.torque.ticks.iter().map(|&k| s.recon.rate[k][c]).collect();
                out.push(Correlation {
                    residual: format!("momentum_{}", "xyz".as_bytes()[axis] as char),
                    signal: format!("rate_{}", "xyz".as_bytes()[c] as char),
                    r: correlation(&r, &x),
                });
            }
        }
    }
    // Wheel channel: against the command, the friction regressors and the command's change.
    let model = WheelModel::from_config(&fit.config);
    for (w, rows) in s.wheel.rows.iter().enumerate() {
        if rows.len() < 3 {
            continue;
        }
        let r: Vec<f64> = rows
            .iter()
            .map(|row| model.residual(data, &s.wheel, w, row))
            .collect();
        let name = format!("wheel_torque_{}", "xyz".as_bytes()[w] as char);
        let tau: Vec<f64> = rows
            .iter()
            .map(|row| {
                data.wheel_cmd_integral(row.t0, row.t1, model.delay_s, s.wheel.max_torque_nm)[w]
            })
            .collect();
        let dtau: Vec<f64> = rows
            .iter()
            .map(|row| {
                data.wheel_cmd_integral(row.t0, row.t1, model.delay_s, s.wheel.max_torque_nm)[w]
                    - data.wheel_cmd_integral(
                        row.t0,
                        row.t1,
                        model.delay_s + data.period_s,
                        s.wheel.max_torque_nm,
                    )[w]
            })
            .collect();
        out.push(Correlation {
            residual: name.clone(),
            signal: "wheel_torque_scale (command)".into(),
            r: correlation(&r, &tau),
        });
        out.push(Correlation {
            residual: name.clone(),
            signal: "actuator_delay (command change)".into(),
            r: correlation(&r, &dtau),
        });
        let labels = [
            "wheel_friction.coulomb_pos_nm",
            "wheel_friction.coulomb_neg_nm",
            "wheel_friction.stribeck_nm (n_s = 1 rad/s)",
            "wheel_friction.viscous_nm_per_rad_s",
        ];
        for (j, label) in labels.iter().enumerate() {
            let x: Vec<f64> = rows
                .iter()
                .map(|row| friction_regressors(row, Some(1.0))[j])
                .collect();
            out.push(Correlation {
                residual: name.clone(),
                signal: (*label).into(),
                r: correlation(&r, &x),
            });
        }
    }
    // Innovations: against the rates and the heading.
    let inn = &s.recon.innovations;
    for c in 0..INNOVATION_LEN {
        let rows: Vec<_> = inn.iter().filter(|i| i.mask & (1 << c) != 0).collect();
        if rows.len() < 3 {
            continue;
        }
        let r: Vec<f64> = rows.iter().map(|i| i.values[c]).collect();
        let name = [
            "innovation_tilt_1",
            "innovation_tilt_2",
            "innovation_field_x",
            "innovation_field_y",
            "innovation_field_z",
        ][c];
        for axis in 0..3 {
            let x: Vec<f64> = rows.iter().map(|i| s.recon.rate[i.tick][axis]).collect();
            out.push(Correlation {
                residual: name.into(),
                signal: format!(
                    "rate_{} (gyro scale/misalignment)",
                    "xyz".as_bytes()[axis] as char
                ),
                r: correlation(&r, &x),
            });
        }
        let cos: Vec<f64> = rows
            .iter()
            .map(|i| attitude::heading(&s.recon.q[i.tick]).cos())
            .collect();
        let sin: Vec<f64> = rows
            .iter()
            .map(|i| attitude::heading(&s.recon.q[i.tick]).sin())
            .collect();
        out.push(Correlation {
            residual: name.into(),
            signal: "cos(heading) (earth rate, hard iron)".into(),
            r: correlation(&r, &cos),
        });
        out.push(Correlation {
            residual: name.into(),
            signal: "sin(heading) (earth rate, hard iron)".into(),
            r: correlation(&r, &sin),
        });
    }
    out.retain(|c| c.r.is_finite());
    out.sort_by(|a, b| b.r.abs().total_cmp(&a.r.abs()));
    out.truncate(8);
    out
}
