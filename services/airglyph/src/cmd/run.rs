//! `airglyph run`: starts the stages as child processes, supervises them, prints gestures.

use crate::stage::StageArgs;
use crate::supervisor::{CrashRule, Deaths, HealthWatch};
use airglyph_capture::SourceSpec;
use airglyph_ipc::{shutdown, GestureEventMsg, Pipeline, Stage};
use anyhow::{bail, Context};
use std::ffi::OsString;
use std::path::PathBuf;
use std::process::{Child, ExitStatus};
use std::time::{Duration, Instant};

/// Start the pipeline and print each gesture it recognizes.
///
/// The stages (capture → pose → gesture) run as child processes; one that dies is
/// restarted after 100 ms, and one that dies again within 2 s of its start waits twice
/// as long each time (up to 5 s). A stage that dies more than --max-restarts times
/// within --crash-window seconds, however long each run lasted, is in a crash loop: the
/// pipeline stops and says which stage and why.
/// With --view the viewer stage runs too (a web page of what the camera sees, on
/// http://127.0.0.1:8080/ unless --listen says otherwise); it is supervised the same
/// way, except that a viewer in a crash loop is given up alone and the pipeline runs on.
/// SIGINT/SIGTERM stop every stage cleanly.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Where frames come from: synthetic, recording:DIR, v4l2:/dev/videoN, openni2 (the first device) or openni2:URI.
    #[arg(long, default_value = "synthetic")]
    pub source: SourceSpec,
    /// Print each gesture as one JSON object a line instead of plain text:
    /// {"event":"gesture","label","score","start_frame","end_frame","hand","start_ns",
    /// "end_ns","latency_ms"} (README, "JSON output").
    #[arg(long)]
    pub json: bool,
    /// The stages to start, comma-separated (e.g. `capture,pose` to profile pose alone).
    #[arg(long, value_delimiter = ',', default_value = "capture,pose,gesture")]
    pub stages: Vec<String>,
    /// Replay a recording as fast as possible.
    #[arg(long)]
    pub fast: bool,
    /// Replay a recording again and again.
    #[arg(long = "loop")]
    pub looping: bool,
    /// Stop capture after this many frames.
    #[arg(long)]
    pub frames: Option<u64>,
    /// The gesture model (from `airglyph train`; default: $AIRGLYPH_MODEL, else the
    /// built-in 36-symbol model).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Extra arguments for one stage, as STAGE=ARGS, split as a shell splits them
    /// (`--stage-args "gesture=--model 'my model.json'"`); repeat it for more stages.
    /// The stages: capture, pose, gesture, viewer; `airglyph stage NAME --help` lists
    /// each one's arguments, which are checked before the pipeline starts.
    #[arg(long = "stage-args", value_name = "STAGE=ARGS")]
    pub stage_args: Vec<StageArgs>,
    /// Restarts of one stage within --crash-window after which it is in a crash loop and
    /// the pipeline gives up (its deaths count whenever they come, not only soon after
    /// a start).
    #[arg(long, default_value_t = CrashRule::default().max_restarts, value_parser = airglyph_ipc::options::within(0usize, 1000), allow_negative_numbers = true)]
    pub max_restarts: usize,
    /// The sliding window of --max-restarts, in seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = CrashRule::default().window.as_secs_f64(), value_parser = airglyph_ipc::options::seconds(airglyph_ipc::options::MAX_SECONDS), allow_negative_numbers = true)]
    pub crash_window: f64,
    /// Also start the viewer: the live depth image, skeleton, hand trail, gestures and
    /// latencies as a web page.
    #[arg(long)]
    pub view: bool,
    /// With --view: the viewer's address, e.g. 0.0.0.0:8080 to watch from another
    /// computer (default 127.0.0.1:8080, this machine only).
    #[arg(long, value_name = "ADDR", requires = "view")]
    pub listen: Option<std::net::SocketAddr>,
    /// Skip pose estimation: the capture stage publishes the ground-truth skeletons of
    /// a synthetic source or of a recording with joints.csv (to tell pose errors from
    /// gesture errors).
    #[arg(long)]
    pub truth: bool,
}

