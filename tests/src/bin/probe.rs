//! `airglyph-probe`: a test subscriber. Receives depth frames from a pipeline, writes
//! them to a recording and prints one JSON line a frame, so system tests can check what
//! arrived, in what order, with which timestamps, bit for bit.

use airglyph_core::recording::{RecordingInfo, RecordingWriter};
use airglyph_core::{DepthImage, Intrinsics, Joint};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::port::Message;
use airglyph_ipc::{
    shutdown, DecisionMsg, DepthHeader, GestureEventMsg, Pipeline, Receiver, SkeletonMsg,
};
use clap::Parser;
use std::io::Write;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Parser)]
struct Args {
    /// Instead of receiving: publish this many depth frames whose header does not match
    /// their payload (a broken or hostile publisher), then exit.
    #[arg(long)]
    publish_bad: Option<u64>,
    /// Instead of receiving: publish this many valid 64x48 depth frames, each followed
    /// by 30 ms of rewriting its width in shared memory (640, 64, … each for 20 µs) after sending
    /// it, as a hostile publisher of the pipeline's own user can; then exit.
    #[arg(long)]
    tamper: Option<u64>,
    /// Instead of receiving: publish this many gesture events, --hz a second (labels
    /// 0–9 in turn, frames numbered on, stamped with their publish time), printing one
    /// line each; then exit.
    #[arg(long)]
    publish_gestures: Option<u64>,
    /// With --publish-gestures: events a second.
    #[arg(long, default_value_t = 20.0)]
    hz: f64,
    /// What to receive: depth, skeleton, gesture or decision.
    #[arg(long, default_value = "depth")]
    stream: String,
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
    if let Some(n) = args.publish_bad {
        return publish_bad(&pipeline, n);
    }
    if let Some(n) = args.tamper {
        return tamper(&pipeline, n);
    }
    if let Some(n) = args.publish_gestures {
        return publish_gestures(&pipeline, n, args.hz);
    }
    match args.stream.as_str() {
        "depth" => depth(&pipeline, &args),
        "skeleton" => messages(pipeline.skeleton_receiver()?, &args, |m: &SkeletonMsg| {
            serde_json::json!({
                "sequence": m.sequence, "session": m.session, "person_found": m.person_found == 1,
                "capture_ns": m.chain.capture_ns, "capture_publish_ns": m.chain.capture_publish_ns,
                "pose_receive_ns": m.chain.pose_receive_ns, "pose_publish_ns": m.chain.pose_publish_ns,
                "right_hand": m.joints[Joint::RightHand.index()], "head": m.joints[Joint::Head.index()],
                "joints": m.joints,
                "visible": Joint::ALL.iter().filter(|j| m.visible & (1 << j.index()) != 0)
                    .map(|j| j.name()).collect::<Vec<_>>(),
                "postures": airglyph_ipc::json::postures(&m.postures),
            })
        }),
        "gesture" => messages(
            pipeline.gesture_receiver()?,
            &args,
            |m: &GestureEventMsg| {
                serde_json::json!({
                    "label": m.label().unwrap_or("?"), "score": m.score, "start_sequence": m.start_sequence,
                    "end_sequence": m.end_sequence, "capture_ns": m.chain.capture_ns,
                    "gesture_publish_ns": m.chain.gesture_publish_ns, "bezier": m.bezier(),
                    "posture": m.posture().ok().flatten(),
                })
            },
        ),
        "decision" => messages(pipeline.decision_receiver()?, &args, |m: &DecisionMsg| {
            serde_json::json!({
                "sequence": m.sequence, "session": m.session,
                "gesture_publish_ns": m.chain.gesture_publish_ns,
                "hand": m.hand_point().map(|(h, _)| h.name()),
                "hand_point": m.hand_point().map(|(_, at)| at),
            })
        }),
        other => {
            anyhow::bail!("unknown stream {other:?}: expected depth, skeleton, gesture or decision")
        }
    }
}

fn publish_gestures(pipeline: &Pipeline, n: u64, hz: f64) -> anyhow::Result<()> {
    let publisher = pipeline.gesture_publisher()?;
    let session = monotonic_ns();
    ready()?;
    let every = Duration::from_secs_f64(1.0 / hz.max(0.1));
    for i in 0..n {
        let now = monotonic_ns();
        let mut g = GestureEventMsg {
            score: 0.9,
            start_sequence: i * 10,
            end_sequence: i * 10 + 9,
            start_ns: now,
            end_ns: now,
            session,
            chain: airglyph_ipc::LatencyChain {
                capture_ns: now,
                capture_publish_ns: now,
                pose_receive_ns: now,
                pose_publish_ns: now,
                gesture_receive_ns: now,
                gesture_publish_ns: now,
            },
            ..GestureEventMsg::default()
        };
        g.set_label(&(i % 10).to_string())?;
        publisher.send(g)?;
        println!(
            "{}",
            serde_json::json!({"sent": i, "end_sequence": g.end_sequence, "publish_ns": now})
        );
        std::io::stdout().flush()?;
        std::thread::sleep(every);
        if shutdown::requested() {
            break;
        }
    }
    Ok(())
}

