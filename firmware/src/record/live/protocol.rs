//! The Foxglove WebSocket protocol (v1) messages Speleo sends and reads:
//! `serverInfo` and `advertise` as JSON text, message data as binary
//! frames, and the viewer's `subscribe` and `unsubscribe`.

use serde_json::json;

use crate::record::Topic;

/// The WebSocket subprotocol a viewer asks for.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";

/// Opcode of a binary message-data frame.
const MESSAGE_DATA: u8 = 0x01;

/// The greeting: the server's name and session, no optional capabilities.
pub fn server_info(session_id: &str) -> String {
    json!({
        "op": "serverInfo",
        "name": concat!("speleo ", env!("CARGO_PKG_VERSION")),
        "capabilities": [],
        "supportedEncodings": [],
        "metadata": {},
        "sessionId": session_id,
    })
    .to_string()
}

/// Every recorded channel with its ROS 2 schema; channel ids are the
/// recording's.
pub fn advertise() -> String {
    let channels: Vec<_> = Topic::ALL
        .iter()
        .map(|t| {
            let i = t.info();
            json!({
                "id": t.channel_id(),
                "topic": i.name,
                "encoding": i.message_encoding(),
                "schemaName": i.schema,
                "schema": i.schema_data,
                "schemaEncoding": i.schema_encoding(),
            })
        })
        .collect();
    json!({"op": "advertise", "channels": channels}).to_string()
}

/// What a viewer asked for.
#[derive(Debug, PartialEq, Eq)]
pub enum ClientOp {
    /// (subscription id, channel id) pairs.
    Subscribe(Vec<(u32, u16)>),
    Unsubscribe(Vec<u32>),
    /// Valid JSON with an operation this server does not offer.
    Other(String),
}

/// Parse a text message from a viewer.
pub fn parse_client_op(text: &str) -> Result<ClientOp, String> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
    let op = v["op"].as_str().ok_or("no \"op\"")?;
    let ids = |key: &str| v[key].as_array().ok_or(format!("{op} without \"{key}\""));
    match op {
        "subscribe" => ids("subscriptions")?
            .iter()
            .map(|s| {
                let id = s["id"].as_u64().and_then(|n| u32::try_from(n).ok());
                let ch = s["channelId"].as_u64().and_then(|n| u16::try_from(n).ok());
                id.zip(ch).ok_or_else(|| format!("bad subscription {s}"))
            })
            .collect::<Result<_, _>>()
            .map(ClientOp::Subscribe),
        "unsubscribe" => ids("subscriptionIds")?
            .iter()
            .map(|s| {
                s.as_u64()
                    .and_then(|n| u32::try_from(n).ok())
                    .ok_or_else(|| format!("bad subscription id {s}"))
            })
            .collect::<Result<_, _>>()
            .map(ClientOp::Unsubscribe),
        other => Ok(ClientOp::Other(other.to_string())),
    }
}

/// A message-data frame: opcode, subscription id, receive time (ns), data.
pub fn message_data(subscription: u32, time_ns: u64, data: &[u8]) -> Vec<u8> {
    let mut f = Vec::with_capacity(13 + data.len());
    f.push(MESSAGE_DATA);
    f.extend_from_slice(&subscription.to_le_bytes());
    f.extend_from_slice(&time_ns.to_le_bytes());
    f.extend_from_slice(data);
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subscriptions_parse_and_bad_ones_are_named() {
        assert_eq!(
            parse_client_op(r#"{"op":"subscribe","subscriptions":[{"id":3,"channelId":10}]}"#),
            Ok(ClientOp::Subscribe(vec![(3, 10)]))
        );
        assert_eq!(
            parse_client_op(r#"{"op":"unsubscribe","subscriptionIds":[3]}"#),
            Ok(ClientOp::Unsubscribe(vec![3]))
        );
        assert_eq!(
            parse_client_op(r#"{"op":"getParameters","parameterNames":[]}"#),
            Ok(ClientOp::Other("getParameters".into()))
        );
        let e =
            parse_client_op(r#"{"op":"subscribe","subscriptions":[{"id":-1}]}"#).expect_err("bad");
        assert!(e.contains("bad subscription"), "{e}");
        assert!(parse_client_op("{").is_err());
    }

    #[test]
    fn message_data_is_opcode_id_time_then_payload() {
        let f = message_data(7, 0x0102, b"ab");
        assert_eq!(f[0], 1);
        assert_eq!(&f[1..5], &7u32.to_le_bytes());
        assert_eq!(&f[5..13], &0x0102u64.to_le_bytes());
        assert_eq!(&f[13..], b"ab");
    }

    #[test]
    fn every_channel_is_advertised_with_its_ros2_schema() {
        let v: serde_json::Value = serde_json::from_str(&advertise()).expect("json");
        let channels = v["channels"].as_array().expect("channels");
        assert_eq!(channels.len(), Topic::ALL.len());
        let odom = channels
            .iter()
            .find(|c| c["topic"] == "/odom")
            .expect("/odom");
        assert_eq!(odom["schemaName"], "nav_msgs/msg/Odometry");
        assert_eq!(odom["encoding"], "cdr");
        assert_eq!(odom["schemaEncoding"], "ros2msg");
    }
}