impl Args {
    /// When a stage that keeps dying is given up.
    pub fn crash_rule(&self) -> CrashRule {
        CrashRule {
            max_restarts: self.max_restarts,
            window: Duration::from_secs_f64(self.crash_window),
        }
    }

    /// `airglyph run --source SOURCE` with every other option at its command-line
    /// default, for the commands that run the pipeline themselves (demo, collect).
    pub fn with_source(source: SourceSpec) -> Self {
        #[derive(clap::Parser)]
        struct Run {
            #[command(flatten)]
            args: Args,
        }
        let mut args = <Run as clap::Parser>::parse_from(["run"]).args;
        args.source = source;
        args
    }
}

/// The first restart waits this long; each further one twice as long, up to `MAX_BACKOFF`.
const MIN_BACKOFF: Duration = Duration::from_millis(100);
const MAX_BACKOFF: Duration = Duration::from_secs(5);
/// A stage that dies sooner than this after its start waits longer for its restart each
/// time; one that ran longer is restarted after `MIN_BACKOFF` again.
const HEALTHY_AFTER: Duration = Duration::from_secs(2);
/// How long a stage gets to stop after SIGTERM before SIGKILL.
const STOP_GRACE: Duration = Duration::from_secs(3);
/// How long capture waits for the viewer to subscribe, so the page shows the stream from
/// its first frame; a viewer that is not up by then is not waited for.
const VIEWER_WAIT: Duration = Duration::from_secs(3);

/// One supervised stage.
struct Supervised {
    stage: Stage,
    args: Vec<OsString>,
    child: Option<Child>,
    started: Instant,
    backoff: Duration,
    restart_at: Option<Instant>,
    deaths: Deaths,
    /// Exited by itself with success (a finite source ran out), or given up: not restarted.
    finished: bool,
    /// Whether the pipeline stops when this stage is in a crash loop (the viewer is not).
    essential: bool,
    /// The viewer's: whether its web server still answers (a stopped or hung viewer
    /// lives on as a process).
    health: Option<HealthWatch>,
}

impl Supervised {
    fn spawn(&mut self) -> anyhow::Result<()> {
        let child = crate::stage::command(self.stage)
            .args(&self.args)
            .spawn()
            .with_context(|| format!("cannot start `{}`", crate::stage::invocation(self.stage)))?;
        tracing::debug!(stage = self.stage.name(), pid = child.id(), "started");
        self.child = Some(child);
        self.started = Instant::now();
        self.restart_at = None;
        if let Some(h) = &self.health {
            h.restarted();
        }
        Ok(())
    }

    fn stop(&mut self) {
        let Some(mut child) = self.child.take() else {
            return;
        };
        // SAFETY: kill(2) on our own child's pid; the child is not reaped yet, so the pid
        // cannot have been reused.
        unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
        let deadline = Instant::now() + STOP_GRACE;
        loop {
            match child.try_wait() {
                Ok(Some(_)) => return,
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(20))
                }
                _ => {
                    tracing::warn!(
                        stage = self.stage.name(),
                        "did not stop within 3 s; killing it"
                    );
                    let _ = child.kill();
                    let _ = child.wait();
                    return;
                }
            }
        }
    }
}

fn describe(status: ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(code), _) => format!("exit code {code}"),
        (None, Some(sig)) => format!("signal {sig}"),
        _ => "unknown status".into(),
    }
}

/// The health check of a viewer started with `args`, unless it listens on port 0 (any
/// free port, which only the viewer knows; its own watchdog still ends it when its
/// server stops).
fn watch_viewer(args: &[OsString]) -> anyhow::Result<Option<HealthWatch>> {
    let addr = crate::stage::viewer_address(args)
        .map_err(|e| anyhow::anyhow!("the arguments of the viewer stage: {e}"))?;
    if addr.port() == 0 {
        tracing::info!(
            "the viewer listens on any free port: the supervisor cannot check its health"
        );
        return Ok(None);
    }
    Ok(Some(
        HealthWatch::start(addr).context("cannot start the viewer's health check")?,
    ))
}

