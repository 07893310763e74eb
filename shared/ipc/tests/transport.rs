//! Publisher and subscriber in one process (two nodes): the contracts of the ports.
//! Multi-process behaviour is tested in the workspace's `tests/` crate.

use airglyph_core::Intrinsics;
use airglyph_ipc::wire::Hand;
use airglyph_ipc::{DepthHeader, IpcConfig, Pipeline, PostureMsg, SkeletonMsg};
use std::time::Duration;

/// A test's own IPC root and prefix; the root's folder and the files in /dev/shm (the
/// node counter, which a pipeline keeps) are removed when this is dropped, so bind it
/// before the pipelines, which then go first.
struct Isolated(IpcConfig);

impl Drop for Isolated {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0.root);
        let _ = std::fs::remove_file(airglyph_ipc::ownership::node_counter(&self.0.prefix));
    }
}

impl Isolated {
    fn config(&self) -> IpcConfig {
        self.0.clone()
    }
}

fn isolated(tag: &str) -> Isolated {
    Isolated(IpcConfig {
        root: format!("/tmp/airglyph-test-{}-{tag}/", std::process::id()),
        prefix: format!("agt{}{tag}_", std::process::id()),
    })
}

#[test]
fn depth_frames_arrive_in_order_and_bad_headers_are_counted() {
    let ipc = isolated("d");
    let cfg = ipc.config();
    let publisher_side = Pipeline::join_with(cfg.clone(), "pub").unwrap();
    let subscriber_side = Pipeline::join_with(cfg, "sub").unwrap();
    let k = Intrinsics::new(4, 3, 10.0, 10.0, 1.5, 1.0);
    let mut publisher = publisher_side.depth_publisher(12).unwrap();
    let mut receiver = subscriber_side.depth_receiver().unwrap();

    publisher
        .publish::<()>(12, |h, px| {
            h.set_intrinsics(&k);
            px.iter_mut()
                .enumerate()
                .for_each(|(i, p)| *p = i as u16 * 100);
            Ok(true)
        })
        .unwrap();
    let frame = receiver
        .recv(Duration::from_secs(1))
        .unwrap()
        .expect("a frame");
    assert_eq!(frame.header().sequence, 0);
    assert_eq!(frame.pixels()[11], 1100);
    assert!(frame.header().capture_ns <= frame.header().publish_ns);
    drop(frame);

    // A header claiming more pixels than its payload holds is refused, not read.
    let mut bad = DepthHeader {
        capture_ns: 1,
        publish_ns: 2,
        sequence: 1,
        ..Default::default()
    };
    bad.set_intrinsics(&Intrinsics::new(640, 480, 500.0, 500.0, 320.0, 240.0));
    publisher.publish_raw(bad, &[0u16; 12]).unwrap();
    assert!(receiver.recv(Duration::from_millis(100)).unwrap().is_none());
    assert_eq!(receiver.rejected(), 1);

    // Skipping sequence 1 (the refused one) shows as one dropped frame.
    publisher
        .publish::<()>(12, |h, _| {
            h.set_intrinsics(&k);
            Ok(true)
        })
        .unwrap();
    publisher
        .publish::<()>(12, |h, _| {
            h.set_intrinsics(&k);
            Ok(true)
        })
        .unwrap();
    let f = receiver.recv(Duration::from_secs(1)).unwrap().unwrap();
    assert_eq!((f.header().sequence, f.dropped), (1, 0));
}

#[test]
fn a_slow_subscriber_loses_the_oldest_frames_and_counts_them() {
    let ipc = isolated("s");
    let cfg = ipc.config();
    let side = Pipeline::join_with(cfg, "both").unwrap();
    // Subscribed before the capture session began: all its frames were meant for us.
    let mut receiver = side.depth_receiver().unwrap();
    let mut publisher = side.depth_publisher(1).unwrap();
    let k = Intrinsics::new(1, 1, 10.0, 10.0, 0.0, 0.0);
    for _ in 0..10 {
        publisher
            .publish::<()>(1, |h, _| {
                h.set_intrinsics(&k);
                Ok(true)
            })
            .unwrap();
    }
    let newest = receiver.latest(Duration::from_secs(1)).unwrap().unwrap();
    assert_eq!(newest.header().sequence, 9);
    assert_eq!(newest.dropped, 9, "sequences 0..=8 never processed");
}

