//! Every long command stops on SIGTERM within 2 s, mid-run, leaving what it wrote whole
//! and saying what it kept; the ones whose work is then unfinished exit with 143 (128 +
//! SIGTERM), `record`, which records until told to stop, with success. (`collect` has
//! its own in collect.rs.)

use airglyph_core::recording::Recording;
use airglyph_system_tests::{one_at_a_time, signal, synth, write_glyphs, Isolated};
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, ExitStatus, Stdio};
use std::sync::{mpsc, OnceLock};
use std::time::{Duration, Instant};

/// The status of a command stopped by SIGTERM and then finished, unless said otherwise.
const STOPPED: i32 = 128 + libc::SIGTERM;

/// A long command, its stdout and stderr read line by line as it runs (so that neither
/// pipe fills and stops it).
struct Running {
    child: Child,
    stdout: mpsc::Receiver<String>,
    stderr: mpsc::Receiver<String>,
    printed: Vec<String>,
    said: Vec<String>,
}

fn lines_of(pipe: impl Read + Send + 'static) -> mpsc::Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(pipe).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    rx
}

/// Waits for a line of `lines` that contains `text`, keeping every line in `kept`.
fn wait_for(lines: &mpsc::Receiver<String>, kept: &mut Vec<String>, text: &str) {
    let deadline = Instant::now() + Duration::from_secs(120);
    while !kept.iter().any(|l| l.contains(text)) {
        let left = deadline.saturating_duration_since(Instant::now());
        match lines.recv_timeout(left) {
            Ok(line) => kept.push(line),
            Err(_) => panic!("no {text:?}; there was {kept:?}"),
        }
    }
}

impl Running {
    fn start(cmd: &mut std::process::Command) -> Self {
        let mut child = cmd
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        Self {
            stdout: lines_of(child.stdout.take().unwrap()),
            stderr: lines_of(child.stderr.take().unwrap()),
            child,
            printed: Vec::new(),
            said: Vec::new(),
        }
    }

    /// Waits until it writes a line containing `text` to stderr.
    fn says(&mut self, text: &str) {
        wait_for(&self.stderr, &mut self.said, text);
    }

    /// Waits until it writes a line containing `text` to stdout.
    fn prints(&mut self, text: &str) {
        wait_for(&self.stdout, &mut self.printed, text);
    }

    /// Sends SIGTERM and waits for the end, which must come within 2 s. Returns the exit
    /// status, and every line of stdout and of stderr.
    fn terminate(mut self) -> (ExitStatus, Vec<String>, String) {
        signal(&self.child, libc::SIGTERM);
        let sent = Instant::now();
        let status = loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                break status;
            }
            if sent.elapsed() > Duration::from_secs(30) {
                self.child.kill().unwrap();
                panic!("still running 30 s after SIGTERM");
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let took = sent.elapsed();
        // Shown with --nocapture: how far within the bound each command stays.
        eprintln!("ended {took:?} after SIGTERM");
        self.printed.extend(self.stdout.iter());
        self.said.extend(self.stderr.iter());
        let said = self.said.join("\n");
        assert!(
            took <= Duration::from_secs(2),
            "ended {took:?} after SIGTERM; said: {said}"
        );
        (status, self.printed, said)
    }
}

/// Waits until `ready` holds.
fn wait_until(what: &str, ready: impl Fn() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(120);
    while !ready() {
        assert!(Instant::now() < deadline, "{what}: not within 120 s");
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn rows(csv: &Path) -> usize {
    std::fs::read_to_string(csv)
        .map(|t| t.lines().count().saturating_sub(1))
        .unwrap_or(0)
}

/// A synthetic recording of air-drawn digits with its ground truth, made once.
fn drawn_digits() -> &'static Path {
    static DIR: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &DIR.get_or_init(|| {
        let tmp = tempfile::tempdir().unwrap();
        let rec = tmp.path().join("digits");
        synth(&Isolated::new(), "draw:01234567", &rec);
        (tmp, rec)
    })
    .1
}

/// The built-in glyphs of the ten digits, five writers each.
fn glyphs(dir: &Path) -> PathBuf {
    let data = dir.join("glyphs.jsonl");
    write_glyphs(&data, "0123456789", 5);
    data
}

fn shipped_model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/unipen-36.json")
}

