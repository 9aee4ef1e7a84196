//! The topic table: every topic of the pipeline, one entry each, in one place.
//!
//! An entry names the topic ([`TopicId`] variant), its sample type, its service name (a
//! constant of this module), the schema name the run log and the ground link give its type
//! (the type's versioned iceoryx2 type name, `"testbed::<Type>.v<N>"`), who publishes it
//! ([`TopicRole`]) and how the ground link shows it ([`GroundView`]). Everything else that lists
//! topics derives from this table: the [`Topic`] impls, [`ALL`], the run log's records, schemas
//! and channel order, the logger's and the ground link's subscriptions and the ground link's
//! channels (through [`for_each_topic!`](crate::for_each_topic)). The table's order is the
//! order of the log's channels (ids 1, 2, …) and of records of equal time in a lockstep log:
//! append new topics at the end.
//!
//! Adding a topic is one entry here; the log crate then asks (by a build error) for the JSON
//! description of the new type's fields.

use crate::{SampleHeader, Topic, TopicRole};

/// How the ground link shows a topic to its viewers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GroundView {
    /// Not served (raw sensor inputs the estimate already shows, the CAN bus, the clock).
    Hidden,
    /// Served decimated to the viewer's rate, per source (streams).
    Decimated,
    /// Served whole: events, heartbeats and commands, every one.
    Whole,
}

/// Generates the table's items; `$d` is a `$` token, so that the generated
/// [`for_each_topic!`](crate::for_each_topic) can have metavariables of its own.
macro_rules! topics {
    ($d:tt $(
        $(#[$doc:meta])*
        $id:ident($ty:ident): $name:ident = $path:literal,
            schema $schema:literal, $role:ident, ground $view:ident;
    )*) => {
        $(
            $(#[$doc])*
            pub const $name: &str = $path;
        )*

        /// Every topic's service name, in table order.
        pub const ALL: &[&str] = &[$($name),*];

        /// A topic of the table (its entry). The order of the variants is the table's.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub enum TopicId {
            $(
                #[doc = concat!("`", $path, "`: [`", stringify!($ty), "`](crate::", stringify!($ty), ").")]
                $id,
            )*
        }

        impl TopicId {
            /// Every topic, in table order.
            pub const ALL: &[TopicId] = &[$(TopicId::$id),*];

            /// The topic's service name.
            pub const fn name(self) -> &'static str {
                match self {
                    $(Self::$id => $name,)*
                }
            }

            /// The schema name of the topic's sample type (its iceoryx2 type name).
            pub const fn schema_name(self) -> &'static str {
                match self {
                    $(Self::$id => $schema,)*
                }
            }

            /// Who publishes the topic.
            pub const fn role(self) -> TopicRole {
                match self {
                    $(Self::$id => TopicRole::$role,)*
                }
            }

            /// How the ground link shows the topic.
            pub const fn ground_view(self) -> GroundView {
                match self {
                    $(Self::$id => GroundView::$view,)*
                }
            }

            /// The topic's position in the table, from 0.
            pub const fn index(self) -> usize {
                self as usize
            }

            /// The topic whose service name is `name`.
            pub fn from_name(name: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|t| t.name() == name)
            }
        }

        $(
            impl Topic for crate::$ty {
                const NAME: &'static str = $name;
                const ROLE: TopicRole = TopicRole::$role;
                fn header(&self) -> &SampleHeader {
                    &self.header
                }
                fn header_mut(&mut self) -> &mut SampleHeader {
                    &mut self.header
                }
            }
        )*

        /// Each topic's iceoryx2 type name, in table order (checked against the schema names).
        #[cfg(test)]
        #[cfg(feature = "zero-copy")]
        pub(crate) fn type_names() -> Vec<(TopicId, &'static str)> {
            // SAFETY: `type_name` only returns the string given to `#[type_name]`.
            vec![$((TopicId::$id, unsafe {
                <crate::$ty as iceoryx2::prelude::ZeroCopySend>::type_name()
            })),*]
        }

        /// Calls the macro `$callback` with every topic of the table, in table order, as
        /// `Id(path::to::SampleType, "service/name"),` (`Id` a [`TopicId`](crate::TopicId)
        /// variant): the way to write code once for every topic type (an enum with a variant
        /// per topic, a subscriber per topic).
        #[macro_export]
        macro_rules! for_each_topic {
            ($d callback:ident) => {
                $d callback! { $($id($crate::$ty, $path),)* }
            };
        }
    };
}

