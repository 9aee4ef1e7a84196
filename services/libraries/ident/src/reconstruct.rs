//! The platform's state estimated from the data: the project's MEKF (`testbed_flight::mekf`) run
//! over the record, with the sensor-side effects of a model configuration taken out of the
//! readings first. Its whitened innovations are the attitude channel of the fits; its attitude,
//! bias and rate estimates are the state the torque and wheel channels and the predictions
//! start from.
//!
//! Conventions: attitudes L→B ([`testbed_model::attitude`]); rates in body axes, rad/s; field in
//! tesla. A gyro row is the rate at its time stamp, so the filter is propagated from tick k−1
//! to tick k with the mean of the two corrected readings (the filter takes a sample as the mean
//! rate over the interval it closes), plus what the thruster pulses inside the interval add to
//! that mean: a pulse steps the rate where it falls, which the two readings cannot place.

use crate::data::{Aligned, interpolate, median_period};
use crate::error::IdentError;
use crate::tangent::{Rate, Sensitivities, Tangent};
use crate::thrusters::ThrusterHistory;
use nalgebra::{Matrix2, Matrix3, UnitQuaternion, Vector2, Vector3};
use testbed_flight::mekf::{Mekf, MekfConfig, VectorMeasurements};
use testbed_model::ModelConfig;
use testbed_model::attitude::{self, Attitude};
use testbed_model::config::{DEG, EARTH_RATE_RAD_S, GAUSS};
use testbed_model::devices::fitted_field::FittedFieldModel;

/// Components of one innovation row: gravity (2, tangent plane) then field (3).
pub const INNOVATION_LEN: usize = 5;

/// The sensor-side effects of a configuration, as the readings see them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorModel {
    /// Gyro sensor matrix `S = (I + diag(s))(I − [m×])`: `w_meas = S (w + A Ω_L) + b`.
    pub gyro_matrix: Matrix3<f64>,
    /// Its inverse.
    pub gyro_matrix_inv: Matrix3<f64>,
    /// The gyros' delay, s: a reading is of the rate this long before its time stamp (zero
    /// without `gyro_delay`).
    pub gyro_delay_s: f64,
    /// Earth's rotation in the level frame, rad/s (zero without `earth_rate`).
    pub earth_rate_l: Vector3<f64>,
    /// Hard-iron field, body axes, tesla (zero without `magnetic_disturbance`).
    pub hard_iron_t: Vector3<f64>,
    /// Soft-iron map `1 + S` of `soft_iron` (identity without it) and its inverse.
    pub soft_iron: Matrix3<f64>,
    pub soft_iron_inv: Matrix3<f64>,
    /// Inclinometer mounting offset of `[θ, φ]`, rad (zero without `inclinometer_bias`).
    pub tilt_offset_rad: [f64; 2],
    /// Inclinometer matrix: the reading is `G [θ, φ]` plus the offset, `G` with `1 + s` of
    /// `inclinometer_scale` on its diagonal and the coupling of `inclinometer_cross_axis` off
    /// it (the identity without them); and its inverse.
    pub tilt_matrix: Matrix2<f64>,
    pub tilt_matrix_inv: Matrix2<f64>,
    /// Inclinometer lag `τ`, s: it reads the attitude `τ` earlier (zero without
    /// `inclinometer_lag`).
    pub tilt_lag_s: f64,
    /// Magnetometer lag, s (zero without `magnetometer_lag`).
    pub field_lag_s: f64,
    /// Gyro bias drift `ḃ`, rad/s² (zero without `gyro_bias_drift`): the readings less
    /// `ḃ (t − t_0)`, `t_0` the record's start, have the bias the filter tracks.
    pub gyro_bias_drift: Vector3<f64>,
    /// Lab field in the level frame, tesla.
    pub field_l_t: Vector3<f64>,
    /// The fitted field error of `effects.fitted_field` (a function of the attitude), tesla.
    pub fitted_field: FittedFieldModel,
}

