//! `airglyph record`: writes a recording from any source.

use airglyph_capture::{Pacing, SourceError, SourceOptions, SourceSpec};
use airglyph_core::recording::{RecordingInfo, RecordingWriter};
use airglyph_ipc::shutdown;
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

/// Record depth frames from a source into a recording directory (recording.toml,
/// depth/NNNNNN.png, frames.csv, and joints.csv when the source knows the true skeleton).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Where frames come from: synthetic, recording:DIR, v4l2:/dev/videoN, openni2 (the first device) or openni2:URI.
    #[arg(long)]
    source: SourceSpec,
    /// The recording directory to create.
    #[arg(long)]
    out: PathBuf,
    /// Stop after this many frames (default: until the source ends or Ctrl-C).
    #[arg(long)]
    frames: Option<u64>,
    /// Take frames as fast as the source gives them, not at its frame rate.
    #[arg(long)]
    fast: bool,
    /// Also record the depth stream to this .oni file through OpenNI2's own recorder
    /// (openni2 sources only; play it back with --source openni2:FILE.oni).
    #[arg(long, value_name = "FILE.oni")]
    oni: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    shutdown::install();
    let opts = SourceOptions {
        pacing: if args.fast {
            Pacing::Fast
        } else {
            Pacing::Realtime
        },
        looping: false,
    };
    let mut source = match &args.oni {
        Some(oni) => airglyph_capture::open_recording_oni(&args.source, &opts, oni),
        None => airglyph_capture::open(&args.source, &opts),
    }
    .with_context(|| format!("cannot open source {}", args.source))?;
    let k = source.intrinsics();
    let mut px = vec![0u16; k.width as usize * k.height as usize];
    // The first frame tells whether this source has ground truth to record.
    let mut pending = loop {
        match source.next_frame(&mut px) {
            Ok(f) => break f,
            Err(SourceError::Skipped(reason)) => tracing::warn!("{reason}"),
            Err(e) => return Err(e.into()),
        }
    };
    let with_joints = pending.is_some() && source.last_truth().is_some();
    let info = RecordingInfo::new(k, source.fps(), source.describe());
    let mut writer = RecordingWriter::create(&args.out, info, with_joints)?;
    let bar = match args.frames {
        Some(n) => ProgressBar::new(n),
        None => ProgressBar::new_spinner(),
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} recording {pos}/{len} frames [{elapsed}] {msg}")
            .expect("static template"),
    );
    let mut skipped = 0u64;
    while let Some(frame) = pending {
        let view = airglyph_core::DepthView::new(k.width, k.height, &px)?;
        let truth = if with_joints {
            source.last_truth()
        } else {
            None
        };
        writer.write_frame(view, frame.source_ns, truth.as_ref())?;
        bar.inc(1);
        if shutdown::requested()
            || args
                .frames
                .is_some_and(|n| writer.frames_written() as u64 >= n)
        {
            break;
        }
        pending = loop {
            match source.next_frame(&mut px) {
                Ok(f) => break f,
                Err(SourceError::Skipped(reason)) => {
                    skipped += 1;
                    bar.set_message(format!("{skipped} skipped"));
                    tracing::warn!("{reason}");
                }
                Err(e) => return Err(e.into()),
            }
        };
    }
    bar.finish_and_clear();
    // Dropping the source stops an OpenNI2 recorder, which writes the .oni's frame count.
    drop(source);
    if let Some(oni) = &args.oni {
        eprintln!("recorded the OpenNI2 stream to {}", oni.display());
    }
    eprintln!(
        "recorded {} frames to {}{}",
        writer.frames_written(),
        args.out.display(),
        if skipped > 0 {
            format!(" ({skipped} unreadable frames skipped)")
        } else {
            String::new()
        }
    );
    Ok(())
}
