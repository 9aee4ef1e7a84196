//! What a run did, read back from its log: settling time, steady error per axis, peak wheel
//! speed, the estimator's error against the truth, deadline misses, and the series for a figure.
//!
//! Attitude error: the rotation vector (axis × angle, ≈ 2 q_v for small angles) that takes the
//! target attitude to the true one, body axes, degrees. Settling time: the first time after
//! which that error stays within [`SETTLE_BAND_DEG`] on every axis. Steady error: the largest
//! |error| per axis over the last [`STEADY_WINDOW_S`] of the run. The target is the one in
//! force ([`targets`]): the configured one until a ground command moved it.

mod targets;

use anyhow::Context;
use ipc_types::{
    AttitudeEstimate, CanLinkStatus, ControllerMode, ControllerStatus, GroundCommand,
    GroundCommandAck, HealthEvent, HealthEventKind, SimTruth, ThrusterStatus, WheelCommand,
    WheelTelemetry,
};
use nalgebra::Vector3;
use serde::Serialize;
use std::collections::HashMap;
use std::path::Path;
pub use targets::{TargetChange, TargetsInForce};
use testbed_config::RunConfig;
use testbed_flight::convert::{quaternion_from_array, seconds};
use testbed_log::RunLog;
use testbed_model::attitude;
use testbed_model::config::{DEG, RPM};
use testbed_sim::metrics;

/// Band that counts as settled, degrees per axis.
pub const SETTLE_BAND_DEG: f64 = 0.1;
/// Final window over which the steady error is taken, s.
pub const STEADY_WINDOW_S: f64 = 50.0;

/// The summary `testbed run` prints.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// First time after which the true attitude error (rotation vector from the target in
    /// force to the true attitude, body axes) stays within [`SETTLE_BAND_DEG`] on every axis,
    /// s; `None`: never settled.
    pub settle_s: Option<f64>,
    /// Targets the ground commanded and the controller applied, in time order (empty: the
    /// configured target held all run). Settling and steady error are measured against the
    /// target in force at each time.
    pub target_changes: Vec<TargetChange>,
    /// Largest |true attitude error| per axis over the final [`STEADY_WINDOW_S`] (the whole run
    /// if shorter), degrees: X/Y (the larger), Z, and per axis.
    pub steady_xy_deg: f64,
    pub steady_z_deg: f64,
    pub steady_deg: [f64; 3],
    /// Settling band, degrees per axis, and steady window, s (the definitions above).
    pub settle_band_deg: f64,
    pub steady_window_s: f64,
    /// Largest |wheel speed| per wheel over the run, rpm.
    pub peak_wheel_rpm: [f64; 3],
    /// The estimator's error against the truth, when the log has estimates.
    pub estimator: Option<EstimatorError>,
    /// Initial condition and controller of the run, from its configuration.
    pub initial_condition: String,
    pub controller: String,
    /// Missed control deadlines: the controller's count ([`ipc_types::ControllerStatus`]), the largest value logged.
    pub deadline_misses: u64,
    pub simulated_s: f64,
    /// The simulated duration asked for (`None`: the run ends with its source or on request).
    pub requested_s: Option<f64>,
    /// The run ended before the requested duration (Ctrl-C, `--max-wall`, a failed process).
    pub interrupted: bool,
    pub ticks: usize,
    pub estimates: usize,
    pub profile: String,
    pub mode: String,
    pub seed: u64,
    pub log: String,
    /// The log ends with its summary (false: the logger was killed, records are still all read).
    pub log_complete: bool,
    /// Where the attitude error comes from: `truth` (simulation), or `estimate` (no truth in
    /// the log, e.g. the real platform: the controller's error of the estimate against the
    /// target, so settling and steady error are as good as the estimate, see its 3σ).
    pub attitude_from: String,
    /// The filter's own attitude 3σ (3 √P_ii) of the final estimate, degrees, if any estimate.
    pub estimate_3sigma_deg: Option<[f64; 3]>,
    /// Faults and recoveries of the run.
    pub health: HealthSummary,
    /// What the thrusters did (runs with thrusters: the log's thruster status).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thrusters: Option<ThrusterSummary>,
}

