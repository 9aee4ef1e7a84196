//! What a campaign keeps of each run: its metrics, and a decimated series of its pointing error
//! and NEES (for the envelope over runs and the ensemble consistency), so that memory does not
//! grow with the runs' length.

use crate::file::MetricOptions;
use serde::Serialize;
use testbed_config::RunConfig;
use testbed_model::config::{DEG, RPM};
use testbed_sim::closed_loop::Trace;
use testbed_sim::metrics as sim_metrics;

/// Which way a metric is better.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Better {
    Lower,
    /// Nearest this value (a consistency measure).
    Near(f64),
}

/// The metrics of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    SettleS,
    SteadyErrorXDeg,
    SteadyErrorYDeg,
    SteadyErrorZDeg,
    PeakWheelSpeedRpm,
    SaturationS,
    EstimateError3rmsXDeg,
    EstimateError3rmsYDeg,
    EstimateError3rmsZDeg,
    Outside3SigmaFraction,
    NeesPerDof,
    SafeModeLimit,
    TiltStops,
    GateRejections,
}

/// Degrees of freedom of the estimator's error state `[δθ, δb]`.
pub const NEES_DOF: usize = 6;

/// Fraction of a consistent filter's errors outside ±3σ: `P(|z| > 3)` of a standard normal.
pub const OUTSIDE_3_SIGMA_IF_CONSISTENT: f64 = 0.0027;

impl Metric {
    pub const ALL: [Metric; 14] = [
        Metric::SettleS,
        Metric::SteadyErrorXDeg,
        Metric::SteadyErrorYDeg,
        Metric::SteadyErrorZDeg,
        Metric::PeakWheelSpeedRpm,
        Metric::SaturationS,
        Metric::EstimateError3rmsXDeg,
        Metric::EstimateError3rmsYDeg,
        Metric::EstimateError3rmsZDeg,
        Metric::Outside3SigmaFraction,
        Metric::NeesPerDof,
        Metric::SafeModeLimit,
        Metric::TiltStops,
        Metric::GateRejections,
    ];