topics! { $
    /// [`GyroSample`](crate::GyroSample), 10 Hz.
    Gyro(GyroSample): GYRO = "testbed/sensors/gyro",
        schema "testbed::GyroSample.v1", Data, ground Decimated;
    /// [`InclinometerSample`](crate::InclinometerSample), 2.5 Hz.
    Inclinometer(InclinometerSample): INCLINOMETER = "testbed/sensors/inclinometer",
        schema "testbed::InclinometerSample.v1", Data, ground Hidden;
    /// [`MagnetometerSample`](crate::MagnetometerSample), 2.5 Hz.
    Magnetometer(MagnetometerSample): MAGNETOMETER = "testbed/sensors/magnetometer",
        schema "testbed::MagnetometerSample.v1", Data, ground Hidden;
    /// [`WheelTelemetry`](crate::WheelTelemetry).
    WheelTelemetry(WheelTelemetry): WHEEL_TELEMETRY = "testbed/actuators/wheels/telemetry",
        schema "testbed::WheelTelemetry.v1", Data, ground Decimated;
    /// [`WheelCommand`](crate::WheelCommand).
    WheelCommand(WheelCommand): WHEEL_COMMAND = "testbed/actuators/wheels/command",
        schema "testbed::WheelCommand.v1", Data, ground Decimated;
    /// [`CmgTelemetry`](crate::CmgTelemetry).
    CmgTelemetry(CmgTelemetry): CMG_TELEMETRY = "testbed/actuators/cmg/telemetry",
        schema "testbed::CmgTelemetry.v1", Data, ground Decimated;
    /// [`CmgCommand`](crate::CmgCommand).
    CmgCommand(CmgCommand): CMG_COMMAND = "testbed/actuators/cmg/command",
        schema "testbed::CmgCommand.v1", Data, ground Decimated;
    /// [`AttitudeEstimate`](crate::AttitudeEstimate).
    AttitudeEstimate(AttitudeEstimate): ATTITUDE_ESTIMATE = "testbed/gnc/attitude_estimate",
        schema "testbed::AttitudeEstimate.v1", Data, ground Decimated;
    /// [`ControllerStatus`](crate::ControllerStatus).
    ControllerStatus(ControllerStatus): CONTROLLER_STATUS = "testbed/gnc/controller_status",
        schema "testbed::ControllerStatus.v1", Data, ground Decimated;
    /// [`SimTruth`](crate::SimTruth), simulation only.
    SimTruth(SimTruth): SIM_TRUTH = "testbed/sim/truth",
        schema "testbed::SimTruth.v1", Data, ground Decimated;
    /// [`SimClockTick`](crate::SimClockTick), simulation only.
    SimClock(SimClockTick): SIM_CLOCK = "testbed/sim/clock",
        schema "testbed::SimClockTick.v1", Data, ground Hidden;
    /// [`Heartbeat`](crate::Heartbeat), published by every process.
    Heartbeat(Heartbeat): HEARTBEAT = "testbed/system/heartbeat",
        schema "testbed::Heartbeat.v1", Housekeeping, ground Whole;
    /// [`CanBusFrame`](crate::CanBusFrame): the software CAN bus, every frame of every sender.
    CanBus(CanBusFrame): CAN_BUS = "testbed/can/bus",
        schema "testbed::CanBusFrame.v1", Shared, ground Hidden;
    /// [`CanLinkStatus`](crate::CanLinkStatus): counters of the CAN gateways and the node.
    CanStatus(CanLinkStatus): CAN_STATUS = "testbed/can/status",
        schema "testbed::CanLinkStatus.v1", Shared, ground Decimated;
    /// [`AppliedWheelCommand`](crate::AppliedWheelCommand): wheel torques as the CAN node applies them.
    WheelApplied(AppliedWheelCommand): WHEEL_APPLIED = "testbed/actuators/wheels/applied",
        schema "testbed::AppliedWheelCommand.v1", Data, ground Hidden;
    /// [`AppliedCmgCommand`](crate::AppliedCmgCommand): gimbal rates as the CAN node applies them.
    CmgApplied(AppliedCmgCommand): CMG_APPLIED = "testbed/actuators/cmg/applied",
        schema "testbed::AppliedCmgCommand.v1", Data, ground Hidden;
    /// [`HealthEvent`](crate::HealthEvent): faults and recoveries (lost inputs, hung or dead
    /// processes, safe mode, zeroed actuators), published when they happen.
    Health(HealthEvent): HEALTH = "testbed/system/health",
        schema "testbed::HealthEvent.v1", Housekeeping, ground Whole;
    /// [`GroundCommand`](crate::GroundCommand): commands from the ground station, accepted by
    /// the ground link, applied by the controller.
    GroundCommand(GroundCommand): GROUND_COMMAND = "testbed/ground/command",
        schema "testbed::GroundCommand.v1", Data, ground Whole;
    /// [`GroundCommandAck`](crate::GroundCommandAck): each ground command applied or rejected,
    /// with the reason.
    GroundCommandAck(GroundCommandAck): GROUND_COMMAND_ACK = "testbed/ground/command_ack",
        schema "testbed::GroundCommandAck.v2", Data, ground Whole;
    /// [`ThrusterCommand`](crate::ThrusterCommand): valve on-times from the controller (runs
    /// with thrusters only).
    ThrusterCommand(ThrusterCommand): THRUSTER_COMMAND = "testbed/actuators/thrusters/command",
        schema "testbed::ThrusterCommand.v1", Data, ground Decimated;
    /// [`ThrusterStatus`](crate::ThrusterStatus): what the thruster drive applied, the valves'
    /// state and the propellant used (runs with thrusters only).
    ThrusterStatus(ThrusterStatus): THRUSTER_STATUS = "testbed/actuators/thrusters/status",
        schema "testbed::ThrusterStatus.v1", Data, ground Decimated;
    /// [`AppliedThrusterCommand`](crate::AppliedThrusterCommand): valve on-times as the CAN
    /// node applies them (CAN actuation with thrusters only).
    ThrusterApplied(AppliedThrusterCommand): THRUSTER_APPLIED = "testbed/actuators/thrusters/applied",
        schema "testbed::AppliedThrusterCommand.v1", Data, ground Hidden;
}
