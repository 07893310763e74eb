//! The push stream: `GET /events`, server-sent events (`text/event-stream`) of what the
//! pipeline says, for the page and for scripts (`curl -N`, a browser's `EventSource`).
//!
//! ```text
//! event: gesture      data: {"event":"gesture","label",…}   every gesture, the keys of `run --json`
//! event: skeleton     data: {"event":"skeleton",…}          ?skeletons=HZ (default 0: none)
//! event: stats        data: {"event":"stats","stage",…}     each stage once a second (?stats=0: none)
//! event: state        data: the page's panels               ?state=HZ (the page asks for 4)
//! event: lagged       data: {"missed":N}                    N events this client was too slow for
//! ```
//!
//! The IPC loop hands each message to [`Push`], which formats it once and puts it in a
//! broadcast ring of [`RING`] events; it never waits for a client. Each client has a
//! task that takes from the ring what it asked for, at its rate, and hands it to its
//! connection through a queue of [`QUEUE`] chunks. A client that does not read stalls
//! only its own task: the ring moves on without it, and when it reads again it is told
//! how many events it missed (`lagged`) before it gets the next. Its connection is closed
//! after the server's idle timeout with nothing written. Nothing a client does reaches
//! the pipeline or another client.

use crate::routes::query_value;
use airglyph_ipc::json;
use airglyph_ipc::{GestureEventMsg, SkeletonMsg, Stage, StageStatsMsg};
use hyper::body::{Bytes, Frame};
use serde_json::json;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::sync::{broadcast, mpsc};

/// Events kept for clients that fall behind: 8 s of skeletons at 30 fps with the rest.
pub const RING: usize = 256;
/// Chunks waiting to be written to one client's connection.
const QUEUE: usize = 4;
/// A comment line this often keeps proxies from closing a quiet stream and finds a
/// client that has gone (the write fails).
pub const HEARTBEAT: Duration = Duration::from_secs(5);
/// Most skeletons or states a second a client may ask for.
pub const MAX_RATE: f64 = 60.0;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Gesture,
    Skeleton,
    Stats,
    State,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Gesture => "gesture",
            Kind::Skeleton => "skeleton",
            Kind::Stats => "stats",
            Kind::State => "state",
        }
    }
}

/// One event, formatted once for every client: the whole SSE frame.
#[derive(Debug, Clone)]
struct Event {
    kind: Kind,
    frame: Bytes,
}

fn sse(kind: &str, data: &str) -> Bytes {
    // serde_json never writes a raw newline, so the data is one `data:` line.
    Bytes::from(format!("event: {kind}\ndata: {data}\n\n"))
}

/// The broadcasting side: what the IPC loop hands messages to.
pub struct Push {
    ring: broadcast::Sender<Event>,
    /// Clients that asked for the page's state: it is made only when someone wants it.
    state_clients: AtomicUsize,
    /// Events some client was too slow for, since the start.
    missed: AtomicU64,
}

impl Default for Push {
    fn default() -> Self {
        Self::new()
    }
}

impl Push {
    /// A broadcaster with no client yet.
    pub fn new() -> Self {
        Self {
            ring: broadcast::Sender::new(RING),
            state_clients: AtomicUsize::new(0),
            missed: AtomicU64::new(0),
        }
    }

    /// Clients connected now.
    pub fn clients(&self) -> usize {
        self.ring.receiver_count()
    }

    /// Events clients were too slow for, all together, since the start.
    pub fn missed(&self) -> u64 {
        self.missed.load(Ordering::Relaxed)
    }

    /// Whether some client wants the page's state.
    pub fn wants_state(&self) -> bool {
        self.state_clients.load(Ordering::Relaxed) > 0
    }

    fn send(&self, kind: Kind, data: impl FnOnce() -> String) {
        // Nothing is formatted for nobody.
        if self.ring.receiver_count() > 0 {
            let _ = self.ring.send(Event {
                kind,
                frame: sse(kind.name(), &data()),
            });
        }
    }

    /// Pushes a gesture event to the clients that asked for gestures.
    pub fn gesture(&self, m: &GestureEventMsg) {
        self.send(Kind::Gesture, || json::GestureLine::live(m).line());
    }

    /// Pushes a skeleton to the clients that asked for skeletons (each at its own rate).
    pub fn skeleton(&self, m: &SkeletonMsg) {
        self.send(Kind::Skeleton, || json::skeleton(m).to_string());
    }