impl SensorModel {
    pub fn from_config(config: &ModelConfig) -> Self {
        let e = &config.effects;
        let scale = e.gyro_scale.as_ref().map_or_else(Matrix3::identity, |s| {
            Matrix3::from_diagonal(&Vector3::from(s.ppm).map(|p| 1.0 + p * 1e-6))
        });
        let misalignment = e
            .gyro_misalignment
            .as_ref()
            .map_or_else(Matrix3::identity, |m| {
                Matrix3::identity() - Vector3::from(m.angles_rad).cross_matrix()
            });
        let gyro_matrix = scale * misalignment;
        let earth_rate_l = e.earth_rate.as_ref().map_or_else(Vector3::zeros, |x| {
            let lat = x.latitude_deg * DEG;
            EARTH_RATE_RAD_S * Vector3::new(lat.cos(), 0.0, lat.sin())
        });
        let [gain_x, gain_y] = e
            .inclinometer_scale
            .as_ref()
            .map_or([1.0; 2], |s| s.ppm.map(|p| 1.0 + p * 1e-6));
        let [cross_x, cross_y] = e
            .inclinometer_cross_axis
            .as_ref()
            .map_or([0.0; 2], |c| c.coupling);
        let tilt_matrix = Matrix2::new(gain_x, cross_x, cross_y, gain_y);
        let soft_iron = e.soft_iron.as_ref().map_or_else(Matrix3::identity, |s| {
            Matrix3::identity() + Matrix3::from_fn(|i, j| s.matrix[i][j])
        });
        Self {
            gyro_matrix,
            gyro_matrix_inv: gyro_matrix.try_inverse().unwrap_or_else(Matrix3::identity),
            gyro_delay_s: e.gyro_delay.as_ref().map_or(0.0, |d| d.delay_s),
            gyro_bias_drift: e
                .gyro_bias_drift
                .as_ref()
                .map_or_else(Vector3::zeros, |d| Vector3::from(d.rate_rad_s2)),
            earth_rate_l,
            hard_iron_t: e
                .magnetic_disturbance
                .as_ref()
                .map_or_else(Vector3::zeros, |d| Vector3::from(d.hard_iron_gauss) * GAUSS),
            soft_iron,
            // Entries within ±0.5 (the configuration's bounds) can still make `1 + S` singular;
            // such a matrix reads no field at all, so the identity stands in for it.
            soft_iron_inv: soft_iron.try_inverse().unwrap_or_else(Matrix3::identity),
            tilt_offset_rad: e
                .inclinometer_bias
                .as_ref()
                .map_or([0.0; 2], |b| b.offset_rad),
            tilt_matrix,
            // Couplings within ±0.1 and scales within ±10 % (the configuration's bounds) keep
            // `G` far from singular; the identity stands in should one not.
            tilt_matrix_inv: tilt_matrix.try_inverse().unwrap_or_else(Matrix2::identity),
            tilt_lag_s: e
                .inclinometer_lag
                .as_ref()
                .map_or(0.0, |l| l.time_constant_s),
            field_lag_s: e
                .magnetometer_lag
                .as_ref()
                .map_or(0.0, |l| l.time_constant_s),
            field_l_t: config.platform.field_l_t(),
            fitted_field: FittedFieldModel::from_config(
                e.fitted_field.as_ref(),
                &config.platform.field_l_t(),
            ),
        }
    }

    /// The gyro reading of the rate at tick `k`: the one stamped [`Self::gyro_delay_s`] later,
    /// interpolated linearly between the rows around that time (the last row's at the record's
    /// end), less the bias drift since the record's start.
    pub fn gyro_of_tick(&self, data: &Aligned, k: usize) -> Vector3<f64> {
        let reading = if self.gyro_delay_s == 0.0 {
            data.gyro[k]
        } else {
            interpolate(&data.t, &data.gyro, data.t[k] + self.gyro_delay_s)
        };
        reading - self.gyro_drift_since_start(data, k)
    }

    /// The bias drift `ḃ (t_k − t_0)` at tick `k`, rad/s.
    pub fn gyro_drift_since_start(&self, data: &Aligned, k: usize) -> Vector3<f64> {
        self.gyro_bias_drift * (data.t[k] - data.t[0])
    }

    /// Body rate relative to L plus the (scaled) bias: `S⁻¹ w_meas − A(q) Ω_L`, rad/s.
    pub fn correct_gyro(&self, w_meas: &Vector3<f64>, q: &Attitude) -> Vector3<f64> {
        self.gyro_matrix_inv * w_meas - q * self.earth_rate_l
    }