#[test]
fn skeletons_with_nan_or_a_hostile_posture_are_refused() {
    let ipc = isolated("k");
    let side = Pipeline::join_with(ipc.config(), "both").unwrap();
    let publisher = side.skeleton_publisher().unwrap();
    let mut receiver = side.skeleton_receiver().unwrap();
    let mut msg = SkeletonMsg {
        sequence: 3,
        ..Default::default()
    };
    msg.chain.capture_ns = 1;
    msg.set_posture(Hand::Right, Some(PostureMsg::new("pinch", 0.9).unwrap()));
    let mut nan = msg;
    nan.joints[0][0] = f32::NAN;
    let mut long = msg;
    long.postures[Hand::Right as usize].label_len = 1 << 20;
    let mut not_utf8 = msg;
    not_utf8.postures[Hand::Left as usize].label = [0xff; 16];
    not_utf8.postures[Hand::Left as usize].label_len = 4;
    let mut unsure = msg;
    unsure.postures[Hand::Right as usize].confidence = f32::INFINITY;
    // One at a time: the stream keeps the newest 4.
    for bad in [nan, long, not_utf8, unsure] {
        publisher.send(bad).unwrap();
        assert!(receiver.recv(Duration::from_millis(50)).unwrap().is_none());
    }
    publisher.send(msg).unwrap();
    let got = receiver.recv(Duration::from_secs(1)).unwrap().unwrap();
    assert_eq!(got.msg.sequence, 3);
    let posture = got.msg.posture(Hand::Right).unwrap().unwrap();
    assert_eq!((posture.label, posture.confidence), ("pinch", 0.9));
    assert_eq!(receiver.rejected(), 4);
}

/// A publisher of the pipeline's own user can write to a frame after sending it: what
/// the receiver checked must be what it hands out, not re-read from shared memory (a
/// width changed after the check once panicked the pose stage).
#[test]
fn a_header_changed_after_its_check_is_not_seen() {
    let ipc = isolated("t");
    let side = Pipeline::join_with(ipc.config(), "both").unwrap();
    let mut receiver = side.depth_receiver().unwrap();
    let mut publisher = side.depth_publisher(12).unwrap();
    let mut h = DepthHeader {
        capture_ns: 1,
        publish_ns: 2,
        ..Default::default()
    };
    h.set_intrinsics(&Intrinsics::new(4, 3, 10.0, 10.0, 1.5, 1.0));
    let sent = publisher.publish_tamperable(h, &[7u16; 12]).unwrap();
    let frame = receiver.recv(Duration::from_secs(1)).unwrap().unwrap();
    sent.set_width(640);
    assert_eq!(frame.header().width, 4);
    let view = frame.view();
    assert_eq!(
        (view.width(), view.height(), view.pixels().len()),
        (4, 3, 12)
    );
}

/// One publisher per stream: a second is refused, naming the first's process, instead
/// of interleaving two streams.
#[test]
fn a_second_publisher_of_a_stream_is_refused_by_name() {
    let ipc = isolated("p");
    let side = Pipeline::join_with(ipc.config(), "first").unwrap();
    let other = Pipeline::join_with(ipc.config(), "second").unwrap();
    let _first = side.skeleton_publisher().unwrap();
    let err = other
        .skeleton_publisher()
        .err()
        .expect("refused")
        .to_string();
    assert!(
        err.contains("airglyph/skeleton already has a publisher")
            && err.contains(&format!("process {}", std::process::id()))
            && err.contains("\"first\""),
        "{err}"
    );
    let _depth = side.depth_publisher(1).unwrap();
    assert!(other.depth_publisher(1).is_err());
}
