//! The web server: hyper's HTTP/1 on a single-threaded tokio runtime, with limits on
//! everything a client controls. tiny_http, before it, had none: an endless header line
//! grew the viewer by a megabyte a megabyte sent, held connections took a thread each
//! and, once they had taken every file descriptor, its accept thread ended for good
//! while the process lived on.
//!
//! - A request's line and headers: [`MAX_HEAD`] bytes and [`MAX_HEADERS`] headers
//!   (hyper answers 431 beyond), all of it within [`HEAD_TIMEOUT`] once begun.
//! - A connection that neither sends nor takes a byte for [`IDLE_TIMEOUT`] is closed,
//!   whether it is silent, mid-request or not reading its answer; one that carries the
//!   push stream ([`crate::push`]) sends nothing after its request and is held to its
//!   writes only (the stream writes a heartbeat every 5 s).
//! - At most [`MAX_CONNECTIONS`] connections (fewer if the file descriptor limit is
//!   lower); a new one pushes out the connection idle longest ([`Connections`]), and an
//!   accept that fails (no descriptor left) frees one and goes on: the server never
//!   stops accepting.
//! - Threads: one for the runtime, [`PICTURE_THREADS`] for drawing and encoding, one
//!   for the [`HealthWatch`]. A request waiting for the next frame costs no thread.

use crate::connections::{Connections, Ticket};
use crate::health::{HealthError, HealthWatch};
use crate::idle::Idle;
use crate::pictures::Shared;
use crate::routes::route;
use http_body_util::Either;
use hyper::body::Incoming;
use hyper::server::conn::http1;
use hyper::service::service_fn;
use hyper::Request;
use hyper_util::rt::{TokioIo, TokioTimer};
use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;
use tokio::sync::oneshot;
use tokio_io_timeout::TimeoutStream;

/// Most connections open at once.
pub const MAX_CONNECTIONS: usize = 2048;
/// Longest request line and headers together (a browser's are under 1 KiB; cookies of
/// other sites on the same host can add a few).
pub const MAX_HEAD: usize = 16 * 1024;
/// Most headers in a request.
pub const MAX_HEADERS: usize = 64;
/// A request's line and headers must have arrived this long after their first byte.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(5);
/// A connection through which no byte moves for this long, either way, is closed. It
/// also bounds how long an answer may take to prepare (hyper keeps reading meanwhile):
/// the longest, a long poll for the next picture, takes a second.
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(10);
/// Threads drawing and encoding pictures (one draws at a time; the other answers a
/// request for a picture already made meanwhile).
pub const PICTURE_THREADS: usize = 2;
/// Connections the kernel queues before they are accepted (capped by
/// net.core.somaxconn, 4096 by default).
const BACKLOG: u32 = 4096;
/// File descriptors kept for everything but connections (shared memory, logs, the
/// runtime).
const SPARE_FDS: u64 = 64;

/// Why the viewer cannot serve, or stopped serving.
#[derive(Debug, thiserror::Error)]
#[error("cannot serve the viewer on {addr}: {reason}")]
pub struct ServeError {
    addr: SocketAddr,
    reason: String,
}

/// The HTTP server and its threads.
pub struct Server {
    addr: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<JoinHandle<()>>,
    watchdog: Option<HealthWatch>,
    connections: Arc<Connections>,
}

/// Raises the soft limit of open files to the hard one (up to what the connections
/// need) and returns it: held connections once exhausted the default 1024.
fn raise_fd_limit() -> u64 {
    let want = MAX_CONNECTIONS as u64 + SPARE_FDS;
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit/setrlimit(2) read and write only `lim`.
    unsafe {
        if libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim) != 0 {
            return 1024;
        }
        if lim.rlim_cur < want && lim.rlim_max > lim.rlim_cur {
            let raised = libc::rlimit {
                rlim_cur: want.min(lim.rlim_max),
                rlim_max: lim.rlim_max,
            };
            if libc::setrlimit(libc::RLIMIT_NOFILE, &raised) == 0 {
                return raised.rlim_cur;
            }
        }
    }
    lim.rlim_cur
}

impl Server {
    /// Listens on `addr` (port 0 picks a free one) and serves from `shared`.
    pub fn start(addr: SocketAddr, shared: Arc<Shared>) -> Result<Self, ServeError> {
        let fail = |reason: String| ServeError { addr, reason };
        let fds = raise_fd_limit();
        let limit = (fds.saturating_sub(SPARE_FDS) as usize).clamp(1, MAX_CONNECTIONS);
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .max_blocking_threads(PICTURE_THREADS)
            .thread_name("web-picture")
            .build()
            .map_err(|e| fail(format!("cannot start the web runtime: {e}")))?;
        let listener = {
            let _in_runtime = runtime.enter();
            listen(addr).map_err(|e| fail(e.to_string()))?
        };
        let bound = listener.local_addr().map_err(|e| fail(e.to_string()))?;
        let connections = Connections::new(limit);
        let (stop, stopped) = oneshot::channel();
        let thread = {
            let connections = connections.clone();
            std::thread::Builder::new()
                .name("web".into())
                .spawn(move || {
                    runtime.block_on(accept(listener, shared, connections, stopped));
                    // Requests still drawing a picture get a moment, not a hang.
                    runtime.shutdown_timeout(Duration::from_secs(1));
                })
                .map_err(|e| fail(format!("cannot start the web thread: {e}")))?
        };
        let watchdog =
            // Started once the port is bound: every failure counts.
            HealthWatch::start(bound, Duration::ZERO)
                .map_err(|e| fail(format!("cannot start the watchdog: {e}")))?;
        tracing::debug!(%bound, connections = limit, "web server");
        Ok(Self {
            addr: bound,
            stop: Some(stop),
            thread: Some(thread),
            watchdog: Some(watchdog),
            connections,
        })
    }

    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Connections open now.
    pub fn connections(&self) -> usize {
        self.connections.open()
    }

