//! The gyro against a vector sensor: does the rotation the gyro integrates turn the measured
//! direction (gravity from the inclinometer, the field from the magnetometer) the way the
//! sensor saw it turn?
//!
//! A direction fixed in the lab, seen in body axes, moves as `v̇ = v × ω`. Over a window
//! (`WINDOW_S`) between two vector samples, `Δv = ∫ v × ω dt` with `v` interpolated between
//! the samples and `ω` the gyro's rate held over its period. For a hypothesis `S` on the gyro's
//! columns (a signed permutation, [`super::axes`]) and a scale `κ`, the rate is `κ S w + β`,
//! `w` the recorded rates and `β` a constant bias (the gyro's own and the Earth's rate). The
//! magnetometer's readings carry a constant hard iron `b`, which turns with nothing:
//! `Δm = ∫ (m − b) × ω dt`, linear in `c = κ b` once the small `b × β` is dropped. So per
//! hypothesis a linear least-squares fit in `κ ≥ 0`, `β` and (field) `c`, each bounded to
//! what is physical ([`BIAS_MAX_RAD_S`], [`HARD_IRON_MAX`]), gives:
//!
//! * the fraction of the vector changes it explains (clean data: above 0.95 even with soft iron
//!   or a lag of a few tenths of a second; a channel of another run: near 0);
//! * `κ`, the sensor's rotation per gyro rotation (1 for clean data; 1/57.3 for a gyro in °/s;
//!   57.3 for tilts in degrees).
//!
//! The field is normalised by its median magnitude (its unit is the `field` check's), gravity
//! is the unit vector of the two tilts (paper eq. 2). A sensor is *excited* when its changes
//! stand [`EXCITATION`] times above its noise (estimated from the samples' second differences,
//! not taken from the configuration): without motion nothing is judged.

use super::axes::SignedPermutation;
use crate::data::{Dataset, median_period};
use crate::stats::NormalEquations;
use nalgebra::{Matrix3, Vector3};

/// Window length, s: 25 vector samples at 2.5 Hz, a rotation of several degrees at the
/// experiment's slew rates (the field's changes then stand well above its noise), and long
/// beside any lag between the files' clocks.
pub const WINDOW_S: f64 = 10.0;
/// Fewest windows for a judgement.
const MIN_WINDOWS: usize = 5;
/// A sensor is excited when the RMS of its windows' changes is this many times the noise of a
/// difference of two samples: noise alone then leaves at most 1/25 of the changes unexplained,
/// far from the thresholds of [`super::attribution`].
pub const EXCITATION: f64 = 5.0;
/// A sample spacing beyond this many median periods is a gap (no window spans it).
const GAP_PERIODS: f64 = 3.0;

/// Which vector sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sensor {
    Inclinometer,
    Magnetometer,
}

/// A direction's samples: time, s, and the vector (unit gravity, or the field over its median
/// magnitude).
#[derive(Debug, Clone, Default)]
pub struct Directions {
    pub t: Vec<f64>,
    pub v: Vec<Vector3<f64>>,
    /// Whether the sample is within the sensor's range: a reading at the range limit is the
    /// clamp's, not the direction's, and no window spans one.
    pub in_range: Vec<bool>,
}

/// Readings within this fraction of the range limit count as clamped (a sensor's clamp may sit
/// a little inside its nominal range).
const CLAMP_FRACTION: f64 = 0.98;

/// The gravity direction of the inclinometer's rows (paper eq. 2; a sum of squared sines above
/// 1 is clamped), their angles read as `angle_factor` × radians (1: as the contract says);
/// `range_rad` is the sensor's range.
pub fn gravity(data: &Dataset, angle_factor: f64, range_rad: f64) -> Directions {
    Directions {
        in_range: data
            .inclinometer
            .iter()
            .map(|r| {
                r.tilt_rad
                    .iter()
                    .all(|a| (a / angle_factor).abs() < CLAMP_FRACTION * range_rad)
            })
            .collect(),
        t: data.inclinometer.iter().map(|r| r.t_s).collect(),
        v: data
            .inclinometer
            .iter()
            .map(|r| {
                let [x, y] = r.tilt_rad.map(|a| a / angle_factor);
                let (sx, sy) = (x.sin(), y.sin());
                Vector3::new(sx, sy, -(1.0 - sx * sx - sy * sy).max(0.0).sqrt())
            })
            .collect(),
    }
}

