//! The services of a pipeline and typed ports on them. Every service setting lives here.

use crate::clock::monotonic_ns;
use crate::stats::SequenceTracker;
use crate::wire::{
    DecisionMsg, DepthHeader, GestureEventMsg, HeaderError, MessageError, SkeletonMsg,
    StageStatsMsg,
};
use crate::{IpcConfig, IpcError};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher as IoxPublisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;
use iceoryx2::service::port_factory::{event, publish_subscribe};
use std::fmt::Debug;
use std::time::Duration;

type Ipc = ipc::Service;

/// A process of the pipeline; names its node and its stats service.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Stage {
    Capture = 1,
    Pose = 2,
    Gesture = 3,
    Viewer = 4,
}

impl Stage {
    /// The stages `airglyph run` starts, in pipeline order.
    pub const PIPELINE: [Stage; 3] = [Stage::Capture, Stage::Pose, Stage::Gesture];
    /// Every stage: the pipeline's, then the viewer (`airglyph run --view`).
    pub const ALL: [Stage; 4] = [Stage::Capture, Stage::Pose, Stage::Gesture, Stage::Viewer];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Capture => "capture",
            Stage::Pose => "pose",
            Stage::Gesture => "gesture",
            Stage::Viewer => "viewer",
        }
    }

    pub fn from_name(name: &str) -> Option<Stage> {
        Stage::ALL.into_iter().find(|s| s.name() == name)
    }

    pub fn from_u32(v: u32) -> Option<Stage> {
        Stage::ALL.into_iter().find(|s| *s as u32 == v)
    }
}

/// The settings of one publish-subscribe service.
struct Settings {
    name: &'static str,
    /// Samples a subscriber holds before the oldest is overwritten (safe overflow):
    /// a slow stage drops frames instead of slowing the one before it.
    buffer: usize,
    max_publishers: usize,
    max_subscribers: usize,
}

const DEPTH: Settings = Settings {
    name: "airglyph/depth",
    buffer: 2,
    max_publishers: 2,
    max_subscribers: 8,
};
const SKELETON: Settings = Settings {
    name: "airglyph/skeleton",
    buffer: 4,
    max_publishers: 2,
    max_subscribers: 8,
};
const GESTURE: Settings = Settings {
    name: "airglyph/gesture",
    buffer: 16,
    max_publishers: 2,
    max_subscribers: 8,
};
const DECISION: Settings = Settings {
    name: "airglyph/decision",
    buffer: 8,
    max_publishers: 2,
    max_subscribers: 8,
};
const STATS: Settings = Settings {
    name: "airglyph/stats",
    buffer: 4,
    max_publishers: 2,
    max_subscribers: 8,
};

/// How many frames one depth publisher may hold loaned at once.
const DEPTH_MAX_LOANED: usize = 2;

fn service_name(name: &str) -> Result<ServiceName, IpcError> {
    ServiceName::new(name).map_err(|e| IpcError::service(name, e))
}

/// One process's membership of a pipeline: its iceoryx2 node.
pub struct Pipeline {
    /// Always `Some` until drop, which must release the node before looking for others.
    node: Option<Node<Ipc>>,
    config: IpcConfig,
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        drop(self.node.take());
        let Ok(iox) = self.config.iceoryx2() else {
            return;
        };
        let mut alive = 0;
        let listed = Node::<Ipc>::list(&iox, |state| {
            match state {
                NodeState::Alive(_) => alive += 1,
                NodeState::Dead(dead) => {
                    let _ = dead.try_remove_stale_resources();
                }
                NodeState::Inaccessible(_) | NodeState::Undefined(_) => alive += 1,
            }
            CallbackProgression::Continue
        });
        // iceoryx2 keeps a 4-byte node counter per domain in /dev/shm for ever; the last
        // process of a pipeline removes it so a stopped pipeline leaves nothing behind.
        if listed.is_ok() && alive == 0 {
            // SAFETY: no node of this domain is alive (just listed); a process that starts
            // right now recreates the counter, which only seeds its node id.
            let _ = unsafe { iceoryx2::testing::remove_global_mgmt_segment::<Ipc>(&iox) };
        }
    }
}

impl Pipeline {
    /// Joins the pipeline the environment names (see [`IpcConfig::from_env`]) as `node_name`.
    pub fn join(node_name: &str) -> Result<Self, IpcError> {
        Self::join_with(IpcConfig::from_env()?, node_name)
    }

