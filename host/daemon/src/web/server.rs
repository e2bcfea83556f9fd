//! The web server: binds its address, then serves the router on its own thread with its own
//! single-threaded tokio runtime until stopped.
//!
//! Everything that can fail (binding, building the runtime, starting the thread) happens in
//! [`WebServer::start`], so that the daemon learns of a taken port at once. [`WebServer::stop`]
//! stops accepting connections, lets the requests under way finish (for at most
//! [`DRAIN_LIMIT`]) and joins the thread.

use std::io;
use std::net::SocketAddr;
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::Duration;

use tokio::sync::watch;

use super::routes::router;
use crate::{GoalResolver, SharedState};

/// How long [`WebServer::stop`] waits for open connections before closing them.
pub const DRAIN_LIMIT: Duration = Duration::from_secs(2);

/// What the web view serves from.
#[derive(Clone)]
pub struct WebContext {
    /// The daemon's live state: read for `/api/state` and `/api/map.png`, its goal written by
    /// `/api/goal`.
    pub state: SharedState,
    /// Turns the goals the user sets into the map frame.
    pub goal: Arc<dyn GoalResolver>,
    /// The geo-referenced image as PNG, served at `/api/image.png`, when there is one.
    pub image_png: Option<Arc<Vec<u8>>>,
}

/// Why the web server could not start.
#[derive(Debug, thiserror::Error)]
pub enum WebError {
    /// The address could not be bound (taken, or not an address of this machine).
    #[error("the web view cannot listen on {addr}: {source}")]
    Bind {
        /// The address asked for.
        addr: SocketAddr,
        /// The system's reason.
        source: io::Error,
    },
    /// The tokio runtime could not be built.
    #[error("the web view cannot start its runtime: {0}")]
    Runtime(io::Error),
    /// The server thread could not be started.
    #[error("the web view cannot start its thread: {0}")]
    Thread(io::Error),
}

/// The running web server. Dropping it without [`WebServer::stop`] also shuts the server
/// down, without waiting for its thread.
#[derive(Debug)]
pub struct WebServer {
    local_addr: SocketAddr,
    stop: watch::Sender<bool>,
    thread: JoinHandle<()>,
}

impl WebServer {
    /// Binds `addr` (the daemon defaults to 127.0.0.1:8080; port 0 picks one) and serves the
    /// page and the API from `context` until stopped.
    ///
    /// # Errors
    /// The address cannot be bound, or the runtime or thread cannot be started.
    pub fn start(addr: SocketAddr, context: WebContext) -> Result<WebServer, WebError> {
        let bind_error = |source| WebError::Bind { addr, source };
        let listener = std::net::TcpListener::bind(addr).map_err(bind_error)?;
        listener.set_nonblocking(true).map_err(bind_error)?;
        let local_addr = listener.local_addr().map_err(bind_error)?;
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .enable_time()
            .build()
            .map_err(WebError::Runtime)?;
        let listener = {
            let _entered = runtime.enter();
            tokio::net::TcpListener::from_std(listener).map_err(bind_error)?
        };
        let app = router(Arc::new(context));
        let (stop, stopped) = watch::channel(false);
        let thread = thread::Builder::new()
            .name(format!("web {local_addr}"))
            .spawn(move || {
                runtime.block_on(async move {
                    let mut graceful = stopped.clone();
                    let serve = axum::serve(listener, app).with_graceful_shutdown(async move {
                        // A dropped sender also means stop.
                        let _ = graceful.wait_for(|stop| *stop).await;
                    });
                    let mut deadline = stopped;
                    let drain_limit = async move {
                        let _ = deadline.wait_for(|stop| *stop).await;
                        tokio::time::sleep(DRAIN_LIMIT).await;
                    };
                    tokio::select! {
                        result = serve => {
                            if let Err(error) = result {
                                eprintln!("web view on {local_addr} stopped: {error}");
                            }
                        }
                        () = drain_limit => {
                            eprintln!(
                                "web view on {local_addr}: connections still open {} s after \
                                 stop, closing them",
                                DRAIN_LIMIT.as_secs()
                            );
                        }
                    }
                });
            })
            .map_err(WebError::Thread)?;
        Ok(WebServer {
            local_addr,
            stop,
            thread,
        })
    }

    /// The address the server listens on (with the port picked when 0 was asked for).
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// Stops accepting connections, lets the requests under way finish (at most
    /// [`DRAIN_LIMIT`]) and joins the server thread.
    pub fn stop(self) {
        // Fails only when the thread is already gone, which is what is wanted.
        let _ = self.stop.send(true);
        if self.thread.join().is_err() {
            eprintln!("web view on {}: its thread panicked", self.local_addr);
        }
    }
}
