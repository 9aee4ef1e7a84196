//! What `testbed run` says after the run: the summary, the figure's panels, a cut log repaired.

use crate::figure::{Panel, Series};
use crate::summary::{self, RunSeries, RunSummary};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

/// Repairs the log in place when it was cut (the logger died); says what it did on stderr.
pub(super) fn repair_if_cut(log: &Path) -> Option<testbed_log::RepairReport> {
    match testbed_log::RunLog::open(log) {
        Ok(opened) if !opened.is_complete() => {}
        _ => return None,
    }
    match crate::log::repair(log, log) {
        Ok(report) => {
            eprintln!(
                "note: the log was not finalised (its logger died); {}",
                crate::log::describe(log, &report)
            );
            Some(report)
        }
        Err(e) => {
            eprintln!(
                "warning: the log {} was not finalised and could not be repaired ({}); every complete record is still readable by a streaming reader; retry with `testbed log repair {}`",
                log.display(),
                crate::errors::report(&e),
                log.display()
            );
            None
        }
    }
}

/// For a replayed log that was cut: how much of it the replay covered.
pub(super) fn replay_cut_warning(source: &testbed_log::RunLog) -> Option<String> {
    let testbed_log::LogEnd::Truncated { offset, file_len } = source.end() else {
        return None;
    };
    let until_ns = source
        .records()
        .ok()?
        .flatten()
        .map(|r| r.header().time_ns)
        .max()
        .unwrap_or(0);
    Some(format!(
        "the replayed log {} was cut (not finalised: its logger died or the file was truncated): complete records end at byte {offset} of {file_len}; replayed its {} complete messages, up to t = {:.3} s of the recorded run; what came after was never recorded",
        source.path().display(),
        source.message_count(),
        until_ns as f64 * 1e-9
    ))
}

pub(super) fn print_summary(s: &RunSummary, figures: &[PathBuf]) {
    let settle = s
        .settle_s
        .map_or_else(|| "never".to_string(), |t| format!("{t:.1} s"));
    let xyz = |v: [f64; 3], digits: usize| {
        format!(
            "X {:.*}  Y {:.*}  Z {:.*}",
            digits, v[0], digits, v[1], digits, v[2]
        )
    };
    let status = if s.interrupted {
        "  INTERRUPTED: the run ended early; the numbers cover what was recorded"
    } else {
        ""
    };
    println!(
        "run: profile {}, {:.1} simulated s, {} ticks, mode {}, seed {}{status}",
        s.profile, s.simulated_s, s.ticks, s.mode, s.seed
    );
    println!("  initial condition    {}", s.initial_condition);
    println!("  controller           {}", s.controller);
    if s.attitude_from == "truth" {
        println!(
            "  attitude error = rotation vector from target to true attitude, body axes, degrees"
        );
    } else {
        println!(
            "  attitude error = the controller's error of the ESTIMATE against the target (no truth in this log), body axes, degrees"
        );
    }
    for change in &s.target_changes {
        println!(
            "  target changed       at {:.1} s by ground command: heading {:.2}°, pitch {:.2}°, roll {:.2}° (settling and steady error against the target in force)",
            change.t_s, change.heading_deg, change.pitch_deg, change.roll_deg
        );
    }
    println!(
        "  settling time        {settle}   (first time after which |error| stays within {}° on every axis)",
        summary::SETTLE_BAND_DEG
    );
    println!(
        "  steady error         {}   (max |error| per axis over the last {} s, deg)",
        xyz(s.steady_deg, 4),
        summary::STEADY_WINDOW_S
    );
    if s.simulated_s < summary::STEADY_WINDOW_S {
        println!(
            "  warning: the run is shorter ({:.1} s) than the steady window ({} s): the steady error covers the whole run, transient included",
            s.simulated_s,
            summary::STEADY_WINDOW_S
        );
    }
    println!(
        "  peak wheel speed     {}   (max |speed| per wheel, rpm)",
        xyz(s.peak_wheel_rpm, 0)
    );
    if let Some(e) = &s.estimator {
        println!(
            "  estimator error      RMS {}   max {}   (estimate vs truth, deg, {} estimates)",
            xyz(e.rms_deg, 4),
            xyz(e.max_deg, 4),
            e.compared
        );
        println!(
            "  estimator 3σ         {}   (the filter's own attitude 3σ at the end, deg)",
            xyz(e.final_3sigma_deg, 4)
        );
    }
    if let (None, Some(sigma)) = (&s.estimator, s.estimate_3sigma_deg) {
        println!(
            "  estimator 3σ         {}   (the filter's own attitude 3σ at the end, deg)",
            xyz(sigma, 4)
        );
    }
    if let Some(t) = &s.thrusters {
        let on = t.on_time_s.map(|x| format!("{x:.1}")).join(" ");
        let c = Vector3::from(t.com_shift_m) * 1e6;
        println!(
            "  thrusters            fired in {} periods, on-time [{on}] s per thruster, {} commands refused{}",
            t.firing_periods,
            t.refused,
            if t.disabled {
                ", DISABLED (stuck-open valve)"
            } else {
                ""
            }
        );
        println!(
            "  propellant used      {:.2} g; CoM shift ({:.3}, {:.3}, {:.3}) µm (body axes)",
            t.propellant_used_kg * 1e3,
            c.x,
            c.y,
            c.z
        );
    }
    println!("  deadline misses      {}", s.deadline_misses);
    print_health(&s.health);
    println!(
        "  log                  {}{}",
        s.log,
        if s.log_complete {
            ""
        } else {
            " (not finalised; all complete records read)"
        }
    );
    for f in figures {
        println!("  figure               {}", f.display());
    }
}

