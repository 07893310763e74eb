//! `airglyph spot DIR`: the gesture stage's spotter over a recording, offline.

use crate::interrupt::Interrupted;
use crate::stage::gesture::wire_hand;
use airglyph_core::gestures::{drawn_for, read_gestures_csv};
use airglyph_core::recording::Recording;
use airglyph_core::{Joint, Skeleton};
use airglyph_gesture::{Model, ModelSource, Spotter, SpotterConfig};
use airglyph_ipc::json::GestureLine;
use airglyph_ipc::shutdown;
use airglyph_pose::{PoseConfig, PoseEstimator};
use anyhow::Context;
use std::path::{Path, PathBuf};

/// Find the gestures drawn in a recording: the pose estimator on every frame (or the
/// recording's ground-truth joints with --truth), then the spotter. When the recording
/// has a gestures.csv (synthetic air-drawing), each spotted gesture is shown beside the
/// symbol drawn.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording directory.
    dir: PathBuf,
    /// Use the recording's joints.csv instead of estimating the pose.
    #[arg(long, conflicts_with = "poses")]
    truth: bool,
    /// Use skeletons estimated before (the output of `airglyph pose DIR --json`, one
    /// frame a line) instead of estimating the pose again.
    #[arg(long, value_name = "FILE")]
    poses: Option<PathBuf>,
    /// The gesture model (default: $AIRGLYPH_MODEL, else the built-in 36-symbol model).
    #[arg(long)]
    model: Option<PathBuf>,
    /// One JSON object a line: each gesture ({"event":"gesture","label":…; README, "JSON
    /// output"), with --alone each drawn symbol's label alone ({"event":"alone",…}), and
    /// when the drawn symbols are known the summary ({"event":"summary",…}).
    #[arg(long)]
    json: bool,
    /// Spotter settings as JSON (fields of SpotterConfig), e.g. '{"hold_seconds":1.0}'.
    #[arg(long)]
    spotter: Option<String>,
    /// Print every segment the spotter weighed (frames, label, classifier score,
    /// verifier probability, Lee & Kim ratio, accepted) to stderr.
    #[arg(long)]
    trace: bool,
    /// Also classify each drawn symbol's own frames (from gestures.csv) alone, to tell
    /// spotting errors from classification errors.
    #[arg(long)]
    alone: bool,
}

/// The skeletons of `airglyph pose DIR --json` (None where no person was found).
fn read_poses(path: &Path) -> anyhow::Result<Vec<Option<Skeleton>>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let bad = |what: &str| anyhow::anyhow!("{}:{}: {what}", path.display(), i + 1);
        let v: serde_json::Value = serde_json::from_str(line).map_err(|e| bad(&e.to_string()))?;
        let frame = v["frame"].as_u64().ok_or_else(|| bad("no frame"))? as usize;
        if frame != out.len() {
            return Err(bad("frames out of order"));
        }
        if !v["person_found"].as_bool().unwrap_or(false) {
            out.push(None);
            continue;
        }
        let mut joints = [nalgebra::Point3::origin(); Joint::COUNT];
        let mut confidence = [0.0f32; Joint::COUNT];
        for j in Joint::ALL {
            let p = v["joints"][j.name()]
                .as_array()
                .filter(|a| a.len() == 3)
                .ok_or_else(|| bad(&format!("no joint {}", j.name())))?;
            let c = |k: usize| p[k].as_f64().unwrap_or(f64::NAN) as f32;
            joints[j.index()] = nalgebra::Point3::new(c(0), c(1), c(2));
            confidence[j.index()] = v["confidence"][j.name()].as_f64().unwrap_or(0.0) as f32;
        }
        let mut s = Skeleton::new(joints);
        s.confidence = confidence;
        out.push(Some(s));
    }
    Ok(out)
}

