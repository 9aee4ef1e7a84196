//! Attitude determination: the multiplicative extended Kalman filter (MEKF) of Lefferts, Markley
//! and Shuster (1982), as the paper uses it for attitude determination.
//!
//! # State and conventions
//!
//! * Attitude `q`: level frame L (x north, y west, z up) to body frame B, `v_B = A(q) v_L`, the
//!   convention of [`testbed_model::attitude`] (nalgebra `UnitQuaternion`, stored `[x, y, z, w]`).
//! * Gyro bias `b`, body axes, rad/s: `w_meas = w + b + η_v`, `b' = η_u`.
//! * Error state `dx = [δθ (3), δb (3)]`: `δθ` the small attitude error in body axes (rad), defined
//!   by `A_true = (I − [δθ×]) A_est` ([`attitude::apply_error`] / [`attitude::attitude_error`]),
//!   and `δb = b_true − b_est` (rad/s). The covariance `P` (6×6) is of that error; units rad²,
//!   rad²/s, rad²/s² by block.
//! * Time: the filter holds its time of validity in nanoseconds (`u64`, the run's clock, as the
//!   IPC headers). It never applies a sample out of order silently: older samples are refused
//!   with an error and counted.
//!
//! # Propagation (every gyro sample)
//!
//! `ŵ = w_meas − b̂`; `q⁻ = propagate(q⁺, ŵ, Δt)`; `P⁻ = Φ P⁺ Φᵀ + Q` with the closed-form
//! transition matrix of `δθ' = −[ŵ×]δθ − δb` ([`transition_matrix`]) and the digest's discrete
//! process noise ([`process_noise`], per-axis `σv`, `σu`).
//!
//! **Hold convention.** The sample passed to [`Mekf::propagate`] at time `t` is taken as the mean
//! body rate over the interval from the state's time to `t` (the rate of an integrating,
//! averaging gyro, sampled at the end of its interval). A vector measurement stamped ahead of the
//! state extrapolates with the *last* gyro sample held constant (zero-order hold forward); before
//! any gyro sample the held rate is `w_meas = b̂` (platform at rest). When a gyro sample and a
//! vector sample carry the same time, feed the gyro sample first.
//!
//! # Update (inclinometer and magnetometer, 2.5 Hz)
//!
//! `y = [G_meas; M_meas]`, `r = [G_L; M_L]`, `H = [[A r_G]× 0; [A r_M]× 0]`,
//! `K = P Hᵀ (H P Hᵀ + R)⁻¹`, `dx = K (y − A(q⁻) r)`, `q⁺ = apply_error(q⁻, δθ)`, `b⁺ = b⁻ + δb`,
//! and `P⁺ = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ`: the **Joseph form**, algebraically equal to
//! `(I − K H) P⁻` for the optimal gain but symmetric and positive semi-definite by construction,
//! which the short form is not in floating point with covariances spanning 1e-10 rad² (tilt) to
//! 1e-13 rad²/s² (bias). Either block may be absent; the update uses the blocks present.
//!
//! Choices beyond the digest, each documented where it is made:
//! * **Gravity block in its tangent plane.** `G_meas` is a unit vector: `R_G` has rank 2 (null
//!   along `G`), and `H_G = [a×]` is null along the predicted `a = A r_G` as well, so the 3×3
//!   `H_G P H_Gᵀ + R_G` is singular or, because the measured and predicted directions differ by
//!   the error, nearly singular with a meaningless near-null direction (its radial innovation is
//!   the second-order `|δθ|²/2`). The block is therefore expressed in an orthonormal basis `T`
//!   (3×2) of the plane orthogonal to `a`: `ν = Tᵀ(y − a)`, `H = Tᵀ H_G`, `R = Tᵀ R_G T`. This is
//!   the pseudo-inverse of the 3-D form restricted to the directions the measurement carries,
//!   and leaves a well-conditioned 2×2 block; its chi-square gate uses **2 effective degrees of
//!   freedom**. (Shuster showed the radial component of a unit-vector measurement carries no
//!   attitude information to first order.)
//! * **Measurement lag.** A vector sample up to [`MekfConfig::max_measurement_lag_s`] older than
//!   the state is used, not refused: its prediction uses the attitude carried back to the
//!   sample's time with the current rate estimate, `A_m = exp([ŵ×] lag) A`, and the error at that
//!   time is `δθ_m = exp([ŵ×] lag) δθ + lag·J_l δb` (first order, [`measurement_jacobian`]).
//!   The gyro noise over the lag (σv²·lag, under 1% of the inclinometer variance for 0.1 s) is
//!   neglected. Older samples are refused ([`MekfError::Stale`]).
//! * **Iterated update.** When the first correction is larger than 1e-4 rad (acquisition from a
//!   degree-level error) the update is relinearised about the corrected state (Gauss–Newton,
//!   i.e. the iterated EKF), up to [`MekfConfig::max_update_iterations`] times. One step leaves a
//!   second-order error of about `|δθ|²/2` (1.5e-4 rad for 1°, ten inclinometer σ), which would
//!   then make the gate reject every following sample. Below 1e-4 rad the step is the plain EKF.
//! * **Innovation gating** per sensor block, on the normalised innovation squared
//!   `NIS = νᵀ S⁻¹ ν` computed with the prior, against the chi-square quantile of the configured
//!   probability for the block's dimension (gravity 2, magnetic field 3), precomputed at
//!   construction. Rejected blocks are counted; the other block is still applied.
//! * **Robust inversion.** `S = H P Hᵀ + R` is factored by Cholesky after symmetric diagonal
//!   equilibration (`D S D` with unit diagonal; the gravity block is dimensionless and the
//!   magnetic block is in tesla², 1e-15 apart). A non-finite or non-positive diagonal, a failed
//!   factorisation, or a pivot below 1e-12 of the unit diagonal (condition number beyond ~1e12)
//!   leaves the state untouched and is counted as `not_invertible`.
//!
//! Pure maths: no I/O, no clock, no heap allocation (every matrix is sized at compile time and
//! lives on the stack; the update is instantiated for 2, 3 and 5 stacked measurement rows).
//! `testbed-sim`'s `tests/flight_allocations.rs` counts the allocations of the estimator's and
//! controller's steady state and requires none.
//!
//! # Where things are
//!
//! * this module: the filter [`Mekf`] (construction, propagation, accessors) and [`MekfError`];
//! * `config`: [`MekfConfig`];
//! * `update`: the vector-measurement update ([`Mekf::update`], [`VectorMeasurements`]);
//! * `gating`: the chi-square gate thresholds and innovation statistics of each block;
//! * `spd_factor`: the equilibrated Cholesky factorisation of the innovation covariance;
//! * `model`: propagation and measurement model matrices ([`transition_matrix`],
//!   [`process_noise`], [`inclinometer_covariance`], [`measurement_jacobian`],
//!   [`tangent_basis`]);
//! * `triad`: TRIAD initialisation ([`triad`]);
//! * `report`: what an update reports and the filter counts ([`UpdateReport`],
//!   [`MekfCounters`], [`MekfEstimate`]).
//!
//! The chi-square distribution used for the gate is in [`crate::stats`].

