//! The supervisor with stand-in stages (shell one-liners) on a pipeline of its own: a
//! stage that died is restarted, one that keeps dying is given up (the viewer alone, a
//! companion alone), one that finishes ends the run, a listener ends it, and every
//! stage is stopped.

use airglyph::supervisor::{
    supervise, CompanionPlan, CrashRule, Idle, Listener, ListenerError, Plan, Poll, StagePlan,
    SupervisorError,
};
use airglyph_ipc::{IpcConfig, Pipeline, Stage};
use std::path::Path;
use std::time::{Duration, Instant};

/// A test's own IPC root and prefix, removed when dropped; bind it before the pipeline,
/// which then goes first.
struct Isolated {
    config: IpcConfig,
    dir: tempfile::TempDir,
}

impl Isolated {
    fn new(tag: &str) -> Self {
        Self {
            config: IpcConfig {
                root: format!("/tmp/airglyph-test-{}-{tag}/", std::process::id()),
                prefix: format!("ags{}{tag}_", std::process::id()),
            },
            dir: tempfile::tempdir().unwrap(),
        }
    }

    fn pipeline(&self) -> Pipeline {
        Pipeline::join_with(self.config.clone(), airglyph::supervisor::NODE).unwrap()
    }

    /// A file of this test's own.
    fn file(&self, name: &str) -> String {
        self.dir.path().join(name).to_str().unwrap().to_owned()
    }
}

impl Drop for Isolated {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.config.root);
        let _ = std::fs::remove_file(airglyph_ipc::ownership::node_counter(&self.config.prefix));
    }
}

/// `stage` played by `sh -c script`.
fn sh(stage: Stage, script: &str) -> StagePlan {
    StagePlan {
        stage,
        program: "sh".into(),
        arg0: None,
        args: vec!["-c".into(), script.into()],
        health: None,
        by_hand: format!("sh -c '{script}'"),
    }
}

fn plan(stages: Vec<StagePlan>, max_restarts: usize) -> Plan {
    Plan {
        stages,
        companions: Vec::new(),
        rule: CrashRule {
            max_restarts,
            window: Duration::from_secs(60),
        },
    }
}

/// How often a stand-in ran: one line a start in its file.
fn runs(path: &str) -> usize {
    std::fs::read_to_string(path).map_or(0, |t| t.lines().count())
}

/// Whether process `pid` is gone.
fn gone(pid: &str) -> bool {
    // SAFETY: kill(2) with signal 0 only asks whether the process exists.
    unsafe { libc::kill(pid.trim().parse().unwrap(), 0) != 0 }
}

/// A capture stand-in that runs until stopped, and the file it writes its pid to.
fn sleeper(p: &Isolated) -> (StagePlan, String) {
    let pid_file = p.file("capture.pid");
    let script = format!("echo $$ > {pid_file}; exec sleep 60");
    (sh(Stage::Capture, &script), pid_file)
}

/// Done after `after`: the caller's reason to stop the pipeline.
struct DoneAfter(Instant, Duration);

impl Listener for DoneAfter {
    fn poll(&mut self, timeout: Duration) -> Result<Poll, ListenerError> {
        std::thread::sleep(timeout);
        Ok(if self.0.elapsed() >= self.1 {
            Poll::Done
        } else {
            Poll::Idle
        })
    }
}

#[test]
fn a_stage_that_keeps_dying_is_given_up_naming_it_and_its_last_status() {
    let p = Isolated::new("loop");
    let count = p.file("runs");
    let capture = sh(Stage::Capture, &format!("echo run >> {count}; exit 3"));
    let t = Instant::now();
    let err = supervise(&plan(vec![capture], 2), p.pipeline(), |_| Ok(Idle))
        .err()
        .expect("a crash loop");
    match &err {
        SupervisorError::CrashLoop {
            stage,
            deaths,
            last,
            ..
        } => assert_eq!(
            (*stage, *deaths, last.as_str()),
            (Stage::Capture, 3, "exit code 3")
        ),
        other => panic!("{other}"),
    }
    let text = err.to_string();
    assert!(
        text.contains("stage capture died 3 times") && text.contains("exit 3"),
        "{text}"
    );
    assert_eq!(runs(&count), 3, "started, restarted twice, given up");
    // Backoff 100 ms, then 200 ms: well under a second of waiting.
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
}

#[test]
fn a_stage_that_died_is_restarted_and_one_that_finishes_ends_the_run() {
    let p = Isolated::new("again");
    let count = p.file("runs");
    // Dies at its first start, finishes (a finite source ran out) at its second.
    let capture = sh(
        Stage::Capture,
        &format!("echo run >> {count}; [ $(wc -l < {count}) -ge 2 ] && exit 0; exit 1"),
    );
    supervise(&plan(vec![capture], 5), p.pipeline(), |_| Ok(Idle)).unwrap();
    assert_eq!(runs(&count), 2);
}

