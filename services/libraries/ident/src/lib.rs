//! System identification for the test bed: what the simulation gets wrong, which effect causes
//! it, the extended model, and how much better it predicts.
//!
//! * [`data`], [`csv`], [`runlog`]: measured data (the CSV directory contract of
//!   `docs/measured-data.md`, or an MCAP run log) and its alignment on the gyro's clock; `csv`
//!   reads and writes the files' plain records, `data` builds the [`Dataset`] from them.
//! * [`sanity`]: the data's mistakes (units, signs, exchanged columns, another run's channel)
//!   found before any cause is fitted.
//! * [`reconstruct`]: the estimated state (the project's MEKF over the data).
//! * [`channels`]: equation-error channels (platform momentum, wheels) and their regressors.
//! * [`effects`]: the library of candidate causes (the model's effect tables).
//! * [`fit`]: fitting sets of causes, with standard errors.
//! * [`predict`]: multi-step predictions of the measurements by the plant model, re-initialised
//!   from the estimated state.
//! * [`identify`]: the whole analysis — residual report, forward selection, extended model, gain.
//! * [`friction_id`]: wheel friction from spin-down data (paper eq. 4–5).
//! * [`experiment`]: an excitation schedule for the closed loop and its data as a CSV directory.
//! * [`design`]: D-optimal choice of that schedule's amplitudes and timing within the tilt and
//!   wheel-speed limits.
//! * [`stats`]: least squares and residual statistics; [`spectral`]: the Whittle test of a
//!   coloured (Gauss–Markov) component in a residual.
//! * [`thrusters`]: the thrust time and propellant use of the recorded valve on-times.
//! * [`balance`]: the balance masses' moves that bring an identified centre of mass to its
//!   target, with the predicted residual and its uncertainty.

#![forbid(unsafe_code)]
// Index loops over the 3 axes and the parameter columns read as the maths they implement.
#![allow(clippy::needless_range_loop)]

pub mod balance;
pub mod channels;
pub mod csv;
pub mod data;
pub mod design;
pub mod effects;
pub mod error;
pub mod experiment;
pub mod fit;
pub mod friction_id;
pub mod identify;
pub mod predict;
pub mod reconstruct;
pub mod runlog;
pub mod sanity;
pub mod separability;
pub mod sparse;
pub mod spectral;
pub mod spikes;
pub mod stats;
pub mod tangent;
pub mod thrusters;

pub use data::Dataset;
pub use effects::Cause;
pub use error::{DataError, IdentError};
pub use identify::{Identification, Options, Report, identify};
