//! Issue 28 with real processes, tried as an attacker or an unlucky user would: another
//! local user (setpriv to nobody, where the machine allows it), a second stage of the
//! same kind, a publisher that rewrites what it sent, a model whose sizes overflow, and
//! a client holding a thousand connections and sending an endless header.

use airglyph_system_tests::{
    binary_path, fail, one_at_a_time, shut_down, stage_children, succeed, top, Isolated,
};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::unix::fs::MetadataExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A command run as nobody, joined to the pipeline `p` (same settings, another user);
/// `None` where this machine cannot switch users (not root, no setpriv).
fn as_nobody(p: &Isolated, program: &str, args: &[&str]) -> Option<Command> {
    // SAFETY: geteuid(2) touches no memory.
    if unsafe { libc::geteuid() } != 0 || !Path::new("/usr/bin/setpriv").exists() {
        eprintln!("skipped: switching to another user needs root and setpriv");
        return None;
    }
    let mut cmd = Command::new("/usr/bin/setpriv");
    cmd.args([
        "--reuid",
        "nobody",
        "--regid",
        "nogroup",
        "--clear-groups",
        "--",
    ])
    .arg(program)
    .args(args)
    .env("AIRGLYPH_IPC_ROOT", format!("{}/", p.root.display()))
    .env("AIRGLYPH_IPC_PREFIX", &p.prefix)
    .env("RUST_LOG", "warn");
    Some(cmd)
}

/// Waits for a child to end within `within`; kills it and panics with `what` if not.
fn ends_within(mut child: Child, within: Duration, what: &str) -> (bool, String) {
    let deadline = Instant::now() + within;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            if let Some(mut e) = child.stderr.take() {
                e.read_to_string(&mut err).unwrap();
            }
            return (status.success(), err);
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {within:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn capture(p: &Isolated, extra: &[&str]) -> Command {
    let mut cmd = p.stage("capture");
    cmd.args(["--source", "synthetic:poses"]).args(extra);
    cmd
}

/// Item 1: sixteen bytes planted by another user under the node counter's name made
/// every stage fail with `UnableToGenerateUniqueNodeId`, naming no file.
#[test]
fn a_node_counter_planted_by_another_user_is_refused_by_name() {
    let p = Isolated::new();
    let counter = p.node_counter();
    let plant = format!(
        "head -c 16 /dev/zero | tr '\\000' '\\377' > {0} && chmod 666 {0}",
        counter.display()
    );
    let Some(mut planting) = as_nobody(&p, "/bin/sh", &["-c", &plant]) else {
        return;
    };
    assert!(
        planting.status().unwrap().success(),
        "nobody plants the file"
    );
    let err = fail(&mut capture(&p, &["--frames", "1", "--fast"]));
    assert!(
        err.contains(&counter.display().to_string()) && err.contains("nobody"),
        "the start is refused naming the file and its owner: {err}"
    );
}

/// Item 1: any file of the pipeline's prefix another user made (here under the name of
/// a service's data segment) is refused by name before iceoryx2 opens it.
#[test]
fn a_shared_memory_file_planted_by_another_user_is_refused_by_name() {
    let p = Isolated::new();
    let planted = Path::new("/dev/shm").join(format!(
        "{}0354a209029e7d094a819e2d4030ea331e6caaf0.dynamic",
        p.prefix
    ));
    let plant = format!("echo x > {0} && chmod 666 {0}", planted.display());
    let Some(mut planting) = as_nobody(&p, "/bin/sh", &["-c", &plant]) else {
        return;
    };
    assert!(
        planting.status().unwrap().success(),
        "nobody plants the file"
    );
    let err = fail(&mut capture(&p, &["--frames", "1", "--fast"]));
    assert!(
        err.contains(&planted.display().to_string()) && err.contains("nobody"),
        "{err}"
    );
}

/// Item 1: the counter a run leaves is the pipeline user's alone and stays, so nobody
/// can write into it or plant one before the next start (which the old build's
/// removal after every run allowed).
#[test]
fn the_node_counter_stays_closed_to_other_users_between_runs() {
    let p = Isolated::new();
    succeed(&mut capture(&p, &["--frames", "3", "--fast"]));
    let counter = p.node_counter();
    let meta = std::fs::metadata(&counter).expect("the node counter stays after a run");
    // SAFETY: geteuid(2) touches no memory.
    assert_eq!(meta.uid(), unsafe { libc::geteuid() });
    assert_eq!(meta.mode() & 0o777, 0o600, "closed to other users");
    let tamper = format!(
        "head -c 16 /dev/zero | tr '\\000' '\\377' > {}",
        counter.display()
    );
    if let Some(mut tampering) = as_nobody(&p, "/bin/sh", &["-c", &tamper]) {
        let out = tampering.output().unwrap();
        assert!(!out.status.success(), "nobody cannot write the counter");
    }
    succeed(&mut capture(&p, &["--frames", "3", "--fast"]));
}

/// Item 7: another user with the same settings is told whose pipeline it is (it got
/// `cannot create the iceoryx2 node "top": InternalError`).
#[test]
fn another_user_is_told_whose_pipeline_it_is() {
    let p = Isolated::new();
    succeed(&mut capture(&p, &["--frames", "1", "--fast"]));
    let airglyph = binary_path("airglyph");
    let Some(mut top) = as_nobody(
        &p,
        airglyph.to_str().unwrap(),
        &["top", "--json", "--wait", "1"],
    ) else {
        return;
    };
    let err = fail(&mut top);
    let root = p.root.display().to_string();
    assert!(
        err.contains(root.trim_end_matches('/')) && err.contains("uid 0 (root)"),
        "names the pipeline's folder and its user: {err}"
    );
}

/// Item 5: a second capture, pose or gesture stage on the same pipeline was taken
/// silently and interleaved its stream with the first's.
#[test]
fn a_second_stage_of_a_kind_is_refused_naming_the_first() {
    let p = Isolated::new();
    let stages: [(&str, &[&str]); 3] = [
        ("capture", &["--source", "synthetic:poses"]),
        ("pose", &[]),
        ("gesture", &[]),
    ];
    let mut first = Vec::new();
    for (stage, args) in stages {
        first.push(p.stage(stage).args(args).spawn().unwrap());
    }
    // Each has its publisher once it reports (the stats service comes after it).
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let stats = top(&p);
        if ["capture", "pose", "gesture"]
            .iter()
            .all(|s| stats["stages"][s]["pid"].as_u64().is_some())
        {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the first stages report: {stats}"
        );
    }
    for ((binary, args), first) in stages.iter().zip(&first) {
        let second = p
            .stage(binary)
            .args(*args)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let (ok, err) = ends_within(second, Duration::from_secs(20), binary);
        assert!(!ok, "{binary}: the second is refused");
        assert!(
            err.contains("already has a publisher")
                && err.contains(&format!("process {}", first.id())),
            "{binary}: the message names the first stage's process: {err}"
        );
    }
    for mut child in first {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the first stages run on"
        );
        airglyph_system_tests::signal(&child, libc::SIGTERM);
        let _ = child.wait();
    }
}

