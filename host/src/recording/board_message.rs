//! The JSON form of a decoded board message, one channel per message kind.
//!
//! Each message is recorded with its frame header and host times around it:
//!
//! ```json
//! {"seq": 812, "lost_before": 0, "recv_time_s": 12.345, "host_time_s": 12.339,
//!  "message": {"stamp_us": 40123456, "uptime_us": ...}}
//! ```
//!
//! The schema of each channel is derived from the protocol's types (`schemars`), so Foxglove
//! shows every field by name.

use protocol::{
    AckMsg, ConfigureLaserCmd, GpsFixMsg, HeartbeatMsg, Kind, LogMsg, Message, NmeaMsg, PpsMsg,
    Received, RequestStatusCmd, ScanMsg, SetStreamingCmd, StatusMsg, TimeSyncPingCmd,
};
use schemars::JsonSchema;
use serde::Serialize;

use super::json_schema::json_schema_of;

/// One decoded board message with its frame header, as written on its channel.
#[derive(Debug, Serialize, JsonSchema)]
pub(crate) struct BoardMessage<'a, T> {
    /// The frame's sequence number (numbered by the board).
    seq: u16,
    /// Frames lost just before this one (a gap in the sequence numbers).
    lost_before: u16,
    /// Host time of the read that completed the frame, s.
    recv_time_s: f64,
    /// The message's board stamp mapped to host time, s, once the clock is synchronised.
    host_time_s: Option<f64>,
    /// The message as decoded.
    message: &'a T,
}

/// Where the messages of one kind are recorded: topic, schema name and JSON schema.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BoardChannel {
    /// The topic, e.g. `/board/scan`.
    pub(crate) topic: &'static str,
    /// The schema name, e.g. `board.Scan`.
    pub(crate) schema_name: &'static str,
    /// Makes the JSON schema (called once per recording and channel).
    pub(crate) schema: fn() -> Vec<u8>,
}

macro_rules! board_kinds {
    ($( $variant:ident($ty:ty) => $topic:literal, $schema_name:literal; )*) => {
        /// The topic a message kind is recorded on, or `None` for a kind this version does not
        /// know.
        pub fn board_topic(kind: Kind) -> Option<&'static str> {
            match kind {
                $( Kind::$variant => Some($topic), )*
                Kind::Unknown(_) => None,
            }
        }

        /// The channel `message` is recorded on.
        pub(crate) fn board_channel(message: &Message) -> BoardChannel {
            match message {
                $( Message::$variant(_) => BoardChannel {
                    topic: $topic,
                    schema_name: $schema_name,
                    schema: json_schema_of::<BoardMessage<'static, $ty>>,
                }, )*
            }
        }

        /// The JSON of `received`, read at host time `recv_time_s`, with its stamp mapped to
        /// `host_time_s`.
        pub(crate) fn board_json(
            received: &Received,
            recv_time_s: f64,
            host_time_s: Option<f64>,
        ) -> serde_json::Result<Vec<u8>> {
            match &received.message {
                $( Message::$variant(message) => serde_json::to_vec(&BoardMessage {
                    seq: received.header.seq,
                    lost_before: received.lost_before,
                    recv_time_s,
                    host_time_s,
                    message,
                }), )*
            }
        }
    };
}

board_kinds! {
    Scan(ScanMsg) => "/board/scan", "board.Scan";
    GpsFix(GpsFixMsg) => "/board/gps_fix", "board.GpsFix";
    Nmea(NmeaMsg) => "/board/nmea", "board.Nmea";
    Status(StatusMsg) => "/board/status", "board.Status";
    Heartbeat(HeartbeatMsg) => "/board/heartbeat", "board.Heartbeat";
    Log(LogMsg) => "/board/log", "board.Log";
    Ack(AckMsg) => "/board/ack", "board.Ack";
    Pps(PpsMsg) => "/board/pps", "board.Pps";
    ConfigureLaser(ConfigureLaserCmd) => "/board/configure_laser", "board.ConfigureLaser";
    SetStreaming(SetStreamingCmd) => "/board/set_streaming", "board.SetStreaming";
    RequestStatus(RequestStatusCmd) => "/board/request_status", "board.RequestStatus";
    TimeSyncPing(TimeSyncPingCmd) => "/board/time_sync_ping", "board.TimeSyncPing";
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::{Header, PROTOCOL_VERSION};
    use serde_json::Value;

    fn received(message: Message) -> Received {
        Received {
            header: Header {
                version: PROTOCOL_VERSION,
                kind: message.kind(),
                seq: 41,
            },
            lost_before: 2,
            message,
        }
    }

    #[test]
    fn json_carries_the_header_times_and_fields() {
        let r = received(Message::Pps(PpsMsg {
            edge_us: 5_000_000,
            count: 7,
        }));
        let json: Value =
            serde_json::from_slice(&board_json(&r, 12.5, Some(12.25)).unwrap()).unwrap();
        assert_eq!(json["seq"], 41);
        assert_eq!(json["lost_before"], 2);
        assert_eq!(json["recv_time_s"], 12.5);
        assert_eq!(json["host_time_s"], 12.25);
        assert_eq!(json["message"]["edge_us"], 5_000_000);
        assert_eq!(json["message"]["count"], 7);
        assert_eq!(board_channel(&r.message).topic, "/board/pps");
        assert_eq!(board_topic(Kind::Pps), Some("/board/pps"));
    }

    #[test]
    fn every_kind_has_its_own_topic() {
        let topics: std::collections::BTreeSet<_> = (0..=255u8)
            .filter_map(|k| board_topic(Kind::from(k)))
            .collect();
        // One topic per known kind, none shared.
        let known = (0..=255u8)
            .filter(|&k| !matches!(Kind::from(k), Kind::Unknown(_)))
            .count();
        assert_eq!(topics.len(), known);
        assert_eq!(board_topic(Kind::Unknown(0xEE)), None);
    }

    #[test]
    fn schema_lists_every_field_of_the_json() {
        let r = received(Message::Heartbeat(HeartbeatMsg {
            uptime_us: 3_000_000,
        }));
        let channel = board_channel(&r.message);
        let schema: Value = serde_json::from_slice(&(channel.schema)()).unwrap();
        let json: Value = serde_json::from_slice(&board_json(&r, 1.0, None).unwrap()).unwrap();
        for (key, value) in json.as_object().unwrap() {
            assert!(
                schema["properties"].get(key).is_some(),
                "{key} not in schema"
            );
            if let Some(inner) = value.as_object() {
                for inner_key in inner.keys() {
                    assert!(
                        schema["properties"][key]["properties"]
                            .get(inner_key)
                            .is_some(),
                        "{key}.{inner_key} not in schema"
                    );
                }
            }
        }
    }
}