/// The thrusters over a run, from the thruster drive's status samples.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ThrusterSummary {
    /// Periods in which at least one valve was open for some time.
    pub firing_periods: u64,
    /// Valve on-time applied per thruster over the run, s.
    pub on_time_s: [f64; 6],
    /// Commands the thruster drive refused (not finite, out of range, too short).
    pub refused: u64,
    /// The thrusters were disabled (a stuck-open valve shut the latch valve).
    pub disabled: bool,
    /// Propellant used over the run, kg.
    pub propellant_used_kg: f64,
    /// The centre of mass's resulting shift, m, body axes: a gravity torque on the bearing
    /// (`model.thrusters.tank_position_m`, `platform.mass_kg`, `effects.com_offset`).
    pub com_shift_m: [f64; 3],
}

/// The thruster summary of a log (`None`: no thruster status in it).
fn thruster_summary(
    log: &RunLog,
    path: &Path,
    config: &RunConfig,
) -> anyhow::Result<Option<ThrusterSummary>> {
    let mut summary: Option<ThrusterSummary> = None;
    for status in log.samples::<ThrusterStatus>()? {
        let status = status.with_context(|| format!("reading {}", path.display()))?;
        let s = summary.get_or_insert(ThrusterSummary {
            firing_periods: 0,
            on_time_s: [0.0; 6],
            refused: 0,
            disabled: false,
            propellant_used_kg: 0.0,
            com_shift_m: [0.0; 3],
        });
        s.firing_periods += u64::from(status.applied_on_time.iter().any(|t| *t > 0.0));
        for (total, t) in s.on_time_s.iter_mut().zip(status.applied_on_time) {
            *total += t;
        }
        s.refused = s.refused.max(status.refused);
        s.disabled |= status.disabled != 0;
        s.propellant_used_kg = s.propellant_used_kg.max(status.propellant_used);
    }
    if let (Some(s), Some(valves)) = (&mut summary, &config.model.thrusters) {
        let com = config
            .model
            .effects
            .com_offset
            .as_ref()
            .map_or_else(Vector3::zeros, |c| Vector3::from(c.r_m));
        s.com_shift_m = testbed_model::physics::thrusters::propellant_com_shift_m(
            &valves.tank_position_m.into(),
            s.propellant_used_kg,
            config.model.platform.mass_kg,
            &com,
        )
        .into();
    }
    Ok(summary)
}

/// What went wrong during a run, and what recovered: from the health events, the controller's
/// status and the CAN links' counters.
#[derive(Debug, Clone, Default, Serialize)]
pub struct HealthSummary {
    /// Every health event, in log order.
    pub events: Vec<HealthLine>,
    /// Times the controller entered safe mode, and control cycles it spent there.
    pub safe_mode_entries: usize,
    pub safe_mode_cycles: usize,
    /// Processes that ended while the run went on (killed, crashed), restarts, hangs.
    pub process_exits: usize,
    pub restarts: usize,
    pub hangs: usize,
    /// Input streams lost (a process's input silent for two periods).
    pub inputs_lost: usize,
    /// Times an actuator (plant or gateway) heard no command and applied zero.
    pub commands_zeroed: usize,
    /// The run was aborted because of a process (lockstep).
    pub aborted: bool,
    /// CAN frames decoded and rejected, summed over the links' final counters.
    pub can_frames_ok: u64,
    pub can_frames_bad: u64,
    /// Log segments written by a restarted logger, beside the log.
    pub segments: Vec<String>,
    /// Anything above happened (other than CAN counters): the run is marked.
    pub marked: bool,
}

/// One health event, readable.
#[derive(Debug, Clone, Serialize)]
pub struct HealthLine {
    /// Run time, s.
    pub t_s: f64,
    pub reporter: String,
    pub kind: String,
    pub subject: String,
    pub detail: u32,
    pub value: f64,
}

impl HealthLine {
    fn new(e: &HealthEvent) -> Self {
        Self {
            t_s: seconds(e.header.time_ns),
            reporter: e.reporter().to_owned(),
            kind: e.kind().unwrap_or_default().name().to_owned(),
            subject: e.subject().to_owned(),
            detail: e.detail,
            value: e.value,
        }
    }
}

