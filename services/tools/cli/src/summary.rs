//! What a run did, read back from its log: settling time, steady error per axis, deadline
//! misses, and the series for a figure.

use testbed_flight::convert::{quaternion_from_array, seconds};
use testbed_runtime::run_config::RunConfig;
use anyhow::Context;
use ipc_types::{AttitudeEstimate, ControllerStatus, SimTruth};
use nalgebra::Vector3;
use serde::Serialize;
use std::path::Path;
use testbed_sim::metrics;
use testbed_log::RunLog;
use testbed_model::attitude;
use testbed_model::config::{DEG, RPM};

/// Band that counts as settled, degrees per axis.
pub const SETTLE_BAND_DEG: f64 = 0.1;
/// Final window over which the steady error is taken, s.
pub const STEADY_WINDOW_S: f64 = 50.0;

/// The summary `testbed run` prints.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// Time after which every axis of the true error stays within [`SETTLE_BAND_DEG`], s.
    pub settle_s: Option<f64>,
    /// Largest true error over the final [`STEADY_WINDOW_S`], X/Y (the larger) and Z, degrees.
    pub steady_xy_deg: f64,
    pub steady_z_deg: f64,
    pub steady_deg: [f64; 3],
    /// Missed control deadlines: the controller's count ([`ipc_types::ControllerStatus`]), the largest value logged.
    pub deadline_misses: u64,
    pub simulated_s: f64,
    pub ticks: usize,
    pub estimates: usize,
    pub mode: String,
    pub seed: u64,
    pub log: String,
    /// The log ends with its summary (false: the logger was killed, records are still all read).
    pub log_complete: bool,
}

/// Per-tick series of a run, for figures and comparisons.
#[derive(Debug, Clone, Default)]
pub struct RunSeries {
    pub t_s: Vec<f64>,
    /// True attitude error relative to the target, degrees, body axes.
    pub error_deg: Vec<[f64; 3]>,
    pub rate_deg_s: Vec<[f64; 3]>,
    pub wheel_speed_rpm: Vec<[f64; 3]>,
    pub estimates: Vec<AttitudeEstimate>,
}

/// Read a run's log and summarise it.
pub fn summarise(path: &Path) -> anyhow::Result<(RunSummary, RunSeries, RunConfig)> {
    let log = RunLog::open(path).with_context(|| format!("opening the log {}", path.display()))?;
    let config = RunConfig::from_toml_str(log.config_toml(), &format!("{} (config.toml attachment)", path.display()))?;
    let target = config.manoeuvre.target();
    let mut series = RunSeries::default();
    for truth in log.samples::<SimTruth>()? {
        let truth = truth.with_context(|| format!("reading {}", path.display()))?;
        let Some(q) = quaternion_from_array(&truth.quaternion) else { continue };
        let error = attitude::attitude_error(&q, &target) / DEG;
        series.t_s.push(seconds(truth.header.time_ns));
        series.error_deg.push([error.x, error.y, error.z]);
        series.rate_deg_s.push((Vector3::from(truth.rate) / DEG).into());
        series.wheel_speed_rpm.push((Vector3::from(truth.wheel_speed) / RPM).into());
    }
    for estimate in log.samples::<AttitudeEstimate>()? {
        series.estimates.push(estimate.with_context(|| format!("reading {}", path.display()))?);
    }
    let mut deadline_misses = 0;
    for status in log.samples::<ControllerStatus>()? {
        deadline_misses = deadline_misses.max(status.with_context(|| format!("reading {}", path.display()))?.deadline_misses);
    }
    anyhow::ensure!(!series.t_s.is_empty(), "{}: the log holds no simulation truth", path.display());
    let errors: Vec<(f64, [f64; 3])> = series.t_s.iter().copied().zip(series.error_deg.iter().copied()).collect();
    let summary = RunSummary {
        settle_s: metrics::settling_time(&errors, SETTLE_BAND_DEG),
        steady_deg: metrics::steady_max(&errors, STEADY_WINDOW_S),
        steady_xy_deg: 0.0,
        steady_z_deg: 0.0,
        deadline_misses,
        simulated_s: *series.t_s.last().unwrap_or(&0.0),
        ticks: series.t_s.len(),
        estimates: series.estimates.len(),
        mode: log.info().mode.clone(),
        seed: log.info().seed,
        log: path.display().to_string(),
        log_complete: log.is_complete(),
    };
    let summary = RunSummary { steady_xy_deg: summary.steady_deg[0].max(summary.steady_deg[1]), steady_z_deg: summary.steady_deg[2], ..summary };
    Ok((summary, series, config))
}

/// A replayed run's estimates against the recorded run's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct EstimateComparison {
    /// Estimates in the recorded log.
    pub recorded: usize,
    /// Estimates in the replay's log.
    pub replayed: usize,
    /// Replayed estimates equal, field for field, to the recorded one of the same position.
    pub identical: usize,
}

/// Compares the estimates of `replayed` with those of `recorded`, in order.
pub fn compare_estimates(recorded: &Path, replayed: &Path) -> anyhow::Result<EstimateComparison> {
    let read = |path: &Path| -> anyhow::Result<Vec<AttitudeEstimate>> {
        let log = RunLog::open(path).with_context(|| format!("opening the log {}", path.display()))?;
        log.samples::<AttitudeEstimate>()?
            .map(|e| e.with_context(|| format!("reading {}", path.display())))
            .collect()
    };
    let (recorded, replayed) = (read(recorded)?, read(replayed)?);
    let identical = recorded.iter().zip(&replayed).filter(|(a, b)| a == b).count();
    Ok(EstimateComparison { recorded: recorded.len(), replayed: replayed.len(), identical })
}
