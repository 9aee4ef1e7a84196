//! Isolated spikes in the sensors' readings (a corrupted frame, a bit error, a glitch of the
//! acquisition): left out before identification and listed in the report.
//!
//! A single wrong reading is no effect of the physics, but the fits take it for one: 0.5 % of
//! the gyro's rows off by 0.01 rad/s (some 500 times its noise) were named a `gyro_delay` of
//! 25 ms. A reading is a spike when the fourth difference centred on it,
//! `D4[k] = (−x[k−2] + 4x[k−1] − 6x[k] + 4x[k+1] − x[k+2]) / 4`, is more than [`THRESHOLD`]
//! times its scale and larger than its neighbours' (a spike of size `s` gives `1.5 s` at its
//! row, `s` beside it). The fourth difference is blind to any cubic in time, so a manoeuvre's
//! smooth motion is not a spike; a change of slope (a torque step seen by the gyro) leaves
//! half of its size in one period, `Δω̇ dt / 2`, far below a spike's at the test bed's torques.
//!
//! A spike must also stand alone: the lines through the two readings on each side agree with
//! each other where it does not (`isolated`), which a step or a change of slope between two
//! readings fails. Rows next to a lost row are not screened.
//!
//! The scale is robust and local: the median absolute deviation of the fourth differences of
//! the `SCALE_HALF_WIDTH` (20) rows on each side beyond the five the reading enters, as the
//! motion's own vary along a record (the inclinometer's 2.5 Hz sees a swing near the tilt
//! stop), but at least what the sensor's configured noise gives them (`√70 / 4 σ`), so a
//! quantised reading that rarely changes is not all spikes. The wheel speeds are screened less
//! what the torque commands explain (`n − ∫T/J`, see [`unexplained_wheel_speeds`]): a commanded
//! step of the torque is a change of slope many times the tachometer's noise, and when it falls
//! on a reading the lines on each side meet there, so the speeds themselves would look like
//! spikes at every such step (four in a clean 600-s experiment). Two spoilt readings in a row
//! are not isolated and stay in.

use crate::csv::{columns, files};
use crate::data::{Dataset, WheelRow, median_period};
use nalgebra::Vector3;
use serde::Serialize;
use testbed_model::ModelConfig;

/// A reading is a spike beyond this many times its column's scale.
pub const THRESHOLD: f64 = 10.0;
/// The fourth difference's noise over the readings': `√(1 + 16 + 36 + 16 + 1) / 4`.
const D4_NOISE_GAIN: f64 = 2.091_650_066_335_189;
/// The median absolute deviation of normal noise over its standard deviation.
const MAD_OVER_SIGMA: f64 = 0.674_489_750_196_081_7;
/// The scale of a row's fourth difference is taken over this many rows on each side: the
/// motion's own fourth differences (a swing at the tilt stop, slow sampling) vary along a record.
const SCALE_HALF_WIDTH: usize = 20;
/// A window of five rows with a spacing over this many median periods (a lost row) is not
/// screened: the fourth difference holds for evenly spaced rows only.
const MAX_GAP_PERIODS: f64 = 1.5;

/// One reading left out.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spike {
    /// The file (or run-log topic) it was read from.
    pub file: String,
    /// Its row's time stamp, s.
    pub t_s: f64,
    /// Its column.
    pub column: &'static str,
    /// The reading, in the file's unit (SI).
    pub value: f64,
    /// Its fourth difference over the column's scale (the threshold is [`THRESHOLD`]).
    pub deviation: f64,
}

