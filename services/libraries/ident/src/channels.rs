//! Equation-error channels: how far the data are from satisfying the model's equations of
//! motion, and how each candidate effect would change that (its regressors).
//!
//! **Torque channel** (platform, body axes). Total angular momentum about the bearing centre
//! `H = I w + J n + h_cmg(δ)`; the wheels' and CMGs' torques are internal, so
//! `H' + w × H = M` (external torque only: the equation-error torque residual
//! `I w' + h' + w × (I w + h) − M` is zero). Integrated from the start `s` of a segment (up to
//! `segment_s` long, inside one fit or held-out block) to each tick k:
//!
//! ```text
//! c_k = H_k − H_s + ∫_s^k (w × H − M_model) dt = e_k − e_s        (Nms, body axes)
//! ```
//!
//! with `e` the measurement noise of `H` (one gyro sample through the inertia, one tachometer
//! reading): white from tick to tick. The common `−e_s` and any constant error of `H` (the
//! estimated bias through the inertia) are a free offset per segment, removed by taking out each
//! segment's mean. This integral form averages the gyro noise over the segment, so slowly varying
//! torques are resolved far below one sample's noise. Each candidate effect adds `X θ`, its
//! regressors integrated the same way. The rates in the regressors are instruments, the mean of
//! the neighbouring samples `(w_{k−1} + w_{k+1})/2`, whose noise is independent of `e_k` (with
//! the raw sample, an inertia error multiplying `w_k − w_s` would be biased by the noise: errors
//! in variables).
//!
//! **Wheel channel** (per wheel i, motor torque τ on the wheel, friction `T_f` opposing the
//! relative speed n): `J (n_i' + w_i') = s·clamp(τ(t − d)) − T_f(n)`. Over one tick interval
//! `y = J Δ(n_i + w_i) − s ∫ clamp(τ(t − d)) dt + ∫ T_f(n) dt` (Nms), on every other interval (white),
//! leaving out intervals in which the wheel may have stuck (|n| below 8 tachometer σ at an end,
//! or a sign change) or was near its speed limit.

use crate::data::Aligned;
use crate::effects::Cause;
use crate::reconstruct::Reconstruction;
use crate::thrusters::ThrusterHistory;
use nalgebra::{Matrix3, Vector3};
use testbed_model::ModelConfig;
use testbed_model::attitude::{self, Attitude};
use testbed_model::physics::{CmgPyramid, ExternalTorqueModel, Wheel, WheelFrictionModel};
use testbed_model::thruster_config::THRUSTER_COUNT;

/// Columns of the torque channel's regressor matrix, in this order: `com_offset.r_m` (3),
/// `constant_torque.torque_nm` (3), `aero_drag.c1` (3), `aero_drag.c2` (3),
/// `inertia_error.fraction` (3), `inertia_error.products_kgm2` (3: xy, yz, zx),
/// `thruster_torque_scale.scale` (6), `propellant_com_shift.tank_position_m` (3),
/// `com_drift.rate_m_per_s` (3). The thrusters' nine are zero without thruster firings.
pub const TORQUE_COLUMNS: usize = 30;

/// Column range of a torque-kind cause in the torque regressors.
pub fn torque_columns(cause: Cause) -> Option<std::ops::Range<usize>> {
    match cause {
        Cause::ComOffset => Some(0..3),
        Cause::ConstantTorque => Some(3..6),
        Cause::AeroDrag => Some(6..12),
        Cause::InertiaError => Some(12..18),
        Cause::ThrusterTorqueScale => Some(18..24),
        Cause::PropellantComShift => Some(24..27),
        Cause::ComDrift => Some(27..30),
        _ => None,
    }
}

/// Cause and value offset of a torque column.
pub fn column_cause(col: usize) -> (Cause, usize) {
    match col {
        0..3 => (Cause::ComOffset, col),
        3..6 => (Cause::ConstantTorque, col - 3),
        6..12 => (Cause::AeroDrag, col - 6),
        12..18 => (Cause::InertiaError, col - 12),
        18..24 => (Cause::ThrusterTorqueScale, col - 18),
        24..27 => (Cause::PropellantComShift, col - 24),
        _ => (Cause::ComDrift, col - 27),
    }
}

/// Whether a torque channel builds its regressors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Regressors {
    /// Every column's (to fit torque causes).
    Built,
    /// None (`x` empty): enough for the residual of the configuration as it is
    /// ([`TorqueChannel::whitened`] with no change) and its whiteness, at a fraction of the
    /// time and memory (the regressors are 30 vectors a row).
    Skipped,
}

