//! The services of a pipeline and typed ports on them. Every service setting lives here.

use crate::clock::monotonic_ns;
use crate::stats::SequenceTracker;
use crate::wire::{
    DecisionMsg, DepthHeader, GestureEventMsg, HeaderError, MessageError, SkeletonMsg,
    StageStatsMsg,
};
use crate::{ownership, IpcConfig, IpcError};
use iceoryx2::node::NodeView;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::{Publisher as IoxPublisher, PublisherCreateError};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
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
    /// Depth frames from a camera, a recording or the synthetic person.
    Capture = 1,
    /// Depth frame to skeleton.
    Pose = 2,
    /// Skeletons to gestures.
    Gesture = 3,
    /// The web page of what the pipeline sees.
    Viewer = 4,
}

impl Stage {
    /// The stages `airglyph run` starts, in pipeline order.
    pub const PIPELINE: [Stage; 3] = [Stage::Capture, Stage::Pose, Stage::Gesture];
    /// Every stage: the pipeline's, then the viewer (`airglyph run --view`).
    pub const ALL: [Stage; 4] = [Stage::Capture, Stage::Pose, Stage::Gesture, Stage::Viewer];

    /// The stage's name in service names, commands and logs.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Capture => "capture",
            Stage::Pose => "pose",
            Stage::Gesture => "gesture",
            Stage::Viewer => "viewer",
        }
    }

    /// The stage named `name`, if any.
    pub fn from_name(name: &str) -> Option<Stage> {
        Stage::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The stage a stats message's `stage` field names, if any.
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
    /// One: a second capture, pose or gesture stage on the same pipeline is refused
    /// ([`IpcError::Taken`]) instead of interleaving its stream with the first's.
    max_publishers: usize,
    max_subscribers: usize,
    /// Messages the publisher keeps for a subscriber that asks for them when it
    /// connects ([`Pipeline::skeleton_receiver_with_history`]); the others ask for none.
    history: usize,
}

const DEPTH: Settings = Settings {
    name: "airglyph/depth",
    buffer: 2,
    max_publishers: 1,
    max_subscribers: 8,
    history: 0,
};
const SKELETON: Settings = Settings {
    name: "airglyph/skeleton",
    buffer: 4,
    max_publishers: 1,
    max_subscribers: 8,
    history: SKELETON_HISTORY,
};

/// Skeletons the skeleton publisher keeps for a gesture stage that starts (again):
/// 256 frames, 8.5 s at 30 fps, the spotter's whole reach back: its longest gesture
/// (4 s), the hold before a pending one is decided (2.5 s) and the context around it
/// (1 s), so a gesture stage killed while a symbol was pending finds it again. It costs
/// the publisher's data segment about 1 MB (every subscriber may buffer as many).
pub const SKELETON_HISTORY: usize = 256;
const GESTURE: Settings = Settings {
    name: "airglyph/gesture",
    // Events come seconds apart, but an importer whose link came back sends those it
    // recovered at once (up to 64: `airglyph-zenoh`) with the live ones, and a full
    // buffer drops its oldest without a word (gesture events carry no sequence to count
    // gaps by). A subscriber descheduled a few hundred ms on a busy machine lost one of
    // such a burst in a buffer of 64 (1 run in 3); 128 events are 17 KB a subscriber.
    buffer: 128,
    max_publishers: 1,
    max_subscribers: 8,
    history: GESTURE_HISTORY,
};

/// Gesture events the gesture publisher keeps for a subscriber that joins late and asks
/// for them ([`Pipeline::gesture_receiver_with_history`], `airglyph echo gesture`): a
/// program started a moment after a symbol was drawn still hears of it. Events come
/// seconds apart, so 8 reach back a minute or more; they cost a few hundred bytes. They
/// live in the gesture stage's process and go with it: a restarted stage starts with none.
pub const GESTURE_HISTORY: usize = 8;
const DECISION: Settings = Settings {
    name: "airglyph/decision",
    buffer: 8,
    max_publishers: 1,
    max_subscribers: 8,
    history: 0,
};
const STATS: Settings = Settings {
    name: "airglyph/stats",
    buffer: 4,
    max_publishers: 1,
    max_subscribers: 8,
    history: 0,
};

