//! Fixed-layout sample types and topic names of the test bed pipeline.
//!
//! Every process of the test bed exchanges the types of this crate over iceoryx2
//! publish/subscribe (shared memory, zero copy). Each type is `#[repr(C)]`, derives
//! [`ZeroCopySend`](iceoryx2::prelude::ZeroCopySend) with a stable, versioned type name
//! (`"testbed::<Type>.v<N>"`), holds no pointers, no heap data and no `bool`, and has explicit
//! padding fields so that no implicit padding exists anywhere. The layout of every type is
//! pinned by the tests of this crate: changing a layout must come with a new type-name version.
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
//! [`Topic`] trait ties each sample type to its service name.

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

/// The identity attitude quaternion `[x, y, z, w] = [0, 0, 0, 1]` (B coincides with L).
pub const IDENTITY_QUATERNION: [f64; 4] = [0.0, 0.0, 0.0, 1.0];

/// A sample type published on exactly one topic.
pub trait Topic:
    iceoryx2::prelude::ZeroCopySend + Copy + Default + core::fmt::Debug + 'static
{
    /// Name of the publish/subscribe service (one of the [`topic`] constants).
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

macro_rules! impl_topic {
    ($($ty:ty => $name:ident $(as $role:ident)?),* $(,)?) => {$(
        impl Topic for $ty {
            const NAME: &'static str = topic::$name;
            $(const ROLE: TopicRole = TopicRole::$role;)?
            fn header(&self) -> &SampleHeader { &self.header }
            fn header_mut(&mut self) -> &mut SampleHeader { &mut self.header }
        }
    )*};
}

impl_topic! {
    GyroSample => GYRO,
    InclinometerSample => INCLINOMETER,
    MagnetometerSample => MAGNETOMETER,
    WheelTelemetry => WHEEL_TELEMETRY,
    WheelCommand => WHEEL_COMMAND,
    CmgTelemetry => CMG_TELEMETRY,
    CmgCommand => CMG_COMMAND,
    AttitudeEstimate => ATTITUDE_ESTIMATE,
    ControllerStatus => CONTROLLER_STATUS,
    SimTruth => SIM_TRUTH,
    SimClockTick => SIM_CLOCK,
    Heartbeat => HEARTBEAT as Housekeeping,
    CanBusFrame => CAN_BUS as Shared,
    CanLinkStatus => CAN_STATUS as Shared,
    AppliedWheelCommand => WHEEL_APPLIED,
    AppliedCmgCommand => CMG_APPLIED,
    HealthEvent => HEALTH as Housekeeping,
    GroundCommand => GROUND_COMMAND,
    GroundCommandAck => GROUND_COMMAND_ACK,
}
