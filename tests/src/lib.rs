//! Helpers for system tests: isolated pipelines, the workspace's binaries, recordings.

pub mod kills;

use airglyph_core::recording::{RecordingInfo, RecordingWriter};
use airglyph_core::{DepthImage, Intrinsics};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Output, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// A pipeline of its own: a fresh iceoryx2 root and /dev/shm prefix, so tests run side
/// by side without seeing each other.
pub struct Isolated {
    pub root: PathBuf,
    pub prefix: String,
}

/// The pipeline goes with it: its processes (a test that fails half-way leaves its
/// supervisor and stages running otherwise, and they would take the CPU from every test
/// after it), its iceoryx2 root folder and its files in /dev/shm. Tests check before
/// that the processes removed their own ([`Isolated::shm_files`]); what is left here
/// is the node counter, which a pipeline keeps on purpose, and whatever processes
/// killed at the end of a test had open.
impl Drop for Isolated {
    fn drop(&mut self) {
        let mut pids = self.processes();
        for &pid in &pids {
            // SAFETY: kill(2) on a process of this test's own pipeline, found by the
            // environment it was started with.
            unsafe { libc::kill(pid as i32, libc::SIGKILL) };
        }
        // Gone before their files are: a process still alive could make more.
        let deadline = Instant::now() + Duration::from_secs(5);
        while !pids.is_empty() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(10));
            pids = self.processes();
        }
        let _ = std::fs::remove_dir_all(&self.root);
        for name in self.all_shm_files() {
            let _ = std::fs::remove_file(Path::new("/dev/shm").join(name));
        }
    }
}

impl Isolated {
    pub fn new() -> Self {
        static N: AtomicU32 = AtomicU32::new(0);
        let n = N.fetch_add(1, Ordering::SeqCst);
        let prefix = format!("agsys{}x{n}_", std::process::id());
        let root = std::env::temp_dir().join(format!("airglyph-sys-{}-{n}/", std::process::id()));
        Self { root, prefix }
    }

    /// A command for one of the workspace's binaries, joined to this pipeline.
    pub fn command(&self, binary: &str) -> Command {
        self.command_at(&binary_path(binary))
    }

    /// A command for the executable at `program`, joined to this pipeline.
    pub fn command_at(&self, program: &Path) -> Command {
        let mut cmd = Command::new(program);
        cmd.env("AIRGLYPH_IPC_ROOT", format!("{}/", self.root.display()))
            .env("AIRGLYPH_IPC_PREFIX", &self.prefix)
            .env("RUST_LOG", "warn");
        cmd
    }

    /// A command for one stage's process (`airglyph stage NAME`), joined to this pipeline.
    pub fn stage(&self, name: &str) -> Command {
        let mut cmd = self.command("airglyph");
        cmd.args(["stage", name]);
        cmd
    }

    /// The processes started for this pipeline (by their environment), still running.
    pub fn processes(&self) -> Vec<u32> {
        let mark = format!("AIRGLYPH_IPC_PREFIX={}", self.prefix);
        let Ok(dir) = std::fs::read_dir("/proc") else {
            return Vec::new();
        };
        dir.filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
            .filter(|pid| {
                std::fs::read(format!("/proc/{pid}/environ"))
                    .is_ok_and(|env| env.split(|&b| b == 0).any(|var| var == mark.as_bytes()))
            })
            .collect()
    }

    /// The files of this pipeline under /dev/shm, but for iceoryx2's node counter,
    /// which the pipeline keeps for ever (closed to other users, it cannot be planted
    /// again between two runs; see `airglyph_ipc::ownership`).
    pub fn shm_files(&self) -> Vec<String> {
        let counter = self.node_counter();
        let counter = counter.file_name().and_then(|n| n.to_str());
        self.all_shm_files()
            .into_iter()
            .filter(|n| Some(n.as_str()) != counter)
            .collect()
    }

