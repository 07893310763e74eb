//! The pen lifted by the hand, through real processes: a synthetic person draws pointing
//! and opens the hand between symbols; capture plays the recording, the pose stage reads
//! the hand's posture from each depth frame, and the gesture stage with the gated pen
//! publishes the symbols drawn pointing, and none when the gate waits for a fist.

use airglyph_system_tests::{one_at_a_time, succeed, Isolated};
use std::path::Path;

/// The gesture events of `rec` played through the pipeline with `pen`.
fn events(p: &Isolated, pen: &str, rec: &Path) -> Vec<serde_json::Value> {
    airglyph_system_tests::played_gestures(p, &["--pen", pen], rec)
}

/// Renders `draw:3714` drawn pointing, the hand open between, at 1.2 m from the waist up.
fn drawn_pointing(p: &Isolated, dir: &Path) -> std::path::PathBuf {
    let rec = dir.join("pointing");
    succeed(
        p.command("airglyph")
            .args([
                "synth",
                "--motion",
                "draw:3714",
                "--pen-posture",
                "point,open",
            ])
            .args([
                "--framing",
                "upper-body",
                "--distance",
                "1.2",
                "--seed",
                "1",
            ])
            .arg("--out")
            .arg(&rec),
    );
    rec
}

#[test]
fn the_gated_pen_publishes_what_is_drawn_pointing() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = drawn_pointing(&p, tmp.path());
    let pointing = events(&p, "gated", &rec);
    println!("gated: {pointing:?}");
    let labels: Vec<&str> = pointing
        .iter()
        .filter_map(|e| e["label"].as_str())
        .collect();
    assert!(
        ["3", "7", "1", "4"].iter().any(|s| labels.contains(s)),
        "no symbol drawn found: {labels:?}"
    );
    for e in &pointing {
        assert_eq!(e["posture"], "point", "{e}");
    }
    // The same skeletons, the gate waiting for a fist the person never makes: the
    // gestures above came through the gate, and none comes now.
    let fist = events(&p, "gated:fist", &rec);
    assert!(fist.is_empty(), "gated on a fist, yet published: {fist:?}");
}

/// What cannot be is refused, saying why: a pen posture where nothing is drawn or where
/// --hand-posture already gives the right hand one, and a posture pen without postures.
#[test]
fn a_pen_without_what_it_needs_is_refused() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x");
    let synth = |args: &[&str]| {
        airglyph_system_tests::fail(
            p.command("airglyph")
                .args(["synth", "--pen-posture", "point,open", "--out"])
                .arg(&out)
                .args(args),
        )
    };
    let e = synth(&["--motion", "pose:wave"]);
    assert!(
        e.contains("--pen-posture is for --motion draw:SYMBOLS"),
        "{e}"
    );
    let e = synth(&["--motion", "draw:7", "--hand-posture", "both=fist"]);
    assert!(
        e.contains("leave the right hand out of --hand-posture"),
        "{e}"
    );
    let rec = tmp.path().join("rec");
    succeed(
        p.command("airglyph")
            .args(["synth", "--motion", "draw:7", "--frames", "20"])
            .args([
                "--pen-posture",
                "point,open",
                "--resolution",
                "320x240",
                "--out",
            ])
            .arg(&rec),
    );
    let e = airglyph_system_tests::fail(
        p.command("airglyph")
            .args(["spot", "--truth", "--pen", "gated"])
            .arg(&rec),
    );
    assert!(e.contains("needs the hands' postures"), "{e}");
}
