//! Multi-step predictions of the measurements: the model's plant (`testbed_model::physics`)
//! started from the estimated state at the beginning of each window and driven open-loop by the
//! recorded actuator commands, its state turned into noise-free readings by the model's sensor
//! effects. Re-initialising every window keeps the predictions from drifting without bound.
//!
//! Start of a window at tick k: attitude and bias from the filter; body rate from the total
//! angular momentum averaged over ±2 s (`w = I⁻¹ (H̄ − J n_k − h_cmg)`, `H̄` the mean of
//! `I ŵ + J n + h_cmg`), which is smooth and so averages the gyro noise down without lag; wheel
//! speeds from the tachometers (within 3σ of zero: stopped); gimbals from the encoders. The
//! actuator delay of the model is applied here (the plant is built without it), so commands
//! issued before the window act in it.
//!
//! Thrusters (data with `thrusters.csv` and a model with `[thrusters]`): the recorded valve
//! on-times are issued to the plant's valves at their times (not delayed: the actuator delay is
//! the wheel and CMG drives'), without the pulse noise (unknown); the propellant used before the
//! window (from [`ThrusterHistory`]) is taken out of the tank and its weight moment
//! `−m_u g r_t` put into the window's centre-of-mass offset, so the plant starts each window
//! with the centre of mass where the draining tank has moved it. A thruster command inside a
//! tick interval split by the actuator delay is clamped to the piece it starts (a limitation of
//! the plant's one-period command; no delay: no split).

use crate::data::{Aligned, interpolate};
use crate::error::IdentError;
use crate::reconstruct::{Reconstruction, SensorModel};
use crate::thrusters::ThrusterHistory;
use nalgebra::{Matrix3, Vector3, Vector4};
use rayon::prelude::*;
use serde::Serialize;
use testbed_model::ModelConfig;
use testbed_model::attitude::{self, Attitude};
use testbed_model::config::ComOffset;
use testbed_model::config::{DEG, GAUSS};
use testbed_model::physics::{ActuatorCommand, CmgPyramid, Plant, PlatformState, ThrusterCommand};

/// The predicted measurement components, in this order.
pub const COMPONENTS: [&str; 11] = [
    "gyro_x", "gyro_y", "gyro_z", "tilt_x", "tilt_y", "field_x", "field_y", "field_z", "wheel_x",
    "wheel_y", "wheel_z",
];

/// Unit of each component.
pub const UNITS: [&str; 11] = [
    "rad/s", "rad/s", "rad/s", "rad", "rad", "T", "T", "T", "rad/s", "rad/s", "rad/s",
];

/// Channel group of each component (rates, tilt, field, wheel speeds).
pub fn group(component: usize) -> &'static str {
    match component {
        0..3 => "rates",
        3..5 => "tilt",
        5..8 => "field",
        _ => "wheel speeds",
    }
}

/// Prediction residuals (measured − predicted).
#[derive(Debug, Clone, Default)]
pub struct Predictions {
    /// Per component: `(t s, residual, window index)`.
    pub residuals: [Vec<(f64, f64, usize)>; 11],
    /// The windows predicted `(first tick, last tick)`; skipped windows are left out.
    pub windows: Vec<(usize, usize)>,
    /// 1σ measurement noise of each component (the model's), for normalisation.
    pub sigma: [f64; 11],
}

/// One window's residuals, per component `(t s, residual)`.
type WindowResiduals = [Vec<(f64, f64)>; 11];

/// RMS of the residuals of one component, normalised RMS, count.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ComponentRms {
    pub rms: f64,
    pub normalised: f64,
    pub n: usize,
}

impl Predictions {
    /// RMS per component over the samples `keep` accepts (by window index).
    pub fn rms(&self, keep: impl Fn(usize) -> bool) -> [Option<ComponentRms>; 11] {
        std::array::from_fn(|c| {
            let xs: Vec<f64> = self.residuals[c]
                .iter()
                .filter(|(_, _, w)| keep(*w))
                .map(|(_, r, _)| *r)
                .collect();
            (!xs.is_empty()).then(|| {
                let rms = (xs.iter().map(|x| x * x).sum::<f64>() / xs.len() as f64).sqrt();
                ComponentRms {
                    rms,
                    normalised: rms / self.sigma[c],
                    n: xs.len(),
                }
            })
        })
    }

