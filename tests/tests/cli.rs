//! The command line itself: what it refuses and how it says so, arguments that carry
//! spaces, and what it prints.

use airglyph_system_tests::{fail, json_lines, one_at_a_time, stop, Isolated};
use std::path::Path;
use std::process::Stdio;
use std::time::Duration;

#[test]
fn stage_arguments_are_checked_before_anything_starts() {
    let p = Isolated::new();
    // A stage that does not exist: refused with the list of stages.
    let err = fail(
        p.command("airglyph")
            .args(["run", "--stage-args", "gestrue=--model m.json"]),
    );
    assert!(err.contains("unknown stage \"gestrue\""), "{err}");
    assert!(err.contains("capture, pose, gesture, viewer"), "{err}");
    // An argument the stage does not take: its own parser says so, before any start.
    let err = fail(
        p.command("airglyph")
            .args(["run", "--stage-args", "gesture=--modle m.json"]),
    );
    assert!(err.contains("the arguments of the gesture stage"), "{err}");
    assert!(err.contains("--modle"), "{err}");
    // A quote left open, and a stage that does not run.
    let err = fail(
        p.command("airglyph")
            .args(["run", "--stage-args", "gesture=--model 'm.json"]),
    );
    assert!(err.contains("a quote is not closed"), "{err}");
    let err = fail(
        p.command("airglyph")
            .args(["run", "--stage-args", "viewer=--max-fps 5"]),
    );
    assert!(
        err.contains("the viewer stage does not run here (add --view)"),
        "{err}"
    );
    let err =
        fail(
            p.command("airglyph")
                .args(["run", "--stages", "capture,pose", "--model", "m.json"]),
        );
    assert!(err.contains("--model"), "{err}");
    assert!(p.processes().is_empty() && p.shm_files().is_empty());
}

/// The first gesture `airglyph run ARGS` prints, drawing a 3.
fn first_gesture(p: &Isolated, args: &[&str]) -> serde_json::Value {
    let mut run = p
        .command("airglyph")
        .args(["run", "--source", "synthetic:draw:3", "--json"])
        .args(args)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let events = json_lines(run.stdout.take().unwrap());
    let first = events
        .recv_timeout(Duration::from_secs(60))
        .expect("a gesture");
    stop(run);
    first
}

#[test]
fn a_model_whose_path_has_a_space_reaches_the_gesture_stage() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("my models");
    std::fs::create_dir(&dir).unwrap();
    let model = dir.join("digits and letters.json");
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/unipen-36.json");
    std::fs::copy(shipped, &model).unwrap();
    let model = model.to_str().unwrap();
    let quoted = format!("gesture=--model '{model}'");
    for args in [&["--model", model][..], &["--stage-args", &quoted][..]] {
        let g = first_gesture(&p, args);
        assert_eq!(g["label"], "3", "{args:?}: {g}");
    }
}