    /// The noise-free gyro reading at body rate `w` (rad/s), attitude `q` and corrected-frame
    /// bias `bias` (the filter's estimate): `S (w + A Ω_L + bias)`.
    pub fn gyro_reading(
        &self,
        w: &Vector3<f64>,
        q: &Attitude,
        bias: &Vector3<f64>,
    ) -> Vector3<f64> {
        self.gyro_matrix * (w + q * self.earth_rate_l + bias)
    }

    /// The tilt reading `[θ, φ]` (rad) with the mounting offset, the scale error and the
    /// cross-axis coupling taken out, `G⁻¹ (r − b)`, and the lag made up: the angles' change
    /// from the attitude the lag earlier to `q`, at body rate `w` (the filter's estimates when
    /// the sample is applied).
    pub fn correct_tilt(&self, tilt: &[f64; 2], q: &Attitude, w: &Vector3<f64>) -> [f64; 2] {
        let offset = Vector2::from(self.tilt_offset_rad);
        let corrected: [f64; 2] = (self.tilt_matrix_inv * (Vector2::from(*tilt) - offset)).into();
        if self.tilt_lag_s == 0.0 {
            return corrected;
        }
        let (now, then) = (
            attitude::tilt_angles(q),
            attitude::tilt_angles(&attitude::lagged(q, w, self.tilt_lag_s)),
        );
        std::array::from_fn(|i| corrected[i] + now[i] - then[i])
    }

    /// The noise-free tilt reading at attitude `q` and body rate `w`, rad.
    pub fn tilt_reading(&self, q: &Attitude, w: &Vector3<f64>) -> [f64; 2] {
        let tilt = attitude::tilt_angles(&attitude::lagged(q, w, self.tilt_lag_s));
        let reading = self.tilt_matrix * Vector2::from(tilt) + Vector2::from(self.tilt_offset_rad);
        reading.into()
    }

    /// The field reading `m` (tesla, body axes) with the hard iron and the fitted field error
    /// at attitude `q` (the filter's estimate when the sample is applied) taken out, then the
    /// soft iron undone, tesla: `(1 + S)⁻¹ (m − M_hard − ΔM(q))`.
    ///
    /// With a lag, the reading is of the attitude the lag earlier at body rate `w`: the errors
    /// are those of that attitude, and the field it gives is turned on to `q`.
    pub fn correct_field(&self, m: &Vector3<f64>, q: &Attitude, w: &Vector3<f64>) -> Vector3<f64> {
        let then = attitude::lagged(q, w, self.field_lag_s);
        let corrected =
            self.soft_iron_inv * (m - self.hard_iron_t - self.fitted_field.error_t(&then));
        if self.field_lag_s == 0.0 {
            return corrected;
        }
        (q * then.inverse()) * corrected
    }

    /// The noise-free field reading at attitude `q` and body rate `w`, tesla.
    pub fn field_reading(&self, q: &Attitude, w: &Vector3<f64>) -> Vector3<f64> {
        let then = attitude::lagged(q, w, self.field_lag_s);
        self.soft_iron * (then * self.field_l_t)
            + self.hard_iron_t
            + self.fitted_field.error_t(&then)
    }
}

/// One vector update of the filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Innovation {
    /// Tick at which the update was applied (the first tick at or after the sample).
    pub tick: usize,
    /// Whitened innovation `[g_t1, g_t2, m_x, m_y, m_z]` (N(0, 1) each for a consistent filter).
    pub values: [f64; INNOVATION_LEN],
    /// Bit i set: component i present.
    pub mask: u8,
    /// The field block's raw residual, corrected reading minus the reading predicted from the
    /// prior attitude, tesla, body axes (zero without a field sample).
    pub field_residual_t: Vector3<f64>,
}

/// The filter's estimates on the data's ticks.
#[derive(Debug, Clone)]
pub struct Reconstruction {
    /// The runs of ticks with estimates of their own, in time order: from the filter's start to
    /// the first break in the record ([`Aligned::breaks`]), and from each restart after a break
    /// to the next. Ticks before the start repeat the first estimate, and the ticks between a
    /// break and its restart the restart's.
    pub spans: Vec<std::ops::Range<usize>>,
    /// Attitude estimate per tick, L→B.
    pub q: Vec<Attitude>,
    /// Bias estimate per tick (of the corrected readings), rad/s.
    pub bias: Vec<Vector3<f64>>,
    /// Body rate per tick: corrected reading minus bias, rad/s, body axes (one sample's noise).
    pub rate: Vec<Vector3<f64>>,
    /// Vector updates in time order.
    pub innovations: Vec<Innovation>,
}

