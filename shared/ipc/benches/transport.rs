//! Transport benchmark between two real processes: airglyph's iceoryx2 ports against the
//! same bytes through a Unix domain socket, side by side in one run.
//!
//! `scripts/bench transport` (or `cargo bench -p airglyph-ipc --bench transport`). The
//! binary re-executes itself as the receiving process. One-way latency is the receiver's
//! CLOCK_MONOTONIC at receipt minus the sender's just before sending.

use airglyph_core::Intrinsics;
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::{IpcConfig, Pipeline, SkeletonMsg};
use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::process::{Command, Stdio};
use std::time::Duration;

const ROLE: &str = "AIRGLYPH_BENCH_ROLE";

#[derive(Clone, Copy, Debug)]
enum Payload {
    Depth,
    Skeleton,
}

impl Payload {
    fn bytes(self) -> usize {
        match self {
            Payload::Depth => 640 * 480 * 2,
            Payload::Skeleton => std::mem::size_of::<SkeletonMsg>(),
        }
    }
}

struct Scenario {
    payload: Payload,
    /// Messages a second, or `None` for as fast as possible.
    rate: Option<f64>,
    messages: usize,
}

fn percentile(sorted: &[u64], q: f64) -> u64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// What the receiving process reports.
struct Report {
    received: usize,
    median_us: f64,
    p99_us: f64,
    per_second: f64,
}

fn report(mut latencies: Vec<u64>, first_ns: u64, last_ns: u64) -> String {
    latencies.sort_unstable();
    let n = latencies.len();
    let span = (last_ns - first_ns) as f64 * 1e-9;
    serde_json::json!({
        "received": n,
        "median_us": percentile(&latencies, 0.5) as f64 / 1e3,
        "p99_us": percentile(&latencies, 0.99) as f64 / 1e3,
        "per_second": if n > 1 && span > 0.0 { (n - 1) as f64 / span } else { 0.0 },
    })
    .to_string()
}

fn parse_report(line: &str) -> Report {
    let v: serde_json::Value = serde_json::from_str(line).expect("receiver report");
    Report {
        received: v["received"].as_u64().unwrap() as usize,
        median_us: v["median_us"].as_f64().unwrap(),
        p99_us: v["p99_us"].as_f64().unwrap(),
        per_second: v["per_second"].as_f64().unwrap(),
    }
}

fn pace(start: u64, i: usize, rate: Option<f64>) {
    if let Some(rate) = rate {
        let due = start + (i as f64 * 1e9 / rate) as u64;
        let now = monotonic_ns();
        if due > now {
            std::thread::sleep(Duration::from_nanos(due - now));
        }
    }
}

fn ipc_config() -> IpcConfig {
    IpcConfig {
        root: format!(
            "/tmp/airglyph-bench-{}/",
            std::env::var("AIRGLYPH_BENCH_ID").unwrap()
        ),
        prefix: format!("agbench{}_", std::env::var("AIRGLYPH_BENCH_ID").unwrap()),
    }
}

// ---- receiving process ----

fn receive_iceoryx2(payload: Payload, messages: usize) {
    let pipeline = Pipeline::join_with(ipc_config(), "bench-rx").unwrap();
    let mut lat = Vec::with_capacity(messages);
    let (mut first, mut last) = (0, 0);
    let ready = || {
        println!("ready");
        std::io::stdout().flush().unwrap();
    };
    let idle = Duration::from_secs(3);
    match payload {
        Payload::Depth => {
            let mut rx = pipeline.depth_receiver().unwrap();
            ready();
            while let Some(f) = rx.recv(idle).unwrap() {
                let now = monotonic_ns();
                lat.push(now - f.header().publish_ns);
                first = if first == 0 { now } else { first };
                last = now;
                if f.header().sequence as usize + 1 == messages {
                    break;
                }
            }
        }
        Payload::Skeleton => {
            let mut rx = pipeline.skeleton_receiver().unwrap();
            ready();
            while let Some(r) = rx.recv(idle).unwrap() {
                let now = monotonic_ns();
                lat.push(now - r.msg.chain.pose_publish_ns);
                first = if first == 0 { now } else { first };
                last = now;
                if r.msg.sequence as usize + 1 == messages {
                    break;
                }
            }
        }
    }
    println!("{}", report(lat, first, last));
}

fn receive_socket(path: &str, payload: Payload, messages: usize) {
    let listener = UnixListener::bind(path).unwrap();
    println!("ready");
    std::io::stdout().flush().unwrap();
    let (mut stream, _) = listener.accept().unwrap();
    let mut buf = vec![0u8; 16 + payload.bytes()];
    let mut lat = Vec::with_capacity(messages);
    let (mut first, mut last) = (0, 0);
    for _ in 0..messages {
        if stream.read_exact(&mut buf).is_err() {
            break;
        }
        let now = monotonic_ns();
        let sent = u64::from_ne_bytes(buf[..8].try_into().unwrap());
        lat.push(now - sent);
        first = if first == 0 { now } else { first };
        last = now;
    }
    println!("{}", report(lat, first, last));
}

