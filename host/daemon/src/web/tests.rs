//! The API tested through a real server on 127.0.0.1 with a plain HTTP client.

use std::net::{Ipv4Addr, SocketAddr};
use std::sync::{Arc, PoisonError};

use serde_json::{Value, json};

use super::{AccessPolicy, WebContext, WebError, WebLimits, WebServer};
use crate::state::{CameraView, GridView, ImageView, LandmarkView, TrackingView};
use crate::{
    GoalError, GoalInMap, GoalRequest, GoalResolver, LinkCounters, LiveState, PoseView, SharedState,
};

/// Image size of the test resolver, pixels.
const IMAGE_SIZE_PX: [f64; 2] = [400.0, 300.0];
/// The test resolver refuses goals east of this, metres.
const MAP_EAST_LIMIT_M: f64 = 30.0;
/// Latitude and longitude of the map origin, degrees.
const ORIGIN_DEG: [f64; 2] = [48.0, 11.0];
/// Metres per degree of latitude and of longitude near the origin (a flat approximation that
/// is enough for a test).
const M_PER_DEG: [f64; 2] = [111_320.0, 74_488.0];

/// Pixels ↔ map through a fixed affine: 4 pixels per metre, the map origin at the image centre,
/// y up. Refuses pixels outside the image and positions east of [`MAP_EAST_LIMIT_M`].
struct AffineResolver;

/// Map → image pixels of [`AffineResolver`], as `LiveState::pixel_from_map`.
const PIXEL_FROM_MAP: [f64; 6] = [200.0, 4.0, 0.0, 150.0, 0.0, -4.0];

impl GoalResolver for AffineResolver {
    fn resolve(&self, request: &GoalRequest) -> Result<GoalInMap, GoalError> {
        let [x_m, y_m] = match *request {
            GoalRequest::Pixel { pixel_x, pixel_y } => {
                let [width, height] = IMAGE_SIZE_PX;
                if !(0.0..=width).contains(&pixel_x) || !(0.0..=height).contains(&pixel_y) {
                    return Err(GoalError::OutsideImage {
                        x: pixel_x,
                        y: pixel_y,
                        width: 400,
                        height: 300,
                    });
                }
                [(pixel_x - 200.0) / 4.0, (150.0 - pixel_y) / 4.0]
            }
            GoalRequest::Geodetic { lat_deg, lon_deg } => [
                (lon_deg - ORIGIN_DEG[1]) * M_PER_DEG[1],
                (lat_deg - ORIGIN_DEG[0]) * M_PER_DEG[0],
            ],
        };
        let lat_deg = ORIGIN_DEG[0] + y_m / M_PER_DEG[0];
        let lon_deg = ORIGIN_DEG[1] + x_m / M_PER_DEG[1];
        if x_m > MAP_EAST_LIMIT_M {
            return Err(GoalError::OutsideMap {
                lat_deg,
                lon_deg,
                reason: format!("{x_m:.1} m east of the origin, the map ends at 30 m"),
            });
        }
        let [a, b, c, d, e, f] = PIXEL_FROM_MAP;
        Ok(GoalInMap {
            x_m,
            y_m,
            lat_deg,
            lon_deg,
            pixel: Some([a + b * x_m + c * y_m, d + e * x_m + f * y_m]),
        })
    }
}

/// A state with a pose, counters, a trajectory, two landmarks and an image.
fn filled_state() -> LiveState {
    LiveState {
        pose: PoseView {
            x_m: 3.5,
            y_m: -1.25,
            theta_rad: 0.75,
            lat_deg: Some(47.9999888),
            lon_deg: Some(11.000047),
            position_cov_m2: [0.5, 0.1, 0.25],
            time_s: 12.0,
        },
        trajectory_m: vec![[0.0, 0.0], [1.0, -0.5], [3.5, -1.25]],
        trajectory_wgs84: vec![[11.0, 48.0]],
        landmarks: vec![
            LandmarkView {
                x_m: 5.0,
                y_m: 2.0,
                lat_lon_deg: None,
            },
            LandmarkView {
                x_m: -4.0,
                y_m: 6.0,
                lat_lon_deg: None,
            },
        ],
        counters: LinkCounters {
            telegrams: 1234,
            telegram_crc_errors: 5,
            crc_errors: 2,
            gps_fix_quality: 4,
            gps_satellites: 9,
            ..LinkCounters::default()
        },
        image: Some(ImageView {
            width: 400,
            height: 300,
            crs: "EPSG:32632".to_owned(),
        }),
        pixel_from_map: Some(PIXEL_FROM_MAP),
        ..LiveState::default()
    }
}

