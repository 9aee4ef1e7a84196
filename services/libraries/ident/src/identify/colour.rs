//! Residual whiteness of the torque channel: a coloured disturbance (a slowly wandering external
//! torque) reported with its size and correlation time.
//!
//! The torque channel's momentum residual ([`crate::channels`]) is rebuilt under the extended
//! model (named causes and carried fitted torques) on segments of up to
//! [`COLOUR_SEGMENT_S`]. Its increments from tick to tick, `d_k = y_k − y_{k−1}` (the segment's
//! free offset cancels), are the innovation-implied torque impulse: under a correct model the
//! measurement noise of the momentum differenced once, plus a white part (the gyro's noise
//! through `w × H`, the bias walk); an unmodelled external torque adds `∫ τ dt` over the tick.
//! The residual itself is not white under a correct model (its noise is differenced and
//! correlated within a segment), so the test is on this pre-whitening model: the Whittle
//! likelihood ratio of the pooled periodogram of `d` with and without a first-order
//! Gauss–Markov component ([`crate::spectral`]), on each axis and on the three jointly with
//! one correlation time (a wandering torque from air flow moves every axis at about the same
//! pace; the joint test finds one too small for any single axis). A component found at
//! `p · 4 < alpha` (Bonferroni over the three axes and the joint test) is a coloured
//! disturbance, with rms `√A / Δt` and correlation time `−Δt / ln φ`.
//!
//! The attitude filter's innovations, normalised by their predicted covariance, are white
//! under a correct sensor model: each component is tested by Ljung–Box over
//! [`INNOVATION_LAGS`] successive samples (Bonferroni over the five components, the same level).

use crate::channels::{Regressors, TorqueChannel};
use crate::data::Aligned;
use crate::reconstruct::Reconstruction;
use crate::spectral::{ColourFit, colour_fits, periodogram};
use rayon::prelude::*;
use serde::Serialize;
use testbed_model::ModelConfig;

/// Longest segment of the momentum residual the test uses, s (longer segments resolve longer
/// correlation times; a segment ends at a gap or the tilt stop).
pub const COLOUR_SEGMENT_S: f64 = 120.0;

/// Level of the whiteness test per record (Bonferroni over the three axes).
pub const COLOUR_ALPHA: f64 = 1e-3;

/// The whiteness test of one torque axis.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelWhiteness {
    /// `torque_x`, `torque_y`, `torque_z`.
    pub channel: String,
    /// Periodogram ordinates used.
    pub ordinates: usize,
    /// Whittle likelihood ratio and its p value times 3 (Bonferroni over the axes), at most 1.
    pub lr: f64,
    pub p: f64,
    /// Whether a coloured disturbance is reported (`p < alpha`).
    pub coloured: bool,
    /// The Gauss–Markov component's rms, Nm, and correlation time, s (the coloured model's
    /// fit, also when not significant).
    pub rms_nm: f64,
    pub correlation_time_s: f64,
}

/// Lags of the Ljung–Box test of the filter's innovations.
pub const INNOVATION_LAGS: usize = 10;

/// The Ljung–Box test of one component of the attitude filter's innovations, each normalised
/// by its predicted covariance (N(0, 1) and white for a consistent filter and a correct sensor
/// model).
#[derive(Debug, Clone, Serialize)]
pub struct InnovationWhiteness {
    /// `innovation_tilt_1` … `innovation_field_z`.
    pub channel: String,
    pub samples: usize,
    /// Ljung–Box statistic over lags 1..=`lags` (successive samples of the component).
    pub ljung_box: f64,
    pub lags: usize,
    /// Its p value times 5 (Bonferroni over the components), at most 1.
    pub p: f64,
    /// Lag-1 autocorrelation and rms (1 expected).
    pub lag1: f64,
    pub rms: f64,
    /// Whether it is reported as not white (`p < alpha`).
    pub coloured: bool,
}

/// The torque channel's whiteness per axis and on the three axes jointly, and the
/// innovations'.
#[derive(Debug, Clone, Serialize)]
pub struct WhitenessReport {
    pub alpha: f64,
    /// Per axis, each its own correlation time (p values times 4: Bonferroni over the three
    /// axes and the joint test).
    pub channels: Vec<ChannelWhiteness>,
    /// The joint test: one correlation time for the three axes, each its own rms; `lr`, `p`
    /// and `coloured` are the joint test's, the same on every axis (empty when an axis has too
    /// few ordinates).
    pub joint: Vec<ChannelWhiteness>,
    pub innovations: Vec<InnovationWhiteness>,
}