    /// iceoryx2's node counter of this pipeline.
    pub fn node_counter(&self) -> PathBuf {
        airglyph_ipc::ownership::node_counter(&self.prefix)
    }

    /// Every file of this pipeline under /dev/shm.
    pub fn all_shm_files(&self) -> Vec<String> {
        let mut files: Vec<String> = std::fs::read_dir("/dev/shm")
            .map(|d| {
                d.filter_map(|e| e.ok())
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .filter(|n| n.starts_with(&self.prefix))
                    .collect()
            })
            .unwrap_or_default();
        files.sort();
        files
    }
}

impl Default for Isolated {
    fn default() -> Self {
        Self::new()
    }
}

/// Where cargo put a binary of this workspace (beside the test's own `deps/` folder).
pub fn binary_path(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let dir = exe
        .parent()
        .and_then(Path::parent)
        .expect("target/<profile>/deps/..");
    let path = dir.join(name);
    assert!(
        path.exists(),
        "{} is not built: run `cargo build --workspace --bins` (scripts/test does)",
        path.display()
    );
    path
}

/// A deterministic 100-frame-like recording: every pixel differs between frames, so a
/// lost, repeated or reordered frame cannot go unnoticed.
pub fn write_ramp_recording(dir: &Path, frames: usize, width: u32, height: u32) {
    let k = Intrinsics::new(
        width,
        height,
        200.0,
        200.0,
        width as f32 / 2.0 - 0.5,
        height as f32 / 2.0 - 0.5,
    );
    let mut w =
        RecordingWriter::create(dir, RecordingInfo::new(k, 30.0, "test-ramp"), false).unwrap();
    for i in 0..frames {
        w.write_frame(
            ramp(width, height, i).view(),
            5_000_000_000 + i as u64 * 33_333_333,
            None,
        )
        .unwrap();
    }
}

pub fn ramp(width: u32, height: u32, frame: usize) -> DepthImage {
    let px = (0..width * height)
        .map(|p| (500 + (p as usize * 7 + frame * 131) % 4000) as u16)
        .collect();
    DepthImage::new(width, height, px).unwrap()
}

/// Writes a 320×240 synthetic recording of the person doing `motion` (`airglyph synth
/// --motion`: `draw:SYMBOLS`, `pose:NAME`, …) into `out`, ground truth and all.
pub fn synth(p: &Isolated, motion: &str, out: &Path) {
    succeed(
        p.command("airglyph")
            .args([
                "synth",
                "--motion",
                motion,
                "--resolution",
                "320x240",
                "--out",
            ])
            .arg(out),
    );
}

/// Trajectory JSONL: each label's built-in glyph `copies` times, each copy a little
/// slanted (another "writer"), so the samples are not all one trajectory.
pub fn write_glyphs(path: &Path, labels: &str, copies: usize) {
    let mut lines = Vec::new();
    for c in labels.chars() {
        let glyph = airglyph_synth::glyphs::template(c).expect("a built-in glyph");
        for k in 0..copies {
            let slant = 0.05 * k as f32;
            let strokes: Vec<Vec<[f32; 2]>> = glyph
                .strokes
                .iter()
                .map(|s| s.iter().map(|p| [p.x + slant * p.y, p.y]).collect())
                .collect();
            lines.push(
                serde_json::json!({"label": c.to_string(), "subject": format!("w{k}"),
                                   "strokes": strokes})
                .to_string(),
            );
        }
    }
    std::fs::write(path, lines.join("\n") + "\n").unwrap();
}

/// Sends SIGTERM (or another signal) to a child.
pub fn signal(child: &Child, sig: i32) {
    // SAFETY: kill(2) on a child we have not reaped.
    unsafe { libc::kill(child.id() as i32, sig) };
}