/// The torque channel on one reconstruction, under a base configuration.
#[derive(Debug, Clone)]
pub struct TorqueChannel {
    /// Tick of each row.
    pub ticks: Vec<usize>,
    /// Rows of each segment, `start..end`.
    pub segments: Vec<std::ops::Range<usize>>,
    /// Momentum residual of each row under the base configuration, segment mean removed, Nms,
    /// body axes.
    pub y: Vec<Vector3<f64>>,
    /// Regressors per row, [`TORQUE_COLUMNS`] columns (Nms per unit of the parameter), segment
    /// mean removed; empty when built with [`Regressors::Skipped`].
    pub x: Vec<[Vector3<f64>; TORQUE_COLUMNS]>,
    /// A-priori 1σ of a row per axis, Nms (gyro and tachometer noise).
    pub sigma: Vector3<f64>,
    /// Whether each column is non-zero in some row (a thruster that never fired, or no
    /// thrusters at all, leaves its columns zero: the data do not determine them).
    pub excited: [bool; TORQUE_COLUMNS],
    /// The thrusters over the record (data with thruster firings and a model with thrusters).
    pub thrusters: Option<ThrusterHistory>,
}

impl TorqueChannel {
    /// Build the channel: segments of at most `segment_s` that do not cross a change of
    /// `split` (a label per tick: fit and held-out ticks, or time blocks), on a regular clock,
    /// after the filter's start, away from the tilt stop; residuals under `config`; regressors
    /// unless `regressors` skips them.
    pub fn new(
        data: &Aligned,
        recon: &Reconstruction,
        config: &ModelConfig,
        segment_s: f64,
        split: &[usize],
        regressors: Regressors,
    ) -> Self {
        let built = regressors == Regressors::Built;
        let n = data.len();
        let max_len = ((segment_s / data.period_s).round() as usize).max(10);
        let inertia = config.true_inertia().unwrap_or_else(Matrix3::identity);
        let nominal = config.platform.inertia().unwrap_or(inertia);
        let j = if data.has_wheels() {
            config.wheels.inertia_kgm2
        } else {
            0.0
        };
        let cmg = CmgPyramid::from_config(&config.cmg);
        let external = ExternalTorqueModel::from_config(config);
        let thrusters = ThrusterHistory::new(data, config);
        let mg = config.platform.mass_kg * config.platform.gravity_mps2;
        let limit = config.platform.tilt_limit_rad() - 1.0_f64.to_radians();
        let rotor = |k: usize| {
            data.wheel_speed_at(k) * j
                + if data.gimbal.is_some() {
                    cmg.momentum(&data.gimbal_at(k))
                } else {
                    Vector3::zeros()
                }
        };
        let usable = |k: usize| {
            let regular = (data.t[k + 1] - data.t[k] - data.period_s).abs() < 0.25 * data.period_s
                && (data.t[k] - data.t[k - 1] - data.period_s).abs() < 0.25 * data.period_s;
            let [x, y] = attitude::tilt_angles(&recon.q[k]);
            regular
                && recon.span_of(k).is_some()
                && x.abs() < limit
                && y.abs() < limit
                && data.wheel_record_complete(data.t[k - 1], data.t[k + 1])
        };
        // Per tick: momentum, integrand of the residual, and the regressors' parts. Within a
        // segment the bias is held at its estimate at the segment's start (`b0`): the filter's
        // small bias corrections at each vector update would otherwise step `I w`.
        let rate = |k: usize, b0: &Vector3<f64>| recon.rate[k] + recon.bias[k] - b0;
        let momentum = |k: usize, b0: &Vector3<f64>| inertia * rate(k, b0) + rotor(k);
        let integrand = |k: usize, b0: &Vector3<f64>| {
            let w = rate(k, b0);
            // A torque that changes with time (a drifting centre of mass, a fitted term in
            // time) at the record's time, the plant's clock.
            let at = if external.time_dependent() {
                ExternalTorqueModel::at_time(&external, data.t[k])
            } else {
                external
            };
            let f = w.cross(&momentum(k, b0)) - at.torque(&recon.q[k], &w).total_b();
            match &thrusters {
                // The propellant's gravity torque; the thrust itself is added per interval.
                Some(th) => f - th.propellant_torque(k, &attitude::gravity_b(&recon.q[k])),
                None => f,
            }
        };
        let parts = |k: usize,
                     b0: &Vector3<f64>|
         -> (
            [Vector3<f64>; TORQUE_COLUMNS],
            [Vector3<f64>; TORQUE_COLUMNS],
        ) {
            let v = 0.5 * (rate(k - 1, b0) + rate(k + 1, b0));
            let g = attitude::gravity_b(&recon.q[k]);
            let mut m = [Vector3::zeros(); TORQUE_COLUMNS];
            let mut f = [Vector3::zeros(); TORQUE_COLUMNS];
            for i in 0..3 {
                let e = Vector3::ith(i, 1.0);
                f[i] = mg * e.cross(&g);
                f[27 + i] = f[i] * data.t[k];
                f[3 + i] = e;
                f[6 + i] = -v[i] * e;
                f[9 + i] = -v[i] * v[i].abs() * e;
                f[12 + i] = -nominal[(i, i)] * v.cross(&(e * v[i]));
                m[12 + i] = -nominal[(i, i)] * v[i] * e;
            }
            // Products of inertia: ΔI = P (e_a e_bᵀ + e_b e_aᵀ), P in kg m².
            for (p, (a, b)) in [(0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
                let (ea, eb) = (Vector3::ith(a, 1.0), Vector3::ith(b, 1.0));
                let dv = ea * v[b] + eb * v[a];
                f[15 + p] = -v.cross(&dv);
                m[15 + p] = -dv;
            }
            // Thrusters: a scale also changes the propellant drawn (`∂m_u/∂s_i = ṁ A_i`), and
            // so the propellant's gravity torque; the thrust's own part is added per interval.
            // The tank position: `∂(−m_u g r_t × G_B)/∂r_t,j = −m_u g e_j × G_B`.
            if let Some(th) = &thrusters {
                let lever = th.tank_m.cross(&g) * th.gravity_mps2 * th.mass_flow_kg_s;
                for i in 0..THRUSTER_COUNT {
                    f[18 + i] = -lever * th.cumulative_s[k][i];
                }
                let mug = th.used_kg(k) * th.gravity_mps2;
                for j in 0..3 {
                    f[24 + j] = -mug * Vector3::ith(j, 1.0).cross(&g);
                }
            }
            (m, f)
        };

        // Every tick may be a row: room for all of them up front (the rows are large, and
        // growing them by doubling copied them over and over).
        let mut out = Self {
            ticks: Vec::with_capacity(n),
            segments: Vec::new(),
            y: Vec::with_capacity(n),
            x: Vec::with_capacity(if built { n } else { 0 }),
            sigma: Vector3::zeros(),
            excited: [false; TORQUE_COLUMNS],
            thrusters: None,
        };
        let mut k = recon.start().max(1) + 1;
        while k + 1 < n {
            if !usable(k) {
                k += 1;
                continue;
            }
            // A segment from k: same block, usable ticks, at most max_len.
            let first_row = out.ticks.len();
            let b0 = recon.bias[k];
            let zero = || [Vector3::zeros(); TORQUE_COLUMNS];
            let parts_if_built = |k: usize| {
                if built {
                    parts(k, &b0)
                } else {
                    (zero(), zero())
                }
            };
            let (m0, mut prev_parts) = parts_if_built(k);
            let h0 = momentum(k, &b0);
            let mut c = Vector3::zeros();
            let mut xc = zero();
            let mut prev_f = integrand(k, &b0);
            let start = k;
            loop {
                let (m, f_parts) = parts_if_built(k);
                if k > start {
                    let h = 0.5 * (data.t[k] - data.t[k - 1]);
                    let fk = integrand(k, &b0);
                    c += h * (prev_f + fk);
                    if built {
                        for col in 0..TORQUE_COLUMNS {
                            xc[col] += h * (prev_parts[col] + f_parts[col]);
                        }
                    }
                    // The thrusters' impulse over the interval, exact (valve switches inside).
                    if let Some(th) = &thrusters {
                        c -= th.impulse_nms(k - 1);
                        if built {
                            for i in 0..THRUSTER_COUNT {
                                xc[18 + i] += th.torque_nm[i] * th.thrust_s[k - 1][i];
                            }
                        }
                    }
                    prev_f = fk;
                    prev_parts = f_parts;
                }
                out.ticks.push(k);
                out.y.push(momentum(k, &b0) - h0 + c);
                if built {
                    out.x
                        .push(std::array::from_fn(|col| m[col] - m0[col] + xc[col]));
                }
                k += 1;
                if k + 1 >= n || k - start >= max_len || split[k] != split[start] || !usable(k) {
                    break;
                }
            }
            let rows = first_row..out.ticks.len();
            if rows.len() < 10 {
                out.ticks.truncate(first_row);
                out.y.truncate(first_row);
                out.x.truncate(first_row);
                continue;
            }
            // Free offset per segment: remove the means.
            let len = rows.len() as f64;
            let ym: Vector3<f64> = out.y[rows.clone()].iter().sum::<Vector3<f64>>() / len;
            for r in rows.clone() {
                out.y[r] -= ym;
            }
            if built {
                let xm: [Vector3<f64>; TORQUE_COLUMNS] = std::array::from_fn(|col| {
                    out.x[rows.clone()]
                        .iter()
                        .map(|r| r[col])
                        .sum::<Vector3<f64>>()
                        / len
                });
                for r in rows.clone() {
                    for col in 0..TORQUE_COLUMNS {
                        out.x[r][col] -= xm[col];
                    }
                }
            }
            out.segments.push(rows);
        }

        for row in &out.x {
            for col in 0..TORQUE_COLUMNS {
                out.excited[col] |= row[col] != Vector3::zeros();
            }
        }
        // A-priori noise of H: one gyro sample through the inertia, and the tachometer.
        let gyro_sigma = config.gyro.noise_density_rad_sqrt_s() / data.period_s.sqrt();
        let tach = config.wheels.speed_noise_rad_s();
        out.sigma = Vector3::from_fn(|i, _| {
            let from_gyro: f64 = (0..3)
                .map(|c| (inertia[(i, c)] * gyro_sigma[c]).powi(2))
                .sum();
            (from_gyro + (j * tach).powi(2)).sqrt()
        });
        out.thrusters = thrusters;
        out
    }

    /// Whether column `col` can be fitted: the thrusters' columns (18 to 26) only where the
    /// data excite them (a thruster that fired, propellant used); the others always.
    pub fn determined(&self, col: usize) -> bool {
        !(18..27).contains(&col) || self.excited[col]
    }

    /// Rows.
    pub fn len(&self) -> usize {
        self.ticks.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ticks.is_empty()
    }

    /// Residual of row `i` with the torque parameters changed by `delta` (per column,
    /// [`TORQUE_COLUMNS`] long, zero for causes not fitted), whitened per axis.
    pub fn whitened(&self, i: usize, delta: &[f64]) -> Vector3<f64> {
        let mut r = self.y[i];
        for (c, d) in delta.iter().enumerate() {
            if *d != 0.0 {
                r -= self.x[i][c] * *d;
            }
        }
        r.component_div(&self.sigma)
    }
}

/// One wheel interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelInterval {
    /// Start tick (the interval is `[k, k + 1]`).
    pub k: usize,
    /// `J Δ(n + w_i)`, Nms.
    pub ja: f64,
    /// Wheel speed at the ends, rad/s.
    pub n0: f64,
    pub n1: f64,
    /// Start and end time, s.
    pub t0: f64,
    pub t1: f64,
    /// The platform's state over the interval (mean of its ends), as a fitted wheel torque's
    /// functions take it: `[sin tilt_x, sin tilt_y, cos ψ, sin ψ, w_x, w_y, w_z]` (the
    /// horizontal components of the unit down vector in body axes, heading harmonics, body
    /// rates in rad/s).
    pub platform: [f64; 7],
}