    /// Joins a pipeline and removes what dead processes left in it, so a stage that was
    /// killed can be started again at once.
    pub fn join_with(config: IpcConfig, node_name: &str) -> Result<Self, IpcError> {
        let iox = config.iceoryx2()?;
        let name = NodeName::new(node_name).map_err(|e| IpcError::Node {
            node: node_name.into(),
            reason: format!("{e:?}"),
        })?;
        let node = NodeBuilder::new()
            .name(&name)
            .config(&iox)
            // Stages handle SIGINT/SIGTERM themselves (see `crate::shutdown`).
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<Ipc>()
            .map_err(|e| IpcError::Node {
                node: node_name.into(),
                reason: format!("{e:?}"),
            })?;
        let pipeline = Self {
            node: Some(node),
            config,
        };
        let cleaned = pipeline.cleanup_dead_nodes();
        if cleaned > 0 {
            tracing::info!(
                cleaned,
                "removed the shared memory of dead airglyph processes"
            );
        }
        Ok(pipeline)
    }

    fn node(&self) -> &Node<Ipc> {
        self.node.as_ref().expect("the node lives until drop")
    }

    pub fn config(&self) -> &IpcConfig {
        &self.config
    }

    /// Removes the stale resources of every dead node of this pipeline; returns how many.
    pub fn cleanup_dead_nodes(&self) -> usize {
        let state = self.node().try_cleanup_dead_nodes();
        state.cleanups as usize
    }

    fn pubsub<P: Debug + IceoryxSend + ?Sized, H: Debug + ZeroCopySend>(
        &self,
        s: &Settings,
        name: &str,
    ) -> Result<iceoryx2::service::builder::publish_subscribe::Builder<P, H, Ipc>, IpcError> {
        Ok(self
            .node()
            .service_builder(&service_name(name)?)
            .publish_subscribe::<P>()
            .user_header::<H>()
            .enable_safe_overflow(true)
            .subscriber_max_buffer_size(s.buffer)
            .history_size(0)
            .max_publishers(s.max_publishers)
            .max_subscribers(s.max_subscribers))
    }

    fn event(&self, name: &str) -> Result<event::PortFactory<Ipc>, IpcError> {
        self.node()
            .service_builder(&service_name(name)?)
            .event()
            .open_or_create()
            .map_err(|e| IpcError::service(name, e))
    }

    /// The capture side of `airglyph/depth`, for frames of up to `max_pixels` pixels
    /// (larger ones reallocate).
    pub fn depth_publisher(&self, max_pixels: usize) -> Result<DepthPublisher, IpcError> {
        let service = self
            .pubsub::<[u16], DepthHeader>(&DEPTH, DEPTH.name)?
            .open_or_create()
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        let publisher = service
            .publisher_builder()
            .initial_max_slice_len(max_pixels.max(1))
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .max_loaned_samples(DEPTH_MAX_LOANED)
            .create()
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        let events = self.event(DEPTH.name)?;
        let notifier = events
            .notifier_builder()
            .create()
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        Ok(DepthPublisher {
            publisher,
            notifier,
            session: monotonic_ns(),
            sequence: 0,
            _service: service,
            _events: events,
        })
    }

    /// A subscriber of `airglyph/depth`.
    pub fn depth_receiver(&self) -> Result<DepthReceiver, IpcError> {
        let service = self
            .pubsub::<[u16], DepthHeader>(&DEPTH, DEPTH.name)?
            .open_or_create()
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        let subscriber = service
            .subscriber_builder()
            .create()
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        let events = self.event(DEPTH.name)?;
        let listener = events
            .listener_builder()
            .create()
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        Ok(DepthReceiver {
            subscriber,
            listener,
            tracker: SequenceTracker::default(),
            rejected: 0,
            _service: service,
            _events: events,
        })
    }

    /// A fixed-size message service and the event service its publisher wakes.
    #[allow(clippy::type_complexity)]
    fn fixed<T: Message>(
        &self,
        s: &Settings,
        name: &str,
    ) -> Result<
        (
            publish_subscribe::PortFactory<Ipc, T, ()>,
            event::PortFactory<Ipc>,
        ),
        IpcError,
    > {
        let service = self
            .pubsub::<T, ()>(s, name)?
            .open_or_create()
            .map_err(|e| IpcError::service(name, e))?;
        Ok((service, self.event(name)?))
    }