    /// Connections closed to make room for newer ones since the start.
    pub fn evicted(&self) -> u64 {
        self.connections.evicted()
    }

    /// Whether the server still serves: an error once its thread has ended or its own
    /// health check failed three times in a row. The viewer's loop returns it, so the
    /// process ends and is restarted instead of living on without a server.
    pub fn health(&self) -> Result<(), ServeError> {
        if self.thread.as_ref().is_none_or(|t| t.is_finished()) {
            return Err(ServeError {
                addr: self.addr,
                reason: "the web server's thread has ended".into(),
            });
        }
        match self
            .watchdog
            .as_ref()
            .and_then(HealthWatch::stopped_serving)
        {
            Some(HealthError { reason, .. }) => Err(ServeError {
                addr: self.addr,
                reason: format!("stopped answering its health check: {reason}"),
            }),
            None => Ok(()),
        }
    }

    /// Stops serving and waits for the server's thread.
    pub fn stop(mut self) {
        drop(self.watchdog.take());
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Listens on `addr` with a backlog of [`BACKLOG`] (std's is 128: a client opening
/// a thousand connections at once overflowed it, and every connection after, a
/// browser's too, waited for its SYN to be sent again, a second or more).
fn listen(addr: SocketAddr) -> std::io::Result<tokio::net::TcpListener> {
    let socket = if addr.is_ipv4() {
        tokio::net::TcpSocket::new_v4()?
    } else {
        tokio::net::TcpSocket::new_v6()?
    };
    socket.set_reuseaddr(true)?;
    socket.bind(addr)?;
    socket.listen(BACKLOG)
}

/// Accepts connections until told to stop. A failed accept (most often: no file
/// descriptor left) closes the longest idle connection and goes on.
async fn accept(
    listener: tokio::net::TcpListener,
    shared: Arc<Shared>,
    connections: Arc<Connections>,
    mut stop: oneshot::Receiver<()>,
) {
    loop {
        tokio::select! {
            _ = &mut stop => return,
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => serve(stream, &shared, &connections),
                Err(e) => {
                    let shed = connections.shed();
                    tracing::warn!(error = %e, shed, "accept failed; the server goes on");
                    tokio::time::sleep(Duration::from_millis(10)).await;
                }
            }
        }
    }
}

/// Serves one connection on a task of its own, within the limits.
fn serve(stream: tokio::net::TcpStream, shared: &Arc<Shared>, connections: &Arc<Connections>) {
    let ticket = Arc::new(connections.admit());
    let _ = stream.set_nodelay(true);
    let mut io = TimeoutStream::new(stream);
    io.set_write_timeout(Some(IDLE_TIMEOUT));
    // The read deadline is lifted once the connection carries the push stream.
    let streaming = Arc::new(AtomicBool::new(false));
    let io = Idle::new(Box::pin(io), IDLE_TIMEOUT, streaming.clone());
    let task = tokio::spawn(converse(
        TokioIo::new(io),
        shared.clone(),
        ticket.clone(),
        streaming,
    ));
    ticket.attach(task.abort_handle());
}

/// One connection's requests and answers, through hyper with the head's limits.
async fn converse<I>(io: I, shared: Arc<Shared>, ticket: Arc<Ticket>, streaming: Arc<AtomicBool>)
where
    I: hyper::rt::Read + hyper::rt::Write + Unpin + Send + 'static,
{
    let service = {
        let ticket = ticket.clone();
        service_fn(move |req: Request<Incoming>| {
            let (shared, ticket, streaming) = (shared.clone(), ticket.clone(), streaming.clone());
            async move {
                ticket.busy(true);
                let target = req.uri().path_and_query().map_or("/", |p| p.as_str());
                let reply = route(&shared, req.method(), target).await;
                if matches!(reply.body(), Either::Right(_)) {
                    streaming.store(true, Ordering::Relaxed);
                }
                ticket.busy(false);
                Ok::<_, Infallible>(reply)
            }
        })
    };
    let connection = http1::Builder::new()
        .timer(TokioTimer::new())
        .header_read_timeout(HEAD_TIMEOUT)
        .max_buf_size(MAX_HEAD)
        .max_headers(MAX_HEADERS)
        .serve_connection(io, service);
    if let Err(e) = connection.await {
        tracing::debug!(error = %e, "connection ended");
    }
}

/// What the server sends back to a client that sends `request` and then closes its
/// side: the same limits and routes as a connection over TCP, through memory. For the
/// fuzz target of the viewer's HTTP handling.
#[doc(hidden)]
pub async fn answer(shared: Arc<Shared>, request: &[u8]) -> Vec<u8> {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let (mut client, server) = tokio::io::duplex(64 * 1024);
    let ticket = Arc::new(Connections::new(1).admit());
    let serving = converse(
        TokioIo::new(server),
        shared,
        ticket,
        Arc::new(AtomicBool::new(false)),
    );
    let talking = async move {
        let _ = client.write_all(request).await;
        let _ = client.shutdown().await;
        let mut out = Vec::new();
        let _ = client.read_to_end(&mut out).await;
        out
    };
    tokio::join!(serving, talking).1
}
