//! The OpenNI2 backend against the real OpenNI2 runtime: its `Dummy` device, its
//! recorder and its file player. Compiled only with `--features openni2`.
#![cfg(feature = "openni2")]

use airglyph_capture::openni2::{depth_modes_of, list_devices, OpenNi2Source};
use airglyph_capture::{
    CameraOptions, DepthSource, Pacing, SourceError, SourceOptions, SourceSpec,
};
use std::time::Instant;

fn opts(pacing: Pacing, looping: bool) -> SourceOptions {
    SourceOptions { pacing, looping }
}

fn fatal<T>(r: Result<T, SourceError>) -> String {
    match r {
        Err(SourceError::Fatal(m)) => m,
        Err(e) => panic!("expected a fatal error, got {e}"),
        Ok(_) => panic!("expected an error"),
    }
}

fn cam(spec: &str) -> (Option<String>, CameraOptions) {
    match spec.parse::<SourceSpec>().unwrap() {
        SourceSpec::OpenNi2(uri, cam) => (uri, cam),
        other => panic!("{other}"),
    }
}

/// OpenNI2 has one `Dummy` device per process, shared by every test that opens it: the
/// tests that do run one at a time. (A recording made while another test streamed from
/// it once played back a frame other than the one read at that time.)
fn one_dummy_user() -> std::sync::MutexGuard<'static, ()> {
    static DUMMY: std::sync::Mutex<()> = std::sync::Mutex::new(());
    DUMMY.lock().unwrap_or_else(|e| e.into_inner())
}

/// Records `n` frames of the Dummy device to `oni` through OpenNI2's recorder, and
/// returns what was read meanwhile: (source time, pixels).
fn record_dummy(oni: &std::path::Path, n: usize) -> Vec<(u64, Vec<u16>)> {
    let mut s = OpenNi2Source::open_recording(
        Some("Dummy"),
        &CameraOptions::default(),
        &opts(Pacing::Fast, false),
        oni,
    )
    .unwrap();
    let k = s.intrinsics();
    let mut out = Vec::new();
    for _ in 0..n {
        let mut px = vec![0u16; (k.width * k.height) as usize];
        let f = s
            .next_frame(&mut px)
            .unwrap()
            .expect("a live device never ends");
        out.push((f.source_ns, px));
    }
    out
}

#[test]
fn dummy_streams_changing_depth_frames_with_intrinsics() {
    let _dummy = one_dummy_user();
    let modes = depth_modes_of("Dummy").unwrap();
    assert!(modes.iter().any(|m| m.format == "DEPTH_1_MM"), "{modes:?}");
    let mut s = OpenNi2Source::open(
        Some("Dummy"),
        &CameraOptions::default(),
        &opts(Pacing::Realtime, false),
    )
    .unwrap();
    let k = s.intrinsics();
    k.validate().unwrap();
    assert_eq!((k.width, k.height), (modes[0].width, modes[0].height));
    assert_eq!(s.describe(), "openni2:Dummy");
    let mut px = vec![0u16; (k.width * k.height) as usize];
    let mut last: Option<(u64, Vec<u16>)> = None;
    for _ in 0..5 {
        let f = s.next_frame(&mut px).unwrap().unwrap();
        if let Some((t, prev)) = &last {
            assert!(f.source_ns > *t, "device time moves on");
            assert_ne!(prev, &px, "the Dummy device's frames change");
        }
        last = Some((f.source_ns, px.clone()));
    }
}

#[test]
fn bad_uri_unsupported_mode_and_no_device_are_clear_errors() {
    let _dummy = one_dummy_user();
    let (uri, c) = cam("openni2:NoSuchCamera");
    let err = fatal(OpenNi2Source::open(
        uri.as_deref(),
        &c,
        &opts(Pacing::Fast, false),
    ));
    assert!(
        err.contains("cannot open device \"NoSuchCamera\"") && err.contains("openni2:Dummy"),
        "{err}"
    );

    let (uri, c) = cam("openni2:Dummy?mode=1234x567@30");
    let err = fatal(OpenNi2Source::open(
        uri.as_deref(),
        &c,
        &opts(Pacing::Fast, false),
    ));
    assert!(
        err.contains("does not support the depth mode 1234x567@30")
            && err.contains("320x240@30 DEPTH_1_MM"),
        "{err}"
    );
    let (uri, c) = cam("openni2:Dummy?format=Z16");
    let err = fatal(OpenNi2Source::open(
        uri.as_deref(),
        &c,
        &opts(Pacing::Fast, false),
    ));
    assert!(err.contains("format=Z16 applies to v4l2 sources"), "{err}");
    let (uri, c) = cam("openni2:Dummy?mode=@60");
    let err = fatal(OpenNi2Source::open(
        uri.as_deref(),
        &c,
        &opts(Pacing::Fast, false),
    ));
    assert!(err.contains("depth mode @60"), "{err}");

    // The first device: there is none on a machine without a camera.
    if list_devices().unwrap().is_empty() {
        let err = fatal(OpenNi2Source::open(
            None,
            &CameraOptions::default(),
            &opts(Pacing::Fast, false),
        ));
        assert!(
            err.contains("no OpenNI2 device found") && err.contains("openni2:Dummy"),
            "{err}"
        );
    }
}

#[test]
fn missing_and_foreign_oni_files_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("nope.oni");
    let err = fatal(OpenNi2Source::open(
        Some(missing.to_str().unwrap()),
        &CameraOptions::default(),
        &opts(Pacing::Fast, false),
    ));
    assert!(
        err.contains("nope.oni") && err.contains("No such file"),
        "{err}"
    );
    let foreign = tmp.path().join("notes.oni");
    std::fs::write(&foreign, b"these are not depth frames").unwrap();
    let err = fatal(OpenNi2Source::open(
        Some(foreign.to_str().unwrap()),
        &CameraOptions::default(),
        &opts(Pacing::Fast, false),
    ));
    assert!(
        err.contains("notes.oni") && err.contains("not an OpenNI recording"),
        "{err}"
    );
}