/// The health of the run in `log` (and the segments beside `path`).
fn health(log: &RunLog, path: &Path) -> anyhow::Result<HealthSummary> {
    let mut h = HealthSummary::default();
    for event in log.samples::<HealthEvent>()? {
        let event = event.with_context(|| format!("reading {}", path.display()))?;
        match event.kind() {
            Some(HealthEventKind::SafeModeEntered) => h.safe_mode_entries += 1,
            Some(HealthEventKind::ProcessExited) => h.process_exits += 1,
            Some(HealthEventKind::ProcessRestarted) => h.restarts += 1,
            Some(HealthEventKind::ProcessHung) => h.hangs += 1,
            Some(HealthEventKind::InputLost) => h.inputs_lost += 1,
            Some(HealthEventKind::CommandsZeroed) => h.commands_zeroed += 1,
            Some(HealthEventKind::RunAborted) => h.aborted = true,
            _ => {}
        }
        h.events.push(HealthLine::new(&event));
    }
    for status in log.samples::<ControllerStatus>()? {
        let status = status.with_context(|| format!("reading {}", path.display()))?;
        if status.mode() == Some(ControllerMode::Safe) {
            h.safe_mode_cycles += 1;
        }
    }
    let mut links: HashMap<u32, CanLinkStatus> = HashMap::new();
    for status in log.samples::<CanLinkStatus>()? {
        let status = status.with_context(|| format!("reading {}", path.display()))?;
        links.insert(status.header.source_id, status);
    }
    h.can_frames_ok = links.values().map(|s| s.frames_ok).sum();
    h.can_frames_bad = links.values().map(|s| s.frames_bad).sum();
    h.segments = segments(path);
    h.marked = h.safe_mode_entries
        + h.process_exits
        + h.restarts
        + h.hangs
        + h.inputs_lost
        + h.commands_zeroed
        > 0
        || h.aborted
        || !h.segments.is_empty();
    Ok(h)
}

/// The segments a restarted logger wrote beside `path` (`<stem>.segment-<n>.<ext>`), in order.
pub fn segments(path: &Path) -> Vec<String> {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    let prefix = format!("{stem}.segment-");
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut found: Vec<(u32, String)> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|entry| {
            let name = entry.file_name().to_string_lossy().into_owned();
            let rest = name.strip_prefix(&prefix)?;
            let (n, ext) = rest.split_once('.').unwrap_or((rest, ""));
            let same_ext = path.extension().map_or(ext.is_empty(), |e| e == ext);
            Some((n.parse().ok()?, name)).filter(|_| same_ext)
        })
        .map(|(n, name)| (n, dir.join(name).display().to_string()))
        .collect();
    found.sort();
    found.into_iter().map(|(_, p)| p).collect()
}

/// The estimator's attitude error against the truth at the same time: the rotation vector from
/// the estimate to the true attitude, body axes, degrees.
#[derive(Debug, Clone, Serialize)]
pub struct EstimatorError {
    /// Estimates compared (those with a truth sample of the same time).
    pub compared: usize,
    pub rms_deg: [f64; 3],
    pub max_deg: [f64; 3],
    /// The filter's own 3σ of its attitude error (3 √P_ii), final estimate, degrees.
    pub final_3sigma_deg: [f64; 3],
}

/// Per-tick series of a run, for figures and comparisons.
#[derive(Debug, Clone, Default)]
pub struct RunSeries {
    pub t_s: Vec<f64>,
    /// True attitude error relative to the target (rotation vector, target to truth), degrees, body axes.
    pub error_deg: Vec<[f64; 3]>,
    pub rate_deg_s: Vec<[f64; 3]>,
    pub wheel_speed_rpm: Vec<[f64; 3]>,
    pub estimates: Vec<AttitudeEstimate>,
    /// Times of the estimates compared with the truth, s; their error (rotation vector,
    /// estimate to truth, body axes, degrees) and the filter's 3σ, degrees.
    pub estimate_t_s: Vec<f64>,
    pub estimate_error_deg: Vec<[f64; 3]>,
    pub estimate_3sigma_deg: Vec<[f64; 3]>,
    /// Wheel torque commands: times, s, and torques, mNm.
    pub command_t_s: Vec<f64>,
    pub wheel_torque_mnm: Vec<[f64; 3]>,
}

