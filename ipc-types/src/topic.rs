//! Service names of the pipeline's topics.
//!
//! Each data (publish/subscribe) service `X` is paired with an event service `X_EVENT`, named
//! `X` + [`EVENT_SUFFIX`], on which publishers notify subscribers that a sample was sent.

/// Suffix appended to a topic name to name its paired event service.
pub const EVENT_SUFFIX: &str = "/event";

macro_rules! topics {
    ($($(#[$doc:meta])* $name:ident, $event:ident = $path:literal;)*) => {
        $(
            $(#[$doc])*
            pub const $name: &str = $path;
            #[doc = concat!("Event service paired with [`", stringify!($name), "`].")]
            pub const $event: &str = concat!($path, "/event");
        )*
        /// Every data topic, in declaration order.
        pub const ALL: &[&str] = &[$($name),*];
        /// Every paired event service, in the same order as [`ALL`].
        pub const ALL_EVENTS: &[&str] = &[$($event),*];
    };
}

topics! {
    /// [`GyroSample`](crate::GyroSample), 10 Hz.
    GYRO, GYRO_EVENT = "testbed/sensors/gyro";
    /// [`InclinometerSample`](crate::InclinometerSample), 2.5 Hz.
    INCLINOMETER, INCLINOMETER_EVENT = "testbed/sensors/inclinometer";
    /// [`MagnetometerSample`](crate::MagnetometerSample), 2.5 Hz.
    MAGNETOMETER, MAGNETOMETER_EVENT = "testbed/sensors/magnetometer";
    /// [`WheelTelemetry`](crate::WheelTelemetry).
    WHEEL_TELEMETRY, WHEEL_TELEMETRY_EVENT = "testbed/actuators/wheels/telemetry";
    /// [`WheelCommand`](crate::WheelCommand).
    WHEEL_COMMAND, WHEEL_COMMAND_EVENT = "testbed/actuators/wheels/command";
    /// [`CmgTelemetry`](crate::CmgTelemetry).
    CMG_TELEMETRY, CMG_TELEMETRY_EVENT = "testbed/actuators/cmg/telemetry";
    /// [`CmgCommand`](crate::CmgCommand).
    CMG_COMMAND, CMG_COMMAND_EVENT = "testbed/actuators/cmg/command";
    /// [`AttitudeEstimate`](crate::AttitudeEstimate).
    ATTITUDE_ESTIMATE, ATTITUDE_ESTIMATE_EVENT = "testbed/gnc/attitude_estimate";
    /// [`ControllerStatus`](crate::ControllerStatus).
    CONTROLLER_STATUS, CONTROLLER_STATUS_EVENT = "testbed/gnc/controller_status";
    /// [`SimTruth`](crate::SimTruth), simulation only.
    SIM_TRUTH, SIM_TRUTH_EVENT = "testbed/sim/truth";
    /// [`SimClockTick`](crate::SimClockTick), simulation only.
    SIM_CLOCK, SIM_CLOCK_EVENT = "testbed/sim/clock";
    /// [`Heartbeat`](crate::Heartbeat), published by every process.
    HEARTBEAT, HEARTBEAT_EVENT = "testbed/system/heartbeat";
    /// [`CanBusFrame`](crate::CanBusFrame): the software CAN bus, every frame of every sender.
    CAN_BUS, CAN_BUS_EVENT = "testbed/can/bus";
    /// [`CanLinkStatus`](crate::CanLinkStatus): counters of the CAN gateways and the node.
    CAN_STATUS, CAN_STATUS_EVENT = "testbed/can/status";
    /// [`AppliedWheelCommand`](crate::AppliedWheelCommand): wheel torques as the CAN node applies them.
    WHEEL_APPLIED, WHEEL_APPLIED_EVENT = "testbed/actuators/wheels/applied";
    /// [`AppliedCmgCommand`](crate::AppliedCmgCommand): gimbal rates as the CAN node applies them.
    CMG_APPLIED, CMG_APPLIED_EVENT = "testbed/actuators/cmg/applied";
    /// [`HealthEvent`](crate::HealthEvent): faults and recoveries (lost inputs, hung or dead
    /// processes, safe mode, zeroed actuators), published when they happen.
    HEALTH, HEALTH_EVENT = "testbed/system/health";
    /// [`GroundCommand`](crate::GroundCommand): commands from the ground station, accepted by
    /// the ground link, applied by the controller.
    GROUND_COMMAND, GROUND_COMMAND_EVENT = "testbed/ground/command";
    /// [`GroundCommandAck`](crate::GroundCommandAck): each ground command applied or rejected,
    /// with the reason.
    GROUND_COMMAND_ACK, GROUND_COMMAND_ACK_EVENT = "testbed/ground/command_ack";
    /// [`ThrusterCommand`](crate::ThrusterCommand): valve on-times from the controller (runs
    /// with thrusters only).
    THRUSTER_COMMAND, THRUSTER_COMMAND_EVENT = "testbed/actuators/thrusters/command";
    /// [`ThrusterStatus`](crate::ThrusterStatus): what the thruster drive applied, the valves'
    /// state and the propellant used (runs with thrusters only).
    THRUSTER_STATUS, THRUSTER_STATUS_EVENT = "testbed/actuators/thrusters/status";
    /// [`AppliedThrusterCommand`](crate::AppliedThrusterCommand): valve on-times as the CAN
    /// node applies them (CAN actuation with thrusters only).
    THRUSTER_APPLIED, THRUSTER_APPLIED_EVENT = "testbed/actuators/thrusters/applied";
}

/// Name of the event service paired with the data service `topic` (`topic` + [`EVENT_SUFFIX`]).
pub fn event_service_name(topic: &str) -> String {
    let mut name = String::with_capacity(topic.len() + EVENT_SUFFIX.len());
    name.push_str(topic);
    name.push_str(EVENT_SUFFIX);
    name
}
