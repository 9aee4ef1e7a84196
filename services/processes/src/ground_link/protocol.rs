//! The Foxglove WebSocket protocol (subprotocol `foxglove.websocket.v1`, as its specification
//! names every op), the part the ground link speaks. Out: `serverInfo`, `advertise`, `status`,
//! `parameterValues` (JSON text); `messageData` (binary opcode 1) and `time` (binary opcode 2).
//! In: `subscribe`, `unsubscribe`, the client's `advertise` and `unadvertise`, `getParameters`,
//! `setParameters` (refused: the run configuration is read-only) (JSON text); client message
//! data (binary opcode 1). The ops of capabilities the link does not declare are read so the
//! refusal can name them. Plain functions, no I/O.

use serde_json::{Value, json};

/// The WebSocket subprotocol.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// Binary opcode of server `messageData` and client message data.
pub const OP_MESSAGE_DATA: u8 = 1;
/// Binary opcode of the server's `time`.
pub const OP_TIME: u8 = 2;
/// The one message encoding the link reads from clients (and sends): JSON.
pub const ENCODING: &str = "json";
/// Capabilities: clients may advertise channels and publish on them.
pub const CAP_CLIENT_PUBLISH: &str = "clientPublish";
/// Capabilities: clients may read (and try to set) parameters.
pub const CAP_PARAMETERS: &str = "parameters";
/// Capabilities: the server sends `time`.
pub const CAP_TIME: &str = "time";
/// Longest topic a client may advertise, bytes.
const MAX_TOPIC: usize = 256;

/// One channel the link advertises.
#[derive(Debug, Clone)]
pub struct Channel {
    pub id: u32,
    pub topic: &'static str,
    pub schema_name: &'static str,
    /// JSON Schema text.
    pub schema: String,
}

/// A channel a client advertises.
#[derive(Debug, Clone, PartialEq)]
pub struct ClientChannel {
    pub id: u32,
    pub topic: String,
    pub encoding: String,
}

/// A message from a viewer.
#[derive(Debug, Clone, PartialEq)]
pub enum ClientMessage {
    /// `(subscription id, channel id)` pairs.
    Subscribe(Vec<(u32, u32)>),
    /// Subscription ids.
    Unsubscribe(Vec<u32>),
    /// The client's `advertise`.
    Advertise(Vec<ClientChannel>),
    /// The client's `unadvertise`: client channel ids.
    Unadvertise(Vec<u32>),
    /// `getParameters`: the names asked for (empty: all), the request id.
    GetParameters {
        names: Vec<String>,
        id: Option<String>,
    },
    /// `setParameters`: the names to set, the request id.
    SetParameters {
        names: Vec<String>,
        id: Option<String>,
    },
    /// Client message data on a client channel.
    Publish { channel: u32, payload: Vec<u8> },
}

/// Why a viewer's message was dropped (counted, and said in a `status`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BadMessage {
    #[error("not JSON")]
    NotJson,
    #[error("no \"op\" field")]
    NoOp,
    #[error("unknown op {0:?}")]
    UnknownOp(String),
    #[error("op {op:?} needs the {capability:?} capability, which this server does not declare")]
    Unsupported {
        op: String,
        capability: &'static str,
    },
    #[error("{0} malformed")]
    Malformed(&'static str),
    #[error("binary message too short or of an unknown opcode")]
    Binary,
}

fn u32_of(v: &Value, key: &str) -> Option<u32> {
    v.get(key)?.as_u64().and_then(|x| u32::try_from(x).ok())
}

fn u32_list(v: Option<&Vec<Value>>) -> Option<Vec<u32>> {
    v?.iter()
        .map(|x| x.as_u64().and_then(|x| u32::try_from(x).ok()))
        .collect()
}

/// The capability an op this server does not serve belongs to, if it is one of the spec's.
fn capability_of(op: &str) -> Option<&'static str> {
    Some(match op {
        "subscribeParameterUpdates" | "unsubscribeParameterUpdates" => "parametersSubscribe",
        "subscribeConnectionGraph" | "unsubscribeConnectionGraph" => "connectionGraph",
        "fetchAsset" => "assets",
        _ => return None,
    })
}