    /// Overall prediction error: the root mean square over the components present of their
    /// normalised RMS (dimensionless; 1 = every component at its sensor's noise).
    pub fn overall(rms: &[Option<ComponentRms>; 11]) -> f64 {
        let present: Vec<f64> = rms.iter().flatten().map(|r| r.normalised).collect();
        if present.is_empty() {
            f64::NAN
        } else {
            (present.iter().map(|x| x * x).sum::<f64>() / present.len() as f64).sqrt()
        }
    }

    /// The predictions of disjoint sets of windows (e.g. the folds of a cross-validation, each
    /// by its own model) as one, windows in time order. The parts share the noise model (the
    /// first part's `sigma` is kept).
    pub fn merge(parts: Vec<Predictions>) -> Predictions {
        let mut out = Predictions {
            sigma: parts.first().map_or([0.0; 11], |p| p.sigma),
            ..Predictions::default()
        };
        // (window, part, index in the part), sorted by the window's ticks.
        let mut order: Vec<((usize, usize), usize, usize)> = parts
            .iter()
            .enumerate()
            .flat_map(|(p, part)| {
                part.windows
                    .iter()
                    .enumerate()
                    .map(move |(i, w)| (*w, p, i))
            })
            .collect();
        order.sort_unstable();
        let mut index: Vec<Vec<usize>> = parts.iter().map(|p| vec![0; p.windows.len()]).collect();
        for (new, (w, p, i)) in order.iter().enumerate() {
            index[*p][*i] = new;
            out.windows.push(*w);
        }
        for c in 0..11 {
            let mut r: Vec<(f64, f64, usize)> = parts
                .iter()
                .enumerate()
                .flat_map(|(p, part)| {
                    let index = &index[p];
                    part.residuals[c]
                        .iter()
                        .map(move |&(t, v, w)| (t, v, index[w]))
                })
                .collect();
            r.sort_by(|a, b| a.2.cmp(&b.2).then(a.0.total_cmp(&b.0)));
            out.residuals[c] = r;
        }
        out
    }

    /// Normalised RMS of every component in each window (for figures): per component
    /// `(window start time, normalised RMS)`.
    pub fn per_window(&self, data: &Aligned) -> [Vec<(f64, f64)>; 11] {
        std::array::from_fn(|c| {
            let mut out = Vec::new();
            let mut i = 0;
            let r = &self.residuals[c];
            while i < r.len() {
                let w = r[i].2;
                let mut sum = 0.0;
                let mut n = 0;
                while i < r.len() && r[i].2 == w {
                    sum += r[i].1 * r[i].1;
                    n += 1;
                    i += 1;
                }
                let t = self.windows.get(w).map_or(0.0, |(a, _)| data.t[*a]);
                out.push((t, (sum / n as f64).sqrt() / self.sigma[c]));
            }
            out
        })
    }
}

/// Windows of `horizon_s` tiling the ticks `[a, b)` of each given span, none across a silence
/// of the wheel telemetry ([`Aligned::without_wheel_silences`]).
pub fn windows(data: &Aligned, spans: &[(usize, usize)], horizon_s: f64) -> Vec<(usize, usize)> {
    let per = ((horizon_s / data.period_s).round() as usize).max(2);
    let mut out = Vec::new();
    let pieces = spans
        .iter()
        .flat_map(|&(a, b)| data.without_wheel_silences(a, b));
    for (a, b) in pieces {
        let mut k = a;
        while k + 1 < b {
            let end = (k + per).min(b - 1);
            if end > k + per / 2 {
                out.push((k, end));
            }
            k += per;
        }
    }
    out
}

