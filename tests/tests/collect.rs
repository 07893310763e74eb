//! `airglyph collect` with real processes: the synthetic person draws a symbol again and
//! again, capture publishes its (ground-truth) skeletons, and every repetition becomes a
//! line of trajectory JSONL that `airglyph train` takes; an interrupted session keeps
//! what it recorded. And the gesture stage's clear messages on bad models.

use airglyph_system_tests::{fail, signal, succeed, Isolated};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

fn lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect()
}

/// One collected repetition: the label, and a path of [x, y, z, ms] points (3-D,
/// `"dims":3`) of about a symbol's size (shoulder widths) and duration (the synthetic
/// person takes 1–1.5 s), drawn on a pane in front of the body (z: the hand well in
/// front of the shoulders, and flat: a symbol is drawn in a plane).
fn check_repetition(v: &serde_json::Value, label: &str) {
    assert_eq!(v["label"], label);
    assert_eq!(v["subject"], "me");
    assert_eq!(v["dims"], 3, "{v}");
    let strokes = v["strokes"].as_array().unwrap();
    assert_eq!(strokes.len(), 1, "{v}");
    let pts: Vec<Vec<f64>> = strokes[0]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            p.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        })
        .collect();
    assert!(pts.len() >= 20, "{} points", pts.len());
    assert!(pts.iter().all(|p| p.len() == 4));
    assert!(pts.windows(2).all(|w| w[1][3] > w[0][3]), "times increase");
    let secs = pts[pts.len() - 1][3] / 1000.0;
    assert!((0.8..2.0).contains(&secs), "{secs} s");
    let span = |k: usize| {
        let v: Vec<f64> = pts.iter().map(|p| p[k]).collect();
        v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
    };
    let size = span(0).max(span(1));
    assert!((0.5..1.6).contains(&size), "size {size}");
    assert!(pts.iter().all(|p| p[2] > 0.5), "in front of the shoulders");
    assert!(span(2) < 0.5 * size, "depth {} for a size {size}", span(2));
}

#[test]
fn collect_writes_each_repetition_and_train_takes_the_file() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("mine.jsonl");
    for label in ["7", "L"] {
        let out = p
            .command("airglyph")
            .args(["collect", "--label", label, "--count", "2", "--truth"])
            .arg("--out")
            .arg(&data)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        assert!(err.contains("repetition 2/2 recorded"), "{err}");
    }
    let samples = lines(&data);
    assert_eq!(samples.len(), 4);
    for (v, label) in samples.iter().zip(["7", "7", "L", "L"]) {
        check_repetition(v, label);
    }
    let read = |path: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    };
    // The 3-D points make a model that reads depth, whose spotting part has no
    // verifier yet (gesture README, "Gestures in three dimensions").
    let deep = tmp.path().join("deep.json");
    let out = succeed(
        p.command("airglyph")
            .args(["train", "--ensemble", "1", "--epochs", "5"])
            .arg("--data")
            .arg(&data)
            .arg("--out")
            .arg(&deep),
    );
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("4 samples drawn in 3-D"),
        "{out:?}"
    );
    let d = read(&deep);
    assert_eq!(
        d["classifier"]["features"]["depth"], true,
        "{}",
        d["classifier"]["features"]
    );
    assert!(d["spotting"]["verifier"].is_null());
    // --flat: what a 2-D camera sees, with a verifier.
    let model = tmp.path().join("mine.json");
    succeed(
        p.command("airglyph")
            .args(["train", "--ensemble", "1", "--epochs", "5", "--flat"])
            .arg("--data")
            .arg(&data)
            .arg("--out")
            .arg(&model),
    );
    let mut m = read(&model);
    assert_eq!(m["labels"], serde_json::json!(["7", "L"]));
    assert!(m["classifier"]["features"].get("depth").is_none());
    // Its spotting part learned from both kinds of stream unless told otherwise.
    assert_eq!(m["training"]["parameters"]["generator"], "mixed");

    // Calibrating the label bars again keeps everything else of the model.
    let again = tmp.path().join("again.json");
    succeed(
        p.command("airglyph")
            .arg("train")
            .arg("--recalibrate")
            .arg(&model)
            .arg("--flat")
            .arg("--data")
            .arg(&data)
            .arg("--out")
            .arg(&again),
    );
    let mut a = read(&again);
    for v in [&mut m, &mut a] {
        v["spotting"]["verifier"]
            .as_object_mut()
            .unwrap()
            .remove("label_bars");
    }
    assert_eq!(a, m, "only the label bars may change");
    // Data of other labels cannot calibrate it.
    let other = tmp.path().join("other.jsonl");
    std::fs::write(
        &other,
        "{\"label\":\"x\",\"strokes\":[[[0,0],[1,0]]]}\n{\"label\":\"y\",\"strokes\":[[[0,0],[0,1]]]}\n",
    )
    .unwrap();
    let err = fail(
        p.command("airglyph")
            .arg("train")
            .arg("--recalibrate")
            .arg(&model)
            .arg("--data")
            .arg(&other)
            .arg("--out")
            .arg(&again),
    );
    assert!(err.contains("labels differ from the data's"), "{err}");
}

