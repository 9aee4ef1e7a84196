//! Why a campaign was refused or its results could not be read; every message names the file,
//! and the key and value where there is one.

/// A refused campaign, or results that cannot be read or merged.
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    #[error("cannot read campaign {path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error("campaign {path}: {message}")]
    Parse { path: String, message: String },
    #[error("campaign {path}: dispersion `{key}`: {reason}")]
    Dispersion {
        path: String,
        key: String,
        reason: String,
    },
    #[error("campaign {path}: variant `{variant}`: {reason}")]
    Variant {
        path: String,
        variant: String,
        reason: String,
    },
    /// The base run configuration (its config file, or `[base]`) was refused.
    #[error("campaign {path}: base run configuration: {reason}")]
    Base { path: String, reason: String },
    /// One run's configuration, with its draws, was refused.
    #[error("campaign {path}: run {index}{variant}: with {assignments}: {reason}")]
    Run {
        path: String,
        index: u64,
        /// ` (variant b)`, or empty without variants.
        variant: String,
        /// The dispersed values of the run, `key = value, …`.
        assignments: String,
        reason: String,
    },
    #[error("campaign results {path}: {reason}")]
    Results { path: String, reason: String },
    #[error("cannot start the campaign's worker threads: {0}")]
    Workers(String),
    #[error("merging campaign results: {0}")]
    Merge(String),
}