/// Reads a text (JSON) message.
pub fn parse_text(text: &str) -> Result<ClientMessage, BadMessage> {
    let v: Value = serde_json::from_str(text).map_err(|_| BadMessage::NotJson)?;
    let list = |key: &str| v.get(key).and_then(Value::as_array);
    let request_id = || v.get("id").and_then(Value::as_str).map(str::to_owned);
    let op = v
        .get("op")
        .and_then(Value::as_str)
        .ok_or(BadMessage::NoOp)?;
    match op {
        "subscribe" => list("subscriptions")
            .and_then(|items| {
                items
                    .iter()
                    .map(|s| Some((u32_of(s, "id")?, u32_of(s, "channelId")?)))
                    .collect::<Option<Vec<_>>>()
            })
            .map(ClientMessage::Subscribe)
            .ok_or(BadMessage::Malformed("subscribe")),
        "unsubscribe" => u32_list(list("subscriptionIds"))
            .map(ClientMessage::Unsubscribe)
            .ok_or(BadMessage::Malformed("unsubscribe")),
        "advertise" => list("channels")
            .and_then(|items| {
                items
                    .iter()
                    .map(|c| {
                        let topic = c.get("topic")?.as_str()?;
                        let encoding = c.get("encoding")?.as_str()?;
                        c.get("schemaName")?.as_str()?;
                        (topic.len() <= MAX_TOPIC && encoding.len() <= MAX_TOPIC).then_some(())?;
                        Some(ClientChannel {
                            id: u32_of(c, "id")?,
                            topic: topic.to_owned(),
                            encoding: encoding.to_owned(),
                        })
                    })
                    .collect::<Option<Vec<_>>>()
            })
            .map(ClientMessage::Advertise)
            .ok_or(BadMessage::Malformed("advertise")),
        "unadvertise" => u32_list(list("channelIds"))
            .map(ClientMessage::Unadvertise)
            .ok_or(BadMessage::Malformed("unadvertise")),
        "getParameters" => list("parameterNames")
            .and_then(|names| {
                names
                    .iter()
                    .map(|n| n.as_str().map(str::to_owned))
                    .collect::<Option<Vec<_>>>()
            })
            .map(|names| ClientMessage::GetParameters {
                names,
                id: request_id(),
            })
            .ok_or(BadMessage::Malformed("getParameters")),
        "setParameters" => list("parameters")
            .and_then(|items| {
                items
                    .iter()
                    .map(|p| p.get("name")?.as_str().map(str::to_owned))
                    .collect::<Option<Vec<_>>>()
            })
            .map(|names| ClientMessage::SetParameters {
                names,
                id: request_id(),
            })
            .ok_or(BadMessage::Malformed("setParameters")),
        other => Err(match capability_of(other) {
            Some(capability) => BadMessage::Unsupported {
                op: other.to_owned(),
                capability,
            },
            None => BadMessage::UnknownOp(other.chars().take(32).collect()),
        }),
    }
}

/// Reads a binary message: client message data (opcode 1, channel id u32 LE, payload). A
/// service call request (opcode 2) is refused by [`BadMessage::Unsupported`].
pub fn parse_binary(data: &[u8]) -> Result<ClientMessage, BadMessage> {
    match data {
        [OP_MESSAGE_DATA, a, b, c, d, payload @ ..] => Ok(ClientMessage::Publish {
            channel: u32::from_le_bytes([*a, *b, *c, *d]),
            payload: payload.to_vec(),
        }),
        [2, ..] => Err(BadMessage::Unsupported {
            op: "service call request".into(),
            capability: "services",
        }),
        _ => Err(BadMessage::Binary),
    }
}

/// `messageData`: opcode, subscription id (u32 LE), time (u64 LE, ns), payload.
pub fn message_data(subscription: u32, time_ns: u64, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(13 + payload.len());
    out.push(OP_MESSAGE_DATA);
    out.extend_from_slice(&subscription.to_le_bytes());
    out.extend_from_slice(&time_ns.to_le_bytes());
    out.extend_from_slice(payload);
    out
}

