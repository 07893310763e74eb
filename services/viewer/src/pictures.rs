//! What the IPC loop and the web side share: the scene, and the pictures drawn from it.
//! Pictures are drawn and encoded one at a time and at most `max_fps` a second for all
//! browsers together, and every browser asking for the same frame gets the same JPEG,
//! so watching costs the pipeline a bounded share of the machine whatever the number
//! of browsers (or of requests a hostile client sends).

use crate::push::Push;
use crate::render::{encode_jpeg, encode_png, render};
use crate::scene::Scene;
use airglyph_ipc::clock::monotonic_ns;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tokio::sync::watch;

/// How long a request for the next picture waits for a new frame before answering 204.
pub const LONG_POLL: Duration = Duration::from_secs(1);

/// How pictures are sent.
#[derive(Debug, Clone, Copy)]
pub struct ServeConfig {
    /// Most pictures encoded per second, for all browsers together.
    pub max_fps: f64,
    /// JPEG quality, 1–100.
    pub quality: u8,
}

#[derive(Clone)]
pub(crate) struct Encoded {
    /// [`Scene::frames_in`] when it was drawn.
    pub id: u64,
    /// When it was drawn.
    pub at: Instant,
    pub jpeg: Arc<Vec<u8>>,
}

struct Encoder {
    next_at: Instant,
    last: Option<Encoded>,
    pictures: u64,
}

/// What the IPC loop and the web side share.
pub struct Shared {
    scene: Mutex<Scene>,
    /// Counts [`Shared::notify`] calls: waiting requests wake on a change without a
    /// thread of their own each.
    fresh: watch::Sender<u64>,
    config: ServeConfig,
    encoder: Mutex<Encoder>,
    push: Arc<Push>,
    /// When the page's state was last pushed.
    state_pushed: Mutex<Option<Instant>>,
}

/// The page's state is pushed at most this often (clients ask for their own rate below).
const STATE_EVERY: Duration = Duration::from_millis(100);

