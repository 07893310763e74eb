//! The pen lifted by the hand: the drawing hand takes one posture over each symbol's
//! frames and another between, in the rendered depth and in the truth alike.

use airglyph_core::Intrinsics;
use airglyph_synth::{
    DrawSpec, HandPosture, MotionSpec, SceneConfig, ScriptedPose, SynthError, Synthesizer,
};

fn pen_scene(symbols: &str, drawing: HandPosture, between: HandPosture) -> SceneConfig {
    let mut cfg = SceneConfig {
        motion: MotionSpec::Draw(DrawSpec {
            symbols: symbols.into(),
            samples: None,
            repeat: false,
            rest: None,
        }),
        intrinsics: Intrinsics::default().scaled_to(320, 240),
        seed: 5,
        ..SceneConfig::default()
    };
    cfg.placement.distance_m = 1.4;
    cfg.hands.right.posture = Some(between);
    cfg.hands.right.drawing = Some(drawing);
    cfg
}

/// Every frame's truth says the pen's posture exactly over the symbols' frames and the
/// other one everywhere else, and the depth rendered is the very frame a hand held in
/// that posture gives.
#[test]
fn the_hand_points_while_drawing_and_opens_between() {
    let cfg = pen_scene("71", HandPosture::Point, HandPosture::Open);
    let mut pen = Synthesizer::new(cfg.clone()).unwrap();
    let held = |p: HandPosture| {
        let mut c = cfg.clone();
        c.hands.right.drawing = None;
        c.hands.right.posture = Some(p);
        Synthesizer::new(c).unwrap()
    };
    let (mut point, mut open) = (held(HandPosture::Point), held(HandPosture::Open));
    let gestures = pen.gestures();
    assert_eq!(gestures.len(), 2);
    let n = pen.len().unwrap();
    let mut seen = [0usize; 2];
    // Every third frame, and each symbol's first and last frames and their neighbours.
    let mut frames: Vec<usize> = (0..n).step_by(3).collect();
    for g in &gestures {
        frames.extend([g.start_frame - 1, g.start_frame, g.end_frame, g.end_frame + 1]);
    }
    for f in frames {
        let (depth, truth) = pen.render(f);
        let in_symbol = gestures
            .iter()
            .any(|g| (g.start_frame..=g.end_frame).contains(&f));
        assert_eq!(truth.gesture.is_some(), in_symbol, "frame {f}");
        let want = if in_symbol {
            HandPosture::Point
        } else {
            HandPosture::Open
        };
        assert_eq!(truth.hands.right.posture, Some(want), "frame {f}");
        assert_eq!(truth.hands.left.posture, None, "frame {f}");
        let same = if in_symbol { &mut point } else { &mut open };
        let (expected, expected_truth) = same.render(f);
        assert!(depth.pixels() == expected.pixels(), "frame {f}: depth differs");
        assert_eq!(truth.hands, expected_truth.hands, "frame {f}");
        seen[in_symbol as usize] += 1;
    }
    assert!(seen[0] > 10 && seen[1] > 10, "{seen:?}");
}

/// The pen's postures differ in the image: the pointing hand reaches further along the
/// fingers than the open one is wide, so the hand's pixels change at the symbol's start.
#[test]
fn the_hand_changes_shape_at_the_symbols_edges() {
    let mut s = Synthesizer::new(pen_scene("7", HandPosture::Fist, HandPosture::Open)).unwrap();
    let g = s.gestures()[0].clone();
    let hand_pixels = |s: &mut Synthesizer, f: usize| {
        s.render(f);
        s.labels()
            .iter()
            .filter(|l| **l == airglyph_synth::Bone::RightHand as u8)
            .count()
    };
    let before = hand_pixels(&mut s, g.start_frame - 1);
    let first = hand_pixels(&mut s, g.start_frame);
    let last = hand_pixels(&mut s, g.end_frame);
    let after = hand_pixels(&mut s, g.end_frame + 1);
    // A fist shows well under the open hand's pixels at the same place.
    assert!(first * 10 < before * 8, "open {before} → fist {first}");
    assert!(last * 10 < after * 8, "fist {last} → open {after}");
}

/// A recording's hands.csv gives the posture of every frame, the pen's exactly on the
/// frames gestures.csv lists.
#[test]
fn the_recordings_truth_follows_the_pen() {
    let dir = tempfile::tempdir().unwrap();
    let summary = airglyph_synth::write_recording(
        pen_scene("4", HandPosture::Point, HandPosture::Open),
        10_000,
        dir.path(),
        |_| {},
    )
    .unwrap();
    let g = &summary.gestures[0];
    let text = std::fs::read_to_string(dir.path().join("hands.csv")).unwrap();
    let mut rows = 0;
    for line in text.lines().skip(1) {
        let cols: Vec<&str> = line.splitn(4, ',').collect();
        if cols[1] != "right" {
            continue;
        }
        let f: usize = cols[0].parse().unwrap();
        let want = if (g.start_frame..=g.end_frame).contains(&f) {
            "point"
        } else {
            "open"
        };
        assert_eq!(cols[2], want, "frame {f}");
        rows += 1;
    }
    assert_eq!(rows, summary.frames);
    let csv = std::fs::read_to_string(dir.path().join("gestures.csv")).unwrap();
    assert!(
        csv.contains(&format!("4,{},{}", g.start_frame, g.end_frame)),
        "{csv}"
    );
}

/// A posture while drawing is refused, with the reason, where nothing draws, on the
/// left hand, or with no posture between symbols.
#[test]
fn a_pen_posture_that_cannot_be_is_refused() {
    let refused = |cfg: SceneConfig, says: &str| match Synthesizer::new(cfg) {
        Err(SynthError::Config(e)) => assert!(e.contains(says), "{e}"),
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("taken: {says}"),
    };
    let mut cfg = pen_scene("7", HandPosture::Point, HandPosture::Open);
    cfg.motion = MotionSpec::Pose(ScriptedPose::Wave);
    refused(cfg, "draws no symbol");
    let mut cfg = pen_scene("7", HandPosture::Point, HandPosture::Open);
    cfg.hands.right.posture = None;
    refused(cfg, "posture between symbols");
    let mut cfg = pen_scene("7", HandPosture::Point, HandPosture::Open);
    cfg.hands.left = cfg.hands.right;
    refused(cfg, "only the right hand draws");
}