/// The field's direction and size in units of its median magnitude; `range_t` is the sensor's
/// range per axis, tesla.
pub fn field(data: &Dataset, range_t: f64) -> Directions {
    let mut magnitudes: Vec<f64> = data.magnetometer.iter().map(|r| r.field_t.norm()).collect();
    magnitudes.sort_by(f64::total_cmp);
    let median = magnitudes.get(magnitudes.len() / 2).copied().unwrap_or(1.0);
    let scale = if median > 0.0 { 1.0 / median } else { 1.0 };
    Directions {
        in_range: data
            .magnetometer
            .iter()
            .map(|r| r.field_t.amax() < CLAMP_FRACTION * range_t)
            .collect(),
        t: data.magnetometer.iter().map(|r| r.t_s).collect(),
        v: data
            .magnetometer
            .iter()
            .map(|r| r.field_t * scale)
            .collect(),
    }
}

/// One window's sums: the change of the vector and the integrals the fit needs.
#[derive(Debug, Clone, Copy)]
struct Window {
    /// `v(end) − v(start)`.
    change: Vector3<f64>,
    /// `Σ v wᵀ Δt`: `∫ v × S w dt` is the axial vector of `M Sᵀ`.
    outer: Matrix3<f64>,
    /// `Σ v Δt`: the bias term is `V × β`.
    v_integral: Vector3<f64>,
    /// `Σ w Δt`: the hard-iron term is `(S Ω) × c`.
    w_integral: Vector3<f64>,
}

/// The fit of one hypothesis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HypothesisFit {
    pub hypothesis: SignedPermutation,
    /// Fraction of the vector changes left unexplained (`RSS / Σ|Δv|²`).
    pub unexplained: f64,
    /// Sensor rotation per gyro rotation (≥ 0).
    pub kappa: f64,
    /// Standard error of `kappa`.
    pub kappa_stderr: f64,
}

/// The gyro against one sensor: every hypothesis's fit.
#[derive(Debug, Clone)]
pub struct SensorFit {
    pub sensor: Sensor,
    /// Whether the sensor moved enough to judge.
    pub excited: bool,
    /// RMS of the windows' changes over the noise of a difference of two samples.
    pub motion_to_noise: f64,
    /// One fit per signed permutation, in [`SignedPermutation::all`]'s order (the identity
    /// first).
    pub fits: Vec<HypothesisFit>,
}

impl SensorFit {
    pub fn identity(&self) -> &HypothesisFit {
        &self.fits[0]
    }

    /// The hypothesis that explains the most.
    pub fn best(&self) -> &HypothesisFit {
        self.fits
            .iter()
            .min_by(|a, b| a.unexplained.total_cmp(&b.unexplained))
            .unwrap_or(&self.fits[0])
    }

    pub fn fit_of(&self, h: &SignedPermutation) -> Option<&HypothesisFit> {
        self.fits.iter().find(|f| f.hypothesis == *h)
    }
}

/// Fit every hypothesis of the gyro's columns against `directions` of `sensor`; `None` if the
/// record holds too few windows.
pub fn fit_sensor(data: &Dataset, sensor: Sensor, directions: &Directions) -> Option<SensorFit> {
    let windows = windows(data, directions);
    if windows.len() < MIN_WINDOWS {
        return None;
    }
    let tss: f64 = windows.iter().map(|w| w.change.norm_squared()).sum();
    let noise = difference_noise(&directions.v);
    let rms_change = (tss / (3 * windows.len()) as f64).sqrt();
    let motion_to_noise = if noise > 0.0 {
        rms_change / (std::f64::consts::SQRT_2 * noise)
    } else {
        f64::INFINITY
    };
    let hard_iron = sensor == Sensor::Magnetometer;
    let fits = SignedPermutation::all()
        .into_iter()
        .map(|h| fit_hypothesis(&windows, tss, h, hard_iron))
        .collect();
    Some(SensorFit {
        sensor,
        excited: tss > 0.0 && motion_to_noise >= EXCITATION,
        motion_to_noise,
        fits,
    })
}

