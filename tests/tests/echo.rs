//! `airglyph echo` as an unrelated process beside a running pipeline: it joins late,
//! hears every gesture once and in order, and prints skeletons, decisions and stats.

use airglyph_system_tests::{
    demo_first_gesture, gesture_identity, json_lines, one_at_a_time, signal, succeed, take_lines,
    Isolated,
};
use std::process::{Child, Stdio};
use std::sync::mpsc;
use std::time::Duration;

fn echo(p: &Isolated, args: &[&str]) -> (Child, mpsc::Receiver<serde_json::Value>) {
    let mut child = p
        .command("airglyph")
        .arg("echo")
        .args(args)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let lines = json_lines(child.stdout.take().unwrap());
    (child, lines)
}

#[test]
fn a_late_echo_prints_every_gesture_of_the_demo_once_in_order() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let (mut demo, demo_lines, first) = demo_first_gesture(&p, "3A7L");
    let (mut gestures_echo, gestures) = echo(&p, &["gesture", "--json"]);

    // The other streams, while the pipeline runs: one line of each, with its keys.
    for (what, key) in [
        ("skeleton", "joints"),
        ("decision", "gesture"),
        ("stats", "fps"),
    ] {
        let out = succeed(
            p.command("airglyph")
                .args(["echo", what, "--json", "--count", "2"]),
        );
        let text = String::from_utf8_lossy(&out.stdout);
        let lines: Vec<serde_json::Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(lines.len(), 2, "echo {what}: {text}");
        assert_eq!(lines[0]["event"], what, "{}", lines[0]);
        assert!(lines[0].get(key).is_some(), "echo {what}: {}", lines[0]);
    }

    let mut from_demo = vec![first];
    from_demo.extend(demo_lines.iter().take_while(|l| l["event"] == "gesture"));
    assert!(demo.wait().unwrap().success());
    let from_demo: Vec<_> = from_demo.iter().map(gesture_identity).collect();
    assert!(
        from_demo.len() >= 3,
        "the demo recognized too little to tell: {from_demo:?}"
    );

    let heard: Vec<_> = take_lines(&gestures, from_demo.len() + 1, Duration::from_secs(3))
        .iter()
        .map(gesture_identity)
        .collect();
    signal(&gestures_echo, libc::SIGTERM);
    assert!(
        gestures_echo.wait().unwrap().success(),
        "echo stops cleanly on SIGTERM"
    );
    assert_eq!(
        heard, from_demo,
        "echo heard every gesture the demo printed, once, in order"
    );
    let _ = gestures_echo.kill();
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}

#[test]
fn the_iceoryx2_configuration_names_the_pipeline() {
    let p = Isolated::new();
    let out = succeed(p.command("airglyph").args(["echo", "iceoryx2-config"]));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(&format!("prefix = \"{}\"", p.prefix)),
        "{text}"
    );
    assert!(
        text.contains(&format!("root-path = \"{}/\"", p.root.display())),
        "{text}"
    );
}
