//! A stage killed again and again while the synthetic person draws: what `airglyph run`
//! reports of every symbol drawn, and how long the stage takes to come back. Used by
//! the system tests (a few kills, a short script) and by `scripts/eval kills` (ten
//! kills of each stage, release build).
//!
//! A symbol counts as drawn when a capture session published all its frames and
//! [`SEEN_AFTER`] more: a restarted capture stage starts the script again in a new
//! session (and frame numbers from 0), so a symbol a capture kill cut short was never
//! drawn whole, and one drawn again in the next session is another drawing. Each symbol
//! drawn must be reported exactly once, with its label, in its session.

use crate::{drawn_for, drawn_symbols, json_lines, signal, stage_children, start_probe, Isolated};
use airglyph_ipc::clock::monotonic_ns;
use std::collections::BTreeMap;
use std::process::{Child, Stdio};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Frames a session must go on after a symbol for it to count as drawn: the end of a
/// stroke shows only in the movement after it (the spotter's context, 0.4 s at 30 fps:
/// `CONTEXT_SECONDS` in `services/gesture/src/model/verifier.rs`). A capture killed 3 frames after a
/// symbol's last one left the spotter a stroke still going.
pub const SEEN_AFTER: u64 = 12;

/// A small deterministic generator of kill moments (xorshift64*).
pub struct Moments(pub u64);

impl Moments {
    pub fn next_in(&mut self, lo: f64, hi: f64) -> Duration {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let u = (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64;
        Duration::from_secs_f64(lo + (hi - lo) * u)
    }
}

/// One run: `kills` SIGKILLs of `stage` while the person draws `symbols`.
#[derive(Debug, Clone)]
pub struct KillRun {
    pub stage: &'static str,
    pub kills: usize,
    pub symbols: String,
    /// The person's exact skeleton from capture (`run --truth`): no pose stage.
    pub truth: bool,
    pub seed: u64,
}

/// What a [`KillRun`] saw.
#[derive(Debug, Default)]
pub struct KillReport {
    pub stage: String,
    pub kills: usize,
    /// Capture sessions (one, and one more for every capture kill).
    pub sessions: usize,
    /// Each session's last frame that became a skeleton.
    pub session_ends: Vec<u64>,
    /// Symbols drawn whole within a session (and [`SEEN_AFTER`] frames more).
    pub drawn: usize,
    /// Of those, reported exactly once with their label.
    pub once: usize,
    /// Reported once, under another label: "drew 4, reported 9".
    pub wrong: Vec<String>,
    /// Never reported: "7 (session 2, frames 566–605)".
    pub missed: Vec<String>,
    /// Reported more than once: "3 ×2 (session 1)".
    pub repeated: Vec<String>,
    /// Every symbol drawn whole, in order, with what became of it: "once", "missed",
    /// "wrong" or "repeated" (to compare with a run without kills).
    pub outcomes: Vec<(String, &'static str)>,
    /// Gestures reported over a symbol a capture kill cut short (or ended the session
    /// right after).
    pub cut: usize,
    /// Gestures reported where no symbol was drawn.
    pub stray: usize,
    /// From each kill to the supervisor's new process of the stage.
    pub process_back: Vec<Duration>,
    /// From each kill to the stage's first output again: capture's first frame that
    /// became a skeleton, pose's first skeleton, gesture's first decision.
    pub output_back: Vec<Duration>,
}

/// Min, median and max of some durations, in ms.
pub fn spread(d: &[Duration]) -> String {
    if d.is_empty() {
        return "none".into();
    }
    let mut ms: Vec<f64> = d.iter().map(|d| d.as_secs_f64() * 1e3).collect();
    ms.sort_by(f64::total_cmp);
    let median = if ms.len() % 2 == 1 {
        ms[ms.len() / 2]
    } else {
        (ms[ms.len() / 2 - 1] + ms[ms.len() / 2]) / 2.0
    };
    format!("{:.0}/{median:.0}/{:.0} ms", ms[0], ms[ms.len() - 1])
}

impl KillReport {
    /// One paragraph of figures.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{}: {} kills; {} symbols drawn whole in {} sessions (ending at frames {:?}): {} reported exactly once, {} missed {:?}, {} more than once {:?}, {} under another label {:?}; {} over symbols cut short, {} where none was drawn; back (min/median/max): process {}, output {}",
            self.stage,
            self.kills,
            self.drawn,
            self.sessions,
            self.session_ends,
            self.once,
            self.missed.len(),
            self.missed,
            self.repeated.len(),
            self.repeated,
            self.wrong.len(),
            self.wrong,
            self.cut,
            self.stray,
            spread(&self.process_back),
            spread(&self.output_back),
        );
        s.push('\n');
        s
    }
}

