//! The pipeline's foundation with real processes: replay, supervision, recording.

use airglyph_core::recording::Recording;
use airglyph_system_tests::{
    ramp, stage_children, start_probe, stop, write_ramp_recording, Isolated,
};
use std::process::Stdio;
use std::time::{Duration, Instant};

#[test]
fn capture_replays_a_recording_to_another_process_bit_exact_in_order() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let (src, got) = (tmp.path().join("src"), tmp.path().join("got"));
    write_ramp_recording(&src, 100, 64, 48);

    // The probe stops 3 s after the last frame if a frame was lost on the way.
    let (probe, rx) = start_probe(
        &p,
        &[
            "--out",
            got.to_str().unwrap(),
            "--frames",
            "100",
            "--idle",
            "3",
        ],
    );
    let capture = p
        .stage("capture")
        .args(["--source", &format!("recording:{}", src.display())])
        .status()
        .unwrap();
    assert!(capture.success());
    let meta: Vec<serde_json::Value> = rx.iter().take(100).collect();
    stop(probe);

    // A subscriber that falls behind loses its oldest frames by design (safe overflow,
    // two frames deep) rather than slowing the capture; the probe writes on a thread of
    // its own so that it keeps up, but a loaded machine can still starve it for longer
    // than two frames. So: whatever was lost is counted in the next frame's `dropped`,
    // the newest frame always arrives, and every frame that arrives is the right one.
    let sequence = |m: &serde_json::Value| m["sequence"].as_u64().unwrap();
    let mut next = 0;
    for m in &meta {
        assert_eq!(
            sequence(m),
            next + m["dropped"].as_u64().unwrap(),
            "in order, losses counted: {m}"
        );
        next = sequence(m) + 1;
    }
    assert_eq!(next, 100, "the last frame arrives");
    assert!(
        meta.len() >= 90,
        "only {} of 100 frames arrived",
        meta.len()
    );
    let original = Recording::open(&src).unwrap();
    let received = Recording::open(&got).unwrap();
    assert_eq!(received.len(), meta.len());
    for (j, m) in meta.iter().enumerate() {
        let i = sequence(m) as usize;
        let (capture_ns, publish_ns, receive_ns) = (
            m["capture_ns"].as_u64().unwrap(),
            m["publish_ns"].as_u64().unwrap(),
            m["receive_ns"].as_u64().unwrap(),
        );
        assert!(capture_ns <= publish_ns && publish_ns <= receive_ns, "{m}");
        assert_eq!(
            m["source_ns"].as_u64().unwrap(),
            original.capture_ns(i),
            "the recorded time travels along"
        );
        assert_eq!(
            received.read_frame(j).unwrap(),
            original.read_frame(i).unwrap(),
            "frame {i} bit-exact"
        );
    }
    // Paced at 30 fps by frames.csv: 100 frames span about 3.3 s.
    let (first, last) = (&meta[0], &meta[meta.len() - 1]);
    let span = last["capture_ns"].as_u64().unwrap() - first["capture_ns"].as_u64().unwrap();
    let period = 1e9 / 30.0;
    let intervals = (sequence(last) - sequence(first)) as f64;
    assert!(
        (0.97 * intervals * period..1.36 * intervals * period).contains(&(span as f64)),
        "paced by frames.csv: {span} ns over {intervals} frame intervals"
    );
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}

#[test]
fn a_killed_capture_stage_is_restarted_and_leaves_no_shared_memory() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("src");
    write_ramp_recording(&src, 30, 32, 24);

    let (probe, rx) = start_probe(&p, &["--idle", "30"]);
    let supervisor = p
        .command("airglyph")
        .args([
            "run",
            "--stages",
            "capture",
            "--loop",
            "--source",
            &format!("recording:{}", src.display()),
        ])
        .spawn()
        .unwrap();
    let first = rx
        .recv_timeout(Duration::from_secs(10))
        .expect("frames flow");
    let captures = stage_children(supervisor.id(), "capture");
    assert_eq!(captures.len(), 1, "one capture child: {captures:?}");
    let before_kill = p.shm_files();
    assert!(!before_kill.is_empty());

    // SAFETY: kill(2) on the capture child we just found.
    unsafe { libc::kill(captures[0] as i32, libc::SIGKILL) };
    let killed_at = Instant::now();
    // Drain what was sent before the kill, then wait for the new session's first frame.
    let restarted = loop {
        let m = rx
            .recv_timeout(Duration::from_secs(5))
            .expect("frames again after the restart");
        if m["session"] != first["session"] {
            break m;
        }
    };
    let gap = killed_at.elapsed();
    assert!(gap < Duration::from_secs(2), "frames again after {gap:?}");
    assert_eq!(restarted["sequence"], 0, "a new session counts from 0");
    let now = stage_children(supervisor.id(), "capture");
    assert_eq!(now.len(), 1);
    assert_ne!(now[0], captures[0]);
    // The dead publisher's data segment is gone while the pipeline runs on.
    let after = p.shm_files();
    let gone: Vec<_> = before_kill.iter().filter(|f| !after.contains(f)).collect();
    assert!(
        !gone.is_empty(),
        "the dead capture's shared memory is still there: {before_kill:?}"
    );

    assert!(
        stop(supervisor).success(),
        "the supervisor stops cleanly on SIGTERM"
    );
    stop(probe);
    assert!(
        p.shm_files().is_empty(),
        "left behind after shutdown: {:?}",
        p.shm_files()
    );
}

