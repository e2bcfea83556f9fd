//! Who may do what through the web view: a token for every request that changes the robot's
//! state (`POST`, the goal), and, unless the configuration keeps them open, for the read-only
//! views of `/api/` too.
//!
//! The token travels as `Authorization: Bearer TOKEN`. A request without it, or with another,
//! gets `401` with a JSON error and `WWW-Authenticate: Bearer`, and is logged with its peer's
//! address. Tokens are compared in constant time. The page itself (`/`, its script and style)
//! is always served: it asks for the token once and keeps it in the browser.

use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::{ConnectInfo, Request, State};
use axum::http::{HeaderValue, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::api_error::ApiError;

/// The access rule of the web view.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AccessPolicy {
    /// The token requests must carry; `None` lets every request through (a loopback-only
    /// daemon).
    pub token: Option<String>,
    /// Whether `GET` requests under `/api/` are served without the token.
    pub open_read_only: bool,
}

impl AccessPolicy {
    /// Every request allowed: no token.
    pub fn open() -> AccessPolicy {
        AccessPolicy {
            token: None,
            open_read_only: true,
        }
    }

    /// Whether a request of `method` on `path` needs the token.
    fn needs_token(&self, method: &Method, path: &str) -> bool {
        if self.token.is_none() {
            return false;
        }
        let reads = method == Method::GET || method == Method::HEAD;
        if !reads {
            return true;
        }
        path.starts_with("/api/") && !self.open_read_only
    }

    /// Whether the `Authorization` header carries the token.
    fn admits(&self, authorization: Option<&HeaderValue>) -> bool {
        let Some(token) = &self.token else {
            return true;
        };
        let presented = authorization
            .and_then(|value| value.to_str().ok())
            .and_then(|value| value.strip_prefix("Bearer "))
            .map(str::trim);
        presented.is_some_and(|presented| constant_time_eq(presented.as_bytes(), token.as_bytes()))
    }
}

/// The middleware: passes a request the policy admits, answers `401` to the others.
pub(crate) async fn require_token(
    State(policy): State<Arc<AccessPolicy>>,
    request: Request,
    next: Next,
) -> Response {
    let path = request.uri().path().to_string();
    if !policy.needs_token(request.method(), &path)
        || policy.admits(request.headers().get(header::AUTHORIZATION))
    {
        return next.run(request).await;
    }
    let peer = request
        .extensions()
        .get::<ConnectInfo<SocketAddr>>()
        .map(|info| info.0.to_string())
        .unwrap_or_else(|| "an unknown peer".into());
    let method = request.method().clone();
    tracing::warn!(%peer, %method, %path, "web view: refused a request without the right token");
    let mut response = ApiError::new(
        StatusCode::UNAUTHORIZED,
        "this request needs the daemon's token (Authorization: Bearer TOKEN); it is printed at \
         start or set in the configuration's [web] token",
    )
    .into_response();
    response.headers_mut().insert(
        header::WWW_AUTHENTICATE,
        HeaderValue::from_static("Bearer realm=\"robot-host\""),
    );
    response
}

/// `a == b` in a time that depends only on their lengths.
fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// A new random token: 128 bits from the operating system, as 32 hexadecimal digits.
///
/// # Errors
/// The operating system's random source failed.
pub fn generate_token() -> Result<String, getrandom::Error> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guarded(open_read_only: bool) -> AccessPolicy {
        AccessPolicy {
            token: Some("s3cret-token-0123".into()),
            open_read_only,
        }
    }

    #[test]
    fn writes_need_the_token_and_reads_only_when_closed() {
        let open_reads = guarded(true);
        assert!(open_reads.needs_token(&Method::POST, "/api/goal"));
        assert!(!open_reads.needs_token(&Method::GET, "/api/state"));
        assert!(!open_reads.needs_token(&Method::GET, "/"));
        let closed = guarded(false);
        assert!(closed.needs_token(&Method::GET, "/api/state"));
        assert!(
            !closed.needs_token(&Method::GET, "/app.js"),
            "the page asks for it"
        );
        assert!(!AccessPolicy::open().needs_token(&Method::POST, "/api/goal"));
    }

    #[test]
    fn only_the_exact_bearer_token_is_admitted() {
        let policy = guarded(true);
        let header = |text: &str| HeaderValue::from_str(text).expect("header");
        assert!(policy.admits(Some(&header("Bearer s3cret-token-0123"))));
        assert!(!policy.admits(Some(&header("Bearer s3cret-token-0124"))));
        assert!(!policy.admits(Some(&header("Bearer s3cret"))));
        assert!(!policy.admits(Some(&header("s3cret-token-0123"))));
        assert!(!policy.admits(None));
    }

    #[test]
    fn generated_tokens_are_long_and_differ() {
        let a = generate_token().expect("random");
        let b = generate_token().expect("random");
        assert_eq!(a.len(), 32);
        assert!(a.chars().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a, b);
    }
}