/// Runs the stages until SIGINT/SIGTERM, a finished source, or a crash loop.
pub fn run(args: Args) -> anyhow::Result<()> {
    let json = args.json;
    run_with(args, |event| crate::cmd::print_gesture(event, json))
}

/// Starts downstream stages first and capture last, once pose and gesture listen (and
/// the viewer, for up to [`VIEWER_WAIT`]), so the first frames are not sent to nobody.
fn start_in_order(stages: &mut [Supervised], pipeline: &Pipeline) -> anyhow::Result<()> {
    let has = |st: Stage| stages.iter().any(|s| s.stage == st) as usize;
    // The viewer subscribes to both services too, its depth subscription last.
    let (pose, gesture, viewer) = (has(Stage::Pose), has(Stage::Gesture), has(Stage::Viewer));
    let (depth0, skeleton0) = (
        pipeline.depth_subscribers()?,
        pipeline.skeleton_subscribers()?,
    );
    for s in stages.iter_mut().filter(|s| s.stage != Stage::Capture) {
        s.spawn()?;
    }
    let started = Instant::now();
    let ready = |p: &Pipeline| -> anyhow::Result<bool> {
        let viewer = if started.elapsed() < VIEWER_WAIT {
            viewer
        } else {
            0
        };
        Ok(p.depth_subscribers()? >= depth0 + pose + viewer
            && p.skeleton_subscribers()? >= skeleton0 + gesture + viewer)
    };
    let deadline = started + Duration::from_secs(15);
    while !ready(pipeline)? && !shutdown::requested() {
        if Instant::now() > deadline {
            tracing::warn!("pose or gesture not listening after 15 s; starting capture anyway");
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    for s in stages.iter_mut().filter(|s| s.stage == Stage::Capture) {
        s.spawn()?;
    }
    Ok(())
}

/// The command-line arguments `airglyph run` gives one stage.
fn stage_args(stage: Stage, args: &Args) -> Vec<OsString> {
    let mut out: Vec<OsString> = Vec::new();
    match stage {
        Stage::Capture => {
            out.extend(["--source".into(), args.source.to_string().into()]);
            if args.fast {
                out.push("--fast".into());
            }
            if args.looping {
                out.push("--loop".into());
            }
            if let Some(n) = args.frames {
                out.extend(["--frames".into(), n.to_string().into()]);
            }
            if args.truth {
                // Capture publishes the skeletons itself.
                out.push("--truth-skeletons".into());
            }
        }
        Stage::Viewer => {
            if let Some(addr) = args.listen {
                out.extend(["--listen".into(), addr.to_string().into()]);
            }
        }
        Stage::Gesture => {
            if let Some(model) = &args.model {
                out.extend(["--model".into(), model.into()]);
            }
        }
        Stage::Pose => {}
    }
    for extra in args.stage_args.iter().filter(|e| e.stage == stage) {
        out.extend(extra.args.iter().map(OsString::from));
    }
    out
}

/// What the supervisor does with the pipeline's output while the stages run.
pub trait Listener {
    /// Waits up to `timeout` for one message and handles it.
    fn poll(&mut self, timeout: Duration) -> anyhow::Result<Poll>;
}

/// What one [`Listener::poll`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Poll {
    /// Nothing came.
    Idle,
    /// A message came and was handled.
    Handled,
    /// The listener has what it wanted: stop the pipeline.
    Done,
}

/// Hands each gesture event to a closure.
struct Gestures<F> {
    rx: airglyph_ipc::Receiver<GestureEventMsg>,
    on_event: F,
}

impl<F: FnMut(&GestureEventMsg) -> std::io::Result<()>> Listener for Gestures<F> {
    fn poll(&mut self, timeout: Duration) -> anyhow::Result<Poll> {
        let Some(event) = self.rx.recv(timeout)? else {
            return Ok(Poll::Idle);
        };
        match (self.on_event)(&event.msg) {
            Ok(()) => Ok(Poll::Handled),
            // Whoever read the events has gone: stop the stages cleanly, not by a panic.
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                tracing::info!("the reader of the events has gone; stopping");
                Ok(Poll::Done)
            }
            Err(e) => Err(anyhow::Error::new(e).context("cannot hand on a gesture event")),
        }
    }
}

