//! Simulated truth for the filter's tests, generated independently of the device models: exact
//! kinematics ([`attitude::propagate`] at 10 sub-steps per gyro period), gyro samples as the mean
//! rate over the period plus bias plus white noise of 1σ `σv/sqrt(Δt)` (the sample noise that
//! the density `σv` implies), a bias random walk of `σu sqrt(Δt)` per period, inclinometer
//! angles with N(0, σ) noise and magnetometer vectors with N(0, σ) per axis (tesla, body axes),
//! all from the default model configuration. Gyro at 10 Hz, vector samples at 2.5 Hz; times in
//! nanoseconds.

use super::{Mekf, MekfConfig, NS_PER_S, UpdateReport, VectorMeasurements};
use nalgebra::{Matrix6, Vector3, Vector6};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;
use testbed_model::attitude::{self, Attitude};
use testbed_model::config::{DEG, ModelConfig};

pub(super) const GYRO_PERIOD_NS: u64 = 100_000_000; // 10 Hz
pub(super) const UPDATE_EVERY: u64 = 4; // 2.5 Hz vector samples
pub(super) const SUBSTEPS: u32 = 10;

pub(super) fn model() -> ModelConfig {
    ModelConfig::default()
}

pub(super) fn config() -> MekfConfig {
    MekfConfig::from_model(&model())
}

pub(super) fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

pub(super) fn normal3(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    Vector3::new(normal(rng), normal(rng), normal(rng))
}

/// Truth body rate, rad/s: slow sinusoids about X and Y (tilt excursions of about ±0.7°) and
/// a slow constant turn about Z (0.3 °/s).
pub(super) fn true_rate(t_s: f64) -> Vector3<f64> {
    Vector3::new(
        0.1 * (2.0 * PI * t_s / 40.0).sin(),
        0.08 * (2.0 * PI * t_s / 55.0).cos(),
        0.3,
    ) * DEG
}

pub(super) struct Truth {
    pub(super) q: Attitude,
    pub(super) bias: Vector3<f64>,
    pub(super) t_ns: u64,
    pub(super) rng: ChaCha8Rng,
    pub(super) sigma_v: Vector3<f64>,
    pub(super) sigma_u: Vector3<f64>,
    pub(super) sigma_tilt: [f64; 2],
    pub(super) sigma_m: Vector3<f64>,
    pub(super) field_l: Vector3<f64>,
}

impl Truth {
    pub(super) fn new(seed: u64, q: Attitude) -> Self {
        let m = model();
        Self {
            q,
            bias: m.gyro.bias_rad_s(),
            t_ns: 0,
            rng: ChaCha8Rng::seed_from_u64(seed),
            sigma_v: m.gyro.noise_density_rad_sqrt_s(),
            sigma_u: m.gyro.bias_walk_rad_s32(),
            sigma_tilt: m.inclinometer.noise_rad(),
            sigma_m: m.magnetometer.noise_t(),
            field_l: m.platform.field_l_t(),
        }
    }

    /// One gyro period of exact kinematics; returns the sample at its end.
    pub(super) fn gyro_step(&mut self) -> (u64, Vector3<f64>) {
        let dt = GYRO_PERIOD_NS as f64 / NS_PER_S;
        let h = dt / SUBSTEPS as f64;
        let t0 = self.t_ns as f64 / NS_PER_S;
        let mut sum = Vector3::zeros();
        for k in 0..SUBSTEPS {
            let w = true_rate(t0 + (k as f64 + 0.5) * h);
            self.q = attitude::propagate(&self.q, &w, h);
            sum += w;
        }
        let mean = sum / SUBSTEPS as f64;
        let noise = self.sigma_v.component_mul(&normal3(&mut self.rng)) / dt.sqrt();
        let sample = mean + self.bias + noise;
        self.bias += self.sigma_u.component_mul(&normal3(&mut self.rng)) * dt.sqrt();
        self.t_ns += GYRO_PERIOD_NS;
        (self.t_ns, sample)
    }

    /// Noisy inclinometer and magnetometer samples at the current truth.
    pub(super) fn vectors(&mut self) -> VectorMeasurements {
        let [theta, phi] = attitude::tilt_angles(&self.q);
        let tilt = [
            theta + self.sigma_tilt[0] * normal(&mut self.rng),
            phi + self.sigma_tilt[1] * normal(&mut self.rng),
        ];
        let field = self.q * self.field_l + self.sigma_m.component_mul(&normal3(&mut self.rng));
        VectorMeasurements {
            tilt_rad: Some(tilt),
            field_b_t: Some(field),
        }
    }
}

/// Error state truth − estimate `[δθ (rad), δb (rad/s)]`, the filter's definition.
pub(super) fn error(truth: &Truth, f: &Mekf) -> Vector6<f64> {
    let dth = attitude::attitude_error(&truth.q, &f.attitude());
    let db = truth.bias - f.bias();
    Vector6::new(dth.x, dth.y, dth.z, db.x, db.y, db.z)
}

pub(super) fn nees(e: &Vector6<f64>, p: &Matrix6<f64>) -> f64 {
    let chol = p
        .cholesky()
        .expect("filter covariance is positive definite");
    e.dot(&chol.solve(e))
}

pub(super) struct Record {
    pub(super) t_s: f64,
    pub(super) err: Vector6<f64>,
    pub(super) p: Matrix6<f64>,
    pub(super) report: UpdateReport,
}

/// Run the filter against the truth for `duration_s`, gyro at 10 Hz, vectors at 2.5 Hz
/// (gyro sample first at coinciding times); `tamper(i, m)` may alter the i-th vector sample.
pub(super) fn run(
    truth: &mut Truth,
    f: &mut Mekf,
    duration_s: f64,
    mut tamper: impl FnMut(usize, &mut VectorMeasurements),
) -> Vec<Record> {
    let steps = (duration_s * 10.0).round() as u64;
    let mut out = Vec::new();
    for k in 1..=steps {
        let (t, w) = truth.gyro_step();
        f.propagate(t, &w).expect("in-order gyro sample");
        if k % UPDATE_EVERY == 0 {
            let mut m = truth.vectors();
            tamper(out.len(), &mut m);
            let report = f.update(t, &m).expect("timely vector sample");
            out.push(Record {
                t_s: t as f64 / NS_PER_S,
                err: error(truth, f),
                p: f.covariance(),
                report,
            });
        }
    }
    out
}

/// A filter started from TRIAD on the truth's first noisy vector samples.
pub(super) fn triad_start(truth: &mut Truth, cfg: MekfConfig) -> Mekf {
    let m = truth.vectors();
    let [theta, phi] = m.tilt_rad.expect("tilt present");
    let g = attitude::gravity_from_tilt(theta, phi).expect("tilt in domain");
    let field = m.field_b_t.expect("field present");
    Mekf::initialise_from_vectors(cfg, truth.t_ns, &g, &field).expect("TRIAD start")
}

/// Root mean square of component `i` of the errors and mean 1σ of the covariance over the
/// records after `t_from_s`.
pub(super) fn rms_and_sigma(log: &[Record], t_from_s: f64, i: usize) -> (f64, f64) {
    let tail: Vec<&Record> = log.iter().filter(|r| r.t_s >= t_from_s).collect();
    let n = tail.len() as f64;
    let rms = (tail.iter().map(|r| r.err[i] * r.err[i]).sum::<f64>() / n).sqrt();
    let sigma = (tail.iter().map(|r| r.p[(i, i)]).sum::<f64>() / n).sqrt();
    (rms, sigma)
}
