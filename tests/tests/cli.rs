//! The command line itself: what it refuses and how it says so, arguments that carry
//! spaces, and what it prints.

use airglyph_system_tests::{
    binary_path, fail, json_lines, one_at_a_time, stop, succeed, synth, Isolated,
};
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::Stdio;
use std::time::Duration;

#[test]
fn stage_arguments_are_checked_before_anything_starts() {
    let p = Isolated::new();
    // A stage that does not exist: refused with the list of stages.
    let err = fail(
        p.command("airglyph")
            .args(["run", "--stage-args", "gestrue=--model m.json"]),
    );
    assert!(err.contains("unknown stage \"gestrue\""), "{err}");
    assert!(err.contains("capture, pose, gesture, viewer"), "{err}");
    // An argument the stage does not take: its own parser says so, before any start.
    let err = fail(
        p.command("airglyph")
            .args(["run", "--stage-args", "gesture=--modle m.json"]),
    );
    assert!(err.contains("the arguments of the gesture stage"), "{err}");
    assert!(err.contains("--modle"), "{err}");
    // A quote left open, and a stage that does not run.
    let err = fail(
        p.command("airglyph")
            .args(["run", "--stage-args", "gesture=--model 'm.json"]),
    );
    assert!(err.contains("a quote is not closed"), "{err}");
    let err = fail(
        p.command("airglyph")
            .args(["run", "--stage-args", "viewer=--max-fps 5"]),
    );
    assert!(
        err.contains("the viewer stage does not run here (add --view)"),
        "{err}"
    );
    let err =
        fail(
            p.command("airglyph")
                .args(["run", "--stages", "capture,pose", "--model", "m.json"]),
        );
    assert!(err.contains("--model"), "{err}");
    assert!(p.processes().is_empty() && p.shm_files().is_empty());
}

#[test]
fn export_without_airglyph_zenoh_is_refused_before_anything_starts() {
    let p = Isolated::new();
    // This build's airglyph in a folder of its own (an airglyph-zenoh built beside the
    // original must not be found), with a PATH that has none either.
    let exe = binary_path("airglyph");
    let alone = tempfile::tempdir_in(exe.parent().unwrap()).unwrap();
    let airglyph = alone.path().join("airglyph");
    if std::fs::hard_link(&exe, &airglyph).is_err() {
        std::fs::copy(&exe, &airglyph).unwrap();
    }
    let path = tempfile::tempdir().unwrap();
    let err = fail(p.command_at(&airglyph).env("PATH", path.path()).args([
        "run",
        "--export",
        "zenoh",
        "--export-listen",
        "tcp/127.0.0.1:7447",
    ]));
    assert!(
        err.contains("--export zenoh needs the airglyph-zenoh executable"),
        "{err}"
    );
    assert!(
        err.contains(&alone.path().display().to_string()),
        "names where it looked: {err}"
    );
    assert!(
        err.contains("cargo build --release -p airglyph-zenoh"),
        "{err}"
    );
    assert!(p.processes().is_empty() && p.shm_files().is_empty());
    assert!(
        !p.root.exists(),
        "no stage started, not even the pipeline's folder"
    );
}

/// The first gesture `airglyph run ARGS` prints, drawing a 3.
fn first_gesture(p: &Isolated, args: &[&str]) -> serde_json::Value {
    let mut run = p
        .command("airglyph")
        .args(["run", "--source", "synthetic:draw:3", "--json"])
        .args(args)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let events = json_lines(run.stdout.take().unwrap());
    let first = events
        .recv_timeout(Duration::from_secs(60))
        .expect("a gesture");
    stop(run);
    first
}

#[test]
fn a_model_whose_path_has_a_space_reaches_the_gesture_stage() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("my models");
    std::fs::create_dir(&dir).unwrap();
    let model = dir.join("digits and letters.json");
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/unipen-36.json");
    std::fs::copy(shipped, &model).unwrap();
    let model = model.to_str().unwrap();
    let quoted = format!("gesture=--model '{model}'");
    for args in [&["--model", model][..], &["--stage-args", &quoted][..]] {
        let g = first_gesture(&p, args);
        assert_eq!(g["label"], "3", "{args:?}: {g}");
    }
}

/// The keys of an object, sorted.
fn keys(v: &serde_json::Value) -> Vec<&str> {
    let mut k: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    k.sort();
    k
}

#[test]
fn a_gesture_has_the_same_keys_from_run_demo_and_spot() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let every = [
        "end_frame",
        "end_ns",
        "event",
        "hand",
        "label",
        "score",
        "start_frame",
        "start_ns",
    ];
    let with = |extra: &[&'static str]| {
        let mut k: Vec<&str> = every.iter().chain(extra).copied().collect();
        k.sort();
        k
    };

    let run = first_gesture(&p, &[]);
    assert_eq!(
        keys(&run),
        with(&["latency_ms", "posture", "session"]),
        "{run}"
    );

    let out = succeed(
        p.command("airglyph")
            .args(["demo", "--symbols", "3", "--truth", "--json"]),
    );
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let (summary, gestures) = lines.split_last().unwrap();
    assert_eq!(summary["event"], "summary", "{summary}");
    assert_eq!(gestures[0]["label"], "3", "{}", gestures[0]);
    assert_eq!(gestures[0]["drawn"], "3", "{}", gestures[0]);
    assert_eq!(
        keys(&gestures[0]),
        with(&["drawn", "latency_ms", "posture", "session"])
    );

    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("rec");
    synth(&p, "draw:3", &rec);
    let out = succeed(
        p.command("airglyph")
            .args(["spot", "--truth", "--json"])
            .arg(&rec),
    );
    let first: serde_json::Value =
        serde_json::from_str(String::from_utf8_lossy(&out.stdout).lines().next().unwrap()).unwrap();
    assert_eq!(keys(&first), with(&["drawn"]), "{first}");
    assert_eq!(
        (&first["label"], &first["drawn"]),
        (&"3".into(), &"3".into())
    );
}