/// The rows of `values` (sampled at `times`) that are isolated spikes, with their deviation:
/// `|D4| / scale` above [`THRESHOLD`] and a local maximum. `sigma` is the configured noise of
/// one reading, the floor of the scale.
pub fn find(times: &[f64], values: &[f64], sigma: f64) -> Vec<(usize, f64)> {
    let n = values.len();
    if n < 5 || times.len() != n {
        return Vec::new();
    }
    let period = median_period(times.iter().copied());
    let d4: Vec<Option<f64>> = (0..n)
        .map(|k| {
            let even = |i: usize| (times[i + 1] - times[i]) < MAX_GAP_PERIODS * period;
            if k < 2 || k + 2 >= n || !(k - 2..k + 2).all(even) {
                return None;
            }
            let x = &values[k - 2..=k + 2];
            Some((-x[0] + 4.0 * x[1] - 6.0 * x[2] + 4.0 * x[3] - x[4]) / 4.0)
        })
        .collect();
    let floor = D4_NOISE_GAIN * sigma;
    let size = |k: usize| d4.get(k).copied().flatten().map_or(0.0, f64::abs);
    let mut window = Vec::with_capacity(2 * SCALE_HALF_WIDTH);
    (0..n)
        .filter_map(|k| {
            let here = size(k);
            let peak = here > size(k.wrapping_sub(1)) && here >= size(k + 1);
            if !(peak && here > THRESHOLD * floor && isolated(&values[k - 2..=k + 2])) {
                return None;
            }
            // Beside the five fourth differences the reading itself enters.
            window.clear();
            let before = k.saturating_sub(SCALE_HALF_WIDTH + 2)..k.saturating_sub(2);
            let after = (k + 3).min(n)..(k + SCALE_HALF_WIDTH + 3).min(n);
            window.extend(
                d4[before]
                    .iter()
                    .chain(&d4[after])
                    .flatten()
                    .map(|d| d.abs()),
            );
            if window.is_empty() {
                return None;
            }
            let mid = window.len() / 2;
            let (_, median, _) = window.select_nth_unstable_by(mid, f64::total_cmp);
            let scale = (*median / MAD_OVER_SIGMA).max(floor);
            (scale.is_finite() && here > THRESHOLD * scale).then_some((k, here / scale))
        })
        .collect()
}

/// Whether the middle of five readings departs from a trend its neighbours agree on: the
/// lines through the two readings on each side meet it at values closer to each other than
/// half its distance from their mean. A step or a change of slope between two readings makes
/// the two sides disagree by as much as the middle departs, a spike does not.
fn isolated(x: &[f64]) -> bool {
    let (left, right) = (2.0 * x[1] - x[0], 2.0 * x[3] - x[4]);
    (x[2] - (left + right) / 2.0).abs() > 2.0 * (left - right).abs()
}

/// `data` without the rows that hold a spike in any column of the gyro, inclinometer or
/// magnetometer or in a wheel speed, and the spikes (at most one per row: the largest), in file and time order.
pub fn remove(data: &Dataset, model: &ModelConfig) -> (Dataset, Vec<Spike>) {
    let gyro_sigma = model.gyro.noise_density_rad_sqrt_s() * model.gyro.rate_hz.sqrt();
    let tilt_sigma = model.inclinometer.noise_rad();
    let field_sigma = model.magnetometer.noise_t();
    let tach_sigma = model.wheels.speed_noise_rad_s();
    let mut spikes = Vec::new();
    let mut out = data.clone();

    let gyro = screen(
        data,
        files::GYRO,
        &columns::GYRO[1..],
        data.gyro.iter().map(|r| (r.t_s, r.rate_rad_s.into())),
        &gyro_sigma.into(),
        &mut spikes,
    );
    retain(&mut out.gyro, &gyro);
    let tilt = screen(
        data,
        files::INCLINOMETER,
        &columns::INCLINOMETER[1..],
        data.inclinometer.iter().map(|r| (r.t_s, r.tilt_rad)),
        &tilt_sigma,
        &mut spikes,
    );
    retain(&mut out.inclinometer, &tilt);
    let field = screen(
        data,
        files::MAGNETOMETER,
        &columns::MAGNETOMETER[1..],
        data.magnetometer.iter().map(|r| (r.t_s, r.field_t.into())),
        &field_sigma.into(),
        &mut spikes,
    );
    retain(&mut out.magnetometer, &field);
    let wheels = screen(
        data,
        files::WHEELS,
        &columns::WHEELS[1..4],
        unexplained_wheel_speeds(&data.wheels, model.wheels.inertia_kgm2),
        &[tach_sigma; 3],
        &mut spikes,
    );
    retain(&mut out.wheels, &wheels);
    (out, spikes)
}

