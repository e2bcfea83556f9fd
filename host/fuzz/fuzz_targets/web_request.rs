//! Arbitrary requests to the daemon's web API, answered in-process by the same router the
//! daemon serves: any method on any of its paths, with or without the access token, with any
//! body. Nothing may panic or answer 5xx; every API refusal is a JSON `{"error": ...}`; a goal
//! is stored only when its request was answered 200, and a guarded server answers every
//! request that could change something without the token 401.

#![no_main]

use std::sync::{Arc, OnceLock, PoisonError};

use arbitrary::Arbitrary;
use axum::body::Body;
use axum::http::{Method, Request, StatusCode, header};
use libfuzzer_sys::fuzz_target;
use robot_host::web::{AccessPolicy, WebContext, WebLimits, router};
use robot_host::{GoalError, GoalInMap, GoalRequest, GoalResolver, LiveState};
use tower::ServiceExt;

const TOKEN: &str = "fuzz-token-0123456789";

const PATHS: [&str; 9] = [
    "/",
    "/app.js",
    "/style.css",
    "/api/state",
    "/api/map.png",
    "/api/image.png",
    "/api/goal",
    "/api/nothing",
    "/elsewhere",
];

const METHODS: [Method; 5] = [
    Method::GET,
    Method::POST,
    Method::PUT,
    Method::DELETE,
    Method::HEAD,
];

#[derive(Arbitrary, Debug)]
struct FuzzedRequest {
    method: u8,
    path: u8,
    /// 0: no token, 1: the token, 2: `authorization` as given.
    authorization: u8,
    authorization_value: String,
    guarded: bool,
    open_read_only: bool,
    body: Vec<u8>,
}

/// Pixels ↔ map at 4 pixels a metre; refuses pixels outside a 400 × 300 image.
struct Resolver;

impl GoalResolver for Resolver {
    fn resolve(&self, request: &GoalRequest) -> Result<GoalInMap, GoalError> {
        let [x_m, y_m] = match *request {
            GoalRequest::Pixel { pixel_x, pixel_y } => {
                if !(0.0..=400.0).contains(&pixel_x) || !(0.0..=300.0).contains(&pixel_y) {
                    return Err(GoalError::OutsideImage {
                        x: pixel_x,
                        y: pixel_y,
                        width: 400,
                        height: 300,
                    });
                }
                [pixel_x / 4.0, -pixel_y / 4.0]
            }
            GoalRequest::Geodetic { lat_deg, lon_deg } => [lon_deg, lat_deg],
        };
        Ok(GoalInMap {
            x_m,
            y_m,
            lat_deg: y_m,
            lon_deg: x_m,
            pixel: None,
        })
    }
}

fn runtime() -> &'static tokio::runtime::Runtime {
    static RUNTIME: OnceLock<tokio::runtime::Runtime> = OnceLock::new();
    RUNTIME.get_or_init(|| {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .expect("tokio runtime")
    })
}

fuzz_target!(|request: FuzzedRequest| {
    let method = METHODS[usize::from(request.method) % METHODS.len()].clone();
    let path = PATHS[usize::from(request.path) % PATHS.len()];
    let state = LiveState::shared();
    let access = if request.guarded {
        AccessPolicy {
            token: Some(TOKEN.to_owned()),
            open_read_only: request.open_read_only,
        }
    } else {
        AccessPolicy::open()
    };
    let context = WebContext {
        state: state.clone(),
        goal: Arc::new(Resolver),
        image_png: None,
        access,
        limits: WebLimits::default(),
    };
    let mut builder = Request::builder().method(method.clone()).uri(path);
    let has_token = match request.authorization % 3 {
        0 => false,
        1 => {
            builder = builder.header(header::AUTHORIZATION, format!("Bearer {TOKEN}"));
            true
        }
        _ => {
            builder = builder.header(header::AUTHORIZATION, request.authorization_value.as_str());
            request
                .authorization_value
                .strip_prefix("Bearer ")
                .map(str::trim)
                == Some(TOKEN)
        }
    };
    let Ok(http_request) = builder.body(Body::from(request.body)) else {
        // A header value HTTP cannot carry: no client could send it.
        return;
    };
    let (status, body) = runtime().block_on(async {
        let response = router(context)
            .oneshot(http_request)
            .await
            .expect("the router answers every request");
        let status = response.status();
        let body = axum::body::to_bytes(response.into_body(), usize::MAX)
            .await
            .expect("the answer's body");
        (status, body)
    });
    assert!(!status.is_server_error(), "{method} {path}: {status}");
    if path.starts_with("/api/") && status.is_client_error() && method != Method::HEAD {
        let json: serde_json::Value = serde_json::from_slice(&body)
            .unwrap_or_else(|e| panic!("{method} {path}: {status} without JSON: {e}"));
        assert!(json["error"].is_string(), "{method} {path}: {json}");
    }
    let goal = state
        .read()
        .unwrap_or_else(PoisonError::into_inner)
        .goal
        .clone();
    if goal.is_some() {
        assert_eq!(status, StatusCode::OK, "{method} {path}");
        assert!(method == Method::POST && path == "/api/goal");
    }
    let reads = method == Method::GET || method == Method::HEAD;
    if request.guarded && !reads && !has_token {
        assert_eq!(status, StatusCode::UNAUTHORIZED, "{method} {path}");
    }
});