fn publish_bad(pipeline: &Pipeline, n: u64) -> anyhow::Result<()> {
    let mut publisher = pipeline.depth_publisher(64 * 48)?;
    for i in 0..n {
        let now = monotonic_ns();
        // Claims 640×480 but carries 64×48 pixels.
        let mut h = DepthHeader {
            sequence: i,
            session: now,
            capture_ns: now,
            publish_ns: now,
            ..Default::default()
        };
        h.set_intrinsics(&Intrinsics::default());
        publisher.publish_raw(h, &vec![1000u16; 64 * 48])?;
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(())
}

fn tamper(pipeline: &Pipeline, n: u64) -> anyhow::Result<()> {
    let mut publisher = pipeline.depth_publisher(64 * 48)?;
    let k = Intrinsics::default().scaled_to(64, 48);
    let session = monotonic_ns();
    for i in 0..n {
        let now = monotonic_ns();
        let mut h = DepthHeader {
            sequence: i,
            session,
            capture_ns: now,
            publish_ns: now,
            ..Default::default()
        };
        h.set_intrinsics(&k);
        let sent = publisher.publish_tamperable(h, &vec![1500u16; 64 * 48])?;
        let until = Instant::now() + Duration::from_millis(30);
        // Each width held for 20 µs: a reader checking the header and reading it
        // again microseconds later sees both.
        let hold = |w: u32| {
            sent.set_width(w);
            let t = Instant::now();
            while t.elapsed() < Duration::from_micros(20) {}
        };
        while Instant::now() < until {
            hold(640);
            hold(64);
        }
    }
    Ok(())
}

fn ready() -> anyhow::Result<()> {
    println!("{}", serde_json::json!({"ready": true}));
    std::io::stdout().flush()?;
    Ok(())
}

fn messages<T: Message>(
    mut rx: Receiver<T>,
    args: &Args,
    line: impl Fn(&T) -> serde_json::Value,
) -> anyhow::Result<()> {
    ready()?;
    let mut received = 0u64;
    let mut last = Instant::now();
    while !shutdown::requested() && args.frames.is_none_or(|n| received < n) {
        let Some(r) = rx.recv(Duration::from_millis(100))? else {
            if last.elapsed().as_secs_f64() > args.idle {
                break;
            }
            continue;
        };
        last = Instant::now();
        received += 1;
        let mut v = line(&r.msg);
        v["dropped"] = r.dropped.into();
        v["receive_ns"] = r.receive_ns.into();
        println!("{v}");
        std::io::stdout().flush()?;
    }
    Ok(())
}

fn depth(pipeline: &Pipeline, args: &Args) -> anyhow::Result<()> {
    let mut rx = pipeline.depth_receiver()?;
    // Frames are written on a thread of their own: encoding a PNG can take longer than a
    // frame's period on a loaded machine, and the depth service holds only two frames a
    // subscriber, so writing in this loop would drop frames the pipeline delivered.
    let (to_writer, frames) = std::sync::mpsc::channel::<(Intrinsics, DepthImage, u64)>();
    let writer = args.out.clone().map(|dir| {
        std::thread::spawn(move || -> anyhow::Result<()> {
            let mut writer: Option<RecordingWriter> = None;
            for (k, image, source_ns) in frames {
                let w = match &mut writer {
                    Some(w) => w,
                    None => writer.insert(RecordingWriter::create(
                        &dir,
                        RecordingInfo::new(k, 30.0, "probe"),
                        false,
                    )?),
                };
                w.write_frame(image.view(), source_ns, None)?;
            }
            Ok(())
        })
    });
    // Tells the test we are subscribed.
    ready()?;
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
        if writer.is_some() {
            to_writer.send((h.intrinsics(), frame.view().to_owned(), h.source_ns))?;
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
    drop(to_writer);
    if let Some(writer) = writer {
        writer
            .join()
            .map_err(|_| anyhow::anyhow!("the recording thread panicked"))??;
    }
    Ok(())
}
