//! The offline gesture commands on trajectories of the synthetic person's handwriting,
//! with the shipped model: `airglyph eval-gestures --json --plots` and
//! `airglyph eval-spotting --json` (and its summary in words).

use airglyph_system_tests::{fail, succeed, write_glyphs, Isolated};
use std::path::{Path, PathBuf};

fn shipped_model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/unipen-36.json")
}

fn json_lines(stdout: &[u8]) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

#[test]
fn eval_gestures_scores_every_sample_and_draws_its_confusion_matrix() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("glyphs.jsonl");
    write_glyphs(&data, "0123456789", 2);
    let plots = tmp.path().join("plots");
    let out = succeed(
        p.command("airglyph")
            .args(["eval-gestures", "--json", "--model"])
            .arg(shipped_model())
            .arg("--data")
            .arg(&data)
            .arg("--plots")
            .arg(&plots),
    );
    let lines = json_lines(&out.stdout);
    let r = &lines[0];
    assert_eq!(r["classifier"], "mlp", "{r}");
    assert_eq!(r["samples"], 20, "{r}");
    // The synthetic person's own glyphs: the shipped model reads nearly all of them.
    let acc = r["accuracy"].as_f64().unwrap();
    assert!((0.8..=1.0).contains(&acc), "{r}");
    // Every label of the model, a recall for those drawn (null for the others).
    let recall = r["per_class_recall"].as_object().unwrap();
    assert_eq!(recall.len(), 36, "{r}");
    for (label, v) in recall {
        let drawn = label.chars().all(|c| c.is_ascii_digit());
        assert_eq!(v.is_f64(), drawn, "{label}: {v}");
    }
    let pngs: Vec<_> = std::fs::read_dir(&plots)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "png"))
        .collect();
    assert!(
        !pngs.is_empty(),
        "no confusion matrix in {}",
        plots.display()
    );
}

#[test]
fn eval_spotting_accounts_for_every_drawn_symbol_by_label() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("glyphs.jsonl");
    write_glyphs(&data, "0123456789", 2);
    let run = |json: bool| {
        let mut cmd = p.command("airglyph");
        cmd.args(["eval-spotting", "--model"])
            .arg(shipped_model())
            .arg("--data")
            .arg(&data)
            .args(["--gestures", "12", "--per-stream", "6", "--seed", "3"])
            .args(["--random-seconds", "20"]);
        if json {
            cmd.arg("--json");
        }
        succeed(&mut cmd)
    };
    let lines = json_lines(&run(true).stdout);
    assert_eq!(lines.len(), 2, "{lines:?}");
    let s = &lines[0];
    let n = |k: &str| s[k].as_u64().unwrap_or_else(|| panic!("no {k} in {s}"));
    assert_eq!(n("gestures"), 12, "{s}");
    assert_eq!(
        n("correct") + n("substitutions") + n("deletions"),
        12,
        "{s}"
    );
    let reliability = n("correct") as f64 / (n("gestures") + n("insertions")) as f64;
    assert!((s["reliability"].as_f64().unwrap() - reliability).abs() < 1e-9);
    // Every drawn symbol is counted under its own label, found or not.
    let by_label = s["by_label"].as_object().unwrap();
    let sum = |k: &str| -> u64 { by_label.values().map(|v| v[k].as_u64().unwrap()).sum() };
    assert_eq!(sum("drawn"), 12, "{s}");
    assert_eq!(sum("correct"), n("correct"), "{s}");
    assert!(by_label
        .keys()
        .all(|l| l.len() == 1 && l.chars().all(|c| c.is_ascii_digit())));
    // The shipped model finds most of its own glyphs in a stream.
    assert!(n("correct") >= 8, "{s}");

    let alarms = &lines[1];
    assert_eq!(alarms["random_movement_seconds"], 20.0, "{alarms}");
    let named: u64 = alarms["insertions_by_label"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(named, alarms["insertions"].as_u64().unwrap(), "{alarms}");

    // In words: the same count, and the symbols found least often.
    let text = String::from_utf8(run(false).stdout).unwrap();
    assert!(
        text.contains(&format!("{} correct", n("correct"))),
        "{text}"
    );
    assert!(text.contains("found least often: \""), "{text}");
}

#[test]
fn eval_spotting_draws_as_many_gestures_as_asked_for_from_fewer_samples() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("glyphs.jsonl");
    write_glyphs(&data, "01234", 1);
    let out = succeed(
        p.command("airglyph")
            .args(["eval-spotting", "--json", "--model"])
            .arg(shipped_model())
            .arg("--data")
            .arg(&data)
            .args(["--gestures", "12", "--random-seconds", "5"]),
    );
    let s = &json_lines(&out.stdout)[0];
    assert_eq!(s["gestures"], 12, "{s}");
    let drawn: u64 = s["by_label"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v["drawn"].as_u64().unwrap())
        .sum();
    assert_eq!(drawn, 12, "{s}");
}