    /// The column name.
    pub fn name(self) -> &'static str {
        match self {
            Self::SettleS => "settle_s",
            Self::SteadyErrorXDeg => "steady_error_x_deg",
            Self::SteadyErrorYDeg => "steady_error_y_deg",
            Self::SteadyErrorZDeg => "steady_error_z_deg",
            Self::PeakWheelSpeedRpm => "peak_wheel_speed_rpm",
            Self::SaturationS => "saturation_s",
            Self::EstimateError3rmsXDeg => "estimate_error_3rms_x_deg",
            Self::EstimateError3rmsYDeg => "estimate_error_3rms_y_deg",
            Self::EstimateError3rmsZDeg => "estimate_error_3rms_z_deg",
            Self::Outside3SigmaFraction => "outside_3sigma_fraction",
            Self::NeesPerDof => "nees_per_dof",
            Self::SafeModeLimit => "safe_mode_limit",
            Self::TiltStops => "tilt_stops",
            Self::GateRejections => "gate_rejections",
        }
    }

    /// The unit, as the report prints it after a value ("" for counts and ratios).
    pub fn unit(self) -> &'static str {
        match self {
            Self::SettleS | Self::SaturationS => "s",
            Self::SteadyErrorXDeg
            | Self::SteadyErrorYDeg
            | Self::SteadyErrorZDeg
            | Self::EstimateError3rmsXDeg
            | Self::EstimateError3rmsYDeg
            | Self::EstimateError3rmsZDeg => "°",
            Self::PeakWheelSpeedRpm => "rpm",
            _ => "",
        }
    }

    pub fn better(self) -> Better {
        match self {
            Self::Outside3SigmaFraction => Better::Near(OUTSIDE_3_SIGMA_IF_CONSISTENT),
            Self::NeesPerDof => Better::Near(1.0),
            _ => Better::Lower,
        }
    }

    /// What a run without a value means (the metric is undefined there).
    pub fn undefined_means(self) -> &'static str {
        match self {
            Self::SettleS => "never settled",
            Self::SteadyErrorXDeg | Self::SteadyErrorYDeg | Self::SteadyErrorZDeg => {
                "no ticks in the window"
            }
            Self::EstimateError3rmsXDeg
            | Self::EstimateError3rmsYDeg
            | Self::EstimateError3rmsZDeg
            | Self::Outside3SigmaFraction
            | Self::NeesPerDof => "no estimate after estimation_from_s",
            _ => "the run failed",
        }
    }

    /// Whether a run without a value failed at what the metric measures (never settled), so
    /// that a comparison counts those runs against their variant.
    pub fn undefined_is_failure(self) -> bool {
        self == Self::SettleS
    }

    /// One line for the documentation and the report.
    pub fn description(self) -> &'static str {
        match self {
            Self::SettleS => {
                "first time after which every axis of the true pointing error stays within the settling band"
            }
            Self::SteadyErrorXDeg => {
                "largest true pointing error about body X over the final window"
            }
            Self::SteadyErrorYDeg => {
                "largest true pointing error about body Y over the final window"
            }
            Self::SteadyErrorZDeg => {
                "largest true pointing error about body Z over the final window"
            }
            Self::PeakWheelSpeedRpm => "largest wheel speed (true, any wheel) over the run",
            Self::SaturationS => {
                "time the controller's command was saturated (torque or momentum limit)"
            }
            Self::EstimateError3rmsXDeg => {
                "3 × RMS of the attitude estimate's error about X, from estimation_from_s"
            }
            Self::EstimateError3rmsYDeg => {
                "3 × RMS of the attitude estimate's error about Y, from estimation_from_s"
            }
            Self::EstimateError3rmsZDeg => {
                "3 × RMS of the attitude estimate's error about Z, from estimation_from_s"
            }
            Self::Outside3SigmaFraction => {
                "fraction of (tick, axis) attitude errors outside the filter's own ±3σ (consistent: 0.0027)"
            }
            Self::NeesPerDof => {
                "mean NEES of [δθ, δb] over the run, per degree of freedom (consistent: 1)"
            }
            Self::SafeModeLimit => {
                "1 when a wheel's speed passed the controller's safe-mode limit (wheel_speed_fraction × max speed), where the real pipeline enters safe mode; the in-process loop has none and runs on"
            }
            Self::TiltStops => "times the platform hit its tilt stop",
            Self::GateRejections => "vector-update blocks the estimator's innovation gate rejected",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// The metrics of one run, in [`Metric::ALL`] order; `None` where undefined.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunMetrics(pub [Option<f64>; Metric::ALL.len()]);

impl RunMetrics {
    pub fn get(&self, metric: Metric) -> Option<f64> {
        self.0[metric as usize]
    }

    fn set(&mut self, metric: Metric, value: Option<f64>) {
        self.0[metric as usize] = value;
    }
}

/// Every `series_step_s` of a run: the true pointing error's magnitude, degrees, and the NEES
/// of `[δθ, δb]` (NaN before the estimator has an estimate). Sample `j` is at `j ·
/// series_step_s`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunSeries {
    pub pointing_error_deg: Vec<f64>,
    pub nees: Vec<f64>,
}