#[test]
fn top_into_a_pipe_is_a_filter_and_ends_quietly_when_its_reader_goes() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let supervisor = p
        .command("airglyph")
        .args(["run", "--source", "synthetic:poses"])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let mut top = p
        .command("airglyph")
        .arg("top")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut rows = BufReader::new(top.stdout.take().unwrap()).lines();
    let mut seen = Vec::new();
    // The header once, then rows, until every stage has shown a frame rate.
    while !["capture", "pose", "gesture"].iter().all(|s| {
        seen.iter()
            .any(|r: &String| r.starts_with(s) && !r.contains("not running"))
    }) {
        seen.push(rows.next().expect("a row").unwrap());
    }
    assert!(seen[0].starts_with("stage"), "{seen:?}");
    assert_eq!(seen.iter().filter(|r| r.starts_with("stage")).count(), 1);
    assert!(
        !seen.iter().any(|r| r.contains('\x1b')),
        "no terminal codes: {seen:?}"
    );
    // `airglyph top | head`: the reader goes; top ends by itself, quietly.
    drop(rows);
    let status = top.wait().unwrap();
    let mut err = String::new();
    top.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert!(status.success() && err.is_empty(), "{status}: {err}");
    stop(supervisor);
}

/// What `airglyph run` logs capturing three frames, with stderr a pipe or, through
/// script(1), a terminal.
fn logs(p: &Isolated, terminal: bool, no_color: Option<&str>) -> String {
    let args = [
        "run",
        "--stages",
        "capture",
        "--source",
        "synthetic",
        "--frames",
        "3",
    ];
    let mut cmd = if terminal {
        let exe = airglyph_system_tests::binary_path("airglyph");
        let mut script = std::process::Command::new("script");
        script
            .args(["--quiet", "--return", "--command"])
            .arg(format!("{} {}", exe.display(), args.join(" ")))
            .arg("/dev/null");
        script
    } else {
        let mut cmd = p.command("airglyph");
        cmd.args(args);
        cmd
    };
    // The pipeline's environment, in case the command above is script's.
    cmd.env("AIRGLYPH_IPC_ROOT", format!("{}/", p.root.display()))
        .env("AIRGLYPH_IPC_PREFIX", &p.prefix)
        .env("RUST_LOG", "info")
        .env_remove("NO_COLOR");
    if let Some(v) = no_color {
        cmd.env("NO_COLOR", v);
    }
    let out = succeed(&mut cmd);
    let mut text = String::from_utf8_lossy(&out.stdout).into_owned();
    text += &String::from_utf8_lossy(&out.stderr);
    assert!(text.contains("capturing"), "{text}");
    text
}

#[test]
fn logs_are_coloured_only_on_a_terminal_and_never_under_no_color() {
    let p = Isolated::new();
    assert!(
        !logs(&p, false, None).contains('\x1b'),
        "no colour into a pipe"
    );
    if std::process::Command::new("script")
        .arg("--version")
        .output()
        .is_err()
    {
        eprintln!("skipping the terminal half: no script(1) (util-linux) here");
        return;
    }
    assert!(
        logs(&p, true, None).contains('\x1b'),
        "colours on a terminal"
    );
    assert!(
        !logs(&p, true, Some("1")).contains('\x1b'),
        "none under NO_COLOR"
    );
    // An empty NO_COLOR is no request (no-color.org).
    assert!(logs(&p, true, Some("")).contains('\x1b'));
}

#[test]
fn version_names_the_commit_and_help_the_environment() {
    let p = Isolated::new();
    let out = succeed(p.command("airglyph").arg("--version"));
    let version = String::from_utf8_lossy(&out.stdout);
    let commit = std::process::Command::new("git")
        .args(["log", "-1", "--format=%h"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned());
    match commit {
        Some(commit) => assert!(version.contains(&format!("({commit} ")), "{version}"),
        None => eprintln!("not a git checkout: {version}"),
    }
    let out = succeed(p.command("airglyph").arg("--help"));
    let help = String::from_utf8_lossy(&out.stdout);
    for var in ["RUST_LOG", "NO_COLOR", "AIRGLYPH_MODEL", "AIRGLYPH_ASSETS"] {
        assert!(help.contains(var), "{var}: {help}");
    }
}

#[test]
fn completions_and_man_pages_come_from_the_command_definitions() {
    let p = Isolated::new();
    for shell in ["bash", "zsh", "fish"] {
        let out = succeed(p.command("airglyph").args(["completions", shell]));
        let script = String::from_utf8_lossy(&out.stdout);
        for word in ["fetch-assets", "eval-spotting", "--stage-args"] {
            assert!(script.contains(word), "{shell}: {word}");
        }
    }
    let out = succeed(p.command("airglyph").arg("man"));
    let page = String::from_utf8_lossy(&out.stdout);
    assert!(
        page.starts_with(".ie") && page.contains(".TH airglyph 1"),
        "{page}"
    );
    assert!(page.contains("RUST_LOG"), "the environment: {page}");
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("man1");
    succeed(p.command("airglyph").args(["man", "--dir"]).arg(&dir));
    let pages: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    for page in [
        "airglyph.1",
        "airglyph-demo.1",
        "airglyph-run.1",
        "airglyph-top.1",
    ] {
        assert!(pages.iter().any(|p| p == page), "{page} in {pages:?}");
    }
    assert!(
        !pages.iter().any(|p| p.starts_with("airglyph-stage")),
        "the stages are not for the manual: {pages:?}"
    );
}