#[test]
fn an_oni_recorded_from_dummy_plays_back_every_frame_bit_exact_and_loops_by_reopening() {
    let _dummy = one_dummy_user();
    let tmp = tempfile::tempdir().unwrap();
    let oni = tmp.path().join("dummy.oni");
    let read = record_dummy(&oni, 20);
    let bytes = std::fs::read(&oni).unwrap();
    let nodes = airglyph_capture::onifile::depth_nodes(&bytes).unwrap();
    assert_eq!(nodes.len(), 1);
    assert!(!nodes[0].has_cropping, "the Dummy trap: no cropping record");
    let in_file = nodes[0].frames as u64;
    assert!(
        in_file >= 20,
        "the recorder saw every frame we read: {nodes:?}"
    );

    let uri = oni.to_str().unwrap();
    let mut p = OpenNi2Source::open(
        Some(uri),
        &CameraOptions::default(),
        &opts(Pacing::Fast, false),
    )
    .unwrap();
    assert_eq!(p.file_frames(), Some(in_file));
    let k = p.intrinsics();
    let mut played: Vec<(u64, Vec<u16>)> = Vec::new();
    let mut px = vec![0u16; (k.width * k.height) as usize];
    let t0 = Instant::now();
    while let Some(f) = p.next_frame(&mut px).unwrap() {
        played.push((f.source_ns, px.clone()));
    }
    assert!(
        t0.elapsed().as_secs_f64() < 1.5,
        "fast playback waits for nothing: {:?}",
        t0.elapsed()
    );
    assert_eq!(
        played.len() as u64,
        in_file,
        "every frame of the file, no more"
    );
    // The recorder rebases time to the first frame; frames keep their spacing.
    let base = read[0].0;
    let first = played[0].0;
    for (i, (t, pixels)) in read.iter().enumerate() {
        let hit = played
            .iter()
            .find(|(pt, _)| (pt - first).abs_diff(t - base) < 1_000_000)
            .unwrap_or_else(|| panic!("frame {i} (t={t}) missing from playback"));
        assert!(hit.1 == *pixels, "frame {i} bit-exact");
    }
    drop(p);

    // start=N: reopen-and-skip stands in for OpenNI2's broken seek.
    let (_, c) = cam("openni2:x.oni?start=5");
    let mut s = OpenNi2Source::open(Some(uri), &c, &opts(Pacing::Fast, false)).unwrap();
    let mut n = 0;
    while s.next_frame(&mut px).unwrap().is_some() {
        assert!(px == played[5 + n].1, "frame {} after start=5", 5 + n);
        n += 1;
    }
    assert_eq!(n as u64, in_file - 5);
    let (_, c) = cam(&format!("openni2:x.oni?start={in_file}"));
    let err = fatal(OpenNi2Source::open(
        Some(uri),
        &c,
        &opts(Pacing::Fast, false),
    ));
    assert!(
        err.contains(&format!("the recording has {in_file} frames")),
        "{err}"
    );

    // Looping starts the file over (by reopening it) with the same frames.
    let mut l = OpenNi2Source::open(
        Some(uri),
        &CameraOptions::default(),
        &opts(Pacing::Fast, true),
    )
    .unwrap();
    for i in 0..in_file as usize + 3 {
        l.next_frame(&mut px).unwrap().expect("looping never ends");
        assert!(px == played[i % in_file as usize].1, "pass 2 frame {i}");
    }

    // Real time: paced by the recorded timestamps (33 ms apart at 30 fps).
    let mut r = OpenNi2Source::open(
        Some(uri),
        &CameraOptions::default(),
        &opts(Pacing::Realtime, false),
    )
    .unwrap();
    let t0 = Instant::now();
    for _ in 0..6 {
        r.next_frame(&mut px).unwrap().unwrap();
    }
    let took = t0.elapsed().as_secs_f64();
    assert!((0.14..0.5).contains(&took), "5 intervals of 33 ms: {took}");
    // A mode other than the recorded one cannot be had from a file.
    let (_, c) = cam("openni2:x.oni?mode=640x480@30");
    let err = fatal(OpenNi2Source::open(
        Some(uri),
        &c,
        &opts(Pacing::Fast, false),
    ));
    assert!(
        err.contains("plays in the mode it was recorded in"),
        "{err}"
    );
}

/// Looping playback reopens the file at its end, many times over in a long session.
/// Before a stopped stream was left to settle before it was destroyed (`Drop for
/// Stream`), about one reopen in a hundred crashed the process inside libOniFile: this
/// test died by SIGSEGV in 6 runs of 6.
#[test]
fn looping_playback_survives_many_reopens() {
    let _dummy = one_dummy_user();
    let tmp = tempfile::tempdir().unwrap();
    let oni = tmp.path().join("short.oni");
    record_dummy(&oni, 5);
    let mut p = OpenNi2Source::open(
        Some(oni.to_str().unwrap()),
        &CameraOptions::default(),
        &opts(Pacing::Fast, true),
    )
    .unwrap();
    let per_pass = p.file_frames().unwrap();
    let k = p.intrinsics();
    let mut px = vec![0u16; (k.width * k.height) as usize];
    let passes = 150;
    for i in 0..passes * per_pass {
        assert!(
            p.next_frame(&mut px).unwrap().is_some(),
            "looping playback ended at frame {i}"
        );
    }
}
