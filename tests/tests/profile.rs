//! `airglyph profile`: the report of a pipeline it starts itself, its figures (JSON,
//! CSV) written before its pictures, and pictures drawn without the system's fonts.

use airglyph_system_tests::{one_at_a_time, Isolated};
use std::path::Path;

const MEASURES: [&str; 7] = [
    "capture_processing",
    "pose_waiting",
    "pose_processing",
    "gesture_waiting",
    "gesture_processing",
    "capture_to_skeleton",
    "capture_to_decision",
];

fn profile(p: &Isolated, out: &Path) -> std::process::Output {
    p.command("airglyph")
        .env("FONTCONFIG_FILE", "/dev/null")
        .args([
            "profile",
            "--source",
            "synthetic:pose:wave",
            "--seconds",
            "2",
        ])
        .args(["--warmup", "1", "--json", "--out"])
        .arg(out)
        .output()
        .unwrap()
}

/// The report's figures: profile.json with every measure, and both CSVs.
fn assert_figures(out: &Path) {
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("profile.json")).unwrap()).unwrap();
    for m in MEASURES {
        assert!(
            report["latency"][m]["count"].as_u64() > Some(0),
            "{m}: {report}"
        );
    }
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(summary.lines().count(), 1 + MEASURES.len(), "{summary}");
    let frames = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    assert!(frames.lines().count() > 10, "{frames}");
}

#[test]
fn profile_writes_its_figures_then_its_pictures_without_system_fonts() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();

    let out = tmp.path().join("report");
    let run = profile(&p, &out);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_figures(&out);
    for m in MEASURES {
        let im = image::open(out.join(format!("{m}.png"))).unwrap();
        assert_eq!((im.width(), im.height()), (800, 400), "{m}");
    }

    // A picture that cannot be written: the figures are there all the same.
    let blocked = tmp.path().join("blocked");
    std::fs::create_dir_all(blocked.join("capture_processing.png")).unwrap();
    let run = profile(&p, &blocked);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("capture_processing.png"), "{err}");
    assert_figures(&blocked);
    assert!(p.processes().is_empty(), "the pipeline it started is gone");
}