/// The wheel channel: per wheel its usable intervals.
#[derive(Debug, Clone)]
pub struct WheelChannel {
    pub rows: [Vec<WheelInterval>; 3],
    /// A-priori 1σ of a row, Nms (tachometer noise at both ends).
    pub sigma: f64,
    /// Torque limit of the drives, Nm.
    pub max_torque_nm: f64,
}

/// Gauss–Legendre nodes and weights on [0, 1] (4 points).
pub(crate) const GL4: [(f64, f64); 4] = [
    (0.069_431_844_202_973_71, 0.173_927_422_568_726_9),
    (0.330_009_478_207_571_9, 0.326_072_577_431_273_1),
    (0.669_990_521_792_428_1, 0.326_072_577_431_273_1),
    (0.930_568_155_797_026_3, 0.173_927_422_568_726_9),
];

impl WheelChannel {
    pub fn new(data: &Aligned, recon: &Reconstruction, config: &ModelConfig) -> Self {
        let j = config.wheels.inertia_kgm2;
        let tach = config.wheels.speed_noise_rad_s();
        let n_min = (8.0 * tach).max(1e-3);
        let n_max = 0.97 * config.wheels.max_speed_rad_s();
        let mut rows: [Vec<WheelInterval>; 3] = Default::default();
        if let Some(speeds) = &data.wheel_speed {
            let start = recon.start().max(1);
            let mut k = start;
            while k + 1 < data.len() {
                let regular =
                    (data.t[k + 1] - data.t[k] - data.period_s).abs() < 0.25 * data.period_s;
                let estimated = recon.span_of(k).is_some_and(|s| k + 1 < s.end);
                if regular && estimated && data.wheel_record_complete(data.t[k], data.t[k + 1]) {
                    let (a, b) = (platform_at(recon, k), platform_at(recon, k + 1));
                    let platform: [f64; 7] = std::array::from_fn(|j| 0.5 * (a[j] + b[j]));
                    for (i, wheel_rows) in rows.iter_mut().enumerate() {
                        let (n0, n1) = (speeds[k][i], speeds[k + 1][i]);
                        let usable = n0.abs() >= n_min
                            && n1.abs() >= n_min
                            && n0 * n1 > 0.0
                            && n0.abs() <= n_max
                            && n1.abs() <= n_max;
                        if usable {
                            wheel_rows.push(WheelInterval {
                                k,
                                ja: j * ((n1 + recon.rate[k + 1][i]) - (n0 + recon.rate[k][i])),
                                n0,
                                n1,
                                t0: data.t[k],
                                t1: data.t[k + 1],
                                platform,
                            });
                        }
                    }
                }
                k += 2;
            }
        }
        Self {
            rows,
            sigma: (2.0f64).sqrt() * j * tach,
            max_torque_nm: config.wheels.max_torque_nm,
        }
    }

