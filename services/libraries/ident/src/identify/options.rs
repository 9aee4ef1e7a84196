//! The settings of the analysis and the held-out share of the data they define.

use crate::data::Aligned;
use crate::effects::Cause;
use crate::error::IdentError;
use crate::fit::FitOptions;
use crate::sparse::SparseOptions;
use serde::Serialize;

/// Settings of the analysis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Options {
    pub fit: FitOptions,
    /// Prediction window: re-initialisation period of the multi-step predictions, s.
    pub horizon_s: f64,
    /// Length of the time blocks (held-out split or cross-validation folds), s.
    pub block_s: f64,
    /// Without cross-validation (`folds` 0): every this-many-th block is held out of the fits
    /// (3: a third of the data).
    pub held_out_every: usize,
    /// Folds of the k-fold cross-validation of the selection and of the gain (block b of
    /// `block_s` in fold `b mod folds`; the fits then use all the data; 5, the default); 0:
    /// off, one held-out share (`held_out_every`) instead.
    pub folds: usize,
    /// Most causes named.
    pub max_causes: usize,
    /// Significance level of a cause (per candidate and step).
    pub alpha: f64,
    /// Candidates considered (default: the whole library).
    pub candidates: Vec<Cause>,
    /// Normalised RMS of an equation-error channel above which residual is said to remain.
    pub remaining_rms: f64,
    /// The search for unexplained effects (sparse regression on the candidate functions).
    pub sparse: SparseOptions,
    /// Disjoint time blocks of the consistency test of a named cause.
    pub consistency_blocks: usize,
    /// Level of the consistency test (a cause fails at p below it).
    pub consistency_alpha: f64,
    /// Whether a named cause is set against the unrestricted candidate search in its channel's
    /// equations and flagged when it explains only part of one (`guard`; on by default, off
    /// only to see what the analysis says without it).
    pub misattribution_guard: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            fit: FitOptions::default(),
            horizon_s: 10.0,
            block_s: 30.0,
            held_out_every: 3,
            folds: 5,
            max_causes: 4,
            alpha: 1e-6,
            candidates: Cause::ALL.to_vec(),
            remaining_rms: 1.3,
            sparse: SparseOptions::default(),
            consistency_blocks: 4,
            consistency_alpha: 1e-3,
            misattribution_guard: true,
        }
    }
}

impl Options {
    /// Refuse options the analysis cannot use, naming the option.
    pub fn validate(&self) -> Result<(), IdentError> {
        let bad = |key: &str, value: String, reason: &str| {
            Err(IdentError::Options {
                key: key.into(),
                value,
                reason: reason.into(),
            })
        };
        if !(self.horizon_s.is_finite() && self.horizon_s > 0.0) {
            return bad("horizon_s", self.horizon_s.to_string(), "must be > 0");
        }
        if !(self.block_s.is_finite() && self.block_s >= self.horizon_s) {
            return bad(
                "block_s",
                self.block_s.to_string(),
                "must be at least the prediction horizon",
            );
        }
        if self.held_out_every < 2 {
            return bad(
                "held_out_every",
                self.held_out_every.to_string(),
                "must be >= 2",
            );
        }
        if self.folds == 1 {
            return bad("folds", self.folds.to_string(), "must be 0 (off) or >= 2");
        }
        if !(self.alpha > 0.0 && self.alpha < 0.5) {
            return bad("alpha", self.alpha.to_string(), "must be within (0, 0.5)");
        }
        if self.consistency_blocks < 2 {
            return bad(
                "consistency_blocks",
                self.consistency_blocks.to_string(),
                "must be >= 2",
            );
        }
        if !(self.consistency_alpha > 0.0 && self.consistency_alpha < 0.5) {
            return bad(
                "consistency_alpha",
                self.consistency_alpha.to_string(),
                "must be within (0, 0.5)",
            );
        }
        if self.sparse.folds < 2 || !(self.sparse.alpha > 0.0 && self.sparse.alpha < 0.5) {
            return bad(
                "sparse",
                format!("{:?}", self.sparse),
                "needs at least 2 folds and alpha within (0, 0.5)",
            );
        }
        if !(self.fit.torque_segment_s > 0.0 && self.fit.max_delay_s > 0.0) {
            return bad("fit", format!("{:?}", self.fit), "intervals must be > 0");
        }
        Ok(())
    }
}

/// Which ticks the fits of [`super::identify`] leave out: with `folds` ≥ 2 (k-fold) none (the
/// fits use all the data, each fold's problem holds out its own blocks); otherwise every
/// `held_out_every`-th block of `block_s`.
pub fn held_out_mask(aligned: &Aligned, options: &Options) -> Vec<bool> {
    let block = |t: f64| crate::data::block_index(t, options.block_s);
    let cross_validated = options.folds >= 2;
    aligned
        .t
        .iter()
        .map(|&t| {
            !cross_validated && block(t) % options.held_out_every == options.held_out_every - 1
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_validation_is_on_by_default_and_needs_two_folds() {
        assert_eq!(Options::default().folds, 5);
        assert!(Options::default().validate().is_ok());
        let off = Options {
            folds: 0,
            ..Options::default()
        };
        assert!(off.validate().is_ok());
        let one = Options {
            folds: 1,
            ..Options::default()
        };
        assert!(
            matches!(one.validate(), Err(IdentError::Options { ref key, .. }) if key == "folds"),
            "1 fold accepted"
        );
    }
}