#[test]
fn synth_keeps_a_whole_recording_of_the_frames_it_wrote() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("rec");
    let synth = Running::start(
        p.command("airglyph")
            .args([
                "synth",
                "--motion",
                "draw:0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ",
            ])
            .arg("--out")
            .arg(&rec),
    );
    wait_until("five frames written", || rows(&rec.join("frames.csv")) >= 5);
    let (status, _, said) = synth.terminate();
    assert_eq!(status.code(), Some(STOPPED), "{said}");
    let r = Recording::open(&rec).unwrap();
    assert!(r.len() >= 5 && r.len() < 4000, "{} frames", r.len());
    assert!(r.has_joints());
    r.read_frame(r.len() - 1).unwrap();
    // gestures.csv names only the symbols drawn within the frames kept.
    let gestures = std::fs::read_to_string(rec.join("gestures.csv")).unwrap();
    for row in gestures.lines().skip(1) {
        let end: usize = row.rsplit(',').next().unwrap().parse().unwrap();
        assert!(end < r.len(), "{row} beyond {} frames", r.len());
    }
    assert!(
        said.contains(&format!("kept the first {} of", r.len())),
        "{said}"
    );
}

#[test]
fn record_ends_its_recording_whole_and_succeeds() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("rec");
    let record = Running::start(
        p.command("airglyph")
            .args(["record", "--source", "synthetic:draw:0123456789"])
            .arg("--out")
            .arg(&rec),
    );
    wait_until("five frames recorded", || {
        rows(&rec.join("frames.csv")) >= 5
    });
    let (status, _, said) = record.terminate();
    assert!(status.success(), "{status}: {said}");
    let r = Recording::open(&rec).unwrap();
    assert!(r.len() >= 5 && r.has_joints(), "{} frames", r.len());
    r.read_frame(r.len() - 1).unwrap();
    assert!(
        said.contains(&format!("recorded {} frames", r.len())),
        "{said}"
    );
}

#[test]
fn train_writes_no_model_and_leaves_the_old_one() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let model = tmp.path().join("model.json");
    std::fs::write(&model, "the old model").unwrap();
    let mut train = Running::start(
        p.command("airglyph")
            .args(["train", "--data"])
            .arg(glyphs(tmp.path()))
            .arg("--out")
            .arg(&model),
    );
    train.says("training mlp on 50 samples");
    let (status, _, said) = train.terminate();
    assert_eq!(status.code(), Some(STOPPED), "{said}");
    assert!(said.contains("no model was written"), "{said}");
    assert_eq!(std::fs::read_to_string(&model).unwrap(), "the old model");
    assert!(!tmp.path().join("model.json.part").exists());
}

#[test]
fn pose_writes_whole_lines_for_the_frames_it_took() {
    let p = Isolated::new();
    let rec = drawn_digits();
    let frames = Recording::open(rec).unwrap().len();
    let mut pose = Running::start(p.command("airglyph").args(["pose", "--json"]).arg(rec));
    pose.prints("\"frame\":0");
    let (status, lines, said) = pose.terminate();
    assert_eq!(status.code(), Some(STOPPED), "{said}");
    assert!(lines.len() < frames, "{} of {frames} frames", lines.len());
    for (i, l) in lines.iter().enumerate() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert_eq!(v["frame"], i, "{l}");
    }
    assert!(
        said.contains(&format!("the first {} of {frames} frames", lines.len())),
        "{said}"
    );
}

