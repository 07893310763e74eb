//! The offline pose commands on a synthetic recording with ground truth:
//! `airglyph pose DIR --json` and `airglyph eval-pose DIR --json --plots OUT`.

use airglyph_core::Joint;
use airglyph_system_tests::{fail, succeed, Isolated};

#[test]
fn pose_and_eval_pose_report_every_frame_against_the_truth() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("wave");
    let frames = 20;
    succeed(
        p.command("airglyph")
            .args(["synth", "--motion", "pose:wave", "--resolution", "320x240"])
            .args(["--frames", &frames.to_string(), "--out"])
            .arg(&rec),
    );

    // One JSON object a frame, in order, every joint in metres before the camera.
    let out = succeed(p.command("airglyph").args(["pose", "--json"]).arg(&rec));
    let lines: Vec<serde_json::Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), frames);
    for (i, l) in lines.iter().enumerate() {
        assert_eq!(l["frame"], i, "{l}");
        assert_eq!(l["person_found"], true, "{l}");
        for j in Joint::ALL {
            let xyz: Vec<f64> = l["joints"][j.name()]
                .as_array()
                .unwrap_or_else(|| panic!("no {} in {l}", j.name()))
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            assert_eq!(xyz.len(), 3);
            assert!((1.5..4.0).contains(&xyz[2]), "{} at {xyz:?}", j.name());
            let c = l["confidence"][j.name()].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&c), "{l}");
        }
    }

    // The figures against joints.csv, and the seed's two plots, drawn with the
    // built-in font on a machine whose fontconfig knows no font at all.
    let plots = tmp.path().join("plots");
    let out = succeed(
        p.command("airglyph")
            .env("FONTCONFIG_FILE", "/dev/null")
            .args(["eval-pose", "--json", "--plots"])
            .arg(&plots)
            .arg(&rec),
    );
    let s: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(s["frames"], frames, "{s}");
    let mean = s["mean_error_cm"].as_f64().unwrap();
    let max = s["max_error_cm"].as_f64().unwrap();
    // A person standing still before the camera, waving: found within centimetres.
    assert!(mean > 0.0 && mean < 10.0 && max >= mean, "{s}");
    let per_joint = s["per_joint_cm"].as_object().unwrap();
    assert_eq!(per_joint.len(), Joint::COUNT, "{s}");
    let joints_mean = per_joint.values().map(|v| v.as_f64().unwrap()).sum::<f64>() / 16.0;
    assert!(
        (joints_mean - mean).abs() < 0.01,
        "e_m is the joints' mean: {s}"
    );
    for k in ["within_10cm", "map_10cm"] {
        let v = s[k].as_f64().unwrap();
        assert!((0.5..=1.0).contains(&v), "{k}: {s}");
    }
    assert!(s["fps"].as_f64().unwrap() > 0.0, "{s}");
    for (name, size) in [
        ("error_per_frame.png", (1000, 500)),
        ("error_per_joint.png", (800, 560)),
    ] {
        let im = image::open(plots.join(name)).unwrap();
        assert_eq!((im.width(), im.height()), size, "{name}");
    }

    // A picture that cannot be written loses none of the figures, which come first, and
    // leaves no part of itself.
    let blocked = tmp.path().join("blocked");
    std::fs::create_dir_all(blocked.join("error_per_frame.png")).unwrap();
    let out = p
        .command("airglyph")
        .args(["eval-pose", "--json", "--plots"])
        .arg(&blocked)
        .arg(&rec)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let again: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(again["frames"], frames, "{again}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("error_per_frame.png"), "{err}");
    let left: Vec<_> = std::fs::read_dir(&blocked).unwrap().flatten().collect();
    assert_eq!(left.len(), 1, "only the directory in the way: {left:?}");

    // Without ground truth there is nothing to evaluate against, and it says so.
    std::fs::remove_file(rec.join("joints.csv")).unwrap();
    let err = fail(p.command("airglyph").arg("eval-pose").arg(&rec));
    assert!(err.contains("has no joints.csv"), "{err}");
}