/// Item 4: a publisher of the same user that rewrites a frame's width after sending it
/// turned "refused and counted" into a panic of the pose stage.
#[test]
fn a_publisher_rewriting_sent_headers_cannot_crash_pose() {
    let p = Isolated::new();
    let mut pose = p.stage("pose").spawn().unwrap();
    std::thread::sleep(Duration::from_secs(1));
    succeed(p.command("airglyph-probe").args(["--tamper", "90"]));
    let stats = top(&p);
    assert!(
        pose.try_wait().unwrap().is_none(),
        "pose lives on after 90 rewritten frames: {stats}"
    );
    let pose_stats = &stats["stages"]["pose"];
    let seen = pose_stats["frames_in"].as_u64().unwrap_or(0)
        + pose_stats["frames_rejected"].as_u64().unwrap_or(0)
        + pose_stats["frames_dropped"].as_u64().unwrap_or(0);
    assert!(seen > 0, "pose took or refused the frames: {stats}");
    airglyph_system_tests::signal(&pose, libc::SIGTERM);
    assert!(pose.wait().unwrap().success());
}

/// Item 3: `features.grid = 2^60 + 6` wrapped around to the expected input size,
/// passed the loader, and the gesture stage panicked at every start.
#[test]
fn a_model_whose_sizes_overflow_is_refused_when_loaded() {
    let p = Isolated::new();
    let dir = tempfile::tempdir().unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/unipen-36.json");
    let mut model: serde_json::Value =
        serde_json::from_slice(&std::fs::read(shipped).unwrap()).unwrap();
    model["classifier"]["features"]["grid"] = serde_json::json!((1u64 << 60) + 6);
    let bad = dir.path().join("grid.json");
    std::fs::write(&bad, model.to_string()).unwrap();
    let gesture = p
        .stage("gesture")
        .arg("--model")
        .arg(&bad)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (ok, err) = ends_within(gesture, Duration::from_secs(60), "airglyph stage gesture");
    assert!(!ok);
    assert!(
        err.contains("grid.json") && err.contains("features.grid") && !err.contains("panicked"),
        "one clear line naming the file and the setting: {err}"
    );
}