/// Listens to nothing (no gesture stage).
struct Nothing;

impl Listener for Nothing {
    fn poll(&mut self, timeout: Duration) -> anyhow::Result<Poll> {
        std::thread::sleep(timeout);
        Ok(Poll::Idle)
    }
}

/// [`run`], handing each gesture event to `on_event` instead of printing it.
pub fn run_with(
    args: Args,
    on_event: impl FnMut(&GestureEventMsg) -> std::io::Result<()>,
) -> anyhow::Result<()> {
    let gesture_stage = args.stages.iter().any(|s| s == Stage::Gesture.name());
    if gesture_stage {
        run_listening(args, |p| {
            Ok(Gestures {
                rx: p.gesture_receiver()?,
                on_event,
            })
        })?;
    } else {
        run_listening(args, |_| Ok(Nothing))?;
    }
    Ok(())
}

/// A listener after the run, with the supervisor's place in the pipeline. The listener's
/// ports keep the supervisor's node alive, so the pipeline must be left after them (the
/// last node out removes iceoryx2's per-domain files): fields drop in this order.
pub struct Listening<L> {
    listener: L,
    _pipeline: Pipeline,
}

impl<L> std::ops::Deref for Listening<L> {
    type Target = L;
    fn deref(&self) -> &L {
        &self.listener
    }
}

impl<L> std::ops::DerefMut for Listening<L> {
    fn deref_mut(&mut self) -> &mut L {
        &mut self.listener
    }
}

/// Starts and supervises the stages; `listener` (made once the pipeline is joined and
/// before any stage starts, so it misses nothing) handles their output until SIGINT or
/// SIGTERM, a finished source, a crash loop, or until it is done. Returns the listener.
pub fn run_listening<L: Listener>(
    args: Args,
    listener: impl FnOnce(&Pipeline) -> anyhow::Result<L>,
) -> anyhow::Result<Listening<L>> {
    shutdown::install();
    let mut names: Vec<Stage> = Vec::new();
    for name in &args.stages {
        let stage = Stage::from_name(name)
            .filter(|s| Stage::PIPELINE.contains(s))
            .with_context(|| {
                format!("unknown stage {name:?}: expected capture, pose or gesture (the viewer comes with --view)")
            })?;
        if args.truth && stage == Stage::Pose {
            // Capture publishes the skeletons itself.
            continue;
        }
        names.push(stage);
    }
    if args.view {
        names.push(Stage::Viewer);
    }
    for extra in &args.stage_args {
        if !names.contains(&extra.stage) {
            bail!(
                "--stage-args {}=…: the {} stage does not run here{}",
                extra.stage.name(),
                extra.stage.name(),
                match extra.stage {
                    Stage::Viewer => " (add --view)",
                    Stage::Pose if args.truth => " (--truth runs none)",
                    _ => " (see --stages)",
                }
            );
        }
    }
    if args.model.is_some() && !names.contains(&Stage::Gesture) {
        bail!("--model: the gesture stage does not run here (see --stages)");
    }
    let rule = args.crash_rule();
    let mut stages = Vec::new();
    for stage in names {
        let args = stage_args(stage, &args);
        crate::stage::check_args(stage, &args)
            .map_err(|e| anyhow::anyhow!("the arguments of the {} stage: {e}", stage.name()))?;
        let health = match stage {
            Stage::Viewer => watch_viewer(&args)?,
            _ => None,
        };
        stages.push(Supervised {
            stage,
            args,
            health,
            child: None,
            started: Instant::now(),
            backoff: MIN_BACKOFF,
            restart_at: None,
            deaths: Deaths::new(rule),
            finished: false,
            essential: stage != Stage::Viewer,
        });
    }
    if stages.is_empty() {
        bail!("no stages to run");
    }

    let pipeline = Pipeline::join("supervisor")?;
    let mut listener = listener(&pipeline)?;
    start_in_order(&mut stages, &pipeline)?;
    let outcome = supervise(&mut stages, &pipeline, &mut listener);
    for s in stages.iter_mut() {
        s.stop();
    }
    pipeline.cleanup_dead_nodes();
    outcome.map(|()| Listening {
        listener,
        _pipeline: pipeline,
    })
}