/// A server on a free port of 127.0.0.1.
fn serve(state: LiveState, image_png: Option<Vec<u8>>) -> (WebServer, SharedState) {
    serve_with(state, image_png, AccessPolicy::open(), WebLimits::default())
}

/// A server on a free port of 127.0.0.1 with `access` and `limits`.
fn serve_with(
    state: LiveState,
    image_png: Option<Vec<u8>>,
    access: AccessPolicy,
    limits: WebLimits,
) -> (WebServer, SharedState) {
    let shared = LiveState::shared();
    *shared.write().unwrap() = state;
    let context = WebContext {
        access,
        limits,
        state: shared.clone(),
        goal: Arc::new(AffineResolver),
        image_png: image_png.map(Arc::new),
    };
    let server = WebServer::start(SocketAddr::from((Ipv4Addr::LOCALHOST, 0)), context).unwrap();
    (server, shared)
}

/// A client that hands back 4xx and 5xx answers instead of failing, and uses no proxy.
fn client() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .proxy(None)
        .build()
        .new_agent()
}

/// An answer: status, content type and body.
struct Answer {
    status: u16,
    content_type: String,
    body: Vec<u8>,
}

impl Answer {
    fn json(&self) -> Value {
        assert!(
            self.content_type.starts_with("application/json"),
            "content type {}",
            self.content_type
        );
        serde_json::from_slice(&self.body).unwrap()
    }

    /// The `error` message of a JSON error answer.
    fn error(&self) -> String {
        self.json()["error"].as_str().unwrap().to_owned()
    }
}

fn answer(mut response: ureq::http::Response<ureq::Body>) -> Answer {
    let content_type = response
        .headers()
        .get("content-type")
        .map(|v| v.to_str().unwrap().to_owned())
        .unwrap_or_default();
    Answer {
        status: response.status().as_u16(),
        content_type,
        body: response.body_mut().read_to_vec().unwrap(),
    }
}

fn get(server: &WebServer, path: &str) -> Answer {
    let url = format!("http://{}{path}", server.local_addr());
    answer(client().get(&url).call().unwrap())
}

fn post_goal(server: &WebServer, body: &str) -> Answer {
    let url = format!("http://{}/api/goal", server.local_addr());
    let request = client()
        .post(&url)
        .header("content-type", "application/json");
    answer(request.send(body).unwrap())
}

fn stored_goal(state: &SharedState) -> Option<GoalInMap> {
    state.read().unwrap_or_else(PoisonError::into_inner).goal
}

#[test]
fn test_state_has_the_pose_counters_and_map() {
    let (server, _state) = serve(filled_state(), None);
    let answer = get(&server, "/api/state");
    assert_eq!(answer.status, 200);
    let json = answer.json();
    let pose = &json["pose"];
    assert_eq!(pose["x_m"], 3.5);
    assert_eq!(pose["y_m"], -1.25);
    assert_eq!(pose["theta_rad"], 0.75);
    assert_eq!(pose["lat_deg"], 47.9999888);
    assert_eq!(pose["lon_deg"], 11.000047);
    assert_eq!(pose["position_cov_m2"], json!([0.5, 0.1, 0.25]));
    assert_eq!(json["counters"]["telegrams"], 1234);
    assert_eq!(json["counters"]["telegram_crc_errors"], 5);
    assert_eq!(json["counters"]["crc_errors"], 2);
    assert_eq!(json["counters"]["gps_fix_quality"], 4);
    assert_eq!(json["trajectory_m"][2], json!([3.5, -1.25]));
    assert_eq!(json["landmarks"][1]["x_m"], -4.0);
    assert_eq!(json["image"]["width"], 400);
    assert_eq!(json["pixel_from_map"], json!(PIXEL_FROM_MAP));
    assert_eq!(json["goal"], Value::Null);
    assert_eq!(json["grid"], Value::Null);
    server.stop();
}

#[test]
fn test_state_follows_the_shared_state() {
    let (server, state) = serve(LiveState::default(), None);
    assert_eq!(
        get(&server, "/api/state").json()["pose"]["lat_deg"],
        Value::Null
    );
    state.write().unwrap().counters.telegrams = 77;
    assert_eq!(
        get(&server, "/api/state").json()["counters"]["telegrams"],
        77
    );
    server.stop();
}

