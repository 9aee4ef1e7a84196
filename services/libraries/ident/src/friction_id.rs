//! Reaction wheel friction identification from spin-down tests (paper eq. 3–5).
//!
//! Friction model (eq. 3): `T_f(n) = T_f0 sign(n) + K n`, n the wheel speed relative to the
//! platform (rad/s). In a spin-down the wheel is run up to ±6000 rpm and left to coast with zero
//! motor torque, so `J dn/dt = −T_f(n)`; while n keeps its sign this has the closed form
//!
//! `n(τ) = n0 e^{−Kτ/J} − sign(n0) T_f0 (1 − e^{−Kτ/J}) / K`,
//!
//! (= `(n0 + T_f0/K) e^{−Kτ/J} − T_f0/K` for n0 > 0) until the wheel stops.
//!
//! Three estimators are offered:
//!
//! * [`fit_spin_downs`] (recommended): nonlinear least squares of the closed-form coast curve
//!   to the measured speeds of all records jointly, `T_f0` and `K` shared, one initial speed per
//!   record. With white tachometer noise this is the maximum-likelihood estimate, and its
//!   standard errors (`s² (JᵀJ)⁻¹` at the solution) are honest; it uses the speeds directly, so no
//!   information is lost to numerical differentiation.
//! * [`fit_torque_samples`]: the paper's eq. 5, a linear least-squares fit of `T_f0` and `K` to
//!   deceleration torques `T_j = −J dn/dt` at speeds `n_j` (from [`deceleration_torques`]).
//! * [`fit_viscous_given_coulomb`]: the paper's eq. 4, `K` alone with `T_f0` known from the
//!   static-friction test.
//!
//! The inertia `J` is the one that converts the measured deceleration into torque. On a free
//! platform the friction also accelerates the platform, so the speed relative to the platform
//! decays faster, by the factor `1 + J/I_axis` (2.5e-5 for the Z wheel); pass the effective
//! inertia `J I_axis / (J + I_axis)` if that matters.
//!
//! The standard errors assume the model is right and the noise white. Friction beyond eq. 3
//! (Stribeck spike near zero speed, direction asymmetry) shows up as systematic residuals, and
//! then the standard errors understate the error: inspect the residuals.

use nalgebra::{DMatrix, DVector, Matrix2, Vector2};

/// One spin-down record: samples of a wheel coasting with zero motor torque.
#[derive(Debug, Clone, Copy)]
pub struct SpinDown<'a> {
    /// Sample times, s, strictly increasing (any origin).
    pub time_s: &'a [f64],
    /// Measured wheel speed relative to the platform, rad/s, one per time.
    pub speed_rad_s: &'a [f64],
}

/// Settings of the identification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Each record is used from its start up to (not including) the first sample slower than
    /// this or of the opposite sign, rad/s. Keeps the standstill and the near-zero speeds, where
    /// eq. 3 is least true (Stribeck effect), out of the fit.
    pub min_speed_rad_s: f64,
    /// Length of the non-overlapping windows of [`deceleration_torques`], s.
    pub window_s: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        // 10 rad/s is 95 rpm, 1.6 % of the test speed. 10 s windows hold 100 samples at 10 Hz: a
        // slope good to ~1e-3 of the deceleration with the tachometer's noise, and over 40 windows
        // per spin-down.
        Self {
            min_speed_rad_s: 10.0,
            window_s: 10.0,
        }
    }
}

/// Deceleration torque at one speed, from a local fit of a window of a spin-down.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TorqueSample {
    /// Speed `n_j` at the centre of the window, rad/s.
    pub speed_rad_s: f64,
    /// Deceleration torque `T_j = −J dn/dt` at the centre of the window, Nm.
    pub torque_nm: f64,
}

/// Fitted friction of eq. 3, with 1σ standard errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionFit {
    /// Coulomb friction `T_f0`, Nm.
    pub coulomb_nm: f64,
    /// Viscous coefficient `K`, Nm/(rad/s).
    pub viscous_nm_per_rad_s: f64,
    /// Standard error of `T_f0`, Nm; 0 if `T_f0` was given rather than fitted.
    pub coulomb_stderr_nm: f64,
    /// Standard error of `K`, Nm/(rad/s).
    pub viscous_stderr: f64,
    /// Number of observations fitted: speed samples for [`fit_spin_downs`], torque samples for
    /// the torque-domain fits.
    pub n_samples: usize,
    /// RMS of the deceleration torques' residuals `T_j − T_f(n_j)` against the fitted friction,
    /// Nm (for [`fit_spin_downs`], over the windows of [`deceleration_torques`]; NaN if the
    /// records are too short for one window).
    pub residual_rms_nm: f64,
    /// RMS of the speed residuals of the coast-curve fit, rad/s ([`fit_spin_downs`] only).
    pub speed_residual_rms_rad_s: Option<f64>,
}