/// Item 3: `train --hidden 4611686018427387904` panicked (capacity overflow) and
/// `--hidden 1000000000` aborted on a 1.8 TB allocation.
#[test]
fn train_refuses_a_network_too_large_to_allocate() {
    let p = Isolated::new();
    let dir = tempfile::tempdir().unwrap();
    let data =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus/trajectory_jsonl/shapes.jsonl");
    for hidden in ["4611686018427387904", "1000000000"] {
        let err = fail(
            p.command("airglyph")
                .args(["train", "--no-spotting", "--hidden", hidden, "--data"])
                .arg(&data)
                .arg("--out")
                .arg(dir.path().join("m.json")),
        );
        assert!(
            err.contains("--hidden") && err.contains(hidden) && !err.contains("panicked"),
            "{err}"
        );
    }
}

fn raise_fd_limit(want: u64) {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit/setrlimit(2) read and write only `lim`.
    unsafe {
        libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim);
        lim.rlim_cur = want.min(lim.rlim_max);
        libc::setrlimit(libc::RLIMIT_NOFILE, &lim);
    }
}

fn get(addr: SocketAddr, path: &str, timeout: Duration) -> std::io::Result<String> {
    let mut s = TcpStream::connect_timeout(&addr, timeout)?;
    s.set_read_timeout(Some(timeout))?;
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )?;
    let mut head = [0u8; 12];
    s.read_exact(&mut head)?;
    Ok(String::from_utf8_lossy(&head).into_owned())
}

fn rss_kib(pid: u32) -> u64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
        })
        .unwrap_or(0)
}

/// Item 2: held connections exhausted tiny_http's file descriptors and its accept
/// thread ended for good; an endless header line grew the viewer a megabyte a
/// megabyte. A new client must still be served within 1 s, and the endless header be
/// cut off.
#[test]
fn the_viewer_serves_a_new_client_under_held_connections_and_an_endless_header() {
    let p = Isolated::new();
    let addr = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let mut viewer = p
        .stage("viewer")
        .args(["--listen", &addr.to_string()])
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while get(addr, "/healthz", Duration::from_secs(1)).is_err() {
        assert!(Instant::now() < deadline, "the viewer serves");
        std::thread::sleep(Duration::from_millis(100));
    }
    raise_fd_limit(4096);
    let held: Vec<TcpStream> = (0..1000)
        .map(|_| TcpStream::connect(addr).expect("a connection"))
        .collect();
    // An endless header line, 64 KiB at a time, until the server hangs up.
    let mut endless = TcpStream::connect(addr).unwrap();
    endless
        .set_write_timeout(Some(Duration::from_secs(20)))
        .unwrap();
    endless.write_all(b"GET / HTTP/1.1\r\nX-Endless: ").unwrap();
    let chunk = vec![b'a'; 64 * 1024];
    let mut sent = 0usize;
    while sent < 256 << 20 && endless.write_all(&chunk).is_ok() {
        sent += chunk.len();
    }
    let rss = rss_kib(viewer.id());
    let started = Instant::now();
    let status = get(addr, "/", Duration::from_secs(1));
    let took = started.elapsed();
    eprintln!(
        "viewer: {} held connections, endless header cut after {} KiB, RSS {} KiB, new client answered in {:?}",
        held.len(),
        sent / 1024,
        rss,
        took
    );
    assert!(
        sent < 64 << 20,
        "the endless header is cut off (sent {sent} bytes)"
    );
    assert!(
        status.as_ref().is_ok_and(|s| s.starts_with("HTTP/1.1 200")),
        "a new client is served: {status:?}"
    );
    assert!(took < Duration::from_secs(1), "within 1 s: {took:?}");
    assert!(viewer.try_wait().unwrap().is_none(), "the viewer runs on");
    drop(held);
    airglyph_system_tests::signal(&viewer, libc::SIGTERM);
    assert!(viewer.wait().unwrap().success());
}

