//! Starts the stages as child processes, restarts one that dies, gives up one that
//! keeps dying, and stops them all; meanwhile a [`Listener`] handles what the pipeline
//! sends (docs/architecture.md, "Processes").
//!
//! ```text
//! Plan ──supervise──▶ start downstream stages, then capture, then companions ──▶ loop:
//!          listener.poll, reap, restart with backoff, crash rule, viewer health ──▶ stop all
//! ```
//!
//! What to start is a [`Plan`]: one [`StagePlan`] a stage, each a program and its
//! arguments (normally this executable's `airglyph stage NAME`, [`StagePlan::own`]),
//! the [`CompanionPlan`]s of processes that only read the stages' messages (the Zenoh
//! exporter of `run --export zenoh`), and the [`CrashRule`]. The caller joins the
//! pipeline and hands it over, so a test can supervise stand-in processes on a pipeline
//! of its own; every child is given that pipeline's root and prefix.

mod child;
mod crash;
mod listen;

pub use crash::{CrashRule, Deaths};
pub use listen::{Gestures, Idle, Listener, ListenerError, Listening, Poll};

use airglyph_ipc::{shutdown, GestureEventMsg, IpcError, Pipeline, Stage};
use child::Supervised;
use std::ffi::OsString;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The node name the supervisor joins the pipeline as.
pub const NODE: &str = "supervisor";

/// How long capture waits for the viewer to subscribe, so the page shows the stream from
/// its first frame; a viewer that is not up by then is not waited for.
const VIEWER_WAIT: Duration = Duration::from_secs(3);
/// How long capture waits for pose and gesture to subscribe before it starts anyway.
const SUBSCRIBE_WAIT: Duration = Duration::from_secs(15);
/// After capture's source ran out, how long the others get for the last frames: the
/// gesture stage decides what is pending half a second after the last skeleton.
const DRAIN: Duration = Duration::from_millis(1500);

/// One stage to supervise: which, and the process that runs it.
#[derive(Debug, Clone, PartialEq)]
pub struct StagePlan {
    /// The stage the process is: it decides the start order and whether the pipeline
    /// stops when it keeps dying (the viewer is not essential).
    pub stage: Stage,
    /// The program to run.
    pub program: PathBuf,
    /// The name the process shows in `ps` (argv\[0\]), when not the program's.
    pub arg0: Option<OsString>,
    /// Its arguments.
    pub args: Vec<OsString>,
    /// Where its web server answers `/healthz` (the viewer), to be probed: a process
    /// that lives but no longer serves is killed and started again.
    pub health: Option<SocketAddr>,
    /// How a person runs it alone, for the message that sends them there.
    pub by_hand: String,
}

impl StagePlan {
    /// `stage` run as `airglyph stage NAME ARGS` from this process's own executable
    /// ([`own_executable`]), as `airglyph run` starts it.
    pub fn own(stage: Stage, args: Vec<OsString>) -> Self {
        let mut all: Vec<OsString> = vec!["stage".into(), stage.name().into()];
        all.extend(args);
        Self {
            stage,
            program: PathBuf::from(OWN_EXECUTABLE),
            arg0: std::env::current_exe().ok().map(OsString::from),
            args: all,
            health: None,
            by_hand: invocation(stage),
        }
    }

    /// Whether the pipeline stops when this stage keeps dying: every stage but the
    /// viewer, which is given up alone while the pipeline runs on.
    pub fn essential(&self) -> bool {
        self.stage != Stage::Viewer
    }
}

/// A process beside the stages that only reads what they send (the Zenoh exporter of
/// `airglyph run --export zenoh`): started once the stages are, restarted as a stage is,
/// stopped after them, and never a reason to stop the pipeline. One that keeps dying, or
/// cannot be started at all, is given up alone and the stages run on.
#[derive(Debug, Clone, PartialEq)]
pub struct CompanionPlan {
    /// Its name in the supervisor's logs.
    pub name: String,
    /// The program to run.
    pub program: PathBuf,
    /// Its arguments.
    pub args: Vec<OsString>,
    /// How a person runs it alone, for the message that sends them there.
    pub by_hand: String,
}