#[test]
fn eval_spotting_refuses_data_without_a_label_the_model_knows() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("lowercase.jsonl");
    std::fs::write(
        &data,
        r#"{"label":"a","subject":"w","strokes":[[[0,0],[1,1],[2,0]]]}"#.to_string() + "\n",
    )
    .unwrap();
    let err = fail(
        p.command("airglyph")
            .args(["eval-spotting", "--model"])
            .arg(shipped_model())
            .arg("--data")
            .arg(&data),
    );
    assert!(
        err.contains("no sample has a label the model knows") && err.contains("lowercase.jsonl"),
        "{err}"
    );
}

/// One writer's glyphs, `copies` of each label, each copy slanted and stretched a
/// little differently.
fn write_one_writer(path: &Path, labels: &str, copies: usize) {
    let mut lines = Vec::new();
    for c in labels.chars() {
        let glyph = airglyph_synth::glyphs::template(c).expect("a built-in glyph");
        for k in 0..copies {
            let slant = 0.04 * k as f32 - 0.1;
            let stretch = 1.0 + 0.05 * (k % 3) as f32;
            let strokes: Vec<Vec<[f32; 2]>> = glyph
                .strokes
                .iter()
                .map(|s| {
                    s.iter()
                        .map(|p| [p.x + slant * p.y, p.y * stretch])
                        .collect()
                })
                .collect();
            lines.push(
                serde_json::json!({"label": c.to_string(), "subject": "me", "strokes": strokes})
                    .to_string(),
            );
        }
    }
    std::fs::write(path, lines.join("\n") + "\n").unwrap();
}

#[test]
fn eval_gestures_per_writer_trains_on_each_writers_own_samples() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("mine.jsonl");
    write_one_writer(&data, "0123456789", 6);
    let plots = tmp.path().join("plots");
    let out = succeed(
        p.command("airglyph")
            .args([
                "eval-gestures",
                "--json",
                "--baselines",
                "--per-writer",
                "3",
                "--model",
            ])
            .arg(shipped_model())
            .arg("--data")
            .arg(&data)
            .arg("--plots")
            .arg(&plots),
    );
    let lines = json_lines(&out.stdout);
    assert_eq!(lines.len(), 2, "{lines:?}");
    for (r, name) in lines.iter().zip(["mlp", "dtw"]) {
        assert_eq!(r["classifier"], name, "{r}");
        assert_eq!(r["protocol"], "per-writer", "{r}");
        assert_eq!(r["train_per_label"], 3, "{r}");
        assert_eq!(r["subjects"], 1, "{r}");
        // Three of six copies of each of ten labels to train on, the other three to test.
        assert_eq!(r["samples"], 30, "{r}");
        let acc = r["accuracy"].as_f64().unwrap();
        assert!(acc >= 0.9, "{r}");
        // A recall for each of the writer's ten labels, as cross-validation gives.
        let recall = r["per_class_recall"].as_object().unwrap();
        assert_eq!(recall.len(), 10, "{r}");
        assert!(recall.values().all(|v| v.is_f64()), "{r}");
    }
    // The default says what it chose for three samples a label.
    let plan = lines[0]["plan"].as_str().unwrap();
    assert!(plan.contains("templates"), "{plan}");
    // --plots draws each method's confusion matrix here too (it was ignored).
    for name in ["mlp", "dtw"] {
        let png = plots.join(format!("confusion-{name}-per-writer-3.png"));
        assert!(png.is_file(), "no {}", png.display());
    }
}

#[test]
fn eval_gestures_trains_on_some_people_and_tests_on_the_others() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let all = tmp.path().join("all.jsonl");
    succeed(
        p.command("airglyph")
            .args(["synth-gestures", "--persons", "5", "--repetitions", "2"])
            .arg("--out")
            .arg(&all),
    );
    // A public set's split: the first two people to train on, the other three to test.
    let (train, test) = (
        tmp.path().join("train.jsonl"),
        tmp.path().join("test.jsonl"),
    );
    let text = std::fs::read_to_string(&all).unwrap();
    let (tr, te): (Vec<&str>, Vec<&str>) = text
        .lines()
        .partition(|l| l.contains("-p00\"") || l.contains("-p01\""));
    assert_eq!((tr.len(), te.len()), (2 * 14 * 2, 3 * 14 * 2));
    std::fs::write(&train, tr.join("\n")).unwrap();
    std::fs::write(&test, te.join("\n")).unwrap();
    let eval = |test: &Path| {
        let mut c = p.command("airglyph");
        c.args([
            "eval-gestures",
            "--json",
            "--baselines",
            "--no-crf",
            "--model",
        ])
        .arg(shipped_model())
        .arg("--train-data")
        .arg(&train)
        .arg("--data")
        .arg(test);
        c
    };
    let lines = json_lines(&succeed(&mut eval(&test)).stdout);
    assert_eq!(lines.len(), 3, "{lines:?}");
    for (r, name) in lines.iter().zip(["mlp", "dtw", "seed-hmm"]) {
        assert_eq!(r["classifier"], name, "{r}");
        assert_eq!(r["samples"], 84, "{r}");
        // Fourteen labels: chance is 7 %; every method learns them from two people.
        let acc = r["accuracy"].as_f64().unwrap();
        assert!(acc >= 0.4, "{r}");
    }
    // A label the training people never drew is named, not scored as a miss.
    let odd = tmp.path().join("odd.jsonl");
    std::fs::write(&odd, te[0].replacen(r#""label":""#, r#""label":"wave-"#, 1)).unwrap();
    let err = fail(&mut eval(&odd));
    assert!(
        err.contains("wave-") && err.contains("train.jsonl"),
        "{err}"
    );
    // Folds by person over a set that names no person are refused, not scored 0.
    let anonymous = tmp.path().join("anonymous.jsonl");
    let unnamed: Vec<String> = te
        .iter()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            v.as_object_mut().unwrap().remove("subject");
            v.to_string()
        })
        .collect();
    std::fs::write(&anonymous, unnamed.join("\n")).unwrap();
    let err = fail(
        p.command("airglyph")
            .args(["eval-gestures", "--folds", "3", "--model"])
            .arg(shipped_model())
            .arg("--data")
            .arg(&anonymous),
    );
    assert!(
        err.contains("--folds 3") && err.contains("no sample names one"),
        "{err}"
    );
}