/// Item 2: a viewer whose process lives on but no longer serves (tiny_http's accept
/// thread had ended; here the whole process is stopped, so its own watchdog cannot act
/// either) was never restarted: the supervisor only watched processes. It now asks
/// `/healthz` and starts a viewer that answers after three failures in a row.
#[test]
fn a_viewer_that_stops_serving_is_restarted_by_the_supervisor() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let addr = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let mut supervisor = p
        .command("airglyph")
        .args(["run", "--view", "--listen", &addr.to_string()])
        .args(["--source", "synthetic:poses"])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let serves = |within: Duration| {
        let deadline = Instant::now() + within;
        while !get(addr, "/healthz", Duration::from_secs(1)).is_ok_and(|s| s.contains(" 200")) {
            if Instant::now() > deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        true
    };
    assert!(serves(Duration::from_secs(30)), "the viewer serves");
    // The supervisor probes every 2 s and judges a viewer once it has seen it serve
    // (or 30 s after its start): let it see this one.
    std::thread::sleep(Duration::from_secs(3));
    let viewer = stage_children(supervisor.id(), "viewer");
    assert_eq!(viewer.len(), 1, "one viewer: {viewer:?}");
    // SAFETY: kill(2) on the viewer child just found.
    unsafe { libc::kill(viewer[0] as i32, libc::SIGSTOP) };
    // kill(2) returns before the process has stopped.
    while !std::fs::read_to_string(format!("/proc/{}/stat", viewer[0])).is_ok_and(|s| {
        s.rsplit_once(") ")
            .is_some_and(|(_, rest)| rest.starts_with('T'))
    }) {
        std::thread::sleep(Duration::from_millis(10));
    }
    let stopped = Instant::now();
    assert!(
        get(addr, "/healthz", Duration::from_secs(1)).is_err(),
        "a stopped viewer does not answer"
    );
    // Three probes two seconds apart, each waiting two seconds: about 8 s, and the
    // restart's backoff; a minute leaves room for a loaded machine.
    let deadline = Instant::now() + Duration::from_secs(60);
    let replaced = loop {
        let now = stage_children(supervisor.id(), "viewer");
        if now.len() == 1 && now[0] != viewer[0] {
            break now[0];
        }
        assert!(
            Instant::now() < deadline,
            "the stopped viewer was not replaced: {now:?}"
        );
        assert!(
            supervisor.try_wait().unwrap().is_none(),
            "the supervisor runs on"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(serves(Duration::from_secs(30)), "the new viewer serves");
    eprintln!(
        "viewer {} stopped, replaced by {replaced} and serving after {:?}",
        viewer[0],
        stopped.elapsed()
    );
    assert!(
        !Path::new(&format!("/proc/{}", viewer[0])).exists(),
        "the stopped viewer was killed and reaped"
    );
    let stats = top(&p);
    assert!(
        stats["stages"]["capture"]["fps"].as_f64().unwrap_or(0.0) > 20.0,
        "the pipeline ran on meanwhile: {stats}"
    );
    shut_down(&p, supervisor);
}

/// Item 7: only deaths within 2 s of a start counted towards a crash loop, so a stage
/// that died a little later each time was restarted for ever. Here capture fails 3 s
/// after each start (90 frames at 30 fps).
#[test]
fn a_stage_dying_seconds_after_each_start_is_given_up() {
    let p = Isolated::new();
    let started = Instant::now();
    let supervisor = p
        .command("airglyph")
        .args(["run", "--stages", "capture", "--source", "synthetic:poses"])
        .args(["--stage-args", "capture=--fail-after 90"])
        .args(["--max-restarts", "2", "--crash-window", "60"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Three runs of 3 s and two restarts are well within the window; the supervisor of
    // e857d26 restarted it for ever.
    let (ok, err) = ends_within(supervisor, Duration::from_secs(60), "airglyph run");
    eprintln!("given up after {:?}", started.elapsed());
    assert!(!ok, "the pipeline gives up: {err}");
    assert!(
        err.contains("stage capture died 3 times within 60 s") && err.contains("giving up"),
        "{err}"
    );
    assert!(
        err.contains("failing after 90 frames"),
        "the stage's own error is shown: {err}"
    );
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}

/// Item 7: a fresh-clone run of the suite left 29 files in /dev/shm: a test's pipeline
/// killed at its end kept what its processes had open.
#[test]
fn a_dropped_pipeline_leaves_nothing_in_dev_shm() {
    let p = Isolated::new();
    let prefix = p.prefix.clone();
    let mut supervisor = p
        .command("airglyph")
        .args(["run", "--source", "synthetic:poses"])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let stats = top(&p);
    assert!(
        stats["stages"]["capture"]["frames_out"].as_u64().is_some(),
        "{stats}"
    );
    assert!(!p.all_shm_files().is_empty(), "the pipeline has files");
    // Killed with the rest of the pipeline's processes, reaped here.
    drop(p);
    supervisor.wait().unwrap();
    let left: Vec<_> = std::fs::read_dir("/dev/shm")
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&prefix))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// Item 7: `top --json --wait 1e300` waited for ever when a stage did not report.
#[test]
fn top_refuses_a_wait_it_cannot_mean() {
    let p = Isolated::new();
    for wait in ["1e300", "NaN", "-1"] {
        let err = fail(
            p.command("airglyph")
                .args(["top", "--json", "--wait", wait]),
        );
        assert!(err.contains("--wait"), "{err}");
    }
}

/// Item 3: every numeric option that sizes memory or time is range-checked as it is
/// parsed: one line naming the option and the value, before anything is read or
/// started (`collect --count 10^18` made a script of that many symbols first; a
/// stage's option out of range given through `--stage-args` started a crash loop).
#[test]
fn numeric_options_out_of_range_are_refused_naming_the_option() {
    let p = Isolated::new();
    let cases: &[(&str, &[&str])] = &[
        (
            "--timeout",
            &["snapshot", "--out", "x.png", "--timeout", "inf"],
        ),
        ("--watch", &["snapshot", "--out", "x.png", "--watch", "1e9"]),
        ("--seconds", &["profile", "--out", "d", "--seconds", "0"]),
        ("--warmup", &["profile", "--out", "d", "--warmup", "NaN"]),
        (
            "--count",
            &[
                "collect",
                "--label",
                "a",
                "--out",
                "x",
                "--count",
                "1000000000000000000",
            ],
        ),
        (
            "--hidden",
            &[
                "train",
                "--data",
                "x",
                "--out",
                "y",
                "--hidden",
                "1000000000",
            ],
        ),
        (
            "--epochs",
            &["train", "--data", "x", "--out", "y", "--epochs", "0"],
        ),
        (
            "--ensemble",
            &["train", "--data", "x", "--out", "y", "--ensemble", "100000"],
        ),
        (
            "--folds",
            &[
                "eval-gestures",
                "--model",
                "m",
                "--data",
                "d",
                "--folds",
                "1",
            ],
        ),
        (
            "--seed-points",
            &[
                "eval-gestures",
                "--model",
                "m",
                "--data",
                "d",
                "--seed-points",
                "15,100000",
            ],
        ),
        (
            "--gestures",
            &[
                "eval-spotting",
                "--model",
                "m",
                "--data",
                "d",
                "--gestures",
                "1000000000000",
            ],
        ),
        (
            "--random-seconds",
            &[
                "eval-spotting",
                "--model",
                "m",
                "--data",
                "d",
                "--random-seconds",
                "1e30",
            ],
        ),
        (
            "--plot-seconds",
            &[
                "eval-spotting",
                "--model",
                "m",
                "--data",
                "d",
                "--plot-seconds",
                "-1",
            ],
        ),
        ("--fps", &["synth", "--out", "x", "--fps", "0"]),
        (
            "--max-fps",
            &["run", "--view", "--stage-args", "viewer=--max-fps NaN"],
        ),
        (
            "--delay-ms",
            &["run", "--stage-args", "gesture=--delay-ms 100000000"],
        ),
    ];
    for (option, args) in cases {
        let err = fail(p.command("airglyph").args(*args));
        let first = err.lines().next().unwrap_or_default();
        assert!(
            first.contains(option) && !err.contains("panicked"),
            "{args:?}: one line naming {option}: {err}"
        );
    }
    assert!(p.processes().is_empty(), "nothing was started");
}