/// What the supervisor starts and how it judges deaths.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The stages, in any order: downstream ones are started first, capture last.
    pub stages: Vec<StagePlan>,
    /// Started after the stages, in this order.
    pub companions: Vec<CompanionPlan>,
    /// When a stage that keeps dying is given up.
    pub rule: CrashRule,
}

/// Why supervision ended with an error.
#[derive(Debug, thiserror::Error)]
pub enum SupervisorError {
    /// The pipeline's shared memory failed.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// A stage's process could not be started.
    #[error("cannot start `{by_hand}`")]
    Start {
        /// How a person runs the stage alone.
        by_hand: String,
        /// Why the process could not be started.
        #[source]
        source: std::io::Error,
    },
    /// Whether a stage's process still runs could not be asked.
    #[error("cannot wait for the {} stage", stage.name())]
    Wait {
        /// The stage.
        stage: Stage,
        /// What `waitpid` said.
        #[source]
        source: std::io::Error,
    },
    /// The viewer's health check could not start its thread.
    #[error("cannot start the viewer's health check")]
    Health(#[source] std::io::Error),
    /// An essential stage died more often than the [`CrashRule`] allows.
    #[error(
        "stage {} died {deaths} times within {window_s} s (last: {last}, {after_s:.1} s after its start); giving up — run `{by_hand}` alone to see why",
        stage.name()
    )]
    CrashLoop {
        /// The stage.
        stage: Stage,
        /// Its deaths within the window.
        deaths: usize,
        /// The window, seconds.
        window_s: f64,
        /// How its last run ended (exit code or signal).
        last: String,
        /// How long its last run lasted, seconds.
        after_s: f64,
        /// How a person runs it alone to see why.
        by_hand: String,
    },
    /// The plan has no stage.
    #[error("no stages to run")]
    NoStages,
    /// The listener failed (its own error, unchanged).
    #[error(transparent)]
    Listener(ListenerError),
}

/// Starts and supervises `plan`'s stages on `pipeline`; `listener` (made before any
/// stage starts, so it misses nothing) handles their output until SIGINT or SIGTERM, a
/// finished source, a crash loop, or until it is done. Every stage is stopped before
/// this returns; the listener comes back with the pipeline it listens on.
pub fn supervise<L: Listener>(
    plan: &Plan,
    pipeline: Pipeline,
    listener: impl FnOnce(&Pipeline) -> Result<L, ListenerError>,
) -> Result<Listening<L>, SupervisorError> {
    if plan.stages.is_empty() {
        return Err(SupervisorError::NoStages);
    }
    shutdown::install();
    let mut stages = plan
        .stages
        .iter()
        .map(|s| Supervised::for_stage(s, plan.rule))
        .collect::<Result<Vec<_>, _>>()?;
    // After the stages: they are stopped in this order too, so a companion that carries
    // their messages away is still there for the last of them.
    stages.extend(
        plan.companions
            .iter()
            .map(|c| Supervised::for_companion(c, plan.rule)),
    );
    let mut listener = listener(&pipeline).map_err(SupervisorError::Listener)?;
    let outcome = start_in_order(&mut stages, &pipeline)
        .and_then(|()| watch(&mut stages, &pipeline, &mut listener));
    for s in stages.iter_mut() {
        s.stop();
    }
    pipeline.cleanup_dead_nodes();
    outcome.map(|()| Listening::new(listener, pipeline))
}

/// [`supervise`], handing each gesture event to `on_event`; without a gesture stage in
/// the plan there are none, and the stages run until stopped.
pub fn supervise_gestures(
    plan: &Plan,
    pipeline: Pipeline,
    on_event: impl FnMut(&GestureEventMsg) -> std::io::Result<()>,
) -> Result<(), SupervisorError> {
    if plan.stages.iter().any(|s| s.stage == Stage::Gesture) {
        supervise(plan, pipeline, |p| Ok(Gestures::new(p, on_event)?))?;
    } else {
        supervise(plan, pipeline, |_| Ok(Idle))?;
    }
    Ok(())
}

