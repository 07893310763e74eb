//! Is the viewer serving? A process that lives on with a server that stopped answering
//! (as tiny_http's did once its accept thread ran out of file descriptors) looks
//! healthy to a supervisor that only watches processes. [`probe`] asks the way a
//! browser would, for a supervisor; [`Watchdog`] asks the viewer's own server the same
//! from inside, so a viewer whose server stopped ends with an error (and is restarted
//! by `airglyph run` or systemd alike).

use crate::routes::HEALTH_PATH;
use std::io::{Read, Write};
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Why the viewer is not healthy.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the viewer at {addr} does not answer its health check: {reason}")]
pub struct HealthError {
    /// The address asked.
    pub addr: SocketAddr,
    /// What went wrong.
    pub reason: String,
}

/// Where to reach a server listening on `addr`: the loopback when it listens on every
/// address (0.0.0.0 or ::).
pub fn reachable(addr: SocketAddr) -> SocketAddr {
    let ip = match addr.ip() {
        IpAddr::V4(ip) if ip.is_unspecified() => IpAddr::V4(Ipv4Addr::LOCALHOST),
        IpAddr::V6(ip) if ip.is_unspecified() => IpAddr::V6(Ipv6Addr::LOCALHOST),
        ip => ip,
    };
    SocketAddr::new(ip, addr.port())
}

/// Asks the viewer listening on `addr` for [`HEALTH_PATH`] and waits at most `timeout`
/// for "200". For a supervisor: a viewer that fails it a few times in a row while its
/// process lives has stopped serving and should be restarted.
pub fn probe(addr: SocketAddr, timeout: Duration) -> Result<(), HealthError> {
    let addr = reachable(addr);
    let fail = |reason: String| HealthError { addr, reason };
    let deadline = Instant::now() + timeout;
    let left = || {
        deadline
            .saturating_duration_since(Instant::now())
            .max(Duration::from_millis(1))
    };
    let mut stream = TcpStream::connect_timeout(&addr, left())
        .map_err(|e| fail(format!("cannot connect: {e}")))?;
    let request =
        format!("GET {HEALTH_PATH} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
    stream
        .set_write_timeout(Some(left()))
        .and_then(|()| stream.write_all(request.as_bytes()))
        .map_err(|e| fail(format!("cannot send the request: {e}")))?;
    // The status line is all we need: "HTTP/1.1 200 OK".
    let mut head = [0u8; 12];
    let mut got = 0;
    while got < head.len() {
        stream
            .set_read_timeout(Some(left()))
            .map_err(|e| fail(e.to_string()))?;
        match stream.read(&mut head[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) => return Err(fail(format!("no answer within {timeout:?}: {e}"))),
        }
    }
    let status = String::from_utf8_lossy(&head[..got]);
    if status.starts_with("HTTP/1.1 200") || status.starts_with("HTTP/1.0 200") {
        Ok(())
    } else {
        Err(fail(format!("answered {status:?}")))
    }
}

/// How often the watchdog (and `airglyph run`, from outside) asks, how long it waits,
/// and how many failures in a row mean the server stopped (one slow answer on a loaded
/// machine is not that).
pub const EVERY: Duration = Duration::from_secs(2);
/// How long one probe waits for an answer.
pub const TIMEOUT: Duration = Duration::from_secs(2);
/// Probes failed in a row after which the viewer has stopped serving.
pub const FAILURES: u32 = 3;

/// Probes the viewer's own server from a thread of its own.
pub(crate) struct Watchdog {
    verdict: Arc<Mutex<Option<HealthError>>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Watchdog {
    pub fn start(addr: SocketAddr) -> std::io::Result<Self> {
        let verdict = Arc::new(Mutex::new(None));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (verdict, stop) = (verdict.clone(), stop.clone());
            std::thread::Builder::new()
                .name("web-watchdog".into())
                .spawn(move || {
                    let mut failures = 0;
                    while !stop.load(Ordering::Relaxed) {
                        let started = Instant::now();
                        match probe(addr, TIMEOUT) {
                            Ok(()) => failures = 0,
                            Err(e) => {
                                failures += 1;
                                tracing::warn!(error = %e, failures, "viewer health check");
                                if failures >= FAILURES {
                                    *verdict.lock().unwrap_or_else(|e| e.into_inner()) = Some(e);
                                    return;
                                }
                            }
                        }
                        // Sleeps in short steps so that stopping is quick.
                        while started.elapsed() < EVERY && !stop.load(Ordering::Relaxed) {
                            std::thread::sleep(Duration::from_millis(50));
                        }
                    }
                })?
        };
        Ok(Self {
            verdict,
            stop,
            thread: Some(thread),
        })
    }

    /// The failure that ended the watch, if one did.
    pub fn verdict(&self) -> Option<HealthError> {
        self.verdict
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::TcpListener;

    #[test]
    fn a_server_that_does_not_answer_fails_the_probe_within_its_timeout() {
        // Accepts (the kernel's backlog does) but never answers.
        let silent = TcpListener::bind("127.0.0.1:0").unwrap();
        let t = Instant::now();
        let err = probe(silent.local_addr().unwrap(), Duration::from_millis(300)).unwrap_err();
        assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
        assert!(err.to_string().contains("health check"), "{err}");
        let closed = silent.local_addr().unwrap();
        drop(silent);
        assert!(probe(closed, Duration::from_millis(300)).is_err());
    }

    #[test]
    fn every_address_is_probed_on_the_loopback() {
        let any: SocketAddr = "0.0.0.0:8080".parse().unwrap();
        assert_eq!(reachable(any), "127.0.0.1:8080".parse().unwrap());
        let one: SocketAddr = "10.1.2.3:80".parse().unwrap();
        assert_eq!(reachable(one), one);
    }
}