/// How many frames one depth publisher may hold loaned at once.
const DEPTH_MAX_LOANED: usize = 2;

/// An iceoryx2 failure, or the file behind it when one of the pipeline's files is not
/// the user's own (planted since the start, say): iceoryx2's errors name no file.
fn explain(config: &IpcConfig, error: IpcError) -> IpcError {
    match ownership::check_shm(&config.prefix) {
        Err(unsafe_file) => unsafe_file,
        Ok(()) => error,
    }
}

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
        // What dead processes left goes with the last ones to leave. iceoryx2's node
        // counter stays: it is ours alone (see `crate::ownership`), and a counter that
        // is never removed cannot be planted before the next start.
        let _ = Node::<Ipc>::list(&iox, |state| {
            if let NodeState::Dead(dead) = state {
                let _ = dead.try_remove_stale_resources();
            }
            CallbackProgression::Continue
        });
    }
}

impl Pipeline {
    /// Joins the pipeline the environment names (see [`IpcConfig::from_env`]) as `node_name`.
    pub fn join(node_name: &str) -> Result<Self, IpcError> {
        Self::join_with(IpcConfig::from_env()?, node_name)
    }

    /// Joins a pipeline and removes what dead processes left in it, so a stage that was
    /// killed can be started again at once.
    /// Refuses a pipeline whose files another user made or could change
    /// ([`crate::ownership`]), naming the file.
    pub fn join_with(config: IpcConfig, node_name: &str) -> Result<Self, IpcError> {
        let iox = config.iceoryx2()?;
        let name = NodeName::new(node_name).map_err(|e| IpcError::Node {
            node: node_name.into(),
            reason: format!("{e:?}"),
        })?;
        ownership::prepare(&config)?;
        let node = NodeBuilder::new()
            .name(&name)
            .config(&iox)
            // Stages handle SIGINT/SIGTERM themselves (see `crate::shutdown`).
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<Ipc>()
            .map_err(|e| {
                explain(
                    &config,
                    IpcError::Node {
                        node: node_name.into(),
                        reason: format!("{e:?}"),
                    },
                )
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

    /// Which pipeline this process joined.
    pub fn config(&self) -> &IpcConfig {
        &self.config
    }

    /// Removes the stale resources of every dead node of this pipeline; returns how many.
    pub fn cleanup_dead_nodes(&self) -> usize {
        let state = self.node().try_cleanup_dead_nodes();
        state.cleanups as usize
    }

    /// An iceoryx2 failure on `service`, or the file behind it (see [`explain`]).
    fn fail(&self, service: &str, reason: impl Debug) -> IpcError {
        explain(&self.config, IpcError::service(service, reason))
    }

    /// The settings of a publish-subscribe service of the pipeline.
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
            .subscriber_max_buffer_size(s.buffer.max(s.history))
            .history_size(s.history)
            .max_publishers(s.max_publishers)
            .max_subscribers(s.max_subscribers))
    }

    /// `airglyph/depth`, opened or created.
    fn depth_service(
        &self,
    ) -> Result<publish_subscribe::PortFactory<Ipc, [u16], DepthHeader>, IpcError> {
        self.pubsub::<[u16], DepthHeader>(&DEPTH, DEPTH.name)?
            .open_or_create()
            .map_err(|e| self.fail(DEPTH.name, e))
    }

    /// A fixed-size message service, opened or created.
    fn fixed_service<T: Message>(
        &self,
        s: &Settings,
        name: &str,
    ) -> Result<publish_subscribe::PortFactory<Ipc, T, ()>, IpcError> {
        self.pubsub::<T, ()>(s, name)?
            .open_or_create()
            .map_err(|e| self.fail(name, e))
    }

    fn event(&self, name: &str) -> Result<event::PortFactory<Ipc>, IpcError> {
        self.node()
            .service_builder(&service_name(name)?)
            .event()
            .open_or_create()
            .map_err(|e| self.fail(name, e))
    }

    /// The one publisher of a service. When its place is taken, a dead process's
    /// publisher (killed, not yet cleaned up by anyone) is removed and the place taken
    /// again; a live one's is refused, naming that process.
    fn sole_publisher<P: Debug + IceoryxSend + ?Sized, H: Debug + ZeroCopySend, T>(
        &self,
        name: &str,
        service: &publish_subscribe::PortFactory<Ipc, P, H>,
        create: impl Fn() -> Result<T, PublisherCreateError>,
    ) -> Result<T, IpcError> {
        let iox = self.config.iceoryx2()?;
        // A dead publisher's node is removed at the first try; the rest covers another
        // process removing it at the same moment.
        for _ in 0..20 {
            match create() {
                Ok(publisher) => return Ok(publisher),
                Err(PublisherCreateError::ExceedsMaxSupportedPublishers) => {}
                Err(e) => return Err(self.fail(name, e)),
            }
            let mut holders = Vec::new();
            service.dynamic_config().list_publishers(|p| {
                holders.push(p.node_id);
                CallbackProgression::Continue
            });
            for id in holders {
                match Node::<Ipc>::state_of(&iox, id) {
                    Ok(Some(NodeState::Alive(alive))) => {
                        return Err(IpcError::Taken {
                            service: name.to_owned(),
                            pid: id.pid::<Ipc>().map_or(-1, |p| p.value() as i64),
                            node: alive
                                .details()
                                .as_ref()
                                .map_or_else(String::new, |d| d.name().as_str().to_owned()),
                            prefix: self.config.prefix.clone(),
                        });
                    }
                    Ok(Some(NodeState::Dead(dead))) => {
                        let _ = dead.try_remove_stale_resources();
                    }
                    _ => {}
                }
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        Err(self.fail(name, PublisherCreateError::ExceedsMaxSupportedPublishers))
    }

    /// The capture side of `airglyph/depth`, for frames of up to `max_pixels` pixels
    /// (larger ones reallocate).
    pub fn depth_publisher(&self, max_pixels: usize) -> Result<DepthPublisher, IpcError> {
        let service = self.depth_service()?;
        let publisher = self.sole_publisher(DEPTH.name, &service, || {
            service
                .publisher_builder()
                .initial_max_slice_len(max_pixels.max(1))
                .allocation_strategy(AllocationStrategy::PowerOfTwo)
                .max_loaned_samples(DEPTH_MAX_LOANED)
                .create()
        })?;
        let events = self.event(DEPTH.name)?;
        let notifier = events
            .notifier_builder()
            .create()
            .map_err(|e| self.fail(DEPTH.name, e))?;
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
        let service = self.depth_service()?;
        let subscriber = service
            .subscriber_builder()
            .create()
            .map_err(|e| self.fail(DEPTH.name, e))?;
        let events = self.event(DEPTH.name)?;
        let listener = events
            .listener_builder()
            .create()
            .map_err(|e| self.fail(DEPTH.name, e))?;
        Ok(DepthReceiver {
            subscriber,
            listener,
            tracker: SequenceTracker::default(),
            rejected: 0,
            _service: service,
            _events: events,
        })
    }

    fn publisher<T: Message>(&self, s: &Settings, name: &str) -> Result<Publisher<T>, IpcError> {
        let service = self.fixed_service::<T>(s, name)?;
        let publisher =
            self.sole_publisher(name, &service, || service.publisher_builder().create())?;
        let events = self.event(name)?;
        Ok(Publisher {
            publisher,
            subscribers: std::cell::Cell::new(0),
            notifier: events
                .notifier_builder()
                .create()
                .map_err(|e| self.fail(name, e))?,
            service,
            _events: events,
        })
    }

    /// A receiver with a buffer of `buffer` messages that asks for `history` of the
    /// publisher's last ones when it connects.
    fn receiver<T: Message>(
        &self,
        s: &Settings,
        name: &str,
        buffer: usize,
        history: usize,
    ) -> Result<Receiver<T>, IpcError> {
        let service = self.fixed_service::<T>(s, name)?;
        let events = self.event(name)?;
        Ok(Receiver {
            subscriber: service
                .subscriber_builder()
                .buffer_size(buffer)
                .history_request(history)
                .create()
                .map_err(|e| self.fail(name, e))?,
            listener: events
                .listener_builder()
                .create()
                .map_err(|e| self.fail(name, e))?,
            tracker: SequenceTracker::default(),
            rejected: 0,
            _service: service,
            _events: events,
        })
    }

    /// Subscribers of `airglyph/depth` now: lets a supervisor start capture only once
    /// the stages after it listen.
    pub fn depth_subscribers(&self) -> Result<usize, IpcError> {
        let service = self.depth_service()?;
        Ok(service.dynamic_config().number_of_subscribers())
    }

    /// Subscribers of `airglyph/skeleton` now.
    pub fn skeleton_subscribers(&self) -> Result<usize, IpcError> {
        let service = self.fixed_service::<SkeletonMsg>(&SKELETON, SKELETON.name)?;
        Ok(service.dynamic_config().number_of_subscribers())
    }

    /// The publisher of skeletons (one a pipeline: the pose stage, or capture with truth).
    pub fn skeleton_publisher(&self) -> Result<Publisher<SkeletonMsg>, IpcError> {
        self.publisher(&SKELETON, SKELETON.name)
    }

    /// A subscriber to skeletons, from the next one published on.
    pub fn skeleton_receiver(&self) -> Result<Receiver<SkeletonMsg>, IpcError> {
        self.receiver(&SKELETON, SKELETON.name, SKELETON.buffer, 0)
    }

    /// A subscriber of `airglyph/skeleton` that is first handed the publisher's last
    /// [`SKELETON_HISTORY`] skeletons (at its next send: iceoryx2 delivers history when
    /// the publisher next looks at its connections), oldest first, and keeps as many:
    /// for a gesture stage catching up after a restart. Its buffer is that large, so a
    /// stage that stays on it lags behind instead of dropping old skeletons: catch up,
    /// then go on with [`Pipeline::skeleton_receiver`].
    pub fn skeleton_receiver_with_history(&self) -> Result<Receiver<SkeletonMsg>, IpcError> {
        self.receiver(&SKELETON, SKELETON.name, SKELETON_HISTORY, SKELETON_HISTORY)
    }

    /// The publisher of gesture events (the gesture stage).
    pub fn gesture_publisher(&self) -> Result<Publisher<GestureEventMsg>, IpcError> {
        self.publisher(&GESTURE, GESTURE.name)
    }

    /// A subscriber to gesture events.
    pub fn gesture_receiver(&self) -> Result<Receiver<GestureEventMsg>, IpcError> {
        self.receiver(&GESTURE, GESTURE.name, GESTURE.buffer, 0)
    }

    /// A subscriber of `airglyph/gesture` first handed the publisher's last
    /// [`GESTURE_HISTORY`] events, oldest first. They arrive when the publisher next
    /// looks at its connections ([`Publisher::update_connections`], which the gesture
    /// stage calls every round), not at once.
    pub fn gesture_receiver_with_history(&self) -> Result<Receiver<GestureEventMsg>, IpcError> {
        self.receiver(&GESTURE, GESTURE.name, GESTURE.buffer, GESTURE_HISTORY)
    }

    /// The publisher of the gesture stage's decisions, one a frame.
    pub fn decision_publisher(&self) -> Result<Publisher<DecisionMsg>, IpcError> {
        self.publisher(&DECISION, DECISION.name)
    }

    /// A subscriber to the gesture stage's decisions.
    pub fn decision_receiver(&self) -> Result<Receiver<DecisionMsg>, IpcError> {
        self.receiver(&DECISION, DECISION.name, DECISION.buffer, 0)
    }

    /// The publisher of `stage`'s telemetry.
    pub fn stats_publisher(&self, stage: Stage) -> Result<Publisher<StageStatsMsg>, IpcError> {
        self.publisher(&STATS, &format!("{}/{}", STATS.name, stage.name()))
    }

    /// A subscriber to `stage`'s telemetry.
    pub fn stats_receiver(&self, stage: Stage) -> Result<Receiver<StageStatsMsg>, IpcError> {
        self.receiver(
            &STATS,
            &format!("{}/{}", STATS.name, stage.name()),
            STATS.buffer,
            0,
        )
    }
}

/// A fixed-size message type of the pipeline: knows how to check itself and where its
/// frame sequence is, so receivers can count drops and refuse garbage.
pub trait Message: Debug + Copy + Default + ZeroCopySend + 'static {
    /// The capture session and frame sequence this message belongs to, if it follows
    /// frames one to one (stats and gesture events do not).
    fn frame(&self) -> Option<(u64, u64)>;
    /// Whether the message, written by another process, is sound enough to use.
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
    /// The source failed to give a frame.
    #[error("{0}")]
    Source(E),
    /// The shared memory refused the frame.
    #[error("shared memory: {0}")]
    Transport(String),
}

impl DepthPublisher {
    /// The capture session this publisher's frames belong to (its start time).
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

/// The header of a frame already sent, still writable by its publisher: what a hostile
/// publisher of the pipeline's own user can change under its subscribers. Only for
/// tests of what subscribers do with that; it borrows the publisher, whose data
/// segment holds the header, so it cannot outlive it.
#[doc(hidden)]
pub struct SentHeader<'a> {
    header: *mut DepthHeader,
    _publisher: std::marker::PhantomData<&'a mut DepthPublisher>,
}

impl SentHeader<'_> {
    pub fn set_width(&self, width: u32) {
        // SAFETY: the header lies in the publisher's data segment, mapped while the
        // publisher lives, which the borrow guarantees; volatile because other
        // processes read it.
        unsafe { std::ptr::addr_of_mut!((*self.header).width).write_volatile(width) };
    }
}

impl DepthPublisher {
    /// Sends a frame whose header is taken as given and hands out its header in shared
    /// memory. Only for tests (see [`SentHeader`]).
    #[doc(hidden)]
    pub fn publish_tamperable(
        &mut self,
        header: DepthHeader,
        pixels: &[u16],
    ) -> Result<SentHeader<'_>, IpcError> {
        let mut sample = self
            .publisher
            .loan_slice(pixels.len())
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        sample.payload_mut().copy_from_slice(pixels);
        *sample.user_header_mut() = header;
        let sent: *mut DepthHeader = sample.user_header_mut();
        sample
            .send()
            .map_err(|e| IpcError::service(DEPTH.name, e))?;
        let _ = self.notifier.notify();
        Ok(SentHeader {
            header: sent,
            _publisher: std::marker::PhantomData,
        })
    }
}