/// The metrics and series of a finished run of `config`.
pub fn evaluate(
    trace: &Trace,
    config: &RunConfig,
    options: &MetricOptions,
) -> (RunMetrics, RunSeries) {
    let mut m = RunMetrics::default();
    let ticks = &trace.ticks;
    m.set(
        Metric::SettleS,
        sim_metrics::settling_time_s(trace, options.settle_band_deg * DEG),
    );
    let end = ticks.last().map_or(0.0, |t| t.t_s);
    let in_window = ticks.iter().any(|t| t.t_s >= end - options.steady_window_s);
    let steady = sim_metrics::steady_error_deg(trace, options.steady_window_s);
    for (metric, value) in [
        Metric::SteadyErrorXDeg,
        Metric::SteadyErrorYDeg,
        Metric::SteadyErrorZDeg,
    ]
    .into_iter()
    .zip(steady)
    {
        m.set(metric, in_window.then_some(value));
    }

    let peak_rad_s = ticks
        .iter()
        .map(|t| t.truth.wheel_speed.amax())
        .fold(0.0, f64::max);
    m.set(Metric::PeakWheelSpeedRpm, Some(peak_rad_s / RPM));
    let saturated = ticks.iter().filter(|t| t.saturated).count();
    m.set(
        Metric::SaturationS,
        Some(saturated as f64 / config.model.gyro.rate_hz),
    );
    let limit_rad_s =
        config.controller.safe_mode.wheel_speed_fraction * config.model.wheels.max_speed_rad_s();
    m.set(
        Metric::SafeModeLimit,
        Some(f64::from(u8::from(peak_rad_s > limit_rad_s))),
    );
    m.set(Metric::TiltStops, Some(trace.tilt_stops.len() as f64));
    m.set(Metric::GateRejections, Some(trace.gate_rejections as f64));

    let (mut sq, mut outside, mut nees_sum, mut samples) = ([0.0; 3], 0usize, 0.0, 0usize);
    for e in ticks
        .iter()
        .filter(|t| t.t_s >= options.estimation_from_s)
        .filter_map(|t| t.estimate.as_ref())
    {
        for ((sum, error), sigma) in sq
            .iter_mut()
            .zip(e.attitude_error_rad.iter())
            .zip(e.attitude_sigma_rad.iter())
        {
            *sum += error * error;
            outside += usize::from(error.abs() > 3.0 * sigma);
        }
        nees_sum += e.nees;
        samples += 1;
    }
    let defined = |x: f64| (samples > 0).then_some(x);
    for (axis, metric) in [
        Metric::EstimateError3rmsXDeg,
        Metric::EstimateError3rmsYDeg,
        Metric::EstimateError3rmsZDeg,
    ]
    .into_iter()
    .enumerate()
    {
        m.set(
            metric,
            defined(3.0 * (sq[axis] / samples.max(1) as f64).sqrt() / DEG),
        );
    }
    m.set(
        Metric::Outside3SigmaFraction,
        defined(outside as f64 / (3 * samples.max(1)) as f64),
    );
    m.set(
        Metric::NeesPerDof,
        defined(nees_sum / (samples.max(1) * NEES_DOF) as f64),
    );

    let mut series = RunSeries::default();
    for tick in ticks {
        let next_t = series.nees.len() as f64 * options.series_step_s;
        // Within rounding of the tick clock (ticks are whole nanoseconds).
        if tick.t_s + 1e-9 >= next_t {
            series
                .pointing_error_deg
                .push(tick.pointing_error_rad.norm() / DEG);
            series
                .nees
                .push(tick.estimate.as_ref().map_or(f64::NAN, |e| e.nees));
        }
    }
    (m, series)
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_sim::closed_loop::{self, Scenario};

    #[test]
    fn names_are_unique_and_found_again() {
        for metric in Metric::ALL {
            assert_eq!(Metric::from_name(metric.name()), Some(metric));
            assert_eq!(Metric::ALL[metric as usize], metric);
        }
    }

    /// The paper's stabilisation (150 s, seed 1): settles, steady error within the paper's
    /// bounds, a consistent filter, wheels well below the safe-mode limit, one series sample
    /// a second.
    #[test]
    fn a_stabilisation_run_is_reduced_to_its_metrics_and_series() {
        let mut config = RunConfig::default();
        config.run.duration_s = 150.0;
        let trace = closed_loop::run(&Scenario::from_run(&config)).unwrap();
        let options = MetricOptions::default();
        let (m, series) = evaluate(&trace, &config, &options);
        let get = |metric| {
            m.get(metric)
                .unwrap_or_else(|| panic!("{metric:?} undefined"))
        };
        assert_eq!(
            m.get(Metric::SettleS),
            sim_metrics::settling_time_s(&trace, 0.1 * DEG)
        );
        assert!(get(Metric::SettleS) < 120.0);
        assert!(get(Metric::SteadyErrorXDeg) < 0.02 && get(Metric::SteadyErrorZDeg) < 0.05);
        let nees = get(Metric::NeesPerDof);
        assert!(nees > 0.2 && nees < 5.0, "NEES per dof {nees}");
        assert!(get(Metric::Outside3SigmaFraction) < 0.05);
        assert!(get(Metric::PeakWheelSpeedRpm) > 0.0 && get(Metric::PeakWheelSpeedRpm) < 4500.0);
        assert_eq!(get(Metric::SafeModeLimit), 0.0);
        assert_eq!(get(Metric::TiltStops), 0.0);
        assert_eq!(series.nees.len(), 151);
        assert_eq!(series.pointing_error_deg.len(), 151);
        let first = trace.ticks[0].pointing_error_rad.norm() / DEG;
        assert_eq!(series.pointing_error_deg[0], first);
        assert_eq!(
            series.pointing_error_deg[10],
            trace.ticks[100].pointing_error_rad.norm() / DEG
        );
        // The safe-mode limit counts a run whose wheels pass it.
        config.controller.safe_mode.wheel_speed_fraction = 1e-3;
        let (m, _) = evaluate(&trace, &config, &options);
        assert_eq!(m.get(Metric::SafeModeLimit), Some(1.0));
    }
}
