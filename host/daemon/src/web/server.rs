//! The web server: binds its address, then serves the router on its own thread with its own
//! single-threaded tokio runtime until stopped, so that nothing the web does can hold up the
//! reader and SLAM threads (they share only the live state's lock, held for a copy).
//!
//! It stays within [`WebLimits`] whatever its peers do: at most so many connections at once
//! (more are closed as they arrive, and logged), a connection that sends no complete request
//! header within the header timeout is closed, a request (its body included) that takes longer
//! than the request timeout is answered `408`, and a body larger than the limit `413`.
//! Requests pass the [`AccessPolicy`] first.
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

use axum::Router;
use axum::extract::ConnectInfo;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio::sync::{Semaphore, watch};
use tokio::task::JoinSet;

use super::access::AccessPolicy;
use super::routes::router;
use crate::{GoalResolver, SharedState};

/// How long [`WebServer::stop`] waits for open connections before closing them.
pub const DRAIN_LIMIT: Duration = Duration::from_secs(2);

/// What the web server allows its peers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WebLimits {
    /// Connections served at once; more are closed as they arrive.
    pub max_connections: usize,
    /// A connection must send a whole request header within this, also between requests.
    pub header_read_timeout: Duration,
    /// A request, its body included, must be answered within this.
    pub request_timeout: Duration,
    /// The largest request body accepted, bytes.
    pub max_body_bytes: usize,
}

impl Default for WebLimits {
    fn default() -> Self {
        WebLimits {
            max_connections: 64,
            header_read_timeout: Duration::from_secs(10),
            request_timeout: Duration::from_secs(10),
            max_body_bytes: 16 * 1024,
        }
    }
}

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
    /// Who may do what.
    pub access: AccessPolicy,
    /// What peers are allowed.
    pub limits: WebLimits,
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
        let limits = context.limits;
        let app = router(Arc::new(context));
        let (stop, stopped) = watch::channel(false);
        let thread = thread::Builder::new()
            .name(format!("web {local_addr}"))
            .spawn(move || {
                runtime.block_on(serve(listener, app, limits, stopped));
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

/// Accepts connections until `stopped`, each served on its own task within `limits`; then lets
/// the open ones finish for at most [`DRAIN_LIMIT`].
async fn serve(
    listener: TcpListener,
    app: Router,
    limits: WebLimits,
    mut stopped: watch::Receiver<bool>,
) {
    let local_addr = listener.local_addr().ok();
    let slots = Arc::new(Semaphore::new(limits.max_connections.max(1)));
    let mut connections = JoinSet::new();
    loop {
        let accepted = tokio::select! {
            _ = stopped.wait_for(|stop| *stop) => break,
            accepted = listener.accept() => accepted,
        };
        // Reap finished connections so the set holds only open ones.
        while connections.try_join_next().is_some() {}
        let (stream, peer) = match accepted {
            Ok(accepted) => accepted,
            Err(error) => {
                // Out of file descriptors and the like: wait a little rather than spin.
                tracing::warn!(%error, "web view: cannot accept a connection");
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
        };
        let Ok(slot) = Arc::clone(&slots).try_acquire_owned() else {
            tracing::warn!(
                %peer,
                max = limits.max_connections,
                "web view: too many connections, closed a new one"
            );
            continue;
        };
        let service =
            TowerToHyperService::new(app.clone().layer(axum::Extension(ConnectInfo(peer))));
        let mut stopping = stopped.clone();
        let stop_signal = async move {
            let _ = stopping.wait_for(|stop| *stop).await;
        };
        connections.spawn(async move {
            let _slot = slot;
            let mut builder = hyper::server::conn::http1::Builder::new();
            builder
                .timer(TokioTimer::new())
                .header_read_timeout(limits.header_read_timeout);
            let connection = builder.serve_connection(TokioIo::new(stream), service);
            tokio::pin!(connection);
            tokio::select! {
                result = connection.as_mut() => {
                    if let Err(error) = result {
                        tracing::debug!(%peer, %error, "web view: connection ended");
                    }
                }
                () = stop_signal => {
                    connection.as_mut().graceful_shutdown();
                    let _ = connection.await;
                }
            }
        });
    }
    let drained = tokio::time::timeout(DRAIN_LIMIT, async {
        while connections.join_next().await.is_some() {}
    })
    .await;
    if drained.is_err() {
        let at = local_addr.map_or_else(String::new, |a| format!(" on {a}"));
        eprintln!(
            "web view{at}: connections still open {} s after stop, closing them",
            DRAIN_LIMIT.as_secs()
        );
        connections.abort_all();
    }
}
