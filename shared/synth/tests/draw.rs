//! Air-drawing on the procedural body: timing, ground-truth gestures, the hand's path.

use airglyph_core::Joint;
use airglyph_synth::glyphs::{self, template};
use airglyph_synth::{DrawSpec, MotionSpec, SceneConfig, Synthesizer};
use std::io::Write;

fn draw(symbols: &str, samples: Option<std::path::PathBuf>, repeat: bool) -> SceneConfig {
    SceneConfig {
        motion: MotionSpec::Draw(DrawSpec {
            symbols: symbols.into(),
            samples,
            repeat,
            rest: None,
        }),
        seed: 3,
        ..SceneConfig::default()
    }
}

#[test]
fn every_digit_and_letter_has_a_template() {
    for c in glyphs::BUILT_IN.chars() {
        let g = template(c).unwrap_or_else(|| panic!("{c}"));
        let path = g.path();
        assert!(path.len() >= 3, "{c}");
        for p in &path {
            assert!(
                p.x > -0.06 && p.x < 1.06 && p.y > -0.06 && p.y < 1.06,
                "{c}: {p:?}"
            );
        }
    }
    assert!(template('#').is_none());
    assert_eq!(template('a').unwrap().label, "A");
}

#[test]
fn symbols_take_one_to_one_and_a_half_seconds_with_movement_between() {
    let synth = Synthesizer::new(draw("L7A", None, false)).unwrap();
    let g = synth.gestures();
    assert_eq!(
        g.iter().map(|g| g.label.as_str()).collect::<Vec<_>>(),
        ["L", "7", "A"]
    );
    for w in g.windows(2) {
        assert!(w[1].start_frame > w[0].end_frame + 15, "{w:?}");
    }
    for x in &g {
        let n = x.end_frame - x.start_frame + 1;
        assert!((27..=50).contains(&n), "{x:?}: {n} frames");
        assert_eq!(
            synth_gesture(&synth, x.start_frame).as_deref(),
            Some(x.label.as_str())
        );
        assert_eq!(synth_gesture(&synth, x.start_frame - 1), None);
    }
    assert!(synth.len().unwrap() > g[2].end_frame);
}

fn synth_gesture(s: &Synthesizer, f: usize) -> Option<String> {
    let mut s2 = Synthesizer::new(s.config().clone()).unwrap();
    s2.render(f).1.gesture.map(|g| g.label)
}

#[test]
fn the_hand_traces_the_symbol_mirrored_as_the_camera_sees_it() {
    let mut synth = Synthesizer::new(draw("L", None, false)).unwrap();
    let g = synth.gestures()[0].clone();
    let k = synth.intrinsics();
    let uv: Vec<(f32, f32)> = (g.start_frame..=g.end_frame)
        .map(|i| {
            let p = synth.render(i).1.skeleton.get(Joint::RightHand);
            k.project(&p).unwrap()
        })
        .collect();
    // The person writes "L" as they see it: down, then to their right, which the camera
    // facing them sees mirrored: down, then left in the image.
    let (start, end) = (uv[0], uv[uv.len() - 1]);
    let corner = uv
        .iter()
        .copied()
        .max_by(|a, b| (a.1 + a.0).total_cmp(&(b.1 + b.0)))
        .unwrap();
    assert!(corner.1 - start.1 > 40.0, "{start:?} -> {corner:?}");
    assert!((corner.0 - start.0).abs() < 12.0, "{start:?} -> {corner:?}");
    assert!(corner.0 - end.0 > 25.0, "{corner:?} -> {end:?}");
    assert!((end.1 - corner.1).abs() < 12.0, "{corner:?} -> {end:?}");
    // The hand is in front of the body while drawing.
    let (_, t) = synth.render((g.start_frame + g.end_frame) / 2);
    assert!(t.skeleton.get(Joint::RightHand).z < t.skeleton.get(Joint::Torso).z - 0.2);
}

#[test]
fn repeating_drawing_is_endless() {
    let synth = Synthesizer::new(draw("12", None, true)).unwrap();
    assert_eq!(synth.len(), None);
    let g = synth.gestures();
    let once = Synthesizer::new(draw("12", None, false))
        .unwrap()
        .len()
        .unwrap();
    let later = synth_gesture(&synth, once + g[1].start_frame + 2);
    assert_eq!(later.as_deref(), Some("2"));
}

#[test]
fn samples_from_trajectory_jsonl_plain_and_gzip() {
    let dir = tempfile::tempdir().unwrap();
    let text = "{\"label\":\"Z\",\"subject\":\"t1\",\"strokes\":[[[0,0,0],[100,0,50],[0,100,100],[100,100,150]]]}\n\
                {\"label\":\"1\",\"subject\":\"t1\",\"strokes\":[[[50,0],[50,100]]]}\n";
    let plain = dir.path().join("s.jsonl");
    std::fs::write(&plain, text).unwrap();
    let gz = dir.path().join("s.jsonl.gz");
    let mut enc = flate2::write::GzEncoder::new(
        std::fs::File::create(&gz).unwrap(),
        flate2::Compression::default(),
    );
    enc.write_all(text.as_bytes()).unwrap();
    enc.finish().unwrap();
    for p in [plain.clone(), gz] {
        let s = Synthesizer::new(draw("Z1", Some(p), false)).unwrap();
        assert_eq!(s.gestures().len(), 2);
    }
    let e = Synthesizer::new(draw("Q", Some(plain.clone()), false))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("s.jsonl") && e.contains("\"Q\""), "{e}");
    let bad = dir.path().join("bad.jsonl");
    std::fs::write(
        &bad,
        format!("{}{{\"label\":\"7\",\"strokes\":[[[1,\"x\"]]]}}\n", text),
    )
    .unwrap();
    let e = Synthesizer::new(draw("Z", Some(bad), false))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("bad.jsonl:3:"), "{e}");
}

#[test]
fn unknown_symbols_are_refused() {
    let e = Synthesizer::new(draw("A#", None, false))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("'#'"), "{e}");
    assert!(Synthesizer::new(draw("", None, false)).is_err());
}

#[test]
fn a_drawing_recording_has_gestures_csv() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("rec");
    let mut cfg = draw("7", None, false);
    cfg.intrinsics = airglyph_core::camera::Preset::KinectV1Qvga.intrinsics();
    let s = airglyph_synth::write_recording(cfg, 10_000, &dir, |_| {}).unwrap();
    let csv = std::fs::read_to_string(dir.join("gestures.csv")).unwrap();
    let g = &s.gestures[0];
    assert_eq!(
        csv,
        format!(
            "label,start_frame,end_frame\n7,{},{}\n",
            g.start_frame, g.end_frame
        )
    );
    assert_eq!(
        airglyph_core::gestures::read_gestures_csv(&dir.join("gestures.csv")).unwrap(),
        s.gestures
    );
    assert!(dir.join("joints.csv").exists());
}
