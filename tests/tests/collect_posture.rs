//! `airglyph collect --posture` with real processes: the synthetic person holds a hand
//! posture, capture publishes the depth frames and (ground-truth or estimated)
//! skeletons, every hand cut out becomes a line of posture sample JSONL, and `airglyph
//! train --postures` makes of the lines a model the posture library loads.

use airglyph_posture::{Features, PostureModel, FEATURE_LEN, FEATURE_VERSION};
use airglyph_system_tests::{fail, succeed, Isolated};
use std::path::Path;

fn lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect()
}

#[test]
fn collected_postures_train_a_model_the_library_loads() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("hands.jsonl");
    let postures = ["open", "fist", "v"];
    for subject in ["ann", "bob"] {
        for posture in postures {
            let out = succeed(
                p.command("airglyph")
                    .args(["collect", "--posture", posture, "--count", "8", "--truth"])
                    .args(["--subject", subject])
                    .arg("--out")
                    .arg(&data),
            );
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(err.contains("hand 8/8 recorded"), "{err}");
        }
    }
    let samples = lines(&data);
    assert_eq!(samples.len(), 48);
    for (i, v) in samples.iter().enumerate() {
        assert_eq!(v["label"], postures[i / 8 % 3], "{v}");
        assert_eq!(v["subject"], if i < 24 { "ann" } else { "bob" });
        assert_eq!(v["hand"], "right");
        assert_eq!(v["feature_version"], FEATURE_VERSION);
        assert_eq!(v["features"].as_array().unwrap().len(), FEATURE_LEN);
        // The synthetic palm is held at 1, 1.5, 2 and 2.5 m in turn: the nearest
        // point of the hand is a little nearer.
        let d = v["depth_m"].as_f64().unwrap();
        assert!((0.8..2.6).contains(&d), "{d}");
    }
    // Eight hands, one every third frame, span three of the four distances.
    let mut depths: Vec<f64> = samples[..8]
        .iter()
        .map(|v| v["depth_m"].as_f64().unwrap())
        .collect();
    depths.sort_by(f64::total_cmp);
    assert!(depths[7] - depths[0] > 0.8, "{depths:?}");

    let model = tmp.path().join("postures.json");
    let out = succeed(
        p.command("airglyph")
            .args(["train", "--postures"])
            .arg(&data)
            .arg("--out")
            .arg(&model),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("leave one subject out (2 subjects)"), "{err}");
    assert!(err.contains("chose "), "{err}");
    let m = PostureModel::load(&model).unwrap();
    assert_eq!(m.labels(), postures);
    // Bob's hands as a model of both names them (the same scenes, other noise).
    let right = samples
        .iter()
        .filter(|v| {
            let x: Vec<f32> = v["features"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap() as f32)
                .collect();
            let f = Features::from_slice(&x).unwrap();
            m.labels()[m.classifier().predict(&f).label] == v["label"]
        })
        .count();
    assert!(right >= 45, "{right} of 48");

    // One posture is no vocabulary.
    let one = tmp.path().join("one.jsonl");
    std::fs::write(
        &one,
        std::fs::read_to_string(&data)
            .unwrap()
            .lines()
            .take(8)
            .collect::<Vec<_>>()
            .join("\n"),
    )
    .unwrap();
    let err = fail(
        p.command("airglyph")
            .args(["train", "--postures"])
            .arg(&one)
            .arg("--out")
            .arg(tmp.path().join("x.json")),
    );
    assert!(
        err.contains("1 label(s)") && err.contains("labels found: open"),
        "{err}"
    );
}

#[test]
fn collect_posture_through_the_pose_stage() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("hands.jsonl");
    let out = succeed(
        p.command("airglyph")
            .args(["collect", "--posture", "point", "--count", "4"])
            .args(["--hand", "right", "--every", "2"])
            .arg("--out")
            .arg(&data),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("4 hands appended"), "{err}");
    let samples = lines(&data);
    assert_eq!(samples.len(), 4);
    assert!(samples.iter().all(|v| v["label"] == "point"));
}

#[test]
fn collect_posture_refuses_what_it_cannot_record() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x.jsonl");
    let err = fail(
        p.command("airglyph")
            .args(["collect", "--posture", "peace", "--count", "2", "--out"])
            .arg(&out),
    );
    assert!(
        err.contains("--posture \"peace\" has no synthetic hand") && err.contains("thumb-up"),
        "{err}"
    );
    let err = fail(
        p.command("airglyph")
            .args(["collect", "--posture", "a-posture-of-17by", "--count", "2"])
            .args(["--source", "synthetic:posture:open", "--out"])
            .arg(&out),
    );
    assert!(err.contains("17 bytes long"), "{err}");
    let err = fail(
        p.command("airglyph")
            .args([
                "collect",
                "--label",
                "7",
                "--posture",
                "open",
                "--count",
                "2",
                "--out",
            ])
            .arg(&out),
    );
    assert!(err.contains("cannot be used with"), "{err}");
    assert!(!out.exists());
}
