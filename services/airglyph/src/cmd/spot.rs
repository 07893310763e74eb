//! `airglyph spot DIR`: the gesture stage's spotter over a recording, offline.

use crate::interrupt::Interrupted;
use crate::stage::gesture::{parse_pen, wire_hand};
use crate::stage::postures::{self, Postures as PostureStep};
use airglyph_core::gestures::{drawn_for, read_gestures_csv};
use airglyph_core::recording::Recording;
use airglyph_core::{Joint, Skeleton};
use airglyph_gesture::{
    HandPosture, Model, ModelSource, Pen, PostureLabel, Postures, Spotter, SpotterConfig,
};
use airglyph_ipc::json::GestureLine;
use airglyph_ipc::shutdown;
use airglyph_ipc::PostureMsg;
use airglyph_pose::{PoseConfig, PoseEstimator};
use anyhow::Context;
use std::path::{Path, PathBuf};

/// Find the gestures drawn in a recording: the pose estimator on every frame (or the
/// recording's ground-truth joints with --truth), then the spotter. When the recording
/// has a gestures.csv (synthetic air-drawing), each spotted gesture is shown beside the
/// symbol drawn. With the hands' postures (the pose stage's posture step, or the
/// "postures" of --poses) the spotter can take the drawing hand's posture as the pen
/// (--pen), and each gesture says the posture it was drawn in.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording directory.
    dir: PathBuf,
    /// Use the recording's joints.csv instead of estimating the pose.
    #[arg(long, conflicts_with = "poses")]
    truth: bool,
    /// Use skeletons estimated before (the output of `airglyph pose DIR --json`, one
    /// frame a line, with its hands' postures when it has them) instead of estimating
    /// the pose again.
    #[arg(long, value_name = "FILE")]
    poses: Option<PathBuf>,
    /// What puts the pen down, as the gesture stage's --pen: motion, posture[:LABEL]
    /// (while the drawing hand holds LABEL, default point) or gated[:LABEL] (found by
    /// motion, kept when drawn in LABEL). A posture or gated pen needs the hands'
    /// postures: from the posture step (not with --truth or --postures off) or from
    /// --poses lines that carry them. Overrides a "pen" in --spotter.
    #[arg(long, value_name = "motion|posture[:LABEL]|gated[:LABEL]", value_parser = parse_pen)]
    pen: Option<Pen>,
    /// When estimating the pose here (neither --truth nor --poses): the posture step's
    /// model, as the pose stage's. builtin|off|FILE.
    #[arg(long, value_name = "builtin|off|FILE", default_value = "builtin", value_parser = PostureStep::parse)]
    postures: PostureStep,
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

/// One frame of `airglyph pose DIR --json`: its skeleton (None where no person was
/// found) and its hands' postures (None where the line carries no "postures").
type PosedFrame = (Option<Skeleton>, Option<Postures>);

/// The frames of `airglyph pose DIR --json`, in order.
fn read_poses(path: &Path) -> anyhow::Result<Vec<PosedFrame>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let bad = |what: &str| anyhow::anyhow!("{}:{}: {what}", path.display(), i + 1);
        let v: serde_json::Value = serde_json::from_str(line).map_err(|e| bad(&e.to_string()))?;
        let frame = v["frame"].as_u64().ok_or_else(|| bad("no frame"))? as usize;
        if frame != out.len() {
            return Err(bad("frames out of order"));
        }
        let postures = match v.get("postures") {
            None => None,
            Some(p) => Some(Postures {
                left: json_posture(&p["left"]).map_err(|e| bad(&format!("postures.left: {e}")))?,
                right: json_posture(&p["right"])
                    .map_err(|e| bad(&format!("postures.right: {e}")))?,
            }),
        };
        if !v["person_found"].as_bool().unwrap_or(false) {
            out.push((None, postures));
            continue;
        }
        let mut joints = [nalgebra::Point3::origin(); Joint::COUNT];
        let mut confidence = [0.0f32; Joint::COUNT];
        // A line from before joints had a visibility has every joint in view.
        let mut visible = [true; Joint::COUNT];
        for j in Joint::ALL {
            let p = v["joints"][j.name()]
                .as_array()
                .filter(|a| a.len() == 3)
                .ok_or_else(|| bad(&format!("no joint {}", j.name())))?;
            let c = |k: usize| p[k].as_f64().unwrap_or(f64::NAN) as f32;
            joints[j.index()] = nalgebra::Point3::new(c(0), c(1), c(2));
            confidence[j.index()] = v["confidence"][j.name()].as_f64().unwrap_or(0.0) as f32;
            visible[j.index()] = v["visible"][j.name()].as_bool().unwrap_or(true);
        }
        let mut s = Skeleton::new(joints);
        s.confidence = confidence;
        s.visible = visible;
        out.push((Some(s), postures));
    }
    Ok(out)
}

/// A hand's posture in a `pose --json` line: null, or {"label","confidence"}.
fn json_posture(v: &serde_json::Value) -> Result<Option<HandPosture>, String> {
    if v.is_null() {
        return Ok(None);
    }
    let label = v["label"].as_str().ok_or("no \"label\"")?;
    let confidence = v["confidence"]
        .as_f64()
        .filter(|c| (0.0..=1.0).contains(c))
        .ok_or("no \"confidence\" in [0, 1]")?;
    Ok(Some(HandPosture {
        label: PostureLabel::new(label).map_err(|e| e.to_string())?,
        confidence: confidence as f32,
    }))
}

