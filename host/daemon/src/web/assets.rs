//! The page's files, compiled into the binary so that the view works with no network.
//!
//! The sources are in `host/daemon/assets/web/`: plain HTML, CSS and JavaScript with no build step.

use axum::http::header;
use axum::response::{IntoResponse, Response};

/// One embedded file.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Asset {
    /// The `Content-Type` it is served with.
    pub content_type: &'static str,
    /// Its contents.
    pub body: &'static str,
}

/// The page: `GET /`.
pub(crate) const INDEX_HTML: Asset = Asset {
    content_type: "text/html; charset=utf-8",
    body: include_str!("../../assets/web/index.html"),
};

/// The page's script: `GET /app.js`.
pub(crate) const APP_JS: Asset = Asset {
    content_type: "text/javascript; charset=utf-8",
    body: include_str!("../../assets/web/app.js"),
};

/// The page's style sheet: `GET /style.css`.
pub(crate) const STYLE_CSS: Asset = Asset {
    content_type: "text/css; charset=utf-8",
    body: include_str!("../../assets/web/style.css"),
};

impl IntoResponse for Asset {
    fn into_response(self) -> Response {
        (
            [
                (header::CONTENT_TYPE, self.content_type),
                (header::CACHE_CONTROL, "no-cache"),
            ],
            self.body,
        )
            .into_response()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_page_loads_only_its_own_files() {
        for asset in [INDEX_HTML, APP_JS, STYLE_CSS] {
            assert!(!asset.body.is_empty());
            for remote in ["http://", "https://", "//cdn", "@import"] {
                assert!(
                    !asset.body.contains(remote),
                    "{} refers to {remote}",
                    asset.content_type
                );
            }
        }
        assert!(INDEX_HTML.body.contains(r#"src="/app.js""#));
        assert!(INDEX_HTML.body.contains(r#"href="/style.css""#));
    }
}
