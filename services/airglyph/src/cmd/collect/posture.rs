//! `airglyph collect --posture NAME`: records a hand held in a posture, a line of
//! posture sample JSONL a hand. Capture and pose run as for gestures; the depth frames
//! are kept a short while, and each skeleton is matched with the frame it was
//! estimated from (by capture session and sequence) so that the hand is cut out of
//! that very frame.

use super::Args;
use crate::interrupt::Interrupted;
use crate::pipeline::PipelineArgs;
use airglyph::supervisor::{supervise, Listener, ListenerError, Poll, NODE};
use airglyph_capture::synthetic::POSTURE_SCRIPT;
use airglyph_capture::SourceSpec;
use airglyph_core::Intrinsics;
use airglyph_ipc::port::{DepthFrame, DepthReceiver};
use airglyph_ipc::{Pipeline, Receiver, SkeletonMsg};
use airglyph_posture::model::check_label;
use airglyph_posture::{describe, ArmJoints, PostureSample, SegmentParams, Side};
use airglyph_synth::HandPosture;
use anyhow::{bail, Context};
use std::collections::VecDeque;
use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::time::Duration;

/// Depth frames kept for skeletons still to come: the pose stage answers within a
/// frame or two.
const KEPT_FRAMES: usize = 8;
/// Skeletons kept while their frame is not yet in (capture's own ground truth may be
/// published before the frame).
const WAITING_SKELETONS: usize = 8;

/// A depth frame copied out of shared memory.
struct Kept {
    session: u64,
    sequence: u64,
    k: Intrinsics,
    pixels: Vec<u16>,
}

/// Cuts hands out and appends them to the file.
struct Writer {
    file: File,
    label: String,
    subject: String,
    side: Side,
    every: u64,
    count: usize,
    written: usize,
    /// The capture session and sequence of the last frame a hand was taken from.
    last: Option<(u64, u64)>,
    /// Frames tried in which no hand was found.
    missed: usize,
}

impl Writer {
    /// Whether the frame is due: none taken yet in its session, or `every` frames
    /// after the last.
    fn due(&self, session: u64, sequence: u64) -> bool {
        match self.last {
            Some((s, q)) if s == session => sequence >= q + self.every,
            _ => true,
        }
    }

    /// Cuts the hand of `skeleton` out of `frame` and writes it, if due and found.
    fn take(&mut self, frame: &Kept, msg: &SkeletonMsg) -> anyhow::Result<()> {
        let Some(skeleton) = msg.skeleton() else {
            return Ok(());
        };
        // One poll may match several skeletons: never more than asked for.
        if self.written >= self.count || !self.due(frame.session, frame.sequence) {
            return Ok(());
        }
        // A frame tried counts as taken, found or not, so that a hand that cannot be
        // found is not tried every frame.
        self.last = Some((frame.session, frame.sequence));
        let view = airglyph_core::DepthView::new(frame.k.width, frame.k.height, &frame.pixels)
            .context("a depth frame of another size than its header says")?;
        let arm = ArmJoints::from_skeleton(&skeleton, self.side);
        match describe(view, &frame.k, arm, &SegmentParams::default()) {
            Ok(hand) => {
                let depth_m = hand.region.palm().centre.z;
                let sample = PostureSample::new(
                    &self.label,
                    &self.subject,
                    self.side,
                    depth_m,
                    &hand.features,
                );
                writeln!(self.file, "{}", sample.to_line())?;
                self.file.flush()?;
                self.file.sync_data()?;
                self.written += 1;
                eprintln!(
                    "hand {}/{} recorded (frame {}, {:.2} m, {} pixels)",
                    self.written,
                    self.count,
                    frame.sequence,
                    depth_m,
                    hand.region.pixels().len()
                );
            }
            Err(e) => {
                self.missed += 1;
                eprintln!("frame {}: {e}", frame.sequence);
            }
        }
        Ok(())
    }
}

/// Matches the pipeline's skeletons with their depth frames while the stages run.
struct Collector<'a> {
    depth: DepthReceiver,
    skeletons: Receiver<SkeletonMsg>,
    frames: VecDeque<Kept>,
    waiting: VecDeque<SkeletonMsg>,
    w: &'a mut Writer,
}