    fn publisher<T: Message>(&self, s: &Settings, name: &str) -> Result<Publisher<T>, IpcError> {
        let (service, events) = self.fixed::<T>(s, name)?;
        let err = |reason: String| IpcError::Service {
            service: name.to_owned(),
            reason,
        };
        Ok(Publisher {
            publisher: service
                .publisher_builder()
                .create()
                .map_err(|e| err(format!("{e:?}")))?,
            notifier: events
                .notifier_builder()
                .create()
                .map_err(|e| err(format!("{e:?}")))?,
            _service: service,
            _events: events,
        })
    }

    fn receiver<T: Message>(&self, s: &Settings, name: &str) -> Result<Receiver<T>, IpcError> {
        let (service, events) = self.fixed::<T>(s, name)?;
        let err = |reason: String| IpcError::Service {
            service: name.to_owned(),
            reason,
        };
        Ok(Receiver {
            subscriber: service
                .subscriber_builder()
                .create()
                .map_err(|e| err(format!("{e:?}")))?,
            listener: events
                .listener_builder()
                .create()
                .map_err(|e| err(format!("{e:?}")))?,
            tracker: SequenceTracker::default(),
            rejected: 0,
            _service: service,
            _events: events,
        })
    }

    /// Subscribers of `airglyph/depth` now: lets a supervisor start capture only once
    /// the stages after it listen.
    pub fn depth_subscribers(&self) -> Result<usize, IpcError> {
        let service = self
            .pubsub::<[u16], DepthHeader>(&DEPTH, DEPTH.name)?
            .open_or_create()
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        Ok(service.dynamic_config().number_of_subscribers())
    }

    /// Subscribers of `airglyph/skeleton` now.
    pub fn skeleton_subscribers(&self) -> Result<usize, IpcError> {
        let service = self
            .pubsub::<SkeletonMsg, ()>(&SKELETON, SKELETON.name)?
            .open_or_create()
            .map_err(|e| IpcError::service(SKELETON.name, e))?;
        Ok(service.dynamic_config().number_of_subscribers())
    }

    pub fn skeleton_publisher(&self) -> Result<Publisher<SkeletonMsg>, IpcError> {
        self.publisher(&SKELETON, SKELETON.name)
    }

    pub fn skeleton_receiver(&self) -> Result<Receiver<SkeletonMsg>, IpcError> {
        self.receiver(&SKELETON, SKELETON.name)
    }

    pub fn gesture_publisher(&self) -> Result<Publisher<GestureEventMsg>, IpcError> {
        self.publisher(&GESTURE, GESTURE.name)
    }

    pub fn gesture_receiver(&self) -> Result<Receiver<GestureEventMsg>, IpcError> {
        self.receiver(&GESTURE, GESTURE.name)
    }

    pub fn decision_publisher(&self) -> Result<Publisher<DecisionMsg>, IpcError> {
        self.publisher(&DECISION, DECISION.name)
    }

    pub fn decision_receiver(&self) -> Result<Receiver<DecisionMsg>, IpcError> {
        self.receiver(&DECISION, DECISION.name)
    }

    pub fn stats_publisher(&self, stage: Stage) -> Result<Publisher<StageStatsMsg>, IpcError> {
        self.publisher(&STATS, &format!("{}/{}", STATS.name, stage.name()))
    }

    pub fn stats_receiver(&self, stage: Stage) -> Result<Receiver<StageStatsMsg>, IpcError> {
        self.receiver(&STATS, &format!("{}/{}", STATS.name, stage.name()))
    }
}

/// A fixed-size message type of the pipeline: knows how to check itself and where its
/// frame sequence is, so receivers can count drops and refuse garbage.
pub trait Message: Debug + Copy + Default + ZeroCopySend + 'static {
    /// The capture session and frame sequence this message belongs to, if it follows
    /// frames one to one (stats and gesture events do not).
    fn frame(&self) -> Option<(u64, u64)>;
    fn check(&self) -> Result<(), MessageError>;
}

impl Message for SkeletonMsg {
    fn frame(&self) -> Option<(u64, u64)> {
        Some((self.session, self.sequence))
    }
    fn check(&self) -> Result<(), MessageError> {
        self.validate()
    }
}