#[test]
fn train_says_it_adds_templates_for_a_few_samples_a_label() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("mine.jsonl");
    write_one_writer(&data, "0123456789", 3);
    let model = tmp.path().join("mine.json");
    let out = succeed(
        p.command("airglyph")
            .args(["train", "--no-spotting", "--data"])
            .arg(&data)
            .arg("--out")
            .arg(&model),
    );
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        said.contains("networks and templates") && said.contains("has 3 samples"),
        "{said}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    let n = json["classifier"]["templates"]["templates"]
        .as_array()
        .unwrap()
        .len();
    assert_eq!(n, 30);
}

#[test]
fn train_in_space_says_what_leaving_each_person_out_chose() {
    // Three people, 12 samples a label: above the few-shot bar, so the templates' share
    // is chosen on the people themselves.
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("people.jsonl");
    succeed(
        p.command("airglyph")
            .args(["synth-gestures", "--persons", "3", "--repetitions", "4"])
            .arg("--out")
            .arg(&data),
    );
    let model = tmp.path().join("people.json");
    let out = succeed(
        p.command("airglyph")
            .args(["train", "--no-spotting", "--epochs", "2", "--data"])
            .arg(&data)
            .arg("--out")
            .arg(&model),
    );
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        said.contains("3 people drew them in space")
            && said.contains("leaving the 3 people out (3 folds"),
        "{said}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    let choice = &json["training"]["template_share"];
    assert_eq!(choice["tested"], 3 * 14 * 4, "{choice}");
    let share = choice["share"].as_f64().unwrap();
    let templates = &json["classifier"]["templates"];
    if share > 0.0 {
        assert_eq!(templates["weight"].as_f64().unwrap(), share, "{templates}");
    } else {
        assert!(templates.is_null(), "{templates}");
    }
    // Asked not to: networks only, nothing left out.
    let out = succeed(
        p.command("airglyph")
            .args(["train", "--no-spotting", "--epochs", "2"])
            .args(["--few-shot", r#"{"shares_by_person":[0,0,0]}"#, "--data"])
            .arg(&data)
            .arg("--out")
            .arg(&model),
    );
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        said.contains("networks only") && !said.contains("leaving"),
        "{said}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert!(json["training"]["template_share"].is_null());
    assert!(json["classifier"]["templates"].is_null());
    // A setting that is not one is named.
    let err = fail(
        p.command("airglyph")
            .args(["train", "--few-shot", r#"{"shares":[0]}"#, "--data"])
            .arg(&data)
            .arg("--out")
            .arg(&model),
    );
    assert!(
        err.contains("--few-shot") && err.contains("\"shares\""),
        "{err}"
    );
}

#[test]
fn a_gesture_in_space_is_spotted_whole_not_as_the_gestures_it_is_made_of() {
    // The zigzag towards the camera is a swipe then a push, and the right-push a swipe
    // with a push at its end: a model without a verifier once published the parts,
    // each surer than the whole. The parts are drawn too, alone.
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("parts");
    succeed(
        p.command("airglyph")
            .args(["synth", "--seed", "7", "--resolution", "320x240"])
            .args([
                "--motion",
                "draw:zigzag-deep,swipe,right-push,push",
                "--out",
            ])
            .arg(&rec),
    );
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/air3d-14.json");
    let out = succeed(
        p.command("airglyph")
            .args(["spot", "--truth", "--json", "--model"])
            .arg(&model)
            .arg(&rec),
    );
    let lines = json_lines(&out.stdout);
    let found: Vec<(&str, &str)> = lines
        .iter()
        .filter(|l| l["event"] == "gesture")
        .map(|l| {
            let drawn = l["drawn"].as_str().unwrap_or("(none)");
            (l["label"].as_str().unwrap(), drawn)
        })
        .collect();
    assert_eq!(
        found,
        [
            ("zigzag-deep", "zigzag-deep"),
            ("swipe", "swipe"),
            ("right-push", "right-push"),
            ("push", "push")
        ]
    );
}
