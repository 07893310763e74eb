//! `airglyph collect`: records a person drawing one gesture again and again, for a
//! vocabulary of one's own; every repetition becomes a line of trajectory JSONL. With
//! `--posture`, a hand held in a posture instead ([`posture`]).

mod posture;

use crate::interrupt::Interrupted;
use crate::pipeline::PipelineArgs;
use airglyph::supervisor::{supervise, Listener, ListenerError, Poll, NODE};
use airglyph_capture::SourceSpec;
use airglyph_gesture::lab::{RepetitionConfig, RepetitionSegmenter};
use airglyph_gesture::model::MAX_LABEL_BYTES;
use airglyph_ipc::{options, Pipeline, Receiver, SkeletonMsg};
use anyhow::{bail, Context};
use std::fs::File;
use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

/// Most repetitions one session records (a synthetic source draws them all in one
/// script, made before the first frame).
const MAX_COUNT: usize = 10_000;

/// Record a gesture of your own, drawn again and again, as trajectory JSONL.
///
/// Draw it --count times in front of the camera, letting the hand come to rest between
/// repetitions (lowered, or held still in the air), and draw with the hand held out in
/// front of you.
///
/// Capture and pose run as child processes, as with `airglyph run`. A repetition is
/// the movement between two rests; of it, the part made with the hand held forward is
/// kept (the travel from and back to a lowered hand is not), and movement that never
/// reaches forward is ignored. Each repetition is appended to --out as one line of
/// trajectory JSONL (body-frame points in shoulder widths, x right, y down, with the
/// time in ms), written and flushed at once, so an interrupted session loses nothing.
/// Progress goes to stderr. `airglyph train --data FILE …` takes the file.
///
/// With --posture NAME instead of --label: hold the hand in a posture (a static hand
/// shape: open, fist, a pointing finger, …) in front of the camera, turning it a little
/// and coming nearer and going farther now and then. Of each skeleton the pose stage
/// estimates, the --hand is cut out of the depth frame it came from, at most one
/// every --every frames, and its features appended to --out as a line of posture
/// sample JSONL (label, subject, hand, its depth in metres, the features), written and
/// flushed at once; --count hands are recorded. `airglyph train --postures FILE …`
/// takes the file. Without --source, a posture of the synthetic hand (open, fist,
/// point, thumb-up, v, pinch) is held by the synthetic person (`synthetic:posture:NAME`:
/// the right hand raised, at 1–2.5 m and six turns of the wrist).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The gesture's name: any text up to 32 bytes (UTF-8).
    #[arg(long, required_unless_present = "posture", conflicts_with = "posture")]
    label: Option<String>,
    /// Record a hand posture of this name (up to 16 bytes, UTF-8) instead of a gesture.
    #[arg(long, value_name = "NAME")]
    posture: Option<String>,
    /// With --posture: the person's hand to record.
    #[arg(long, default_value = "right", value_parser = ["left", "right"], requires = "posture")]
    hand: String,
    /// With --posture: at most one hand every this many frames (1–1000), so that the
    /// samples are not all alike.
    #[arg(long, default_value_t = 3, value_parser = options::within(1u64, 1000), allow_negative_numbers = true, requires = "posture")]
    every: u64,
    /// How many repetitions (or hands, with --posture) to record (1–10000).
    #[arg(long, value_parser = options::within(1usize, MAX_COUNT), allow_negative_numbers = true)]
    count: usize,
    /// The trajectory JSONL (posture sample JSONL with --posture) file to append to
    /// (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Where frames come from: v4l2:/dev/videoN, openni2 or openni2:URI, recording:DIR,
    /// synthetic:draw:SYMBOLS or synthetic:posture:NAME. Default for a built-in symbol
    /// (0–9, A–Z): the synthetic person drawing it --count times; for a posture of the
    /// synthetic hand: the synthetic person holding it.
    #[arg(long)]
    source: Option<SourceSpec>,
    /// Who draws (the `subject` field; keeps writers apart in cross-validation).
    #[arg(long, default_value = "me")]
    subject: String,
    /// Skip pose estimation: record the ground-truth skeletons of a synthetic source
    /// or of a recording with joints.csv.
    #[arg(long)]
    truth: bool,
}

/// Finds repetitions and appends each to the file.
struct Writer {
    seg: RepetitionSegmenter,
    file: File,
    label: String,
    subject: String,
    source: String,
    count: usize,
    written: usize,
}

/// Hands the pipeline's skeletons to the writer while the stages run.
struct Collector<'a> {
    rx: Receiver<SkeletonMsg>,
    w: &'a mut Writer,
}

