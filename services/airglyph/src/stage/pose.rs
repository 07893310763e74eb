//! `airglyph stage pose`: the pose stage process. Subscribes to depth frames, publishes a
//! skeleton for each frame it takes (person-found false when there is none) and its stats.

use airglyph_core::recording::Recording;
use airglyph_core::{DepthView, Intrinsics};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::stats::Telemetry;
use airglyph_ipc::wire::{DepthHeader, LatencyChain};
use airglyph_ipc::{shutdown, Pipeline, SkeletonMsg, Stage};
use airglyph_pose::{PoseConfig, PoseEstimator};
use std::path::PathBuf;
use std::time::Duration;

/// The pose stage: a 16-joint skeleton from each depth frame by geodesic distances.
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

fn skeleton_msg(h: &DepthHeader, receive_ns: u64, r: &airglyph_pose::PoseResult) -> SkeletonMsg {
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
    msg
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let pipeline = Pipeline::join("pose")?;
    let publisher = pipeline.skeleton_publisher()?;
    let mut telemetry = Telemetry::new(&pipeline, Stage::Pose)?;
    let mut stage = CameraEstimator { estimator: None };

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
            let r = stage.estimate(k, DepthView::new(k.width, k.height, &px)?, capture_ns);
            let mut msg = skeleton_msg(&h, receive_ns, &r);
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
        let r = stage.estimate(h.intrinsics(), frame.view(), h.capture_ns);
        let mut msg = skeleton_msg(&h, frame.receive_ns, &r);
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
