//! The run's events as Foxglove's `foxglove.Log`, so the Log panel lists them: health events
//! (faults and recoveries), controller mode changes and ground command acknowledgements, each
//! with a level, the process it concerns and a sentence.

use crate::record::LogRecord;
use ipc_types::{ControllerMode, GroundAckStatus, GroundCommandAck, HealthEvent, HealthEventKind};
use serde_json::json;

/// Topic of the run's events.
pub const EVENTS_TOPIC: &str = "testbed/events";
/// Schema name of a log message.
pub const LOG: &str = "foxglove.Log";

/// Foxglove's JSON Schema of `foxglove.Log` (foxglove/schemas, MIT).
pub fn log_schema() -> &'static str {
    include_str!("schemas/Log.json")
}

/// `foxglove.LogLevel`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Level {
    Info = 2,
    Warning = 3,
    Error = 4,
    Fatal = 5,
}

/// One event: its level, the process it is about, and what happened.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    pub level: Level,
    pub name: String,
    pub message: String,
}

impl Event {
    /// The `foxglove.Log` message of the event at `time_ns` (ns since the Unix epoch).
    pub fn log_json(&self, time_ns: u64) -> String {
        json!({
            "timestamp": {"sec": time_ns / 1_000_000_000, "nsec": time_ns % 1_000_000_000},
            "level": self.level as u8,
            "message": self.message,
            "name": self.name,
            "file": "",
            "line": 0,
        })
        .to_string()
    }
}

/// The event of a health event or a ground command acknowledgement (`None` for other
/// records; a controller mode is an event only when it changes: [`ModeChanges`]).
pub fn event_of(record: &LogRecord) -> Option<Event> {
    match record {
        LogRecord::Health(e) => Some(health(e)),
        LogRecord::GroundCommandAck(a) => Some(acknowledgement(a)),
        _ => None,
    }
}

/// The controller's mode changes as events. Holds the last mode seen.
#[derive(Debug, Default, Clone)]
pub struct ModeChanges {
    last_mode: Option<u32>,
}

impl ModeChanges {
    /// The event of the controller reporting `mode`, if it is a change (or the first).
    pub fn event(&mut self, mode: u32) -> Option<Event> {
        let previous = self.last_mode.replace(mode);
        (previous != Some(mode)).then(|| Event {
            level: if ControllerMode::from_u32(mode) == Some(ControllerMode::Safe) {
                Level::Warning
            } else {
                Level::Info
            },
            name: "controller".into(),
            message: match previous {
                Some(p) => format!("mode {} → {}", mode_name(p), mode_name(mode)),
                None => format!("mode {}", mode_name(mode)),
            },
        })
    }
}

fn mode_name(mode: u32) -> String {
    ControllerMode::from_u32(mode).map_or_else(|| format!("{mode} (unknown)"), |m| format!("{m:?}"))
}

fn health(e: &HealthEvent) -> Event {
    let kind = e.kind();
    let level = match kind {
        Some(HealthEventKind::RunAborted) => Level::Fatal,
        Some(
            HealthEventKind::ProcessExited
            | HealthEventKind::ProcessHung
            | HealthEventKind::ThrustersDisabled,
        ) => Level::Error,
        Some(k) if k.is_fault() => Level::Warning,
        Some(HealthEventKind::ProcessRestarted) => Level::Warning,
        _ => Level::Info,
    };
    let what = kind.map_or_else(|| format!("event {}", e.kind), |k| k.name().to_owned());
    let detail = match kind {
        Some(HealthEventKind::InputLost | HealthEventKind::ProcessHung) => {
            format!(" (silent for {:.2} s)", e.value)
        }
        Some(HealthEventKind::InputRestored) => format!(" (after {:.2} s)", e.value),
        Some(HealthEventKind::CommandsZeroed) => {
            format!(" (no command for {:.2} s)", e.value)
        }
        Some(HealthEventKind::ProcessExited) => format!(" (status {})", e.detail),
        Some(HealthEventKind::ProcessRestarted) => format!(" (restart {})", e.detail),
        Some(HealthEventKind::SafeModeEntered) => format!(" (reasons {:#x})", e.detail),
        Some(HealthEventKind::ThrustersDisabled) => format!(" (valve {})", e.detail),
        _ => String::new(),
    };
    Event {
        level,
        name: e.reporter().to_owned(),
        message: format!("{what}: {}{detail}", e.subject()),
    }
}