impl FrictionFit {
    /// Friction torque of the fitted model at wheel speed `speed_rad_s` (rad/s), Nm.
    pub fn torque_nm(&self, speed_rad_s: f64) -> f64 {
        friction_torque(speed_rad_s, self.coulomb_nm, self.viscous_nm_per_rad_s)
    }
}

/// Why an identification was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FrictionIdError {
    #[error("too few samples for {what}: {got}, need at least {needed}")]
    TooFewSamples {
        what: &'static str,
        got: usize,
        needed: usize,
    },
    #[error("record {record}: time does not increase strictly at sample {index}")]
    NonMonotonicTime { record: usize, index: usize },
    #[error("record {record}: sample {index} is not a finite number")]
    NotFinite { record: usize, index: usize },
    #[error("record {record}: {times} times but {speeds} speeds")]
    LengthMismatch {
        record: usize,
        times: usize,
        speeds: usize,
    },
    #[error("torque sample {index} is not a finite number")]
    NotFiniteSample { index: usize },
    #[error("{name} = {value}: must be a finite number > 0")]
    InvalidParameter { name: &'static str, value: f64 },
    #[error("the data cannot separate Coulomb from viscous friction (singular normal equations)")]
    Singular,
    #[error("the coast-curve fit did not converge in {iterations} iterations")]
    NoConvergence { iterations: usize },
}

/// Friction torque of eq. 3, Nm, at speed `speed_rad_s` (rad/s); zero at standstill.
pub fn friction_torque(speed_rad_s: f64, coulomb_nm: f64, viscous_nm_per_rad_s: f64) -> f64 {
    let sign = if speed_rad_s > 0.0 {
        1.0
    } else if speed_rad_s < 0.0 {
        -1.0
    } else {
        0.0
    };
    coulomb_nm * sign + viscous_nm_per_rad_s * speed_rad_s
}

/// The coast of eq. 3: wheel speed (rad/s) `t_s` seconds after coasting from `n0_rad_s`, with
/// friction `coulomb_nm`, `viscous_nm_per_rad_s` and rotor inertia `inertia_kgm2`; 0 once the
/// wheel has stopped (Coulomb friction holds it). The platform is taken as inertial.
pub fn coast_speed(
    n0_rad_s: f64,
    t_s: f64,
    coulomb_nm: f64,
    viscous_nm_per_rad_s: f64,
    inertia_kgm2: f64,
) -> f64 {
    let sign = n0_rad_s.signum();
    let n =
        CoastTerms::new(t_s, viscous_nm_per_rad_s, inertia_kgm2).speed(n0_rad_s, sign, coulomb_nm);
    if n * sign > 0.0 { n } else { 0.0 }
}

/// Deceleration torques `T_j = −J dn/dt` at speeds `n_j` over non-overlapping windows of
/// `options.window_s` of every record (each used down to `options.min_speed_rad_s`).
///
/// Each window gets a local quadratic fit about its mean time: the slope there is free of the
/// curvature's bias, and the speed is the fitted value at the same instant rather than the
/// window mean (which the curvature shifts). Disjoint windows keep the samples independent, and
/// only full windows (with ≥ 5 samples) are used, so that with regular sampling all samples have
/// the same variance: the unweighted fits of eq. 4–5 assume both. The record's last, partial
/// window is dropped; its few samples would give a slope an order of magnitude noisier.
pub fn deceleration_torques(
    records: &[SpinDown],
    inertia_kgm2: f64,
    options: &FitOptions,
) -> Result<Vec<TorqueSample>, FrictionIdError> {
    check_positive("inertia_kgm2", inertia_kgm2)?;
    check_options(options)?;
    let mut samples = Vec::new();
    for (r, record) in records.iter().enumerate() {
        let (t, n) = coasting_part(r, record, options.min_speed_rad_s)?;
        let mut start = 0;
        while start < t.len() {
            let end = start
                + t[start..]
                    .iter()
                    .take_while(|&&ti| ti < t[start] + options.window_s)
                    .count();
            let window = start..end;
            start = end;
            // `end == t.len()`: the record ran out before the window was full.
            if end == t.len() || window.len() < 5 {
                continue;
            }
            if let Some((speed, slope)) = local_quadratic(&t[window.clone()], &n[window]) {
                samples.push(TorqueSample {
                    speed_rad_s: speed,
                    torque_nm: -inertia_kgm2 * slope,
                });
            }
        }
    }
    Ok(samples)
}