/// The pids of a process's direct children that run stage `name` (`airglyph stage
/// NAME …`, told by their command line: every stage's process is `airglyph`).
pub fn stage_children(parent: u32, name: &str) -> Vec<u32> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir("/proc").into_iter().flatten().flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
            continue;
        };
        // pid (comm) state ppid ...
        let Some(close) = stat.rfind(')') else {
            continue;
        };
        let ppid = stat[close + 2..]
            .split(' ')
            .nth(1)
            .and_then(|p| p.parse::<u32>().ok());
        if ppid != Some(parent) {
            continue;
        }
        // A child between fork and exec still carries its parent's command line.
        let Ok(cmdline) = std::fs::read(format!("/proc/{pid}/cmdline")) else {
            continue;
        };
        let args: Vec<&[u8]> = cmdline.split(|&b| b == 0).skip(1).take(2).collect();
        if args == [b"stage".as_slice(), name.as_bytes()] {
            out.push(pid);
        }
    }
    out
}

/// Runs a command to its end and asserts it succeeded, showing its stderr if not.
pub fn succeed(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{:?}: {}\n{}",
        cmd,
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs a command that must fail and returns what it wrote to stderr (the message the
/// test then checks).
pub fn fail(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(!out.status.success(), "{cmd:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// One full pipeline at a time within a test binary: on a 2-core machine parallel
/// pipelines starve each other's capture stage and measure the machine instead.
pub fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static ONE_PIPELINE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    ONE_PIPELINE.lock().unwrap_or_else(|e| e.into_inner())
}

/// `airglyph top --json` of this pipeline.
pub fn top(p: &Isolated) -> serde_json::Value {
    let out = succeed(p.command("airglyph").args(["top", "--json", "--wait", "3"]));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// SIGTERM to a supervisor: it must stop cleanly and leave nothing in /dev/shm.
pub fn shut_down(p: &Isolated, mut supervisor: Child) {
    signal(&supervisor, libc::SIGTERM);
    let status = supervisor.wait().unwrap();
    assert!(status.success(), "the supervisor stops cleanly: {status}");
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}

/// Streams a child's JSON lines to a channel (lines that are not JSON are skipped).
pub fn json_lines(stdout: ChildStdout) -> mpsc::Receiver<serde_json::Value> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if let Ok(v) = serde_json::from_str(&line) {
                if tx.send(v).is_err() {
                    break;
                }
            }
        }
    });
    rx
}

