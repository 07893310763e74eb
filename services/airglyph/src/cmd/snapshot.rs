//! `airglyph snapshot`: the viewer's picture of the running pipeline, as a PNG file.

use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::{options, shutdown, Pipeline};
use airglyph_viewer::render::{encode_png, render};
use airglyph_viewer::{Feed, Scene};
use anyhow::{bail, Context};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Write what the camera sees to a PNG, as the viewer's page shows it: the depth image
/// colour-mapped, the skeleton, the drawing hand's trail with its Bezier points, and
/// the gestures recognized while it watched. For a device without a browser.
///
/// Joins the running pipeline (start one with `airglyph run`), watches it for --watch
/// seconds from the first frame (the trail needs some frames) until a frame arrives
/// together with its skeleton, and fails after --timeout without a frame.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The PNG to write.
    #[arg(long)]
    out: PathBuf,
    /// Seconds to wait for the first depth frame before giving up (up to an hour).
    #[arg(long, default_value_t = 5.0, value_parser = options::seconds_or_zero(3600.0), allow_negative_numbers = true)]
    timeout: f64,
    /// Seconds to watch from the first frame, so the picture has a trail (up to an hour).
    #[arg(long, default_value_t = 1.0, value_parser = options::seconds_or_zero(3600.0), allow_negative_numbers = true)]
    watch: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    shutdown::install();
    let pipeline = Pipeline::join("snapshot")?;
    let mut feed = Feed::new(&pipeline)?;
    let scene = Mutex::new(Scene::new());
    let started = Instant::now();
    let timeout = Duration::from_secs_f64(args.timeout);
    let watch = Duration::from_secs_f64(args.watch);
    let mut first_frame: Option<Instant> = None;
    loop {
        feed.poll(&scene, Duration::from_millis(50))?;
        let s = scene.lock().unwrap_or_else(|e| e.into_inner());
        if first_frame.is_none() && s.has_frame() {
            first_frame = Some(Instant::now());
        }
        let watched = first_frame.is_some_and(|t| t.elapsed() >= watch);
        // A skeleton can only be waited for while the timeout allows: without a pose
        // stage the picture is the depth image alone.
        if (watched && s.has_skeleton_frame())
            || (first_frame.is_some() && started.elapsed() >= timeout.max(watch))
            || shutdown::requested()
        {
            break;
        }
        if first_frame.is_none() && started.elapsed() >= timeout {
            bail!(
                "no depth frame within {:.1} s: is a pipeline running? (start one with `airglyph run`; the same AIRGLYPH_IPC_* settings select it)",
                args.timeout
            );
        }
    }
    let s = scene.lock().unwrap_or_else(|e| e.into_inner());
    let Some(p) = s.picture(monotonic_ns()) else {
        bail!("stopped before a depth frame arrived");
    };
    if p.overlay.skeleton.is_none() {
        tracing::warn!("no skeleton came with the frames: is the pose stage running? the picture shows depth only");
    }
    let img = render(p.frame.view(), &p.intrinsics, &p.overlay);
    let png = encode_png(&img).context("cannot encode the picture")?;
    std::fs::write(&args.out, png)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    println!(
        "{}: frame {}, {}x{}, {}",
        args.out.display(),
        p.frame.header.sequence,
        img.width(),
        img.height(),
        if p.overlay.skeleton.is_some() {
            "with its skeleton"
        } else {
            "no skeleton"
        }
    );
    Ok(())
}
