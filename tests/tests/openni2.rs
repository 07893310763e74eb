//! Real OpenNI2 runtime, real processes: the capture stage streams OpenNI2's `Dummy`
//! device to a subscriber, and a `.oni` recorded from it plays back through the capture
//! stage frame for frame, bit for bit. Needs the workspace built with --all-features
//! (scripts/test does) and libopenni2-0 (scripts/setup installs it).
#![cfg(feature = "openni2")]

use airglyph_core::recording::Recording;
use airglyph_system_tests::{signal, start_probe, succeed, Isolated};
use std::process::Child;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The streaming tests run one at a time: each keeps a 30 fps subscriber busy writing
/// PNGs, and two at once on a small machine would drop frames (by design) and fail.
static SERIAL: Mutex<()> = Mutex::new(());

/// Waits for a child to exit by itself (SIGTERM after the deadline).
fn wait_exit(mut child: Child, secs: u64) -> std::process::ExitStatus {
    let deadline = Instant::now() + Duration::from_secs(secs);
    while Instant::now() < deadline {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    signal(&child, libc::SIGTERM);
    let _ = child.wait();
    panic!("process {} did not exit within {secs} s", child.id());
}

#[test]
fn capture_streams_60_frames_of_the_openni2_dummy_device_to_another_process() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let got = tmp.path().join("got");
    let (probe, rx) = start_probe(&p, &["--out", got.to_str().unwrap(), "--idle", "3"]);
    succeed(
        p.stage("capture")
            .args(["--source", "openni2:Dummy", "--frames", "60"]),
    );
    assert!(wait_exit(probe, 15).success());
    let meta: Vec<serde_json::Value> = rx.try_iter().collect();
    // 60 frames were published (sequences 0..59) and all arrived in order. A subscriber
    // starved by an overloaded machine drops frames by design (the pipeline never
    // queues): those show as counted gaps; on a quiet machine there are none.
    let dropped: u64 = meta.iter().map(|m| m["dropped"].as_u64().unwrap()).sum();
    assert_eq!(meta.last().expect("frames arrived")["sequence"], 59);
    assert_eq!(
        meta.len() as u64 + dropped,
        60,
        "every frame is accounted for"
    );
    if dropped > 0 {
        eprintln!("note: the subscriber dropped {dropped} of 60 frames (machine overloaded)");
    }
    assert!(
        meta.len() >= 45,
        "most frames arrive even on a busy machine: {}",
        meta.len()
    );
    for w in meta.windows(2) {
        assert!(
            w[0]["sequence"].as_u64() < w[1]["sequence"].as_u64(),
            "in order"
        );
    }
    for m in &meta {
        assert_eq!(m["rejected"], 0, "headers and intrinsics pass the checks");
    }
    let received = Recording::open(&got).unwrap();
    let n = received.len();
    assert_eq!(n, meta.len());
    let k = received.intrinsics();
    assert_eq!((k.width, k.height), (320, 240), "Dummy's depth mode");
    // The Dummy device's frames change: a stuck stream would not.
    assert_ne!(
        received.read_frame(0).unwrap(),
        received.read_frame(n - 1).unwrap()
    );
    // Device time travels along and moves on at ~30 fps.
    let frames = meta[n - 1]["sequence"].as_u64().unwrap() - meta[0]["sequence"].as_u64().unwrap();
    let span = received.capture_ns(n - 1) - received.capture_ns(0);
    let per_frame = span / frames;
    assert!(
        (25_000_000..45_000_000).contains(&per_frame),
        "{per_frame} ns a frame"
    );
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}

