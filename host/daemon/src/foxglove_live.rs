//! The live state served to Foxglove over its WebSocket protocol (the `foxglove` crate's
//! server, subprotocols `foxglove.sdk.v1` / `foxglove.sdk.v1.1`).
//!
//! Channels, with the same topics and schemas as a recording:
//!
//! * [`POSE_TOPIC`]: the pose estimate in the map frame (`foxglove.PoseInFrame`);
//! * [`POSE_LOCATION_TOPIC`]: the pose in WGS84 once geo-referenced (`foxglove.LocationFix`);
//! * [`GPS_LOCATION_TOPIC`]: each GPS fix with a position (`foxglove.LocationFix`);
//! * [`COUNTERS_TOPIC`]: the link and sensor counters (JSON, [`LinkCounters`]).
//!
//! In Foxglove: "Open connection", "Foxglove WebSocket", `ws://HOST:PORT`. Messages published
//! while no client is subscribed are dropped.

use std::net::SocketAddr;
use std::sync::Arc;

use foxglove::messages::{LocationFix, PoseInFrame};
use foxglove::{Channel, Context, FoxgloveError, RawChannel, Schema, WebSocketServer};
use protocol::GpsFixMsg;

use crate::state::{LinkCounters, LiveState, PoseView};
use host::recording::foxglove_messages::{gps_location, pose_in_frame, pose_location};
use host::recording::json_schema::json_schema_of;
use host::recording::topics::{
    COUNTERS_TOPIC, GPS_LOCATION_TOPIC, POSE_LOCATION_TOPIC, POSE_TOPIC,
};

/// Why the live server could not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveServerError {
    /// A channel could not be set up.
    #[error("cannot set up the Foxglove channel {topic}: {source}")]
    Channel {
        /// The channel's topic.
        topic: &'static str,
        /// What the Foxglove SDK said.
        source: FoxgloveError,
    },
    /// The server could not listen on the address (in use, not a local address).
    #[error("cannot start the Foxglove WebSocket server on {addr}: {source}")]
    Start {
        /// The address asked for.
        addr: SocketAddr,
        /// What the Foxglove SDK said.
        source: FoxgloveError,
    },
}

/// A running Foxglove WebSocket server and its channels. Dropping it stops the server.
pub struct LiveServer {
    /// `None` once stopped.
    handle: Option<foxglove::WebSocketServerHandle>,
    local_addr: SocketAddr,
    pose: Channel<PoseInFrame>,
    pose_location: Channel<LocationFix>,
    gps_location: Channel<LocationFix>,
    counters: Arc<RawChannel>,
    /// The context the channels and the server share; kept for their lifetime.
    _context: Arc<Context>,
}

impl std::fmt::Debug for LiveServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveServer")
            .field("local_addr", &self.local_addr)
            .finish_non_exhaustive()
    }
}

/// Starts a Foxglove WebSocket server on `addr` (port 0: any free port) with the channels of
/// the [module documentation](self); `name` is the name Foxglove shows for it.
///
/// The server runs on the Foxglove SDK's own runtime threads.
///
/// # Errors
/// [`LiveServerError::Start`] if the server cannot listen on `addr`.
///
/// # Panics
/// If called from inside an async runtime (the SDK then refuses to block on its own).
pub fn start_live_server(addr: SocketAddr, name: &str) -> Result<LiveServer, LiveServerError> {
    // Channels first, on a context of our own: each client is told about them on connecting.
    let context = Context::new();
    let pose = context.channel_builder(POSE_TOPIC).build::<PoseInFrame>();
    let pose_location = context
        .channel_builder(POSE_LOCATION_TOPIC)
        .build::<LocationFix>();
    let gps_location = context
        .channel_builder(GPS_LOCATION_TOPIC)
        .build::<LocationFix>();
    let counters = context
        .channel_builder(COUNTERS_TOPIC)
        .message_encoding("json")
        .schema(Schema::new(
            "host.LinkCounters",
            "jsonschema",
            json_schema_of::<LinkCounters>(),
        ))
        .build_raw()
        .map_err(|source| LiveServerError::Channel {
            topic: COUNTERS_TOPIC,
            source,
        })?;
    let host = match addr {
        SocketAddr::V4(v4) => v4.ip().to_string(),
        SocketAddr::V6(v6) => format!("[{}]", v6.ip()),
    };
    let handle = WebSocketServer::new()
        .name(name)
        .bind(host, addr.port())
        .context(&context)
        .start_blocking()
        .map_err(|source| LiveServerError::Start { addr, source })?;
    let local_addr = SocketAddr::new(addr.ip(), handle.port());
    Ok(LiveServer {
        handle: Some(handle),
        local_addr,
        pose,
        pose_location,
        gps_location,
        counters,
        _context: context,
    })
}

