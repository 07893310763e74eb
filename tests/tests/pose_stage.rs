//! capture (synthetic person) → pose → a subscriber process, all real processes.

use airglyph_system_tests::{signal, top, Isolated};
use std::io::{BufRead, BufReader};
use std::process::Stdio;
use std::time::Duration;

#[test]
fn skeletons_carry_their_frames_sequence_and_timestamps() {
    let p = Isolated::new();
    let mut probe = p
        .command("airglyph-probe")
        .args(["--stream", "skeleton", "--idle", "5"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(probe.stdout.take().unwrap()).lines();
    assert!(lines.next().unwrap().unwrap().contains("ready"));
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
    let got: Vec<serde_json::Value> = lines
        .map_while(Result::ok)
        .map(|l| serde_json::from_str(&l).unwrap())
        .collect();
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