impl Message for GestureEventMsg {
    fn frame(&self) -> Option<(u64, u64)> {
        None
    }
    fn check(&self) -> Result<(), MessageError> {
        self.validate()
    }
}

impl Message for DecisionMsg {
    fn frame(&self) -> Option<(u64, u64)> {
        Some((self.session, self.sequence))
    }
    fn check(&self) -> Result<(), MessageError> {
        self.validate()
    }
}

impl Message for StageStatsMsg {
    fn frame(&self) -> Option<(u64, u64)> {
        None
    }
    fn check(&self) -> Result<(), MessageError> {
        Ok(())
    }
}

/// Publishes depth frames: the source writes straight into the loaned shared memory.
pub struct DepthPublisher {
    publisher: IoxPublisher<Ipc, [u16], DepthHeader>,
    notifier: Notifier<Ipc>,
    session: u64,
    sequence: u64,
    _service: publish_subscribe::PortFactory<Ipc, [u16], DepthHeader>,
    _events: event::PortFactory<Ipc>,
}

/// Why a frame was not published.
#[derive(Debug, thiserror::Error)]
pub enum PublishError<E> {
    #[error("{0}")]
    Source(E),
    #[error("shared memory: {0}")]
    Transport(String),
}

impl DepthPublisher {
    pub fn session(&self) -> u64 {
        self.session
    }

    /// Frames published so far; the next frame's sequence number.
    pub fn sequence(&self) -> u64 {
        self.sequence
    }

    /// Loans a `pixels`-long sample, lets `fill` write the frame into it and set the
    /// header's capture time and intrinsics, then sends it and wakes the subscribers.
    /// `fill` returns `Ok(false)` when it has no frame; nothing is sent then. Returns the
    /// header as sent.
    pub fn publish<E>(
        &mut self,
        pixels: usize,
        fill: impl FnOnce(&mut DepthHeader, &mut [u16]) -> Result<bool, E>,
    ) -> Result<Option<DepthHeader>, PublishError<E>> {
        // `loan_slice` initializes the memory (a memset): handing uninitialized shared
        // memory out as `&mut [u16]` would be undefined behaviour.
        let mut sample = self
            .publisher
            .loan_slice(pixels)
            .map_err(|e| PublishError::Transport(format!("loan of {pixels} pixels: {e:?}")))?;
        let mut header = DepthHeader::default();
        if !fill(&mut header, sample.payload_mut()).map_err(PublishError::Source)? {
            return Ok(None);
        }
        header.sequence = self.sequence;
        header.session = self.session;
        header.publish_ns = monotonic_ns();
        if header.capture_ns == 0 {
            header.capture_ns = header.publish_ns;
        }
        if header.source_ns == 0 {
            header.source_ns = header.capture_ns;
        }
        *sample.user_header_mut() = header;
        sample
            .send()
            .map_err(|e| PublishError::Transport(format!("send: {e:?}")))?;
        // A missing listener is not an error: nobody may be subscribed yet.
        let _ = self.notifier.notify();
        self.sequence += 1;
        Ok(Some(header))
    }

    /// Sends a frame whose header is taken as given (no sequence or time is filled in).
    /// Only for tests of what subscribers do with malformed headers.
    #[doc(hidden)]
    pub fn publish_raw(&mut self, header: DepthHeader, pixels: &[u16]) -> Result<(), IpcError> {
        let mut sample = self
            .publisher
            .loan_slice(pixels.len())
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        sample.payload_mut().copy_from_slice(pixels);
        *sample.user_header_mut() = header;
        sample
            .send()
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        let _ = self.notifier.notify();
        Ok(())
    }
}

/// Publishes fixed-size messages and wakes the subscribers.
pub struct Publisher<T: Message> {
    publisher: IoxPublisher<Ipc, T, ()>,
    notifier: Notifier<Ipc>,
    _service: publish_subscribe::PortFactory<Ipc, T, ()>,
    _events: event::PortFactory<Ipc>,
}

impl<T: Message> Publisher<T> {
    pub fn send(&self, msg: T) -> Result<(), IpcError> {
        self.publisher
            .send_copy(msg)
            .map_err(|e| IpcError::service("publish", e))?;
        let _ = self.notifier.notify();
        Ok(())
    }
}

