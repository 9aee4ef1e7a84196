//! Ground commands as viewers send them (JSON), their validation against the limits of
//! `[ground]`, the per-viewer rate limit and the per-viewer decimation. Plain logic, no I/O.
//!
//! A command is the JSON payload of a Foxglove client-publish message on the channel
//! `testbed/ground/command` (see `docs/ground.md`), from a connection in the command role (it
//! gave the run's token on its URL, `?token=`); a `token` in the payload is optional and, when
//! there, must be the run's too:
//!
//! ```json
//! {"id": 7, "command": "mode", "mode": "rate_damping"}
//! {"token": "…", "id": 8, "command": "target", "heading_deg": 10, "pitch_deg": 0, "roll_deg": 2}
//! {"id": 9, "command": "experiment", "action": "start"}
//! ```

use ipc_types::{ControllerMode, GroundCommand, GroundCommandKind, SampleHeader};
use serde_json::Value;
use std::collections::HashMap;
use std::time::{Duration, Instant};
use testbed_model::config::DEG;

/// A command read from a viewer, before validation (degrees at this edge).
#[derive(Debug, Clone, PartialEq)]
pub struct CommandRequest {
    /// The payload's token, if it has one.
    pub token: Option<String>,
    pub id: u64,
    pub kind: GroundCommandKind,
    pub mode: Option<ControllerMode>,
    pub heading_deg: f64,
    pub pitch_deg: f64,
    pub roll_deg: f64,
}

/// Why a message is not a command at all (counted as malformed).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Malformed {
    #[error("not JSON: {0}")]
    NotJson(String),
    #[error("not a JSON object")]
    NotObject,
    #[error("field {0:?} missing or of the wrong type")]
    Field(&'static str),
    #[error("unknown command {0:?} (mode, target, experiment)")]
    UnknownCommand(String),
    #[error("unknown mode {0:?} (idle, rate_damping, wheel_pointing, cmg_slew, safe)")]
    UnknownMode(String),
    #[error("unknown experiment action {0:?} (start, abort)")]
    UnknownAction(String),
}

impl Malformed {
    /// The command id, if the message had a readable one (for the acknowledgement).
    pub fn id_of(payload: &[u8]) -> u64 {
        serde_json::from_slice::<Value>(payload)
            .ok()
            .and_then(|v| v.get("id").and_then(Value::as_u64))
            .unwrap_or(0)
    }
}

/// The mode names of the commands.
pub const MODES: &[(&str, ControllerMode)] = &[
    ("idle", ControllerMode::Idle),
    ("rate_damping", ControllerMode::RateDamping),
    ("wheel_pointing", ControllerMode::WheelPointing),
    ("cmg_slew", ControllerMode::CmgSlew),
    ("safe", ControllerMode::Safe),
];

fn number(obj: &serde_json::Map<String, Value>, key: &'static str) -> Result<f64, Malformed> {
    obj.get(key)
        .and_then(Value::as_f64)
        .ok_or(Malformed::Field(key))
}

/// Reads a command payload.
pub fn parse(payload: &[u8]) -> Result<CommandRequest, Malformed> {
    let value: Value =
        serde_json::from_slice(payload).map_err(|e| Malformed::NotJson(e.to_string()))?;
    let obj = value.as_object().ok_or(Malformed::NotObject)?;
    let text = |key: &'static str| {
        obj.get(key)
            .and_then(Value::as_str)
            .ok_or(Malformed::Field(key))
    };
    let token = match obj.get("token") {
        None => None,
        Some(Value::String(t)) => Some(t.clone()),
        Some(_) => return Err(Malformed::Field("token")),
    };
    let id = obj
        .get("id")
        .and_then(Value::as_u64)
        .ok_or(Malformed::Field("id"))?;
    let mut request = CommandRequest {
        token,
        id,
        kind: GroundCommandKind::Unknown,
        mode: None,
        heading_deg: 0.0,
        pitch_deg: 0.0,
        roll_deg: 0.0,
    };
    match text("command")? {
        "mode" => {
            let name = text("mode")?;
            let mode = MODES
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, m)| *m)
                .ok_or_else(|| Malformed::UnknownMode(name.chars().take(32).collect()))?;
            request.kind = GroundCommandKind::Mode;
            request.mode = Some(mode);
        }
        "target" => {
            request.kind = GroundCommandKind::Target;
            request.heading_deg = number(obj, "heading_deg")?;
            request.pitch_deg = number(obj, "pitch_deg")?;
            request.roll_deg = number(obj, "roll_deg")?;
        }
        "experiment" => {
            request.kind = match text("action")? {
                "start" => GroundCommandKind::ExperimentStart,
                "abort" => GroundCommandKind::ExperimentAbort,
                other => return Err(Malformed::UnknownAction(other.chars().take(32).collect())),
            };
        }
        other => return Err(Malformed::UnknownCommand(other.chars().take(32).collect())),
    }
    Ok(request)
}