#[test]
fn eval_pose_prints_no_figures_and_keeps_whole_overlays() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let plots = tmp.path().join("plots");
    let eval = Running::start(
        p.command("airglyph")
            .args(["eval-pose", "--overlay-every", "1", "--plots"])
            .arg(&plots)
            .arg(drawn_digits()),
    );
    wait_until("an overlay written", || {
        std::fs::read_dir(&plots).is_ok_and(|d| d.count() >= 2)
    });
    let (status, printed, said) = eval.terminate();
    assert_eq!(status.code(), Some(STOPPED), "{said}");
    assert!(printed.is_empty(), "no figures of part of it: {printed:?}");
    assert!(said.contains("no figures"), "{said}");
    for overlay in std::fs::read_dir(&plots).unwrap().flatten() {
        image::open(overlay.path()).unwrap();
    }
}

#[test]
fn spot_prints_what_it_spotted_before_the_signal() {
    let p = Isolated::new();
    let mut spot = Running::start(
        p.command("airglyph")
            .args(["spot", "--json"])
            .arg(drawn_digits()),
    );
    spot.says("spotting gestures in");
    let (status, printed, said) = spot.terminate();
    assert_eq!(status.code(), Some(STOPPED), "{said}");
    for l in &printed {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert!(v["label"].is_string(), "only gestures, no summary: {l}");
    }
    assert!(said.contains("stopped at frame"), "{said}");
}

#[test]
fn eval_gestures_prints_and_draws_nothing() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let plots = tmp.path().join("plots");
    let mut eval = Running::start(
        p.command("airglyph")
            .args(["eval-gestures", "--folds", "3", "--model"])
            .arg(shipped_model())
            .arg("--data")
            .arg(glyphs(tmp.path()))
            .arg("--plots")
            .arg(&plots),
    );
    eval.says("cross-validating");
    let (status, printed, said) = eval.terminate();
    assert_eq!(status.code(), Some(STOPPED), "{said}");
    assert!(printed.is_empty(), "{printed:?}");
    assert!(!plots.exists());
    assert!(said.contains("nothing was printed or drawn"), "{said}");
}

#[test]
fn eval_spotting_writes_and_prints_nothing() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let dump = tmp.path().join("dump.jsonl");
    let mut eval = Running::start(
        p.command("airglyph")
            .args([
                "eval-spotting",
                "--gestures",
                "2000",
                "--random-seconds",
                "3000",
            ])
            .arg("--model")
            .arg(shipped_model())
            .arg("--data")
            .arg(glyphs(tmp.path()))
            .arg("--dump")
            .arg(&dump),
    );
    eval.says("spotting 2000 gestures");
    let (status, printed, said) = eval.terminate();
    assert_eq!(status.code(), Some(STOPPED), "{said}");
    assert!(printed.is_empty(), "{printed:?}");
    assert!(!dump.exists());
    assert!(said.contains("nothing was written or printed"), "{said}");
}

#[test]
fn profile_writes_the_report_of_what_it_measured_and_stops_its_pipeline() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("report");
    let mut profile = Running::start(
        p.command("airglyph")
            .args(["profile", "--source", "synthetic", "--seconds", "600"])
            .args(["--warmup", "1", "--out"])
            .arg(&out),
    );
    profile.says("measuring for 600 s");
    // Some frames to measure before the signal.
    std::thread::sleep(Duration::from_millis(1500));
    let (status, _, said) = profile.terminate();
    assert_eq!(status.code(), Some(STOPPED), "{said}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("profile.json")).unwrap()).unwrap();
    let seconds = report["seconds"].as_f64().unwrap();
    assert!(seconds > 0.0 && seconds < 600.0, "{report}");
    assert!(report["frames"].as_u64() > Some(0), "{report}");
    for f in ["summary.csv", "frames.csv", "capture_to_decision.png"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    assert!(said.contains("covers the"), "{said}");
    assert!(p.processes().is_empty(), "its pipeline stopped with it");
    assert!(p.shm_files().is_empty(), "{:?}", p.shm_files());
}