/// Blocks until the publisher signals or `ns` pass. A signal (SIGINT/SIGTERM) only
/// wakes the caller early, so it can look at [`crate::shutdown::requested`].
fn wait(listener: &Listener<Ipc>, ns: u64) -> Result<(), IpcError> {
    // iceoryx2 0.10 waits on a Unix socket with SO_RCVTIMEO, in whole microseconds, and
    // a timeout of zero there means "for ever": a deadline less than a microsecond away
    // hung the supervisor for good once (its stages idle, SIGTERM restarting the call).
    let timeout = Duration::from_micros(ns.div_ceil(1_000).max(1));
    match listener.timed_wait(|_| {}, timeout) {
        Ok(_) | Err(iceoryx2::port::listener::ListenerWaitError::InterruptSignal) => Ok(()),
        Err(e) => Err(IpcError::service("wait", e)),
    }
}

/// What every receiver does with its subscriber: block on the publisher's event with a
/// deadline, and skip to the newest message when asked.
trait Inbox {
    type Item;
    fn listener(&self) -> &Listener<Ipc>;
    /// The next valid item already in the buffer.
    fn take(&mut self) -> Result<Option<Self::Item>, IpcError>;
    fn dropped(item: &mut Self::Item) -> &mut u64;

    fn next_before(&mut self, timeout: Duration) -> Result<Option<Self::Item>, IpcError> {
        let deadline = monotonic_ns() + timeout.as_nanos() as u64;
        loop {
            if let Some(item) = self.take()? {
                return Ok(Some(item));
            }
            let now = monotonic_ns();
            if now >= deadline {
                return Ok(None);
            }
            wait(self.listener(), deadline - now)?;
        }
    }

    fn newest_before(&mut self, timeout: Duration) -> Result<Option<Self::Item>, IpcError> {
        let Some(mut newest) = self.next_before(timeout)? else {
            return Ok(None);
        };
        while let Some(mut next) = self.take()? {
            // The item we skip is lost to this stage too.
            *Self::dropped(&mut next) += *Self::dropped(&mut newest) + 1;
            newest = next;
        }
        Ok(Some(newest))
    }
}

/// What a receiver hands out: a validated message and how many were lost before it.
#[derive(Debug)]
pub struct Received<T> {
    pub msg: T,
    /// Frames lost since the previous message of the same session (sequence gaps).
    pub dropped: u64,
    /// When this process took the message out of shared memory.
    pub receive_ns: u64,
}

/// Blocks on the service's event with a deadline and hands out validated messages.
pub struct Receiver<T: Message> {
    subscriber: Subscriber<Ipc, T, ()>,
    listener: Listener<Ipc>,
    tracker: SequenceTracker,
    rejected: u64,
    _service: publish_subscribe::PortFactory<Ipc, T, ()>,
    _events: event::PortFactory<Ipc>,
}

impl<T: Message> Receiver<T> {
    /// Messages refused as malformed since the receiver was made.
    pub fn rejected(&self) -> u64 {
        self.rejected
    }

    /// The next valid message, or `None` if none arrives before `timeout`.
    pub fn recv(&mut self, timeout: Duration) -> Result<Option<Received<T>>, IpcError> {
        Inbox::next_before(self, timeout)
    }

    /// The next valid message already in the buffer, without blocking.
    pub fn try_recv(&mut self) -> Result<Option<Received<T>>, IpcError> {
        while let Some(sample) = self
            .subscriber
            .receive()
            .map_err(|e| IpcError::service("receive", e))?
        {
            let msg = *sample.payload();
            if let Err(e) = msg.check() {
                self.rejected += 1;
                tracing::warn!(error = %e, "dropped a malformed message");
                continue;
            }
            let dropped = msg
                .frame()
                .map_or(0, |(session, seq)| self.tracker.observe(session, seq));
            return Ok(Some(Received {
                msg,
                dropped,
                receive_ns: monotonic_ns(),
            }));
        }
        Ok(None)
    }

    /// The newest valid message in the buffer, skipping (and counting as dropped) older ones.
    pub fn latest(&mut self, timeout: Duration) -> Result<Option<Received<T>>, IpcError> {
        Inbox::newest_before(self, timeout)
    }
}

impl<T: Message> Inbox for Receiver<T> {
    type Item = Received<T>;
    fn listener(&self) -> &Listener<Ipc> {
        &self.listener
    }
    fn take(&mut self) -> Result<Option<Received<T>>, IpcError> {
        self.try_recv()
    }
    fn dropped(item: &mut Received<T>) -> &mut u64 {
        &mut item.dropped
    }
}

