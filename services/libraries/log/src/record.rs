//! The logged sample types: [`LogRecord`], [`LogEncode`], their JSON encoding and JSON Schemas.

use crate::json::{DecodeError, Field, as_object, check_no_extra, member, object_schema};
use ipc_types::{
    AppliedCmgCommand, AppliedThrusterCommand, AppliedWheelCommand, AttitudeEstimate, CanBusFrame,
    CanLinkStatus, CmgCommand, CmgTelemetry, ControllerStatus, GroundCommand, GroundCommandAck,
    GyroSample, HealthEvent, Heartbeat, InclinometerSample, MagnetometerSample, SampleHeader,
    SimClockTick, SimTruth, ThrusterCommand, ThrusterStatus, Topic, TopicId, WheelCommand,
    WheelTelemetry,
};
use serde_json::Value;

mod sealed {
    /// The JSON side of a logged type (implemented by [`log_schemas!`] only, which seals
    /// [`LogEncode`](super::LogEncode)).
    pub trait Json: Sized {
        fn json_schema() -> String;
        fn encode_json(&self, out: &mut Vec<u8>);
        fn decode_json(data: &[u8]) -> Result<Self, super::DecodeError>;
    }
}

/// A sample type the run log can hold: every type of the topic table of `ipc-types`.
///
/// Implemented for exactly the types of [`LogRecord`]'s variants (sealed).
pub trait LogEncode: Topic + sealed::Json {
    /// The type's topic in the table.
    const ID: TopicId;
    /// Name of the type's schema in the log: the iceoryx2 type name (`"testbed::<Type>.v<N>"`),
    /// so a layout change (new version) is a new schema.
    const SCHEMA_NAME: &'static str = Self::ID.schema_name();

    /// The JSON Schema (draft 2020-12) of the type's messages, with units in the descriptions.
    fn json_schema() -> String {
        <Self as sealed::Json>::json_schema()
    }

    /// Appends the message's JSON (deterministic: fields in declaration order, no whitespace,
    /// padding fields left out) to `out`.
    fn encode_json(&self, out: &mut Vec<u8>) {
        sealed::Json::encode_json(self, out)
    }

    /// Decodes a JSON message written by [`encode_json`](Self::encode_json).
    fn decode_json(data: &[u8]) -> Result<Self, DecodeError> {
        <Self as sealed::Json>::decode_json(data)
    }

    /// The sample as a [`LogRecord`].
    fn into_record(self) -> LogRecord;

    /// The sample, if `record` holds this type.
    fn from_record(record: &LogRecord) -> Option<Self>;
}

/// [`LogRecord`] and the [`LogEncode`] impls, one variant per topic of the table, in table
/// order (called by [`ipc_types::for_each_topic!`]).
macro_rules! log_records {
    ($($id:ident($ty:ty, $path:literal),)*) => {
        /// One sample of any topic, as held in the run log.
        ///
        /// Variants are in the order of the topic table ([`TopicId`]), which is also the topic
        /// order used to sort records of equal time (see [`TickSorter`](crate::TickSorter)).
        // Samples are plain fixed-size values (480 bytes at most); boxing would cost an
        // allocation per record and the `Copy`.
        #[allow(clippy::large_enum_variant)]
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub enum LogRecord {
            $(
                #[doc = concat!("A sample on `", $path, "`.")]
                $id($ty),
            )*
        }

        impl TopicJson for TopicId {
            fn json_schema(self) -> String {
                match self {
                    $(Self::$id => <$ty as LogEncode>::json_schema(),)*
                }
            }

            fn decode(self, data: &[u8]) -> Result<LogRecord, DecodeError> {
                Ok(match self {
                    $(Self::$id => LogRecord::$id(<$ty as LogEncode>::decode_json(data)?),)*
                })
            }
        }

        impl LogRecord {
            /// The record's topic.
            pub const fn topic_id(&self) -> TopicId {
                match self {
                    $(Self::$id(_) => TopicId::$id,)*
                }
            }

            /// The record's sample header.
            pub fn header(&self) -> &SampleHeader {
                match self {
                    $(Self::$id(s) => s.header(),)*
                }
            }

            /// The record's sample header, mutably (e.g. to set
            /// [`REPLAYED`](SampleHeader::REPLAYED) when replaying).
            pub fn header_mut(&mut self) -> &mut SampleHeader {
                match self {
                    $(Self::$id(s) => s.header_mut(),)*
                }
            }

            /// Appends the record's JSON message to `out` (see [`LogEncode::encode_json`]).
            pub fn encode_json(&self, out: &mut Vec<u8>) {
                match self {
                    $(Self::$id(s) => LogEncode::encode_json(s, out),)*
                }
            }
        }

        $(
            impl From<$ty> for LogRecord {
                fn from(sample: $ty) -> Self {
                    Self::$id(sample)
                }
            }

            impl LogEncode for $ty {
                const ID: TopicId = TopicId::$id;

                fn into_record(self) -> LogRecord {
                    LogRecord::$id(self)
                }

                fn from_record(record: &LogRecord) -> Option<Self> {
                    match record {
                        LogRecord::$id(s) => Some(*s),
                        #[allow(unreachable_patterns)]
                        _ => None,
                    }
                }
            }
        )*
    };
}