/// Read a run's log and summarise it; `requested_s`: the simulated duration the run was asked
/// for, if it ends by duration (a shorter log is marked interrupted).
pub fn summarise(
    path: &Path,
    requested_s: Option<f64>,
) -> anyhow::Result<(RunSummary, RunSeries, RunConfig)> {
    let log = RunLog::open(path).with_context(|| format!("opening the log {}", path.display()))?;
    let config = RunConfig::from_toml_str(
        log.config_toml(),
        &format!("{} (config.toml attachment)", path.display()),
    )?;
    let targets = targets_in_force(&log, path, &config)?;
    let mut series = RunSeries::default();
    let mut truth_at = HashMap::new();
    for truth in log.samples::<SimTruth>()? {
        let truth = truth.with_context(|| format!("reading {}", path.display()))?;
        let Some(q) = quaternion_from_array(&truth.quaternion) else {
            continue;
        };
        truth_at.insert(truth.header.time_ns, q);
        let error = attitude::attitude_error(&q, targets.at(truth.header.time_ns)) / DEG;
        series.t_s.push(seconds(truth.header.time_ns));
        series.error_deg.push([error.x, error.y, error.z]);
        series
            .rate_deg_s
            .push((Vector3::from(truth.rate) / DEG).into());
        series
            .wheel_speed_rpm
            .push((Vector3::from(truth.wheel_speed) / RPM).into());
    }
    for estimate in log.samples::<AttitudeEstimate>()? {
        let estimate = estimate.with_context(|| format!("reading {}", path.display()))?;
        if let (Some(q_true), Some(q_est)) = (
            truth_at.get(&estimate.header.time_ns),
            quaternion_from_array(&estimate.quaternion),
        ) {
            let e = attitude::attitude_error(q_true, &q_est) / DEG;
            let sigma3 = |i: usize| 3.0 * estimate.covariance[7 * i].max(0.0).sqrt() / DEG;
            series.estimate_t_s.push(seconds(estimate.header.time_ns));
            series.estimate_error_deg.push([e.x, e.y, e.z]);
            series
                .estimate_3sigma_deg
                .push([sigma3(0), sigma3(1), sigma3(2)]);
        }
        series.estimates.push(estimate);
    }
    for command in log.samples::<WheelCommand>()? {
        let command = command.with_context(|| format!("reading {}", path.display()))?;
        series.command_t_s.push(seconds(command.header.time_ns));
        series
            .wheel_torque_mnm
            .push((Vector3::from(command.torque) * 1e3).into());
    }
    let mut deadline_misses = 0;
    for status in log.samples::<ControllerStatus>()? {
        deadline_misses = deadline_misses.max(
            status
                .with_context(|| format!("reading {}", path.display()))?
                .deadline_misses,
        );
    }
    let attitude_from = if series.t_s.is_empty() {
        estimated_series(&log, path, &mut series)?;
        "estimate"
    } else {
        "truth"
    };
    anyhow::ensure!(
        !series.t_s.is_empty(),
        "{}: the log holds neither simulation truth nor controller status: nothing to summarise",
        path.display()
    );
    let estimate_3sigma_deg = series.estimates.last().map(|e| {
        let sigma3 = |i: usize| 3.0 * e.covariance[7 * i].max(0.0).sqrt() / DEG;
        [sigma3(0), sigma3(1), sigma3(2)]
    });
    let errors: Vec<(f64, [f64; 3])> = series
        .t_s
        .iter()
        .copied()
        .zip(series.error_deg.iter().copied())
        .collect();
    let abs_max = |values: &[[f64; 3]]| {
        values.iter().fold([0.0_f64; 3], |m, v| {
            [
                m[0].max(v[0].abs()),
                m[1].max(v[1].abs()),
                m[2].max(v[2].abs()),
            ]
        })
    };
    let estimator = (!series.estimate_error_deg.is_empty()).then(|| {
        let n = series.estimate_error_deg.len() as f64;
        let sum_sq = series.estimate_error_deg.iter().fold([0.0; 3], |s, e| {
            [s[0] + e[0] * e[0], s[1] + e[1] * e[1], s[2] + e[2] * e[2]]
        });
        EstimatorError {
            compared: series.estimate_error_deg.len(),
            rms_deg: sum_sq.map(|s| (s / n).sqrt()),
            max_deg: abs_max(&series.estimate_error_deg),
            final_3sigma_deg: *series.estimate_3sigma_deg.last().unwrap_or(&[0.0; 3]),
        }
    });
    let simulated_s = *series.t_s.last().unwrap_or(&0.0);
    // The plant's last tick is one period short of the duration at most.
    let period_s = series.t_s.windows(2).next().map_or(0.0, |w| w[1] - w[0]);
    let interrupted = requested_s.is_some_and(|d| simulated_s + 2.0 * period_s + 1e-6 < d);
    let steady_deg = metrics::steady_max(&errors, STEADY_WINDOW_S);
    let m = &config.manoeuvre;
    let summary = RunSummary {
        settle_s: metrics::settling_time(&errors, SETTLE_BAND_DEG),
        target_changes: targets.changes(),
        steady_xy_deg: steady_deg[0].max(steady_deg[1]),
        steady_z_deg: steady_deg[2],
        steady_deg,
        settle_band_deg: SETTLE_BAND_DEG,
        steady_window_s: STEADY_WINDOW_S,
        peak_wheel_rpm: abs_max(&series.wheel_speed_rpm),
        estimator,
        initial_condition: format!(
            "heading {}°, pitch {}°, roll {}°, rate {:?} °/s, wheels {:?} rpm; target heading {}°, pitch {}°, roll {}°",
            m.initial_heading_deg,
            m.initial_pitch_deg,
            m.initial_roll_deg,
            m.initial_rate_deg_s,
            m.initial_wheel_speed_rpm,
            m.target_heading_deg,
            m.target_pitch_deg,
            m.target_roll_deg
        ),
        controller: controller_description(&config),
        deadline_misses,
        simulated_s,
        requested_s,
        interrupted,
        ticks: series.t_s.len(),
        estimates: series.estimates.len(),
        profile: log.info().profile.clone(),
        mode: log.info().mode.clone(),
        seed: log.info().seed,
        log: path.display().to_string(),
        log_complete: log.is_complete(),
        attitude_from: attitude_from.to_owned(),
        estimate_3sigma_deg,
        health: health(&log, path)?,
        thrusters: thruster_summary(&log, path, &config)?,
    };
    Ok((summary, series, config))
}

