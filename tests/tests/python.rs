//! The Python package (`python/`): its ctypes copies of the wire types against the Rust
//! layout, and its example receiving the demo's gestures through iceoryx2's Python
//! bindings.

use airglyph_ipc::wire::{type_name, Hand, Percentiles};
use airglyph_ipc::{
    DecisionMsg, DepthHeader, GestureEventMsg, LatencyChain, PostureMsg, SkeletonMsg, StageStatsMsg,
};
use airglyph_system_tests::{
    demo_first_gesture, gesture_identity, json_lines, one_at_a_time, python3, signal, take_lines,
    Isolated,
};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

fn python_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../python")
}

/// The Python with iceoryx2's bindings that `scripts/setup` installs (a venv in the
/// target folder), or `AIRGLYPH_PYTHON`.
fn python_with_iceoryx2() -> Option<PathBuf> {
    let candidates = std::env::var_os("AIRGLYPH_PYTHON")
        .map(PathBuf::from)
        .into_iter()
        .chain([Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/python/bin/python3")]);
    candidates.into_iter().find(|p| {
        p.exists()
            && Command::new(p)
                .args(["-c", "import iceoryx2"])
                .stderr(Stdio::null())
                .status()
                .is_ok_and(|s| s.success())
    })
}

/// Offset and size of each field, the struct's size, alignment and type name.
macro_rules! layout {
    ($t:ty { $($field:ident),* $(,)? }) => {{
        let v = <$t>::default();
        let mut fields = serde_json::Map::new();
        $(
            fields.insert(
                stringify!($field).to_owned(),
                json!([std::mem::offset_of!($t, $field), std::mem::size_of_val(&v.$field)]),
            );
        )*
        (
            stringify!($t).to_owned(),
            json!({
                "type_name": type_name::<$t>(),
                "size": std::mem::size_of::<$t>(),
                "align": std::mem::align_of::<$t>(),
                "fields": fields,
            }),
        )
    }};
}

#[test]
fn the_python_wire_types_have_the_rust_layout() {
    let Some(python) = python3() else {
        eprintln!("skipped: no python3 on PATH");
        return;
    };
    let rust: serde_json::Map<String, Value> = [
        layout!(LatencyChain {
            capture_ns,
            capture_publish_ns,
            pose_receive_ns,
            pose_publish_ns,
            gesture_receive_ns,
            gesture_publish_ns
        }),
        layout!(DepthHeader {
            sequence,
            session,
            capture_ns,
            publish_ns,
            source_ns,
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            source_kind,
            flags
        }),
        layout!(PostureMsg {
            label,
            label_len,
            confidence
        }),
        layout!(SkeletonMsg {
            sequence,
            session,
            chain,
            joints,
            confidence,
            person_found,
            _pad,
            visible,
            _reserved,
            postures
        }),
        layout!(GestureEventMsg {
            label,
            label_len,
            score,
            start_sequence,
            end_sequence,
            start_ns,
            end_ns,
            session,
            chain,
            hand,
            _reserved,
            bezier_len,
            bezier,
            posture,
            posture_len,
            _reserved_end
        }),
        layout!(DecisionMsg {
            sequence,
            session,
            chain,
            hand_point,
            gesture,
            hand_found,
            hand,
            _reserved
        }),
        layout!(Percentiles {
            count,
            p50,
            p90,
            p99,
            max
        }),
        layout!(StageStatsMsg {
            stage,
            pid,
            time_ns,
            window_ns,
            frames_in,
            frames_out,
            frames_dropped,
            frames_rejected,
            fps,
            _reserved,
            processing,
            waiting,
            latency
        }),
    ]
    .into_iter()
    .collect();
    let out = Command::new(python)
        .args(["-m", "airglyph.wire"])
        .current_dir(python_dir())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let py: serde_json::Map<String, Value> = serde_json::from_slice(&out.stdout).unwrap();
    // Every type, and every field by name, offset and size: a field added, moved or
    // resized on one side only fails here.
    assert_eq!(
        py.keys().collect::<Vec<_>>(),
        rust.keys().collect::<Vec<_>>()
    );
    for (name, r) in &rust {
        assert_eq!(
            &py[name], r,
            "{name}: Python (left) and Rust (right) differ"
        );
    }
}

/// What a Rust publisher writes, Python reads: each hand's posture and the drawing
/// hand's posture of a gesture, and nothing from labels the Rust receivers refuse.
#[test]
fn python_reads_the_postures_rust_writes() {
    let Some(python) = python3() else {
        eprintln!("skipped: no python3 on PATH");
        return;
    };
    fn bytes<T: Copy>(m: &T) -> Vec<u8> {
        // SAFETY: the wire types are `#[repr(C)]` with every gap a named field
        // (`the_python_wire_types_have_the_rust_layout`), so all their bytes are
        // initialized; the slice lives only while `m` is borrowed.
        unsafe { std::slice::from_raw_parts((m as *const T).cast::<u8>(), size_of::<T>()) }.to_vec()
    }
    let mut s = SkeletonMsg::default();
    s.set_posture(Hand::Right, Some(PostureMsg::new("thumb_up", 0.5).unwrap()));
    let mut hostile = s;
    hostile.postures[Hand::Right as usize].label_len = 99;
    let mut g = GestureEventMsg::default();
    g.set_posture(Some("point")).unwrap();
    let hex = |b: Vec<u8>| b.iter().map(|x| format!("{x:02x}")).collect::<String>();
    let script = format!(
        "import json\n\
         from airglyph import wire\n\
         s = wire.SkeletonMsg.from_buffer_copy(bytes.fromhex('{}'))\n\
         h = wire.SkeletonMsg.from_buffer_copy(bytes.fromhex('{}'))\n\
         g = wire.GestureEventMsg.from_buffer_copy(bytes.fromhex('{}'))\n\
         print(json.dumps([s.posture('left'), s.posture('right'), h.posture('right'), \
         g.posture_text(), wire.GestureEventMsg().posture_text()]))\n",
        hex(bytes(&s)),
        hex(bytes(&hostile)),
        hex(bytes(&g))
    );
    let out = Command::new(python)
        .args(["-c", &script])
        .env("PYTHONPATH", python_dir())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let got: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        got,
        json!([null, ["thumb_up", 0.5], null, "point", null]),
        "left none, right thumb_up, the hostile label refused, the gesture's posture"
    );
}

#[test]
fn the_python_example_prints_the_demos_gestures() {
    let Some(python) = python_with_iceoryx2() else {
        eprintln!(
            "skipped: no Python with iceoryx2's bindings (scripts/setup makes target/python \
             with `pip install iceoryx2==0.10.*`; PyPI unreachable?), or set AIRGLYPH_PYTHON"
        );
        return;
    };
    let _one = one_at_a_time();
    let p = Isolated::new();
    let (mut demo, demo_lines, first) = demo_first_gesture(&p, "3A7");
    // Joins late, like any program started beside a running pipeline.
    let mut example = p
        .command_at(&python)
        .arg(python_dir().join("examples/gestures.py"))
        .env("PYTHONPATH", python_dir())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let heard = json_lines(example.stdout.take().unwrap());
    let mut from_demo = vec![first];
    from_demo.extend(demo_lines.iter().take_while(|l| l["event"] == "gesture"));
    assert!(demo.wait().unwrap().success());
    let got = take_lines(&heard, from_demo.len(), Duration::from_secs(5));
    signal(&example, libc::SIGTERM);
    let ended = example.wait().unwrap();
    assert_eq!(
        got.iter().map(gesture_identity).collect::<Vec<_>>(),
        from_demo.iter().map(gesture_identity).collect::<Vec<_>>(),
        "the Python example heard every gesture of the demo, in order"
    );
    // The same keys as `airglyph run --json`.
    let keys = |v: &Value| {
        let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
        k.sort();
        k
    };
    let mut run_keys = keys(&from_demo[0]);
    run_keys.retain(|k| k != "drawn");
    assert_eq!(keys(&got[0]), run_keys);
    // Stopped by a signal mid-wait, it ends cleanly (iceoryx2's wait raised on it).
    assert!(ended.success(), "the example ended with {ended}");
}