/// The gesture events `airglyph run ARGS --json --source recording:REC` prints while it
/// plays `rec` through all three stages to its end (within 90 s).
pub fn played_gestures(p: &Isolated, args: &[&str], rec: &Path) -> Vec<serde_json::Value> {
    let mut run = p
        .command("airglyph")
        .arg("run")
        .args(args)
        .args(["--json", "--source"])
        .arg(format!("recording:{}", rec.display()))
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let events = json_lines(run.stdout.take().unwrap());
    let deadline = Instant::now() + Duration::from_secs(90);
    while run.try_wait().unwrap().is_none() {
        assert!(
            Instant::now() < deadline,
            "run did not end with its recording"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(run.wait().unwrap().success());
    events
        .try_iter()
        .filter(|e| e["event"] == "gesture")
        .collect()
}

/// `airglyph profile --json` of a running pipeline for `seconds` (`env` gives the
/// command the pipeline's environment): its report, and how long the profile took.
pub fn profile_report(
    env: impl Fn(&mut Command),
    seconds: f64,
) -> anyhow::Result<(serde_json::Value, Duration)> {
    static N: AtomicU32 = AtomicU32::new(0);
    let out_dir = std::env::temp_dir().join(format!(
        "airglyph-profile-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let mut cmd = Command::new(binary_path("airglyph"));
    cmd.args([
        "profile",
        "--json",
        "--seconds",
        &seconds.to_string(),
        "--out",
    ])
    .arg(&out_dir);
    env(&mut cmd);
    let t0 = Instant::now();
    let out = cmd.stderr(Stdio::null()).output()?;
    let took = t0.elapsed();
    let _ = std::fs::remove_dir_all(&out_dir);
    anyhow::ensure!(
        out.status.success(),
        "airglyph profile failed: {}",
        out.status
    );
    Ok((serde_json::from_slice(&out.stdout)?, took))
}

/// The median of `v` (the mean of the middle two when `v` has an even length).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// `airglyph demo --symbols SYMBOLS --truth --json` started, and its first gesture come:
/// the demo, the rest of its lines, and that first one.
pub fn demo_first_gesture(
    p: &Isolated,
    symbols: &str,
) -> (Child, mpsc::Receiver<serde_json::Value>, serde_json::Value) {
    let mut demo = p
        .command("airglyph")
        .args(["demo", "--symbols", symbols, "--truth", "--json"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let lines = json_lines(demo.stdout.take().unwrap());
    let first = lines
        .recv_timeout(Duration::from_secs(90))
        .expect("the demo's first gesture");
    assert_eq!(first["event"], "gesture", "{first}");
    (demo, lines, first)
}

/// Items of `rx` until `n` came or `within` passed.
pub fn take_lines<T>(rx: &mpsc::Receiver<T>, n: usize, within: Duration) -> Vec<T> {
    let deadline = Instant::now() + within;
    let mut out = Vec::new();
    while out.len() < n {
        match rx.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
            Ok(v) => out.push(v),
            Err(_) => break,
        }
    }
    out
}

/// A gesture line's identity: the same label, session and frames twice would be one
/// gesture twice.
pub fn gesture_identity(g: &serde_json::Value) -> (String, u64, u64, u64) {
    (
        g["label"].as_str().unwrap_or("?").to_owned(),
        g["session"].as_u64().unwrap_or(0),
        g["start_frame"].as_u64().unwrap_or(0),
        g["end_frame"].as_u64().unwrap_or(0),
    )
}

/// A Python 3 on PATH (`AIRGLYPH_PYTHON` to name another).
pub fn python3() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("AIRGLYPH_PYTHON") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("python3"))
        .find(|p| p.exists())
}

pub fn start_probe(p: &Isolated, extra: &[&str]) -> (Child, mpsc::Receiver<serde_json::Value>) {
    let mut child = p
        .command("airglyph-probe")
        .args(extra)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let rx = json_lines(child.stdout.take().unwrap());
    let ready = rx
        .recv_timeout(Duration::from_secs(10))
        .expect("probe ready");
    assert_eq!(ready["ready"], true);
    (child, rx)
}

pub fn stop(mut child: Child) -> std::process::ExitStatus {
    signal(&child, libc::SIGTERM);
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap();
    panic!("process {} ignored SIGTERM for 5 s", child.id());
}

/// What the synthetic person draws for `script` (`draw:SYMBOLS`, as capture's
/// `--source synthetic:draw:SYMBOLS` plays it): each symbol with its first and last
/// frame, which are capture's frame numbers counted from each start of capture.
pub fn drawn_symbols(script: &str) -> Vec<airglyph_core::gestures::GestureTruth> {
    let scene = airglyph_capture::synthetic::scene(Some(script), false).expect("a script");
    airglyph_synth::Synthesizer::new(scene)
        .expect("a synthetic scene")
        .gestures()
}

pub use airglyph_core::gestures::drawn_for;

/// Waits for a line of a probe's skeleton stream at frame `sequence` or later; its
/// session. Panics after `within`.
pub fn wait_for_frame(
    skeletons: &mpsc::Receiver<serde_json::Value>,
    sequence: u64,
    within: Duration,
) -> u64 {
    let deadline = Instant::now() + within;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let s = skeletons
            .recv_timeout(left)
            .unwrap_or_else(|_| panic!("no skeleton of frame {sequence} within {within:?}"));
        if s["sequence"].as_u64().is_some_and(|q| q >= sequence) {
            return s["session"].as_u64().unwrap_or(0);
        }
    }
}
