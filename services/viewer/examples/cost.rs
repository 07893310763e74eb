//! What watching costs the pipeline: its frame rate with the viewer and a headless
//! Chromium open on the page, against without, on the synthetic person at 640×480 and
//! 30 fps; several alternating runs, medians.
//!
//! ```sh
//! cargo build --release -p airglyph
//! cargo run --release -p airglyph-viewer --example cost -- --runs 5 --seconds 20
//! ```
//! `--fast` lets capture run as fast as it can, so the pipeline is CPU-bound and any
//! cycle the viewer or the browser takes shows in its frame rate. Run it on an otherwise
//! idle machine: other work moves the figures more than the viewer does.

use airglyph_system_tests::{binary_path, median, profile_report, stage_children, stop};
use anyhow::{bail, Context};
use clap::Parser;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[derive(Parser)]
struct Args {
    /// Runs of each kind (without and with the viewer), alternating.
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Seconds measured per run (after a warm-up).
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// Seconds to let the pipeline settle first.
    #[arg(long, default_value_t = 5.0)]
    warmup: f64,
    /// The capture source.
    #[arg(long, default_value = "synthetic")]
    source: String,
    /// The browser.
    #[arg(long, default_value = "chromium")]
    chromium: String,
    /// Capture as fast as it can instead of at 30 fps: the pipeline is then CPU-bound,
    /// and every cycle the viewer and the browser take shows in its frame rate.
    #[arg(long)]
    fast: bool,
}

/// One run's figures.
#[derive(Debug, Default, Clone, Copy)]
struct Run {
    capture_fps: f64,
    pose_fps: f64,
    gesture_fps: f64,
    pose_dropped: u64,
    /// Pictures the browser took per second, and the viewer's share of one core.
    pictures_per_s: f64,
    viewer_cpu: f64,
}

fn get(addr: SocketAddr, path: &str) -> anyhow::Result<serde_json::Value> {
    let mut s = TcpStream::connect_timeout(&addr, Duration::from_secs(2))?;
    s.set_read_timeout(Some(Duration::from_secs(5)))?;
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )?;
    let mut raw = String::new();
    s.read_to_string(&mut raw)?;
    let body = raw.split_once("\r\n\r\n").context("no body")?.1;
    Ok(serde_json::from_str(body)?)
}

/// CPU seconds a process has used (utime + stime from /proc).
fn cpu_seconds(pid: u32) -> f64 {
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return 0.0;
    };
    let Some(close) = stat.rfind(')') else {
        return 0.0;
    };
    let fields: Vec<&str> = stat[close + 2..].split(' ').collect();
    // Fields 14 and 15 of stat(5) (utime, stime), counted from after the command name.
    let ticks: f64 =
        fields[11].parse::<f64>().unwrap_or(0.0) + fields[12].parse::<f64>().unwrap_or(0.0);
    // SAFETY: sysconf has no memory effects.
    ticks / unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64
}