    /// Pushes a stage's telemetry to the clients that asked for stats.
    pub fn stats(&self, stage: Stage, m: &StageStatsMsg) {
        self.send(Kind::Stats, || json::stats_event(stage, m).to_string());
    }

    /// The page's panels (`Shared::state`), for clients that asked for them.
    pub fn state(&self, state: &serde_json::Value) {
        self.send(Kind::State, || state.to_string());
    }
}

/// What one client asked for (`/events?skeletons=10&stats=0&state=4`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wants {
    gestures: bool,
    stats: bool,
    /// Most skeletons a second (0: none).
    skeletons: f64,
    /// Most states a second (0: none).
    state: f64,
}

impl Wants {
    /// Parses the query; the reason when a value is not one.
    pub fn parse(query: &str) -> Result<Self, String> {
        let flag = |key: &str, default: bool| match query_value(query, key) {
            None => Ok(default),
            Some("1" | "true") => Ok(true),
            Some("0" | "false") => Ok(false),
            Some(_) => Err(format!("{key} must be 0 or 1")),
        };
        let rate = |key: &str| match query_value(query, key).map(str::parse::<f64>) {
            None => Ok(0.0),
            Some(Ok(r)) if (0.0..=MAX_RATE).contains(&r) => Ok(r),
            _ => Err(format!(
                "{key} must be a rate from 0 to {MAX_RATE} a second"
            )),
        };
        Ok(Self {
            gestures: flag("gestures", true)?,
            stats: flag("stats", true)?,
            skeletons: rate("skeletons")?,
            state: rate("state")?,
        })
    }
}

/// One client's stream: the body of its `/events` answer.
pub struct Stream {
    chunks: mpsc::Receiver<Bytes>,
}

impl hyper::body::Body for Stream {
    type Data = Bytes;
    type Error = std::convert::Infallible;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, Self::Error>>> {
        self.chunks
            .poll_recv(cx)
            .map(|chunk| chunk.map(|c| Ok(Frame::data(c))))
    }
}

/// Counts a client among those that want the page's state while it lives.
struct StateClient<'a>(&'a Push);

impl Drop for StateClient<'_> {
    fn drop(&mut self) {
        self.0.state_clients.fetch_sub(1, Ordering::Relaxed);
    }
}

/// Opens a stream for one client: its task runs on the web runtime until the client goes.
pub fn open(push: &Arc<Push>, wants: Wants) -> Stream {
    let (tx, rx) = mpsc::channel(QUEUE);
    let ring = push.ring.subscribe();
    tokio::spawn(feed(push.clone(), ring, wants, tx));
    Stream { chunks: rx }
}

/// Time between two events of a kind a client asked a rate for (`None`: every one).
fn spacing(rate: f64) -> Option<Duration> {
    (rate > 0.0).then(|| Duration::from_secs_f64(1.0 / rate))
}