/// `time`: opcode, time (u64 LE, ns; the clock of the message times).
pub fn time(time_ns: u64) -> [u8; 9] {
    let mut out = [0u8; 9];
    out[0] = OP_TIME;
    out[1..].copy_from_slice(&time_ns.to_le_bytes());
    out
}

/// `serverInfo` with `capabilities`; `supportedEncodings` only with `clientPublish` (as the
/// spec says).
pub fn server_info(session: &str, capabilities: &[&str], metadata: &Value) -> String {
    let mut v = json!({
        "op": "serverInfo",
        "name": "testbed ground-link",
        "capabilities": capabilities,
        "metadata": metadata,
        "sessionId": session,
    });
    if capabilities.contains(&CAP_CLIENT_PUBLISH) {
        v["supportedEncodings"] = json!([ENCODING]);
    }
    v.to_string()
}

/// `advertise` of `channels` (JSON messages, JSON Schema schemas).
pub fn advertise(channels: &[Channel]) -> String {
    let list: Vec<Value> = channels
        .iter()
        .map(|c| {
            json!({
                "id": c.id,
                "topic": c.topic,
                "encoding": ENCODING,
                "schemaName": c.schema_name,
                "schema": c.schema,
                "schemaEncoding": "jsonschema",
            })
        })
        .collect();
    json!({"op": "advertise", "channels": list}).to_string()
}

/// `status`: level 0 info, 1 warning, 2 error; `id` ties it to a command.
pub fn status(level: u8, message: &str, id: Option<&str>) -> String {
    let mut v = json!({"op": "status", "level": level, "message": message});
    if let Some(id) = id {
        v["id"] = Value::from(id);
    }
    v.to_string()
}

/// `parameterValues`: `(name, value)` pairs; `id` that of the request.
pub fn parameter_values<'a>(
    parameters: impl IntoIterator<Item = (&'a str, &'a Value)>,
    id: Option<&str>,
) -> String {
    let list: Vec<Value> = parameters
        .into_iter()
        .map(|(name, value)| json!({"name": name, "value": value}))
        .collect();
    let mut v = json!({"op": "parameterValues", "parameters": list});
    if let Some(id) = id {
        v["id"] = Value::from(id);
    }
    v.to_string()
}

