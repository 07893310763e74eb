//! The web side: one self-contained page, the picture as JPEG (long-polled, so a slow
//! browser simply gets fewer frames), a PNG snapshot, and the panels' state as JSON.
//! A small pool of threads of tiny_http serves them; pictures are drawn and encoded on
//! those threads, one at a time and at most `max_fps` a second for all browsers together,
//! so watching costs the pipeline a bounded share of the machine.

use crate::render::{encode_jpeg, encode_png, render};
use crate::scene::Scene;
use airglyph_ipc::clock::monotonic_ns;
use std::io::Cursor;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use tiny_http::{Header, Method, Request, Response};

const PAGE: &str = include_str!("page.html");
/// How long a request for the next picture waits for a new frame before answering 204.
const LONG_POLL: Duration = Duration::from_secs(1);
/// Worker threads: each browser holds at most two requests (picture and state) at once.
const THREADS: usize = 6;

/// How pictures are sent.
#[derive(Debug, Clone, Copy)]
pub struct ServeConfig {
    /// Most pictures encoded per second, for all browsers together.
    pub max_fps: f64,
    /// JPEG quality, 1–100.
    pub quality: u8,
}

#[derive(Clone)]
struct Encoded {
    /// [`Scene::frames_in`] when it was drawn.
    id: u64,
    jpeg: Arc<Vec<u8>>,
}

struct Encoder {
    next_at: Instant,
    last: Option<Encoded>,
    pictures: u64,
}

/// What the IPC loop and the web threads share.
pub struct Shared {
    scene: Mutex<Scene>,
    fresh: Condvar,
    config: ServeConfig,
    encoder: Mutex<Encoder>,
}

