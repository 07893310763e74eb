//! One supervised stage's process (or a companion's): started, reaped, restarted with
//! backoff, stopped.

use super::{CompanionPlan, CrashRule, Deaths, StagePlan, SupervisorError};
use airglyph_ipc::config::{ENV_PREFIX, ENV_ROOT};
use airglyph_ipc::{Pipeline, Stage};
use airglyph_viewer::health::HealthWatch;
use std::os::unix::process::CommandExt;
use std::process::{Child, Command, ExitStatus};
use std::time::{Duration, Instant};

/// How long a viewer just started may take to answer before a failed probe counts: it
/// joins the pipeline and binds its port first (well under a second on an idle
/// machine, longer on a loaded one). A viewer that never binds exits by itself.
const STARTUP_GRACE: Duration = Duration::from_secs(30);
/// The first restart waits this long; each further one twice as long, up to `MAX_BACKOFF`.
const MIN_BACKOFF: Duration = Duration::from_millis(100);
const MAX_BACKOFF: Duration = Duration::from_secs(5);
/// A stage that dies sooner than this after its start waits longer for its restart each
/// time; one that ran longer is restarted after `MIN_BACKOFF` again.
const HEALTHY_AFTER: Duration = Duration::from_secs(2);
/// How long a stage gets to stop after SIGTERM before SIGKILL.
const STOP_GRACE: Duration = Duration::from_secs(3);

/// Makes `cmd`'s child receive SIGTERM when this process dies (even by SIGKILL), so a
/// stage whose supervisor is gone stops too instead of running on unsupervised.
pub(super) fn end_with_parent(cmd: &mut Command) {
    // SAFETY: prctl is async-signal-safe; the closure touches nothing else.
    unsafe {
        cmd.pre_exec(|| {
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
            Ok(())
        });
    }
}

/// What is supervised: a stage of the pipeline, or a companion beside it.
#[derive(Clone, Copy)]
enum Who<'a> {
    Stage(&'a StagePlan),
    Companion(&'a CompanionPlan),
}

impl<'a> Who<'a> {
    fn name(&self) -> &'a str {
        match self {
            Who::Stage(p) => p.stage.name(),
            Who::Companion(c) => &c.name,
        }
    }

    fn by_hand(&self) -> &'a str {
        match self {
            Who::Stage(p) => &p.by_hand,
            Who::Companion(c) => &c.by_hand,
        }
    }

    fn command(&self) -> Command {
        match self {
            Who::Stage(p) => {
                let mut cmd = Command::new(&p.program);
                if let Some(arg0) = &p.arg0 {
                    cmd.arg0(arg0);
                }
                cmd.args(&p.args);
                cmd
            }
            Who::Companion(c) => {
                let mut cmd = Command::new(&c.program);
                cmd.args(&c.args);
                cmd
            }
        }
    }
}

/// One supervised process.
pub(super) struct Supervised<'a> {
    who: Who<'a>,
    child: Option<Child>,
    started: Instant,
    backoff: Duration,
    restart_at: Option<Instant>,
    deaths: Deaths,
    /// Exited by itself with success (a finite source ran out), or given up: not restarted.
    finished: bool,
    /// The viewer's: whether its web server still answers (a stopped or hung viewer
    /// lives on as a process).
    health: Option<HealthWatch>,
}

impl<'a> Supervised<'a> {
    pub(super) fn for_stage(plan: &'a StagePlan, rule: CrashRule) -> Result<Self, SupervisorError> {
        let health = match plan.health {
            Some(addr) if addr.port() == 0 => {
                // Any free port, which only the viewer knows; its own watchdog still
                // ends it when its server stops.
                tracing::info!(
                    stage = plan.stage.name(),
                    "listens on any free port: the supervisor cannot check its health"
                );
                None
            }
            Some(addr) => {
                Some(HealthWatch::start(addr, STARTUP_GRACE).map_err(SupervisorError::Health)?)
            }
            None => None,
        };
        Ok(Self::new(Who::Stage(plan), rule, health))
    }

    pub(super) fn for_companion(plan: &'a CompanionPlan, rule: CrashRule) -> Self {
        Self::new(Who::Companion(plan), rule, None)
    }

    fn new(who: Who<'a>, rule: CrashRule, health: Option<HealthWatch>) -> Self {
        Self {
            who,
            child: None,
            started: Instant::now(),
            backoff: MIN_BACKOFF,
            restart_at: None,
            deaths: Deaths::new(rule),
            finished: false,
            health,
        }
    }

    /// The stage it is; none for a companion.
    pub(super) fn stage(&self) -> Option<Stage> {
        match self.who {
            Who::Stage(p) => Some(p.stage),
            Who::Companion(_) => None,
        }
    }

    pub(super) fn finished(&self) -> bool {
        self.finished
    }