/// Starts downstream stages first and capture once pose and gesture listen (and the
/// viewer, for up to [`VIEWER_WAIT`]), so the first frames are not sent to nobody; then
/// the companions, which are not waited for (and whose subscriptions would otherwise
/// be taken for a stage's).
fn start_in_order(stages: &mut [Supervised], pipeline: &Pipeline) -> Result<(), SupervisorError> {
    let has = |st: Stage| stages.iter().any(|s| s.stage() == Some(st)) as usize;
    // The viewer subscribes to both services too, its depth subscription last.
    let (pose, gesture, viewer) = (has(Stage::Pose), has(Stage::Gesture), has(Stage::Viewer));
    let (depth0, skeleton0) = (
        pipeline.depth_subscribers()?,
        pipeline.skeleton_subscribers()?,
    );
    let downstream = |s: &&mut Supervised| s.stage().is_some_and(|st| st != Stage::Capture);
    for s in stages.iter_mut().filter(downstream) {
        s.spawn(pipeline)?;
    }
    let started = Instant::now();
    let ready = |p: &Pipeline| -> Result<bool, IpcError> {
        let viewer = if started.elapsed() < VIEWER_WAIT {
            viewer
        } else {
            0
        };
        Ok(p.depth_subscribers()? >= depth0 + pose + viewer
            && p.skeleton_subscribers()? >= skeleton0 + gesture + viewer)
    };
    while !ready(pipeline)? && !shutdown::requested() {
        if started.elapsed() > SUBSCRIBE_WAIT {
            tracing::warn!("pose or gesture not listening after 15 s; starting capture anyway");
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    for s in stages
        .iter_mut()
        .filter(|s| s.stage() == Some(Stage::Capture))
    {
        s.spawn(pipeline)?;
    }
    for s in stages.iter_mut().filter(|s| s.stage().is_none()) {
        s.spawn(pipeline)?;
    }
    Ok(())
}

/// The supervisor's loop: the listener in turn with the stages, until a signal, the
/// listener is done, capture's source ran out, or an essential stage keeps dying.
fn watch(
    stages: &mut [Supervised],
    pipeline: &Pipeline,
    listener: &mut impl Listener,
) -> Result<(), SupervisorError> {
    let mut poll = |t: Duration| listener.poll(t).map_err(SupervisorError::Listener);
    while !shutdown::requested() {
        if poll(Duration::from_millis(50))? == Poll::Done {
            return Ok(());
        }
        let now = Instant::now();
        for s in stages.iter_mut() {
            s.check(now, pipeline)?;
        }
        if stages
            .iter()
            .any(|s| s.stage() == Some(Stage::Capture) && s.finished())
        {
            let until = Instant::now() + DRAIN;
            while Instant::now() < until {
                if poll(Duration::from_millis(20))? == Poll::Done {
                    break;
                }
            }
            return Ok(());
        }
    }
    Ok(())
}

/// What [`StagePlan::own`] runs: the image this process was started from, rather than
/// the file at its path. A stage restarted after that file was replaced (a `cargo
/// build` or an upgrade while the pipeline runs) is still the supervisor's own build,
/// whose message types its peers accept, and a file that was removed is no obstacle.
const OWN_EXECUTABLE: &str = "/proc/self/exe";

/// A command that runs this very executable again (a stage, or a pipeline to profile)
/// as a child that ends with this process: see [`OWN_EXECUTABLE`]; the path stays
/// argv\[0\], for `ps`.
pub fn own_executable() -> std::process::Command {
    use std::os::unix::process::CommandExt;
    let mut cmd = std::process::Command::new(OWN_EXECUTABLE);
    if let Ok(path) = std::env::current_exe() {
        cmd.arg0(path);
    }
    child::end_with_parent(&mut cmd);
    cmd
}

/// How a person runs `stage` by hand, for messages that send them there.
pub fn invocation(stage: Stage) -> String {
    format!("airglyph stage {}", stage.name())
}
