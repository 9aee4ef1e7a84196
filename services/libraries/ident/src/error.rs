//! Why identification could not be carried out.

use std::path::PathBuf;

/// Something is wrong with the measured data: each variant names the file and, where it
/// applies, the row (`row` counts data rows from 1; `line` is the line in the file, the header
/// being line 1).
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    #[error("{path}: not a directory of measured-data CSV files or an MCAP run log")]
    NotData { path: PathBuf },
    #[error("{file}: cannot read: {source}")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: cannot write: {source}")]
    Write {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: missing; {why}")]
    Missing { file: PathBuf, why: String },
    #[error("{file}: empty file (expected the header `{expected}`)")]
    Empty { file: PathBuf, expected: String },
    #[error("{file}, line 1 (header): {message}; the contract is `{expected}`")]
    Header {
        file: PathBuf,
        message: String,
        expected: String,
    },
    #[error("{file}, row {row}{}: {message}", line.map_or_else(String::new, |l| format!(" (line {l})")))]
    Row {
        file: PathBuf,
        row: usize,
        /// The row's line in a CSV file (none in a run log).
        line: Option<usize>,
        message: String,
    },
    #[error("{file}: {message}")]
    Content { file: PathBuf, message: String },
    #[error("{file}: {message}")]
    TooShort { file: PathBuf, message: String },
    /// A channel disagrees with the others or with physics by a gross factor, a sign, a
    /// permutation or as a record of another run: an export mistake (see [`crate::sanity`]).
    #[error("{0}")]
    Implausible(Box<crate::sanity::Finding>),
    #[error("{file}: run log: {source}")]
    Log {
        file: PathBuf,
        source: testbed_log::LogError,
    },
}

/// Why `identify` or `experiment` failed.
#[derive(Debug, thiserror::Error)]
pub enum IdentError {
    #[error(transparent)]
    Data(#[from] DataError),
    #[error(transparent)]
    Config(#[from] testbed_model::config::ConfigError),
    #[error("estimator: {0}")]
    Estimator(#[from] testbed_flight::mekf::MekfError),
    #[error("physics: {0}")]
    Physics(#[from] testbed_model::physics::PhysicsError),
    #[error("closed loop: {0}")]
    Loop(#[from] testbed_sim::closed_loop::LoopError),
    #[error("identification options: `{key}` = {value}: {reason}")]
    Options {
        key: String,
        value: String,
        reason: String,
    },
    #[error("{0}")]
    Failed(String),
}
