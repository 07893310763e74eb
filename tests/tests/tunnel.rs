//! Gesture events from one host's pipeline to another's through `airglyph-zenoh`: two
//! isolated pipelines (roots and prefixes of their own) stand for the two hosts, and a
//! TCP relay between them is the network, cut for longer than the exporter keeps events
//! and put back. Every event sent is received, or counted as lost by the importer:
//! nothing goes silently. And `airglyph run --export zenoh`: the pipeline with its
//! exporter as one command, whose gestures and stats reach `airglyph echo` on the other
//! side, also across a restart of the exporter.

use airglyph_ipc::clock::monotonic_ns;
use airglyph_system_tests::{json_lines, one_at_a_time, signal, start_probe, stop, Isolated};
use std::io::{Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// `airglyph-zenoh`, when it was built (`cargo build -p airglyph-zenoh`, a step of its
/// own in scripts/test: Zenoh is heavy to build); else None, the test saying it skips.
fn bridge() -> Option<PathBuf> {
    let path = std::env::current_exe()
        .ok()
        .and_then(|exe| Some(exe.parent()?.parent()?.join("airglyph-zenoh")))
        .filter(|path| path.exists());
    if path.is_none() {
        eprintln!("skipped: airglyph-zenoh is not built (cargo build -p airglyph-zenoh; scripts/test does)");
    }
    path
}

/// `airglyph-zenoh import --json` on `host` for `domain`, its connection `args`
/// (`--connect E` or `--listen E`), its stdout piped.
fn importer(host: &Isolated, bridge: &Path, domain: &str, args: &[&str]) -> Child {
    host.command_at(bridge)
        .args(["import", "--json", "--domain", domain])
        .args(args)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap()
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The network between the two hosts: a TCP relay to `to` that can be cut (every
/// connection closed, new ones refused) and put back.
struct Network {
    addr: SocketAddr,
    down: Arc<AtomicBool>,
    open: Arc<Mutex<Vec<TcpStream>>>,
}

impl Network {
    fn start(to: SocketAddr) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let down = Arc::new(AtomicBool::new(false));
        let open: Arc<Mutex<Vec<TcpStream>>> = Arc::default();
        let (d, o) = (down.clone(), open.clone());
        std::thread::spawn(move || {
            for client in listener.incoming().map_while(Result::ok) {
                let connected = if d.load(Ordering::SeqCst) {
                    Err(std::io::Error::other("the network is down"))
                } else {
                    TcpStream::connect(to)
                };
                let Ok(server) = connected else {
                    let _ = client.shutdown(Shutdown::Both);
                    continue;
                };
                let mut held = o.lock().unwrap();
                for (from, into) in [(&client, &server), (&server, &client)] {
                    let (mut from, mut into) =
                        (from.try_clone().unwrap(), into.try_clone().unwrap());
                    std::thread::spawn(move || {
                        let mut buf = [0u8; 16 * 1024];
                        while let Ok(n) = from.read(&mut buf) {
                            if n == 0 || into.write_all(&buf[..n]).is_err() {
                                break;
                            }
                        }
                        let _ = into.shutdown(Shutdown::Both);
                    });
                }
                held.extend([client, server]);
            }
        });
        Self { addr, down, open }
    }

    fn cut(&self) {
        self.down.store(true, Ordering::SeqCst);
        for s in self.open.lock().unwrap().drain(..) {
            let _ = s.shutdown(Shutdown::Both);
        }
    }

    fn restore(&self) {
        self.down.store(false, Ordering::SeqCst);
    }
}

/// How long the network is down.
const CUT: Duration = Duration::from_secs(5);

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

#[test]
fn gestures_cross_to_another_host_and_losses_are_counted() {
    // Alone: the other test here runs a whole pipeline, which would take the CPU from
    // this one's bursts.
    let _one = one_at_a_time();
    let Some(bridge) = bridge() else {
        return;
    };
    let (device, other) = (Isolated::new(), Isolated::new());
    let domain = format!("test{}", std::process::id());
    let port = free_port();
    let exporter_addr: SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
    let network = Network::start(exporter_addr);

    let exporter = device
        .command_at(&bridge)
        .args([
            "export",
            "--domain",
            &domain,
            "--listen",
            &format!("tcp/{exporter_addr}"),
        ])
        .spawn()
        .unwrap();
    let relay = format!("tcp/{}", network.addr);
    let mut importer = importer(&other, &bridge, &domain, &["--connect", &relay]);
    let reports = json_lines(importer.stdout.take().unwrap());
    let (receiver, received) = start_probe(&other, &["--stream", "gesture", "--idle", "60"]);
    // The two sessions find each other through the relay.
    std::thread::sleep(Duration::from_secs(3));

    let sent_n = 200u64;
    let (sender, sent) = start_probe(
        &device,
        &["--publish-gestures", &sent_n.to_string(), "--hz", "20"],
    );
    // 10 s of events; the link is cut from 3 s to 8 s in: 100 events sent meanwhile,
    // more than the exporter keeps (64), so some are lost for good and must be counted.
    let started = Instant::now();
    std::thread::sleep(Duration::from_secs(3));
    network.cut();
    let cut_ns = monotonic_ns();
    std::thread::sleep(CUT);
    network.restore();
    let restored_ns = monotonic_ns();
    let cut_for = started.elapsed();
    let mut publish_ns = std::collections::HashMap::new();
    while let Ok(line) = sent.recv_timeout(Duration::from_secs(15)) {
        publish_ns.insert(
            line["end_sequence"].as_u64().unwrap(),
            line["publish_ns"].as_u64().unwrap(),
        );
        if publish_ns.len() as u64 == sent_n {
            break;
        }
    }
    assert_eq!(
        publish_ns.len() as u64,
        sent_n,
        "the sender sent everything"
    );
    assert!(stop(sender).success());
    // Time for the importer to find and fetch what the cut lost.
    std::thread::sleep(Duration::from_secs(4));

    let mut got = Vec::new();
    while let Ok(g) = received.recv_timeout(Duration::from_millis(500)) {
        got.push(g);
    }
    stop(receiver);
    signal(&importer, libc::SIGTERM);
    assert!(
        importer.wait().unwrap().success(),
        "the importer stops cleanly"
    );
    let mut missed = 0;
    let mut totals = None;
    while let Ok(r) = reports.recv_timeout(Duration::from_secs(2)) {
        match (r["event"].as_str(), r["stream"].as_str()) {
            (Some("missed"), Some("gesture")) => missed += r["count"].as_u64().unwrap(),
            (Some("totals"), Some("gesture")) => totals = Some(r),
            _ => {}
        }
    }

    let mut seen = std::collections::HashSet::new();
    // Events sent while the link was up, and those sent while it was down (received, if
    // at all, when it came back).
    let (mut up_ms, mut down_ms) = (Vec::new(), Vec::new());
    for g in &got {
        let end = g["end_sequence"].as_u64().unwrap();
        assert!(seen.insert(end), "gesture {end} received twice");
        let sent_at = publish_ns[&end];
        let ms = g["receive_ns"].as_u64().unwrap().saturating_sub(sent_at) as f64 * 1e-6;
        if (cut_ns..restored_ns).contains(&sent_at) {
            down_ms.push(ms);
        } else {
            up_ms.push(ms);
        }
    }
    up_ms.sort_by(f64::total_cmp);
    down_ms.sort_by(f64::total_cmp);
    let received_n = seen.len() as u64;
    eprintln!(
        "tunnel: sent {sent_n}, received {received_n}, counted lost {missed}, link cut for {:.0} s \
         ({:.1} s into the run); sent while up: {} events, latency p50 {:.2} ms, p99 {:.2} ms; \
         sent while down: {} received after it came back, latency p50 {:.0} ms, max {:.0} ms; \
         importer {}",
        CUT.as_secs_f64(),
        cut_for.as_secs_f64() - CUT.as_secs_f64(),
        up_ms.len(),
        percentile(&up_ms, 0.5),
        percentile(&up_ms, 0.99),
        down_ms.len(),
        if down_ms.is_empty() { 0.0 } else { percentile(&down_ms, 0.5) },
        down_ms.last().copied().unwrap_or(0.0),
        totals.map_or("reported no totals".into(), |t| t.to_string()),
    );
    assert!(stop(exporter).success(), "the exporter stops cleanly");
    assert_eq!(
        received_n + missed,
        sent_n,
        "every event was received or counted as lost"
    );
    assert!(received_n > sent_n / 2, "most events crossed");
    assert!(
        missed > 0,
        "a cut longer than the exporter keeps loses events, and says so"
    );
}

/// A gesture's identity: the same session and frames twice would be one gesture twice.
fn identity(g: &serde_json::Value) -> (String, u64, u64, u64) {
    (
        g["label"].as_str().unwrap_or("?").to_owned(),
        g["session"].as_u64().unwrap_or(0),
        g["start_frame"].as_u64().unwrap_or(0),
        g["end_frame"].as_u64().unwrap_or(0),
    )
}

/// The pids of `airglyph-zenoh export` processes of pipeline `p`.
fn exporters(p: &Isolated) -> Vec<u32> {
    p.processes()
        .into_iter()
        .filter(|pid| {
            let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
            let args: Vec<&[u8]> = cmdline.split(|&b| b == 0).take(2).collect();
            args.len() == 2 && args[0].ends_with(b"airglyph-zenoh") && args[1] == b"export"
        })
        .collect()
}

#[test]
fn run_export_zenoh_carries_gestures_and_stats_to_another_host_across_a_restart() {
    let _one = one_at_a_time();
    let Some(bridge) = bridge() else {
        return;
    };
    let (device, other) = (Isolated::new(), Isolated::new());
    let domain = format!("run{}", std::process::id());
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());

    // The other host first: an importer that connects (and keeps trying until the
    // device listens), and `echo` reading what it republishes.
    let mut importer = importer(&other, &bridge, &domain, &["--connect", &endpoint]);
    let reports = json_lines(importer.stdout.take().unwrap());
    let mut gestures_echo = other
        .command("airglyph")
        .args(["echo", "gesture", "--json"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let heard = json_lines(gestures_echo.stdout.take().unwrap());
    let mut stats_echo = other
        .command("airglyph")
        .args(["echo", "stats", "--json", "--count", "2"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let stats = json_lines(stats_echo.stdout.take().unwrap());

    // The device: three symbols, the person's exact skeleton (no pose stage: less CPU),
    // and the exporter; the source runs out and the run ends by itself.
    let mut run = device
        .command("airglyph")
        .args(["run", "--source", "synthetic:draw:37L", "--truth", "--json"])
        .args(["--export", "zenoh", "--export-listen", &endpoint])
        .args(["--export-domain", &domain])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let printed = json_lines(run.stdout.take().unwrap());

    let first = heard
        .recv_timeout(Duration::from_secs(60))
        .expect("a gesture of the device heard on the other host");
    let stats: Vec<_> = (0..2)
        .map_while(|_| stats.recv_timeout(Duration::from_secs(5)).ok())
        .collect();
    let exporter = exporters(&device);
    assert_eq!(exporter.len(), 1, "one exporter: {exporter:?}");
    // The exporter dies: the supervisor starts it again, and the gestures after come
    // through the new one.
    // SAFETY: kill(2) on a process of this test's own pipeline.
    unsafe { libc::kill(exporter[0] as i32, libc::SIGKILL) };
    let deadline = Instant::now() + Duration::from_secs(5);
    let restarted = loop {
        let now = exporters(&device);
        if now.iter().any(|pid| !exporter.contains(pid)) {
            break now;
        }
        assert!(Instant::now() < deadline, "the exporter was not restarted");
        std::thread::sleep(Duration::from_millis(50));
    };

    let status = run.wait().unwrap();
    assert!(status.success(), "the run ends with its source: {status}");
    assert!(
        device.processes().is_empty(),
        "the exporter stops with the pipeline: {:?}",
        device.processes()
    );
    assert!(
        device.shm_files().is_empty(),
        "left behind: {:?}",
        device.shm_files()
    );
    // Until its end of file: the stages, which share its stdout, are gone too.
    let from_run: Vec<_> = printed
        .iter()
        .filter(|l| l["event"] == "gesture")
        .map(|g| identity(&g))
        .collect();
    let mut from_echo = vec![identity(&first)];
    while from_echo.len() < from_run.len() {
        match heard.recv_timeout(Duration::from_secs(5)) {
            Ok(g) => from_echo.push(identity(&g)),
            Err(_) => break,
        }
    }
    for child in [&stats_echo, &gestures_echo, &importer] {
        signal(child, libc::SIGTERM);
    }
    assert!(stats_echo.wait().unwrap().success());
    assert!(gestures_echo.wait().unwrap().success());
    assert!(
        importer.wait().unwrap().success(),
        "the importer stops cleanly"
    );
    let totals: Vec<_> = reports
        .try_iter()
        .filter(|r| r["event"] == "totals" && r["stream"] == "gesture")
        .collect();
    eprintln!(
        "run --export zenoh: the device printed {from_run:?}; the other host heard {from_echo:?}; \
         exporter {exporter:?} killed, then {restarted:?}; stats {}; importer {totals:?}",
        stats.first().map_or("none".into(), |s| s.to_string())
    );
    assert!(
        from_run.len() >= 2,
        "too few gestures to tell: {from_run:?}"
    );
    assert_eq!(
        from_echo, from_run,
        "every gesture the device printed reached the other host, once, in order"
    );
    assert_eq!(stats.len(), 2, "stats reached the other host: {stats:?}");
    assert!(stats
        .iter()
        .all(|s| s["event"] == "stats" && s.get("fps").is_some()));
}