ipc_types::for_each_topic!(log_records);

/// What the log knows of each topic beyond the table: its JSON Schema and decoder.
pub trait TopicJson {
    /// The JSON Schema text.
    fn json_schema(self) -> String;
    /// Decodes a JSON message of this topic.
    fn decode(self, data: &[u8]) -> Result<LogRecord, DecodeError>;
}

impl LogRecord {
    /// The topic (service) name of the record.
    pub const fn topic(&self) -> &'static str {
        self.topic_id().name()
    }

    /// The schema name of the record's type (see [`LogEncode::SCHEMA_NAME`]).
    pub const fn schema_name(&self) -> &'static str {
        self.topic_id().schema_name()
    }

    /// Decodes a JSON message published on `topic`; `None` if `topic` is not a topic of the
    /// table.
    pub fn decode_json(topic: &str, data: &[u8]) -> Option<Result<Self, DecodeError>> {
        TopicId::from_name(topic).map(|id| id.decode(data))
    }
}

/// The JSON encoding and Schema of each logged type: a description of the type, then of each
/// field (with its unit), in declaration order, and the padding fields left out. The field
/// list is exhaustive: a field added to the type without being described fails to build.
macro_rules! log_schemas {
    ($(
        $ty:ident $desc:literal {
            header: $hdesc:literal,
            $($field:ident: $fdesc:literal,)*
        } pad [$($pad:ident),*];
    )*) => {$(
        impl sealed::Json for $ty {
            fn json_schema() -> String {
                let mut schema = object_schema(
                    <$ty as LogEncode>::SCHEMA_NAME,
                    $desc,
                    &[
                        ("header", <SampleHeader as Field>::schema($hdesc)),
                        $((
                            stringify!($field),
                            field_schema(&|s: &$ty| &s.$field, $fdesc),
                        ),)*
                    ],
                );
                if let Value::Object(map) = &mut schema {
                    map.insert(
                        "$schema".to_owned(),
                        Value::from("https://json-schema.org/draft/2020-12/schema"),
                    );
                }
                schema.to_string()
            }

            fn encode_json(&self, out: &mut Vec<u8>) {
                // Exhaustive: a field added to the type without being logged fails to build.
                let $ty { header, $($field,)* $($pad: _,)* } = self;
                out.extend_from_slice(b"{\"header\":");
                header.write(out);
                $(
                    out.extend_from_slice(concat!(",\"", stringify!($field), "\":").as_bytes());
                    $field.write(out);
                )*
                out.push(b'}');
            }

            fn decode_json(data: &[u8]) -> Result<Self, DecodeError> {
                let value: Value = serde_json::from_slice(data)?;
                let obj = as_object(&value, "")?;
                let sample = $ty {
                    header: member(obj, "", "header")?,
                    $($field: member(obj, "", stringify!($field))?,)*
                    $($pad: 0,)*
                };
                check_no_extra(obj, "", &["header", $(stringify!($field)),*])?;
                Ok(sample)
            }
        }
    )*};
}

/// The schema of the field `get` returns (type inference helper for the macro).
fn field_schema<S, F: Field>(_get: &dyn Fn(&S) -> &F, description: &str) -> Value {
    F::schema(description)
}

