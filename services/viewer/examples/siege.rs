//! What a hostile client does to a running viewer, measured: `--held` connections
//! opened and left silent, one endless header line, then how fast new clients are
//! served, alone and `--parallel` at once, while the attack lasts.
//!
//! ```sh
//! airglyph run --view --source synthetic:poses &
//! cargo run --release -p airglyph-viewer --example siege -- --addr 127.0.0.1:8080
//! ```
//! The viewer's memory and the pipeline's frame rate are read beside it (`ps`, `airglyph
//! top`).

use clap::Parser;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

#[derive(Parser)]
struct Args {
    #[arg(long, default_value = "127.0.0.1:8080")]
    addr: SocketAddr,
    /// Connections opened and never used.
    #[arg(long, default_value_t = 1000)]
    held: usize,
    /// Requests sent at once, each on a connection of its own.
    #[arg(long, default_value_t = 200)]
    parallel: usize,
    /// Most bytes of the endless header to send.
    #[arg(long, default_value_t = 256 << 20)]
    endless: usize,
    /// How long to keep the attack up after measuring, seconds (to read the viewer's
    /// memory and the pipeline's rate meanwhile).
    #[arg(long, default_value_t = 0)]
    hold: u64,
}

fn get(addr: SocketAddr, path: &str) -> Result<Duration, String> {
    let t = Instant::now();
    let mut s =
        TcpStream::connect_timeout(&addr, Duration::from_secs(10)).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(10)))
        .map_err(|e| e.to_string())?;
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .map_err(|e| e.to_string())?;
    let mut reply = Vec::new();
    s.read_to_end(&mut reply).map_err(|e| e.to_string())?;
    if reply.starts_with(b"HTTP/1.1 200") {
        Ok(t.elapsed())
    } else {
        Err(String::from_utf8_lossy(&reply[..reply.len().min(40)]).into_owned())
    }
}

fn percentile(sorted: &[Duration], q: f64) -> Duration {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn main() {
    let args = Args::parse();
    // SAFETY: getrlimit/setrlimit(2) read and write only `lim`.
    unsafe {
        let mut lim = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim);
        lim.rlim_cur = lim.rlim_max.min(65536);
        libc::setrlimit(libc::RLIMIT_NOFILE, &lim);
    }
    let held: Vec<TcpStream> = (0..args.held)
        .filter_map(|_| TcpStream::connect(args.addr).ok())
        .collect();
    println!("held connections: {}", held.len());
    let mut endless = TcpStream::connect(args.addr).expect("connect");
    endless
        .set_write_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    let t = Instant::now();
    endless.write_all(b"GET / HTTP/1.1\r\nX-Endless: ").unwrap();
    let chunk = vec![b'a'; 64 * 1024];
    let mut sent = 0;
    let cut = loop {
        if sent >= args.endless {
            break None;
        }
        if let Err(e) = endless.write_all(&chunk) {
            break Some(e);
        }
        sent += chunk.len();
    };
    match cut {
        Some(e) => println!(
            "endless header: cut after {} KiB sent, {:?} ({e})",
            sent / 1024,
            t.elapsed()
        ),
        None => println!("endless header: {} MiB sent and still taken", sent >> 20),
    }
    let mut alone: Vec<Duration> = (0..20)
        .map(|_| get(args.addr, "/").unwrap_or(Duration::MAX))
        .collect();
    alone.sort();
    println!(
        "a new client alone, 20 times: p50 {:?}, max {:?}",
        percentile(&alone, 0.5),
        alone[alone.len() - 1]
    );
    let threads: Vec<_> = (0..args.parallel)
        .map(|i| {
            let addr = args.addr;
            let path = if i % 2 == 0 {
                "/"
            } else {
                "/frame.jpg?after=0"
            };
            std::thread::spawn(move || get(addr, path))
        })
        .collect();
    let results: Vec<_> = threads.into_iter().map(|t| t.join().unwrap()).collect();
    let failed = results.iter().filter(|r| r.is_err()).count();
    let mut why = std::collections::BTreeMap::new();
    for e in results.iter().filter_map(|r| r.as_ref().err()) {
        *why.entry(e.clone()).or_insert(0) += 1;
    }
    if !why.is_empty() {
        println!("failures: {why:?}");
    }
    let mut ok: Vec<Duration> = results.into_iter().filter_map(Result::ok).collect();
    ok.sort();
    if ok.is_empty() {
        println!("{} parallel requests: all failed", args.parallel);
    } else {
        println!(
            "{} parallel requests (page and picture): {} served, {failed} failed, p50 {:?}, p99 {:?}, max {:?}",
            args.parallel,
            ok.len(),
            percentile(&ok, 0.5),
            percentile(&ok, 0.99),
            ok[ok.len() - 1]
        );
    }
    if args.hold > 0 {
        println!("holding the attack for {} s", args.hold);
        std::thread::sleep(Duration::from_secs(args.hold));
    }
    drop(held);
}