impl Writer {
    /// Appends one repetition: x, y and t of each point in `points`, with the depth of
    /// each in `depth`, as 3-D points `[x, y, z, t]` (`"dims":3`).
    fn write(&mut self, points: &[[f32; 3]], depth: &[f32]) -> anyhow::Result<()> {
        let stroke: Vec<[f64; 4]> = points
            .iter()
            .zip(depth)
            .map(|(p, z)| {
                // Millimetre-level rounding keeps the lines short.
                let r = |v: f32, k: f64| (v as f64 * k).round() / k;
                [r(p[0], 1e4), r(p[1], 1e4), r(*z, 1e4), r(p[2], 10.0)]
            })
            .collect();
        let line = serde_json::json!({
            "label": self.label,
            "subject": self.subject,
            "source": self.source,
            "dims": 3,
            "strokes": [stroke],
        });
        writeln!(self.file, "{line}")?;
        self.file.flush()?;
        self.file.sync_data()?;
        self.written += 1;
        eprintln!(
            "repetition {}/{} recorded ({} points, {:.1} s)",
            self.written,
            self.count,
            points.len(),
            points.last().map_or(0.0, |p| p[2] / 1000.0)
        );
        Ok(())
    }
}

impl Listener for Collector<'_> {
    fn poll(&mut self, timeout: Duration) -> Result<Poll, ListenerError> {
        let Some(r) = self.rx.recv(timeout)? else {
            return Ok(Poll::Idle);
        };
        let msg = r.msg;
        let w = &mut *self.w;
        if let Some(rep) = msg
            .skeleton()
            .and_then(|s| w.seg.push(&s, msg.sequence, msg.chain.capture_ns))
        {
            w.write(&rep.points, &rep.depth)?;
        }
        Ok(if w.written >= w.count {
            Poll::Done
        } else {
            Poll::Handled
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let label = match (&args.label, &args.posture) {
        (_, Some(posture)) => return posture::run(&args, posture),
        (Some(label), None) => label.clone(),
        (None, None) => bail!("--label or --posture is needed"),
    };
    gesture(&args, &label)
}

/// Records repetitions of the gesture `label`.
fn gesture(args: &Args, label: &str) -> anyhow::Result<()> {
    if label.is_empty() {
        bail!("--label must not be empty");
    }
    if label.len() > MAX_LABEL_BYTES {
        bail!(
            "--label {:?} is {} bytes long; labels are at most {MAX_LABEL_BYTES} bytes (UTF-8), the size of a gesture event's label",
            label,
            label.len()
        );
    }
    let source = match args.source.clone() {
        Some(s) => s,
        // A gesture of the 3-D vocabulary, drawn in depth by the synthetic person.
        None if airglyph_synth::shapes3d::shape(label).is_some() => {
            let script = vec![label; args.count].join(",");
            SourceSpec::Synthetic(Some(format!("draw:{script}")))
        }
        None => {
            let c = label.chars().next().unwrap_or(' ');
            if label.chars().count() != 1
                || !airglyph_synth::glyphs::BUILT_IN.contains(c.to_ascii_uppercase())
            {
                bail!(
                    "--label {:?} has no built-in synthetic drawing (0–9, A–Z, or a gesture of the 3-D vocabulary: {}); give --source (e.g. v4l2:/dev/video0)",
                    label,
                    airglyph_synth::shapes3d::VOCABULARY.join(", ")
                );
            }
            let script: String = std::iter::repeat_n(c, args.count).collect();
            SourceSpec::Synthetic(Some(format!("draw:{script}")))
        }
    };
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&args.out)
        .with_context(|| format!("{}: cannot open for appending", args.out.display()))?;
    eprintln!(
        "recording {} repetitions of {:?} from {source} into {}; rest the hand between repetitions",
        args.count,
        label,
        args.out.display()
    );
    let plan = PipelineArgs {
        stages: vec!["capture".into(), "pose".into()],
        truth: args.truth,
        ..PipelineArgs::with_source(source.clone())
    }
    .plan()?;
    let mut c = Writer {
        seg: RepetitionSegmenter::new(RepetitionConfig::default()),
        file,
        label: label.to_string(),
        subject: args.subject.clone(),
        source: "airglyph collect".into(),
        count: args.count,
        written: 0,
    };
    supervise(&plan, Pipeline::join(NODE)?, |pipeline| {
        Ok(Collector {
            rx: pipeline.skeleton_receiver()?,
            w: &mut c,
        })
    })?;
    if c.written < c.count && airglyph_ipc::shutdown::requested() {
        return Err(Interrupted::new(format!(
            "{} of {} repetitions were recorded (appended to {}, each line whole)",
            c.written,
            c.count,
            args.out.display()
        ))
        .into());
    }
    // A finished source may stop in the middle of the last movement.
    if c.written < c.count {
        if let Some(rep) = c.seg.finish() {
            c.write(&rep.points, &rep.depth)?;
        }
    }
    if c.written < args.count {
        bail!(
            "the source ended after {} of {} repetitions (appended to {})",
            c.written,
            args.count,
            args.out.display()
        );
    }
    eprintln!(
        "{} repetitions appended to {}",
        c.written,
        args.out.display()
    );
    Ok(())
}