/// One client's task: from the ring to its connection, what it asked for, at its rates.
async fn feed(
    push: Arc<Push>,
    mut ring: broadcast::Receiver<Event>,
    wants: Wants,
    tx: mpsc::Sender<Bytes>,
) {
    let _state = (wants.state > 0.0).then(|| {
        push.state_clients.fetch_add(1, Ordering::Relaxed);
        StateClient(&push)
    });
    // The browser reconnects after a second when the stream ends.
    if tx
        .send(Bytes::from_static(b"retry: 1000\n\n"))
        .await
        .is_err()
    {
        return;
    }
    let mut heartbeat = tokio::time::interval(HEARTBEAT);
    heartbeat.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let (skeleton_every, state_every) = (spacing(wants.skeletons), spacing(wants.state));
    let mut last_skeleton: Option<tokio::time::Instant> = None;
    let mut last_state: Option<tokio::time::Instant> = None;
    let due = |last: &mut Option<tokio::time::Instant>, every: Duration| {
        let now = tokio::time::Instant::now();
        if last.is_some_and(|t| now < t + every) {
            return false;
        }
        *last = Some(now);
        true
    };
    loop {
        let chunk = tokio::select! {
            event = ring.recv() => match event {
                Ok(e) => {
                    let wanted = match e.kind {
                        Kind::Gesture => wants.gestures,
                        Kind::Stats => wants.stats,
                        Kind::Skeleton => skeleton_every.is_some_and(|every| due(&mut last_skeleton, every)),
                        Kind::State => state_every.is_some_and(|every| due(&mut last_state, every)),
                    };
                    if !wanted {
                        continue;
                    }
                    e.frame
                }
                Err(broadcast::error::RecvError::Lagged(missed)) => {
                    // Said, never silent: the client learns what it did not get.
                    push.missed.fetch_add(missed, Ordering::Relaxed);
                    sse("lagged", &json!({ "missed": missed }).to_string())
                }
                Err(broadcast::error::RecvError::Closed) => return,
            },
            _ = heartbeat.tick() => Bytes::from_static(b": heartbeat\n\n"),
        };
        // Waits while the client does not read; the ring moves on meanwhile. Fails when
        // the connection is gone.
        if tx.send(chunk).await.is_err() {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hyper::body::Body;

    fn block_on<F: std::future::Future>(f: F) -> F::Output {
        tokio::runtime::Builder::new_current_thread()
            .enable_time()
            .build()
            .unwrap()
            .block_on(f)
    }

    async fn next_text(s: &mut Stream) -> String {
        let frame = std::future::poll_fn(|cx| Pin::new(&mut *s).poll_frame(cx))
            .await
            .unwrap()
            .unwrap();
        String::from_utf8(frame.into_data().unwrap().to_vec()).unwrap()
    }

    fn gesture(label: &str) -> GestureEventMsg {
        let mut g = GestureEventMsg::default();
        g.set_label(label).unwrap();
        g
    }

    #[test]
    fn queries_are_parsed_and_bad_ones_refused() {
        let w = Wants::parse("skeletons=10&stats=0").unwrap();
        assert_eq!(
            (w.gestures, w.stats, w.skeletons, w.state),
            (true, false, 10.0, 0.0)
        );
        assert!(Wants::parse("skeletons=x").is_err());
        assert!(Wants::parse("skeletons=1000").is_err());
        assert!(Wants::parse("skeletons=-1").is_err());
        assert!(Wants::parse("stats=2").is_err());
        assert!(Wants::parse("skeletons=NaN").is_err());
    }

    #[test]
    fn a_client_gets_what_it_asked_for() {
        block_on(async {
            let push = Arc::new(Push::new());
            let mut s = open(&push, Wants::parse("stats=0").unwrap());
            assert!(next_text(&mut s).await.starts_with("retry:"));
            push.skeleton(&SkeletonMsg::default());
            push.stats(Stage::Pose, &StageStatsMsg::default());
            push.gesture(&gesture("7"));
            let text = next_text(&mut s).await;
            assert!(text.starts_with("event: gesture\ndata: {"), "{text}");
            assert!(text.contains("\"label\":\"7\""), "{text}");
            assert!(text.ends_with("\n\n"));
        });
    }

    #[test]
    fn a_client_that_does_not_read_is_told_what_it_missed_and_slows_no_one() {
        block_on(async {
            let push = Arc::new(Push::new());
            let mut slow = open(&push, Wants::parse("").unwrap());
            let mut quick = open(&push, Wants::parse("").unwrap());
            assert!(next_text(&mut slow).await.starts_with("retry:"));
            assert!(next_text(&mut quick).await.starts_with("retry:"));
            let n = RING + 100;
            for i in 0..n {
                // Never waits, whoever reads or not.
                push.gesture(&gesture(&i.to_string()));
                if i % 8 == 0 {
                    tokio::task::yield_now().await;
                }
                // The quick client keeps up.
                if i % 2 == 0 {
                    while let Ok(Some(Ok(_))) = tokio::time::timeout(
                        Duration::from_millis(1),
                        std::future::poll_fn(|cx| Pin::new(&mut quick).poll_frame(cx)),
                    )
                    .await
                    {}
                }
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
            // The slow one reads at last: what fits in its queue, then how many it missed.
            let mut texts = Vec::new();
            for _ in 0..QUEUE + 2 {
                texts.push(next_text(&mut slow).await);
            }
            let lagged = texts
                .iter()
                .find(|t| t.starts_with("event: lagged"))
                .expect("a lagged event");
            assert!(lagged.contains("\"missed\":"), "{lagged}");
            assert!(push.missed() > 0);
        });
    }
}