/// The filter's configuration for identification: the model's noises and field, gating off (the
/// innovations must be a smooth function of the fitted parameters) and one linearisation per
/// update. With soft iron the field noise is that of the corrected readings (see
/// [`corrected_field_sigma_t`]).
pub fn filter_config(config: &ModelConfig) -> MekfConfig {
    let mut c = MekfConfig::from_model(config);
    c.gate_enabled = false;
    c.max_update_iterations = 1;
    c.max_measurement_lag_s = 1.0 / config.gyro.rate_hz.max(1e-3);
    if config.effects.soft_iron.is_some() {
        let inv = SensorModel::from_config(config).soft_iron_inv;
        c.magnetometer_sigma_t = corrected_field_sigma_t(&inv, &c.magnetometer_sigma_t);
    }
    c
}

/// Noise per axis of readings corrected for soft iron, `(1 + S)⁻¹ m`: axis i has
/// `sqrt(Σ_j (1 + S)⁻¹_ij² σ_j²)`, tesla (the correlation between axes it brings is left out,
/// second order in `S`). Without it the whitened innovations would shrink as `S` grows and a
/// fit that minimises their sum would be pulled towards larger `S`: by `n σ_S²` per diagonal
/// entry, `n` field samples and `σ_S` the entry's standard error (2.5e-3, two standard errors,
/// for `S_zz` beside a hard iron in 600 s).
pub fn corrected_field_sigma_t(inv: &Matrix3<f64>, sigma_t: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| {
        (0..3)
            .map(|j| (inv[(i, j)] * sigma_t[j]).powi(2))
            .sum::<f64>()
            .sqrt()
    })
}

fn t_ns(t: f64) -> u64 {
    (t.max(0.0) * 1e9).round() as u64
}

/// Run the filter over the record with the sensor model of `config`.
pub fn reconstruct(data: &Aligned, config: &ModelConfig) -> Result<Reconstruction, IdentError> {
    run(data, config, None)
}

/// [`reconstruct`], and the whitened innovations' sensitivities to the sensor parameters of the
/// directions: each a configuration with one parameter stepped from `config`'s, and the step
/// ([`Tangent`]). Per innovation of the reconstruction, per direction, the change of its values
/// per unit of the parameter.
pub fn reconstruct_with_sensitivities(
    data: &Aligned,
    config: &ModelConfig,
    directions: &[(ModelConfig, f64)],
) -> Result<(Reconstruction, Sensitivities), IdentError> {
    let mut tangent = Tangent::new(
        directions
            .iter()
            .map(|(c, step)| (SensorModel::from_config(c), *step))
            .collect(),
    );
    let recon = run(data, config, Some(&mut tangent))?;
    debug_assert_eq!(tangent.innovations.len(), recon.innovations.len());
    Ok((recon, tangent.innovations))
}

/// Propagate the filter (and the tangent beside it) to `t_ns` with the gyro sample `w`.
fn propagate(
    f: &mut Mekf,
    t_ns: u64,
    w: &Vector3<f64>,
    tangent: Option<&mut Tangent>,
    rate: Rate,
) -> Result<(), IdentError> {
    if let Some(tangent) = tangent {
        let dt_s = t_ns.saturating_sub(f.time_ns()) as f64 / 1e9;
        tangent.propagate(&(w - f.bias()), dt_s, rate);
    }
    f.propagate(t_ns, w)?;
    Ok(())
}