/// The targets in force over the run in `log`: its configured target and the ground's
/// applied `target` commands.
fn targets_in_force(
    log: &RunLog,
    path: &Path,
    config: &RunConfig,
) -> anyhow::Result<TargetsInForce> {
    let read = || format!("reading {}", path.display());
    let commands = log
        .samples::<GroundCommand>()?
        .collect::<Result<Vec<_>, _>>()
        .with_context(read)?;
    let acks = log
        .samples::<GroundCommandAck>()?
        .collect::<Result<Vec<_>, _>>()
        .with_context(read)?;
    Ok(TargetsInForce::new(
        config.manoeuvre.target(),
        &commands,
        &acks,
    ))
}

/// Without truth (the real platform): the attitude error is the controller's (estimate against
/// target, cycles in safe mode left out: they compute none), the rate the estimate's, the
/// wheel speeds their telemetry's.
fn estimated_series(log: &RunLog, path: &Path, series: &mut RunSeries) -> anyhow::Result<()> {
    let rates: HashMap<u64, [f64; 3]> = series
        .estimates
        .iter()
        .map(|e| (e.header.time_ns, (Vector3::from(e.rate) / DEG).into()))
        .collect();
    let mut wheels: HashMap<u64, [f64; 3]> = HashMap::new();
    for t in log.samples::<WheelTelemetry>()? {
        let t = t.with_context(|| format!("reading {}", path.display()))?;
        wheels.insert(t.header.time_ns, (Vector3::from(t.speed) / RPM).into());
    }
    for status in log.samples::<ControllerStatus>()? {
        let status = status.with_context(|| format!("reading {}", path.display()))?;
        let computed = matches!(
            status.mode(),
            Some(ControllerMode::WheelPointing | ControllerMode::CmgSlew)
        );
        if !computed {
            continue;
        }
        let t_ns = status.header.time_ns;
        series.t_s.push(seconds(t_ns));
        series
            .error_deg
            .push((Vector3::from(status.attitude_error) / DEG).into());
        series
            .rate_deg_s
            .push(rates.get(&t_ns).copied().unwrap_or_default());
        series
            .wheel_speed_rpm
            .push(wheels.get(&t_ns).copied().unwrap_or_default());
    }
    Ok(())
}