fn supervise(
    stages: &mut [Supervised],
    pipeline: &Pipeline,
    listener: &mut impl Listener,
) -> anyhow::Result<()> {
    while !shutdown::requested() {
        if listener.poll(Duration::from_millis(50))? == Poll::Done {
            return Ok(());
        }
        let now = Instant::now();
        for s in stages.iter_mut() {
            if let Some(child) = s.child.as_mut() {
                let Some(status) = child.try_wait()? else {
                    if let Some(reason) = s.health.as_ref().and_then(HealthWatch::stopped_serving) {
                        // SIGKILL: a stopped process would not act on SIGTERM. Its death
                        // is then handled as any other, at the next round.
                        tracing::warn!(
                            stage = s.stage.name(),
                            pid = child.id(),
                            %reason,
                            "the viewer lives but stopped serving; killing it to start it again"
                        );
                        let _ = child.kill();
                    }
                    continue;
                };
                s.child = None;
                if status.success() {
                    tracing::info!(stage = s.stage.name(), "finished");
                    s.finished = true;
                    continue;
                }
                // Free the dead stage's shared memory now, not only when it restarts.
                pipeline.cleanup_dead_nodes();
                let young = s.started.elapsed() <= HEALTHY_AFTER;
                if !young {
                    // It was working: restart it at once, whatever came before.
                    s.backoff = MIN_BACKOFF;
                }
                let looping = s.deaths.record(now);
                let window = s.deaths.rule().window.as_secs_f64();
                if looping && !s.essential {
                    tracing::error!(
                        stage = s.stage.name(),
                        deaths = s.deaths.count(),
                        window_s = window,
                        last = %describe(status),
                        "stage keeps dying; giving it up (the pipeline runs on) — run `{}` alone to see why",
                        crate::stage::invocation(s.stage)
                    );
                    s.finished = true;
                    continue;
                }
                if looping {
                    bail!(
                        "stage {} died {} times within {window} s (last: {}, {:.1} s after its start); giving up — run `{}` alone to see why",
                        s.stage.name(),
                        s.deaths.count(),
                        describe(status),
                        s.started.elapsed().as_secs_f64(),
                        crate::stage::invocation(s.stage)
                    );
                }
                tracing::warn!(
                    stage = s.stage.name(),
                    status = %describe(status),
                    backoff_ms = s.backoff.as_millis() as u64,
                    "stage died; restarting"
                );
                s.restart_at = Some(now + s.backoff);
                if young {
                    s.backoff = (s.backoff * 2).min(MAX_BACKOFF);
                }
            } else if s.restart_at.is_some_and(|t| now >= t) {
                s.spawn()?;
                tracing::info!(
                    stage = s.stage.name(),
                    deaths = s.deaths.count(),
                    "stage restarted"
                );
            }
        }
        // When capture ran out of frames, give the others a moment to finish the last ones.
        if stages
            .iter()
            .any(|s| s.stage == Stage::Capture && s.finished)
        {
            // The gesture stage decides what is pending half a second after the last
            // skeleton.
            let until = Instant::now() + Duration::from_millis(1500);
            while Instant::now() < until {
                if listener.poll(Duration::from_millis(20))? == Poll::Done {
                    break;
                }
            }
            return Ok(());
        }
    }
    Ok(())
}
