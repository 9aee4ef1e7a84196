//! The configuration of a run, read by every process, the launcher and the CLI: the run file
//! ([`RunConfig`], its path in [`ENV_RUN_CONFIG`]) and the ground link's settings
//! ([`GroundConfig`]). Plain data and its validation: no bus, so the simulation, the
//! identification and the CLI's offline commands read a run without linking iceoryx2.

#![forbid(unsafe_code)]

mod ground;
mod run;

pub use ground::{ENV_GROUND_TOKEN, GroundConfig, random_token};
pub use run::{
    Actuation, CanFaults, CanLink, CanSection, DEFAULT_LOCKSTEP_WAIT, ENV_RUN_CONFIG, RunConfig,
    RunConfigError, RunSection, SerialLinkConfig,
};
