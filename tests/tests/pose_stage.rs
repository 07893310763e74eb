//! capture (synthetic person) → pose → a subscriber process, all real processes.

use airglyph_core::recording::Recording;
use airglyph_core::Joint;
use airglyph_system_tests::{signal, succeed, top, Isolated};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Stdio};
use std::thread::JoinHandle;
use std::time::Duration;

/// The probe's lines, read on a thread of their own once it is subscribed: read only
/// after the pipeline ran, a full pipe would stall the probe and the skeletons it could
/// not take in time would be lost to it.
fn read_lines(probe: &mut Child) -> JoinHandle<Vec<serde_json::Value>> {
    let mut lines = BufReader::new(probe.stdout.take().unwrap()).lines();
    assert!(lines.next().unwrap().unwrap().contains("ready"));
    std::thread::spawn(move || {
        lines
            .map_while(Result::ok)
            .map(|l| serde_json::from_str(&l).unwrap())
            .collect()
    })
}

/// The skeletons a probe receives while the capture stage plays the recording `rec`
/// through a pose stage started with `pose_args`.
fn played_through_pose(p: &Isolated, rec: &Path, pose_args: &[&str]) -> Vec<serde_json::Value> {
    let mut probe = p
        .command("airglyph-probe")
        .args(["--stream", "skeleton", "--idle", "5"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let reader = read_lines(&mut probe);
    let mut pose = p.stage("pose").args(pose_args).spawn().unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let source = format!("recording:{}", rec.display());
    let capture = p
        .stage("capture")
        .args(["--source", &source])
        .status()
        .unwrap();
    assert!(capture.success());
    let got = reader.join().unwrap();
    signal(&pose, libc::SIGTERM);
    assert!(pose.wait().unwrap().success());
    let _ = probe.wait();
    got
}

#[test]
fn skeletons_carry_their_frames_sequence_and_timestamps() {
    let p = Isolated::new();
    let mut probe = p
        .command("airglyph-probe")
        .args(["--stream", "skeleton", "--idle", "5"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let reader = read_lines(&mut probe);
    let mut pose = p.stage("pose").spawn().unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let frames = 45u64;
    let capture = p
        .stage("capture")
        .args([
            "--source",
            "synthetic:pose:neutral",
            "--frames",
            &frames.to_string(),
        ])
        .status()
        .unwrap();
    assert!(capture.success());
    // The probe leaves when no skeleton came for its idle time.
    let got = reader.join().unwrap();
    // What the pose stage took and published, from its own stats (totals so far).
    let stats = top(&p);
    let count = |k: &str| {
        stats["stages"]["pose"][k]
            .as_u64()
            .unwrap_or_else(|| panic!("no pose {k} in {stats}"))
    };
    signal(&pose, libc::SIGTERM);
    assert!(
        pose.wait().unwrap().success(),
        "the pose stage stops cleanly on SIGTERM"
    );
    let _ = probe.wait();

    assert!(!got.is_empty(), "skeletons arrive");
    // A pose stage slower than the camera (a debug build on a loaded machine) skips
    // frames, and counts them; every frame it takes gives a skeleton, and the
    // subscriber receives each one.
    assert_eq!(
        count("frames_in") + count("frames_dropped"),
        frames,
        "every frame reaches pose or is counted lost: {stats}"
    );
    assert_eq!(count("frames_out"), count("frames_in"), "{stats}");
    assert_eq!(got.len() as u64, count("frames_out"), "{stats}");
    let mut last_seq = None;
    for s in &got {
        let seq = s["sequence"].as_u64().unwrap();
        assert!(seq < frames);
        assert!(
            last_seq.is_none_or(|l| seq > l),
            "in frame order: {seq} after {last_seq:?}"
        );
        last_seq = Some(seq);
        let t = |k: &str| s[k].as_u64().unwrap();
        assert!(t("capture_ns") > 0);
        assert!(t("capture_ns") <= t("capture_publish_ns"), "{s}");
        assert!(t("capture_publish_ns") <= t("pose_receive_ns"), "{s}");
        assert!(t("pose_receive_ns") <= t("pose_publish_ns"), "{s}");
        assert!(t("pose_publish_ns") <= t("receive_ns"), "{s}");
        assert_eq!(s["person_found"], true, "{s}");
        let head_z = s["head"][2].as_f64().unwrap();
        assert!((1.5..4.0).contains(&head_z), "head depth {head_z} m: {s}");
    }
    // The pose stage always finishes on the newest frame.
    assert_eq!(last_seq, Some(frames - 1));
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}

/// A person seen from the waist up, 1.2 m from the camera, arms at rest, through the
/// sensor model (a recording played by the capture stage): the pose stage reports the
/// legs out of view and nothing it calls visible lies outside the image.
#[test]
fn seen_from_the_waist_up_the_legs_are_reported_out_of_view() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("upper");
    let frames = 30u64;
    succeed(
        p.command("airglyph")
            .args(["synth", "--motion", "rest", "--resolution", "320x240"])
            .args(["--distance", "1.2", "--framing", "upper-body"])
            .args(["--background", "room", "--noise", "--frames"])
            .arg(frames.to_string())
            .arg("--out")
            .arg(&rec),
    );
    let k = Recording::open(&rec).unwrap().intrinsics();
    let got = played_through_pose(&p, &rec, &[]);

    assert!(got.len() >= 5, "{} skeletons", got.len());
    for s in &got {
        assert_eq!(s["person_found"], true, "{s}");
        let visible: Vec<&str> = s["visible"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        for j in ["head", "neck", "left_shoulder", "right_shoulder"] {
            assert!(visible.contains(&j), "{j} not visible: {s}");
        }
        for j in ["left_knee", "right_knee", "left_foot", "right_foot"] {
            assert!(!visible.contains(&j), "{j} visible: {s}");
        }
        for j in Joint::ALL.iter().filter(|j| visible.contains(&j.name())) {
            let p: Vec<f32> = s["joints"][j.index()]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap() as f32)
                .collect();
            let (u, v) = k.project(&nalgebra::Point3::new(p[0], p[1], p[2])).unwrap();
            assert!(
                (0.0..k.width as f32).contains(&u) && (0.0..k.height as f32).contains(&v),
                "{} reported visible at ({u}, {v}), outside the image: {s}",
                j.name()
            );
        }
    }
}

/// A person 2 m from the camera holding an open hand before them (the synthetic hand,
/// at 640×480 through the sensor model, played by the capture stage): the pose stage
/// classifies the right hand from the frame it estimated the skeleton from, and its
/// skeletons carry the built-in model's "open" for it, most of the time; with
/// `--postures off` they carry none.
#[test]
fn skeletons_carry_the_right_hands_posture_unless_postures_are_off() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("open");
    let frames = 30usize;
    succeed(
        p.command("airglyph")
            .args(["synth", "--motion", "pose:hands-in-front"])
            .args(["--hand-posture", "right=open"])
            .args(["--distance", "2", "--noise"])
            .args(["--frames", &frames.to_string()])
            .arg("--out")
            .arg(&rec),
    );
    let run = |postures: &str| {
        let got = played_through_pose(&p, &rec, &["--postures", postures]);
        assert!(got.len() >= frames / 2, "{} skeletons", got.len());
        got
    };
    let labels = ["open", "fist", "point", "thumb-up", "v", "pinch"];
    let with = run("builtin");
    let right: Vec<&str> = with
        .iter()
        .filter_map(|s| s["postures"]["right"]["label"].as_str())
        .collect();
    println!("right hand: {right:?}");
    let open = right.iter().filter(|&&l| l == "open").count();
    assert!(
        open * 2 > with.len(),
        "the open right hand is called open in {open} of {} skeletons: {right:?}",
        with.len()
    );
    for s in &with {
        let r = &s["postures"]["right"];
        if !r.is_null() {
            assert!(labels.contains(&r["label"].as_str().unwrap()), "{s}");
            let c = r["confidence"].as_f64().unwrap();
            assert!(c > 0.0 && c <= 1.0, "{s}");
        }
    }
    let without = run("off");
    assert!(
        without
            .iter()
            .all(|s| s["postures"] == serde_json::json!({"left": null, "right": null})),
        "--postures off: {:?}",
        without.iter().map(|s| &s["postures"]).collect::<Vec<_>>()
    );
}
