//! What the push stream costs the pipeline: its frame rate with N clients on `/events`
//! (each taking every skeleton, the page's state and the gestures, and reading all of
//! it) against none, the viewer running in both; alternating runs, medians.
//!
//! ```sh
//! cargo build --release -p airglyph
//! cargo run --release -p airglyph-viewer --example push_bench -- --clients 10 --runs 3 --seconds 15
//! ```
//! `--fast` lets capture run as fast as it can, so any cycle the clients take shows.

use airglyph_system_tests::{binary_path, median, profile_report, stop};
use anyhow::{bail, Context};
use clap::Parser;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(Parser)]
struct Args {
    /// Push clients in the runs with clients.
    #[arg(long, default_value_t = 10)]
    clients: usize,
    /// Runs of each kind, alternating.
    #[arg(long, default_value_t = 3)]
    runs: usize,
    /// Seconds measured per run (after the warm-up).
    #[arg(long, default_value_t = 15.0)]
    seconds: f64,
    #[arg(long, default_value_t = 5.0)]
    warmup: f64,
    /// Capture as fast as it can instead of at 30 fps.
    #[arg(long)]
    fast: bool,
}

#[derive(Debug, Default, Clone, Copy)]
struct Run {
    capture_fps: f64,
    pose_fps: f64,
    gesture_fps: f64,
    /// Bytes a second each client read, on average.
    client_bytes_per_s: f64,
}

/// A client that asks for everything and reads it all, counting bytes, until `done`.
fn client(addr: SocketAddr, bytes: Arc<AtomicU64>, done: Arc<AtomicBool>) -> anyhow::Result<()> {
    let mut s = TcpStream::connect(addr)?;
    s.set_read_timeout(Some(Duration::from_millis(200)))?;
    write!(
        s,
        "GET /events?skeletons=60&state=60 HTTP/1.1\r\nHost: {addr}\r\n\r\n"
    )?;
    let mut buf = [0u8; 16 * 1024];
    while !done.load(Ordering::Relaxed) {
        match s.read(&mut buf) {
            Ok(0) => bail!("the viewer closed the stream"),
            Ok(n) => {
                bytes.fetch_add(n as u64, Ordering::Relaxed);
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(e) => return Err(e.into()),
        }
    }
    Ok(())
}

fn one_run(args: &Args, clients: usize, n: usize) -> anyhow::Result<Run> {
    let root = std::env::temp_dir().join(format!("airglyph-push-{}-{n}/", std::process::id()));
    let prefix = format!("agpush{}x{n}_", std::process::id());
    let env = |c: &mut Command| {
        c.env("AIRGLYPH_IPC_ROOT", &root)
            .env("AIRGLYPH_IPC_PREFIX", &prefix)
            .env("RUST_LOG", "warn");
    };
    let addr = TcpListener::bind("127.0.0.1:0")?.local_addr()?;
    let mut run = Command::new(binary_path("airglyph"));
    run.args([
        "run",
        "--source",
        "synthetic:draw:0123456789",
        "--loop",
        "--view",
    ])
    .args(["--listen", &addr.to_string()]);
    if args.fast {
        run.arg("--fast");
    }
    env(&mut run);
    let supervisor = run.stdout(Stdio::null()).spawn()?;
    let deadline = Instant::now() + Duration::from_secs(10);
    while TcpStream::connect(addr).is_err() {
        if Instant::now() > deadline {
            bail!("the viewer did not come up");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let bytes = Arc::new(AtomicU64::new(0));
    let done = Arc::new(AtomicBool::new(false));
    let threads: Vec<_> = (0..clients)
        .map(|_| {
            let (bytes, done) = (bytes.clone(), done.clone());
            std::thread::spawn(move || client(addr, bytes, done))
        })
        .collect();
    std::thread::sleep(Duration::from_secs_f64(args.warmup));
    let b0 = bytes.load(Ordering::Relaxed);
    let profiled = profile_report(env, args.seconds);
    let read = bytes.load(Ordering::Relaxed) - b0;
    done.store(true, Ordering::Relaxed);
    for t in threads {
        t.join()
            .expect("a client thread")
            .context("a push client")?;
    }
    stop(supervisor);
    let _ = std::fs::remove_dir_all(&root);
    let (report, took) = profiled?;
    let elapsed = took.as_secs_f64();
    let fps = |s: &str| report["stages"][s]["fps"].as_f64().unwrap_or(0.0);
    Ok(Run {
        capture_fps: fps("capture"),
        pose_fps: fps("pose"),
        gesture_fps: fps("gesture"),
        client_bytes_per_s: if clients > 0 {
            read as f64 / elapsed / clients as f64
        } else {
            0.0
        },
    })
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let (mut none, mut some) = (Vec::new(), Vec::new());
    for i in 0..args.runs {
        for clients in [0, args.clients] {
            let r = one_run(&args, clients, 2 * i + usize::from(clients > 0))?;
            eprintln!("run {i}, {clients} clients: {r:?}");
            if clients == 0 { &mut none } else { &mut some }.push(r);
        }
    }
    println!("| median fps | capture | pose | gesture |");
    println!("|---|---|---|---|");
    let row = |name: &str, runs: &[Run]| {
        let m = |f: fn(&Run) -> f64| median(runs.iter().map(f).collect());
        let v = (
            m(|r| r.capture_fps),
            m(|r| r.pose_fps),
            m(|r| r.gesture_fps),
        );
        println!("| {name} | {:.2} | {:.2} | {:.2} |", v.0, v.1, v.2);
        v
    };
    let a = row("no push client", &none);
    let b = row(&format!("{} push clients", args.clients), &some);
    let d = |x: f64, y: f64| 100.0 * (y - x) / x;
    println!(
        "| difference | {:+.1} % | {:+.1} % | {:+.1} % |",
        d(a.0, b.0),
        d(a.1, b.1),
        d(a.2, b.2)
    );
    println!(
        "each client read {:.0} KB/s",
        median(some.iter().map(|r| r.client_bytes_per_s).collect()) / 1e3
    );
    Ok(())
}