#[test]
fn an_interrupted_collect_keeps_every_repetition_it_announced() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("mine.jsonl");
    let mut child = p
        .command("airglyph")
        .args(["collect", "--label", "Z", "--count", "5", "--truth"])
        .arg("--out")
        .arg(&data)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap()).lines();
    let deadline = Instant::now() + Duration::from_secs(60);
    for line in stderr.by_ref().map_while(Result::ok) {
        if line.contains("repetition 1/5 recorded") {
            break;
        }
        assert!(Instant::now() < deadline, "no repetition within 60 s");
    }
    signal(&child, libc::SIGTERM);
    let sent = Instant::now();
    let status = child.wait().unwrap();
    assert!(
        sent.elapsed() <= Duration::from_secs(2),
        "{:?}",
        sent.elapsed()
    );
    // Stopped before the count: 128 + SIGTERM, like any command a signal ended, but
    // nothing is lost, and it says so.
    let said: Vec<String> = stderr.map_while(Result::ok).collect();
    assert_eq!(status.code(), Some(128 + libc::SIGTERM), "{said:?}");
    let samples = lines(&data);
    assert!(
        !samples.is_empty() && samples.len() < 5,
        "{}",
        samples.len()
    );
    for v in &samples {
        check_repetition(v, "Z");
    }
    let kept = format!("{} of 5 repetitions were recorded", samples.len());
    assert!(said.iter().any(|l| l.contains(&kept)), "{said:?}");
}

#[test]
fn bad_labels_and_models_fail_with_a_clear_message() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let long = "x".repeat(40);
    let err = fail(
        p.command("airglyph")
            .args(["collect", "--label", &long, "--count", "1", "--out"])
            .arg(tmp.path().join("x.jsonl")),
    );
    assert!(err.contains("at most 32 bytes"), "{err}");

    // Training data with an empty stroke, a NaN point, a label too long: each named by
    // file and line.
    for (line, want) in [
        (r#"{"label":"a","strokes":[[]]}"#, "stroke 0 is empty"),
        (
            r#"{"label":"a","strokes":[[[0,0],[NaN,1]]]}"#,
            "not a finite number",
        ),
        (
            r#"{"label":"a-label-much-longer-than-thirty-two-bytes","strokes":[[[0,0],[1,1]]]}"#,
            "at most 32 bytes",
        ),
    ] {
        let data = tmp.path().join("bad.jsonl");
        std::fs::write(
            &data,
            format!("{{\"label\":\"b\",\"strokes\":[[[0,0],[1,0]]]}}\n{line}\n"),
        )
        .unwrap();
        let err = fail(
            p.command("airglyph")
                .args(["train", "--epochs", "1", "--ensemble", "1", "--data"])
                .arg(&data)
                .arg("--out")
                .arg(tmp.path().join("m.json")),
        );
        assert!(err.contains(want), "{line}: {err}");
        if !want.contains("32 bytes") {
            assert!(err.contains("bad.jsonl:2"), "{line}: {err}");
        }
    }

    // A spotting verifier of no networks at all is refused before any work.
    let err = fail(
        p.command("airglyph")
            .args(["train", "--verifiers", "0", "--data"])
            .arg(tmp.path().join("bad.jsonl"))
            .arg("--out")
            .arg(tmp.path().join("m.json")),
    );
    assert!(
        err.contains("'0' for '--verifiers") && err.contains("from 1 to"),
        "{err}"
    );

    // A model of another version: the stage says which file and what to do.
    let model = tmp.path().join("old.json");
    std::fs::write(
        &model,
        r#"{"format":"airglyph-gesture-model","version":1,"labels":["a","b"]}"#,
    )
    .unwrap();
    let err = fail(p.stage("gesture").arg("--model").arg(&model));
    assert!(
        err.contains("old.json") && err.contains("version 1 is not supported"),
        "{err}"
    );
}