fn relock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A web thread that panicked must not take the viewer down with it.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Shared {
    pub fn new(config: ServeConfig) -> Self {
        Self {
            scene: Mutex::new(Scene::new()),
            fresh: Condvar::new(),
            config,
            encoder: Mutex::new(Encoder {
                next_at: Instant::now(),
                last: None,
                pictures: 0,
            }),
        }
    }

    pub fn scene(&self) -> &Mutex<Scene> {
        &self.scene
    }

    /// Wakes the requests waiting for a new frame.
    pub fn notify(&self) {
        self.fresh.notify_all();
    }

    /// Pictures encoded for browsers so far.
    pub fn pictures(&self) -> u64 {
        relock(&self.encoder).pictures
    }

    /// The next picture newer than `after` (a [`Scene::frames_in`] value), waiting up to
    /// [`LONG_POLL`] for one; `None` when none came.
    fn next_jpeg(&self, after: u64) -> Result<Option<Encoded>, String> {
        let deadline = Instant::now() + LONG_POLL;
        let mut scene = relock(&self.scene);
        while scene.frames_in() <= after {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            scene = self
                .fresh
                .wait_timeout(scene, left)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
        drop(scene);
        // One encode at a time, paced: other browsers wait here and then share it.
        let mut enc = relock(&self.encoder);
        let now = Instant::now();
        if enc.next_at > now {
            std::thread::sleep(enc.next_at - now);
        }
        let started = Instant::now();
        let (id, picture) = {
            let scene = relock(&self.scene);
            (scene.frames_in(), scene.picture(monotonic_ns()))
        };
        if let Some(last) = enc.last.as_ref().filter(|l| l.id == id) {
            return Ok(Some(last.clone()));
        }
        let Some(p) = picture else { return Ok(None) };
        let img = render(p.frame.view(), &p.intrinsics, &p.overlay);
        let jpeg = Arc::new(encode_jpeg(&img, self.config.quality).map_err(|e| e.to_string())?);
        enc.next_at = started + Duration::from_secs_f64(1.0 / self.config.max_fps);
        enc.pictures += 1;
        let encoded = Encoded { id, jpeg };
        enc.last = Some(encoded.clone());
        Ok(Some(encoded))
    }

    /// A lossless picture, paced with the JPEGs: asking for PNGs in a loop must not
    /// take more of the machine than watching does.
    fn snapshot_png(&self) -> Result<Option<Vec<u8>>, String> {
        let mut enc = relock(&self.encoder);
        let now = Instant::now();
        if enc.next_at > now {
            std::thread::sleep(enc.next_at - now);
        }
        let started = Instant::now();
        let picture = relock(&self.scene).picture(monotonic_ns());
        let Some(p) = picture else { return Ok(None) };
        let img = render(p.frame.view(), &p.intrinsics, &p.overlay);
        let png = encode_png(&img).map_err(|e| e.to_string())?;
        enc.next_at = started + Duration::from_secs_f64(1.0 / self.config.max_fps);
        Ok(Some(png))
    }

    fn state(&self) -> serde_json::Value {
        let mut state = relock(&self.scene).state(monotonic_ns());
        state["viewer"]["pictures"] = self.pictures().into();
        state["viewer"]["max_fps"] = self.config.max_fps.into();
        state
    }
}

/// The HTTP server and its threads.
pub struct Server {
    http: Arc<tiny_http::Server>,
    threads: Vec<JoinHandle<()>>,
    stop: Arc<AtomicBool>,
    addr: SocketAddr,
}

#[derive(Debug, thiserror::Error)]
#[error("cannot serve the viewer on {addr}: {reason}")]
pub struct ServeError {
    addr: SocketAddr,
    reason: String,
}

impl Server {
    /// Listens on `addr` (port 0 picks a free one) and serves from `shared`.
    pub fn start(addr: SocketAddr, shared: Arc<Shared>) -> Result<Self, ServeError> {
        let http = tiny_http::Server::http(addr).map_err(|e| ServeError {
            addr,
            reason: e.to_string(),
        })?;
        let bound = http.server_addr().to_ip().unwrap_or(addr);
        let http = Arc::new(http);
        let stop = Arc::new(AtomicBool::new(false));
        let threads = (0..THREADS)
            .map(|i| {
                let (http, shared, stop) = (http.clone(), shared.clone(), stop.clone());
                std::thread::Builder::new()
                    .name(format!("web-{i}"))
                    .spawn(move || {
                        while !stop.load(Ordering::Relaxed) {
                            match http.recv_timeout(Duration::from_millis(200)) {
                                Ok(Some(req)) => handle(&shared, req),
                                Ok(None) => {}
                                Err(e) => {
                                    tracing::warn!(error = %e, "web server");
                                    std::thread::sleep(Duration::from_millis(100));
                                }
                            }
                        }
                    })
                    .map_err(|e| ServeError {
                        addr,
                        reason: format!("cannot start a web thread: {e}"),
                    })
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            http,
            threads,
            stop,
            addr: bound,
        })
    }

    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    pub fn stop(self) {
        self.stop.store(true, Ordering::Relaxed);
        self.http.unblock();
        for t in self.threads {
            let _ = t.join();
        }
    }
}

type Reply = Response<Cursor<Vec<u8>>>;

fn header(name: &str, value: &str) -> Header {
    Header::from_bytes(name.as_bytes(), value.as_bytes()).expect("ASCII header")
}

fn reply(status: u16, content_type: &str, body: Vec<u8>) -> Reply {
    Response::from_data(body)
        .with_status_code(status)
        .with_header(header("Content-Type", content_type))
        // Every answer is live: nothing may be served from a cache.
        .with_header(header("Cache-Control", "no-store"))
}

fn text(status: u16, body: &str) -> Reply {
    reply(
        status,
        "text/plain; charset=utf-8",
        body.as_bytes().to_vec(),
    )
}

/// The value of `key` in a query string `a=1&b=2`.
fn query_value<'a>(query: &'a str, key: &str) -> Option<&'a str> {
    query
        .split('&')
        .filter_map(|kv| kv.split_once('='))
        .find(|(k, _)| *k == key)
        .map(|(_, v)| v)
}

/// Answers one request (a browser that went away meanwhile is no error of ours).
fn handle(shared: &Shared, req: Request) {
    let resp = route(shared, req.method(), req.url());
    if let Err(e) = req.respond(resp) {
        tracing::debug!(error = %e, "browser went away");
    }
}