/// Paper eq. 5: `T_f0` and `K` jointly by linear least squares of `T_j = T_f0 sign(n_j) + K n_j`.
/// Needs at least 3 samples, and speeds that separate the two terms (both directions, or a
/// spread of speeds in one).
pub fn fit_torque_samples(samples: &[TorqueSample]) -> Result<FrictionFit, FrictionIdError> {
    check_samples(samples, 3)?;
    let mut normal = Matrix2::zeros();
    let mut rhs = Vector2::zeros();
    for s in samples {
        let x = Vector2::new(sign(s.speed_rad_s), s.speed_rad_s);
        normal += x * x.transpose();
        rhs += x * s.torque_nm;
    }
    let inverse = invert_2x2(&normal)?;
    let beta = inverse * rhs;
    let (coulomb, viscous) = (beta[0], beta[1]);
    let rss = torque_rss(samples, coulomb, viscous);
    let n = samples.len();
    let s2 = rss / (n - 2) as f64;
    Ok(FrictionFit {
        coulomb_nm: coulomb,
        viscous_nm_per_rad_s: viscous,
        coulomb_stderr_nm: (s2 * inverse[(0, 0)]).sqrt(),
        viscous_stderr: (s2 * inverse[(1, 1)]).sqrt(),
        n_samples: n,
        residual_rms_nm: (rss / n as f64).sqrt(),
        speed_residual_rms_rad_s: None,
    })
}

/// Paper eq. 4: `K = Σ n_j (T_j − T_f0 sign n_j) / Σ n_j²` with `T_f0 = coulomb_nm` given (from
/// the static-friction test). Needs at least 2 samples, not all at standstill.
pub fn fit_viscous_given_coulomb(
    samples: &[TorqueSample],
    coulomb_nm: f64,
) -> Result<FrictionFit, FrictionIdError> {
    check_samples(samples, 2)?;
    if !coulomb_nm.is_finite() {
        return Err(FrictionIdError::InvalidParameter {
            name: "coulomb_nm",
            value: coulomb_nm,
        });
    }
    let sum_n2: f64 = samples.iter().map(|s| s.speed_rad_s.powi(2)).sum();
    if sum_n2 <= 0.0 {
        return Err(FrictionIdError::Singular);
    }
    let viscous = samples
        .iter()
        .map(|s| s.speed_rad_s * (s.torque_nm - coulomb_nm * sign(s.speed_rad_s)))
        .sum::<f64>()
        / sum_n2;
    let rss = torque_rss(samples, coulomb_nm, viscous);
    let n = samples.len();
    Ok(FrictionFit {
        coulomb_nm,
        viscous_nm_per_rad_s: viscous,
        coulomb_stderr_nm: 0.0,
        viscous_stderr: (rss / (n - 1) as f64 / sum_n2).sqrt(),
        n_samples: n,
        residual_rms_nm: (rss / n as f64).sqrt(),
        speed_residual_rms_rad_s: None,
    })
}