    /// Rows in all wheels.
    pub fn len(&self) -> usize {
        self.rows.iter().map(Vec::len).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The platform's part of a fitted wheel torque's functions at sample `k` of `recon`:
/// `[G_x, G_y, cos ψ, sin ψ, w_x, w_y, w_z]` (see [`WheelInterval::platform`]).
pub fn platform_at(recon: &Reconstruction, k: usize) -> [f64; 7] {
    let q = &recon.q[k];
    let g = testbed_model::attitude::gravity_b(q);
    let psi = testbed_model::attitude::heading(q);
    let w = recon.rate[k];
    [g.x, g.y, psi.cos(), psi.sin(), w.x, w.y, w.z]
}

/// `∫ T_f(n(t)) dt` over an interval with n linear from `n0` to `n1` (same sign), Nm s.
pub fn friction_integral(model: &WheelFrictionModel, row: &WheelInterval) -> f64 {
    let dt = row.t1 - row.t0;
    let dir = row.n0.signum();
    GL4.iter()
        .map(|(s, w)| w * model.sliding_torque(row.n0 + s * (row.n1 - row.n0), dir))
        .sum::<f64>()
        * dt
}

/// `∫ f(n(t)) dt` over an interval with n linear from `n0` to `n1` (4-point Gauss–Legendre),
/// unit of f times s.
pub fn speed_integral(row: &WheelInterval, f: impl Fn(f64) -> f64) -> f64 {
    GL4.iter()
        .map(|(s, w)| w * f(row.n0 + s * (row.n1 - row.n0)))
        .sum::<f64>()
        * (row.t1 - row.t0)
}

/// Regressors of the friction parameters `[coulomb_pos, coulomb_neg, stribeck, viscous]` for a
/// Stribeck speed `ns` (rad/s; `None`: no Stribeck term): `∫ T_f dt = Σ θ_j R_j`.
pub fn friction_regressors(row: &WheelInterval, ns: Option<f64>) -> [f64; 4] {
    let dt = row.t1 - row.t0;
    let dir = row.n0.signum();
    let mut r = [0.0; 4];
    for (s, w) in GL4 {
        let n = row.n0 + s * (row.n1 - row.n0);
        let e = ns.map_or(0.0, |ns| (-(n / ns).powi(2)).exp());
        if dir > 0.0 {
            r[0] += w * (1.0 - e);
        } else {
            r[1] -= w * (1.0 - e);
        }
        r[2] += w * dir * e;
        r[3] += w * n;
    }
    r.map(|x| x * dt)
}

/// The base friction model of each wheel from a configuration.
pub fn friction_models(config: &ModelConfig) -> [WheelFrictionModel; 3] {
    Wheel::ALL.map(|w| WheelFrictionModel::from_config(config, w))
}

/// Gravity direction in body axes at an attitude (convenience for correlations).
pub fn gravity(q: &Attitude) -> Vector3<f64> {
    attitude::gravity_b(q)
}