/// Predict the measurements over `windows` with `config` (its plant, effects and sensor model),
/// starting each from the estimated state `recon` (which should be the reconstruction with
/// `config`'s sensor model).
pub fn predict(
    data: &Aligned,
    recon: &Reconstruction,
    config: &ModelConfig,
    windows: &[(usize, usize)],
) -> Result<Predictions, IdentError> {
    config.validate()?;
    let sensors = SensorModel::from_config(config);
    let delay = config
        .effects
        .actuator_delay
        .as_ref()
        .map_or(0.0, |d| d.delay_s);
    let mut plant_config = config.clone();
    plant_config.effects.actuator_delay = None;
    if let Some(t) = plant_config.thrusters.as_mut() {
        t.thrust_noise_fraction = 0.0;
    }
    let thrusters = ThrusterHistory::new(data, config);
    let inertia = config.true_inertia().unwrap_or_else(Matrix3::identity);
    let inertia_inv = inertia.try_inverse().unwrap_or_else(Matrix3::identity);
    let j = if data.has_wheels() {
        config.wheels.inertia_kgm2
    } else {
        0.0
    };
    let cmg = CmgPyramid::from_config(&config.cmg);
    let rotor = |k: usize| {
        data.wheel_speed_at(k) * j
            + if data.gimbal.is_some() {
                cmg.momentum(&data.gimbal_at(k))
            } else {
                Vector3::zeros()
            }
    };
    let tach = config.wheels.speed_noise_rad_s();
    let tilt_range = config.inclinometer.range_deg * DEG - 1e-9;
    let gyro_sigma = config.gyro.noise_density_rad_sqrt_s() / data.period_s.sqrt();
    let incl = config.inclinometer.noise_rad();
    let mag = config.magnetometer.noise_t();
    let mut out = Predictions {
        sigma: [
            gyro_sigma.x,
            gyro_sigma.y,
            gyro_sigma.z,
            incl[0],
            incl[1],
            mag.x,
            mag.y,
            mag.z,
            tach.max(1e-12),
            tach.max(1e-12),
            tach.max(1e-12),
        ],
        ..Predictions::default()
    };
    let average = ((2.0 / data.period_s).round() as usize).max(1);
    // Each window on its own (across the cores), then gathered in window order.
    let window = |k0: usize, k1: usize| -> Option<WindowResiduals> {
        // A window lies within one span of estimates: none crosses a break in the record.
        let span = recon.span_of(k0).filter(|s| k1 < s.end)?;
        // Initial rate from the averaged total momentum, over ticks whose wheel speeds were
        // measured (not interpolated over a silence).
        let reach = average.min(k0 - span.start).min(span.end - 1 - k0);
        let (a, b) = (data
            .without_wheel_silences(k0 - reach, k0 + reach + 1)
            .into_iter())
        .find(|&(a, b)| a <= k0 && k0 < b)?;
        let half = (k0 - a).min(b - 1 - k0);
        let mut h_mean = Vector3::zeros();
        for k in k0 - half..=k0 + half {
            h_mean += inertia * recon.rate[k] + rotor(k);
        }
        h_mean /= (2 * half + 1) as f64;
        let rate = inertia_inv * (h_mean - rotor(k0));
        let wheel_speed = data
            .wheel_speed_at(k0)
            .map(|n| if n.abs() < 3.0 * tach { 0.0 } else { n });
        let q0 = onto_stop(&recon.q[k0], config.platform.tilt_limit_rad());
        let state = PlatformState {
            q: q0,
            rate_b: rate,
            wheel_speed,
            gimbal: data.gimbal_at(k0),
        };
        let mut window_config = match &thrusters {
            Some(th) => propellant_used_before(&plant_config, th.used_kg(k0)),
            None => plant_config.clone(),
        };
        // A fitted (wheel) torque's time runs from the record's start; the window's plant starts
        // at 0.
        if let Some(fitted) = window_config.effects.fitted_torque.as_mut() {
            fitted.start_time_s += data.t[k0] - data.t[0];
        }
        if let Some(fitted) = window_config.effects.fitted_wheel_torque.as_mut() {
            fitted.start_time_s += data.t[k0] - data.t[0];
        }
        let mut plant = Plant::new(&window_config, state).ok()?;
        let bias = recon.bias[k0];
        let mut residuals: WindowResiduals = Default::default();
        let mut attitudes: Vec<Attitude> = Vec::with_capacity(k1 - k0 + 1);
        let mut rates: Vec<Vector3<f64>> = Vec::with_capacity(k1 - k0 + 1);
        // A window whose plant refuses a command or a step is left out.
        for k in k0..=k1 {
            let s = plant.state();
            attitudes.push(s.q);
            rates.push(s.rate_b);
            if let Some(speeds) = &data.wheel_speed {
                for c in 0..3 {
                    residuals[8 + c].push((data.t[k], speeds[k][c] - s.wheel_speed[c]));
                }
            }
            if k == k1 {
                break;
            }
            // Step to the next tick, splitting where the (delayed) commands change.
            for (dt, command, thrust) in command_pieces(data, data.t[k], data.t[k + 1], delay) {
                if let Some(thrust) = thrust {
                    plant.command_thrusters(&thrust).ok()?;
                }
                plant.step(&command, dt).ok()?;
            }
        }
        // A delayed gyro reads the rate of `gyro_delay_s` before (the window's first before it).
        let times = &data.t[k0..=k1];
        for (i, k) in (k0..=k1).enumerate() {
            let rate = if sensors.gyro_delay_s == 0.0 {
                rates[i]
            } else {
                interpolate(times, &rates, data.t[k] - sensors.gyro_delay_s)
            };
            let gyro = sensors.gyro_reading(&rate, &attitudes[i], &bias)
                + sensors.gyro_drift_since_start(data, k);
            for c in 0..3 {
                residuals[c].push((data.t[k], data.gyro[k][c] - gyro[c]));
            }
        }
        // Vector samples inside the window, at the nearest tick.
        let (ta, tb) = (data.t[k0], data.t[k1]);
        let nearest = |t: f64| -> Option<usize> {
            let i = data.t.partition_point(|x| *x < t);
            let cands = [i.checked_sub(1), Some(i)];
            cands
                .into_iter()
                .flatten()
                .filter(|&k| k >= k0 && k <= k1)
                .min_by(|a, b| (data.t[*a] - t).abs().total_cmp(&(data.t[*b] - t).abs()))
                .filter(|&k| (data.t[k] - t).abs() <= 0.5 * data.period_s)
        };
        for &(t, tilt) in data
            .tilt
            .iter()
            .filter(|(t, _)| *t >= ta - 1e-9 && *t <= tb + 1e-9)
        {
            if tilt[0].abs() >= tilt_range || tilt[1].abs() >= tilt_range {
                continue;
            }
            if let Some(k) = nearest(t) {
                let predicted = sensors.tilt_reading(&attitudes[k - k0], &rates[k - k0]);
                for c in 0..2 {
                    residuals[3 + c].push((t, tilt[c] - predicted[c]));
                }
            }
        }
        let field_range = config.magnetometer.range_gauss * GAUSS;
        for &(t, field) in data
            .field
            .iter()
            .filter(|(t, _)| *t >= ta - 1e-9 && *t <= tb + 1e-9)
        {
            if field.iter().any(|x| x.abs() >= field_range) {
                continue;
            }
            if let Some(k) = nearest(t) {
                let predicted = sensors.field_reading(&attitudes[k - k0], &rates[k - k0]);
                for c in 0..3 {
                    residuals[5 + c].push((t, field[c] - predicted[c]));
                }
            }
        }
        Some(residuals)
    };
    let per_window: Vec<Option<WindowResiduals>> =
        windows.par_iter().map(|&(k0, k1)| window(k0, k1)).collect();
    for (&(k0, k1), residuals) in windows.iter().zip(per_window) {
        let Some(residuals) = residuals else {
            continue;
        };
        let index = out.windows.len();
        for (all, own) in out.residuals.iter_mut().zip(residuals) {
            all.extend(own.into_iter().map(|(t, r)| (t, r, index)));
        }
        out.windows.push((k0, k1));
    }
    // Keep each component's samples in time order (vector samples were added per window).
    for r in out.residuals.iter_mut() {
        r.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    Ok(out)
}

/// An estimated attitude a little beyond the tilt stop (resting on it, within the estimate's
/// error) put back onto the stop by the smallest rotation; further beyond it is left as it is
/// (and the plant refuses the window).
fn onto_stop(q: &Attitude, limit_rad: f64) -> Attitude {
    let g = attitude::gravity_b(q);
    let s = limit_rad.sin();
    let beyond = g.x.abs().max(g.y.abs()) - s;
    if beyond <= 0.0 || beyond > 0.05 {
        return *q;
    }
    let (x, y) = (g.x.clamp(-s, s), g.y.clamp(-s, s));
    let z = -(1.0 - x * x - y * y).max(0.0).sqrt();
    let target = Vector3::new(x, y, z);
    nalgebra::UnitQuaternion::rotation_between(&g, &target).map_or(*q, |r| r * q)
}

/// Times of a time-ordered series strictly inside `(a, b)`.
fn times_inside<T>(series: &[(f64, T)], a: f64, b: f64) -> impl Iterator<Item = f64> + '_ {
    let lo = series.partition_point(|(t, _)| *t <= a + 1e-9);
    let hi = series.partition_point(|(t, _)| *t < b - 1e-9).max(lo);
    series[lo..hi].iter().map(|(t, _)| *t)
}