/// The filter over the record with the sensor model of `config`, and `tangent` (if any)
/// carried beside it.
fn run(
    data: &Aligned,
    config: &ModelConfig,
    mut tangent: Option<&mut Tangent>,
) -> Result<Reconstruction, IdentError> {
    let sensors = SensorModel::from_config(config);
    let filter_cfg = filter_config(config);
    let n = data.len();
    let tilt_range = config.inclinometer.range_deg * DEG - 1e-9;
    let field_range = config.magnetometer.range_gauss * GAUSS - 1e-12;
    let has_tilt = !data.tilt.is_empty();
    let has_field = !data.field.is_empty();
    let pair_window_s = start_pair_window_s(data);
    // Thruster pulses inside the interval up to tick k (see `ThrusterHistory::intra_tick_rate`),
    // at nominal thrust and inertia: a filter run depends on the sensor causes only.
    let thrusters = ThrusterHistory::new(data, config);
    let inertia_inv = config.platform.inertia().and_then(|j| j.try_inverse());
    let intra_tick_rate = |k: usize| match (&thrusters, &inertia_inv) {
        (Some(h), Some(j_inv)) if k > 0 => {
            h.intra_tick_rate(k - 1, data.t[k] - data.t[k - 1], j_inv)
        }
        _ => Vector3::zeros(),
    };
    // Before the filter starts: the latest usable sample of each vector sensor (time, value).
    let mut latest_tilt: Option<(f64, [f64; 2])> = None;
    let mut latest_field: Option<(f64, Vector3<f64>)> = None;

    let mut mekf: Option<Mekf> = None;
    let mut q_prior = Attitude::identity();
    let mut out = Reconstruction {
        spans: Vec::new(),
        q: Vec::with_capacity(n),
        bias: Vec::with_capacity(n),
        rate: Vec::with_capacity(n),
        innovations: Vec::with_capacity(data.tilt.len().max(data.field.len())),
    };
    let initial_bias = Vector3::from(filter_cfg.initial_bias_rad_s);
    let (mut i_tilt, mut i_field) = (0usize, 0usize);
    let mut previous: Option<Vector3<f64>> = None;
    // The span under way: its first tick.
    let mut span_start: Option<usize> = None;
    // The bias at the last break: the gyro's, which a silence does not change.
    let mut carried_bias: Option<Vector3<f64>> = None;
    let mut breaks = data.breaks.iter().copied().peekable();
    for k in 0..n {
        let tk = data.t[k];
        // A break: what the filter knew does not carry over it. It starts again from the
        // vector sensors, as at the record's start.
        if breaks.next_if_eq(&k).is_some() {
            if let Some(f) = mekf.take() {
                q_prior = f.attitude();
                carried_bias = Some(f.bias());
            }
            if let Some(first) = span_start.take() {
                out.spans.push(first..k);
            }
            latest_tilt = None;
            latest_field = None;
            // Vector samples in the silence have no rates to carry them to the restart: only
            // those of its last gyro period may start the filter.
            let from = tk - data.period_s;
            i_tilt += data.tilt[i_tilt..].partition_point(|s| s.0 < from - 1e-6);
            i_field += data.field[i_field..].partition_point(|s| s.0 < from - 1e-6);
        }
        let q_now = mekf.as_ref().map_or(q_prior, Mekf::attitude);
        let w = sensors.correct_gyro(&sensors.gyro_of_tick(data, k), &q_now);
        if let Some(t) = tangent.as_deref_mut() {
            t.gyro(data, k, &q_now, &w);
        }
        let mean = previous.map_or(w, |p| 0.5 * (p + w) + intra_tick_rate(k));
        previous = Some(w);
        // Vector samples up to this tick, grouped by time.
        loop {
            let next_tilt = data
                .tilt
                .get(i_tilt)
                .map(|s| s.0)
                .filter(|t| *t <= tk + 1e-6);
            let next_field = data
                .field
                .get(i_field)
                .map(|s| s.0)
                .filter(|t| *t <= tk + 1e-6);
            let t_sample = match (next_tilt, next_field) {
                (None, None) => break,
                (Some(a), None) => a,
                (None, Some(b)) => b,
                (Some(a), Some(b)) => a.min(b),
            };
            // A vector sample between two gyro ticks (a lost gyro row, jitter in the time
            // stamps) is applied at its own time: attached to the next tick it could be older
            // than the filter's state by more than the filter accepts.
            if let Some(f) = mekf.as_mut() {
                let at = if tk - t_sample <= 1e-6 { tk } else { t_sample };
                if t_ns(at) > f.time_ns() {
                    propagate(f, t_ns(at), &mean, tangent.as_deref_mut(), Rate::Mean)?;
                }
            }
            let mut meas = VectorMeasurements::default();
            let (mut raw_tilt, mut raw_field) = (None, None);
            if let Some(&(_, tilt)) = data
                .tilt
                .get(i_tilt)
                .filter(|s| (s.0 - t_sample).abs() <= 1e-6)
            {
                i_tilt += 1;
                if tilt[0].abs() < tilt_range && tilt[1].abs() < tilt_range {
                    let (q_now, rate) = estimate(&mekf, &q_prior, &w, &initial_bias);
                    meas.tilt_rad = Some(sensors.correct_tilt(&tilt, &q_now, &rate));
                    raw_tilt = Some((tilt, q_now, rate));
                }
            }
            if let Some(&(_, field)) = data
                .field
                .get(i_field)
                .filter(|s| (s.0 - t_sample).abs() <= 1e-6)
            {
                i_field += 1;
                if field.iter().all(|x| x.abs() < field_range) {
                    let (q_now, rate) = estimate(&mekf, &q_prior, &w, &initial_bias);
                    meas.field_b_t = Some(sensors.correct_field(&field, &q_now, &rate));
                    raw_field = Some((field, q_now, rate));
                }
            }
            if t_sample < -1e-9 || (meas.tilt_rad.is_none() && meas.field_b_t.is_none()) {
                continue;
            }
            match mekf.as_mut() {
                Some(f) => {
                    if let Some(t) = tangent.as_deref_mut() {
                        t.readings(
                            raw_tilt.as_ref().map(|(t, q, w)| (t, q, w)),
                            raw_field.as_ref().map(|(m, q, w)| (m, q, w)),
                            &meas,
                        );
                    }
                    let report = f.update(t_ns(t_sample), &meas)?;
                    let changes = tangent
                        .as_deref_mut()
                        .map(|t| t.update(f.last_linearisation()));
                    let (values, mask) = report.whitened_array();
                    // [g_t1, g_t2, (radial), m_x, m_y, m_z] → 5 components.
                    let v = [values[0], values[1], values[3], values[4], values[5]];
                    let m = (mask & 0b11) as u8 | (((mask >> 3) & 0b111) as u8) << 2;
                    if m != 0 {
                        let field_residual_t = report
                            .magnetic
                            .stats
                            .as_ref()
                            .map_or_else(Vector3::zeros, |s| s.residual);
                        out.innovations.push(Innovation {
                            tick: k,
                            values: v,
                            mask: m,
                            field_residual_t,
                        });
                        if let (Some(t), Some(changes)) = (tangent.as_deref_mut(), changes) {
                            t.innovations.push(changes);
                        }
                    }
                }
                None => {
                    latest_tilt = meas.tilt_rad.map(|x| (t_sample, x)).or(latest_tilt);
                    latest_field = meas.field_b_t.map(|x| (t_sample, x)).or(latest_field);
                    // Devices with their own clocks do not sample at the same instants: a tilt
                    // and a field sample close enough in time make the starting pair.
                    let mut start = meas;
                    if let (Some((ta, tilt)), Some((tb, field))) = (latest_tilt, latest_field)
                        && (ta - tb).abs() <= pair_window_s
                    {
                        start.tilt_rad = Some(tilt);
                        start.field_b_t = Some(field);
                    }
                    let mut cfg = filter_cfg.clone();
                    if let Some(b) = carried_bias {
                        cfg.initial_bias_rad_s = b.into();
                    }
                    if let Some(f) =
                        start_filter(&cfg, t_ns(t_sample), &start, &sensors, has_tilt, has_field)
                    {
                        let mut f = f;
                        if let Some(t) = tangent.as_deref_mut() {
                            match carried_bias {
                                Some(_) => t.restart(),
                                None => t.start(),
                            }
                        }
                        propagate(&mut f, t_ns(tk), &w, tangent.as_deref_mut(), Rate::Current)?;
                        q_prior = f.attitude();
                        mekf = Some(f);
                        span_start = Some(k);
                    }
                }
            }
        }
        if let Some(f) = mekf.as_mut()
            && t_ns(tk) > f.time_ns()
        {
            propagate(f, t_ns(tk), &mean, tangent.as_deref_mut(), Rate::Mean)?;
        }
        match mekf.as_ref() {
            Some(f) => {
                out.q.push(f.attitude());
                out.bias.push(f.bias());
                out.rate.push(w - f.bias());
            }
            None => {
                out.q.push(q_prior);
                let b = Vector3::from(filter_cfg.initial_bias_rad_s);
                out.bias.push(b);
                out.rate.push(w - b);
            }
        }
    }
    if let Some(first) = span_start {
        out.spans.push(first..n);
    }
    // Ticks before the start repeat the first estimate, and those after a break its restart's.
    let waits: Vec<(usize, usize)> = std::iter::once((0, out.start()))
        .chain(out.spans.windows(2).map(|w| (w[0].end, w[1].start)))
        .collect();
    for (from, to) in waits.into_iter().filter(|&(_, to)| to < n) {
        let (q0, b0) = (out.q[to], out.bias[to]);
        for k in from..to {
            out.q[k] = q0;
            out.bias[k] = b0;
            out.rate[k] = sensors.correct_gyro(&sensors.gyro_of_tick(data, k), &q0) - b0;
        }
    }
    Ok(out)
}