/// How many health events the summary lists (all are in the log and in `--json`).
const EVENTS_SHOWN: usize = 20;

fn print_health(h: &summary::HealthSummary) {
    if h.can_frames_ok + h.can_frames_bad > 0 {
        println!(
            "  CAN frames           {} decoded, {} rejected (all links)",
            h.can_frames_ok, h.can_frames_bad
        );
    }
    if !h.marked {
        println!(
            "  health               no fault: no safe mode, process exit, restart, hang, lost input or zeroed command"
        );
        return;
    }
    println!(
        "  HEALTH               safe mode entered {} times ({} cycles), process exits {}, restarts {}, hangs {}, inputs lost {}, commands zeroed {}{}",
        h.safe_mode_entries,
        h.safe_mode_cycles,
        h.process_exits,
        h.restarts,
        h.hangs,
        h.inputs_lost,
        h.commands_zeroed,
        if h.aborted { ", RUN ABORTED" } else { "" }
    );
    for e in h.events.iter().take(EVENTS_SHOWN) {
        println!(
            "    t = {:>8.1} s  {:<18} {:<28} by {}{}",
            e.t_s,
            e.kind,
            e.subject,
            e.reporter,
            match e.kind.as_str() {
                "safe mode entered" => format!(
                    " ({})",
                    testbed_flight::safe_mode::SafeReasons(e.detail).describe()
                ),
                "process exited" if e.detail > 128 => format!(" (signal {})", e.detail - 128),
                "process exited" => format!(" (exit status {})", e.detail),
                "input lost" | "process hung" => format!(" (silent {:.2} s)", e.value),
                _ => String::new(),
            }
        );
    }
    if h.events.len() > EVENTS_SHOWN {
        println!(
            "    … {} more events in the log (topic {}, or --json)",
            h.events.len() - EVENTS_SHOWN,
            ipc_types::topic::HEALTH
        );
    }
    for segment in &h.segments {
        println!("  log segment          {segment}   (written by the restarted logger)");
    }
}

pub(super) fn panels<'a>(series: &RunSeries, summary: &RunSummary) -> Vec<Panel<'a>> {
    let per_axis = |t: &[f64],
                    values: &[[f64; 3]],
                    labels: [&'a str; 3],
                    dashed: bool,
                    sign: f64|
     -> Vec<Series<'a>> {
        (0..3)
            .map(|axis| Series {
                label: labels[axis],
                points: t
                    .iter()
                    .zip(values)
                    .map(|(t, v)| (*t, sign * v[axis]))
                    .collect(),
                dashed,
            })
            .collect()
    };
    const XYZ: [&str; 3] = ["X", "Y", "Z"];
    let band = summary::SETTLE_BAND_DEG;
    let error = || per_axis(&series.t_s, &series.error_deg, XYZ, false, 1.0);
    let mut estimate_vs_truth = per_axis(
        &series.estimate_t_s,
        &series.estimate_error_deg,
        ["error X", "error Y", "error Z"],
        false,
        1.0,
    );
    estimate_vs_truth.extend(per_axis(
        &series.estimate_t_s,
        &series.estimate_3sigma_deg,
        ["±3σ X", "±3σ Y", "±3σ Z"],
        true,
        1.0,
    ));
    estimate_vs_truth.extend(per_axis(
        &series.estimate_t_s,
        &series.estimate_3sigma_deg,
        ["", "", ""],
        true,
        -1.0,
    ));
    // The filter's error after its start-up transient sets the scale: the first estimates
    // (initial covariance) would flatten everything else.
    let settled_estimates = series
        .estimate_t_s
        .iter()
        .zip(&series.estimate_3sigma_deg)
        .filter(|(t, _)| **t >= 10.0);
    let sigma_scale = settled_estimates
        .map(|(_, s)| s[0].max(s[1]).max(s[2]))
        .fold(0.0_f64, f64::max);
    let error_scale = series
        .estimate_t_s
        .iter()
        .zip(&series.estimate_error_deg)
        .filter(|(t, _)| **t >= 10.0)
        .map(|(_, e)| e[0].abs().max(e[1].abs()).max(e[2].abs()))
        .fold(0.0_f64, f64::max);
    let estimate_range = (sigma_scale.max(error_scale) > 0.0)
        .then(|| 1.3 * sigma_scale.max(error_scale))
        .map(|r| (-r, r));
    vec![
        Panel::new("attitude error (deg)", error()),
        Panel {
            band: Some(band),
            marker: summary.settle_s.map(|t| {
                (
                    t,
                    format!("settled at {t:.1} s (within ±{band}° from here on)"),
                )
            }),
            y_range: Some((-5.0 * band, 5.0 * band)),
            ..Panel::new("error, zoom; ±0.1° band (deg)", error())
        },
        Panel {
            y_range: estimate_range,
            ..Panel::new("estimate error, ±3σ (deg)", estimate_vs_truth)
        },
        Panel::new(
            "wheel torque cmd (mNm)",
            per_axis(
                &series.command_t_s,
                &series.wheel_torque_mnm,
                XYZ,
                false,
                1.0,
            ),
        ),
        Panel::new(
            "wheel speed (rpm)",
            per_axis(&series.t_s, &series.wheel_speed_rpm, XYZ, false, 1.0),
        ),
        Panel::new(
            "body rate (deg/s)",
            per_axis(&series.t_s, &series.rate_deg_s, XYZ, false, 1.0),
        ),
    ]
}