log_schemas! {
    GyroSample
    "One sample of the three fibre-optic gyros (10 Hz)." {
        header: "Common header; time_ns is the device's sampling instant.",
        rate: "Measured angular rate of B against inertial space, body axes x, y, z, rad/s \
               (as the gyros sense it: including bias, noise and the Earth's rotation).",
    } pad [];

    InclinometerSample
    "One sample of the two-axis inclinometer (2.5 Hz)." {
        header: "Common header; time_ns is the device's sampling instant.",
        tilt: "Measured tilt angles [theta, phi] of body x and body y against the level plane, \
               rad, defined by the body components of gravity \
               G_B = [sin theta, sin phi, -sqrt(1 - sin^2 theta - sin^2 phi)].",
    } pad [];

    MagnetometerSample
    "One sample of the three-axis magnetometer (2.5 Hz)." {
        header: "Common header; time_ns is the device's sampling instant.",
        field: "Measured magnetic flux density, body axes x, y, z, T (tesla; 1 gauss = 1e-4 T).",
    } pad [];

    WheelTelemetry
    "Telemetry of the three reaction wheels (wheel i spins about body axis i)." {
        header: "Common header; time_ns is the device's sampling instant.",
        speed: "Wheel speeds relative to the platform, about each wheel's own axis, rad/s.",
        torque: "Measured (motor-current-derived) motor torque on each wheel, about its axis, \
                 N m. The platform feels the opposite torque.",
    } pad [];

    WheelCommand
    "Motor torque command to the three reaction wheels." {
        header: "Common header; time_ns is the time of the input the command was computed \
                 from. SATURATED flags mark channels clipped to the torque limit.",
        torque: "Commanded motor torque on each wheel, about its axis, N m. The platform feels \
                 the opposite torque.",
    } pad [];

    CmgTelemetry
    "Telemetry of the four control moment gyros (pyramid, CMG 1-4 at index 0-3)." {
        header: "Common header; time_ns is the device's sampling instant.",
        gimbal_angle: "Gimbal angles from the encoders, rad.",
        gimbal_rate: "Gimbal rates, rad/s.",
    } pad [];

    CmgCommand
    "Gimbal rate command to the four control moment gyros." {
        header: "Common header; time_ns is the time of the input the command was computed \
                 from. SATURATED flags mark gimbals clipped to the rate limit.",
        gimbal_rate: "Commanded gimbal rates, rad/s.",
    } pad [];

    AttitudeEstimate
    "Output of the attitude estimator (MEKF). Error-state order: [dtheta_x, dtheta_y, dtheta_z, \
     db_x, db_y, db_z], dtheta the small-angle attitude error in body axes (rad), db the gyro \
     bias error (rad/s)." {
        header: "Common header; time_ns is the time the estimate refers to (the latest gyro \
                 sample).",
        quaternion: "Estimated attitude quaternion [x, y, z, w] (scalar last, Hamilton), \
                     rotation from the level frame L (x north, y west, z up) to the body frame \
                     B; dimensionless.",
        rate: "Estimated angular rate of B relative to L, body axes, rad/s (gyro rate minus \
               estimated bias).",
        gyro_bias: "Estimated gyro bias, body axes, rad/s (absorbs the Earth's rotation as the \
                    gyro senses it).",
        covariance: "6x6 error-state covariance, row-major (P[i][j] at 6*i + j); units rad^2, \
                     rad^2/s, rad^2/s^2 by block.",
        innovation: "Normalised innovations of the latest vector update, dimensionless, order \
                     [G_x, G_y, G_z, M_x, M_y, M_z] (gravity direction, magnetic field; body \
                     axes). Components whose innovation_mask bit is clear are undefined.",
        innovation_time_ns: "Time of the latest vector update the innovations belong to, ns on \
                             the run's clock.",
        innovation_mask: "Bit i set: innovation[i] was computed in the latest update (bits 0-2 \
                          gravity, 3-5 magnetic field).",
        updates_applied: "Vector-measurement updates applied since start (count).",
        updates_skipped: "Updates skipped since start (invalid, stale or unusable measurement; \
                          count).",
        updates_rejected: "Updates rejected by innovation gating since start (count).",
    } pad [_pad0];

    ControllerStatus
    "Status of the attitude controller, published once per control cycle." {
        header: "Common header; time_ns is the time of the estimate the cycle used.",
        mode: "Controller mode: 0 Idle, 1 RateDamping, 2 WheelPointing, 3 CmgSlew, 4 Fault, \
               5 Safe.",
        attitude_error: "Attitude error 2*q_e,v (vector part of q_e = q * q_ref^-1), body axes, \
                         rad.",
        torque_command: "Commanded control torque on the platform, body axes, N m (before \
                         allocation, including friction compensation).",
        deadline_misses: "Control cycles that missed their deadline since start (count).",
        loop_period_ns: "Time since the previous control cycle, ns on the run's clock.",
        compute_time_ns: "Compute time of this cycle, ns of wall-clock time; diagnostic only, 0 \
                          in lockstep simulation.",
    } pad [_pad0];

    SimTruth
    "True state of the simulated platform (simulation only), published every tick." {
        header: "Common header; time_ns is the simulation time of the state.",
        quaternion: "True attitude quaternion [x, y, z, w] (scalar last, Hamilton), rotation \
                     from the level frame L (x north, y west, z up) to the body frame B; \
                     dimensionless.",
        rate: "True angular rate of B relative to L, body axes, rad/s.",
        wheel_speed: "True reaction wheel speeds relative to the platform, about each wheel's \
                      axis, rad/s.",
        gimbal_angle: "True CMG gimbal angles, rad.",
        gyro_bias: "True bias of the simulated gyros, body axes, rad/s.",
        angular_momentum: "Total angular momentum (platform, wheels, CMGs), level-frame L \
                           components, N m s.",
        kinetic_energy: "Total rotational kinetic energy (platform, wheels, CMGs), J.",
        tilt_stop: "Bit 0: at the air bearing's tilt stop about body x; bit 1: about body y.",
    } pad [_pad0];

    SimClockTick
    "One tick of the simulation clock (simulation only)." {
        header: "Common header; time_ns equals sim_time_ns, sequence equals tick.",
        tick: "Tick index, 0 at the start of the run.",
        sim_time_ns: "Simulation time of this tick, ns since the start of the run.",
        step_ns: "Length of the step from this tick to the next, ns.",
    } pad [];

    Heartbeat
    "Periodic liveness and counter report of one process (all processes share the topic; pid \
     differs between runs)." {
        header: "Common header; time_ns is the run's clock when the report was made.",
        name: "Process name (UTF-8, at most 32 bytes).",
        pid: "OS process id.",
        state: "Process state: 0 Starting, 1 Running, 2 Degraded, 3 Stopping, 4 Faulted.",
        samples_in: "Samples received since start (count).",
        samples_out: "Samples published since start (count).",
        errors: "Errors since start (count).",
        frames_ok: "Device frames decoded successfully since start (gateways; 0 elsewhere).",
        frames_bad: "Device frames rejected since start (gateways; 0 elsewhere).",
    } pad [];

    CanBusFrame
    "One classic CAN frame on the software CAN bus, as its sender put it on the bus." {
        header: "Common header; time_ns is the run-clock time the frame was sent, sequence \
                 counts the sender's frames, source_id is the sender: 1 CAN node, 2 gyro, \
                 3 inclinometer, 4 magnetometer, 5 wheel, 6 CMG gateway, 7 replay.",
        can_id: "Identifier with the Linux flags: bit 31 extended (29-bit) identifier, bit 30 \
                 remote frame; otherwise the 11-bit identifier.",
        len: "Data length code, 0 to 8 (bytes).",
        data: "Payload bytes; bytes past len are zero.",
        check: "Frame check sequence (CRC-15/CAN) over the frame's 16 bytes; a frame whose \
                check does not match was corrupted on the bus.",
    } pad [_pad0, _pad1, _pad2];

    CanLinkStatus
    "Frame and error counters of one CAN link (a gateway or the CAN node), totals since start." {
        header: "Common header; time_ns is the latest tick of the link, source_id the link: \
                 1 CAN node, 2 gyro, 3 inclinometer, 4 magnetometer, 5 wheel, 6 CMG gateway.",
        frames_ok: "Frames of the link's device decoded and used (count).",
        frames_bad: "Frames rejected: CRC, DLC, unknown identifier, duplicate, late (count).",
        crc_errors: "Frames dropped for a failed frame check (count).",
        wrong_dlc: "Frames with the wrong data length (count).",
        unknown_id: "Frames outside the identifier map (count).",
        duplicates: "Repeated frames (count).",
        lost_frames: "Frames missed, from rolling-counter jumps (count).",
        incomplete_samples: "Multi-frame samples abandoned incomplete (count).",
        late_frames: "Frames arriving after their tick's deadline (count).",
        out_of_range: "Frames with a value beyond the device range (count).",
        stale_samples: "Samples published STALE, not VALID, at the tick deadline (count).",
        frames_sent: "Frames sent (count).",
        commands_clamped: "Commands clamped to their limit before sending (count).",
        commands_refused: "Commands refused and replaced by the safe command (count).",
        transport_errors: "Transport send or receive errors (count).",
        injected_tx_drop: "Simulated node: sent frames dropped by fault injection (count).",
        injected_tx_corrupt: "Simulated node: sent frames corrupted (count).",
        injected_tx_delay: "Simulated node: sent frames delayed past the tick sync (count).",
        injected_tx_duplicate: "Simulated node: sent frames duplicated (count).",
        injected_rx_drop: "Simulated node: received command frames dropped (count).",
        injected_rx_corrupt: "Simulated node: received command frames corrupted (count).",
        injected_rx_delay: "Simulated node: received command frames delayed (count).",
        injected_rx_duplicate: "Simulated node: received command frames duplicated (count).",
    } pad [];

    AppliedWheelCommand
    "Reaction wheel motor torques as the CAN node applies them (CAN actuation path)." {
        header: "Common header; time_ns is the tick the command is applied for; STALE: the \
                 node holds the previous command (none complete and valid for this tick).",
        torque: "Motor torque on each wheel, about its axis, N m. The platform feels the \
                 opposite torque.",
    } pad [];

    AppliedCmgCommand
    "CMG gimbal rates as the CAN node applies them (CAN actuation path)." {
        header: "Common header; time_ns is the tick the command is applied for; STALE: the \
                 node holds the previous command.",
        gimbal_rate: "Gimbal rates, rad/s.",
    } pad [];

    HealthEvent
    "A fault or recovery seen by a process or the launcher (the run's event list)." {
        header: "Common header; time_ns is the run's clock when the event was seen (the \
                 reporter's latest sample time), sequence counts the reporter's events.",
        reporter: "Reporting process (UTF-8, at most 32 bytes; launcher for the supervisor).",
        subject: "What the event is about: a process name, or a topic without its testbed/ \
                  prefix.",
        kind: "Event kind: 1 input lost, 2 input restored, 3 process hung, 4 process exited, \
               5 process restarted, 6 safe mode entered, 7 safe mode left, 8 commands zeroed, \
               9 commands resumed, 10 run aborted, 11 thrusters disabled.",
        detail: "Kind-specific: exit status or 128 + signal (4), restart count (5), safe-mode \
                 reason bits (6: 1 estimate lost, 2 estimate invalid, 4 wheel telemetry lost, \
                 8 CMG telemetry lost, 16 wheel near its speed limit, 32 ground command), the \
                 thruster found stuck open (11).",
        value: "Kind-specific: time since the last sample or heartbeat, or outage length, s.",
    } pad [];

    GroundCommand
    "A command from the ground station, accepted by the ground link (token, limits, rate) for \
     the controller." {
        header: "Common header; time_ns is the run's clock as the link last saw it, sequence \
                 counts the link's commands.",
        kind: "Command: 1 mode, 2 target, 3 experiment start, 4 experiment abort.",
        mode: "With kind 1: controller mode asked for (0 Idle, 1 RateDamping, 2 WheelPointing, \
               3 CmgSlew, 5 Safe).",
        target_heading_rad: "With kind 2: target heading, rad.",
        target_pitch_rad: "With kind 2: target tilt about body y, rad.",
        target_roll_rad: "With kind 2: target tilt about body x, rad.",
        command_id: "Identifier the viewer gave the command.",
        client_id: "The link's number for the viewer's connection.",
    } pad [_pad0];

    GroundCommandAck
    "The outcome of a ground command: applied by the controller or rejected, with the reason." {
        header: "Common header; time_ns is the run's clock of the decision.",
        command_id: "The command's identifier (0 if the message had none).",
        kind: "The command's kind (0 if it could not be read).",
        status: "1 applied, 2 rejected.",
        client_id: "The viewer's connection.",
        decided_by: "1 the ground link, 2 the controller.",
        reason: "Why it was rejected, or what was applied (UTF-8, at most 256 bytes).",
    } pad [];

    ThrusterCommand
    "Valve on-times of the six thrusters for one control period, from the controller. Thruster \
     2a gives + torque about body axis a, thruster 2a+1 - torque." {
        header: "Common header; time_ns is the time of the input the command was computed \
                 from (the valves open at the start of the period that follows).",
        on_time: "Electrical on-time of each valve from the start of the period, s (0: shut).",
    } pad [];

    ThrusterStatus
    "What the thruster drive applied and counted, once per period." {
        header: "Common header; time_ns is the period the status describes (its end).",
        applied_on_time: "Valve on-times applied in the period, s.",
        valves_open: "Valves open at the end of the period: bit i for thruster i.",
        disabled: "1 if the thrusters are disabled (latch valve shut), else 0.",
        refused: "Commands refused since start (not finite, out of range, too short).",
        propellant_used: "Propellant used since start, kg.",
    } pad [];

    AppliedThrusterCommand
    "Valve on-times as the smart CAN node applies them (CAN actuation with thrusters)." {
        header: "Common header; time_ns is the tick the pulses start at; flag STALE: no \
                 complete command came for the tick and every valve stays shut.",
        on_time: "Electrical on-time of each valve from the start of the period, s (0: shut).",
        latch_shut: "1 once the latch valve upstream of every thruster is shut, else 0.",
    } pad [_pad0];
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A default sample of every topic, in table order.
    fn defaults() -> Vec<LogRecord> {
        macro_rules! defaults {
            ($($id:ident($ty:ty, $path:literal),)*) => {
                vec![$(LogRecord::$id(<$ty>::default()),)*]
            };
        }
        ipc_types::for_each_topic!(defaults)
    }

    #[test]
    fn records_are_in_table_order() {
        let ids: Vec<_> = defaults().iter().map(LogRecord::topic_id).collect();
        assert_eq!(ids, TopicId::ALL);
        let names: Vec<_> = defaults().iter().map(LogRecord::topic).collect();
        assert_eq!(names, ipc_types::topic::ALL);
        assert_eq!(GyroSample::ID, TopicId::Gyro);
        assert_eq!(
            AppliedThrusterCommand::SCHEMA_NAME,
            "testbed::AppliedThrusterCommand.v1"
        );
    }

    #[test]
    fn schemas_are_json_objects_listing_every_encoded_field() {
        for record in defaults() {
            let id = record.topic_id();
            let schema: Value = serde_json::from_str(&id.json_schema()).expect("valid JSON");
            assert_eq!(schema["title"], id.schema_name(), "{}", id.name());
            let props = schema["properties"].as_object().expect("properties");
            let mut encoded = Vec::new();
            record.encode_json(&mut encoded);
            assert_eq!(id.decode(&encoded).expect("default decodes"), record);
            let value: Value = serde_json::from_slice(&encoded).expect("valid JSON");
            let keys: Vec<_> = value.as_object().expect("object").keys().collect();
            let schema_keys: Vec<_> = props.keys().collect();
            assert_eq!(keys, schema_keys, "{}", id.name());
            for (name, prop) in props {
                assert!(
                    prop["description"].is_string(),
                    "{}.{name} has no description",
                    id.name()
                );
            }
        }
    }

    #[test]
    fn encoding_is_compact_and_in_declaration_order() {
        let gyro = GyroSample::new(SampleHeader::new(5, 6, 1).with_source(2), [0.5, -1.0, 1e-9]);
        let mut out = Vec::new();
        gyro.encode_json(&mut out);
        assert_eq!(
            std::str::from_utf8(&out).expect("utf8"),
            r#"{"header":{"time_ns":5,"sequence":6,"flags":1,"source_id":2},"rate":[0.5,-1.0,1e-9]}"#
        );
    }

    #[test]
    fn decoding_rejects_missing_and_unknown_fields() {
        assert!(matches!(
            GyroSample::decode_json(
                br#"{"header":{"time_ns":5,"sequence":6,"flags":1,"source_id":2}}"#
            ),
            Err(DecodeError::Missing { .. })
        ));
        assert!(matches!(
            GyroSample::decode_json(
                br#"{"header":{"time_ns":5,"sequence":6,"flags":1,"source_id":2},"rate":[0,0,0],"x":1}"#
            ),
            Err(DecodeError::Unknown { .. })
        ));
        assert!(matches!(
            GyroSample::decode_json(b"[1]"),
            Err(DecodeError::Type { .. })
        ));
        assert!(matches!(
            GyroSample::decode_json(b"{"),
            Err(DecodeError::Json(_))
        ));
    }
}