#[test]
fn an_oni_recorded_from_the_dummy_device_plays_back_through_capture_with_every_frame_bit_exact() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let (dir, oni, got) = (
        tmp.path().join("rec"),
        tmp.path().join("dummy.oni"),
        tmp.path().join("got"),
    );
    // Record 60 frames: our recording of the frames as read, and the .oni that OpenNI2's
    // recorder writes from the same stream meanwhile.
    succeed(
        p.command("airglyph")
            .args(["record", "--source", "openni2:Dummy", "--frames", "60"])
            .arg("--out")
            .arg(&dir)
            .arg("--oni")
            .arg(&oni),
    );
    let read = Recording::open(&dir).unwrap();
    assert_eq!(read.len(), 60);
    let nodes = airglyph_capture::onifile::depth_nodes(&std::fs::read(&oni).unwrap()).unwrap();
    assert_eq!(nodes.len(), 1, "one depth stream in {}", oni.display());
    assert!(
        !nodes[0].has_cropping,
        "the Dummy trap is present in the file"
    );
    let in_file = nodes[0].frames as usize;
    assert!(in_file >= 60, "the recorder kept every frame: {nodes:?}");

    // Play it back through the capture stage in real time (a subscriber that writes PNGs
    // cannot keep up with --fast, and the pipeline drops frames rather than queue them).
    let (probe, rx) = start_probe(&p, &["--out", got.to_str().unwrap(), "--idle", "3"]);
    let capture = p
        .stage("capture")
        .arg("--source")
        .arg(format!("openni2:{}", oni.display()))
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&capture.stderr);
    assert!(capture.status.success(), "{log}");
    assert!(
        log.contains("lacks the cropping property") && log.contains("copy"),
        "the user is told the file is played through a repaired copy: {log}"
    );
    assert!(wait_exit(probe, 15).success());
    let meta: Vec<serde_json::Value> = rx.try_iter().collect();
    // The capture stage published exactly the file's frames: sequences 0..N-1. A
    // subscriber starved by an overloaded machine drops frames by design (the pipeline
    // never queues); those are counted, and on a quiet machine there are none.
    let dropped: u64 = meta.iter().map(|m| m["dropped"].as_u64().unwrap()).sum();
    let last = meta.last().expect("frames arrived")["sequence"]
        .as_u64()
        .unwrap();
    assert_eq!(
        last + 1,
        in_file as u64,
        "the file's last frame is the last one published"
    );
    assert_eq!(
        meta.len() as u64 + dropped,
        in_file as u64,
        "exactly the file's frames, then the end"
    );
    if dropped > 0 {
        eprintln!(
            "note: the subscriber dropped {dropped} of {in_file} frames (machine overloaded)"
        );
    }

    // Bit-exact: every frame read while recording is in the playback at the same time
    // relative to the file's clock (OpenNI2's recorder starts it at 0; within a
    // millisecond, since a file's time 0 travels as 1 ns).
    let played = Recording::open(&got).unwrap();
    assert_eq!(played.len(), meta.len());
    let frames: Vec<_> = (0..played.len())
        .map(|j| played.read_frame(j).unwrap())
        .collect();
    // Device time of the file's clock 0, from a frame both sides have.
    let offset = (0..read.len().min(10))
        .find_map(|i| {
            let px = read.read_frame(i).unwrap();
            frames
                .iter()
                .position(|f| *f == px)
                .map(|j| read.capture_ns(i) as i64 - played.capture_ns(j) as i64)
        })
        .expect("one of the first frames read is in the playback");
    let mut missing = 0u64;
    for i in 0..read.len() {
        let t = read.capture_ns(i) as i64 - offset;
        match (0..played.len()).find(|&j| (played.capture_ns(j) as i64 - t).abs() < 1_000_000) {
            Some(j) => assert!(
                frames[j] == read.read_frame(i).unwrap(),
                "frame {i} bit-exact"
            ),
            None => missing += 1,
        }
    }
    assert!(
        missing <= dropped,
        "{missing} frames read while recording are not in the playback ({dropped} dropped in delivery)"
    );
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}

#[test]
fn devices_lists_both_backends_and_cameras_that_are_not_there_fail_clearly() {
    let p = Isolated::new();
    let out = succeed(
        p.command("airglyph")
            .args(["devices", "--json", "--openni2-uri", "Dummy"]),
    );
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2, "one line a backend: {lines:?}");
    assert_eq!(lines[0]["backend"], "v4l2");
    assert_eq!(lines[1]["backend"], "openni2");
    let dummy = lines[1]["devices"]
        .as_array()
        .unwrap()
        .iter()
        .find(|d| d["source"] == "openni2:Dummy")
        .expect("Dummy listed");
    assert_eq!(dummy["modes"][0]["width"], 320);
    assert_eq!(dummy["modes"][0]["format"], "DEPTH_1_MM");

    for (source, want) in [
        (
            "v4l2:/dev/video-airglyph-none",
            "no V4L2 device /dev/video-airglyph-none",
        ),
        (
            "openni2:NoSuchCamera",
            "cannot open device \"NoSuchCamera\"",
        ),
        (
            "openni2:Dummy?mode=640x480@30",
            "does not support the depth mode 640x480@30",
        ),
    ] {
        let out = p
            .stage("capture")
            .args(["--source", source])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{source} opened");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(want), "{source}: {err}");
    }
}