/// Both hands' postures as the posture step gives them, for the spotter.
fn postures_of(classified: &[PostureMsg; 2]) -> Postures {
    let of = |m: &PostureMsg| {
        let p = m.get().ok().flatten()?;
        Some(HandPosture {
            label: PostureLabel::new(p.label).ok()?,
            confidence: p.confidence,
        })
    };
    Postures {
        left: of(&classified[0]),
        right: of(&classified[1]),
    }
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
    let mut scfg = SpotterConfig::with_overrides(args.spotter.as_deref()).context("--spotter")?;
    if let Some(pen) = args.pen {
        scfg.pen = pen;
    }
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
    // Where the hands' postures come from, if anywhere.
    let posture_model = args
        .postures
        .model()
        .filter(|_| poses.is_none() && !args.truth);
    let have_postures = match &poses {
        Some(p) => p.iter().any(|(_, postures)| postures.is_some()),
        None => posture_model.is_some(),
    };
    if scfg.pen != Pen::Motion && !have_postures {
        anyhow::bail!(
            "a posture or gated pen needs the hands' postures: {}",
            match (&args.poses, args.truth) {
                (Some(p), _) => format!("{} has no \"postures\" (write it with `airglyph pose DIR --json`, without --postures off)", p.display()),
                (None, true) => "--truth has none; leave it out, or give --poses".into(),
                (None, false) => "leave out --postures off".into(),
            }
        );
    }
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
        let (skeleton, hand_postures) = if let Some(p) = &poses {
            p.get(i).copied().unwrap_or_default()
        } else if args.truth {
            (rec.joints(i).copied(), None)
        } else {
            rec.read_frame_into(i, &mut px)?;
            let view = airglyph_core::DepthView::new(k.width, k.height, &px)?;
            let r = estimator.estimate(view);
            let classified = posture_model.filter(|_| r.person_found).map(|m| {
                postures_of(
                    &postures::classify_hands(m, view, &k, &r.skeleton)
                        .map(Option::unwrap_or_default),
                )
            });
            (r.person_found.then_some(r.skeleton), classified)
        };
        let Some(s) = skeleton else {
            hand.push(None);
            found.extend(spotter.no_hand());
            continue;
        };
        hand.push(
            tracker
                .update(&s, rec.capture_ns(i))
                .map(|p| [p.x, p.y, p.z]),
        );
        let postures = hand_postures.unwrap_or(Postures::NONE);
        found.extend(
            spotter
                .push_posed(&s, &postures, i as u64, rec.capture_ns(i))
                .1,
        );
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
            let line = if have_postures {
                line.posture(g.posture.as_ref().map(PostureLabel::as_str))
            } else {
                line
            };
            // Beside the symbol drawn there when the recording says what was drawn.
            let line = if truth.is_empty() {
                line
            } else {
                line.drawn(drawn)
            };
            println!("{}", line.line());
        } else {
            println!(
                "frames {}–{}: {} (score {:.2}){}{}",
                g.start_seq,
                g.end_seq,
                g.label,
                g.score,
                match (&g.posture, have_postures) {
                    (Some(p), true) => format!(", drawn {}", p.as_str()),
                    (None, true) => ", posture unknown".into(),
                    (_, false) => String::new(),
                },
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

#[cfg(test)]
mod tests {
    use super::*;

    fn poses_file(lines: &[&str]) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("poses.jsonl");
        std::fs::write(&path, lines.join("\n")).unwrap();
        (dir, path)
    }

    /// A line of `pose --json` with the right hand's posture `right` (JSON).
    fn line(frame: usize, right: &str) -> String {
        let joints: Vec<String> = Joint::ALL
            .iter()
            .map(|j| format!("\"{}\":[0.1,0.2,2.0]", j.name()))
            .collect();
        format!(
            "{{\"frame\":{frame},\"person_found\":true,\"joints\":{{{}}},\"postures\":{{\"left\":null,\"right\":{right}}}}}",
            joints.join(",")
        )
    }

    #[test]
    fn the_postures_of_pose_json_reach_the_spotter() {
        let a = line(0, r#"{"label":"point","confidence":0.75}"#);
        let b = line(1, "null");
        let (_dir, path) = poses_file(&[&a, &b, r#"{"frame":2,"person_found":false}"#]);
        let frames = read_poses(&path).unwrap();
        let right = frames[0].1.unwrap().right.unwrap();
        assert_eq!((right.label.as_str(), right.confidence), ("point", 0.75));
        assert_eq!(frames[1].1, Some(Postures::NONE));
        assert!(frames[1].0.is_some());
        // A line without "postures" (--postures off) says nothing of them.
        assert_eq!(frames[2], (None, None));
    }

    #[test]
    fn a_bad_posture_is_refused_with_its_line() {
        for (right, says) in [
            (r#"{"label":"point","confidence":1.5}"#, "confidence"),
            (r#"{"confidence":0.5}"#, "label"),
            (r#"{"label":"","confidence":0.5}"#, "postures.right"),
        ] {
            let (_dir, path) = poses_file(&[&line(0, "null"), &line(1, right)]);
            let e = read_poses(&path).unwrap_err().to_string();
            assert!(
                e.contains("poses.jsonl:2") && e.contains(says),
                "{right}: {e}"
            );
        }
    }
}