/// What the link checks a well-formed command against.
#[derive(Debug, Clone)]
pub struct Limits {
    /// The run's command token.
    pub token: String,
    /// Largest target pitch or roll, rad.
    pub max_tilt_rad: f64,
}

/// What a connection may do, decided at its handshake by the token on its URL.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// No token: sees every channel, commands nothing.
    Watch,
    /// The run's token: may command too.
    Command,
}

impl Role {
    pub const fn name(self) -> &'static str {
        match self {
            Self::Watch => "watch",
            Self::Command => "command",
        }
    }
}

/// Why a watching connection's command is refused (the sender's status and the logged
/// acknowledgement say it).
pub const WATCH_ONLY: &str =
    "watch-only connection: commanding needs the run's command token on the URL (?token=…)";

/// The role of a connection that gave `token` on its URL, or why its handshake is refused.
pub fn role_of(token: Option<&str>, limits: &Limits) -> Result<Role, &'static str> {
    match token {
        None => Ok(Role::Watch),
        Some(t) if same_token(t, &limits.token) => Ok(Role::Command),
        // A guess, or the token of another (earlier) run: each run has its own.
        Some(_) => Err("wrong command token"),
    }
}

/// Compares two tokens in time independent of where they differ.
fn same_token(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

/// Checks `request` from a connection of `role` (role, token, limits) and makes the bus
/// command; the reason if refused.
pub fn validate(
    request: &CommandRequest,
    limits: &Limits,
    role: Role,
    client_id: u32,
    header: SampleHeader,
) -> Result<GroundCommand, String> {
    if role != Role::Command {
        return Err(WATCH_ONLY.into());
    }
    if let Some(token) = &request.token
        && !same_token(token, &limits.token)
    {
        return Err("wrong token".into());
    }
    let mut command = GroundCommand {
        header,
        kind: request.kind as u32,
        command_id: request.id,
        client_id,
        ..GroundCommand::default()
    };
    match request.kind {
        GroundCommandKind::Mode => {
            let mode = request.mode.ok_or("mode missing")?;
            command.mode = mode as u32;
        }
        GroundCommandKind::Target => {
            let max_deg = limits.max_tilt_rad / DEG;
            for (name, value) in [("pitch", request.pitch_deg), ("roll", request.roll_deg)] {
                if !value.is_finite() || value.abs() > max_deg + 1e-9 {
                    return Err(format!(
                        "{name} {value:.1}° beyond the ±{max_deg:.1}° tilt limit"
                    ));
                }
            }
            if !request.heading_deg.is_finite() || request.heading_deg.abs() > 360.0 {
                return Err(format!("heading {:.1}° outside ±360°", request.heading_deg));
            }
            command.target_heading_rad = request.heading_deg * DEG;
            command.target_pitch_rad = request.pitch_deg * DEG;
            command.target_roll_rad = request.roll_deg * DEG;
        }
        GroundCommandKind::ExperimentStart | GroundCommandKind::ExperimentAbort => {
            // Refused here rather than passed on: nothing on the platform could run it.
            return Err("no identification experiment runner on the platform yet".into());
        }
        GroundCommandKind::Unknown => return Err("unknown command".into()),
    }
    Ok(command)
}

/// A token bucket: `burst` commands at once, refilled at `rate_hz`.
#[derive(Debug, Clone)]
pub struct RateLimit {
    burst: f64,
    rate_hz: f64,
    tokens: f64,
    last: Option<Instant>,
}

impl RateLimit {
    pub fn new(burst: u32, rate_hz: f64) -> Self {
        Self {
            burst: f64::from(burst),
            rate_hz,
            tokens: f64::from(burst),
            last: None,
        }
    }

    /// Whether a command at `now` is allowed (and takes a token if so).
    pub fn allow(&mut self, now: Instant) -> bool {
        if let Some(last) = self.last {
            let dt = now.saturating_duration_since(last).as_secs_f64();
            self.tokens = (self.tokens + dt * self.rate_hz).min(self.burst);
        }
        self.last = Some(now);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

/// One viewer's decimation: at most one sample per `interval` of wall time for each stream
/// (a channel and the sample's source).
#[derive(Debug, Clone)]
pub struct Decimator {
    interval: Duration,
    last: HashMap<(u32, u32), Instant>,
}

impl Decimator {
    /// At most `rate_hz` samples per second per stream.
    pub fn new(rate_hz: f64) -> Self {
        Self {
            interval: Duration::from_secs_f64(1.0 / rate_hz),
            last: HashMap::new(),
        }
    }

    /// Whether the sample of `stream` at `now` goes to the viewer.
    pub fn pass(&mut self, stream: (u32, u32), now: Instant) -> bool {
        match self.last.get(&stream) {
            Some(&last) if now.saturating_duration_since(last) < self.interval => false,
            _ => {
                self.last.insert(stream, now);
                true
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOKEN: &str = "0123456789abcdef0123456789abcdef";

    fn limits() -> Limits {
        Limits {
            token: TOKEN.into(),
            max_tilt_rad: 20.0 * DEG,
        }
    }

    fn check(json: &str) -> Result<GroundCommand, String> {
        let request = parse(json.as_bytes()).map_err(|e| e.to_string())?;
        validate(
            &request,
            &limits(),
            Role::Command,
            3,
            SampleHeader::default(),
        )
    }

    #[test]
    fn a_mode_command_becomes_a_bus_command() {
        let c = check(&format!(
            r#"{{"token":"{TOKEN}","id":7,"command":"mode","mode":"rate_damping"}}"#
        ))
        .unwrap();
        assert_eq!(c.kind(), Some(GroundCommandKind::Mode));
        assert_eq!(c.mode, ControllerMode::RateDamping as u32);
        assert_eq!((c.command_id, c.client_id), (7, 3));
    }

    #[test]
    fn a_target_is_checked_against_the_tilt_limit_and_converted_to_radians() {
        let ok = check(&format!(
            r#"{{"token":"{TOKEN}","id":1,"command":"target","heading_deg":90,"pitch_deg":-20,"roll_deg":5}}"#
        ))
        .unwrap();
        assert!((ok.target_heading_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((ok.target_pitch_rad + 20.0 * DEG).abs() < 1e-15);
        let tilted = check(&format!(
            r#"{{"token":"{TOKEN}","id":2,"command":"target","heading_deg":0,"pitch_deg":0,"roll_deg":25}}"#
        ));
        assert_eq!(
            tilted.unwrap_err(),
            "roll 25.0° beyond the ±20.0° tilt limit"
        );
        let spun = check(&format!(
            r#"{{"token":"{TOKEN}","id":3,"command":"target","heading_deg":1e9,"pitch_deg":0,"roll_deg":0}}"#
        ));
        assert!(spun.unwrap_err().contains("heading"));
    }

    #[test]
    fn a_wrong_token_is_refused_whatever_the_command() {
        let wrong = check(r#"{"token":"guess","id":1,"command":"mode","mode":"idle"}"#);
        assert_eq!(wrong.unwrap_err(), "wrong token");
        let almost = format!("{}x", &TOKEN[..TOKEN.len() - 1]);
        let wrong = check(&format!(
            r#"{{"token":"{almost}","id":1,"command":"mode","mode":"idle"}}"#
        ));
        assert_eq!(wrong.unwrap_err(), "wrong token");
    }

    #[test]
    fn a_watching_connection_commands_nothing_and_a_wrong_url_token_is_refused() {
        let request = parse(br#"{"id":1,"command":"mode","mode":"idle"}"#).unwrap();
        assert_eq!(request.token, None);
        let header = SampleHeader::default();
        let refused = validate(&request, &limits(), Role::Watch, 3, header).unwrap_err();
        assert_eq!(refused, WATCH_ONLY);
        // With the token in the payload too: the role is the connection's.
        let with_token = parse(
            format!(r#"{{"token":"{TOKEN}","id":1,"command":"mode","mode":"idle"}}"#).as_bytes(),
        )
        .unwrap();
        assert_eq!(
            validate(&with_token, &limits(), Role::Watch, 3, header).unwrap_err(),
            WATCH_ONLY
        );
        assert!(validate(&request, &limits(), Role::Command, 3, header).is_ok());
        assert_eq!(role_of(None, &limits()), Ok(Role::Watch));
        assert_eq!(role_of(Some(TOKEN), &limits()), Ok(Role::Command));
        let earlier_run = "fedcba9876543210fedcba9876543210";
        assert_eq!(
            role_of(Some(earlier_run), &limits()),
            Err("wrong command token")
        );
        assert_eq!(role_of(Some(""), &limits()), Err("wrong command token"));
    }

    #[test]
    fn experiments_are_refused_with_the_reason() {
        let e = check(&format!(
            r#"{{"token":"{TOKEN}","id":1,"command":"experiment","action":"start"}}"#
        ));
        assert!(
            e.unwrap_err()
                .contains("no identification experiment runner")
        );
    }

    #[test]
    fn malformed_commands_say_what_is_wrong() {
        assert!(matches!(parse(b"{"), Err(Malformed::NotJson(_))));
        assert_eq!(parse(b"[1]"), Err(Malformed::NotObject));
        assert_eq!(
            parse(br#"{"token":"t","command":"mode","mode":"idle"}"#),
            Err(Malformed::Field("id"))
        );
        assert_eq!(
            parse(br#"{"token":"t","id":1,"command":"mode","mode":"warp"}"#),
            Err(Malformed::UnknownMode("warp".into()))
        );
        assert_eq!(
            parse(br#"{"token":"t","id":1,"command":"target","heading_deg":"north","pitch_deg":0,"roll_deg":0}"#),
            Err(Malformed::Field("heading_deg"))
        );
        assert_eq!(
            parse(br#"{"token":7,"id":1,"command":"mode","mode":"idle"}"#),
            Err(Malformed::Field("token"))
        );
        assert_eq!(Malformed::id_of(br#"{"id":42}"#), 42);
    }

    /// The longest reasons the link gives fit an acknowledgement whole: a malformed command
    /// quoting 32 four-byte characters of the sender's, and the watch-only refusal.
    #[test]
    fn the_longest_reasons_fit_an_acknowledgement_whole() {
        use ipc_types::{GroundAckStatus, GroundCommandAck};
        let quoted = "😀".repeat(40);
        let payload = format!(r#"{{"id":1,"command":"mode","mode":"{quoted}"}}"#);
        let malformed = format!("malformed: {}", parse(payload.as_bytes()).unwrap_err());
        let mode = format!("malformed: {}", Malformed::UnknownAction("😀".repeat(32)));
        for reason in [malformed.as_str(), mode.as_str(), WATCH_ONLY] {
            assert!(reason.len() > 64, "{reason}");
            let ack = GroundCommandAck::new(
                SampleHeader::default(),
                1,
                1,
                GroundAckStatus::Rejected,
                1,
                GroundCommandAck::BY_LINK,
                reason,
            );
            assert_eq!(ack.reason(), reason);
        }
    }

    #[test]
    fn the_rate_limit_allows_a_burst_then_the_sustained_rate() {
        let mut limit = RateLimit::new(3, 1.0);
        let t0 = Instant::now();
        assert!((0..3).all(|_| limit.allow(t0)));
        assert!(!limit.allow(t0));
        assert!(!limit.allow(t0 + Duration::from_millis(900)));
        assert!(limit.allow(t0 + Duration::from_millis(1100)));
        assert!(!limit.allow(t0 + Duration::from_millis(1200)));
    }

    #[test]
    fn decimation_keeps_one_sample_per_interval_per_stream() {
        let mut d = Decimator::new(10.0);
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let passed: Vec<bool> = (0..10).map(|i| d.pass((1, 0), t0 + ms(i * 25))).collect();
        // 25 ms apart at 10 Hz: every fourth sample.
        assert_eq!(
            passed,
            [
                true, false, false, false, true, false, false, false, true, false
            ]
        );
        // Another stream (source) is decimated on its own.
        assert!(d.pass((1, 2), t0 + ms(30)));
        assert!(d.pass((2, 0), t0 + ms(30)));
    }
}
