//! `airglyph-probe`: a test subscriber. Receives depth frames from a pipeline, writes
//! them to a recording and prints one JSON line a frame, so system tests can check what
//! arrived, in what order, with which timestamps, bit for bit.

use airglyph_core::recording::{RecordingInfo, RecordingWriter};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::{shutdown, Pipeline};
use clap::Parser;
use std::io::Write;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Parser)]
struct Args {
    /// Write received frames here as a recording (frames.csv carries the source times).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Exit after this many frames.
    #[arg(long)]
    frames: Option<u64>,
    /// Exit when no frame came for this many seconds.
    #[arg(long, default_value_t = 10.0)]
    idle: f64,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    shutdown::install();
    let pipeline = Pipeline::join("probe")?;
    let mut rx = pipeline.depth_receiver()?;
    // Tells the test we are subscribed.
    println!("{}", serde_json::json!({"ready": true}));
    std::io::stdout().flush()?;
    let mut writer: Option<RecordingWriter> = None;
    let mut received = 0u64;
    let mut last = Instant::now();
    while !shutdown::requested() && args.frames.is_none_or(|n| received < n) {
        let Some(frame) = rx.recv(Duration::from_millis(100))? else {
            if last.elapsed().as_secs_f64() > args.idle {
                break;
            }
            continue;
        };
        last = Instant::now();
        let h = *frame.header();
        if let Some(dir) = &args.out {
            if writer.is_none() {
                writer = Some(RecordingWriter::create(
                    dir,
                    RecordingInfo::new(h.intrinsics(), 30.0, "probe"),
                    false,
                )?);
            }
            writer
                .as_mut()
                .expect("created above")
                .write_frame(frame.view(), h.source_ns, None)?;
        }
        received += 1;
        let line = serde_json::json!({
            "sequence": h.sequence, "session": h.session, "capture_ns": h.capture_ns,
            "publish_ns": h.publish_ns, "source_ns": h.source_ns, "receive_ns": frame.receive_ns,
            "now_ns": monotonic_ns(), "dropped": frame.dropped, "rejected": rx.rejected(),
        });
        println!("{line}");
        std::io::stdout().flush()?;
    }
    Ok(())
}