/// The attitude and body rate the filter estimates (before it starts: the prior attitude and
/// the initial bias), `w` the corrected gyro reading.
fn estimate(
    mekf: &Option<Mekf>,
    q_prior: &Attitude,
    w: &Vector3<f64>,
    initial_bias: &Vector3<f64>,
) -> (Attitude, Vector3<f64>) {
    match mekf {
        Some(f) => (f.attitude(), w - f.bias()),
        None => (*q_prior, w - initial_bias),
    }
}

/// How far apart in time a tilt and a field sample may be to start the filter as a pair, s: the
/// longer of the two sensors' median sample intervals (at least 1 µs, the tolerance of
/// samples taken together). At the start of a record the platform turns at most a few mrad/s,
/// so the pair's attitude is off by well under a milliradian, which the filter's initial
/// covariance covers.
fn start_pair_window_s(data: &Aligned) -> f64 {
    let tilt = median_period(data.tilt.iter().map(|s| s.0));
    let field = median_period(data.field.iter().map(|s| s.0));
    tilt.max(field).max(1e-6)
}

/// Start the filter from the first usable vector samples: TRIAD from a tilt and field pair;
/// with only one kind of vector sensor in the record, the shortest rotation that explains it.
fn start_filter(
    cfg: &MekfConfig,
    t: u64,
    meas: &VectorMeasurements,
    sensors: &SensorModel,
    has_tilt: bool,
    has_field: bool,
) -> Option<Mekf> {
    let gravity = meas
        .tilt_rad
        .and_then(|[a, b]| attitude::gravity_from_tilt(a, b));
    match (gravity, meas.field_b_t) {
        (Some(g), Some(m)) => Mekf::initialise_from_vectors(cfg.clone(), t, &g, &m).ok(),
        (Some(g), None) if !has_field => {
            let q = UnitQuaternion::rotation_between(&attitude::gravity_l(), &g)?;
            Mekf::new(cfg.clone(), t, q).ok()
        }
        (None, Some(m)) if !has_tilt => {
            let q = UnitQuaternion::rotation_between(&sensors.field_l_t, &m)?;
            Mekf::new(cfg.clone(), t, q).ok()
        }
        _ => None,
    }
}