/// `config` for a window that starts when `used_kg` of propellant has been used: the tank holds
/// that much less, and the weight moment of the propellant gone, `−m_u g r_t`, is part of the
/// centre-of-mass offset (`Δr = −m_u r_t / M`), as the plant would have it after drawing it.
fn propellant_used_before(config: &ModelConfig, used_kg: f64) -> ModelConfig {
    let mut out = config.clone();
    let Some(t) = out.thrusters.as_mut() else {
        return out;
    };
    if used_kg <= 0.0 {
        return out;
    }
    let used = used_kg.min(t.propellant_kg);
    t.propellant_kg -= used;
    let shift = Vector3::from(t.tank_position_m) * (-used / config.platform.mass_kg);
    let r = out
        .effects
        .com_offset
        .as_ref()
        .map_or_else(Vector3::zeros, |c| Vector3::from(c.r_m));
    out.effects.com_offset = Some(ComOffset {
        r_m: (r + shift).into(),
    });
    out
}

/// The commands acting over `[a, b]` after a delay, as `(duration, command, thruster command
/// issued at the piece's start)` pieces (thruster commands are not delayed).
fn command_pieces(
    data: &Aligned,
    a: f64,
    b: f64,
    delay: f64,
) -> Vec<(f64, ActuatorCommand, Option<ThrusterCommand>)> {
    let (sa, sb) = (a - delay, b - delay);
    // Thruster commands in the delayed frame of the pieces: real time − delay.
    let thrust_times = times_inside(&data.thruster_cmd, a, b).map(|t| t - delay);
    let mut cuts: Vec<f64> = times_inside(&data.wheel_cmd, sa, sb)
        .chain(times_inside(&data.gimbal_cmd, sa, sb))
        .chain(thrust_times)
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let mut out = Vec::with_capacity(cuts.len() + 1);
    let mut start = sa;
    for end in cuts.into_iter().chain(std::iter::once(sb)) {
        let mid = start + 1e-9;
        let command = ActuatorCommand {
            wheel_torque_nm: data.wheel_cmd_at(mid),
            gimbal_rate_rad_s: if data.gimbal_cmd.is_empty() {
                Vector4::zeros()
            } else {
                data.gimbal_cmd_at(mid)
            },
        };
        if end - start > 1e-9 {
            out.push((
                end - start,
                command,
                thruster_command_at(data, start + delay),
            ));
        }
        start = end;
    }
    out
}

