//! Figures of merit of closed-loop runs, as the paper reports them.

use crate::closed_loop::Trace;
use testbed_flight::stats::chi_square_quantile;
use testbed_model::config::DEG;

/// First time after which every component of `error` stays within `band` to the end of the
/// series (`None` if it never does or ends outside). `samples` are `(t, error)` in time order,
/// in any consistent unit.
pub fn settling_time(samples: &[(f64, [f64; 3])], band: f64) -> Option<f64> {
    let last_outside = samples
        .iter()
        .rposition(|(_, e)| e.iter().any(|x| x.abs() > band));
    match last_outside {
        None => samples.first().map(|(t, _)| *t),
        Some(i) => samples.get(i + 1).map(|(t, _)| *t),
    }
}

/// Largest absolute value per component over the final `window_s` seconds of `samples`.
pub fn steady_max(samples: &[(f64, [f64; 3])], window_s: f64) -> [f64; 3] {
    let end = samples.last().map_or(0.0, |(t, _)| *t);
    let mut worst = [0.0_f64; 3];
    for (_, e) in samples.iter().filter(|(t, _)| *t >= end - window_s) {
        for (w, x) in worst.iter_mut().zip(e) {
            *w = w.max(x.abs());
        }
    }
    worst
}

/// True pointing error of a run in degrees, `(t, [x, y, z])`.
pub fn pointing_error_deg(trace: &Trace) -> Vec<(f64, [f64; 3])> {
    trace
        .ticks
        .iter()
        .map(|t| (t.t_s, (t.pointing_error_rad / DEG).into()))
        .collect()
}

/// Settling time of a run's true pointing error into `band_rad` per axis.
pub fn settling_time_s(trace: &Trace, band_rad: f64) -> Option<f64> {
    settling_time(&pointing_error_deg(trace), band_rad / DEG)
}

/// Largest absolute true pointing error per body axis over the final `window_s` seconds, degrees.
pub fn steady_error_deg(trace: &Trace, window_s: f64) -> [f64; 3] {
    steady_max(&pointing_error_deg(trace), window_s)
}

/// Estimation accuracy pooled over Monte Carlo runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimationStats {
    /// 3 × RMS of the true attitude estimation error per body axis, degrees.
    pub err3s_deg: [f64; 3],
    /// 3 × RMS of the filter's own 1σ per axis, degrees (what the filter believes).
    pub filter_3s_deg: [f64; 3],
    /// Mean NEES over runs and ticks (6 degrees of freedom).
    pub nees_mean: f64,
    pub nees_dof: usize,
    /// Two-sided 95 % interval of the run-averaged NEES for this many runs:
    /// `[χ²(2.5 %, 6N), χ²(97.5 %, 6N)] / N`.
    pub nees_interval: [f64; 2],
    /// Fraction of ticks whose run-averaged NEES lies inside that interval (≈ 0.95 if consistent).
    pub nees_fraction_inside: f64,
    pub runs: usize,
    pub samples: usize,
}

/// Pool the estimation errors of `traces` (equal-length runs) from `from_s` on.
pub fn estimation_stats(traces: &[Trace], from_s: f64) -> Option<EstimationStats> {
    let runs = traces.len();
    let dof = 6;
    let lo = chi_square_quantile(0.025, (dof * runs) as f64)? / runs as f64;
    let hi = chi_square_quantile(0.975, (dof * runs) as f64)? / runs as f64;
    let ticks = traces.iter().map(|t| t.ticks.len()).min()?;
    let (mut sq, mut var) = ([0.0; 3], [0.0; 3]);
    let (mut nees_sum, mut samples, mut inside, mut steps) = (0.0, 0usize, 0usize, 0usize);
    for k in 0..ticks {
        if traces[0].ticks[k].t_s < from_s {
            continue;
        }
        let mut step_nees = 0.0;
        for trace in traces {
            let e = trace.ticks[k].estimate.as_ref()?;
            for axis in 0..3 {
                sq[axis] += e.attitude_error_rad[axis].powi(2);
                var[axis] += e.attitude_sigma_rad[axis].powi(2);
            }
            step_nees += e.nees;
            samples += 1;
        }
        nees_sum += step_nees;
        let mean = step_nees / runs as f64;
        inside += usize::from(mean >= lo && mean <= hi);
        steps += 1;
    }
    if samples == 0 {
        return None;
    }
    let three_rms = |s: f64| 3.0 * (s / samples as f64).sqrt() / DEG;
    Some(EstimationStats {
        err3s_deg: sq.map(three_rms),
        filter_3s_deg: var.map(three_rms),
        nees_mean: nees_sum / samples as f64,
        nees_dof: dof,
        nees_interval: [lo, hi],
        nees_fraction_inside: inside as f64 / steps as f64,
        runs,
        samples,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::closed_loop::TickRecord;
    use nalgebra::Vector3;
    use testbed_model::physics::{ActuatorCommand, PlatformState};

    fn trace_of(errors_deg: &[f64]) -> Trace {
        let ticks = errors_deg
            .iter()
            .enumerate()
            .map(|(i, e)| TickRecord {
                t_s: i as f64,
                truth: PlatformState::default(),
                bias_true: Vector3::zeros(),
                estimate: None,
                pointing_error_rad: Vector3::new(e * DEG, 0.0, -0.5 * e * DEG),
                command: ActuatorCommand::default(),
                saturated: false,
                singularity_measure: None,
            })
            .collect();
        Trace {
            ticks,
            tilt_stops: vec![],
            gate_rejections: 0,
        }
    }

    #[test]
    fn settling_time_is_the_last_exit_from_the_band() {
        let trace = trace_of(&[5.0, 1.0, 0.05, 0.2, 0.05, 0.01, 0.0]);
        assert_eq!(settling_time_s(&trace, 0.1 * DEG), Some(4.0));
        assert_eq!(settling_time_s(&trace_of(&[0.0, 0.5]), 0.1 * DEG), None);
    }

    #[test]
    fn steady_error_is_the_worst_over_the_window() {
        let trace = trace_of(&[5.0, 1.0, 0.05, -0.2, 0.05]);
        let steady = steady_error_deg(&trace, 2.0);
        assert!((steady[0] - 0.2).abs() < 1e-12 && (steady[2] - 0.1).abs() < 1e-12);
    }
}