/// `T_f0` and `K` by nonlinear least squares of the closed-form coast curve to the measured
/// speeds of all `records` jointly (typically one + and one − spin-down), each record with its
/// own initial speed. `inertia_kgm2`: the wheel's rotor inertia J, kg m².
///
/// Levenberg–Marquardt from the eq. 5 estimate; converged when no parameter moves by more than
/// 1e-6 of its standard error. Standard errors: `s² (JᵀJ)⁻¹`, `s²` the residual variance with the
/// initial speeds counted as fitted parameters.
pub fn fit_spin_downs(
    records: &[SpinDown],
    inertia_kgm2: f64,
    options: &FitOptions,
) -> Result<FrictionFit, FrictionIdError> {
    check_positive("inertia_kgm2", inertia_kgm2)?;
    check_options(options)?;
    if records.is_empty() {
        return Err(FrictionIdError::TooFewSamples {
            what: "spin-down records",
            got: 0,
            needed: 1,
        });
    }
    let mut data = Vec::with_capacity(records.len());
    for (r, record) in records.iter().enumerate() {
        let (t, n) = coasting_part(r, record, options.min_speed_rad_s)?;
        if t.len() < 3 {
            return Err(FrictionIdError::TooFewSamples {
                what: "a coasting record above the minimum speed",
                got: t.len(),
                needed: 3,
            });
        }
        data.push(Record {
            t0: t[0],
            sign: sign(n[0]),
            t,
            n,
        });
    }
    let params = 2 + data.len();
    let n_obs: usize = data.iter().map(|d| d.t.len()).sum();
    if n_obs <= params {
        return Err(FrictionIdError::TooFewSamples {
            what: "the coast-curve fit",
            got: n_obs,
            needed: params + 1,
        });
    }

    let torques = deceleration_torques(records, inertia_kgm2, options)?;
    let mut theta = DVector::zeros(params);
    match fit_torque_samples(&torques) {
        Ok(fit) => {
            theta[0] = fit.coulomb_nm;
            theta[1] = fit.viscous_nm_per_rad_s;
        }
        Err(_) => {
            // Short records: start from pure Coulomb friction matching the mean deceleration.
            let decel: f64 = data
                .iter()
                .map(|d| (d.n[0] - d.n[d.n.len() - 1]).abs() / (d.t[d.t.len() - 1] - d.t0))
                .sum::<f64>()
                / data.len() as f64;
            theta[0] = inertia_kgm2 * decel;
        }
    }
    for (i, d) in data.iter().enumerate() {
        theta[2 + i] = d.n[0];
    }

    let (mut normal, mut gradient, mut cost) = normal_equations(&data, &theta, inertia_kgm2);
    let mut lambda = 1e-6;
    const MAX_ITERATIONS: usize = 200;
    let mut converged = false;
    for _ in 0..MAX_ITERATIONS {
        // Marquardt's scaling (damping ∝ diag(JᵀJ)) makes the step independent of the parameters'
        // wildly different units (Nm, Nm s/rad, rad/s).
        let mut damped = normal.clone();
        for k in 0..params {
            damped[(k, k)] *= 1.0 + lambda;
        }
        let Some(chol) = damped.cholesky() else {
            lambda *= 10.0;
            if lambda > 1e12 {
                return Err(FrictionIdError::Singular);
            }
            continue;
        };
        let step = chol.solve(&gradient);
        let candidate = &theta + &step;
        let (cand_normal, cand_gradient, cand_cost) =
            normal_equations(&data, &candidate, inertia_kgm2);
        if cand_cost.is_finite() && cand_cost <= cost {
            let s2 = (cost / (n_obs - params) as f64).max(f64::MIN_POSITIVE);
            // Step size in units of each parameter's conditional standard error sqrt(s² / A_kk),
            // which is at most its marginal one: the test is conservative.
            let small = (0..params).all(|k| step[k].abs() * (normal[(k, k)] / s2).sqrt() < 1e-6);
            let stalled = (0..params).all(|k| step[k].abs() <= 1e-15 * theta[k].abs());
            theta = candidate;
            (normal, gradient, cost) = (cand_normal, cand_gradient, cand_cost);
            lambda = (lambda * 0.1).max(1e-12);
            if small || stalled {
                converged = true;
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                // No descent left at any step length: the point is a minimum to working precision.
                converged = true;
                break;
            }
        }
    }
    if !converged {
        return Err(FrictionIdError::NoConvergence {
            iterations: MAX_ITERATIONS,
        });
    }

    let covariance = normal.try_inverse().ok_or(FrictionIdError::Singular)?;
    let s2 = cost / (n_obs - params) as f64;
    let (coulomb, viscous) = (theta[0], theta[1]);
    let residual_rms_nm = if torques.is_empty() {
        f64::NAN
    } else {
        (torque_rss(&torques, coulomb, viscous) / torques.len() as f64).sqrt()
    };
    Ok(FrictionFit {
        coulomb_nm: coulomb,
        viscous_nm_per_rad_s: viscous,
        coulomb_stderr_nm: (s2 * covariance[(0, 0)]).sqrt(),
        viscous_stderr: (s2 * covariance[(1, 1)]).sqrt(),
        n_samples: n_obs,
        residual_rms_nm,
        speed_residual_rms_rad_s: Some((cost / n_obs as f64).sqrt()),
    })
}

/// The coasting part of one record, validated.
struct Record<'a> {
    t0: f64,
    /// Direction of the coast, ±1.
    sign: f64,
    t: &'a [f64],
    n: &'a [f64],
}

/// `x/|x|`, and 0 for 0 (standstill carries no Coulomb friction in eq. 3).
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

fn check_positive(name: &'static str, value: f64) -> Result<(), FrictionIdError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(FrictionIdError::InvalidParameter { name, value })
    }
}

fn check_options(options: &FitOptions) -> Result<(), FrictionIdError> {
    check_positive("window_s", options.window_s)?;
    if !(options.min_speed_rad_s.is_finite() && options.min_speed_rad_s >= 0.0) {
        return Err(FrictionIdError::InvalidParameter {
            name: "min_speed_rad_s",
            value: options.min_speed_rad_s,
        });
    }
    Ok(())
}

fn check_samples(samples: &[TorqueSample], needed: usize) -> Result<(), FrictionIdError> {
    if samples.len() < needed {
        return Err(FrictionIdError::TooFewSamples {
            what: "torque samples",
            got: samples.len(),
            needed,
        });
    }
    for (index, s) in samples.iter().enumerate() {
        if !(s.speed_rad_s.is_finite() && s.torque_nm.is_finite()) {
            return Err(FrictionIdError::NotFiniteSample { index });
        }
    }
    Ok(())
}

/// Validate record `r` whole, then cut it where it first drops below `min_speed` or changes sign.
fn coasting_part<'a>(
    r: usize,
    record: &SpinDown<'a>,
    min_speed: f64,
) -> Result<(&'a [f64], &'a [f64]), FrictionIdError> {
    let (t, n) = (record.time_s, record.speed_rad_s);
    if t.len() != n.len() {
        return Err(FrictionIdError::LengthMismatch {
            record: r,
            times: t.len(),
            speeds: n.len(),
        });
    }
    for (index, (ti, ni)) in t.iter().zip(n).enumerate() {
        if !(ti.is_finite() && ni.is_finite()) {
            return Err(FrictionIdError::NotFinite { record: r, index });
        }
        if index > 0 && *ti <= t[index - 1] {
            return Err(FrictionIdError::NonMonotonicTime { record: r, index });
        }
    }
    let direction = n.first().map_or(0.0, |&n0| sign(n0));
    let len = n
        .iter()
        .take_while(|&&ni| ni * direction >= min_speed && ni * direction > 0.0)
        .count();
    Ok((&t[..len], &n[..len]))
}

