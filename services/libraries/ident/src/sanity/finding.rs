//! What a sanity check reports: the file, the columns and the likely mistake, with the factor or
//! the permutation found and the evidence.

use std::fmt;
use std::path::PathBuf;

/// A data mistake: how the recorded values differ from the contract's.
#[derive(Debug, Clone, PartialEq)]
pub enum Mistake {
    /// The values are in `unit`, not the contract's `si`: they are `factor` × the SI values
    /// (`factor` is the one measured, the unit's nominal factor is in `unit`'s table).
    Units {
        unit: &'static str,
        si: &'static str,
        factor: f64,
    },
    /// The values are `factor` × what the other channels say, a gross factor of no unit known.
    Scale { si: &'static str, factor: f64 },
    /// These columns have their sign flipped.
    SignFlipped,
    /// Two columns that must agree in sign disagree: one of them is flipped (the data cannot
    /// tell which).
    SignsDisagree,
    /// The columns' contents are exchanged (and perhaps sign-flipped): `mapping` says which
    /// column holds what.
    Permuted { mapping: String },
    /// The channel does not belong with the others: recorded in another run (or garbled).
    OtherRun,
    /// The values lie beyond what the device can report, in no unit known.
    OutOfRange,
}

impl Mistake {
    /// The mistake as the predicate of its columns (`plural`: more than one).
    pub fn phrase(&self, plural: bool) -> String {
        let (look, be, lie) = if plural {
            ("look", "are", "lie")
        } else {
            ("looks", "is", "lies")
        };
        match self {
            Mistake::Units { unit, si, .. } => format!("{look} like {unit}, not {si}"),
            Mistake::Scale { si, factor } => format!(
                "{be} {} the values the other channels imply (a gross factor of no unit known; \
                 the contract's unit is {si})",
                times(*factor)
            ),
            Mistake::SignFlipped => format!("{look} sign-flipped"),
            Mistake::SignsDisagree => "disagree in sign: one of them looks sign-flipped".into(),
            Mistake::Permuted { mapping } => format!("{look} exchanged ({mapping})"),
            Mistake::OtherRun => format!("{look} recorded in another run"),
            Mistake::OutOfRange => format!("{lie} beyond the device's range"),
        }
    }
}

/// One data mistake found: the file, the columns, the mistake and why it is believed.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    pub file: PathBuf,
    /// The columns concerned, as the file names them.
    pub columns: Vec<String>,
    pub mistake: Mistake,
    /// The measurement behind it, in words with its numbers.
    pub evidence: String,
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let plural = self.columns.len() > 1;
        let columns = if plural {
            format!("columns {}", self.columns.join(", "))
        } else {
            format!("column {}", self.columns.join(""))
        };
        write!(
            f,
            "{}: {columns} {} ({}); a data error, not physics: no cause is named until it is \
             mended",
            self.file.display(),
            self.mistake.phrase(plural),
            self.evidence
        )
    }
}

/// `57.3×`, `1e+04×`: a factor as a reader compares it with a unit's.
pub fn times(factor: f64) -> String {
    let a = factor.abs();
    if (0.01..1e4).contains(&a) {
        format!("{factor:.3}×")
    } else {
        format!("{factor:.3e}×")
    }
}