#[test]
fn a_viewer_that_keeps_dying_is_given_up_alone_and_the_others_are_stopped_at_the_end() {
    let p = Isolated::new("viewer");
    let viewer_runs = p.file("viewer");
    let (capture, capture_pid) = sleeper(&p);
    let viewer = sh(Stage::Viewer, &format!("echo run >> {viewer_runs}; exit 1"));
    let t = Instant::now();
    let listening = supervise(&plan(vec![capture, viewer], 1), p.pipeline(), |_| {
        Ok(DoneAfter(Instant::now(), Duration::from_secs(4)))
    })
    .expect("the pipeline runs on without its viewer");
    drop(listening);
    assert_eq!(runs(&viewer_runs), 2, "started, restarted once, given up");
    let pid = std::fs::read_to_string(&capture_pid).unwrap();
    assert!(gone(&pid), "capture was stopped");
    // SIGTERM ends `sleep` at once: no 3 s grace used up.
    assert!(t.elapsed() < Duration::from_secs(10), "{:?}", t.elapsed());
}

/// A companion played by `sh -c script`.
fn sh_companion(name: &str, script: &str) -> CompanionPlan {
    CompanionPlan {
        name: name.into(),
        program: "sh".into(),
        args: vec!["-c".into(), script.into()],
        by_hand: format!("sh -c '{script}'"),
    }
}

#[test]
fn companions_never_stop_the_pipeline_and_are_stopped_with_it() {
    let p = Isolated::new("companion");
    let (capture, capture_pid) = sleeper(&p);
    // One that keeps dying, telling which pipeline it was given each time; one whose
    // program is missing; one that runs until stopped.
    let dying_runs = p.file("dying");
    let dying = sh_companion(
        "dying",
        &format!("echo \"$AIRGLYPH_IPC_ROOT $AIRGLYPH_IPC_PREFIX\" >> {dying_runs}; exit 1"),
    );
    let missing = CompanionPlan {
        program: "/nonexistent/airglyph-zenoh".into(),
        ..sh_companion("missing", "true")
    };
    let living_pid = p.file("living.pid");
    let living = sh_companion("living", &format!("echo $$ > {living_pid}; exec sleep 60"));
    let plan = Plan {
        companions: vec![dying, missing, living],
        ..plan(vec![capture], 1)
    };
    supervise(&plan, p.pipeline(), |_| {
        Ok(DoneAfter(Instant::now(), Duration::from_secs(2)))
    })
    .expect("the pipeline runs on without its companions");
    let given = std::fs::read_to_string(&dying_runs).unwrap();
    let pipeline = format!("{} {}", p.config.root, p.config.prefix);
    assert_eq!(
        given.lines().collect::<Vec<_>>(),
        [pipeline.as_str(), pipeline.as_str()],
        "started on the supervisor's pipeline, restarted once, given up"
    );
    for pid_file in [capture_pid, living_pid] {
        let pid = std::fs::read_to_string(&pid_file).unwrap();
        assert!(gone(&pid), "{pid_file} was stopped");
    }
}

#[test]
fn a_listener_that_fails_ends_the_run_with_its_own_error_and_stops_the_stages() {
    let p = Isolated::new("fail");
    let (capture, pid_file) = sleeper(&p);
    struct Fails;
    impl Listener for Fails {
        fn poll(&mut self, timeout: Duration) -> Result<Poll, ListenerError> {
            std::thread::sleep(timeout);
            Err("the listener's own trouble".into())
        }
    }
    let err = supervise(&plan(vec![capture], 5), p.pipeline(), |_| Ok(Fails))
        .err()
        .expect("the listener's error");
    assert!(matches!(err, SupervisorError::Listener(_)), "{err:?}");
    assert_eq!(err.to_string(), "the listener's own trouble");
    // The stand-in may not have written its pid yet when the listener failed.
    let deadline = Instant::now() + Duration::from_secs(2);
    while !Path::new(&pid_file).exists() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    if let Ok(pid) = std::fs::read_to_string(&pid_file) {
        assert!(gone(&pid), "capture was stopped");
    }
}

#[test]
fn a_plan_without_stages_or_with_a_program_that_cannot_start_is_refused() {
    let p = Isolated::new("bad");
    let err = supervise(&plan(vec![], 5), p.pipeline(), |_| Ok(Idle)).err();
    assert!(matches!(err, Some(SupervisorError::NoStages)), "{err:?}");
    let missing = StagePlan {
        program: "/nonexistent/airglyph".into(),
        ..sh(Stage::Capture, "true")
    };
    let err = supervise(&plan(vec![missing], 5), p.pipeline(), |_| Ok(Idle))
        .err()
        .expect("cannot start");
    assert!(matches!(err, SupervisorError::Start { .. }), "{err:?}");
    assert!(
        err.to_string().contains("cannot start `sh -c 'true'`"),
        "{err}"
    );
}

#[test]
fn the_own_plan_runs_this_executable_as_the_stage() {
    let plan = StagePlan::own(Stage::Pose, vec!["--recording".into(), "dir".into()]);
    assert_eq!(plan.program, Path::new("/proc/self/exe"));
    assert_eq!(plan.args, ["stage", "pose", "--recording", "dir"]);
    assert_eq!(plan.by_hand, "airglyph stage pose");
    assert!(plan.essential());
    assert!(!StagePlan::own(Stage::Viewer, vec![]).essential());
}