/// Publishes fixed-size messages and wakes the subscribers.
pub struct Publisher<T: Message> {
    publisher: IoxPublisher<Ipc, T, ()>,
    notifier: Notifier<Ipc>,
    /// Subscribers at the last [`Publisher::update_connections`].
    subscribers: std::cell::Cell<usize>,
    service: publish_subscribe::PortFactory<Ipc, T, ()>,
    _events: event::PortFactory<Ipc>,
}

impl<T: Message> Publisher<T> {
    /// Sends `msg` and wakes the subscribers.
    pub fn send(&self, msg: T) -> Result<(), IpcError> {
        self.publisher
            .send_copy(msg)
            .map_err(|e| IpcError::service("publish", e))?;
        let _ = self.notifier.notify();
        Ok(())
    }

    /// Connects subscribers that came since the last send and hands them the history
    /// they asked for. iceoryx2 does this at every send; a publisher that sends seldom
    /// (gesture events) calls it between sends, or a late subscriber would wait for the
    /// next event to hear of the last ones. A subscriber that cannot be connected now
    /// is tried again at the next call.
    pub fn update_connections(&self) {
        let subscribers = self.service.dynamic_config().number_of_subscribers();
        let newcomers = subscribers > self.subscribers.replace(subscribers);
        if self.publisher.update_connections().is_ok() && newcomers {
            // Wakes the newcomer blocked on the event: its history has arrived.
            let _ = self.notifier.notify();
        }
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
    /// The message, checked.
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

/// A received depth frame: its pixels still in shared memory, its header the copy that
/// was checked. The publisher can still write to the sample after sending it, so
/// nothing that was validated is read from shared memory again: a width changed after
/// the check once sized a view of pixels the check never saw (and panicked). That
/// includes the payload's length, which iceoryx2 0.10 reads from the sample's header in
/// shared memory at every `payload()`: it is read once, on receipt.
pub struct DepthFrame {
    /// Keeps the chunk `pixels` points into reserved for this subscriber.
    _sample: Sample<Ipc, [u16], DepthHeader>,
    header: DepthHeader,
    pixels: *const u16,
    len: usize,
    /// Frames lost since the previous one of this capture session.
    pub dropped: u64,
    /// When this process took the frame out of shared memory.
    pub receive_ns: u64,
}

impl DepthFrame {
    /// The header as it was validated on receipt.
    pub fn header(&self) -> &DepthHeader {
        &self.header
    }

    /// The pixels, width × height of the validated header. Their values may still
    /// change under a hostile publisher; their number cannot.
    pub fn pixels(&self) -> &[u16] {
        // SAFETY: `pixels` and `len` are the payload slice iceoryx2 handed out on
        // receipt; the chunk stays mapped and reserved for us while `_sample` lives,
        // which is as long as `self`.
        unsafe { std::slice::from_raw_parts(self.pixels, self.len) }
    }

    /// The frame as a depth image, in shared memory.
    pub fn view(&self) -> airglyph_core::DepthView<'_> {
        airglyph_core::DepthView::new(self.header.width, self.header.height, self.pixels())
            .expect("the copied header's width x height was checked against this length")
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
    /// The frame's sequence number, as its header claims.
    pub sequence: u64,
    /// Why it was refused.
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
            // Each read once: the copies are what is checked and what is used.
            let header = *sample.user_header();
            let (pixels, len) = {
                let payload = sample.payload();
                (payload.as_ptr(), payload.len())
            };
            if let Err(error) = header.validate(len, now) {
                self.rejected += 1;
                tracing::warn!(sequence = header.sequence, %error, "dropped a depth frame with a bad header");
                continue;
            }
            let dropped = self.tracker.observe(header.session, header.sequence);
            return Ok(Some(DepthFrame {
                _sample: sample,
                header,
                pixels,
                len,
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
            let counter = ownership::node_counter(&cfg.prefix);
            let pipeline = Pipeline::join_with(cfg, "waiter").unwrap();
            let receiver = pipeline.skeleton_receiver().unwrap();
            for ns in [1, 500, 999, 1_000, 1_001] {
                wait(&receiver.listener, ns).unwrap();
            }
            // Gone before the test's process may end, so its shared memory is removed.
            drop(receiver);
            drop(pipeline);
            let _ = std::fs::remove_dir_all(root);
            let _ = std::fs::remove_file(counter);
            done.send(()).unwrap();
        });
        assert!(
            finished.recv_timeout(Duration::from_secs(20)).is_ok(),
            "a wait of under a microsecond blocked"
        );
    }
}