#[test]
fn a_recording_recorded_from_a_recording_is_bit_exact() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let (src, copy) = (tmp.path().join("src"), tmp.path().join("copy"));
    write_ramp_recording(&src, 20, 40, 30);
    let status = p
        .command("airglyph")
        .args([
            "record",
            "--fast",
            "--source",
            &format!("recording:{}", src.display()),
            "--out",
            copy.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(status.success());
    let (a, b) = (
        Recording::open(&src).unwrap(),
        Recording::open(&copy).unwrap(),
    );
    assert_eq!(a.len(), b.len());
    assert_eq!(a.intrinsics(), b.intrinsics());
    for i in 0..a.len() {
        assert_eq!(a.read_frame(i).unwrap(), b.read_frame(i).unwrap());
        assert_eq!(a.capture_ns(i), b.capture_ns(i));
    }
    assert_eq!(b.read_frame(7).unwrap(), ramp(40, 30, 7));
}

#[test]
fn a_corrupt_frame_is_skipped_and_counted_and_the_stream_goes_on() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("src");
    write_ramp_recording(&src, 10, 16, 12);
    let png = airglyph_core::recording::frame_path(&src, 4);
    let bytes = std::fs::read(&png).unwrap();
    std::fs::write(&png, &bytes[..bytes.len() / 3]).unwrap();

    let (probe, rx) = start_probe(&p, &["--frames", "9"]);
    let out = p
        .stage("capture")
        .args(["--source", &format!("recording:{}", src.display())])
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    assert!(out.status.success());
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(
        log.contains("000004.png") && log.contains("frame 4"),
        "the log names the bad frame: {log}"
    );
    let got: Vec<_> = rx.iter().take(9).collect();
    assert_eq!(got.len(), 9, "the 9 good frames arrive");
    stop(probe);
}

#[test]
fn bad_sources_fail_with_a_clear_message() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let out = p
        .stage("capture")
        .args(["--source", &format!("recording:{}", tmp.path().display())])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("recording.toml") && err.contains("missing"),
        "{err}"
    );
    let out = p
        .stage("capture")
        .args(["--source", "kinect"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown source \"kinect\""));
}

#[test]
fn a_pipeline_left_running_by_a_failed_test_goes_with_its_isolation() {
    // What a test that panics half-way leaves behind: a supervisor and its stages,
    // never stopped. Dropping the test's `Isolated` must take them down, or they would
    // take the CPU from every test after it.
    let p = Isolated::new();
    let mut supervisor = p
        .command("airglyph")
        .args(["run", "--source", "synthetic:poses"])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    let stages = loop {
        let found: Vec<u32> = ["capture", "pose", "gesture"]
            .iter()
            .flat_map(|s| stage_children(supervisor.id(), s))
            .collect();
        if found.len() == 3 {
            break found;
        }
        assert!(Instant::now() < deadline, "stages started: {found:?}");
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(p.processes().len() >= 4, "{:?}", p.processes());
    drop(p);
    let deadline = Instant::now() + Duration::from_secs(5);
    let status = loop {
        if let Some(status) = supervisor.try_wait().unwrap() {
            break status;
        }
        if Instant::now() > deadline {
            let _ = supervisor.kill();
            panic!("the supervisor outlived its isolation");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(!status.success(), "killed, not finished: {status}");
    let alive = |pid: &u32| {
        std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|s| {
            s.rsplit(')')
                .next()
                .is_some_and(|rest| !rest.trim_start().starts_with('Z'))
        })
    };
    let deadline = Instant::now() + Duration::from_secs(5);
    while stages.iter().any(alive) {
        assert!(
            Instant::now() < deadline,
            "stages still running: {stages:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}
