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
    // From the waist up at 1.2 m, where the drawing hand is in the image.
    cfg.placement.distance_m = 1.2;
    let mut cfg = cfg.framing_upper_body().unwrap();
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
        frames.extend([
            g.start_frame - 1,
            g.start_frame,
            g.end_frame,
            g.end_frame + 1,
        ]);
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
        assert!(
            depth.pixels() == expected.pixels(),
            "frame {f}: depth differs"
        );
        assert_eq!(truth.hands, expected_truth.hands, "frame {f}");
        seen[in_symbol as usize] += 1;
    }
    assert!(seen[0] > 10 && seen[1] > 10, "{seen:?}");
    // The hand is in the image: the sameness is of a hand seen.
    let (_, t) = pen.render(gestures[0].start_frame);
    let k = pen.intrinsics();
    let (u, v) = k.project(&t.hands.right.palm_centre).unwrap();
    assert!(
        u > 0.0 && v > 0.0 && u < k.width as f32 && v < k.height as f32,
        "{u} {v}"
    );
}

/// The pen's change shows in the depth: at each edge of a symbol, the frame differs from
/// the same frame with the hand held in the posture of the other side of the edge, so the
/// sameness above is not that of two postures that render alike.
#[test]
fn the_hand_changes_shape_at_the_symbols_edges() {
    let cfg = pen_scene("7", HandPosture::Fist, HandPosture::Open);
    let mut pen = Synthesizer::new(cfg.clone()).unwrap();
    let held = |p: HandPosture| {
        let mut c = cfg.clone();
        c.hands.right.drawing = None;
        c.hands.right.posture = Some(p);
        Synthesizer::new(c).unwrap()
    };
    let (mut fist, mut open) = (held(HandPosture::Fist), held(HandPosture::Open));
    let g = pen.gestures()[0].clone();
    // Drawing in a fist, the frames set against the open hand, and the others the fist.
    for (f, drawing) in [
        (g.start_frame - 1, false),
        (g.start_frame, true),
        (g.end_frame, true),
        (g.end_frame + 1, false),
    ] {
        let other = if drawing { &mut open } else { &mut fist };
        let (a, b) = (pen.render(f).0, other.render(f).0);
        let differ = a
            .pixels()
            .iter()
            .zip(b.pixels())
            .filter(|(x, y)| x != y)
            .count();
        assert!(differ > 5, "frame {f}: {differ} pixels differ");
    }
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