// ---- sending process ----

fn spawn_receiver(
    transport: &str,
    s: &Scenario,
    socket: &str,
) -> (std::process::Child, impl BufRead) {
    let mut child = Command::new(std::env::current_exe().unwrap())
        .env(
            ROLE,
            format!("{transport}:{:?}:{}:{socket}", s.payload, s.messages),
        )
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    assert_eq!(line.trim(), "ready");
    (child, out)
}

fn finish(mut child: std::process::Child, mut out: impl BufRead) -> Report {
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    child.wait().unwrap();
    parse_report(&line)
}

fn send_iceoryx2(s: &Scenario) -> Report {
    let pipeline = Pipeline::join_with(ipc_config(), "bench-tx").unwrap();
    let k = Intrinsics::new(640, 480, 575.8, 575.8, 319.5, 239.5);
    let mut depth = pipeline.depth_publisher(640 * 480).unwrap();
    let skeletons = pipeline.skeleton_publisher().unwrap();
    let (child, out) = spawn_receiver("iceoryx2", s, "");
    std::thread::sleep(Duration::from_millis(200));
    let start = monotonic_ns();
    for i in 0..s.messages {
        pace(start, i, s.rate);
        match s.payload {
            Payload::Depth => {
                depth
                    .publish::<()>(640 * 480, |h, px| {
                        // The camera writes the frame into shared memory.
                        px.iter_mut()
                            .enumerate()
                            .for_each(|(j, p)| *p = (i + j) as u16);
                        h.set_intrinsics(&k);
                        Ok(true)
                    })
                    .unwrap();
            }
            Payload::Skeleton => {
                let mut m = SkeletonMsg {
                    sequence: i as u64,
                    ..Default::default()
                };
                m.chain.capture_ns = monotonic_ns();
                m.chain.capture_publish_ns = m.chain.capture_ns;
                m.chain.pose_receive_ns = m.chain.capture_ns;
                m.chain.pose_publish_ns = monotonic_ns();
                skeletons.send(m).unwrap();
            }
        }
    }
    finish(child, out)
}

fn send_socket(s: &Scenario) -> Report {
    let path = format!("/tmp/airglyph-bench-{}.sock", std::process::id());
    let _ = std::fs::remove_file(&path);
    let (child, out) = spawn_receiver("socket", s, &path);
    let mut stream = UnixStream::connect(&path).unwrap();
    let mut buf = vec![0u8; 16 + s.payload.bytes()];
    let start = monotonic_ns();
    for i in 0..s.messages {
        pace(start, i, s.rate);
        // The same frame written into the sender's buffer, then through the socket.
        for (j, px) in buf[16..].chunks_exact_mut(2).enumerate() {
            px.copy_from_slice(&((i + j) as u16).to_ne_bytes());
        }
        buf[..8].copy_from_slice(&monotonic_ns().to_ne_bytes());
        stream.write_all(&buf).unwrap();
    }
    let r = finish(child, out);
    let _ = std::fs::remove_file(&path);
    r
}

fn main() {
    if let Ok(role) = std::env::var(ROLE) {
        let parts: Vec<&str> = role.splitn(4, ':').collect();
        let payload = if parts[1] == "Depth" {
            Payload::Depth
        } else {
            Payload::Skeleton
        };
        let messages: usize = parts[2].parse().unwrap();
        match parts[0] {
            "iceoryx2" => receive_iceoryx2(payload, messages),
            _ => receive_socket(parts[3], payload, messages),
        }
        return;
    }
    std::env::set_var("AIRGLYPH_BENCH_ID", std::process::id().to_string());
    let scenarios = [
        Scenario {
            payload: Payload::Depth,
            rate: Some(30.0),
            messages: 150,
        },
        Scenario {
            payload: Payload::Depth,
            rate: None,
            messages: 2000,
        },
        Scenario {
            payload: Payload::Skeleton,
            rate: Some(30.0),
            messages: 150,
        },
        Scenario {
            payload: Payload::Skeleton,
            rate: None,
            messages: 20000,
        },
    ];
    println!(
        "{:<28} {:<10} {:>9} {:>12} {:>12} {:>12}",
        "scenario", "transport", "received", "median µs", "p99 µs", "msgs/s"
    );
    for s in &scenarios {
        let name = format!(
            "{} @ {}",
            match s.payload {
                Payload::Depth => "depth 640x480 u16",
                Payload::Skeleton => "skeleton message",
            },
            s.rate.map_or("full rate".to_owned(), |r| format!("{r} Hz"))
        );
        let iox = send_iceoryx2(s);
        let uds = send_socket(s);
        for (t, r) in [("iceoryx2", &iox), ("unix sock", &uds)] {
            println!(
                "{:<28} {:<10} {:>9} {:>12.1} {:>12.1} {:>12.0}",
                name, t, r.received, r.median_us, r.p99_us, r.per_second
            );
        }
        println!(
            "{:<28} median iceoryx2/socket = {:.2}",
            "",
            iox.median_us / uds.median_us
        );
    }
}