impl Collector<'_> {
    fn keep(&mut self, f: &DepthFrame) {
        let h = f.header();
        if self.frames.len() == KEPT_FRAMES {
            self.frames.pop_front();
        }
        self.frames.push_back(Kept {
            session: h.session,
            sequence: h.sequence,
            k: h.intrinsics(),
            pixels: f.pixels().to_vec(),
        });
    }

    /// Takes every waiting skeleton whose frame is kept; drops those whose frame is
    /// older than any kept (it was missed).
    fn match_waiting(&mut self) -> anyhow::Result<()> {
        let mut still = VecDeque::new();
        while let Some(msg) = self.waiting.pop_front() {
            let found = self
                .frames
                .iter()
                .find(|f| f.session == msg.session && f.sequence == msg.sequence);
            match found {
                Some(frame) => self.w.take(frame, &msg)?,
                None if still.len() < WAITING_SKELETONS => still.push_back(msg),
                None => {}
            }
        }
        self.waiting = still;
        Ok(())
    }
}

impl Listener for Collector<'_> {
    fn poll(&mut self, timeout: Duration) -> Result<Poll, ListenerError> {
        // Frames first, waiting for one: a skeleton always comes after its frame was
        // published, so its frame is in by the time the skeleton is looked at, or
        // comes with a later poll.
        let mut next = self.depth.recv(timeout)?;
        let idle = next.is_none();
        while let Some(f) = next {
            self.keep(&f);
            drop(f);
            next = self.depth.try_recv()?;
        }
        while let Some(r) = self.skeletons.try_recv()? {
            self.waiting.push_back(r.msg);
        }
        self.match_waiting()?;
        Ok(if self.w.written >= self.w.count {
            Poll::Done
        } else if idle {
            Poll::Idle
        } else {
            Poll::Handled
        })
    }
}

/// The source of a posture session: the one given, else the synthetic person holding
/// the posture when it is one of the synthetic hand's.
fn source(args: &Args, posture: &str) -> anyhow::Result<SourceSpec> {
    if let Some(s) = &args.source {
        return Ok(s.clone());
    }
    if HandPosture::from_name(posture).is_none() {
        let names: Vec<&str> = HandPosture::ALL.iter().map(|p| p.name()).collect();
        bail!(
            "--posture {posture:?} has no synthetic hand (the synthetic person holds {}); give --source (e.g. v4l2:/dev/video0)",
            names.join(", ")
        );
    }
    Ok(SourceSpec::Synthetic(Some(format!(
        "{POSTURE_SCRIPT}{posture}"
    ))))
}

pub fn run(args: &Args, posture: &str) -> anyhow::Result<()> {
    check_label(posture).map_err(|e| anyhow::anyhow!("--posture: {e}"))?;
    let side = match args.hand.as_str() {
        "left" => Side::Left,
        _ => Side::Right,
    };
    let source = source(args, posture)?;
    let file = open_append(&args.out)?;
    eprintln!(
        "recording {} {} hands holding {posture:?} from {source} into {} (one every {} frames)",
        args.count,
        args.hand,
        args.out.display(),
        args.every
    );
    let plan = PipelineArgs {
        stages: vec!["capture".into(), "pose".into()],
        truth: args.truth,
        ..PipelineArgs::with_source(source)
    }
    .plan()?;
    let mut w = Writer {
        file,
        label: posture.into(),
        subject: args.subject.clone(),
        side,
        every: args.every,
        count: args.count,
        written: 0,
        last: None,
        missed: 0,
    };
    supervise(&plan, Pipeline::join(NODE)?, |pipeline| {
        // The depth subscription last, as the viewer's: the others exist once it does.
        let skeletons = pipeline.skeleton_receiver()?;
        Ok(Collector {
            depth: pipeline.depth_receiver()?,
            skeletons,
            frames: VecDeque::new(),
            waiting: VecDeque::new(),
            w: &mut w,
        })
    })?;
    let missed = if w.missed > 0 {
        format!("; no hand found in {} frames tried", w.missed)
    } else {
        String::new()
    };
    if w.written < w.count && airglyph_ipc::shutdown::requested() {
        return Err(Interrupted::new(format!(
            "{} of {} hands were recorded (appended to {}, each line whole){missed}",
            w.written,
            w.count,
            args.out.display()
        ))
        .into());
    }
    if w.written < w.count {
        bail!(
            "the source ended after {} of {} hands (appended to {}){missed}",
            w.written,
            w.count,
            args.out.display()
        );
    }
    eprintln!(
        "{} hands appended to {}{missed}",
        w.written,
        args.out.display()
    );
    Ok(())
}

/// The file to append to, created if missing.
fn open_append(path: &Path) -> anyhow::Result<File> {
    std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .with_context(|| format!("{}: cannot open for appending", path.display()))
}
