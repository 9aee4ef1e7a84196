//! The launcher of the test bed's process pipeline: reads a launch profile, starts the
//! processes in dependency order, supervises them and stops them all.
//!
//! See `launch/README.md` for the profile format, the environment children get, the stop
//! sequence and the exit status.

mod cli;
pub mod placement;
pub mod plan;
pub mod profile;
pub mod restart;
pub mod roles;
pub mod supervisor;
pub mod sys;
pub mod watchdog;

pub use cli::{Args, main};
pub use plan::Plan;
pub use profile::{Profile, ProfileError};
pub use roles::Roles;
pub use supervisor::{Outcome, Supervisor};
