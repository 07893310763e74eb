//! Fault isolation with real processes: stages killed at random moments, a slow stage,
//! a publisher of malformed frames. The pipeline must keep running and leave no shared
//! memory behind.

use airglyph_system_tests::kills::{KillRun, Moments};
use airglyph_system_tests::{
    drawn_for, drawn_symbols, json_lines, one_at_a_time, shut_down, stage_children, start_probe,
    top, wait_for_frame, Isolated,
};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

fn start_pipeline(p: &Isolated, extra: &[&str]) -> Child {
    p.command("airglyph")
        .args([
            "run",
            "--source",
            "synthetic:poses",
            "--max-restarts",
            "100",
        ])
        .args(extra)
        .stdout(Stdio::null())
        .spawn()
        .unwrap()
}

fn pid_of(supervisor: &Child, stage: &str) -> Option<u32> {
    let pids = stage_children(supervisor.id(), stage);
    assert!(pids.len() <= 1, "two {stage} stages at once: {pids:?}");
    pids.first().copied()
}

fn wait_for_pid(supervisor: &Child, stage: &str, within: Duration) -> Option<(u32, Duration)> {
    let t = Instant::now();
    while t.elapsed() < within {
        if let Some(pid) = pid_of(supervisor, stage) {
            return Some((pid, t.elapsed()));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    None
}

fn kill_repeatedly(stage: &str, seed: u64) {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let supervisor = start_pipeline(&p, &[]);
    let stages = ["capture", "pose", "gesture"];
    for s in stages {
        assert!(
            wait_for_pid(&supervisor, s, Duration::from_secs(10)).is_some(),
            "{s} started"
        );
    }
    let mut moments = Moments(seed);
    let mut worst = Duration::ZERO;
    for round in 0..10 {
        // A random moment, but later than 2 s after the last start: a stage that dies
        // younger than that waits longer for its restart each time (backoff).
        std::thread::sleep(moments.next_in(2.1, 3.0));
        let others: Vec<(&str, u32)> = stages
            .iter()
            .filter(|&&s| s != stage)
            .map(|&s| (s, pid_of(&supervisor, s).unwrap()))
            .collect();
        let victim = pid_of(&supervisor, stage).expect("the stage runs");
        // SAFETY: kill(2) on a grandchild we found in /proc just now.
        unsafe { libc::kill(victim as i32, libc::SIGKILL) };
        let killed = Instant::now();
        let back = loop {
            match pid_of(&supervisor, stage) {
                Some(pid) if pid != victim => break killed.elapsed(),
                _ if killed.elapsed() > Duration::from_secs(5) => {
                    panic!("{stage} not back after 5 s (round {round})")
                }
                _ => std::thread::sleep(Duration::from_millis(5)),
            }
        };
        worst = worst.max(back);
        assert!(
            back < Duration::from_secs(1),
            "{stage} back after {back:?} (round {round})"
        );
        for (s, pid) in others {
            assert_eq!(
                pid_of(&supervisor, s),
                Some(pid),
                "{s} kept running while {stage} died"
            );
        }
    }
    eprintln!("{stage}: 10 kills, slowest return {worst:?}");
    // And the pipeline still works end to end.
    std::thread::sleep(Duration::from_secs(3));
    let stats = top(&p);
    for s in stages {
        assert!(
            stats["stages"][s]["frames_out"].as_u64().unwrap_or(0) > 0,
            "{s} works after the kills: {stats}"
        );
    }
    shut_down(&p, supervisor);
}

#[test]
fn killing_capture_ten_times_leaves_the_others_running() {
    kill_repeatedly("capture", 1);
}

#[test]
fn killing_pose_ten_times_leaves_the_others_running() {
    kill_repeatedly("pose", 2);
}

#[test]
fn killing_gesture_ten_times_leaves_the_others_running() {
    kill_repeatedly("gesture", 3);
}

#[test]
fn a_slow_gesture_stage_never_slows_capture() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let supervisor = start_pipeline(&p, &["--stage-args", "gesture=--delay-ms 700"]);
    // A gesture stage that starts first catches up through the skeletons' history (for
    // at most 2 s, lagging behind meanwhile), then drops what it cannot take.
    std::thread::sleep(Duration::from_secs(7));
    let stats = top(&p);
    let capture_fps = stats["stages"]["capture"]["fps"].as_f64().unwrap();
    assert!(capture_fps > 24.0, "capture keeps its 30 fps: {stats}");
    let pose_out = stats["stages"]["pose"]["frames_out"].as_u64().unwrap();
    let gesture_in = stats["stages"]["gesture"]["frames_in"].as_u64().unwrap();
    let gesture_dropped = stats["stages"]["gesture"]["frames_dropped"]
        .as_u64()
        .unwrap();
    assert!(
        gesture_dropped > 0,
        "the slow stage drops skeletons and counts them: {stats}"
    );
    // Each stage reports once a second, not at the same moment: the gesture stage's
    // report may count up to a second (30 frames) of skeletons past pose's last one.
    assert!(gesture_in + gesture_dropped <= pose_out + 30 + 8, "{stats}");
    shut_down(&p, supervisor);
}

#[test]
fn malformed_frames_are_rejected_and_counted_by_the_receiving_stage() {
    let p = Isolated::new();
    let supervisor = p
        .command("airglyph")
        .args(["run", "--stages", "pose"])
        .spawn()
        .unwrap();
    wait_for_pid(&supervisor, "pose", Duration::from_secs(5)).expect("pose runs");
    std::thread::sleep(Duration::from_millis(500));
    let status = p
        .command("airglyph-probe")
        .args(["--publish-bad", "5"])
        .status()
        .unwrap();
    assert!(status.success());
    let stats = top(&p);
    assert_eq!(stats["stages"]["pose"]["frames_rejected"], 5, "{stats}");
    assert_eq!(stats["stages"]["pose"]["frames_in"], 0, "{stats}");
    shut_down(&p, supervisor);
}

#[test]
fn a_stage_that_cannot_start_ends_the_pipeline_with_a_clear_message() {
    let p = Isolated::new();
    let out = p
        .command("airglyph")
        .args([
            "run",
            "--stages",
            "gesture",
            "--max-restarts",
            "2",
            "--stage-args",
            "gesture=--model /nonexistent.json",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("stage gesture died 3 times") && err.contains("giving up"),
        "{err}"
    );
    assert!(
        err.contains("/nonexistent.json"),
        "the stage's own error is shown: {err}"
    );
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}

/// `airglyph run --json | head -1`: when whoever reads the events goes, the supervisor
/// stops its stages and leaves nothing behind instead of dying on a broken pipe.
#[test]
fn the_supervisor_stops_cleanly_when_the_reader_of_its_events_goes() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let mut supervisor = p
        .command("airglyph")
        .args(["run", "--source", "synthetic:draw:0123", "--loop", "--json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut events = std::io::BufReader::new(supervisor.stdout.take().unwrap());
    let mut first = String::new();
    std::io::BufRead::read_line(&mut events, &mut first).unwrap();
    assert!(
        first.contains(r#""event":"gesture""#),
        "a first event: {first}"
    );
    drop(events);
    let deadline = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(status) = supervisor.try_wait().unwrap() {
            break status;
        }
        assert!(
            Instant::now() < deadline,
            "the supervisor kept running with nobody reading its events"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut supervisor.stderr.take().unwrap(), &mut err).unwrap();
    assert!(status.success(), "{status}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}

/// `airglyph synth … --json | true`: an offline tool whose reader has gone ends quietly,
/// as `cat` or `grep` do, instead of panicking in the middle of its output.
#[test]
fn an_offline_tool_ends_quietly_when_the_reader_of_its_output_goes() {
    let p = Isolated::new();
    let dir = tempfile::tempdir().unwrap();
    let mut synth = p
        .command("airglyph")
        .args(["synth", "--motion", "pose:neutral", "--frames", "2"])
        .args(["--resolution", "320x240", "--json", "--out"])
        .arg(dir.path().join("rec"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The reader goes before the summary is written.
    drop(synth.stdout.take());
    let status = synth.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(&mut synth.stderr.take().unwrap(), &mut err).unwrap();
    assert!(!err.contains("panicked"), "{status}: {err}");
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(status.signal(), Some(libc::SIGPIPE), "{status}: {err}");
    // What was written before is whole.
    assert!(dir.path().join("rec/recording.toml").exists());
}

/// Issue 28, item 6: a gesture stage killed while a symbol was drawn, or while it was
/// pending (drawn, not yet decided), lost it: 5 of 19 symbols drawn around 10 kills.
/// The restarted stage is handed the last 8.5 s of skeletons (the skeleton service's
/// history) and finds it again; what it had reported before the kill it does not
/// report again. Killed here in the middle of the second symbol and just after the
/// third; every symbol must be reported exactly once, and named right (the truth
/// skeletons leave the classifier nothing to get wrong).
#[test]
fn a_symbol_pending_when_the_gesture_stage_is_killed_is_reported_once() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let script = "draw:0123";
    let truth = drawn_symbols(script);
    let middle = |k: usize| ((truth[k].start_frame + truth[k].end_frame) / 2) as u64;
    let kills = [middle(1), truth[2].end_frame as u64 + 10];
    let (mut probe, skeletons) = start_probe(&p, &["--stream", "skeleton", "--idle", "120"]);
    let mut supervisor = p
        .command("airglyph")
        .args(["run", "--truth", "--json", "--max-restarts", "100"])
        .args(["--source", &format!("synthetic:{script}")])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let events = json_lines(supervisor.stdout.take().unwrap());
    for frame in kills {
        wait_for_frame(&skeletons, frame, Duration::from_secs(120));
        let (victim, _) = wait_for_pid(&supervisor, "gesture", Duration::from_secs(10))
            .expect("a gesture stage to kill");
        // SAFETY: kill(2) on a grandchild we found in /proc just now.
        unsafe { libc::kill(victim as i32, libc::SIGKILL) };
        eprintln!("killed the gesture stage at frame {frame}");
    }
    // Capture ends with the script; the supervisor then stops the rest.
    let deadline = Instant::now() + Duration::from_secs(120);
    while supervisor.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "the drawing did not end");
        std::thread::sleep(Duration::from_millis(100));
    }
    let reported: Vec<serde_json::Value> = events.try_iter().collect();
    let mut per_symbol = vec![Vec::new(); truth.len()];
    for e in &reported {
        let (start, end) = (e["start_frame"].as_u64(), e["end_frame"].as_u64());
        match drawn_for(&truth, start.unwrap(), end.unwrap()) {
            Some(i) => per_symbol[i].push(e["label"].as_str().unwrap_or("?").to_owned()),
            None => panic!("a gesture reported where none was drawn: {e}"),
        }
    }
    for (t, labels) in truth.iter().zip(&per_symbol) {
        eprintln!(
            "drew {} (frames {}–{}): reported {labels:?}",
            t.label, t.start_frame, t.end_frame
        );
    }
    for (t, labels) in truth.iter().zip(&per_symbol) {
        assert_eq!(
            labels,
            std::slice::from_ref(&t.label),
            "{} reported exactly once: {reported:#?}",
            t.label
        );
    }
    let sessions: std::collections::BTreeSet<_> =
        reported.iter().map(|e| e["session"].as_u64()).collect();
    assert_eq!(sessions.len(), 1, "one capture session: {reported:#?}");
    airglyph_system_tests::signal(&probe, libc::SIGTERM);
    let _ = probe.wait();
}

/// Issue 28, the kill test extended (the light version; `scripts/eval kills` kills each
/// stage ten times, pose too, release build): three SIGKILLs of the gesture stage, then
/// of capture, while the person draws seven symbols (truth skeletons: nothing but the
/// kills can make a symbol missed or misnamed). Every symbol drawn whole in a capture
/// session must be reported exactly once, with its label; a capture kill starts the
/// script again in a new session.
#[test]
fn symbols_drawn_while_gesture_or_capture_is_killed_are_each_reported_once() {
    for (stage, seed) in [("gesture", 5), ("capture", 6)] {
        let _one = one_at_a_time();
        let p = Isolated::new();
        let report = KillRun {
            stage,
            kills: 3,
            symbols: "0123456".into(),
            truth: true,
            seed,
        }
        .run(&p);
        eprint!("{}", report.summary());
        assert_eq!(report.process_back.len(), 3, "{report:#?}");
        assert!(report.drawn >= 7, "the script was drawn whole: {report:#?}");
        assert_eq!(report.once, report.drawn, "{report:#?}");
        assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
    }
}
