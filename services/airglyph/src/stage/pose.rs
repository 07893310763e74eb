//! `airglyph stage pose`: the pose stage process. Subscribes to depth frames, publishes a
//! skeleton for each frame it takes (person-found false when there is none), with each
//! visible hand's posture classified from the same frame, and its stats.

use super::postures::{self, Postures};
use airglyph_core::recording::Recording;
use airglyph_core::{DepthView, Intrinsics};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::stats::Telemetry;
use airglyph_ipc::wire::{DepthHeader, Hand, LatencyChain};
use airglyph_ipc::{shutdown, Pipeline, PostureMsg, SkeletonMsg, Stage};
use airglyph_pose::{PoseConfig, PoseEstimator};
use std::path::PathBuf;
use std::time::Duration;

/// The pose stage: a 16-joint skeleton from each depth frame by geodesic distances, and
/// each visible hand's static posture.
///
/// The posture step runs here, not in a stage of its own, because it needs the very
/// depth frame the skeleton was estimated from, which this stage holds at that moment.
/// It classifies a hand whose joint and elbow are in view (about 2.4 ms a hand at
/// 0.8 m, under 1 ms at 2 m); --postures off leaves it out.
///
/// Takes frames from `airglyph/depth` (always the newest: a frame that waited behind a
/// slower estimate is dropped and counted, never queued) and publishes on
/// `airglyph/skeleton`. The pipeline it joins is set by AIRGLYPH_IPC_ROOT /
/// AIRGLYPH_IPC_PREFIX (or the config file named by AIRGLYPH_CONFIG). Normally started
/// by `airglyph run`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Run alone: read frames from this recording instead of the capture stage, publish
    /// their skeletons as fast as possible, then exit (to profile this stage by itself).
    #[arg(long)]
    recording: Option<PathBuf>,
    #[arg(long, value_name = "builtin|off|FILE", default_value = "builtin", value_parser = Postures::parse, help = postures::HELP)]
    postures: Postures,
}

/// One estimator for the stream; remade when the camera changes.
struct CameraEstimator {
    estimator: Option<PoseEstimator>,
}

impl CameraEstimator {
    /// The skeleton of a frame captured at `capture_ns` (paces the joints' smoothing).
    fn estimate(
        &mut self,
        k: Intrinsics,
        depth: DepthView<'_>,
        capture_ns: u64,
    ) -> airglyph_pose::PoseResult {
        if self.estimator.as_ref().is_none_or(|e| *e.intrinsics() != k) {
            tracing::info!(
                width = k.width,
                height = k.height,
                "camera changed; new estimator"
            );
            self.estimator = Some(PoseEstimator::new(k, PoseConfig::default()));
        }
        self.estimator
            .as_mut()
            .expect("made above")
            .estimate_at(depth, capture_ns as f64 * 1e-9)
    }
}

/// Time the posture step took, over the skeletons it ran on, for the log at the end.
#[derive(Default)]
struct StepTime {
    skeletons: u64,
    total_ns: u64,
    max_ns: u64,
}

impl Drop for StepTime {
    fn drop(&mut self) {
        if self.skeletons > 0 {
            tracing::info!(
                skeletons = self.skeletons,
                mean_ms = self.total_ns as f64 * 1e-6 / self.skeletons as f64,
                max_ms = self.max_ns as f64 * 1e-6,
                "posture step"
            );
        }
    }
}

/// The postures of the skeleton of `r`, classified from the frame it was estimated
/// from; none without a model or a person.
fn postures_of(
    model: Option<&airglyph_posture::PostureModel>,
    depth: DepthView<'_>,
    k: &Intrinsics,
    r: &airglyph_pose::PoseResult,
    time: &mut StepTime,
) -> [Option<PostureMsg>; 2] {
    let Some(model) = model.filter(|_| r.person_found) else {
        return [None, None];
    };
    let start = monotonic_ns();
    let out = postures::classify_hands(model, depth, k, &r.skeleton);
    let took = monotonic_ns().saturating_sub(start);
    time.skeletons += 1;
    time.total_ns += took;
    time.max_ns = time.max_ns.max(took);
    out
}

fn skeleton_msg(
    h: &DepthHeader,
    receive_ns: u64,
    r: &airglyph_pose::PoseResult,
    postures: [Option<PostureMsg>; 2],
) -> SkeletonMsg {
    let mut msg = SkeletonMsg {
        sequence: h.sequence,
        session: h.session,
        chain: LatencyChain {
            pose_receive_ns: receive_ns,
            ..LatencyChain::of_frame(h)
        },
        ..SkeletonMsg::default()
    };
    msg.set_skeleton(r.person_found.then_some(&r.skeleton));
    if r.person_found {
        let [left, right] = postures;
        msg.set_posture(Hand::Left, left);
        msg.set_posture(Hand::Right, right);
    }
    msg
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let pipeline = Pipeline::join("pose")?;
    let publisher = pipeline.skeleton_publisher()?;
    let mut telemetry = Telemetry::new(&pipeline, Stage::Pose)?;
    let mut stage = CameraEstimator { estimator: None };
    let model = args.postures.model();
    let mut step = StepTime::default();

    if let Some(dir) = args.recording {
        let rec = Recording::open(&dir)?;
        let k = rec.intrinsics();
        let mut px = vec![0u16; k.width as usize * k.height as usize];
        let session = monotonic_ns();
        for i in 0..rec.len() {
            if shutdown::requested() {
                break;
            }
            let capture_ns = monotonic_ns();
            rec.read_frame_into(i, &mut px)?;
            let mut h = DepthHeader {
                sequence: i as u64,
                session,
                capture_ns,
                ..Default::default()
            };
            h.set_intrinsics(&k);
            let receive_ns = monotonic_ns();
            h.publish_ns = receive_ns;
            let view = DepthView::new(k.width, k.height, &px)?;
            let r = stage.estimate(k, view, capture_ns);
            let postures = postures_of(model, view, &k, &r, &mut step);
            let mut msg = skeleton_msg(&h, receive_ns, &r, postures);
            msg.chain.pose_publish_ns = monotonic_ns();
            publisher.send(msg)?;
            telemetry.input(0, 0);
            telemetry.output(
                msg.chain.pose_publish_ns - receive_ns,
                msg.chain.pose_publish_ns - capture_ns,
            );
            telemetry.tick();
        }
        return Ok(());
    }

    let mut frames = pipeline.depth_receiver()?;
    tracing::info!("waiting for depth frames");
    while !shutdown::requested() {
        telemetry.tick();
        let frame = frames.latest(Duration::from_millis(100))?;
        telemetry.set_rejected(frames.rejected());
        let Some(frame) = frame else { continue };
        // One clock for the whole chain, also for a frame from another host.
        let h = frame.header().on_this_host(frame.receive_ns);
        telemetry.input(frame.receive_ns.saturating_sub(h.publish_ns), frame.dropped);
        let k = h.intrinsics();
        let r = stage.estimate(k, frame.view(), h.capture_ns);
        let postures = postures_of(model, frame.view(), &k, &r, &mut step);
        let mut msg = skeleton_msg(&h, frame.receive_ns, &r, postures);
        // Hand the frame's shared memory back before we publish.
        drop(frame);
        msg.chain.pose_publish_ns = monotonic_ns();
        publisher.send(msg)?;
        telemetry.output(
            msg.chain.pose_publish_ns - msg.chain.pose_receive_ns,
            msg.chain.pose_publish_ns.saturating_sub(h.capture_ns),
        );
    }
    Ok(())
}