impl LiveServer {
    /// The address the server listens on (with the port chosen when port 0 was asked for).
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// Clients connected now.
    pub fn client_count(&self) -> usize {
        self.handle.as_ref().map_or(0, |h| h.client_count())
    }

    /// Publishes what Foxglove shows of `state`: the pose (and its WGS84 position once
    /// geo-referenced) and the counters, all stamped with the pose's time.
    pub fn publish_state(&self, state: &LiveState) {
        self.publish_pose(&state.pose);
        self.publish_counters(state.pose.time_s, &state.counters);
    }

    /// Publishes the pose estimate, stamped with its own time.
    pub fn publish_pose(&self, pose: &PoseView) {
        let time_ns = log_time_ns(pose.time_s);
        self.pose.log_with_time(&pose_in_frame(pose), time_ns);
        if let Some(location) = pose_location(pose) {
            self.pose_location.log_with_time(&location, time_ns);
        }
    }

    /// Publishes a GPS fix received at host time `time_s`; a report without a position is
    /// skipped.
    pub fn publish_gps_fix(&self, time_s: f64, fix: &GpsFixMsg) {
        if let Some(location) = gps_location(time_s, fix) {
            self.gps_location
                .log_with_time(&location, log_time_ns(time_s));
        }
    }

    /// Publishes the counters at host time `time_s`.
    pub fn publish_counters(&self, time_s: f64, counters: &LinkCounters) {
        // Serialising plain numbers and booleans cannot fail.
        if let Ok(json) = serde_json::to_vec(counters) {
            self.counters.log_with_meta(
                &json,
                foxglove::PartialMetadata::with_log_time(log_time_ns(time_s)),
            );
        }
    }

    /// Stops the server: closes the clients' connections and waits until they are closed.
    ///
    /// # Panics
    /// If called from inside an async runtime.
    pub fn stop(mut self) {
        if let Some(handle) = self.handle.take() {
            handle.stop().wait_blocking();
        }
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        if let Some(handle) = self.handle.take() {
            // Without waiting: the connections are aborted.
            drop(handle.stop());
        }
    }
}

/// Host time `time_s` as nanoseconds, saturated to the representable range.
fn log_time_ns(time_s: f64) -> u64 {
    // `as` saturates, and maps NaN to 0.
    (time_s * 1e9).round() as u64
}

#[cfg(test)]
mod tests {
    use std::net::{Ipv4Addr, TcpStream};
    use std::time::{Duration, Instant};

    use foxglove::Decode;
    use serde_json::{Value, json};
    use tungstenite::client::IntoClientRequest;
    use tungstenite::stream::MaybeTlsStream;
    use tungstenite::{Message as WsMessage, WebSocket};

    use super::*;

    type Client = WebSocket<MaybeTlsStream<TcpStream>>;

    fn connect(addr: SocketAddr) -> Client {
        let mut request = format!("ws://{addr}").into_client_request().unwrap();
        request
            .headers_mut()
            .insert("sec-websocket-protocol", "foxglove.sdk.v1".parse().unwrap());
        let (client, response) = tungstenite::connect(request).unwrap();
        assert_eq!(
            response.headers()["sec-websocket-protocol"],
            "foxglove.sdk.v1"
        );
        if let MaybeTlsStream::Plain(stream) = client.get_ref() {
            stream
                .set_read_timeout(Some(Duration::from_millis(200)))
                .unwrap();
        }
        client
    }

    /// The next text message as JSON, or `None` after a read timeout.
    fn next_json(client: &mut Client) -> Option<Value> {
        loop {
            match client.read() {
                Ok(WsMessage::Text(text)) => return serde_json::from_str(&text).ok(),
                Ok(_) => continue,
                Err(_) => return None,
            }
        }
    }

