//! Whether a living viewer still serves: its `/healthz`, probed from a thread.

use airglyph_viewer::health::{probe, EVERY, FAILURES, TIMEOUT};
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long a viewer just started may take to answer before a failed probe counts: it
/// joins the pipeline and binds its port first (well under a second on an idle
/// machine, longer on a loaded one). A viewer that never binds exits by itself.
const STARTUP_GRACE: Duration = Duration::from_secs(30);

/// The probes' verdict on the viewer process started last.
#[derive(Debug)]
struct Verdict {
    /// Which start of the viewer the probes are about: a probe begun before a restart
    /// says nothing about the new process.
    generation: u64,
    started: Instant,
    served: bool,
    failures: u32,
    last_error: Option<String>,
}

/// Probes a viewer's `/healthz` from a thread of its own, as a browser would. A viewer
/// whose process lives but does not answer (stopped, hung, its server gone) is only
/// noticed this way; the viewer's own watchdog cannot help when the whole process is
/// stopped. A thread, because a probe waits up to [`TIMEOUT`] and the supervisor's
/// loop must go on restarting the other stages meanwhile.
pub struct HealthWatch {
    verdict: Arc<Mutex<Verdict>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl HealthWatch {
    /// Probes `addr` every [`EVERY`] from now on, until dropped.
    pub fn start(addr: SocketAddr) -> std::io::Result<Self> {
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
                                Err(e) if v.served || v.started.elapsed() > STARTUP_GRACE => {
                                    v.failures += 1;
                                    tracing::debug!(error = %e, failures = v.failures, "viewer health check");
                                    v.last_error = Some(e.to_string());
                                }
                                Err(_) => {}
                            }
                        }
                        drop(v);
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

    /// A new viewer process was started: the probes start over for it.
    pub fn restarted(&self) {
        let mut v = lock(&self.verdict);
        v.generation += 1;
        v.started = Instant::now();
        v.served = false;
        v.failures = 0;
        v.last_error = None;
    }

    /// Why the viewer started last has stopped serving: [`FAILURES`] probes in a row
    /// failed (after it had served, or after its grace at start).
    pub fn stopped_serving(&self) -> Option<String> {
        let v = lock(&self.verdict);
        (v.failures >= FAILURES).then(|| v.last_error.clone().unwrap_or_default())
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
    use std::io::{Read, Write};
    use std::net::TcpListener;

    /// Answers every request with `status` until dropped.
    fn server(status: &'static str) -> (SocketAddr, Arc<AtomicBool>) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let serving = Arc::new(AtomicBool::new(true));
        let on = serving.clone();
        std::thread::spawn(move || {
            for mut s in listener.incoming().map_while(Result::ok) {
                if !on.load(Ordering::Relaxed) {
                    // Accepted by the kernel, never answered: a stopped process.
                    std::mem::forget(s);
                    continue;
                }
                let mut buf = [0u8; 1024];
                let _ = s.read(&mut buf);
                let _ = write!(s, "HTTP/1.1 {status}\r\nContent-Length: 2\r\n\r\nok");
            }
        });
        (addr, serving)
    }

    #[test]
    fn a_server_that_stops_answering_is_reported_after_three_failures_in_a_row() {
        let (addr, serving) = server("200 OK");
        let watch = HealthWatch::start(addr).unwrap();
        std::thread::sleep(EVERY / 2);
        assert_eq!(watch.stopped_serving(), None, "it serves");
        serving.store(false, Ordering::Relaxed);
        let t = Instant::now();
        while watch.stopped_serving().is_none() {
            assert!(t.elapsed() < (EVERY + TIMEOUT) * 5, "never reported");
            std::thread::sleep(Duration::from_millis(50));
        }
        assert!(watch.stopped_serving().unwrap().contains("health check"));
        // A new process starts the count over.
        watch.restarted();
        assert_eq!(watch.stopped_serving(), None);
    }
}