/// The largest constant rate a gyro's bias and the Earth's rotation make as the sensor sees it
/// (times `κ` when the sensor turns faster than the gyro), rad/s (0.5 °/s: beyond
/// the bias of any gyro fit for a test bed, fibre-optic ones are at 0.005 °/s). Without this
/// bound a large fitted "bias" about the vertical turns the tilt vector as a tilt programme of
/// another run does, and such a channel would pass as explained.
pub const BIAS_MAX_RAD_S: f64 = 0.5 * std::f64::consts::PI / 180.0;
/// The largest hard iron, in units of the readings' median magnitude (twice it: a hard iron
/// larger than the field it sits in would dominate every reading).
pub const HARD_IRON_MAX: f64 = 2.0;

/// The least-squares fit of hypothesis `h` with the plausible parameters: `κ ≥ 0` (its
/// negation is another hypothesis), `|β| ≤` [`BIAS_MAX_RAD_S`], `|b| ≤` [`HARD_IRON_MAX`]. The
/// full model first; where its bias or hard iron is implausible, the model without the bias;
/// then the bias alone (no rotation from the gyro at all).
fn fit_hypothesis(
    windows: &[Window],
    tss: f64,
    h: SignedPermutation,
    hard_iron: bool,
) -> HypothesisFit {
    let s = h.matrix();
    let solve = |with_kappa: bool, with_bias: bool, with_iron: bool| {
        let p = usize::from(with_kappa) + 3 * usize::from(with_bias) + 3 * usize::from(with_iron);
        let mut normal = NormalEquations::new(p);
        for w in windows {
            let k = w.outer * s.transpose();
            let axial = Vector3::new(
                k[(1, 2)] - k[(2, 1)],
                k[(2, 0)] - k[(0, 2)],
                k[(0, 1)] - k[(1, 0)],
            );
            let bias = w.v_integral.cross_matrix();
            let iron = (s * w.w_integral).cross_matrix();
            for r in 0..3 {
                let mut x = Vec::with_capacity(p);
                if with_kappa {
                    x.push(axial[r]);
                }
                if with_bias {
                    x.extend((0..3).map(|c| bias[(r, c)]));
                }
                if with_iron {
                    x.extend((0..3).map(|c| iron[(r, c)]));
                }
                normal.add(&x, w.change[r]);
            }
        }
        // A whisper of ridge on every column, so a direction the motion leaves undetermined
        // (the bias about a vertical that never tilts) does not make the fit fail.
        let largest = (0..p).map(|j| normal.diag(j)).fold(0.0f64, f64::max);
        for j in 0..p {
            let mut x = vec![0.0; p];
            x[j] = (1e-10 * largest).sqrt();
            normal.add(&x, 0.0);
        }
        normal.solve()
    };
    let plausible = |theta: &nalgebra::DVector<f64>, with_bias: bool, with_iron: bool| {
        let kappa = theta[0];
        // The bias is seen through the sensor: tilts in degrees see it 57× too.
        let bias_ok = !with_bias
            || Vector3::new(theta[1], theta[2], theta[3]).norm() <= BIAS_MAX_RAD_S * kappa.max(1.0);
        let at = if with_bias { 4 } else { 1 };
        let iron_ok = !with_iron
            || Vector3::new(theta[at], theta[at + 1], theta[at + 2]).norm()
                <= HARD_IRON_MAX * kappa;
        kappa >= 0.0 && bias_ok && iron_ok
    };
    let unexplained = |rss: f64| if tss > 0.0 { (rss / tss).min(1.0) } else { 1.0 };
    for with_bias in [true, false] {
        if let Some(fit) = solve(true, with_bias, hard_iron)
            && plausible(&fit.theta, with_bias, hard_iron)
        {
            return HypothesisFit {
                hypothesis: h,
                unexplained: unexplained(fit.rss),
                kappa: fit.theta[0],
                kappa_stderr: fit.stderr()[0],
            };
        }
    }
    let bias_only = solve(false, true, false)
        .filter(|fit| fit.theta.norm() <= BIAS_MAX_RAD_S)
        .map_or(1.0, |fit| unexplained(fit.rss));
    HypothesisFit {
        hypothesis: h,
        unexplained: bias_only,
        kappa: 0.0,
        kappa_stderr: f64::INFINITY,
    }
}