/// The pid of the supervisor's child running `name`.
fn one_run(args: &Args, view: bool, n: usize) -> anyhow::Result<Run> {
    let root = std::env::temp_dir().join(format!("airglyph-cost-{}-{n}/", std::process::id()));
    let prefix = format!("agcost{}x{n}_", std::process::id());
    let env = |c: &mut Command| {
        c.env("AIRGLYPH_IPC_ROOT", &root)
            .env("AIRGLYPH_IPC_PREFIX", &prefix)
            .env("RUST_LOG", "warn");
    };
    let addr = TcpListener::bind("127.0.0.1:0")?.local_addr()?;
    let mut run = Command::new(binary_path("airglyph"));
    run.args(["run", "--source", &args.source]);
    if args.fast {
        run.arg("--fast");
    }
    if view {
        run.args(["--view", "--listen", &addr.to_string()]);
    }
    env(&mut run);
    let supervisor = run.stdout(Stdio::null()).spawn()?;
    let mut browser = None;
    let profile = tempfile_dir(n)?;
    if view {
        let deadline = Instant::now() + Duration::from_secs(10);
        while get(addr, "/state.json").is_err() {
            if Instant::now() > deadline {
                bail!("the viewer did not come up");
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        // A browser with the page open for the whole run, pulling pictures in real time.
        browser = Some(
            Command::new(&args.chromium)
                .args([
                    "--headless",
                    "--no-sandbox",
                    "--disable-gpu",
                    "--no-first-run",
                ])
                .args(["--remote-debugging-port=0", "--window-size=1200,700"])
                .arg(format!("--user-data-dir={}", profile.display()))
                .arg(format!("http://{addr}/"))
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .context("cannot start chromium")?,
        );
    }
    std::thread::sleep(Duration::from_secs_f64(args.warmup));
    let viewer = if view {
        stage_children(supervisor.id(), "viewer").first().copied()
    } else {
        None
    };
    let pictures0 = view
        .then(|| get(addr, "/state.json").ok())
        .flatten()
        .and_then(|s| s["viewer"]["pictures"].as_u64())
        .unwrap_or(0);
    let cpu0 = viewer.map_or(0.0, cpu_seconds);
    let profiled = profile_report(env, args.seconds);
    let cpu = viewer.map_or(0.0, cpu_seconds) - cpu0;
    let pictures1 = view
        .then(|| get(addr, "/state.json").ok())
        .flatten()
        .and_then(|s| s["viewer"]["pictures"].as_u64())
        .unwrap_or(0);
    if let Some(b) = browser {
        stop(b);
    }
    stop(supervisor);
    let _ = std::fs::remove_dir_all(&profile);
    let (report, took) = profiled?;
    let elapsed = took.as_secs_f64();
    let st = &report["stages"];
    let fps = |s: &str| st[s]["fps"].as_f64().unwrap_or(0.0);
    Ok(Run {
        capture_fps: fps("capture"),
        pose_fps: fps("pose"),
        gesture_fps: fps("gesture"),
        pose_dropped: st["pose"]["frames_dropped"].as_u64().unwrap_or(0),
        pictures_per_s: pictures1.saturating_sub(pictures0) as f64 / elapsed,
        viewer_cpu: cpu / elapsed,
    })
}

fn tempfile_dir(n: usize) -> anyhow::Result<PathBuf> {
    let d = std::env::temp_dir().join(format!("airglyph-cost-browser-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&d)?;
    Ok(d)
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let (mut without, mut with) = (Vec::new(), Vec::new());
    for i in 0..args.runs {
        for view in [false, true] {
            let r = one_run(&args, view, i * 2 + view as usize)?;
            println!(
                "run {} {:<14} capture {:5.2}  pose {:5.2}  gesture {:5.2} fps  pose dropped {:4}  browser {:4.1} pictures/s  viewer {:4.1} % of a core",
                i + 1,
                if view { "viewer+browser" } else { "no viewer" },
                r.capture_fps,
                r.pose_fps,
                r.gesture_fps,
                r.pose_dropped,
                r.pictures_per_s,
                r.viewer_cpu * 100.0
            );
            if view {
                with.push(r)
            } else {
                without.push(r)
            }
        }
    }
    let m = |v: &[Run], f: fn(&Run) -> f64| median(v.iter().map(f).collect());
    for (name, f) in [
        ("capture", (|r: &Run| r.capture_fps) as fn(&Run) -> f64),
        ("pose", |r: &Run| r.pose_fps),
        ("gesture", |r: &Run| r.gesture_fps),
    ] {
        let (a, b) = (m(&without, f), m(&with, f));
        println!(
            "median {name:<8} fps: {a:6.2} without, {b:6.2} with viewer and browser ({:+.1} %)",
            (b / a - 1.0) * 100.0
        );
    }
    println!(
        "viewer: median {:.1} pictures/s to the browser, {:.1} % of one core",
        m(&with, |r| r.pictures_per_s),
        m(&with, |r| r.viewer_cpu) * 100.0
    );
    Ok(())
}