    /// Reads until a binary message-data frame arrives for `subscription_id`, publishing with
    /// `publish` between reads (subscribing takes effect asynchronously). Returns the payload.
    fn wait_for_data(
        client: &mut Client,
        subscription_id: u32,
        publish: impl Fn(),
    ) -> (u64, Vec<u8>) {
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            publish();
            match client.read() {
                Ok(WsMessage::Binary(data)) if data.len() >= 13 && data[0] == 1 => {
                    let id = u32::from_le_bytes(data[1..5].try_into().unwrap());
                    let log_time = u64::from_le_bytes(data[5..13].try_into().unwrap());
                    if id == subscription_id {
                        return (log_time, data[13..].to_vec());
                    }
                }
                _ => {}
            }
        }
        panic!("no message for subscription {subscription_id}");
    }

    #[test]
    fn advertises_the_channels_and_streams_the_state() {
        let server =
            start_live_server(SocketAddr::from((Ipv4Addr::LOCALHOST, 0)), "robot-host").unwrap();
        assert_ne!(server.local_addr().port(), 0);
        let mut client = connect(server.local_addr());

        let info = next_json(&mut client).unwrap();
        assert_eq!(info["op"], "serverInfo");
        assert_eq!(info["name"], "robot-host");

        // Advertisements may come in several messages.
        let mut channels: Vec<Value> = Vec::new();
        while channels.len() < 4 {
            let message = next_json(&mut client).expect("advertise");
            if message["op"] == "advertise" {
                channels.extend(message["channels"].as_array().unwrap().iter().cloned());
            }
        }
        let channel = |topic: &str| {
            channels
                .iter()
                .find(|c| c["topic"] == topic)
                .unwrap_or_else(|| panic!("{topic} not advertised: {channels:?}"))
                .clone()
        };
        assert_eq!(channel(POSE_TOPIC)["schemaName"], "foxglove.PoseInFrame");
        assert_eq!(channel(POSE_TOPIC)["encoding"], "protobuf");
        assert_eq!(
            channel(GPS_LOCATION_TOPIC)["schemaName"],
            "foxglove.LocationFix"
        );
        assert_eq!(
            channel(POSE_LOCATION_TOPIC)["schemaName"],
            "foxglove.LocationFix"
        );
        let counters = channel(COUNTERS_TOPIC);
        assert_eq!(counters["encoding"], "json");
        assert_eq!(counters["schemaEncoding"], "jsonschema");
        let schema: Value = serde_json::from_str(counters["schema"].as_str().unwrap()).unwrap();
        assert!(schema["properties"]["frames_lost"].is_object(), "{schema}");

        client
            .send(WsMessage::text(
                json!({"op": "subscribe", "subscriptions": [
                    {"id": 1, "channelId": counters["id"]},
                    {"id": 2, "channelId": channel(POSE_TOPIC)["id"]},
                ]})
                .to_string(),
            ))
            .unwrap();

        let mut state = LiveState::default();
        state.counters.frames = 1234;
        state.counters.frames_lost = 5;
        state.pose = PoseView {
            x_m: 4.0,
            y_m: -3.0,
            theta_rad: 0.5,
            time_s: 12.5,
            ..Default::default()
        };
        let (log_time, payload) = wait_for_data(&mut client, 1, || server.publish_state(&state));
        assert_eq!(log_time, 12_500_000_000);
        let received: LinkCounters = serde_json::from_slice(&payload).unwrap();
        assert_eq!(received, state.counters);

        let (_, payload) = wait_for_data(&mut client, 2, || server.publish_state(&state));
        let pose = PoseInFrame::decode(&payload[..]).unwrap();
        let position = pose.pose.unwrap().position.unwrap();
        assert_eq!((position.x, position.y), (4.0, -3.0));

        assert_eq!(server.client_count(), 1);
        server.stop();
        // The server closes the connection.
        let closed = (0..50).any(|_| match client.read() {
            Ok(WsMessage::Close(_)) => true,
            Err(tungstenite::Error::Io(e)) => !matches!(
                e.kind(),
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
            ),
            Err(_) => true,
            Ok(_) => false,
        });
        assert!(closed);
    }

    #[test]
    fn address_in_use_is_an_error() {
        let first = start_live_server(SocketAddr::from((Ipv4Addr::LOCALHOST, 0)), "first").unwrap();
        let again = start_live_server(first.local_addr(), "second");
        assert!(
            matches!(again, Err(LiveServerError::Start { .. })),
            "{again:?}"
        );
        first.stop();
    }
}