/// The control law and its gains, in one line (the law's own description).
fn controller_description(config: &RunConfig) -> String {
    match config
        .controller
        .law(&config.model, config.manoeuvre.target())
    {
        Ok(law) => law.describe(),
        Err(e) => format!("{} (not built: {e})", config.controller.law),
    }
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
        let log =
            RunLog::open(path).with_context(|| format!("opening the log {}", path.display()))?;
        log.samples::<AttitudeEstimate>()?
            .map(|e| e.with_context(|| format!("reading {}", path.display())))
            .collect()
    };
    let (recorded, replayed) = (read(recorded)?, read(replayed)?);
    let identical = recorded
        .iter()
        .zip(&replayed)
        .filter(|(a, b)| a == b)
        .count();
    Ok(EstimateComparison {
        recorded: recorded.len(),
        replayed: replayed.len(),
        identical,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::{GroundAckStatus, GroundCommandKind, SampleHeader};
    use testbed_flight::convert::quaternion_to_array;
    use testbed_log::{RunInfo, RunLogWriter};

    fn at(t_ns: u64) -> SampleHeader {
        SampleHeader {
            time_ns: t_ns,
            ..SampleHeader::default()
        }
    }

    /// A platform that sits at heading 30° for 100 s; the ground moves the target there at
    /// 10 s. Against the configured target it never settles; against the target in force it
    /// settles when the command is applied.
    #[test]
    fn settling_is_measured_against_the_target_the_ground_commanded() {
        let dir = std::env::temp_dir().join(format!("summary-target-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("run.mcap");
        let heading_rad = 30.0 * DEG;
        let info = RunInfo {
            profile: "test".into(),
            mode: "lockstep".into(),
            ..RunInfo::default()
        };
        let mut log = RunLogWriter::create(&path, &info).unwrap();
        let command = GroundCommand {
            header: at(9_950_000_000),
            kind: GroundCommandKind::Target as u32,
            target_heading_rad: heading_rad,
            command_id: 4,
            client_id: 1,
            ..GroundCommand::default()
        };
        let ack = GroundCommandAck::new(
            at(10_000_000_000),
            4,
            GroundCommandKind::Target as u32,
            GroundAckStatus::Applied,
            1,
            GroundCommandAck::BY_CONTROLLER,
            "target set",
        );
        let q = quaternion_to_array(&attitude::from_heading_pitch_roll(heading_rad, 0.0, 0.0));
        for tick in 0..=1000_u64 {
            let t_ns = tick * 100_000_000;
            if t_ns == command.header.time_ns.next_multiple_of(100_000_000) {
                log.write(&command).unwrap();
                log.write(&ack).unwrap();
            }
            log.write(&SimTruth {
                header: at(t_ns),
                quaternion: q,
                ..SimTruth::default()
            })
            .unwrap();
        }
        log.finish().unwrap();

        let (summary, _, config) = summarise(&path, None).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let configured = attitude::attitude_error(
            &attitude::from_heading_pitch_roll(heading_rad, 0.0, 0.0),
            &config.manoeuvre.target(),
        );
        assert!(
            configured.norm() / DEG > 10.0,
            "the configured target must differ from the commanded one"
        );
        assert_eq!(
            summary.target_changes.len(),
            1,
            "{:?}",
            summary.target_changes
        );
        assert_eq!(summary.target_changes[0].t_s, 10.0);
        assert!((summary.target_changes[0].heading_deg - 30.0).abs() < 1e-12);
        assert_eq!(summary.settle_s, Some(10.0));
        assert!(
            summary.steady_deg.iter().all(|e| *e < 1e-9),
            "{:?}",
            summary.steady_deg
        );
    }
}