fn acknowledgement(a: &GroundCommandAck) -> Event {
    let by = if a.decided_by == GroundCommandAck::BY_CONTROLLER {
        "controller"
    } else {
        "ground-link"
    };
    let (level, verdict) = match a.status() {
        Some(GroundAckStatus::Applied) => (Level::Info, "applied"),
        Some(GroundAckStatus::Rejected) => (Level::Warning, "rejected"),
        _ => (Level::Warning, "unknown outcome"),
    };
    Event {
        level,
        name: by.into(),
        message: format!(
            "ground command {} (viewer {}) {verdict}: {}",
            a.command_id,
            a.client_id,
            a.reason()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::{ControllerStatus, SampleHeader};
    use serde_json::Value;

    #[test]
    fn a_mode_is_an_event_only_when_it_changes() {
        let mut events = ModeChanges::default();
        let status = LogRecord::ControllerStatus(ControllerStatus::default());
        assert_eq!(event_of(&status), None);
        let first = events.event(ControllerMode::WheelPointing as u32).unwrap();
        assert_eq!(first.message, "mode WheelPointing");
        assert!(events.event(ControllerMode::WheelPointing as u32).is_none());
        let safe = events.event(ControllerMode::Safe as u32).unwrap();
        assert_eq!(safe.message, "mode WheelPointing → Safe");
        assert_eq!(safe.level, Level::Warning);
    }

    #[test]
    fn faults_are_warnings_or_worse_and_name_their_reporter() {
        let event = |kind| {
            let e = HealthEvent::new(
                SampleHeader::default(),
                "launcher",
                "testbed/sensors/gyro",
                kind,
                9,
                0.25,
            );
            event_of(&LogRecord::Health(e)).unwrap()
        };
        let lost = event(HealthEventKind::InputLost);
        assert_eq!(lost.level, Level::Warning);
        assert_eq!(lost.name, "launcher");
        assert_eq!(lost.message, "input lost: sensors/gyro (silent for 0.25 s)");
        assert_eq!(event(HealthEventKind::ProcessExited).level, Level::Error);
        assert_eq!(event(HealthEventKind::RunAborted).level, Level::Fatal);
        assert_eq!(event(HealthEventKind::InputRestored).level, Level::Info);
    }

    #[test]
    fn the_message_has_the_fields_of_foxgloves_schema() {
        let ack = GroundCommandAck::new(
            SampleHeader::default(),
            6,
            1,
            GroundAckStatus::Rejected,
            2,
            GroundCommandAck::BY_LINK,
            "wrong token",
        );
        let event = event_of(&LogRecord::GroundCommandAck(ack)).unwrap();
        assert_eq!(
            event.message,
            "ground command 6 (viewer 2) rejected: wrong token"
        );
        let message: Value = serde_json::from_str(&event.log_json(1_000_000_007)).unwrap();
        let schema: Value = serde_json::from_str(log_schema()).unwrap();
        let mut expected: Vec<_> = schema["properties"].as_object().unwrap().keys().collect();
        let mut got: Vec<_> = message.as_object().unwrap().keys().collect();
        expected.sort();
        got.sort();
        assert_eq!(got, expected);
        assert_eq!(message["level"], 3);
        assert_eq!(message["timestamp"]["sec"], 1);
        assert_eq!(message["timestamp"]["nsec"], 7);
    }
}