fn relock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A web task that panicked must not take the viewer down with it.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Shared {
    /// Shared state for a server with `config`, its scene empty.
    pub fn new(config: ServeConfig) -> Self {
        Self {
            scene: Mutex::new(Scene::new()),
            fresh: watch::Sender::new(0),
            config,
            encoder: Mutex::new(Encoder {
                next_at: Instant::now(),
                last: None,
                pictures: 0,
            }),
            push: Arc::new(Push::new()),
            state_pushed: Mutex::new(None),
        }
    }

    /// The push stream's broadcaster ([`crate::push`]).
    pub fn push(&self) -> &Arc<Push> {
        &self.push
    }

    /// Pushes the page's state to the clients that want it, at most every
    /// [`STATE_EVERY`]; call it often.
    pub fn push_state(&self) {
        if !self.push.wants_state() {
            return;
        }
        {
            let mut last = relock(&self.state_pushed);
            if last.is_some_and(|t| t.elapsed() < STATE_EVERY) {
                return;
            }
            *last = Some(Instant::now());
        }
        self.push.state(&self.state());
    }

    /// The scene the feed fills and the routes read.
    pub fn scene(&self) -> &Mutex<Scene> {
        &self.scene
    }

    /// Wakes the requests waiting for a new frame.
    pub fn notify(&self) {
        self.fresh.send_modify(|n| *n = n.wrapping_add(1));
    }

    /// Pictures encoded for browsers so far.
    pub fn pictures(&self) -> u64 {
        relock(&self.encoder).pictures
    }

    fn frames_in(&self) -> u64 {
        relock(&self.scene).frames_in()
    }

    /// Waits up to [`LONG_POLL`] for a frame newer than `after` (a
    /// [`Scene::frames_in`] value); false when none came.
    pub(crate) async fn wait_for_frame_after(&self, after: u64) -> bool {
        let deadline = tokio::time::Instant::now() + LONG_POLL;
        let mut changes = self.fresh.subscribe();
        while self.frames_in() <= after {
            match tokio::time::timeout_at(deadline, changes.changed()).await {
                Ok(Ok(())) => {}
                // The deadline, or the sender gone (the viewer is stopping).
                _ => return false,
            }
        }
        true
    }

    /// Waits until the encoder may draw the next picture.
    fn pace(&self, enc: &Encoder) {
        let now = Instant::now();
        if enc.next_at > now {
            std::thread::sleep(enc.next_at - now);
        }
    }

    /// A picture newer than `after` as JPEG: the one already encoded when it is of the
    /// newest frame, or newer than `after` and made less than [`LONG_POLL`] ago; else
    /// the newest frame's, drawn now, paced. Only a browser that already has the last
    /// picture waits for the next, and all such share its encoding: a crowd of
    /// requests costs no more encodings than one browser (under a siege of 200 at once
    /// on a loaded machine, each queueing for an encoding of its own took up to 10 s).
    /// Blocks (a blocking thread's work).
    pub(crate) fn newest_jpeg(&self, after: u64) -> Result<Option<Encoded>, String> {
        let mut enc = relock(&self.encoder);
        let newest = self.frames_in();
        if let Some(last) = enc
            .last
            .as_ref()
            .filter(|l| l.id == newest || (l.id > after && l.at.elapsed() < LONG_POLL))
        {
            return Ok(Some(last.clone()));
        }
        self.pace(&enc);
        let started = Instant::now();
        let (id, picture) = {
            let scene = relock(&self.scene);
            (scene.frames_in(), scene.picture(monotonic_ns()))
        };
        let Some(p) = picture else { return Ok(None) };
        let img = render(p.frame.view(), &p.intrinsics, &p.overlay);
        let jpeg = Arc::new(encode_jpeg(&img, self.config.quality).map_err(|e| e.to_string())?);
        enc.next_at = started + Duration::from_secs_f64(1.0 / self.config.max_fps);
        enc.pictures += 1;
        let encoded = Encoded {
            id,
            at: Instant::now(),
            jpeg,
        };
        enc.last = Some(encoded.clone());
        Ok(Some(encoded))
    }

    /// A lossless picture, paced with the JPEGs: asking for PNGs in a loop must not
    /// take more of the machine than watching does. Blocks.
    pub(crate) fn snapshot_png(&self) -> Result<Option<Vec<u8>>, String> {
        let mut enc = relock(&self.encoder);
        self.pace(&enc);
        let started = Instant::now();
        let picture = relock(&self.scene).picture(monotonic_ns());
        let Some(p) = picture else { return Ok(None) };
        let img = render(p.frame.view(), &p.intrinsics, &p.overlay);
        let png = encode_png(&img).map_err(|e| e.to_string())?;
        enc.next_at = started + Duration::from_secs_f64(1.0 / self.config.max_fps);
        Ok(Some(png))
    }

    pub(crate) fn state(&self) -> serde_json::Value {
        let mut state = relock(&self.scene).state(monotonic_ns());
        state["viewer"]["pictures"] = self.pictures().into();
        state["viewer"]["max_fps"] = self.config.max_fps.into();
        state
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use airglyph_core::Intrinsics;
    use airglyph_ipc::DepthHeader;

    pub(crate) fn push_frame(shared: &Shared, seq: u64) {
        let mut h = DepthHeader {
            sequence: seq,
            session: 1,
            capture_ns: 1 + seq,
            publish_ns: 2 + seq,
            ..Default::default()
        };
        h.set_intrinsics(&Intrinsics::default().scaled_to(64, 48));
        relock(&shared.scene).push_depth(h, &vec![1500; 64 * 48], 0);
        shared.notify();
    }

    pub(crate) fn shared_with_frames(n: u64, max_fps: f64) -> Shared {
        let shared = Shared::new(ServeConfig {
            max_fps,
            quality: 80,
        });
        for seq in 0..n {
            push_frame(&shared, seq);
        }
        shared
    }

    fn block_on<F: std::future::Future>(f: F) -> F::Output {
        tokio::runtime::Builder::new_current_thread()
            .enable_time()
            .build()
            .unwrap()
            .block_on(f)
    }

    #[test]
    fn the_next_picture_waits_for_a_newer_frame_and_is_a_jpeg() {
        let shared = shared_with_frames(3, 1000.0);
        assert!(block_on(shared.wait_for_frame_after(0)));
        let e = shared.newest_jpeg(0).unwrap().unwrap();
        assert_eq!(e.id, 3);
        assert_eq!(
            &e.jpeg[..2],
            &[0xFF, 0xD8],
            "a JPEG's start-of-image marker"
        );
        let t = Instant::now();
        assert!(!block_on(shared.wait_for_frame_after(3)), "nothing newer");
        assert!(t.elapsed() >= LONG_POLL);
        // The same frame again is the same picture, not a second encoding.
        assert_eq!(shared.newest_jpeg(0).unwrap().unwrap().id, 3);
        assert_eq!(shared.pictures(), 1);
    }

    #[test]
    fn a_frame_arriving_wakes_the_waiting_request() {
        let shared = Arc::new(shared_with_frames(1, 1000.0));
        let pusher = shared.clone();
        let t = Instant::now();
        let woke = block_on(async move {
            let push = tokio::spawn(async move {
                tokio::time::sleep(Duration::from_millis(100)).await;
                push_frame(&pusher, 1);
            });
            let woke = shared.wait_for_frame_after(1).await;
            push.await.unwrap();
            woke
        });
        assert!(woke && t.elapsed() < LONG_POLL, "{:?}", t.elapsed());
    }

    #[test]
    fn requests_between_two_pictures_share_the_last_one() {
        let shared = shared_with_frames(1, 1.0);
        assert_eq!(shared.newest_jpeg(0).unwrap().unwrap().id, 1);
        push_frame(&shared, 1);
        let t = Instant::now();
        // A newer frame came, but the last picture is recent: a browser without a
        // picture gets it at once, without waiting for the next to be due.
        assert_eq!(shared.newest_jpeg(0).unwrap().unwrap().id, 1);
        assert!(
            t.elapsed() < Duration::from_millis(500),
            "{:?}",
            t.elapsed()
        );
        assert_eq!(shared.pictures(), 1);
    }

    #[test]
    fn pictures_are_paced_to_max_fps() {
        let shared = shared_with_frames(1, 10.0);
        let t = Instant::now();
        for i in 0..4u64 {
            push_frame(&shared, 10 + i);
            // What the browser has: the frame before this one.
            assert_eq!(shared.newest_jpeg(i + 1).unwrap().unwrap().id, i + 2);
        }
        // Four pictures at 10 a second: the last three each waited 100 ms.
        assert!(
            t.elapsed() >= Duration::from_millis(300),
            "{:?}",
            t.elapsed()
        );
    }
}
