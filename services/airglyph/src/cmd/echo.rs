//! `airglyph echo`: a running pipeline's messages, one line each, for other programs.

use airglyph_core::Joint;
use airglyph_ipc::json::{self, GestureLine};
use airglyph_ipc::wire::Hand;
use airglyph_ipc::{
    shutdown, site, DecisionMsg, GestureEventMsg, Pipeline, Receiver, SkeletonMsg, Stage,
    StageStatsMsg,
};
use anyhow::Context;
use std::collections::VecDeque;
use std::io::Write;
use std::time::{Duration, Instant};

/// Print a running pipeline's messages as they come, one a line (JSON with --json).
///
/// Joins the pipeline as one more subscriber, beside whatever started it (`airglyph
/// run`, systemd's units, `demo`): the stages neither wait for it nor notice it. It
/// must run as the pipeline's user with the pipeline's AIRGLYPH_IPC_ROOT /
/// AIRGLYPH_IPC_PREFIX (shared memory is that user's alone: docs/deploy.md).
///
/// gesture: each recognized gesture, with the keys of `run --json` ({"event":"gesture",
/// "label","score","start_frame","end_frame","hand","start_ns","end_ns","session",
/// "latency_ms","posture"}; posture: the drawing hand's over most of the gesture, or
/// null). One that joins late first gets the last 8 the gesture stage kept; each
/// gesture is printed once, even when a restarted gesture stage reports one again (the
/// same capture session and frames).
///
/// skeleton: every skeleton ({"event":"skeleton","sequence","session","person_found",
/// "joints":{"head":[x,y,z],…},"confidence":{…},"visible":{…},"postures":{"left":
/// {"label","confidence"} or null,"right":…},"capture_ns","latency_ms"}; metres, camera
/// frame; a posture is null when the pose stage did not classify that hand), at most
/// --max-rate a second.
///
/// decision: the gesture stage's decision on every frame ({"event":"decision",
/// "sequence","session","gesture","latency_ms"}).
///
/// stats: each stage's telemetry once a second ({"event":"stats","stage",…} with the
/// keys of `top --json`).
///
/// iceoryx2-config: print the iceoryx2 configuration this pipeline uses (TOML), to put
/// where iceoryx2 looks for one (config/iceoryx2.toml under the working directory,
/// ~/.config/iceoryx2/iceoryx2.toml, /etc/iceoryx2/iceoryx2.toml) so that iceoryx2's
/// own tools see the pipeline: `iox2 service list`, `iox2 service hz airglyph/skeleton`.
/// airglyph reads that file too, with its own root and prefix on top.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// What to print.
    #[arg(value_enum)]
    what: What,
    /// One JSON object a line instead of text.
    #[arg(long)]
    json: bool,
    /// Stop after this many messages (default: until Ctrl-C, SIGTERM or the reader goes).
    #[arg(long, value_name = "N")]
    count: Option<u64>,
    /// Skeletons: at most this many a second, the others skipped (0: every one).
    #[arg(long, value_name = "HZ", default_value_t = 0.0, value_parser = airglyph_ipc::options::within(0.0f64, 1000.0))]
    max_rate: f64,
    /// Gestures: only those recognized from now on, not the last ones kept.
    #[arg(long)]
    no_history: bool,
}

#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
enum What {
    Gesture,
    Skeleton,
    Decision,
    Stats,
    #[value(name = "iceoryx2-config")]
    Iceoryx2Config,
}

/// How long one wait for a message lasts: a signal or a closed reader is noticed within it.
const ROUND: Duration = Duration::from_millis(100);

