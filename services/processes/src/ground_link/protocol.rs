//! The Foxglove WebSocket protocol (subprotocol `foxglove.websocket.v1`), the part the ground
//! link speaks: `serverInfo`, `advertise`, `status` out; `subscribe`, `unsubscribe`,
//! `clientAdvertise`, `clientUnadvertise` in (JSON text); `messageData` out and client message
//! data in (binary, opcode 1). Plain functions, no I/O.

use serde_json::{Value, json};

/// The WebSocket subprotocol.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// Binary opcode of server `messageData` and client message data.
pub const OP_MESSAGE_DATA: u8 = 1;

/// One channel the link advertises.
#[derive(Debug, Clone)]
pub struct Channel {
    pub id: u32,
    pub topic: &'static str,
    pub schema_name: &'static str,
    /// JSON Schema text.
    pub schema: String,
}

/// A message from a viewer.
#[derive(Debug, Clone, PartialEq)]
pub enum ClientMessage {
    /// `(subscription id, channel id)` pairs.
    Subscribe(Vec<(u32, u32)>),
    /// Subscription ids.
    Unsubscribe(Vec<u32>),
    /// `(client channel id, topic)` pairs.
    Advertise(Vec<(u32, String)>),
    /// Client channel ids.
    Unadvertise(Vec<u32>),
    /// Client message data on a client channel.
    Publish { channel: u32, payload: Vec<u8> },
}

/// Why a viewer's message was dropped (counted).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BadMessage {
    #[error("not JSON")]
    NotJson,
    #[error("no known op")]
    UnknownOp,
    #[error("{0} malformed")]
    Malformed(&'static str),
    #[error("binary message too short or of an unknown opcode")]
    Binary,
}

fn u32_of(v: &Value, key: &str) -> Option<u32> {
    v.get(key)?.as_u64().and_then(|x| u32::try_from(x).ok())
}

/// Reads a text (JSON) message.
pub fn parse_text(text: &str) -> Result<ClientMessage, BadMessage> {
    let v: Value = serde_json::from_str(text).map_err(|_| BadMessage::NotJson)?;
    let list = |key: &str| v.get(key).and_then(Value::as_array);
    match v.get("op").and_then(Value::as_str) {
        Some("subscribe") => list("subscriptions")
            .and_then(|items| {
                items
                    .iter()
                    .map(|s| Some((u32_of(s, "id")?, u32_of(s, "channelId")?)))
                    .collect::<Option<Vec<_>>>()
            })
            .map(ClientMessage::Subscribe)
            .ok_or(BadMessage::Malformed("subscribe")),
        Some("unsubscribe") => list("subscriptionIds")
            .and_then(|items| {
                items
                    .iter()
                    .map(|x| x.as_u64().and_then(|x| u32::try_from(x).ok()))
                    .collect::<Option<Vec<_>>>()
            })
            .map(ClientMessage::Unsubscribe)
            .ok_or(BadMessage::Malformed("unsubscribe")),
        Some("clientAdvertise") => list("channels")
            .and_then(|items| {
                items
                    .iter()
                    .map(|c| {
                        let topic = c.get("topic")?.as_str()?;
                        (topic.len() <= 256).then(|| Some((u32_of(c, "id")?, topic.to_owned())))?
                    })
                    .collect::<Option<Vec<_>>>()
            })
            .map(ClientMessage::Advertise)
            .ok_or(BadMessage::Malformed("clientAdvertise")),
        Some("clientUnadvertise") => list("channelIds")
            .and_then(|items| {
                items
                    .iter()
                    .map(|x| x.as_u64().and_then(|x| u32::try_from(x).ok()))
                    .collect::<Option<Vec<_>>>()
            })
            .map(ClientMessage::Unadvertise)
            .ok_or(BadMessage::Malformed("clientUnadvertise")),
        _ => Err(BadMessage::UnknownOp),
    }
}

/// Reads a binary message: client message data (opcode 1, channel id u32 LE, payload).
pub fn parse_binary(data: &[u8]) -> Result<ClientMessage, BadMessage> {
    match data {
        [OP_MESSAGE_DATA, a, b, c, d, payload @ ..] => Ok(ClientMessage::Publish {
            channel: u32::from_le_bytes([*a, *b, *c, *d]),
            payload: payload.to_vec(),
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

/// `serverInfo`.
pub fn server_info(session: &str, metadata: &Value) -> String {
    json!({
        "op": "serverInfo",
        "name": "testbed ground-link",
        "capabilities": ["clientPublish"],
        "supportedEncodings": ["json"],
        "metadata": metadata,
        "sessionId": session,
    })
    .to_string()
}

/// `advertise` of `channels` (JSON messages, JSON Schema schemas).
pub fn advertise(channels: &[Channel]) -> String {
    let list: Vec<Value> = channels
        .iter()
        .map(|c| {
            json!({
                "id": c.id,
                "topic": c.topic,
                "encoding": "json",
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subscriptions_and_client_channels_are_read() {
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
                r#"{"op":"clientAdvertise","channels":[{"id":5,"topic":"testbed/ground/command","encoding":"json","schemaName":""}]}"#
            ),
            Ok(ClientMessage::Advertise(vec![(
                5,
                "testbed/ground/command".into()
            )]))
        );
        assert_eq!(
            parse_text(r#"{"op":"subscribe","subscriptions":[{"id":-1,"channelId":3}]}"#),
            Err(BadMessage::Malformed("subscribe"))
        );
        assert_eq!(parse_text(r#"{"op":"reboot"}"#), Err(BadMessage::UnknownOp));
        assert_eq!(parse_text("{{"), Err(BadMessage::NotJson));
    }

    #[test]
    fn binary_frames_round_trip() {
        let frame = message_data(7, 1_500_000_000, b"{}");
        assert_eq!(frame.len(), 15);
        assert_eq!(&frame[1..5], &7u32.to_le_bytes());
        assert_eq!(
            parse_binary(&[1, 5, 0, 0, 0, b'x']),
            Ok(ClientMessage::Publish {
                channel: 5,
                payload: b"x".to_vec()
            })
        );
        assert_eq!(parse_binary(&[1, 5, 0]), Err(BadMessage::Binary));
        assert_eq!(parse_binary(&[2, 5, 0, 0, 0]), Err(BadMessage::Binary));
    }
}