    /// Starts the process on `pipeline`. A stage that cannot be started is an error; a
    /// companion's failure counts as a death (restarted after its backoff, given up
    /// when it keeps failing), so that the stages run on without it.
    pub(super) fn spawn(&mut self, pipeline: &Pipeline) -> Result<(), SupervisorError> {
        let mut cmd = self.who.command();
        end_with_parent(&mut cmd);
        // The pipeline the supervisor was handed, whatever named it (the environment, a
        // config file, a test's own join): a child reads the same services.
        let ipc = pipeline.config();
        cmd.env(ENV_ROOT, &ipc.root).env(ENV_PREFIX, &ipc.prefix);
        let child = match cmd.spawn() {
            Ok(child) => child,
            Err(source) if matches!(self.who, Who::Companion(_)) => {
                self.started = Instant::now();
                let how = format!("could not be started: {source}");
                return self.died(Instant::now(), how);
            }
            Err(source) => {
                return Err(SupervisorError::Start {
                    by_hand: self.who.by_hand().to_owned(),
                    source,
                })
            }
        };
        tracing::debug!(stage = self.who.name(), pid = child.id(), "started");
        self.child = Some(child);
        self.started = Instant::now();
        self.restart_at = None;
        if let Some(h) = &self.health {
            h.restarted();
        }
        Ok(())
    }

    /// Looks at the process once, at `now`: kills a viewer that stopped serving, reaps a
    /// process that ended and plans its restart (or gives it up), and restarts one whose
    /// backoff is over. An essential stage in a crash loop is an error.
    pub(super) fn check(
        &mut self,
        now: Instant,
        pipeline: &Pipeline,
    ) -> Result<(), SupervisorError> {
        let Some(child) = self.child.as_mut() else {
            if self.restart_at.is_some_and(|t| now >= t) {
                self.spawn(pipeline)?;
                if self.child.is_some() {
                    tracing::info!(
                        stage = self.who.name(),
                        deaths = self.deaths.count(),
                        "stage restarted"
                    );
                }
            }
            return Ok(());
        };
        let status = match child.try_wait() {
            Ok(status) => status,
            Err(source) => {
                let Who::Stage(plan) = self.who else {
                    // Not worth the pipeline: let it go, as one that keeps dying.
                    tracing::error!(
                        stage = self.who.name(),
                        error = %source,
                        "cannot wait for it; giving it up (the pipeline runs on)"
                    );
                    self.stop();
                    self.finished = true;
                    return Ok(());
                };
                return Err(SupervisorError::Wait {
                    stage: plan.stage,
                    source,
                });
            }
        };
        let Some(status) = status else {
            if let Some(reason) = self.health.as_ref().and_then(HealthWatch::stopped_serving) {
                // SIGKILL: a stopped process would not act on SIGTERM. Its death is then
                // handled as any other, at the next round.
                tracing::warn!(
                    stage = self.who.name(),
                    pid = child.id(),
                    %reason,
                    "the viewer lives but stopped serving; killing it to start it again"
                );
                let _ = child.kill();
            }
            return Ok(());
        };
        self.child = None;
        if status.success() {
            tracing::info!(stage = self.who.name(), "finished");
            self.finished = true;
            return Ok(());
        }
        // Free the dead process's shared memory now, not only when it restarts.
        pipeline.cleanup_dead_nodes();
        self.died(now, describe(status))
    }

    /// Counts a death at `now` (`last`: how the run ended) and plans the restart, or
    /// gives the process up: alone when it is not essential, with an error otherwise.
    fn died(&mut self, now: Instant, last: String) -> Result<(), SupervisorError> {
        let name = self.who.name();
        // Planned anew below, or not at all for one given up.
        self.restart_at = None;
        let young = self.started.elapsed() <= HEALTHY_AFTER;
        if !young {
            // It was working: restart it at once, whatever came before.
            self.backoff = MIN_BACKOFF;
        }
        let looping = self.deaths.record(now);
        let window_s = self.deaths.rule().window.as_secs_f64();
        match self.who {
            Who::Stage(plan) if looping && plan.essential() => {
                return Err(SupervisorError::CrashLoop {
                    stage: plan.stage,
                    deaths: self.deaths.count(),
                    window_s,
                    last,
                    after_s: self.started.elapsed().as_secs_f64(),
                    by_hand: plan.by_hand.clone(),
                });
            }
            _ if looping => {
                tracing::error!(
                    stage = name,
                    deaths = self.deaths.count(),
                    window_s,
                    %last,
                    "stage keeps dying; giving it up (the pipeline runs on) — run `{}` alone to see why",
                    self.who.by_hand()
                );
                self.finished = true;
                return Ok(());
            }
            _ => {}
        }
        tracing::warn!(
            stage = name,
            status = %last,
            backoff_ms = self.backoff.as_millis() as u64,
            "stage died; restarting"
        );
        self.restart_at = Some(now + self.backoff);
        if young {
            self.backoff = (self.backoff * 2).min(MAX_BACKOFF);
        }
        Ok(())
    }

    /// Stops the process: SIGTERM, then SIGKILL after [`STOP_GRACE`].
    pub(super) fn stop(&mut self) {
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
                        stage = self.who.name(),
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

/// How a process ended, in words.
fn describe(status: ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(code), _) => format!("exit code {code}"),
        (None, Some(sig)) => format!("signal {sig}"),
        _ => "unknown status".into(),
    }
}