mod config;
mod gating;
mod model;
mod report;
mod spd_factor;
mod triad;
mod update;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod truth;

pub use config::MekfConfig;
pub use model::{
    inclinometer_covariance, measurement_jacobian, process_noise, tangent_basis, transition_matrix,
};
pub use report::{
    Block, BlockCounters, BlockLinearisation, BlockResult, BlockStatus, InnovationStats,
    MekfCounters, MekfEstimate, UpdateLinearisation, UpdateReport,
};
pub use triad::triad;
pub use update::VectorMeasurements;

use gating::gate_thresholds;
use nalgebra::{Matrix6, Vector3};
use testbed_model::attitude::{self, Attitude};

/// Nanoseconds per second.
const NS_PER_S: f64 = 1e9;

/// Why the filter refused an input or could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MekfError {
    /// A gyro sample older than the state's time (never applied out of order).
    #[error("gyro sample at {t_ns} ns is older than the filter state at {state_ns} ns; refused")]
    OutOfOrder { t_ns: u64, state_ns: u64 },
    /// A vector sample older than the state's time by more than the tolerance.
    #[error(
        "vector sample at {t_ns} ns is older than the filter state at {state_ns} ns by more than \
         {tolerance_ns} ns; refused"
    )]
    Stale {
        t_ns: u64,
        state_ns: u64,
        tolerance_ns: u64,
    },
    /// A non-finite input.
    #[error("{what} is not finite")]
    NonFinite { what: &'static str },
    /// A configuration the filter cannot use.
    #[error("MEKF configuration: `{key}` = {value}: {reason}")]
    InvalidConfig {
        key: String,
        value: String,
        reason: String,
    },
    /// TRIAD cannot build a frame from these vectors.
    #[error("TRIAD: {0}")]
    Degenerate(&'static str),
    /// A supplied covariance is not symmetric positive definite.
    #[error("covariance is not finite, symmetric and positive definite")]
    Covariance,
}

/// Refuses (and counts) a gyro sample a filter at `state_ns` cannot apply: not finite, or
/// older than the state.
pub(crate) fn check_gyro_sample(
    counters: &mut MekfCounters,
    t_ns: u64,
    state_ns: u64,
    w_meas_rad_s: &Vector3<f64>,
) -> Result<(), MekfError> {
    if !w_meas_rad_s.iter().all(|x| x.is_finite()) {
        counters.invalid_gyro += 1;
        return Err(MekfError::NonFinite {
            what: "gyro sample",
        });
    }
    if t_ns < state_ns {
        counters.out_of_order_gyro += 1;
        return Err(MekfError::OutOfOrder { t_ns, state_ns });
    }
    Ok(())
}

/// The MEKF. See the module documentation for the equations and conventions.
#[derive(Debug, Clone)]
pub struct Mekf {
    config: MekfConfig,
    /// Chi-square gate thresholds `[gravity (2 dof), magnetic (3 dof)]`.
    gate: [f64; 2],
    sigma_v: Vector3<f64>,
    sigma_u: Vector3<f64>,
    field_l: Vector3<f64>,
    t_ns: u64,
    q: Attitude,
    bias: Vector3<f64>,
    p: Matrix6<f64>,
    last_w_meas: Option<Vector3<f64>>,
    counters: MekfCounters,
    last_update: Option<UpdateReport>,
    last_linearisation: UpdateLinearisation,
}

impl Mekf {
    /// A filter at time `t_ns` with attitude `attitude`, the configured initial bias and `P₀`.
    pub fn new(config: MekfConfig, t_ns: u64, attitude: Attitude) -> Result<Self, MekfError> {
        let bias = Vector3::from(config.initial_bias_rad_s);
        let p = config.initial_covariance();
        Self::with_state(config, t_ns, attitude, bias, p)
    }

    /// A filter with a given state: attitude (L→B), bias (rad/s) and covariance of `[δθ, δb]`.
    pub fn with_state(
        config: MekfConfig,
        t_ns: u64,
        attitude: Attitude,
        bias_rad_s: Vector3<f64>,
        covariance: Matrix6<f64>,
    ) -> Result<Self, MekfError> {
        config.validate()?;
        if !attitude.coords.iter().all(|x| x.is_finite()) {
            return Err(MekfError::NonFinite {
                what: "initial attitude",
            });
        }
        if !bias_rad_s.iter().all(|x| x.is_finite()) {
            return Err(MekfError::NonFinite {
                what: "initial bias",
            });
        }
        let scale = covariance.abs().max();
        let symmetric = (covariance - covariance.transpose()).abs().max() <= 1e-9 * scale;
        if !(covariance.iter().all(|x| x.is_finite())
            && symmetric
            && covariance.cholesky().is_some())
        {
            return Err(MekfError::Covariance);
        }
        let gate = gate_thresholds(config.gate_probability)?;
        Ok(Self {
            gate,
            sigma_v: Vector3::from(config.gyro_noise_density_rad_sqrt_s),
            sigma_u: Vector3::from(config.gyro_bias_walk_rad_s32),
            field_l: Vector3::from(config.field_l_t),
            config,
            t_ns,
            q: attitude,
            bias: bias_rad_s,
            p: covariance,
            last_w_meas: None,
            counters: MekfCounters::default(),
            last_update: None,
            last_linearisation: UpdateLinearisation::default(),
        })
    }

    /// Start without truth: attitude by TRIAD from a measured down vector `g_meas_b` (body,
    /// need not be unit; the primary vector, e.g. [`attitude::gravity_from_tilt`] of the
    /// inclinometer angles) and a measured field `m_meas_b` (body, T), against `G_L` and the
    /// configured `M_L`; bias and covariance from the configuration.
    pub fn initialise_from_vectors(
        config: MekfConfig,
        t_ns: u64,
        g_meas_b: &Vector3<f64>,
        m_meas_b: &Vector3<f64>,
    ) -> Result<Self, MekfError> {
        config.validate()?;
        let field_l = Vector3::from(config.field_l_t);
        let q = triad(g_meas_b, m_meas_b, &attitude::gravity_l(), &field_l)?;
        Self::new(config, t_ns, q)
    }

    /// Advance the state from its time to `t_ns` with the gyro sample `w_meas_rad_s` (body,
    /// rad/s, bias included), taken as the mean rate over that interval (see the module's hold
    /// convention). `t_ns` equal to the state's time only records the sample. A sample older than
    /// the state is refused ([`MekfError::OutOfOrder`]) and counted; a non-finite one likewise.
    pub fn propagate(&mut self, t_ns: u64, w_meas_rad_s: &Vector3<f64>) -> Result<(), MekfError> {
        check_gyro_sample(&mut self.counters, t_ns, self.t_ns, w_meas_rad_s)?;
        let dt_s = (t_ns - self.t_ns) as f64 / NS_PER_S;
        self.advance(dt_s, w_meas_rad_s);
        self.t_ns = t_ns;
        self.last_w_meas = Some(*w_meas_rad_s);
        self.counters.propagations += 1;
        Ok(())
    }

    /// Time of validity, ns.
    pub fn time_ns(&self) -> u64 {
        self.t_ns
    }
    /// Attitude estimate, L to B.
    pub fn attitude(&self) -> Attitude {
        self.q
    }
    /// Gyro bias estimate, body axes, rad/s.
    pub fn bias(&self) -> Vector3<f64> {
        self.bias
    }
    /// Covariance of `[δθ, δb]` (rad², rad²/s, rad²/s²).
    pub fn covariance(&self) -> Matrix6<f64> {
        self.p
    }
    /// Body rate estimate (latest gyro sample minus bias), rad/s; zero before any gyro sample.
    pub fn rate(&self) -> Vector3<f64> {
        self.last_w_meas.map_or(Vector3::zeros(), |w| w - self.bias)
    }
    /// Counters since construction.
    pub fn counters(&self) -> MekfCounters {
        self.counters
    }
    /// The latest update report.
    pub fn last_update(&self) -> Option<UpdateReport> {
        self.last_update
    }
    /// The latest update's linearisation (each block's as it was whitened, the gain applied),
    /// for sensitivity analyses; empty before any update.
    pub fn last_linearisation(&self) -> &UpdateLinearisation {
        &self.last_linearisation
    }
    /// Precomputed chi-square gate thresholds `[gravity (2 dof), magnetic (3 dof)]`.
    pub fn gate_thresholds(&self) -> [f64; 2] {
        self.gate
    }
    /// The configuration in use.
    pub fn config(&self) -> &MekfConfig {
        &self.config
    }
    /// Snapshot for publishing.
    pub fn estimate(&self) -> MekfEstimate {
        MekfEstimate {
            t_ns: self.t_ns,
            attitude: self.q,
            rate_rad_s: self.rate(),
            bias_rad_s: self.bias,
            covariance: self.p,
            last_update: self.last_update,
            counters: self.counters,
        }
    }

    /// Propagate state and covariance by `dt_s` with the gyro sample `w_meas` held constant.
    fn advance(&mut self, dt_s: f64, w_meas: &Vector3<f64>) {
        if dt_s <= 0.0 {
            return;
        }
        let w_hat = w_meas - self.bias;
        self.q = attitude::propagate(&self.q, &w_hat, dt_s);
        self.q.renormalize();
        let phi = transition_matrix(&w_hat, dt_s);
        let q = process_noise(&self.sigma_v, &self.sigma_u, dt_s);
        self.p = symmetrise(&(propagate_covariance(&phi, &self.p) + q));
    }
}

/// `Φ P Φᵀ` for the error state's transition matrix, whose lower block row is `[0, I]`
/// ([`transition_matrix`]): by 3×3 blocks, a third of the full product's multiplications.
/// With `Φ = [[A, B], [0, I]]` and `P = [[P11, P12], [P21, P22]]`:
/// `[[(A P11 + B P21) Aᵀ + (A P12 + B P22) Bᵀ, A P12 + B P22], [(…)ᵀ, P22]]`.
fn propagate_covariance(phi: &Matrix6<f64>, p: &Matrix6<f64>) -> Matrix6<f64> {
    let a = phi.fixed_view::<3, 3>(0, 0);
    let b = phi.fixed_view::<3, 3>(0, 3);
    let p11 = p.fixed_view::<3, 3>(0, 0);
    let p12 = p.fixed_view::<3, 3>(0, 3);
    let p21 = p.fixed_view::<3, 3>(3, 0);
    let p22 = p.fixed_view::<3, 3>(3, 3);
    let top_left = a * p11 + b * p21;
    let top_right = a * p12 + b * p22;
    let mut out = Matrix6::zeros();
    out.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(top_left * a.transpose() + top_right * b.transpose()));
    out.fixed_view_mut::<3, 3>(0, 3).copy_from(&top_right);
    out.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(p21 * a.transpose() + p22 * b.transpose()));
    out.fixed_view_mut::<3, 3>(3, 3).copy_from(&p22);
    out
}

/// `(P + Pᵀ) / 2`: removes the rounding asymmetry of a covariance.
fn symmetrise(p: &Matrix6<f64>) -> Matrix6<f64> {
    (p + p.transpose()) * 0.5
}