/// A received depth frame, still in shared memory.
pub struct DepthFrame {
    sample: Sample<Ipc, [u16], DepthHeader>,
    /// Frames lost since the previous one of this capture session.
    pub dropped: u64,
    pub receive_ns: u64,
}

impl DepthFrame {
    pub fn header(&self) -> &DepthHeader {
        self.sample.user_header()
    }

    pub fn pixels(&self) -> &[u16] {
        self.sample.payload()
    }

    pub fn view(&self) -> airglyph_core::DepthView<'_> {
        let h = self.header();
        airglyph_core::DepthView::new(h.width, h.height, self.pixels())
            .expect("validated on receipt")
    }
}

/// Receives depth frames, checking every header against its payload.
pub struct DepthReceiver {
    subscriber: Subscriber<Ipc, [u16], DepthHeader>,
    listener: Listener<Ipc>,
    tracker: SequenceTracker,
    rejected: u64,
    _service: publish_subscribe::PortFactory<Ipc, [u16], DepthHeader>,
    _events: event::PortFactory<Ipc>,
}

/// A refused depth frame, for logs.
#[derive(Debug)]
pub struct Rejected {
    pub sequence: u64,
    pub error: HeaderError,
}

impl DepthReceiver {
    /// Frames refused for a malformed header since the receiver was made.
    pub fn rejected(&self) -> u64 {
        self.rejected
    }

    /// The next valid frame already in the buffer, without blocking.
    pub fn try_recv(&mut self) -> Result<Option<DepthFrame>, IpcError> {
        while let Some(sample) = self
            .subscriber
            .receive()
            .map_err(|e| IpcError::service(DEPTH.name, e))?
        {
            let now = monotonic_ns();
            let header = *sample.user_header();
            if let Err(error) = header.validate(sample.payload().len(), now) {
                self.rejected += 1;
                tracing::warn!(sequence = header.sequence, %error, "dropped a depth frame with a bad header");
                continue;
            }
            let dropped = self.tracker.observe(header.session, header.sequence);
            return Ok(Some(DepthFrame {
                sample,
                dropped,
                receive_ns: now,
            }));
        }
        Ok(None)
    }

    /// The next valid frame, or `None` if none arrives before `timeout`.
    pub fn recv(&mut self, timeout: Duration) -> Result<Option<DepthFrame>, IpcError> {
        Inbox::next_before(self, timeout)
    }

    /// The newest valid frame, releasing older ones unprocessed (counted as dropped): a
    /// stage slower than the camera works on the present, not on a backlog.
    pub fn latest(&mut self, timeout: Duration) -> Result<Option<DepthFrame>, IpcError> {
        Inbox::newest_before(self, timeout)
    }
}

impl Inbox for DepthReceiver {
    type Item = DepthFrame;
    fn listener(&self) -> &Listener<Ipc> {
        &self.listener
    }
    fn take(&mut self) -> Result<Option<DepthFrame>, IpcError> {
        self.try_recv()
    }
    fn dropped(item: &mut DepthFrame) -> &mut u64 {
        &mut item.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;

    #[test]
    fn a_deadline_under_a_microsecond_away_does_not_wait_for_ever() {
        let (done, finished) = mpsc::channel();
        // In a thread of its own: were the wait to block for good, the test fails
        // instead of hanging.
        std::thread::spawn(move || {
            let cfg = IpcConfig {
                root: format!("/tmp/airglyph-test-{}-wait/", std::process::id()),
                prefix: format!("agt{}wait_", std::process::id()),
            };
            let root = cfg.root.clone();
            let pipeline = Pipeline::join_with(cfg, "waiter").unwrap();
            let receiver = pipeline.skeleton_receiver().unwrap();
            for ns in [1, 500, 999, 1_000, 1_001] {
                wait(&receiver.listener, ns).unwrap();
            }
            // Gone before the test's process may end, so its shared memory is removed.
            drop(receiver);
            drop(pipeline);
            let _ = std::fs::remove_dir_all(root);
            done.send(()).unwrap();
        });
        assert!(
            finished.recv_timeout(Duration::from_secs(20)).is_ok(),
            "a wait of under a microsecond blocked"
        );
    }
}
