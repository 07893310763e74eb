//! The pen lifted by the hand, through real processes: a synthetic person draws pointing
//! and opens the hand between symbols; capture plays the recording, the pose stage reads
//! the hand's posture from each depth frame, and the gesture stage with the gated pen
//! publishes the symbols drawn pointing, and none drawn with an open hand.

use airglyph_system_tests::{one_at_a_time, succeed, Isolated};
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

/// The gesture events `airglyph run --pen gated --json` prints while it plays `rec`
/// through all three stages to its end.
fn gated_events(p: &Isolated, rec: &Path) -> Vec<serde_json::Value> {
    let mut run = p
        .command("airglyph")
        .args(["run", "--pen", "gated", "--json", "--source"])
        .arg(format!("recording:{}", rec.display()))
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let events = airglyph_system_tests::json_lines(run.stdout.take().unwrap());
    let deadline = Instant::now() + Duration::from_secs(60);
    while run.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "run did not end with its recording");
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(run.wait().unwrap().success());
    events
        .try_iter()
        .filter(|e| e["event"] == "gesture")
        .collect()
}

/// Renders `draw:37` drawn in `pen` (DRAWING,BETWEEN) at 1.2 m, from the waist up.
fn drawn(p: &Isolated, dir: &Path, pen: &str) -> std::path::PathBuf {
    let rec = dir.join(pen.replace(',', "-"));
    succeed(
        p.command("airglyph")
            .args(["synth", "--motion", "draw:37", "--pen-posture", pen])
            .args(["--framing", "upper-body", "--distance", "1.2", "--seed", "1"])
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
    let pointing = gated_events(&p, &drawn(&p, tmp.path(), "point,open"));
    println!("drawn pointing: {pointing:?}");
    let labels: Vec<&str> = pointing
        .iter()
        .filter_map(|e| e["label"].as_str())
        .collect();
    assert!(
        labels.contains(&"3") || labels.contains(&"7"),
        "neither symbol found: {labels:?}"
    );
    for e in &pointing {
        assert_eq!(e["posture"], "point", "{e}");
    }
    // The same motion drawn with an open hand and a fist between: the pen never goes down.
    let open = gated_events(&p, &drawn(&p, tmp.path(), "open,fist"));
    assert!(open.is_empty(), "drawn open, yet published: {open:?}");
}