fn trace(candidates: &[airglyph_gesture::Candidate], model: &Model) {
    for c in candidates {
        eprintln!(
            "segment {}–{}: {} score {:.2} p(gesture) {:.2} Lee&Kim {:+.2}{}",
            c.start_seq,
            c.end_seq,
            model.labels[c.class],
            c.score,
            c.p_gesture,
            c.ratio,
            if c.accepted { " accepted" } else { "" }
        );
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let rec = Recording::open(&args.dir)?;
    if args.truth && !rec.has_joints() {
        anyhow::bail!("{}: --truth needs a joints.csv", args.dir.display());
    }
    let model = ModelSource::choose(args.model.as_deref()).load()?;
    let scfg = SpotterConfig::with_overrides(args.spotter.as_deref()).context("--spotter")?;
    let mut spotter = Spotter::new(model, scfg)?;
    spotter.set_trace(args.trace);
    let k = rec.intrinsics();
    let mut estimator = PoseEstimator::new(k, PoseConfig::default());
    let mut px = vec![0u16; k.width as usize * k.height as usize];
    let truth_path = args.dir.join("gestures.csv");
    let truth = if truth_path.exists() {
        read_gestures_csv(&truth_path)?
    } else {
        Vec::new()
    };
    let mut recognized = vec![None; truth.len()];
    let mut spotted = 0;
    // The hand as the spotter sees it, by frame, for --alone.
    let mut tracker = airglyph_gesture::HandTracker::new(scfg.tracker);
    let mut hand: Vec<Option<[f32; 3]>> = Vec::new();
    let mut found = Vec::new();
    let poses = args.poses.as_deref().map(read_poses).transpose()?;
    eprintln!(
        "spotting gestures in {} ({} frames, {})",
        args.dir.display(),
        rec.len(),
        match (&args.poses, args.truth) {
            (Some(p), _) => format!("the skeletons of {}", p.display()),
            (None, true) => "its ground-truth joints".into(),
            (None, false) => "the pose estimated frame by frame".into(),
        }
    );
    let mut stopped = None;
    for i in 0..rec.len() {
        if shutdown::requested() {
            stopped = Some(i);
            break;
        }
        let skeleton = if let Some(p) = &poses {
            p.get(i).copied().flatten()
        } else if args.truth {
            rec.joints(i).copied()
        } else {
            rec.read_frame_into(i, &mut px)?;
            let r = estimator.estimate(airglyph_core::DepthView::new(k.width, k.height, &px)?);
            r.person_found.then_some(r.skeleton)
        };
        let Some(s) = skeleton else {
            hand.push(None);
            continue;
        };
        hand.push(
            tracker
                .update(&s, rec.capture_ns(i))
                .map(|p| [p.x, p.y, p.z]),
        );
        found.extend(spotter.push(&s, i as u64, rec.capture_ns(i)));
        trace(&spotter.take_trace(), spotter.model());
    }
    if stopped.is_none() {
        found.extend(spotter.finish());
        trace(&spotter.take_trace(), spotter.model());
    }
    for g in found {
        spotted += 1;
        let drawn = drawn_for(&truth, g.start_seq, g.end_seq);
        if let Some(d) = drawn {
            recognized[d].get_or_insert(g.label.clone());
        }
        let drawn = drawn.map(|d| truth[d].label.as_str());
        if args.json {
            let line = GestureLine::offline(
                &g.label,
                g.score,
                [g.start_seq, g.end_seq],
                wire_hand(g.hand),
                [g.start_ns, g.end_ns],
            );
            // Beside the symbol drawn there when the recording says what was drawn.
            let line = if truth.is_empty() {
                line
            } else {
                line.drawn(drawn)
            };
            println!("{}", line.line());
        } else {
            println!(
                "frames {}–{}: {} (score {:.2}){}",
                g.start_seq,
                g.end_seq,
                g.label,
                g.score,
                drawn.map_or(String::new(), |d| format!("   drawn: {d}"))
            );
        }
    }
    if let Some(i) = stopped {
        return Err(Interrupted::new(format!(
            "stopped at frame {i} of {}: the gestures spotted before it are printed; no summary",
            rec.len()
        ))
        .into());
    }
    if args.alone {
        for t in &truth {
            let pts: Vec<[f32; 3]> = (t.start_frame..=t.end_frame)
                .filter_map(|i| hand.get(i).copied().flatten())
                .collect();
            if pts.len() < 2 {
                continue;
            }
            // With its depth: a model of 2-D gestures does not read it.
            let c = spotter
                .model()
                .classify(&airglyph_gesture::Trajectory::from_points3(&pts));
            let label = &spotter.model().labels[c.class];
            if args.json {
                println!(
                    "{}",
                    serde_json::json!({"event": "alone", "drawn": t.label, "label": label,
                        "score": c.score, "start_frame": t.start_frame, "end_frame": t.end_frame})
                );
            } else {
                println!(
                    "drawn {} (frames {}–{}) alone: {label} (score {:.2})",
                    t.label, t.start_frame, t.end_frame, c.score
                );
            }
        }
    }
    if !truth.is_empty() {
        let correct = truth
            .iter()
            .zip(&recognized)
            .filter(|(t, r)| r.as_deref() == Some(t.label.as_str()))
            .count();
        let summary = serde_json::json!({"event": "summary", "drawn": truth.len(),
            "correct": correct, "spotted": spotted});
        if args.json {
            println!("{summary}");
        } else {
            println!(
                "{correct} of {} drawn symbols recognized ({spotted} gestures spotted)",
                truth.len()
            );
        }
    }
    Ok(())
}