/// Lines of a child's JSON output, kept as they come.
fn keep(rx: mpsc::Receiver<serde_json::Value>) -> Arc<Mutex<Vec<serde_json::Value>>> {
    let kept = Arc::new(Mutex::new(Vec::new()));
    let into = kept.clone();
    std::thread::spawn(move || {
        for v in rx {
            into.lock().unwrap().push(v);
        }
    });
    kept
}

fn pid_of(supervisor: &Child, stage: &str) -> Option<u32> {
    let pids = stage_children(supervisor.id(), stage);
    assert!(pids.len() <= 1, "two {stage} stages at once: {pids:?}");
    pids.first().copied()
}

fn wait_until(within: Duration, what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + within;
    while !done() {
        assert!(Instant::now() < deadline, "{what}: not within {within:?}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

impl KillRun {
    pub fn run(&self, p: &Isolated) -> KillReport {
        let script = format!("draw:{}", self.symbols);
        let truth = drawn_symbols(&script);
        let script_length =
            Duration::from_secs_f64(truth.last().map_or(0, |t| t.end_frame) as f64 / 30.0);
        let (skeleton_probe, skeletons) =
            start_probe(p, &["--stream", "skeleton", "--idle", "600"]);
        let skeletons = keep(skeletons);
        let decision_probe = (self.stage == "gesture")
            .then(|| start_probe(p, &["--stream", "decision", "--idle", "600"]));
        let (decision_probe, decisions) = match decision_probe {
            Some((child, rx)) => (Some(child), Some(keep(rx))),
            None => (None, None),
        };
        let mut supervisor = p
            .command("airglyph")
            .args(["run", "--json", "--max-restarts", "1000"])
            .args(["--source", &format!("synthetic:{script}")])
            .args(self.truth.then_some("--truth"))
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let events = json_lines(supervisor.stdout.take().unwrap());
        wait_until(Duration::from_secs(60), "a first skeleton", || {
            !skeletons.lock().unwrap().is_empty()
        });

        let mut report = KillReport {
            stage: self.stage.into(),
            kills: self.kills,
            ..KillReport::default()
        };
        let mut moments = Moments(self.seed);
        let mut killed_at = Vec::new();
        for round in 0..self.kills {
            // Later than 2 s after the last start, so that every restart is a first
            // one (a stage dying younger waits longer for its restart each time).
            std::thread::sleep(moments.next_in(2.5, 4.5));
            let victim = pid_of(&supervisor, self.stage)
                .unwrap_or_else(|| panic!("{}: no stage to kill (round {round})", self.stage));
            let kill_ns = monotonic_ns();
            let killed = Instant::now();
            // SAFETY: kill(2) on a grandchild we found in /proc just now.
            unsafe { libc::kill(victim as i32, libc::SIGKILL) };
            wait_until(Duration::from_secs(10), "the stage back", || {
                pid_of(&supervisor, self.stage).is_some_and(|pid| pid != victim)
            });
            report.process_back.push(killed.elapsed());
            killed_at.push(kill_ns);
        }
        // Capture ends with the script (the whole script again after a capture kill);
        // the supervisor then stops the rest.
        let deadline = Instant::now() + script_length + Duration::from_secs(120);
        while supervisor.try_wait().unwrap().is_none() {
            assert!(Instant::now() < deadline, "the drawing did not end");
            std::thread::sleep(Duration::from_millis(100));
        }
        let reported: Vec<serde_json::Value> = events.iter().collect();
        for child in [Some(skeleton_probe), decision_probe].into_iter().flatten() {
            signal(&child, libc::SIGTERM);
            let mut child = child;
            let _ = child.wait();
        }
        let skeletons = skeletons.lock().unwrap().clone();
        let decisions = decisions.map(|d| d.lock().unwrap().clone());

        // When each kill's stage gave output again.
        let ns = |v: &serde_json::Value, k: &str| v[k].as_u64().unwrap_or(0);
        for &kill_ns in &killed_at {
            let back = match self.stage {
                "capture" => skeletons
                    .iter()
                    .filter(|s| ns(s, "session") > kill_ns)
                    .map(|s| ns(s, "capture_publish_ns"))
                    .min(),
                "pose" => skeletons
                    .iter()
                    .map(|s| ns(s, "pose_publish_ns"))
                    .filter(|&t| t > kill_ns)
                    .min(),
                _ => decisions
                    .iter()
                    .flatten()
                    .map(|d| ns(d, "gesture_publish_ns"))
                    .filter(|&t| t > kill_ns)
                    .min(),
            };
            if let Some(t) = back {
                report
                    .output_back
                    .push(Duration::from_nanos(t.saturating_sub(kill_ns)));
            }
        }

        // Each session's last frame that became a skeleton: symbols up to it were
        // drawn whole.
        let mut sessions: BTreeMap<u64, u64> = BTreeMap::new();
        for s in &skeletons {
            let last = sessions.entry(ns(s, "session")).or_default();
            *last = (*last).max(ns(s, "sequence"));
        }
        report.sessions = sessions.len();
        report.session_ends = sessions.values().copied().collect();
        let mut labels: BTreeMap<(u64, usize), Vec<String>> = BTreeMap::new();
        for e in &reported {
            let (session, start, end) =
                (ns(e, "session"), ns(e, "start_frame"), ns(e, "end_frame"));
            let whole = |i: usize| {
                sessions
                    .get(&session)
                    .is_some_and(|&last| truth[i].end_frame as u64 + SEEN_AFTER <= last)
            };
            match drawn_for(&truth, start, end) {
                Some(i) if whole(i) => labels
                    .entry((session, i))
                    .or_default()
                    .push(e["label"].as_str().unwrap_or("?").to_owned()),
                Some(_) => report.cut += 1,
                None => report.stray += 1,
            }
        }
        for (n, (&session, &last)) in sessions.iter().enumerate() {
            for (i, t) in truth.iter().enumerate() {
                if t.end_frame as u64 + SEEN_AFTER > last {
                    continue;
                }
                report.drawn += 1;
                let outcome = match labels.get(&(session, i)).map(Vec::as_slice) {
                    None | Some([]) => {
                        report.missed.push(format!(
                            "{} (session {}, frames {}–{})",
                            t.label,
                            n + 1,
                            t.start_frame,
                            t.end_frame
                        ));
                        "missed"
                    }
                    Some([one]) if *one == t.label => {
                        report.once += 1;
                        "once"
                    }
                    Some([one]) => {
                        report
                            .wrong
                            .push(format!("drew {}, reported {one}", t.label));
                        "wrong"
                    }
                    Some(many) => {
                        report.repeated.push(format!(
                            "{} ×{} (session {}: {many:?})",
                            t.label,
                            many.len(),
                            n + 1
                        ));
                        "repeated"
                    }
                };
                report.outcomes.push((t.label.clone(), outcome));
            }
        }
        report
    }
}