/// Each wheel row's speeds less what the torque commands so far explain,
/// `n_k − Σ_{j<k} T_j (t_{j+1} − t_j) / J` (a command holds until the next row), with the time
/// stamps: the commanded steps and doublets of the speeds are gone, the friction's smooth drift
/// and a spoilt reading stay.
fn unexplained_wheel_speeds(
    rows: &[WheelRow],
    inertia_kgm2: f64,
) -> impl Iterator<Item = (f64, [f64; 3])> + '_ {
    let mut commanded = Vector3::zeros();
    let mut previous: Option<&WheelRow> = None;
    rows.iter().map(move |r| {
        if let Some(p) = previous {
            commanded += p.torque_nm * ((r.t_s - p.t_s) / inertia_kgm2);
        }
        previous = Some(r);
        (r.t_s, (r.speed_rad_s - commanded).into())
    })
}

/// The rows of one file to leave out (sorted), adding their spikes to `spikes`.
fn screen<const N: usize>(
    data: &Dataset,
    file: &str,
    names: &[&'static str],
    rows: impl Iterator<Item = (f64, [f64; N])>,
    sigma: &[f64; N],
    spikes: &mut Vec<Spike>,
) -> Vec<usize> {
    let (times, readings): (Vec<f64>, Vec<[f64; N]>) = rows.unzip();
    let mut worst: std::collections::BTreeMap<usize, Spike> = Default::default();
    for (axis, &column) in names.iter().enumerate().take(N) {
        let values: Vec<f64> = readings.iter().map(|r| r[axis]).collect();
        for (k, deviation) in find(&times, &values, sigma[axis]) {
            let spike = Spike {
                file: data.file(file).display().to_string(),
                t_s: times[k],
                column,
                value: values[k],
                deviation,
            };
            if worst.get(&k).is_none_or(|s| s.deviation < deviation) {
                worst.insert(k, spike);
            }
        }
    }
    let rows = worst.keys().copied().collect();
    spikes.extend(worst.into_values());
    rows
}

/// Removes the rows at the sorted indices `drop`.
fn retain<R>(rows: &mut Vec<R>, drop: &[usize]) {
    let mut index = 0;
    rows.retain(|_| {
        let keep = drop.binary_search(&index).is_err();
        index += 1;
        keep
    });
}

/// One line for the report's summary (none without spikes).
pub fn summary(spikes: &[Spike]) -> Option<String> {
    let mut files: Vec<(&str, usize)> = Vec::new();
    for s in spikes {
        match files.iter_mut().find(|(f, _)| *f == s.file) {
            Some((_, n)) => *n += 1,
            None => files.push((&s.file, 1)),
        }
    }
    let counts: Vec<String> = files.iter().map(|(f, n)| format!("{n} in {f}")).collect();
    let largest = spikes
        .iter()
        .max_by(|a, b| a.deviation.total_cmp(&b.deviation))?;
    Some(format!(
        "Left out: {} isolated spike{} (a reading off both neighbours' trend by more than {THRESHOLD} times its column's scale; `data.spikes` lists each): {}; the largest {} = {:.4e} at t = {:.3} s in {}, {:.0}× the scale.",
        spikes.len(),
        if spikes.len() == 1 { "" } else { "s" },
        counts.join(", "),
        largest.column,
        largest.value,
        largest.t_s,
        largest.file,
        largest.deviation,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(n: usize, sigma: f64) -> Vec<f64> {
        crate::stats::normals(n, 12345)
            .into_iter()
            .map(|e| sigma * e)
            .collect()
    }

    /// A cubic manoeuvre far larger than the noise, with noise: no spike; the same with two
    /// readings off by 20σ and −50σ: exactly those two, at their size over the scale
    /// (`1.5 s / (2.09 σ)`) within 30 % (the scale is the median of 40 values).
    #[test]
    fn spikes_are_found_on_a_cubic_and_nothing_else() {
        let sigma = 1e-5;
        let times: Vec<f64> = (0..3000).map(|k| k as f64 * 0.1).collect();
        let mut values: Vec<f64> = times
            .iter()
            .zip(noise(3000, sigma))
            .map(|(t, e)| 1e-3 * t - 2e-5 * t * t + 3e-8 * t * t * t + e)
            .collect();
        assert!(find(&times, &values, sigma).is_empty());
        values[700] += 20.0 * sigma;
        values[1801] -= 50.0 * sigma;
        let found = find(&times, &values, sigma);
        let rows: Vec<usize> = found.iter().map(|(k, _)| *k).collect();
        assert_eq!(rows, [700, 1801]);
        for ((_, deviation), size) in found.iter().zip([20.0, 50.0]) {
            let expected = 1.5 * size / D4_NOISE_GAIN;
            assert!(
                (deviation / expected - 1.0).abs() < 0.3,
                "{deviation} against {expected}"
            );
        }
    }

    /// A change of slope (a torque step, `Δω̇ = 4.4e-3 rad/s²`, the test bed's 0.2 Nm on
    /// 45 kg m²) in the gyro's noise (2e-5 rad/s at 10 Hz) is not a spike; a rate step (a
    /// thruster's pulse, 50σ) neither, with noise or on a quantised reading without it.
    #[test]
    fn a_change_of_slope_or_a_quantised_step_is_no_spike() {
        let times: Vec<f64> = (0..600).map(|k| k as f64 * 0.1).collect();
        let kink: Vec<f64> = times
            .iter()
            .zip(noise(600, 2e-5))
            .map(|(t, e)| 4.4e-3 * (t - 30.05).max(0.0) + e)
            .collect();
        assert!(find(&times, &kink, 2e-5).is_empty());
        let step = |t: f64| if t < 20.0 { 0.0 } else { 1e-3 };
        let quantised: Vec<f64> = times.iter().map(|t| step(*t)).collect();
        assert!(find(&times, &quantised, 2e-5).is_empty());
        let noisy: Vec<f64> = times
            .iter()
            .zip(noise(600, 2e-5))
            .map(|(t, e)| step(*t) + e)
            .collect();
        assert!(find(&times, &noisy, 2e-5).is_empty());
    }

    /// A fast ramp with a row lost: the windows across the gap are not screened (their fourth
    /// difference would be the ramp's slope times the gap).
    #[test]
    fn a_lost_row_on_a_ramp_is_no_spike() {
        let times: Vec<f64> = (0..200)
            .filter(|k| *k != 90)
            .map(|k| k as f64 * 0.4)
            .collect();
        let values: Vec<f64> = times.iter().map(|t| 1e-2 * t).collect();
        assert!(find(&times, &values, 1e-6).is_empty());
    }

    /// A commanded torque doublet (+20 mNm then −20 mNm, a tick each) bumps the wheel speed by
    /// one reading of 1.26 rad/s, 120 times the tachometer's noise: a spike in the speeds, none
    /// in what the commands leave unexplained, where a spoilt reading is still found.
    #[test]
    fn a_commanded_doublet_is_no_wheel_spike() {
        let (j, sigma) = (1.5915e-3, 1.05e-2);
        let torque = |k: usize| match k {
            300 => 0.02,
            301 => -0.02,
            _ => 1e-3,
        };
        let mut speed = 100.0;
        let mut rows: Vec<WheelRow> = noise(600, sigma)
            .into_iter()
            .enumerate()
            .map(|(k, e)| {
                let row = WheelRow {
                    t_s: k as f64 * 0.1,
                    speed_rad_s: Vector3::repeat(speed + e),
                    torque_nm: Vector3::repeat(torque(k)),
                };
                speed += torque(k) * 0.1 / j;
                row
            })
            .collect();
        let axis = |rows: &[WheelRow], unexplained: bool| -> Vec<usize> {
            let (times, values): (Vec<f64>, Vec<f64>) = if unexplained {
                unexplained_wheel_speeds(rows, j)
                    .map(|(t, v)| (t, v[0]))
                    .unzip()
            } else {
                rows.iter().map(|r| (r.t_s, r.speed_rad_s.x)).unzip()
            };
            find(&times, &values, sigma)
                .iter()
                .map(|(k, _)| *k)
                .collect()
        };
        assert_eq!(axis(&rows, false), [301]);
        assert!(axis(&rows, true).is_empty());
        rows[450].speed_rad_s.x += 1.0;
        assert_eq!(axis(&rows, true), [450]);
    }

    #[test]
    fn rows_are_removed_by_index() {
        let mut rows = vec![10, 11, 12, 13, 14];
        retain(&mut rows, &[1, 3]);
        assert_eq!(rows, [10, 12, 14]);
    }
}