#[test]
fn test_pixel_goal_is_resolved_and_stored() {
    let (server, state) = serve(filled_state(), None);
    let answer = post_goal(&server, r#"{"pixel_x": 240, "pixel_y": 110}"#);
    assert_eq!(
        answer.status,
        200,
        "{}",
        String::from_utf8_lossy(&answer.body)
    );
    let goal: GoalInMap = serde_json::from_slice(&answer.body).unwrap();
    assert_eq!((goal.x_m, goal.y_m), (10.0, 10.0));
    assert_eq!(goal.pixel, Some([240.0, 110.0]));
    assert!((goal.lat_deg - (48.0 + 10.0 / 111_320.0)).abs() < 1e-12);
    assert_eq!(stored_goal(&state), Some(goal));
    assert_eq!(get(&server, "/api/state").json()["goal"]["x_m"], 10.0);
    server.stop();
}

#[test]
fn test_geodetic_goal_is_resolved_and_stored() {
    let (server, state) = serve(filled_state(), None);
    let body = json!({ "lat_deg": 48.0 - 5.0 / 111_320.0, "lon_deg": 11.0 + 2.0 / 74_488.0 });
    let answer = post_goal(&server, &body.to_string());
    assert_eq!(answer.status, 200);
    let goal: GoalInMap = serde_json::from_slice(&answer.body).unwrap();
    assert!((goal.x_m - 2.0).abs() < 1e-9 && (goal.y_m + 5.0).abs() < 1e-9);
    assert_eq!(stored_goal(&state), Some(goal));
    server.stop();
}

#[test]
fn test_malformed_goals_are_400_and_leave_the_goal() {
    let (server, state) = serve(filled_state(), None);
    for (body, says) in [
        ("pixel 3 4", "not valid JSON"),
        ("", "not valid JSON"),
        (r#"{"pixel_x": 3}"#, "pixel_x: a number"),
        (r#"{"pixel_x": "3", "pixel_y": 4}"#, "pixel_x: a string"),
        (r#"{"x": 3, "y": 4}"#, "x: a number, y: a number"),
        ("[3, 4]", "an array"),
        (
            r#"{"pixel_x": 3, "pixel_y": 4, "lat_deg": 48, "lon_deg": 11}"#,
            "both a pixel and a latitude",
        ),
    ] {
        let answer = post_goal(&server, body);
        assert_eq!(answer.status, 400, "{body}");
        let error = answer.error();
        assert!(error.contains(says), "{body}: {error}");
    }
    assert_eq!(stored_goal(&state), None);
    server.stop();
}

#[test]
fn test_refused_goals_are_422_with_the_reason() {
    let (server, state) = serve(filled_state(), None);
    let outside_image = post_goal(&server, r#"{"pixel_x": 420, "pixel_y": 10}"#);
    assert_eq!(outside_image.status, 422);
    assert_eq!(
        outside_image.error(),
        "pixel (420.0, 10.0) is outside the 400×300 image"
    );
    let outside_map = post_goal(&server, r#"{"pixel_x": 360, "pixel_y": 150}"#);
    assert_eq!(outside_map.status, 422);
    let error = outside_map.error();
    assert!(error.contains("is outside the map: 40.0 m east"), "{error}");
    assert_eq!(stored_goal(&state), None);
    server.stop();
}

#[test]
fn test_image_is_404_without_one_and_served_with_one() {
    let (server, _state) = serve(filled_state(), None);
    let missing = get(&server, "/api/image.png");
    assert_eq!(missing.status, 404);
    assert!(missing.error().contains("no geo-referenced image"));
    server.stop();

    let png = vec![0x89, b'P', b'N', b'G', 1, 2, 3];
    let (server, _state) = serve(filled_state(), Some(png.clone()));
    let image = get(&server, "/api/image.png");
    assert_eq!(image.status, 200);
    assert_eq!(image.content_type, "image/png");
    assert_eq!(image.body, png);
    server.stop();
}

#[test]
fn test_map_is_the_grid_else_the_landmarks_drawn() {
    let (server, state) = serve(LiveState::default(), None);
    let empty = get(&server, "/api/map.png");
    assert_eq!(empty.status, 404);
    assert!(empty.error().contains("no map built yet"));

    *state.write().unwrap() = filled_state();
    let drawn = get(&server, "/api/map.png");
    assert_eq!(drawn.status, 200);
    assert_eq!(drawn.content_type, "image/png");
    let info = png::Decoder::new(std::io::Cursor::new(drawn.body))
        .read_info()
        .unwrap()
        .info()
        .clone();
    assert_eq!(info.width.max(info.height), 800);

    let grid_png = vec![0x89, b'P', b'N', b'G', 9];
    state.write().unwrap().grid = Some(GridView {
        png: grid_png.clone(),
        resolution_m: 0.1,
        origin_m: [-2.0, -3.0],
        size_cells: [50, 40],
    });
    let grid = get(&server, "/api/map.png");
    assert_eq!(grid.status, 200);
    assert_eq!(grid.body, grid_png);
    let placement = &get(&server, "/api/state").json()["grid"];
    assert_eq!(placement["origin_m"], json!([-2.0, -3.0]));
    assert_eq!(placement["size_cells"], json!([50, 40]));

    // The page says "tracking lost" from this.
    assert_eq!(get(&server, "/api/state").json()["tracking"], json!(null));
    state.write().unwrap().tracking = Some(TrackingView {
        lost: true,
        lost_scans: 3,
    });
    let tracking = &get(&server, "/api/state").json()["tracking"];
    assert_eq!(tracking["lost"], true);
    assert_eq!(tracking["lost_scans"], 3);
    server.stop();
}

#[test]
fn test_unknown_api_paths_and_methods_answer_json() {
    let (server, _state) = serve(filled_state(), None);
    let unknown = get(&server, "/api/nothing/here");
    assert_eq!(unknown.status, 404);
    assert_eq!(unknown.error(), "no such API path: /api/nothing/here");
    let wrong_method = get(&server, "/api/goal");
    assert_eq!(wrong_method.status, 405);
    assert!(wrong_method.error().contains("/api/goal"));
    server.stop();
}

#[test]
fn test_page_and_its_files_are_served() {
    let (server, _state) = serve(filled_state(), None);
    let page = get(&server, "/");
    assert_eq!(page.status, 200);
    assert!(page.content_type.starts_with("text/html"));
    assert!(
        String::from_utf8(page.body)
            .unwrap()
            .contains("<canvas id=\"view\"")
    );
    assert!(
        get(&server, "/app.js")
            .content_type
            .starts_with("text/javascript")
    );
    assert!(
        get(&server, "/style.css")
            .content_type
            .starts_with("text/css")
    );
    assert_eq!(get(&server, "/nothing").status, 404);
    server.stop();
}

#[test]
fn test_taken_address_is_a_bind_error() {
    let (server, _state) = serve(filled_state(), None);
    let context = WebContext {
        access: AccessPolicy::open(),
        limits: WebLimits::default(),
        state: LiveState::shared(),
        goal: Arc::new(AffineResolver),
        image_png: None,
    };
    let error = WebServer::start(server.local_addr(), context).unwrap_err();
    assert!(
        matches!(&error, WebError::Bind { addr, .. } if *addr == server.local_addr()),
        "{error}"
    );
    server.stop();
}

#[test]
fn test_stop_closes_the_port() {
    let (server, _state) = serve(filled_state(), None);
    let addr = server.local_addr();
    assert_eq!(get(&server, "/api/state").status, 200);
    server.stop();
    assert!(std::net::TcpStream::connect(addr).is_err());
}

const TOKEN: &str = "a-token-of-sixteen-or-more";

fn guarded(open_read_only: bool) -> AccessPolicy {
    AccessPolicy {
        token: Some(TOKEN.into()),
        open_read_only,
    }
}

fn post_goal_with(server: &WebServer, body: &str, authorization: &str) -> Answer {
    let url = format!("http://{}/api/goal", server.local_addr());
    let request = client()
        .post(&url)
        .header("content-type", "application/json")
        .header("authorization", authorization);
    answer(request.send(body).unwrap())
}

#[test]
fn test_a_goal_without_the_token_is_401_and_changes_nothing() {
    let (server, state) = serve_with(filled_state(), None, guarded(true), WebLimits::default());
    let body = r#"{"pixel_x": 220, "pixel_y": 130}"#;
    let refused = post_goal(&server, body);
    assert_eq!(refused.status, 401);
    assert!(refused.error().contains("token"), "{}", refused.error());
    let wrong = post_goal_with(&server, body, "Bearer a-token-of-sixteen-or-mord");
    assert_eq!(wrong.status, 401);
    assert_eq!(stored_goal(&state), None);
    let accepted = post_goal_with(&server, body, &format!("Bearer {TOKEN}"));
    assert_eq!(accepted.status, 200);
    assert!(stored_goal(&state).is_some());
    // The read-only views and the page stay open.
    assert_eq!(get(&server, "/api/state").status, 200);
    assert_eq!(get(&server, "/").status, 200);
    server.stop();
}

#[test]
fn test_closed_read_only_views_need_the_token_but_not_the_page() {
    let (server, _) = serve_with(filled_state(), None, guarded(false), WebLimits::default());
    let answer = get(&server, "/api/state");
    assert_eq!(answer.status, 401);
    assert_eq!(get(&server, "/app.js").status, 200);
    let url = format!("http://{}/api/state", server.local_addr());
    let with_token = client()
        .get(&url)
        .header("authorization", &format!("Bearer {TOKEN}"))
        .call()
        .unwrap();
    assert_eq!(with_token.status().as_u16(), 200);
    server.stop();
}

#[test]
fn test_a_body_over_the_limit_is_413() {
    let limits = WebLimits {
        max_body_bytes: 64,
        ..WebLimits::default()
    };
    let (server, state) = serve_with(filled_state(), None, AccessPolicy::open(), limits);
    let padding = " ".repeat(200);
    let answer = post_goal(
        &server,
        &format!("{{\"pixel_x\": 220, \"pixel_y\": 130{padding}}}"),
    );
    assert_eq!(answer.status, 413);
    assert_eq!(stored_goal(&state), None);
    server.stop();
}

#[test]
fn test_idle_and_surplus_connections_are_closed() {
    use std::io::{Read, Write};
    use std::net::TcpStream;
    use std::time::{Duration, Instant};

    let limits = WebLimits {
        max_connections: 2,
        header_read_timeout: Duration::from_millis(300),
        ..WebLimits::default()
    };
    let (server, _) = serve_with(filled_state(), None, AccessPolicy::open(), limits);
    let addr = server.local_addr();
    // Two connections that never send a whole request hold both slots…
    let mut idle: Vec<TcpStream> = (0..2)
        .map(|_| {
            let mut stream = TcpStream::connect(addr).unwrap();
            stream.write_all(b"GET /api/state HTTP/1.1\r\n").unwrap();
            stream
        })
        .collect();
    std::thread::sleep(Duration::from_millis(50));
    // …so a third is closed at once, without an answer.
    let mut third = TcpStream::connect(addr).unwrap();
    third
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    let _ = third.write_all(b"GET /api/state HTTP/1.1\r\nhost: x\r\n\r\n");
    let mut buffer = Vec::new();
    let read = third.read_to_end(&mut buffer);
    assert!(
        read.is_err() || buffer.is_empty(),
        "a surplus connection got {:?}",
        String::from_utf8_lossy(&buffer)
    );
    // The idle ones are closed once the header timeout passes, and serving resumes.
    let started = Instant::now();
    for stream in &mut idle {
        stream
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        let mut rest = Vec::new();
        let _ = stream.read_to_end(&mut rest);
    }
    assert!(started.elapsed() < Duration::from_secs(4));
    assert_eq!(get(&server, "/api/state").status, 200);
    server.stop();
}

#[test]
fn test_camera_frames_are_served_by_number_while_kept() {
    let (server, state) = serve(LiveState::default(), None);
    let answer = get(&server, "/api/camera.jpg");
    assert_eq!(answer.status, 404);
    assert!(
        answer.error().contains("no camera frame yet"),
        "{}",
        answer.error()
    );
    {
        let mut s = state.write().unwrap();
        let camera = s.camera.get_or_insert_with(CameraView::default);
        for n in 1..=12u8 {
            camera.show(Arc::new(vec![0xFF, 0xD8, n]), f64::from(n) * 0.1, [4, 4]);
        }
    }
    let status = &get(&server, "/api/state").json()["camera"];
    assert_eq!(status["frame"], 12);
    let newest = get(&server, "/api/camera.jpg");
    assert_eq!(newest.status, 200);
    assert_eq!(newest.content_type, "image/jpeg");
    assert_eq!(newest.body, vec![0xFF, 0xD8, 12]);
    // The page asks for the frame whose status it drew, a few frames behind the newest.
    let asked = get(&server, "/api/camera.jpg?frame=9");
    assert_eq!(asked.body, vec![0xFF, 0xD8, 9]);
    let gone = get(&server, "/api/camera.jpg?frame=2");
    assert_eq!(gone.status, 404);
    assert!(gone.error().contains("no longer kept"), "{}", gone.error());
    let bad = get(&server, "/api/camera.jpg?frame=x");
    assert_eq!(bad.status, 400);
    assert!(
        bad.error().contains("not a frame number"),
        "{}",
        bad.error()
    );
    server.stop();
}