fn route(shared: &Shared, method: &Method, url: &str) -> Reply {
    if *method != Method::Get && *method != Method::Head {
        return text(405, "only GET");
    }
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    match path {
        "/" | "/index.html" => reply(200, "text/html; charset=utf-8", PAGE.as_bytes().to_vec()),
        "/state.json" => reply(
            200,
            "application/json",
            shared.state().to_string().into_bytes(),
        ),
        "/frame.jpg" => {
            let after = match query_value(query, "after").map(str::parse::<u64>) {
                None => 0,
                Some(Ok(n)) => n,
                Some(Err(_)) => return text(400, "after must be a picture number"),
            };
            match shared.next_jpeg(after) {
                Ok(Some(e)) => reply(200, "image/jpeg", e.jpeg.to_vec())
                    .with_header(header("X-Picture", &e.id.to_string())),
                Ok(None) => text(204, ""),
                Err(e) => text(500, &format!("cannot encode the picture: {e}")),
            }
        }
        "/snapshot.png" => match shared.snapshot_png() {
            Ok(Some(png)) => reply(200, "image/png", png),
            Ok(None) => text(503, "no depth frame yet: is capture running?"),
            Err(e) => text(500, &format!("cannot encode the picture: {e}")),
        },
        _ => text(404, "not found"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use airglyph_core::Intrinsics;
    use airglyph_ipc::DepthHeader;

    fn shared_with_frames(n: u64) -> Shared {
        let shared = Shared::new(ServeConfig {
            max_fps: 1000.0,
            quality: 80,
        });
        let k = Intrinsics::default().scaled_to(64, 48);
        for seq in 0..n {
            let mut h = DepthHeader {
                sequence: seq,
                session: 1,
                capture_ns: 1 + seq,
                publish_ns: 2 + seq,
                ..Default::default()
            };
            h.set_intrinsics(&k);
            relock(&shared.scene).push_depth(h, &vec![1500; 64 * 48], 0);
        }
        shared
    }

    fn status(r: &Reply) -> u16 {
        r.status_code().0
    }

    #[test]
    fn routes_answer_and_bad_input_is_refused_not_a_panic() {
        let shared = shared_with_frames(3);
        let get = |url: &str| route(&shared, &Method::Get, url);
        assert_eq!(status(&get("/")), 200);
        assert_eq!(status(&get("/state.json")), 200);
        assert_eq!(status(&get("/nope")), 404);
        assert_eq!(status(&get("/frame.jpg?after=x")), 400);
        assert_eq!(status(&route(&shared, &Method::Post, "/")), 405);
        let r = get("/frame.jpg?after=0");
        assert_eq!(status(&r), 200);
        assert_eq!(status(&get("/snapshot.png")), 200);
        let empty = shared_with_frames(0);
        assert_eq!(status(&route(&empty, &Method::Get, "/snapshot.png")), 503);
    }

    #[test]
    fn the_next_picture_waits_for_a_newer_frame_and_is_a_jpeg() {
        let shared = shared_with_frames(3);
        let e = shared.next_jpeg(0).unwrap().unwrap();
        assert_eq!(e.id, 3);
        assert_eq!(
            &e.jpeg[..2],
            &[0xFF, 0xD8],
            "a JPEG's start-of-image marker"
        );
        let t = Instant::now();
        assert!(shared.next_jpeg(3).unwrap().is_none(), "nothing newer");
        assert!(t.elapsed() >= LONG_POLL);
        assert_eq!(shared.pictures(), 1);
    }

    #[test]
    fn pictures_are_paced_to_max_fps() {
        let shared = Shared {
            config: ServeConfig {
                max_fps: 10.0,
                quality: 50,
            },
            ..shared_with_frames(1)
        };
        let t = Instant::now();
        for i in 0..4u64 {
            let mut h = DepthHeader {
                sequence: 10 + i,
                session: 1,
                capture_ns: 100 + i,
                publish_ns: 200 + i,
                ..Default::default()
            };
            h.set_intrinsics(&Intrinsics::default().scaled_to(64, 48));
            relock(&shared.scene).push_depth(h, &vec![1500; 64 * 48], 0);
            let after = relock(&shared.scene).frames_in() - 1;
            assert!(shared.next_jpeg(after).unwrap().is_some());
        }
        // Four pictures at 10 a second: the last three each waited 100 ms.
        assert!(
            t.elapsed() >= Duration::from_millis(300),
            "{:?}",
            t.elapsed()
        );
    }
}
