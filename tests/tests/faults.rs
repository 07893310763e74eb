//! Fault isolation with real processes: stages killed at random moments, a slow stage,
//! a publisher of malformed frames. The pipeline must keep running and leave no shared
//! memory behind.

use airglyph_system_tests::{one_at_a_time, shut_down, stage_children, top, Isolated};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

/// A small deterministic generator for kill moments (xorshift64*).
struct Moments(u64);

impl Moments {
    fn next_in(&mut self, lo: f64, hi: f64) -> Duration {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let u = (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64;
        Duration::from_secs_f64(lo + (hi - lo) * u)
    }
}

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
    std::thread::sleep(Duration::from_secs(6));
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
