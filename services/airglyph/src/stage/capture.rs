//! `airglyph stage capture`: publishes depth frames from a source on `airglyph/depth`.

use airglyph_capture::{Pacing, SourceError, SourceOptions, SourceSpec};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::port::PublishError;
use airglyph_ipc::stats::Telemetry;
use airglyph_ipc::{shutdown, LatencyChain, Pipeline, SkeletonMsg, Stage};
use anyhow::Context;

/// The capture stage: reads depth frames from a source and publishes each one, written
/// once into shared memory, on the iceoryx2 service `airglyph/depth`.
///
/// The pipeline it joins is set by AIRGLYPH_IPC_ROOT / AIRGLYPH_IPC_PREFIX (or the
/// config file named by AIRGLYPH_CONFIG). Normally started by `airglyph run`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Where frames come from: synthetic, recording:DIR, v4l2:/dev/videoN, openni2 (the first device) or openni2:URI.
    #[arg(long, default_value = "synthetic")]
    source: SourceSpec,
    /// Replay a recording as fast as possible instead of at its recorded times.
    #[arg(long)]
    fast: bool,
    /// Start a recording again from its first frame when it ends.
    #[arg(long = "loop")]
    looping: bool,
    /// Stop after this many frames.
    #[arg(long)]
    frames: Option<u64>,
    /// Also publish the ground-truth skeleton of each frame on `airglyph/skeleton`, in
    /// place of the pose stage (synthetic sources, and recordings with joints.csv): the
    /// gesture stage then sees exact joints. Do not run the pose stage beside it.
    #[arg(long)]
    truth_skeletons: bool,
    /// Fault injection for tests: fail after publishing this many frames (a stage that
    /// dies seconds after every start, for the supervisor's crash-loop rule).
    #[arg(long, hide = true, value_name = "FRAMES")]
    fail_after: Option<u64>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let opts = SourceOptions {
        pacing: if args.fast {
            Pacing::Fast
        } else {
            Pacing::Realtime
        },
        looping: args.looping,
    };
    let mut source = airglyph_capture::open(&args.source, &opts)
        .with_context(|| format!("cannot open source {}", args.source))?;
    let k = source.intrinsics();
    let pixels = k.width as usize * k.height as usize;
    let pipeline = Pipeline::join("capture")?;
    let mut publisher = pipeline.depth_publisher(pixels)?;
    let truth = if args.truth_skeletons {
        Some(pipeline.skeleton_publisher()?)
    } else {
        None
    };
    let mut telemetry = Telemetry::new(&pipeline, Stage::Capture)?;
    tracing::info!(source = %source.describe(), width = k.width, height = k.height, fps = source.fps(), "capturing");

    let mut skipped = 0u64;
    while !shutdown::requested() && args.frames.is_none_or(|n| publisher.sequence() < n) {
        let result = publisher.publish(pixels, |header, out| {
            let frame = source.next_frame(out)?;
            if let Some(f) = frame {
                header.set_intrinsics(&k);
                header.capture_ns = if f.capture_ns == 0 {
                    monotonic_ns()
                } else {
                    f.capture_ns
                };
                header.source_ns = f.source_ns;
                header.source_kind = source.kind() as u32;
            }
            Ok::<_, SourceError>(frame.is_some())
        });
        match result {
            Ok(Some(sent)) => {
                // Capture's own work (decode, render, readout) is its whole latency.
                let took = sent.publish_ns - sent.capture_ns;
                telemetry.input(0, 0);
                telemetry.output(took, took);
                if let Some(skeletons) = &truth {
                    let now = monotonic_ns();
                    let mut msg = SkeletonMsg {
                        sequence: sent.sequence,
                        session: sent.session,
                        chain: LatencyChain {
                            pose_receive_ns: now,
                            pose_publish_ns: now,
                            ..LatencyChain::of_frame(&sent)
                        },
                        ..SkeletonMsg::default()
                    };
                    msg.set_skeleton(source.last_truth().as_ref());
                    skeletons.send(msg)?;
                }
            }
            Ok(None) => {
                tracing::info!(frames = publisher.sequence(), skipped, "end of source");
                break;
            }
            Err(PublishError::Source(SourceError::Skipped(reason))) => {
                skipped += 1;
                telemetry.set_rejected(skipped);
                tracing::warn!(skipped, "{reason}");
            }
            Err(PublishError::Source(e @ SourceError::Fatal(_))) => return Err(e.into()),
            Err(e @ PublishError::Transport(_)) => return Err(anyhow::anyhow!("{e}")),
        }
        telemetry.tick();
        if args.fail_after.is_some_and(|n| publisher.sequence() >= n) {
            anyhow::bail!(
                "failing after {} frames, as --fail-after asks",
                publisher.sequence()
            );
        }
    }
    // Let subscribers take the last frames before our shared memory goes away.
    std::thread::sleep(std::time::Duration::from_millis(100));
    Ok(())
}
