//! Service names of the pipeline's topics (one iceoryx2 publish/subscribe service each).

macro_rules! topics {
    ($($(#[$doc:meta])* $name:ident = $path:literal;)*) => {
        $(
            $(#[$doc])*
            pub const $name: &str = $path;
        )*
        /// Every data topic, in declaration order.
        pub const ALL: &[&str] = &[$($name),*];
    };
}

topics! {
    /// [`GyroSample`](crate::GyroSample), 10 Hz.
    GYRO = "testbed/sensors/gyro";
    /// [`InclinometerSample`](crate::InclinometerSample), 2.5 Hz.
    INCLINOMETER = "testbed/sensors/inclinometer";
    /// [`MagnetometerSample`](crate::MagnetometerSample), 2.5 Hz.
    MAGNETOMETER = "testbed/sensors/magnetometer";
    /// [`WheelTelemetry`](crate::WheelTelemetry).
    WHEEL_TELEMETRY = "testbed/actuators/wheels/telemetry";
    /// [`WheelCommand`](crate::WheelCommand).
    WHEEL_COMMAND = "testbed/actuators/wheels/command";
    /// [`CmgTelemetry`](crate::CmgTelemetry).
    CMG_TELEMETRY = "testbed/actuators/cmg/telemetry";
    /// [`CmgCommand`](crate::CmgCommand).
    CMG_COMMAND = "testbed/actuators/cmg/command";
    /// [`AttitudeEstimate`](crate::AttitudeEstimate).
    ATTITUDE_ESTIMATE = "testbed/gnc/attitude_estimate";
    /// [`ControllerStatus`](crate::ControllerStatus).
    CONTROLLER_STATUS = "testbed/gnc/controller_status";
    /// [`SimTruth`](crate::SimTruth), simulation only.
    SIM_TRUTH = "testbed/sim/truth";
    /// [`SimClockTick`](crate::SimClockTick), simulation only.
    SIM_CLOCK = "testbed/sim/clock";
    /// [`Heartbeat`](crate::Heartbeat), published by every process.
    HEARTBEAT = "testbed/system/heartbeat";
    /// [`CanBusFrame`](crate::CanBusFrame): the software CAN bus, every frame of every sender.
    CAN_BUS = "testbed/can/bus";
    /// [`CanLinkStatus`](crate::CanLinkStatus): counters of the CAN gateways and the node.
    CAN_STATUS = "testbed/can/status";
    /// [`AppliedWheelCommand`](crate::AppliedWheelCommand): wheel torques as the CAN node applies them.
    WHEEL_APPLIED = "testbed/actuators/wheels/applied";
    /// [`AppliedCmgCommand`](crate::AppliedCmgCommand): gimbal rates as the CAN node applies them.
    CMG_APPLIED = "testbed/actuators/cmg/applied";
    /// [`HealthEvent`](crate::HealthEvent): faults and recoveries (lost inputs, hung or dead
    /// processes, safe mode, zeroed actuators), published when they happen.
    HEALTH = "testbed/system/health";
    /// [`GroundCommand`](crate::GroundCommand): commands from the ground station, accepted by
    /// the ground link, applied by the controller.
    GROUND_COMMAND = "testbed/ground/command";
    /// [`GroundCommandAck`](crate::GroundCommandAck): each ground command applied or rejected,
    /// with the reason.
    GROUND_COMMAND_ACK = "testbed/ground/command_ack";
    /// [`ThrusterCommand`](crate::ThrusterCommand): valve on-times from the controller (runs
    /// with thrusters only).
    THRUSTER_COMMAND = "testbed/actuators/thrusters/command";
    /// [`ThrusterStatus`](crate::ThrusterStatus): what the thruster drive applied, the valves'
    /// state and the propellant used (runs with thrusters only).
    THRUSTER_STATUS = "testbed/actuators/thrusters/status";
    /// [`AppliedThrusterCommand`](crate::AppliedThrusterCommand): valve on-times as the CAN
    /// node applies them (CAN actuation with thrusters only).
    THRUSTER_APPLIED = "testbed/actuators/thrusters/applied";
}