/// Fit `n = a + b x + c x²`, x = t − mean(t); returns (a, b): speed and slope at the mean time.
/// `None` if the times do not span a parabola (cannot happen for ≥ 3 distinct times).
fn local_quadratic(t: &[f64], n: &[f64]) -> Option<(f64, f64)> {
    let tc = t.iter().sum::<f64>() / t.len() as f64;
    let mut normal = nalgebra::Matrix3::zeros();
    let mut rhs = nalgebra::Vector3::zeros();
    for (ti, ni) in t.iter().zip(n) {
        let x = ti - tc;
        let row = nalgebra::Vector3::new(1.0, x, x * x);
        normal += row * row.transpose();
        rhs += row * *ni;
    }
    let beta = normal.cholesky()?.solve(&rhs);
    Some((beta[0], beta[1]))
}

fn invert_2x2(m: &Matrix2<f64>) -> Result<Matrix2<f64>, FrictionIdError> {
    // Relative to the diagonal's scale, so the test is independent of the units' magnitudes.
    let det = m.determinant();
    if !(det.is_finite() && det > 1e-12 * m[(0, 0)] * m[(1, 1)]) {
        return Err(FrictionIdError::Singular);
    }
    m.try_inverse().ok_or(FrictionIdError::Singular)
}

fn torque_rss(samples: &[TorqueSample], coulomb: f64, viscous: f64) -> f64 {
    samples
        .iter()
        .map(|s| (s.torque_nm - friction_torque(s.speed_rad_s, coulomb, viscous)).powi(2))
        .sum()
}

/// The exponential terms of the coast curve at elapsed time τ, written with `expm1` so that
/// `K → 0` (pure Coulomb friction) is exact rather than 0/0.
struct CoastTerms {
    /// τ / J, s/(kg m²).
    tau_j: f64,
    /// e^{−x}, x = K τ / J.
    decay: f64,
    /// φ(x) = (1 − e^{−x}) / x, so `(1 − e^{−Kτ/J}) / K = (τ/J) φ`.
    phi: f64,
    /// φ'(x).
    dphi: f64,
}

impl CoastTerms {
    fn new(tau_s: f64, viscous: f64, inertia: f64) -> Self {
        let tau_j = tau_s / inertia;
        let x = viscous * tau_j;
        let (phi, dphi) = if x.abs() < 1e-3 {
            // Taylor series: the closed forms cancel catastrophically near 0.
            (
                1.0 - x / 2.0 + x * x / 6.0 - x * x * x / 24.0,
                -0.5 + x / 3.0 - x * x / 8.0 + x * x * x / 30.0,
            )
        } else {
            (-(-x).exp_m1() / x, ((-x).exp() * (1.0 + x) - 1.0) / (x * x))
        };
        Self {
            tau_j,
            decay: (-x).exp(),
            phi,
            dphi,
        }
    }

    /// n(τ) for initial speed `n0`, coast direction `sign`, Coulomb friction `coulomb`.
    fn speed(&self, n0: f64, sign: f64, coulomb: f64) -> f64 {
        n0 * self.decay - sign * coulomb * self.tau_j * self.phi
    }
}

