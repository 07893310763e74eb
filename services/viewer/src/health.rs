//! Is the viewer serving? A process that lives on with a server that stopped answering
//! (as tiny_http's did once its accept thread ran out of file descriptors) looks
//! healthy to a supervisor that only watches processes. [`probe`] asks the way a
//! browser would; [`HealthWatch`] asks every few seconds, the viewer's own server from
//! inside (so a viewer whose server stopped ends with an error, and is restarted by
//! `airglyph run` or systemd alike) and a viewer process from `airglyph run`.

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

/// The probes' verdict on the viewer process started last.
#[derive(Debug)]
struct Verdict {
    /// Which start of the viewer the probes are about: a probe begun before a restart
    /// says nothing about the new process.
    generation: u64,
    started: Instant,
    served: bool,
    failures: u32,
    last_error: Option<HealthError>,
}

/// Probes a viewer's [`HEALTH_PATH`] every [`EVERY`] from a thread of its own, as a
/// browser would: the viewer's own server from inside (a viewer whose server stopped
/// ends with an error), or a viewer process from its supervisor (a process that is
/// stopped or hung whole can only be noticed from outside). A thread, because a probe
/// waits up to [`TIMEOUT`] and its owner's loop must go on meanwhile.
pub struct HealthWatch {
    verdict: Arc<Mutex<Verdict>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl HealthWatch {
    /// Probes `addr` from now on, until dropped. Failures count once the viewer has
    /// answered, or once `grace` has passed: a viewer just started joins the pipeline
    /// and binds its port first.
    pub fn start(addr: SocketAddr, grace: Duration) -> std::io::Result<Self> {
        let verdict = Arc::new(Mutex::new(Verdict {
            generation: 0,
            started: Instant::now(),
            served: false,
            failures: 0,
            last_error: None,
        }));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (verdict, stop) = (verdict.clone(), stop.clone());
            std::thread::Builder::new()
                .name("viewer-health".into())
                .spawn(move || {
                    while !stop.load(Ordering::Relaxed) {
                        let asked = Instant::now();
                        let generation = lock(&verdict).generation;
                        let result = probe(addr, TIMEOUT);
                        let mut v = lock(&verdict);
                        if v.generation == generation {
                            match result {
                                Ok(()) => {
                                    v.served = true;
                                    v.failures = 0;
                                }
                                Err(e) if v.served || v.started.elapsed() >= grace => {
                                    v.failures += 1;
                                    tracing::warn!(error = %e, failures = v.failures, "viewer health check");
                                    v.last_error = Some(e);
                                }
                                Err(_) => {}
                            }
                        }
                        drop(v);
                        // Sleeps in short steps so that stopping is quick.
                        while asked.elapsed() < EVERY && !stop.load(Ordering::Relaxed) {
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

    /// A new viewer process was started at the same address: the probes start over.
    pub fn restarted(&self) {
        let mut v = lock(&self.verdict);
        v.generation += 1;
        v.started = Instant::now();
        v.served = false;
        v.failures = 0;
        v.last_error = None;
    }

    /// Why the viewer started last has stopped serving: [`FAILURES`] probes in a row
    /// failed.
    pub fn stopped_serving(&self) -> Option<HealthError> {
        let v = lock(&self.verdict);
        (v.failures >= FAILURES)
            .then(|| v.last_error.clone())
            .flatten()
    }
}

impl Drop for HealthWatch {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn lock(v: &Mutex<Verdict>) -> std::sync::MutexGuard<'_, Verdict> {
    v.lock().unwrap_or_else(|e| e.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::TcpListener;

    /// Answers every request with "200 OK" while `serving`, then accepts and never
    /// answers (a stopped process).
    fn server() -> (SocketAddr, Arc<AtomicBool>) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let serving = Arc::new(AtomicBool::new(true));
        let on = serving.clone();
        std::thread::spawn(move || {
            for mut s in listener.incoming().map_while(Result::ok) {
                if !on.load(Ordering::Relaxed) {
                    std::mem::forget(s);
                    continue;
                }
                let mut buf = [0u8; 1024];
                let _ = s.read(&mut buf);
                let _ = write!(s, "HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nok");
            }
        });
        (addr, serving)
    }

    #[test]
    fn a_server_that_stops_answering_is_reported_after_three_failures_in_a_row() {
        let (addr, serving) = server();
        let watch = HealthWatch::start(addr, Duration::ZERO).unwrap();
        std::thread::sleep(EVERY / 2);
        assert_eq!(watch.stopped_serving(), None, "it serves");
        serving.store(false, Ordering::Relaxed);
        let t = Instant::now();
        while watch.stopped_serving().is_none() {
            assert!(t.elapsed() < (EVERY + TIMEOUT) * 5, "never reported");
            std::thread::sleep(Duration::from_millis(50));
        }
        let e = watch.stopped_serving().unwrap();
        assert_eq!(e.addr, addr);
        assert!(e.to_string().contains("health check"), "{e}");
        // A new process starts the count over.
        watch.restarted();
        assert_eq!(watch.stopped_serving(), None);
    }

    #[test]
    fn a_viewer_still_starting_is_given_its_grace() {
        // Nothing listens: every probe fails at once, but within the grace none counts.
        let closed = TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap();
        let watch = HealthWatch::start(closed, Duration::from_secs(600)).unwrap();
        std::thread::sleep(EVERY * 2 + EVERY / 2);
        assert_eq!(watch.stopped_serving(), None);
    }

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
