//! The viewer's subscriptions: every service of the pipeline, read into a [`Scene`].
//! Subscribers keep iceoryx2's small safe-overflow buffers, and a frame is copied out
//! and its shared memory released at once, so the viewer never holds capture back.

use crate::push::Push;
use crate::scene::Scene;
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::port::DepthReceiver;
use airglyph_ipc::{
    DecisionMsg, GestureEventMsg, IpcError, Pipeline, Receiver, SkeletonMsg, Stage, StageStatsMsg,
};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The viewer's subscriptions to every service of a pipeline.
pub struct Feed {
    /// Where each message also goes, for the push stream's clients.
    push: Option<Arc<Push>>,
    depth: DepthReceiver,
    skeletons: Receiver<SkeletonMsg>,
    decisions: Receiver<DecisionMsg>,
    gestures: Receiver<GestureEventMsg>,
    stats: Vec<(Stage, Receiver<StageStatsMsg>)>,
}

/// What one [`Feed::poll`] brought in.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Polled {
    /// Depth frames taken.
    pub frames: usize,
    /// Skeletons taken.
    pub skeletons: usize,
    /// Decisions taken.
    pub decisions: usize,
    /// Gesture events taken.
    pub gestures: usize,
}

impl Feed {
    /// Subscribes to the pipeline. The depth subscription comes last: a supervisor that
    /// sees it knows every other one exists too.
    pub fn new(pipeline: &Pipeline) -> Result<Self, IpcError> {
        let stats = Stage::PIPELINE
            .iter()
            .map(|&s| Ok((s, pipeline.stats_receiver(s)?)))
            .collect::<Result<_, IpcError>>()?;
        let gestures = pipeline.gesture_receiver()?;
        let decisions = pipeline.decision_receiver()?;
        let skeletons = pipeline.skeleton_receiver()?;
        let depth = pipeline.depth_receiver()?;
        Ok(Self {
            push: None,
            depth,
            skeletons,
            decisions,
            gestures,
            stats,
        })
    }

    /// Also hands every skeleton, gesture and stats message to `push`.
    pub fn with_push(self, push: Arc<Push>) -> Self {
        Self {
            push: Some(push),
            ..self
        }
    }

    /// Waits up to `timeout` for a depth frame, then moves everything that has arrived
    /// into the scene. The scene is locked once per message, never while waiting.
    pub fn poll(&mut self, scene: &Mutex<Scene>, timeout: Duration) -> Result<Polled, IpcError> {
        let mut polled = Polled::default();
        let lock = || scene.lock().unwrap_or_else(|e| e.into_inner());
        let mut next = self.depth.recv(timeout)?;
        while let Some(frame) = next {
            lock().push_depth(*frame.header(), frame.pixels(), frame.dropped);
            // Hand the sample back to shared memory before looking for the next one.
            drop(frame);
            polled.frames += 1;
            next = self.depth.try_recv()?;
        }
        while let Some(r) = self.skeletons.try_recv()? {
            if let Some(p) = &self.push {
                p.skeleton(&r.msg);
            }
            lock().push_skeleton(r.msg);
            polled.skeletons += 1;
        }
        while let Some(r) = self.decisions.try_recv()? {
            lock().push_decision(r.msg);
            polled.decisions += 1;
        }
        while let Some(r) = self.gestures.try_recv()? {
            if let Some(p) = &self.push {
                p.gesture(&r.msg);
            }
            lock().push_gesture(r.msg, monotonic_ns());
            polled.gestures += 1;
        }
        for (stage, rx) in self.stats.iter_mut() {
            while let Some(r) = rx.try_recv()? {
                if let Some(p) = &self.push {
                    p.stats(*stage, &r.msg);
                }
                lock().push_stats(*stage, r.msg);
            }
        }
        Ok(polled)
    }
}