/// JᵀJ, Jᵀr and rᵀr of the coast-curve fit at parameters `theta = [T_f0, K, n0_1, ...]`.
fn normal_equations(
    data: &[Record],
    theta: &DVector<f64>,
    inertia: f64,
) -> (DMatrix<f64>, DVector<f64>, f64) {
    let p = theta.len();
    let (coulomb, viscous) = (theta[0], theta[1]);
    let mut normal = DMatrix::zeros(p, p);
    let mut gradient = DVector::zeros(p);
    let mut cost = 0.0;
    for (i, d) in data.iter().enumerate() {
        let n0 = theta[2 + i];
        // Only three Jacobian columns are non-zero per row: T_f0, K and this record's n0.
        let cols = [0, 1, 2 + i];
        let mut block = nalgebra::Matrix3::zeros();
        let mut g = nalgebra::Vector3::zeros();
        for (ti, ni) in d.t.iter().zip(d.n) {
            let c = CoastTerms::new(ti - d.t0, viscous, inertia);
            let residual = ni - c.speed(n0, d.sign, coulomb);
            let row = nalgebra::Vector3::new(
                -d.sign * c.tau_j * c.phi,
                -n0 * c.tau_j * c.decay - d.sign * coulomb * c.tau_j * c.tau_j * c.dphi,
                c.decay,
            );
            block += row * row.transpose();
            g += row * residual;
            cost += residual * residual;
        }
        for a in 0..3 {
            gradient[cols[a]] += g[a];
            for b in 0..3 {
                normal[(cols[a], cols[b])] += block[(a, b)];
            }
        }
    }
    (normal, gradient, cost)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use testbed_model::config::{ModelConfig, RPM};
    use testbed_model::devices::WheelTachometer;

    /// A spin-down as the tachometer reports it: the analytic coast of eq. 3 from `n0`, sampled
    /// at the telemetry rate for `duration_s`, through the configured tachometer noise and
    /// resolution (0.1 rpm, 0.01 rpm).
    ///
    /// The platform is inertial here, so this is the exact model the fit assumes: cheap enough to
    /// repeat over many seeds.
    fn spin_down(
        config: &ModelConfig,
        seed: u64,
        n0: f64,
        duration_s: f64,
    ) -> (Vec<f64>, Vec<f64>) {
        let w = &config.wheels;
        let mut tach = WheelTachometer::new(config, seed);
        let dt = 1.0 / w.telemetry_rate_hz;
        let steps = (duration_s / dt).round() as usize;
        let mut time = Vec::with_capacity(steps + 1);
        let mut speed = Vec::with_capacity(steps + 1);
        for k in 0..=steps {
            let t = k as f64 * dt;
            let n = coast_speed(
                n0,
                t,
                w.coulomb_nm[0],
                w.viscous_nm_per_rad_s[0],
                w.inertia_kgm2,
            );
            time.push(t);
            speed.push(tach.sample(&Vector3::new(n, 0.0, 0.0)).x);
        }
        (time, speed)
    }

    fn both_directions(config: &ModelConfig, seed: u64) -> [(Vec<f64>, Vec<f64>); 2] {
        // 500 s covers the whole coast (the wheel stops after about 430 s) and some standstill.
        let n0 = config.wheels.max_speed_rpm * RPM;
        [
            spin_down(config, seed, n0, 500.0),
            spin_down(config, seed + 1, -n0, 500.0),
        ]
    }

    fn records(data: &[(Vec<f64>, Vec<f64>)]) -> Vec<SpinDown<'_>> {
        data.iter()
            .map(|(t, n)| SpinDown {
                time_s: t,
                speed_rad_s: n,
            })
            .collect()
    }

    fn check(label: &str, estimate: f64, stderr: f64, truth: f64) {
        let rel = estimate / truth - 1.0;
        let z = (estimate - truth) / stderr;
        println!(
            "{label}: {estimate:.6e} ± {stderr:.2e} (truth {truth:.3e}): error {rel:+.2e}, {z:+.2} stderr"
        );
        assert!(rel.abs() < 0.02, "{label}: relative error {rel}");
        assert!(z.abs() < 4.0, "{label}: {z} standard errors from the truth");
    }

    #[test]
    fn coast_curve_matches_integrated_ode_and_stops() {
        let (t0, k, j) = (1.5e-3, 3.0e-6, 1.59e-3);
        let n0 = 628.0;
        // Fine explicit integration of J dn/dt = −T_f(n).
        let (mut n, dt) = (n0, 1e-3);
        for step in 1..=100_000 {
            n -= dt * friction_torque(n, t0, k) / j;
            if step % 20_000 == 0 {
                let analytic = coast_speed(n0, step as f64 * dt, t0, k, j);
                assert!((analytic - n).abs() < 1e-3, "{analytic} vs {n}");
            }
        }
        assert!(coast_speed(n0, 1000.0, t0, k, j) == 0.0);
        assert!(coast_speed(-n0, 1000.0, t0, k, j) == 0.0);
        // Pure Coulomb friction: linear coast, no 0/0.
        assert!((coast_speed(n0, 10.0, t0, 0.0, j) - (n0 - t0 * 10.0 / j)).abs() < 1e-9);
    }

    /// A spin-down of the Z wheel (the free axis) on the simulated free platform, as the
    /// tachometer reports it: `physics::Plant` from a level platform at rest with the wheel at
    /// `n0`, motors off, stepped at the telemetry rate for `duration_s`. Returns the record and the
    /// wheel's effective inertia (the platform's reaction speeds up the relative deceleration by
    /// `1 + J/I`, 2.5e-5, which is several standard errors of the coast-curve fit).
    fn plant_spin_down(
        config: &ModelConfig,
        seed: u64,
        n0: f64,
        duration_s: f64,
    ) -> (Vec<f64>, Vec<f64>, f64) {
        use testbed_model::physics::{ActuatorCommand, Plant, PlatformState, Wheel};
        let initial = PlatformState {
            wheel_speed: Vector3::new(0.0, 0.0, n0),
            ..PlatformState::default()
        };
        let mut plant = Plant::new(config, initial).expect("default configuration is valid");
        let mut tach = WheelTachometer::new(config, seed);
        let dt = 1.0 / config.wheels.telemetry_rate_hz;
        let steps = (duration_s / dt).round() as usize;
        let mut time = Vec::with_capacity(steps + 1);
        let mut speed = Vec::with_capacity(steps + 1);
        for k in 0..=steps {
            if k > 0 {
                let report = plant
                    .step(&ActuatorCommand::default(), dt)
                    .expect("finite step");
                assert!(
                    !report.at_tilt_stop,
                    "the spin-down must not touch the tilt stop"
                );
            }
            time.push(plant.time_s());
            speed.push(tach.sample(&plant.state().wheel_speed).z);
        }
        (
            time,
            speed,
            plant.dynamics().wheel_effective_inertia(Wheel::Z),
        )
    }

    #[test]
    fn friction_fit_recovers_tf0_and_k_within_2_percent_from_simulated_spin_downs() {
        // The paper's wheel (J = 1.59e-3 kg m², ±6000 rpm) with the configured tachometer noise
        // (0.1 rpm, 0.01 rpm resolution) on the simulated free platform. The gyros play no part:
        // the tachometer measures the wheel relative to the platform directly.
        let config = ModelConfig::default();
        let (t0, k) = (
            config.wheels.coulomb_nm[2],
            config.wheels.viscous_nm_per_rad_s[2],
        );
        let n0 = config.wheels.max_speed_rpm * RPM;
        // 500 s covers the whole coast (the wheel stops after about 430 s) and some standstill.
        let plus = plant_spin_down(&config, 2010, n0, 500.0);
        let minus = plant_spin_down(&config, 2011, -n0, 500.0);
        let j_eff = plus.2;
        assert!((j_eff / config.wheels.inertia_kgm2 - 1.0).abs() < 1e-4);
        let records = [
            SpinDown {
                time_s: &plus.0,
                speed_rad_s: &plus.1,
            },
            SpinDown {
                time_s: &minus.0,
                speed_rad_s: &minus.1,
            },
        ];
        let fit = fit_spin_downs(&records, j_eff, &FitOptions::default()).unwrap();
        println!("coast-curve fit: {fit:?}");
        check(
            "T_f0 (coast curve)",
            fit.coulomb_nm,
            fit.coulomb_stderr_nm,
            t0,
        );
        check(
            "K (coast curve)",
            fit.viscous_nm_per_rad_s,
            fit.viscous_stderr,
            k,
        );
        // The speed residuals are the tachometer noise: 0.1 rpm plus the 0.01 rpm quantum.
        let rms = fit.speed_residual_rms_rad_s.unwrap() / RPM;
        assert!((rms / 0.1 - 1.0).abs() < 0.05, "speed residual {rms} rpm");

        // The paper's torque-domain estimators on the same records.
        let torques = deceleration_torques(&records, j_eff, &FitOptions::default()).unwrap();
        let joint = fit_torque_samples(&torques).unwrap();
        println!("eq. 5 fit: {joint:?}");
        check(
            "T_f0 (eq. 5)",
            joint.coulomb_nm,
            joint.coulomb_stderr_nm,
            t0,
        );
        check(
            "K (eq. 5)",
            joint.viscous_nm_per_rad_s,
            joint.viscous_stderr,
            k,
        );
        let given = fit_viscous_given_coulomb(&torques, t0).unwrap();
        println!("eq. 4 fit: {given:?}");
        check(
            "K (eq. 4, T_f0 given)",
            given.viscous_nm_per_rad_s,
            given.viscous_stderr,
            k,
        );
        assert_eq!(given.coulomb_stderr_nm, 0.0);
    }

    #[test]
    fn analytic_coast_fits_recover_tf0_and_k() {
        let config = ModelConfig::default();
        let (t0, k) = (
            config.wheels.coulomb_nm[0],
            config.wheels.viscous_nm_per_rad_s[0],
        );
        let data = both_directions(&config, 2010);
        let j = config.wheels.inertia_kgm2;
        let fit = fit_spin_downs(&records(&data), j, &FitOptions::default()).unwrap();
        check(
            "T_f0 (coast curve, analytic)",
            fit.coulomb_nm,
            fit.coulomb_stderr_nm,
            t0,
        );
        check(
            "K (coast curve, analytic)",
            fit.viscous_nm_per_rad_s,
            fit.viscous_stderr,
            k,
        );
        let torques = deceleration_torques(&records(&data), j, &FitOptions::default()).unwrap();
        let joint = fit_torque_samples(&torques).unwrap();
        check(
            "T_f0 (eq. 5, analytic)",
            joint.coulomb_nm,
            joint.coulomb_stderr_nm,
            t0,
        );
        check(
            "K (eq. 5, analytic)",
            joint.viscous_nm_per_rad_s,
            joint.viscous_stderr,
            k,
        );
        let given = fit_viscous_given_coulomb(&torques, t0).unwrap();
        check(
            "K (eq. 4, analytic)",
            given.viscous_nm_per_rad_s,
            given.viscous_stderr,
            k,
        );
    }

    #[test]
    fn coast_curve_standard_errors_are_honest_across_seeds() {
        // If the standard errors are right, (estimate − truth) / stderr is standard normal; its
        // RMS over M seeds has relative standard deviation ≈ 1/sqrt(2M): assert within 4× that.
        let config = ModelConfig::default();
        let (t0, k) = (
            config.wheels.coulomb_nm[0],
            config.wheels.viscous_nm_per_rad_s[0],
        );
        let runs = 60;
        let (mut sum_z0, mut sum_zk) = (0.0, 0.0);
        for run in 0..runs {
            let data = both_directions(&config, 1000 + 2 * run);
            let fit = fit_spin_downs(
                &records(&data),
                config.wheels.inertia_kgm2,
                &FitOptions::default(),
            )
            .unwrap();
            sum_z0 += ((fit.coulomb_nm - t0) / fit.coulomb_stderr_nm).powi(2);
            sum_zk += ((fit.viscous_nm_per_rad_s - k) / fit.viscous_stderr).powi(2);
        }
        let bound = 4.0 / (2.0 * runs as f64).sqrt();
        for (label, sum) in [("T_f0", sum_z0), ("K", sum_zk)] {
            let rms = (sum / runs as f64).sqrt();
            println!("{label}: RMS of normalised errors over {runs} seeds = {rms:.3}");
            assert!((rms - 1.0).abs() < bound, "{label}: RMS z {rms}");
        }
    }

    #[test]
    fn single_direction_and_pure_coulomb_are_identified() {
        let mut config = ModelConfig::default();
        config.wheels.viscous_nm_per_rad_s = [0.0; 3];
        let n0 = config.wheels.max_speed_rpm * RPM;
        let (t, n) = spin_down(&config, 4, n0, 300.0);
        let fit = fit_spin_downs(
            &[SpinDown {
                time_s: &t,
                speed_rad_s: &n,
            }],
            config.wheels.inertia_kgm2,
            &FitOptions::default(),
        )
        .unwrap();
        assert!((fit.coulomb_nm / 1.5e-3 - 1.0).abs() < 0.02, "{fit:?}");
        assert!(
            fit.viscous_nm_per_rad_s.abs() < 4.0 * fit.viscous_stderr,
            "{fit:?}"
        );
    }

    #[test]
    fn bad_input_is_refused_with_a_reason() {
        let j = 1.59e-3;
        let opts = FitOptions::default();
        let t = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5];
        let n = [600.0, 599.0, 598.0, 597.0, 596.0, 595.0];
        let ok = |t: &[f64], n: &[f64]| {
            fit_spin_downs(
                &[SpinDown {
                    time_s: t,
                    speed_rad_s: n,
                }],
                j,
                &opts,
            )
        };

        assert!(matches!(
            ok(&t[..2], &n[..2]),
            Err(FrictionIdError::TooFewSamples { .. })
        ));
        assert!(matches!(
            fit_spin_downs(&[], j, &opts),
            Err(FrictionIdError::TooFewSamples { .. })
        ));
        let mut bad_t = t;
        bad_t[3] = 0.2;
        assert_eq!(
            ok(&bad_t, &n).unwrap_err(),
            FrictionIdError::NonMonotonicTime {
                record: 0,
                index: 3
            }
        );
        let mut nan_n = n;
        nan_n[4] = f64::NAN;
        assert_eq!(
            ok(&t, &nan_n).unwrap_err(),
            FrictionIdError::NotFinite {
                record: 0,
                index: 4
            }
        );
        assert!(matches!(
            ok(&t, &n[..5]),
            Err(FrictionIdError::LengthMismatch { .. })
        ));
        assert!(matches!(
            fit_spin_downs(
                &[SpinDown {
                    time_s: &t,
                    speed_rad_s: &n
                }],
                -1.0,
                &opts
            ),
            Err(FrictionIdError::InvalidParameter { .. })
        ));
        // Starting below the minimum speed leaves nothing to fit.
        assert!(matches!(
            ok(&t, &[5.0; 6]),
            Err(FrictionIdError::TooFewSamples { .. })
        ));

        let one = [TorqueSample {
            speed_rad_s: 100.0,
            torque_nm: 1e-3,
        }];
        assert!(matches!(
            fit_torque_samples(&one),
            Err(FrictionIdError::TooFewSamples { .. })
        ));
        assert!(matches!(
            fit_viscous_given_coulomb(&one, 1e-3),
            Err(FrictionIdError::TooFewSamples { .. })
        ));
        let same = [TorqueSample {
            speed_rad_s: 100.0,
            torque_nm: 1e-3,
        }; 4];
        assert_eq!(
            fit_torque_samples(&same).unwrap_err(),
            FrictionIdError::Singular
        );
        let nan = [TorqueSample {
            speed_rad_s: f64::NAN,
            torque_nm: 1e-3,
        }; 4];
        assert_eq!(
            fit_torque_samples(&nan).unwrap_err(),
            FrictionIdError::NotFiniteSample { index: 0 }
        );
    }
}