pub fn run(args: Args) -> anyhow::Result<()> {
    if args.what == What::Iceoryx2Config {
        return print_iceoryx2_config();
    }
    let pipeline = Pipeline::join("echo")?;
    let mut out = Lines {
        json: args.json,
        left: args.count,
    };
    let printed = match args.what {
        What::Gesture => gestures(&pipeline, &args, &mut out),
        What::Skeleton => skeletons(&pipeline, &args, &mut out),
        What::Decision => decisions(&pipeline, &mut out),
        What::Stats => stats(&pipeline, &mut out),
        What::Iceoryx2Config => unreachable!("handled above"),
    };
    match printed {
        // The reader has gone (`echo gesture | head -3`): leave the pipeline cleanly.
        Err(e) if is_broken_pipe(&e) => Ok(()),
        other => other,
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.downcast_ref::<std::io::Error>()
        .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
}

fn print_iceoryx2_config() -> anyhow::Result<()> {
    let cfg = airglyph_ipc::IpcConfig::from_env()?;
    let iox = cfg.iceoryx2()?;
    if let Some(file) = site::file() {
        eprintln!(
            "echo: from {} with the pipeline's root {} and prefix {}",
            file.display(),
            cfg.root,
            cfg.prefix
        );
    }
    print!("{}", site::to_toml(&iox)?);
    Ok(())
}

/// Where the lines go, and how many more.
struct Lines {
    json: bool,
    left: Option<u64>,
}

impl Lines {
    /// Whether to go on.
    fn more(&self) -> bool {
        self.left != Some(0) && !shutdown::requested()
    }

    fn print(
        &mut self,
        json: impl FnOnce() -> String,
        text: impl FnOnce() -> String,
    ) -> anyhow::Result<()> {
        let line = if self.json { json() } else { text() };
        let mut stdout = std::io::stdout().lock();
        writeln!(stdout, "{line}")?;
        // Every line at once: whoever reads it is waiting for it.
        stdout.flush()?;
        if let Some(n) = self.left.as_mut() {
            *n -= 1;
        }
        Ok(())
    }
}

/// The gestures printed, by capture session and last frame: a restarted gesture stage
/// may send again the last one it sent before it died, and the spotter never ends a
/// gesture at or before the end of the last one it reported, so an event ending at or
/// before the last one printed of its session was printed already.
#[derive(Default)]
pub(crate) struct Printed {
    last_end: VecDeque<(u64, u64)>,
}

/// Sessions remembered: capture restarts seldom, and a session long gone sends nothing.
const SESSIONS: usize = 16;

impl Printed {
    /// Whether `event` is new, remembering it if so.
    pub(crate) fn first_time(&mut self, event: &GestureEventMsg) -> bool {
        match self.last_end.iter_mut().find(|(s, _)| *s == event.session) {
            Some((_, end)) if event.end_sequence <= *end => false,
            Some((_, end)) => {
                *end = event.end_sequence;
                true
            }
            None => {
                if self.last_end.len() == SESSIONS {
                    self.last_end.pop_front();
                }
                self.last_end.push_back((event.session, event.end_sequence));
                true
            }
        }
    }
}

fn gestures(pipeline: &Pipeline, args: &Args, out: &mut Lines) -> anyhow::Result<()> {
    let mut rx = if args.no_history {
        pipeline.gesture_receiver()?
    } else {
        pipeline.gesture_receiver_with_history()?
    };
    let mut printed = Printed::default();
    while out.more() {
        let Some(r) = rx.recv(ROUND)? else { continue };
        if !printed.first_time(&r.msg) {
            continue;
        }
        let g = GestureLine::live(&r.msg);
        out.print(
            || g.line(),
            || {
                format!(
                    "{}  (score {:.2}, frames {}–{}, {} hand{})",
                    g.label,
                    g.score,
                    g.start_frame,
                    g.end_frame,
                    g.hand,
                    match g.posture.flatten() {
                        Some(p) => format!(", {p}"),
                        None => String::new(),
                    }
                )
            },
        )?;
    }
    Ok(())
}

fn skeletons(pipeline: &Pipeline, args: &Args, out: &mut Lines) -> anyhow::Result<()> {
    let mut rx: Receiver<SkeletonMsg> = pipeline.skeleton_receiver()?;
    let every = (args.max_rate > 0.0).then(|| Duration::from_secs_f64(1.0 / args.max_rate));
    let mut last: Option<Instant> = None;
    while out.more() {
        let Some(r) = rx.recv(ROUND)? else { continue };
        if let (Some(every), Some(at)) = (every, last) {
            if at.elapsed() < every {
                continue;
            }
        }
        last = Some(Instant::now());
        let m = r.msg;
        out.print(
            || json::skeleton(&m).to_string(),
            || {
                let head = m.joints[Joint::Head.index()];
                if m.person_found != 0 {
                    format!(
                        "frame {}  person found, head at ({:.2}, {:.2}, {:.2}) m{}",
                        m.sequence,
                        head[0],
                        head[1],
                        head[2],
                        postures_text(&m)
                    )
                } else {
                    format!("frame {}  no person", m.sequence)
                }
            },
        )?;
    }
    Ok(())
}

/// ", left hand fist 0.93, right hand open 0.71" for the hands classified, else "".
fn postures_text(m: &SkeletonMsg) -> String {
    [Hand::Left, Hand::Right]
        .into_iter()
        .filter_map(|hand| {
            let p = m.posture(hand).ok().flatten()?;
            Some(format!(
                ", {} hand {} {:.2}",
                hand.name(),
                p.label,
                p.confidence
            ))
        })
        .collect()
}

fn decisions(pipeline: &Pipeline, out: &mut Lines) -> anyhow::Result<()> {
    let mut rx: Receiver<DecisionMsg> = pipeline.decision_receiver()?;
    while out.more() {
        let Some(r) = rx.recv(ROUND)? else { continue };
        let m = r.msg;
        let latency = json::latency_ms(m.chain.capture_ns, m.chain.gesture_publish_ns);
        out.print(
            || json::decision(&m).to_string(),
            || {
                format!(
                    "frame {}  {}  ({latency:.1} ms after capture)",
                    m.sequence,
                    if m.gesture != 0 { "gesture" } else { "-" }
                )
            },
        )?;
    }
    Ok(())
}

fn stats(pipeline: &Pipeline, out: &mut Lines) -> anyhow::Result<()> {
    let mut receivers: Vec<(Stage, Receiver<StageStatsMsg>)> = Stage::PIPELINE
        .iter()
        .map(|&s| Ok((s, pipeline.stats_receiver(s)?)))
        .collect::<anyhow::Result<_>>()
        .context("cannot subscribe to the stages' stats")?;
    while out.more() {
        let mut any = false;
        for (stage, rx) in receivers.iter_mut() {
            while let Some(r) = rx.try_recv()? {
                any = true;
                let s = r.msg;
                out.print(
                    || json::stats_event(*stage, &s).to_string(),
                    || {
                        format!(
                            "{:<8} {:>6.1} fps  {:>9} frames  {:>6} dropped  {:>6} rejected  capture→out p50 {:.1} ms",
                            stage.name(),
                            s.fps,
                            s.frames_out,
                            s.frames_dropped,
                            s.frames_rejected,
                            s.latency.p50 as f64 * 1e-6
                        )
                    },
                )?;
                if !out.more() {
                    return Ok(());
                }
            }
        }
        if !any {
            // Stats come once a second from each stage: no need to wait on three events.
            std::thread::sleep(ROUND);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_skeletons_text_names_the_classified_hands_postures() {
        let mut m = SkeletonMsg::default();
        assert_eq!(postures_text(&m), "");
        m.set_posture(
            Hand::Right,
            Some(airglyph_ipc::PostureMsg::new("fist", 0.934).unwrap()),
        );
        assert_eq!(postures_text(&m), ", right hand fist 0.93");
        m.postures[Hand::Left as usize].label_len = 99;
        assert_eq!(
            postures_text(&m),
            ", right hand fist 0.93",
            "a bad one is left out"
        );
    }

    fn event(session: u64, end: u64) -> GestureEventMsg {
        GestureEventMsg {
            session,
            end_sequence: end,
            ..GestureEventMsg::default()
        }
    }

    #[test]
    fn a_gesture_sent_again_is_printed_once() {
        let mut p = Printed::default();
        assert!(p.first_time(&event(7, 100)));
        // The same one again (a restarted gesture stage), or one before it.
        assert!(!p.first_time(&event(7, 100)));
        assert!(!p.first_time(&event(7, 60)));
        assert!(p.first_time(&event(7, 140)));
        // Another capture session counts its frames anew.
        assert!(p.first_time(&event(8, 20)));
        assert!(!p.first_time(&event(8, 20)));
    }

    #[test]
    fn old_sessions_are_forgotten_not_hoarded() {
        let mut p = Printed::default();
        for s in 0..100 {
            assert!(p.first_time(&event(s, 1)));
        }
        assert_eq!(p.last_end.len(), SESSIONS);
    }
}