/// The thruster command issued at `t` (s from the record's start), if one is.
fn thruster_command_at(data: &Aligned, t: f64) -> Option<ThrusterCommand> {
    let i = data.thruster_cmd.partition_point(|(ti, _)| *ti < t - 1e-9);
    data.thruster_cmd
        .get(i)
        .filter(|(ti, _)| (ti - t).abs() <= 1e-9)
        .map(|(_, on)| ThrusterCommand { on_time_s: *on })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merged_folds_keep_every_residual_in_time_order_of_their_windows() {
        let part = |windows: Vec<(usize, usize)>, ts: &[(f64, usize)]| {
            let mut p = Predictions {
                windows,
                sigma: [2.0; 11],
                ..Predictions::default()
            };
            p.residuals[0] = ts.iter().map(|&(t, w)| (t, t * 10.0, w)).collect();
            p
        };
        // Fold A predicts windows at ticks 0 and 20, fold B the one at 10.
        let a = part(vec![(0, 9), (20, 29)], &[(0.0, 0), (0.5, 0), (2.0, 1)]);
        let b = part(vec![(10, 19)], &[(1.0, 0), (1.5, 0)]);
        let m = Predictions::merge(vec![a, b]);
        assert_eq!(m.windows, vec![(0, 9), (10, 19), (20, 29)]);
        let t: Vec<(f64, usize)> = m.residuals[0].iter().map(|r| (r.0, r.2)).collect();
        assert_eq!(t, vec![(0.0, 0), (0.5, 0), (1.0, 1), (1.5, 1), (2.0, 2)]);
        assert!(m.residuals[0].iter().all(|r| r.1 == r.0 * 10.0));
        assert_eq!(m.sigma, [2.0; 11]);
        assert!(m.residuals[1].is_empty());
    }
}