impl WhitenessReport {
    /// The coloured disturbances, in words.
    pub fn lines(&self) -> Vec<String> {
        let joint = self.joint.first().filter(|j| j.coloured).map(|j| {
            format!(
                "coloured disturbance on the three torque axes, one correlation time {} s: rms {} Nm (joint whiteness test p = {:.1e})",
                round_sig(j.correlation_time_s),
                self.joint
                    .iter()
                    .map(|c| format!("{:.2e}", c.rms_nm))
                    .collect::<Vec<_>>()
                    .join(", "),
                j.p
            )
        });
        joint
            .into_iter()
            .chain(self.channels.iter().filter(|c| c.coloured).map(|c| {
                format!(
                    "coloured disturbance on {}: rms {:.2e} Nm, correlation time {} s (whiteness test p = {:.1e})",
                    c.channel,
                    c.rms_nm,
                    round_sig(c.correlation_time_s),
                    c.p
                )
            }))
            .chain(self.innovations.iter().filter(|c| c.coloured).map(|c| {
                format!(
                    "coloured residual on {}: lag-1 correlation {:.2}, rms {:.2} of the predicted (whiteness test: Ljung–Box {:.1} on {} lags, p = {:.1e})",
                    c.channel, c.lag1, c.rms, c.ljung_box, c.lags, c.p
                )
            }))
            .collect()
    }
}

/// Ljung–Box of each innovation component of `recon` (Bonferroni over the components).
fn innovation_whiteness(recon: &Reconstruction) -> Vec<InnovationWhiteness> {
    use super::innovation::INNOVATION_LABELS;
    let count = INNOVATION_LABELS.len();
    (0..count)
        .filter_map(|c| {
            let v: Vec<f64> = recon
                .innovations
                .iter()
                .filter(|i| i.mask & (1 << c) != 0)
                .map(|i| i.values[c])
                .collect();
            if v.len() < 4 * INNOVATION_LAGS {
                return None;
            }
            let index: Vec<f64> = (0..v.len()).map(|i| i as f64).collect();
            let st = crate::stats::series_stats(&index, &v, INNOVATION_LAGS);
            let p = (st.white_p * count as f64).min(1.0);
            Some(InnovationWhiteness {
                channel: INNOVATION_LABELS[c].to_string(),
                samples: v.len(),
                ljung_box: st.ljung_box,
                lags: st.lags,
                p,
                lag1: st.lag1,
                rms: st.rms,
                coloured: p < COLOUR_ALPHA,
            })
        })
        .collect()
}

fn round_sig(x: f64) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    let e = 10f64.powi(x.abs().log10().floor() as i32 - 1);
    (x / e).round() * e
}

/// The test on the momentum residual of `recon` under `config` (the extended model).
pub(super) fn whiteness(
    data: &Aligned,
    recon: &Reconstruction,
    config: &ModelConfig,
) -> WhitenessReport {
    let channel = TorqueChannel::new(
        data,
        recon,
        config,
        COLOUR_SEGMENT_S,
        &vec![0; data.len()],
        Regressors::Skipped,
    );
    let mut report = whiteness_of(&channel, data.period_s);
    report.innovations = innovation_whiteness(recon);
    report
}

/// The tests on a torque channel whose rows are `dt_s` apart: each axis, and the three axes
/// jointly with one correlation time (Bonferroni over the four).
fn whiteness_of(channel: &TorqueChannel, dt_s: f64) -> WhitenessReport {
    const AXES: [&str; 3] = ["torque_x", "torque_y", "torque_z"];
    const TESTS: f64 = AXES.len() as f64 + 1.0;
    let ordinates: Vec<Vec<(f64, f64)>> = (0..3)
        .into_par_iter()
        .map(|axis| {
            let segments: Vec<Vec<f64>> = channel
                .segments
                .iter()
                .map(|rows| {
                    rows.clone()
                        .skip(1)
                        .map(|r| channel.y[r][axis] - channel.y[r - 1][axis])
                        .collect()
                })
                .collect();
            periodogram(&segments)
        })
        .collect();
    let whiteness = |channel: &str, fit: &ColourFit| {
        let p = (fit.p * TESTS).min(1.0);
        ChannelWhiteness {
            channel: channel.to_string(),
            ordinates: fit.ordinates,
            lr: fit.lr,
            p,
            coloured: p < COLOUR_ALPHA,
            rms_nm: fit.ar_variance.sqrt() / dt_s,
            correlation_time_s: fit.correlation_time_s(dt_s),
        }
    };
    let (own, joint) = colour_fits(&ordinates);
    let channels = AXES
        .iter()
        .zip(&own)
        .filter_map(|(name, fit)| Some(whiteness(name, fit.as_ref()?)))
        .collect();
    let joint = joint.map(|fits| {
        AXES.iter()
            .zip(&fits)
            .map(|(name, fit)| whiteness(name, fit))
            .collect()
    });
    WhitenessReport {
        alpha: COLOUR_ALPHA,
        channels,
        joint: joint.unwrap_or_default(),
        innovations: Vec::new(),
    }
}

/// The test on `data` against `model` alone (its attitude estimate, no cause fitted): what
/// [`crate::identify()`] reports when it names nothing and carries no fitted torque.
pub fn torque_whiteness(
    data: &crate::data::Dataset,
    model: &ModelConfig,
) -> Result<WhitenessReport, crate::error::IdentError> {
    let aligned = Aligned::new(data);
    let recon = crate::reconstruct::reconstruct(&aligned, model)?;
    Ok(whiteness(&aligned, &recon, model))
}