impl Reconstruction {
    /// The first tick with an estimate (the filter's start); the record's length if the filter
    /// never started.
    pub fn start(&self) -> usize {
        self.spans.first().map_or(self.q.len(), |s| s.start)
    }

    /// The span of ticks with estimates of their own that holds tick `k`, if one does.
    pub fn span_of(&self, k: usize) -> Option<std::ops::Range<usize>> {
        let i = self.spans.partition_point(|s| s.end <= k);
        self.spans.get(i).filter(|s| s.contains(&k)).cloned()
    }

    /// Whitened innovation components of the updates on the ticks `keep` accepts, flattened
    /// (present components only), for fits.
    pub fn innovation_vector(&self, keep: impl Fn(usize) -> bool) -> Vec<f64> {
        let mut v = Vec::with_capacity(self.innovations.len() * INNOVATION_LEN);
        v.extend(self.innovation_rows(keep).map(|(_, v)| v));
        v
    }

    /// The tick of each row of [`Reconstruction::innovation_vector`] with the same `keep`.
    pub fn innovation_ticks(&self, keep: impl Fn(usize) -> bool) -> Vec<usize> {
        self.innovation_rows(keep).map(|(tick, _)| tick).collect()
    }

    /// The rows of [`Reconstruction::innovation_vector`] with the same `keep` of each direction
    /// of `sensitivities` (of this run, [`reconstruct_with_sensitivities`]): its Jacobian
    /// columns.
    pub fn sensitivity_columns(
        &self,
        sensitivities: &Sensitivities,
        directions: usize,
        keep: impl Fn(usize) -> bool + Copy,
    ) -> Vec<Vec<f64>> {
        (0..directions)
            .map(|j| {
                self.present(keep)
                    .map(|(i, c)| sensitivities[i][j][c])
                    .collect()
            })
            .collect()
    }

