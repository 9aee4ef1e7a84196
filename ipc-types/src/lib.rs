//! Fixed-layout sample types and topic names of the test bed pipeline.
//!
//! Every process of the test bed exchanges the types of this crate over iceoryx2
//! publish/subscribe (shared memory, zero copy). Each type is `#[repr(C)]`, derives iceoryx2's
//! `ZeroCopySend` with a stable, versioned type name (`"testbed::<Type>.v<N>"`), holds no
//! pointers, no heap data and no `bool`, and has explicit padding fields so that no implicit
//! padding exists anywhere. The layout of every type is pinned by the tests of this crate:
//! changing a layout must come with a new type-name version.
//!
//! # Features
//!
//! - `zero-copy` (default): the iceoryx2 derive and type names, so the types can go on the bus
//!   (`testbed-bus` enables it). Crates that only compute with the samples (flight, simulation,
//!   identification, the log) depend on this crate without it and so do not link iceoryx2; the
//!   layout is the same either way (`#[repr(C)]`, pinned by the tests).
//!
//! Every sample starts with a [`SampleHeader`] carrying the time the sample describes (device or
//! simulation time, ns on the run's clock), a sequence number and validity flags.
//!
//! # Units and frames
//!
//! SI units throughout (rad, rad/s, T, Nm, Nms, J, ns). Vectors are given in body-frame
//! components unless a field's documentation says otherwise.
//!
//! - Level frame L: x north, y west, z up.
//! - Body frame B: fixed to the platform; reaction wheel `i` spins about body axis `i`
//!   (x, y, z); CMGs are numbered 1–4 (array index 0–3) around the pyramid.
//!
//! # Quaternion convention
//!
//! Attitude quaternion q = [x, y, z, w] (scalar last, Hamilton product as in nalgebra, whose
//! `Quaternion::coords` storage has the same order). q is the rotation from the level frame L
//! (x north, y west, z up) to the body frame B: v_B = q ⊗ v_L ⊗ q*, i.e. A(q) = nalgebra
//! `UnitQuaternion::to_rotation_matrix()` maps L components to B components. Kinematics:
//! q' = ½ (0, −ω_B) ⊗ q (left multiplication in Hamilton product).
//!
//! # Services
//!
//! Each topic is one iceoryx2 publish/subscribe service named by a constant of [`topic`]. The
//! topic table there ([`TopicId`]) ties each sample type to its service name and implements
//! [`Topic`]; [`for_each_topic!`] hands the table to code written once for every topic.

mod actuators;
mod can;
mod gnc;
mod ground;
mod header;
mod run;
mod sensors;
mod sim;
mod system;
pub mod thrusters;
pub mod topic;
mod wait;

#[cfg(test)]
mod tests;

pub use actuators::{CmgCommand, CmgTelemetry, WheelCommand, WheelTelemetry};
pub use can::{AppliedCmgCommand, AppliedWheelCommand, CanBusFrame, CanLinkStatus, can_source};
pub use gnc::{AttitudeEstimate, ControllerMode, ControllerStatus};
pub use ground::{GroundAckStatus, GroundCommand, GroundCommandAck, GroundCommandKind};
pub use header::SampleHeader;
pub use run::{
    ClockMode, Device, ENV_RESTART_COUNT, ENV_SERVED_DEVICES, parse_devices, restart_count,
    served_devices,
};
pub use sensors::{GyroSample, InclinometerSample, MagnetometerSample};
pub use sim::{SimClockTick, SimTruth};
pub use system::{HealthEvent, HealthEventKind, Heartbeat, ProcessState};
pub use thrusters::{AppliedThrusterCommand, ThrusterCommand, ThrusterStatus};
pub use topic::{GroundView, TopicId};
pub use wait::{ENV_WAIT, WaitStrategy, WaitStrategyError};

/// The identity attitude quaternion `[x, y, z, w] = [0, 0, 0, 1]` (B coincides with L).
pub const IDENTITY_QUATERNION: [f64; 4] = [0.0, 0.0, 0.0, 1.0];

/// What a sample type must be to travel on the bus: with the `zero-copy` feature an iceoryx2
/// `ZeroCopySend` payload (every sample type of this crate then derives it, so a [`Topic`]
/// implemented outside this crate must too); without it, no requirement.
#[cfg(feature = "zero-copy")]
pub trait Payload: iceoryx2::prelude::ZeroCopySend {}
#[cfg(feature = "zero-copy")]
impl<T: iceoryx2::prelude::ZeroCopySend> Payload for T {}
/// What a sample type must be to travel on the bus: without the `zero-copy` feature, no
/// requirement (nothing here goes on the bus).
#[cfg(not(feature = "zero-copy"))]
pub trait Payload {}
#[cfg(not(feature = "zero-copy"))]
impl<T> Payload for T {}

/// A sample type published on exactly one topic.
pub trait Topic: Payload + Copy + Default + core::fmt::Debug + 'static {
    /// Name of the publish/subscribe service (for the pipeline's topics one of the [`topic`]
    /// constants, set by the topic table).
    const NAME: &'static str;
    /// Who publishes the topic and how it is delivered (sets the service's publisher slots and
    /// overflow policy).
    const ROLE: TopicRole = TopicRole::Data;

    /// The sample's common header.
    fn header(&self) -> &SampleHeader;
    /// The sample's common header, mutably.
    fn header_mut(&mut self) -> &mut SampleHeader;
}

/// Who publishes a topic, and so how its service is built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TopicRole {
    /// One publisher in a run (a gateway's samples, the estimate, the commands). Delivered
    /// as the run says: lossless in lockstep, overflowing when paced.
    Data,
    /// Many publishers, delivered as the run says: every CAN sender's frames and link counters.
    Shared,
    /// Published by every process about itself, and always overflowing. Heartbeats are paced
    /// by wall time and never part of a reproducible log, and a process must never block on a
    /// heartbeat nobody reads; health events are rare and published when something has already
    /// gone wrong, possibly with a dead subscriber: reporting a fault must never block the
    /// reporter.
    Housekeeping,
}

impl TopicRole {
    /// Whether more than one process publishes the topic in a run.
    pub const fn has_many_publishers(self) -> bool {
        !matches!(self, Self::Data)
    }
}
