//! The daemon's web view and JSON API.
//!
//! A page (HTML, CSS and JavaScript compiled into the binary, so it works with no network)
//! draws the geo-referenced image with the built map over it: the occupancy grid or the
//! landmarks, the trajectory, the current pose with its 95 % uncertainty ellipse and the goal.
//! It shows the link and GPS counters, refreshed by polling `/api/state` twice a second, and
//! sets the goal where the user clicks on the image through `POST /api/goal`.
//!
//! | route | answer |
//! | --- | --- |
//! | `GET /`, `/app.js`, `/style.css` | the page |
//! | `GET /api/state` | pose, counters, trajectory, landmarks, grid placement, goal, image size, `pixel_from_map` |
//! | `GET /api/map.png` | the occupancy grid's PNG, else the landmarks and trajectory drawn by [`render_map_png`]; 404 before any map |
//! | `GET /api/image.png` | the geo-referenced image; 404 without one |
//! | `POST /api/goal` | `{"pixel_x", "pixel_y"}` or `{"lat_deg", "lon_deg"}` → [`GoalInMap`](crate::GoalInMap), also stored as the state's goal; 400 for a body that is no goal, 422 for a goal the resolver refuses |
//!
//! Every API error is a JSON object `{"error": "..."}`; unknown `/api/` paths answer 404 and
//! wrong methods 405 that way. With a token ([`AccessPolicy`], required when the daemon
//! listens beyond loopback), `POST` requests without it answer 401, and so do `GET /api/`
//! requests unless read-only views are kept open. Connections, timeouts and body sizes are
//! bounded ([`WebLimits`]).
//!
//! [`WebServer::start`] serves it all on its own thread with its own tokio runtime.

mod access;
mod api_error;
mod assets;
mod goal_body;
mod map_render;
mod routes;
mod server;
mod state_json;

pub use access::{AccessPolicy, generate_token};
pub use map_render::{MapRenderError, render_map_png};
pub use server::{DRAIN_LIMIT, WebContext, WebError, WebLimits, WebServer};

/// The page and the API as a router of their own, behind `context`'s access policy and body
/// limit, without a listener: to serve them within another server, or to answer requests
/// in-process. [`WebServer::start`] serves this router.
pub fn router(context: WebContext) -> axum::Router {
    routes::router(std::sync::Arc::new(context))
}

#[cfg(test)]
mod tests;