    /// `(tick, value)` of each present component of the innovations whose tick `keep` accepts.
    fn innovation_rows(&self, keep: impl Fn(usize) -> bool) -> impl Iterator<Item = (usize, f64)> {
        self.present(keep)
            .map(|(i, c)| (self.innovations[i].tick, self.innovations[i].values[c]))
    }

    /// `(innovation, component)` of each present component of the innovations whose tick
    /// `keep` accepts: the rows of the fits.
    fn present(&self, keep: impl Fn(usize) -> bool) -> impl Iterator<Item = (usize, usize)> {
        self.innovations
            .iter()
            .enumerate()
            .filter(move |(_, i)| keep(i.tick))
            .flat_map(|(n, i)| {
                (0..INNOVATION_LEN)
                    .filter(move |c| i.mask & (1 << c) != 0)
                    .map(move |c| (n, c))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With the inclinometer's offset, scale and cross-axis coupling configured, taking them out
    /// of the noise-free reading gives back the attitude's tilt angles.
    #[test]
    fn correcting_the_tilt_reading_undoes_offset_scale_and_coupling() {
        let config = ModelConfig::from_toml_str(
            "[effects.inclinometer_bias]\noffset_rad = [0.002, -0.001]\n\
             [effects.inclinometer_scale]\nppm = [2e4, -1e4]\n\
             [effects.inclinometer_cross_axis]\ncoupling = [0.03, -0.01]\n",
            "test",
        )
        .expect("valid");
        let sensors = SensorModel::from_config(&config);
        let q = attitude::from_heading_pitch_roll(0.7, 0.08, -0.05);
        let tilt = attitude::tilt_angles(&q);
        let reading = sensors.tilt_reading(&q, &Vector3::zeros());
        // The reading as the simulator's inclinometer forms it, noise aside.
        let want = [
            1.02 * tilt[0] + 0.03 * tilt[1] + 0.002,
            0.99 * tilt[1] - 0.01 * tilt[0] - 0.001,
        ];
        for i in 0..2 {
            assert!(
                (reading[i] - want[i]).abs() < 1e-15,
                "{reading:?} against {want:?}"
            );
        }
        let back = sensors.correct_tilt(&reading, &q, &Vector3::zeros());
        for i in 0..2 {
            assert!(
                (back[i] - tilt[i]).abs() < 1e-15,
                "{back:?} against {tilt:?}"
            );
        }
    }

    /// With hard and soft iron configured, taking them out of the noise-free reading gives back
    /// the lab field in body axes.
    #[test]
    fn correcting_the_field_reading_undoes_hard_and_soft_iron() {
        let config = ModelConfig::from_toml_str(
            "[effects.soft_iron]\nmatrix = [[0.03, 0.02, 0.01], [0.02, -0.03, 0.0], [0.01, 0.0, 0.02]]\n\
             [effects.magnetic_disturbance]\nhard_iron_gauss = [0.08, -0.05, 0.1]\n",
            "test",
        )
        .expect("valid");
        let sensors = SensorModel::from_config(&config);
        let q = attitude::from_heading_pitch_roll(0.7, 0.1, -0.05);
        let reading = sensors.field_reading(&q, &Vector3::zeros());
        let body = q * config.platform.field_l_t();
        assert!((reading - body).norm() > 1e-6);
        assert!((sensors.correct_field(&reading, &q, &Vector3::zeros()) - body).norm() < 1e-18);
    }
}
