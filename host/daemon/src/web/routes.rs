//! The routes: the page's files and the JSON API. Handlers only read the request, call the
//! state or the goal resolver, and write the answer. The table of routes is in the module
//! above.

use std::sync::{Arc, PoisonError, RwLockReadGuard};

use std::time::Duration;

use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, Request, State};
use axum::http::{StatusCode, Uri, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{any, get, post};
use axum::{Json, Router};

use super::access::require_token;
use super::api_error::ApiError;
use super::assets::{APP_JS, INDEX_HTML, STYLE_CSS};
use super::goal_body::parse_goal_body;
use super::map_render::{MapRenderError, render_map_png};
use super::server::WebContext;
use super::state_json::StateJson;
use crate::LiveState;

/// Longer side of the landmark map drawn for `/api/map.png`, pixels.
const MAP_RENDER_SIDE_PX: u32 = 800;

/// The router serving the page and the API from `context`, behind its access policy and
/// limits.
pub(crate) fn router(context: Arc<WebContext>) -> Router {
    let access = Arc::new(context.access.clone());
    let limits = context.limits;
    Router::new()
        .route("/", get(|| async { INDEX_HTML }))
        .route("/app.js", get(|| async { APP_JS }))
        .route("/style.css", get(|| async { STYLE_CSS }))
        .route("/api/state", get(state))
        .route("/api/map.png", get(map_png))
        .route("/api/image.png", get(image_png))
        .route("/api/camera.jpg", get(camera_jpg))
        .route("/api/goal", post(goal))
        .method_not_allowed_fallback(method_not_allowed)
        .route("/api/{*rest}", any(api_not_found))
        .fallback(page_not_found)
        .with_state(context)
        .layer(DefaultBodyLimit::max(limits.max_body_bytes))
        .layer(middleware::from_fn_with_state(access, require_token))
        .layer(middleware::from_fn(move |request: Request, next: Next| {
            within_deadline(limits.request_timeout, request, next)
        }))
}

/// Answers `408` to a request not answered within `limit` (a slow body, a stalled client).
async fn within_deadline(limit: Duration, request: Request, next: Next) -> Response {
    match tokio::time::timeout(limit, next.run(request)).await {
        Ok(response) => response,
        Err(_) => ApiError::new(
            StatusCode::REQUEST_TIMEOUT,
            format!("the request was not complete within {} s", limit.as_secs()),
        )
        .into_response(),
    }
}

/// Reads the live state; a lock poisoned by a panicking writer still holds the last values.
fn read(context: &WebContext) -> RwLockReadGuard<'_, LiveState> {
    context.state.read().unwrap_or_else(PoisonError::into_inner)
}

/// `GET /api/state`.
async fn state(State(context): State<Arc<WebContext>>) -> Response {
    let state = read(&context);
    (
        [(header::CACHE_CONTROL, "no-store")],
        Json(StateJson::from(&*state)),
    )
        .into_response()
}

/// `GET /api/map.png`.
async fn map_png(State(context): State<Arc<WebContext>>) -> Result<Response, ApiError> {
    let (grid_png, trajectory_m, landmarks_m) = {
        let state = read(&context);
        match &state.grid {
            Some(grid) => (Some(grid.png.clone()), Vec::new(), Vec::new()),
            None => (
                None,
                state.trajectory_m.clone(),
                state.landmarks.iter().map(|l| [l.x_m, l.y_m]).collect(),
            ),
        }
    };
    let png =
        match grid_png {
            Some(png) => png,
            None => render_map_png(&trajectory_m, &landmarks_m, MAP_RENDER_SIDE_PX).map_err(
                |error| match error {
                    MapRenderError::Empty => {
                        ApiError::new(StatusCode::NOT_FOUND, error.to_string())
                    }
                    MapRenderError::Encoding(_) => {
                        ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, error.to_string())
                    }
                },
            )?,
        };
    Ok(png_response(png))
}

/// `GET /api/image.png`.
async fn image_png(State(context): State<Arc<WebContext>>) -> Result<Response, ApiError> {
    let png = context.image_png.as_ref().ok_or_else(|| {
        ApiError::new(
            StatusCode::NOT_FOUND,
            "no geo-referenced image was loaded (start the daemon with an image)",
        )
    })?;
    Ok(png_response(png.as_ref().clone()))
}

/// `GET /api/camera.jpg[?frame=N]`: camera frame N (the one `/api/state` described), while
/// the daemon keeps it, else the newest.
async fn camera_jpg(
    State(context): State<Arc<WebContext>>,
    uri: Uri,
) -> Result<Response, ApiError> {
    let asked = uri
        .query()
        .into_iter()
        .flat_map(|q| q.split('&'))
        .find_map(|pair| pair.strip_prefix("frame="))
        .map(|n| {
            n.parse::<u64>().map_err(|_| {
                ApiError::new(
                    StatusCode::BAD_REQUEST,
                    format!("frame={n:?} is not a frame number"),
                )
            })
        })
        .transpose()?;
    let jpeg = {
        let state = read(&context);
        let camera = state.camera.as_ref().ok_or_else(|| {
            ApiError::new(
                StatusCode::NOT_FOUND,
                "no camera frame yet (the daemon has no camera, or it has sent nothing)",
            )
        })?;
        camera.jpeg(asked).cloned().ok_or_else(|| match asked {
            Some(frame) => ApiError::new(
                StatusCode::NOT_FOUND,
                format!(
                    "frame {frame} is no longer kept (the newest is {}): ask /api/state again",
                    camera.status.frame
                ),
            ),
            None => ApiError::new(StatusCode::NOT_FOUND, "no camera frame yet"),
        })?
    };
    Ok((
        [
            (header::CONTENT_TYPE, "image/jpeg"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        jpeg.as_ref().clone(),
    )
        .into_response())
}

/// `POST /api/goal`.
async fn goal(State(context): State<Arc<WebContext>>, body: Bytes) -> Result<Response, ApiError> {
    let request = parse_goal_body(&body)
        .map_err(|error| ApiError::new(StatusCode::BAD_REQUEST, error.to_string()))?;
    let goal = context
        .goal
        .resolve(&request)
        .map_err(|error| ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, error.to_string()))?;
    context
        .state
        .write()
        .unwrap_or_else(PoisonError::into_inner)
        .goal = Some(goal);
    Ok(Json(goal).into_response())
}

/// Any other path under `/api/`.
async fn api_not_found(uri: Uri) -> ApiError {
    ApiError::new(
        StatusCode::NOT_FOUND,
        format!("no such API path: {}", uri.path()),
    )
}

/// A known path asked for with the wrong method.
async fn method_not_allowed(uri: Uri) -> ApiError {
    ApiError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        format!("method not allowed on {}", uri.path()),
    )
}

/// Any other path.
async fn page_not_found(uri: Uri) -> (StatusCode, String) {
    (
        StatusCode::NOT_FOUND,
        format!("no such page: {}; the view is at /", uri.path()),
    )
}

/// A PNG answer that the browser must not cache.
fn png_response(png: Vec<u8>) -> Response {
    (
        [
            (header::CONTENT_TYPE, "image/png"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        png,
    )
        .into_response()
}