/// Parameters from a JSON object (the run configuration): one per leaf, named by its path with
/// dots (`ground.port`); arrays are one parameter; nulls (unset options) and the `skip` names
/// are left out.
pub fn flatten_parameters(value: &Value, skip: &[&str]) -> Vec<(String, Value)> {
    fn walk(prefix: &str, value: &Value, skip: &[&str], out: &mut Vec<(String, Value)>) {
        match value {
            Value::Null => {}
            _ if skip.contains(&prefix) => {}
            Value::Object(map) => {
                for (k, v) in map {
                    let name = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(&name, v, skip, out);
                }
            }
            v => out.push((prefix.to_owned(), v.clone())),
        }
    }
    let mut out = Vec::new();
    walk("", value, skip, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subscriptions_and_client_channels_are_read_as_the_spec_names_them() {
        assert_eq!(
            parse_text(
                r#"{"op":"subscribe","subscriptions":[{"id":1,"channelId":3},{"id":2,"channelId":4}]}"#
            ),
            Ok(ClientMessage::Subscribe(vec![(1, 3), (2, 4)]))
        );
        assert_eq!(
            parse_text(r#"{"op":"unsubscribe","subscriptionIds":[1]}"#),
            Ok(ClientMessage::Unsubscribe(vec![1]))
        );
        assert_eq!(
            parse_text(
                r#"{"op":"advertise","channels":[{"id":5,"topic":"testbed/ground/command","encoding":"json","schemaName":""}]}"#
            ),
            Ok(ClientMessage::Advertise(vec![ClientChannel {
                id: 5,
                topic: "testbed/ground/command".into(),
                encoding: "json".into(),
            }]))
        );
        assert_eq!(
            parse_text(r#"{"op":"unadvertise","channelIds":[5,6]}"#),
            Ok(ClientMessage::Unadvertise(vec![5, 6]))
        );
        // The spec's client advertise needs the encoding and the schema name.
        assert_eq!(
            parse_text(r#"{"op":"advertise","channels":[{"id":5,"topic":"t"}]}"#),
            Err(BadMessage::Malformed("advertise"))
        );
        assert_eq!(
            parse_text(r#"{"op":"subscribe","subscriptions":[{"id":-1,"channelId":3}]}"#),
            Err(BadMessage::Malformed("subscribe"))
        );
        // The project's former private names are unknown ops now.
        assert_eq!(
            parse_text(r#"{"op":"clientAdvertise","channels":[]}"#),
            Err(BadMessage::UnknownOp("clientAdvertise".into()))
        );
        assert_eq!(
            parse_text(r#"{"op":"reboot"}"#).unwrap_err().to_string(),
            "unknown op \"reboot\""
        );
        assert_eq!(parse_text(r#"{"ops":1}"#), Err(BadMessage::NoOp));
        assert_eq!(parse_text("{{"), Err(BadMessage::NotJson));
    }

    #[test]
    fn parameter_requests_are_read_and_undeclared_capabilities_named() {
        assert_eq!(
            parse_text(r#"{"op":"getParameters","parameterNames":[],"id":"r1"}"#),
            Ok(ClientMessage::GetParameters {
                names: vec![],
                id: Some("r1".into())
            })
        );
        assert_eq!(
            parse_text(r#"{"op":"setParameters","parameters":[{"name":"ground.port","value":1}]}"#),
            Ok(ClientMessage::SetParameters {
                names: vec!["ground.port".into()],
                id: None
            })
        );
        let e =
            parse_text(r#"{"op":"subscribeParameterUpdates","parameterNames":[]}"#).unwrap_err();
        assert_eq!(
            e.to_string(),
            "op \"subscribeParameterUpdates\" needs the \"parametersSubscribe\" capability, which this server does not declare"
        );
        assert!(matches!(
            parse_binary(&[2, 0, 0, 0, 0, 1, 0, 0, 0]),
            Err(BadMessage::Unsupported {
                capability: "services",
                ..
            })
        ));
    }

    #[test]
    fn server_info_declares_encodings_only_with_client_publish() {
        let watch: Value =
            serde_json::from_str(&server_info("s", &[CAP_PARAMETERS, CAP_TIME], &json!({})))
                .unwrap();
        assert_eq!(watch["capabilities"], json!(["parameters", "time"]));
        assert!(watch.get("supportedEncodings").is_none());
        let command: Value =
            serde_json::from_str(&server_info("s", &[CAP_CLIENT_PUBLISH], &json!({}))).unwrap();
        assert_eq!(command["supportedEncodings"], json!(["json"]));
    }

    #[test]
    fn the_configuration_flattens_to_dotted_parameters_without_secrets() {
        let config = json!({"ground": {"port": 8765, "token": "secret", "tls_cert": null},
                            "model": {"inertia": [1, 2, 3]}});
        let params = flatten_parameters(&config, &["ground.token"]);
        assert_eq!(
            params,
            [
                ("ground.port".to_owned(), json!(8765)),
                ("model.inertia".to_owned(), json!([1, 2, 3])),
            ]
        );
        let text = parameter_values(params.iter().map(|(n, v)| (n.as_str(), v)), Some("r"));
        let v: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["op"], "parameterValues");
        assert_eq!(v["id"], "r");
        assert_eq!(
            v["parameters"][0],
            json!({"name": "ground.port", "value": 8765})
        );
    }

    #[test]
    fn binary_frames_round_trip() {
        let frame = message_data(7, 1_500_000_000, b"{}");
        assert_eq!(frame.len(), 15);
        assert_eq!(&frame[1..5], &7u32.to_le_bytes());
        let t = time(1_500_000_000);
        assert_eq!(t[0], 2);
        assert_eq!(
            u64::from_le_bytes(t[1..].try_into().unwrap()),
            1_500_000_000
        );
        assert_eq!(
            parse_binary(&[1, 5, 0, 0, 0, b'x']),
            Ok(ClientMessage::Publish {
                channel: 5,
                payload: b"x".to_vec()
            })
        );
        assert_eq!(parse_binary(&[1, 5, 0]), Err(BadMessage::Binary));
        assert_eq!(parse_binary(&[3, 5, 0, 0, 0]), Err(BadMessage::Binary));
    }
}