/// The windows between vector samples `WINDOW_S` apart (consecutive, not overlapping), with
/// the gyro integrated over each; windows across a gap of either series or a clamped sample
/// are left out.
fn windows(data: &Dataset, d: &Directions) -> Vec<Window> {
    let gyro = &data.gyro;
    if gyro.len() < 2 || d.t.len() < 2 {
        return Vec::new();
    }
    let gyro_period = median_period(gyro.iter().map(|r| r.t_s));
    let vector_period = median_period(d.t.iter().copied());
    let mut out = Vec::new();
    let mut i = 0;
    while i + 1 < d.t.len() {
        let mut j = i;
        let mut gap = !d.in_range[i];
        while j + 1 < d.t.len() && d.t[j] - d.t[i] < WINDOW_S {
            gap |= d.t[j + 1] - d.t[j] > GAP_PERIODS * vector_period || !d.in_range[j + 1];
            j += 1;
        }
        if d.t[j] - d.t[i] < 0.5 * WINDOW_S {
            break;
        }
        let (ta, tb) = (d.t[i], d.t[j]);
        if !gap && let Some(w) = integrate(gyro, gyro_period, d, i, ta, tb) {
            out.push(Window {
                change: d.v[j] - d.v[i],
                ..w
            });
        }
        i = j;
    }
    out
}

/// The gyro's sums over `[ta, tb]` (rates held over their period), `v` interpolated from
/// sample `from` on; `None` if the gyro does not cover the window or has a gap in it.
fn integrate(
    gyro: &[crate::data::GyroRow],
    gyro_period: f64,
    d: &Directions,
    from: usize,
    ta: f64,
    tb: f64,
) -> Option<Window> {
    let first = gyro.partition_point(|r| r.t_s <= ta).checked_sub(1)?;
    if gyro.last()?.t_s < tb {
        return None;
    }
    let mut window = Window {
        change: Vector3::zeros(),
        outer: Matrix3::zeros(),
        v_integral: Vector3::zeros(),
        w_integral: Vector3::zeros(),
    };
    let mut s = from;
    for k in first..gyro.len() {
        let start = gyro[k].t_s.max(ta);
        let next = gyro.get(k + 1).map_or(f64::INFINITY, |r| r.t_s);
        if next - gyro[k].t_s > GAP_PERIODS * gyro_period && next < tb {
            return None;
        }
        let end = next.min(tb);
        if end <= start {
            if start >= tb {
                break;
            }
            continue;
        }
        let mid = 0.5 * (start + end);
        while s + 1 < d.t.len() && d.t[s + 1] < mid {
            s += 1;
        }
        let (t0, t1) = (d.t[s], d.t[(s + 1).min(d.t.len() - 1)]);
        let f = if t1 > t0 {
            ((mid - t0) / (t1 - t0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let v = d.v[s] * (1.0 - f) + d.v[(s + 1).min(d.t.len() - 1)] * f;
        let w = gyro[k].rate_rad_s;
        let dt = end - start;
        window.outer += v * w.transpose() * dt;
        window.v_integral += v * dt;
        window.w_integral += w * dt;
        if end >= tb {
            break;
        }
    }
    Some(window)
}

/// The white noise of one sample, per component: from the second differences, whose variance
/// is 6σ² for white noise and which smooth motion barely touches; the median of their
/// magnitudes makes steps in the motion harmless (`median |N(0, 6σ²)| = 0.6745 √6 σ`).
fn difference_noise(v: &[Vector3<f64>]) -> f64 {
    if v.len() < 3 {
        return 0.0;
    }
    let mut variance = 0.0;
    for c in 0..3 {
        let mut d: Vec<f64> = v
            .windows(3)
            .map(|w| (w[2][c] - 2.0 * w[1][c] + w[0][c]).abs())
            .collect();
        d.sort_by(f64::total_cmp);
        let sigma = d[d.len() / 2] / (0.6745 * 6f64.sqrt());
        variance += sigma * sigma / 3.0;
    }
    variance.sqrt()
}
