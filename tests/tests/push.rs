//! The viewer's push stream (`/events`, server-sent events) with real processes: a
//! script receives the gestures the supervisor prints while a client that never reads
//! holds a stream open beside it. (The page's own use of it, through headless Chromium,
//! is `viewer.rs`: its panels are filled from the stream only.)

use airglyph_system_tests::{json_lines, one_at_a_time, python3, shut_down, Isolated};
use std::io::Write;
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn a_script_gets_each_gesture_pushed_while_a_client_that_never_reads_holds_on() {
    let Some(python) = python3() else {
        eprintln!("skipped: no python3 on PATH for the example script");
        return;
    };
    let _one = one_at_a_time();
    let p = Isolated::new();
    let addr = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let mut run = p
        .command("airglyph")
        .args(["run", "--view", "--listen", &addr.to_string()])
        .args([
            "--source",
            "synthetic:draw:37L",
            "--loop",
            "--truth",
            "--json",
        ])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let printed = json_lines(run.stdout.take().unwrap());
    let deadline = Instant::now() + Duration::from_secs(30);
    while TcpStream::connect(addr).is_err() {
        assert!(Instant::now() < deadline, "the viewer never listened");
        std::thread::sleep(Duration::from_millis(100));
    }
    // Asks for everything, as fast as it comes, and never reads a byte of it.
    let mut hog = TcpStream::connect(addr).unwrap();
    write!(
        hog,
        "GET /events?skeletons=60&state=60 HTTP/1.1\r\nHost: {addr}\r\n\r\n"
    )
    .unwrap();

    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../python/examples/push_events.py");
    let mut reader = Command::new(python)
        .arg(script)
        .args([
            "--url",
            &format!("http://{addr}"),
            "--count",
            "3",
            "--skeletons",
            "5",
        ])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let pushed = json_lines(reader.stdout.take().unwrap());
    let mut gestures = Vec::new();
    let mut skeletons = 0;
    let deadline = Instant::now() + Duration::from_secs(120);
    while gestures.len() < 3 {
        let left = deadline.saturating_duration_since(Instant::now());
        let line = pushed.recv_timeout(left).expect("three gestures pushed");
        match line["event"].as_str() {
            Some("gesture") => gestures.push(line),
            Some("skeleton") => skeletons += 1,
            _ => {}
        }
    }
    assert!(reader.wait().unwrap().success());
    assert!(skeletons > 0, "skeletons were pushed at the rate asked");
    // The same gestures, with the same keys, as the supervisor printed.
    std::thread::sleep(Duration::from_millis(500));
    let supervisor: Vec<serde_json::Value> = printed.try_iter().collect();
    for g in &gestures {
        let same = supervisor
            .iter()
            .find(|s| s["session"] == g["session"] && s["end_frame"] == g["end_frame"]);
        let same = same.unwrap_or_else(|| panic!("{g} was not printed by run: {supervisor:?}"));
        assert_eq!(same["label"], g["label"]);
        let keys = |v: &serde_json::Value| {
            let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
            k.sort();
            k
        };
        assert_eq!(keys(same), keys(g));
    }
    // The pipeline kept its pace with the stalled client connected: capture's rate.
    let top = airglyph_system_tests::top(&p);
    let fps = top["stages"]["capture"]["fps"].as_f64().unwrap();
    assert!(
        fps > 20.0,
        "capture at {fps} fps beside a client that does not read"
    );
    drop(hog);
    shut_down(&p, run);
}
