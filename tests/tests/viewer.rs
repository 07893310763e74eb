//! The viewer with real processes: `airglyph run --view` on a synthetic person drawing
//! symbols, headless Chromium on its page, `airglyph snapshot`, a frozen viewer that must
//! not slow capture, and a viewer that cannot start while the pipeline runs on.

use airglyph_system_tests::{
    json_lines, one_at_a_time, shut_down, stage_children, start_probe, stop, succeed, top, Isolated,
};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The viewer's colours for a joint it is sure of (see airglyph-viewer's render.rs).
const JOINT: [u8; 3] = [255, 0, 255];

/// A program on PATH (`names` in order), or the path in `env`.
fn program(env: &str, names: &[&str]) -> Option<PathBuf> {
    if let Some(p) = std::env::var_os(env) {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| names.iter().map(move |n| d.join(n)))
        .find(|p| p.exists())
}

fn free_addr() -> SocketAddr {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap()
}

/// A plain HTTP/1.1 request: status and body.
fn request(
    addr: SocketAddr,
    method: &str,
    path: &str,
    body: Option<&str>,
    timeout: Duration,
) -> std::io::Result<(u16, Vec<u8>)> {
    let mut s = TcpStream::connect_timeout(&addr, Duration::from_secs(2))?;
    s.set_read_timeout(Some(timeout))?;
    let body = body.unwrap_or("");
    write!(
        s,
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\
         Content-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )?;
    // Read the head, then the body by its Content-Length: ChromeDriver keeps the
    // connection open whatever the request says.
    let mut reader = BufReader::new(s);
    let mut head = Vec::new();
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line)? == 0 || line == "\r\n" {
            break;
        }
        head.push(line);
    }
    let status = head
        .first()
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|c| c.parse().ok())
        .ok_or_else(|| std::io::Error::other(format!("bad status line: {head:?}")))?;
    let length = head.iter().find_map(|l| {
        let (name, value) = l.split_once(':')?;
        name.eq_ignore_ascii_case("content-length")
            .then(|| value.trim().parse::<usize>().ok())
            .flatten()
    });
    let mut body = Vec::new();
    match length {
        Some(n) => {
            body.resize(n, 0);
            reader.read_exact(&mut body)?;
        }
        None => {
            reader.read_to_end(&mut body)?;
        }
    }
    Ok((status, body))
}

fn get(addr: SocketAddr, path: &str) -> std::io::Result<(u16, Vec<u8>)> {
    request(addr, "GET", path, None, Duration::from_secs(5))
}

fn state(addr: SocketAddr) -> Option<serde_json::Value> {
    match get(addr, "/state.json") {
        Ok((200, body)) => serde_json::from_slice(&body).ok(),
        _ => None,
    }
}

/// The viewer's state, asked again for up to 10 s: on a loaded machine (a Chromium that
/// hung and was killed, a full CI run beside it) one request can time out.
fn state_soon(addr: SocketAddr) -> serde_json::Value {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Some(s) = state(addr) {
            return s;
        }
        assert!(
            Instant::now() < deadline,
            "the viewer gave no state for 10 s"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// Headless Chromium driven by ChromeDriver (W3C WebDriver over HTTP), in real time.
///
/// Chromium's own `--dump-dom` / `--screenshot` need `--virtual-time-budget` to let the
/// page's script run first, and virtual time stands still while a request is pending:
/// with the page's endless polling of the viewer, about one run in fifteen never ended.
/// Through WebDriver the test reads the live page when it is ready instead.
struct Browser {
    driver: std::process::Child,
    addr: SocketAddr,
    /// Empty until the driver has given one (the struct exists first, so that Drop
    /// stops the driver whatever fails while starting).
    session: String,
    /// Chromium's profile, removed with the browser.
    profile: tempfile::TempDir,
}

impl Browser {
    fn start(chromium: &Path, chromedriver: &Path) -> Browser {
        let addr = free_addr();
        let driver = Command::new(chromedriver)
            .arg(format!("--port={}", addr.port()))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            // Its own process group, so that Chromium and its renderers go with it.
            .process_group(0)
            .spawn()
            .expect("start chromedriver");
        let profile = tempfile::tempdir().unwrap();
        let mut browser = Browser {
            driver,
            addr,
            session: String::new(),
            profile,
        };
        let deadline = Instant::now() + Duration::from_secs(20);
        while !matches!(get(addr, "/status"), Ok((200, _))) {
            assert!(Instant::now() < deadline, "chromedriver did not start");
            std::thread::sleep(Duration::from_millis(100));
        }
        let capabilities = serde_json::json!({"capabilities": {"alwaysMatch": {
            "goog:chromeOptions": {
                "binary": chromium,
                "args": [
                    "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    "--no-first-run", "--window-size=1200,700",
                    format!("--user-data-dir={}", browser.profile.path().display()),
                ],
            },
            "timeouts": {"pageLoad": 20_000},
        }}});
        let reply = browser.call("POST", "/session", Some(capabilities));
        browser.session = reply["sessionId"].as_str().expect("a session").to_owned();
        browser
    }

    /// One WebDriver command; its `value`.
    fn call(&self, method: &str, path: &str, body: Option<serde_json::Value>) -> serde_json::Value {
        let body = body.map(|b| b.to_string());
        let (status, reply) = request(
            self.addr,
            method,
            path,
            body.as_deref(),
            Duration::from_secs(30),
        )
        .unwrap_or_else(|e| panic!("chromedriver {method} {path}: {e}"));
        let reply: serde_json::Value = serde_json::from_slice(&reply).unwrap();
        assert_eq!(status, 200, "chromedriver {method} {path}: {reply}");
        reply["value"].clone()
    }

    fn open(&self, url: &str) {
        let path = format!("/session/{}/url", self.session);
        self.call("POST", &path, Some(serde_json::json!({ "url": url })));
    }

    /// The page's DOM as it is now, serialized.
    fn source(&self) -> String {
        let path = format!("/session/{}/source", self.session);
        self.call("GET", &path, None).as_str().unwrap().to_owned()
    }

    /// The page's DOM once `ready` holds for it (the page's script has filled it in from
    /// the viewer); panics with the last DOM after 20 s.
    fn source_when(&self, ready: impl Fn(&str) -> bool) -> String {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let dom = self.source();
            if ready(&dom) {
                return dom;
            }
            assert!(Instant::now() < deadline, "the page never got ready: {dom}");
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    fn screenshot(&self) -> image::RgbImage {
        use base64::Engine;
        let path = format!("/session/{}/screenshot", self.session);
        let png = base64::engine::general_purpose::STANDARD
            .decode(self.call("GET", &path, None).as_str().unwrap())
            .unwrap();
        image::load_from_memory(&png).unwrap().to_rgb8()
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let path = format!("/session/{}", self.session);
            let _ = request(self.addr, "DELETE", &path, None, Duration::from_secs(5));
        }
        // SAFETY: kill(2) on the process group of the driver this browser started.
        unsafe { libc::kill(-(self.driver.id() as i32), libc::SIGKILL) };
        let _ = self.driver.wait();
    }
}

/// Pixels within `tol` of `c` in every channel.
fn count_near(img: &image::RgbImage, c: [u8; 3], tol: u8) -> usize {
    img.pixels()
        .filter(|p| (0..3).all(|k| p[k].abs_diff(c[k]) <= tol))
        .count()
}

#[test]
fn the_page_shows_the_skeleton_and_a_recognized_gesture() {
    let (Some(chromium), Some(chromedriver)) = (
        program("AIRGLYPH_CHROMIUM", &["chromium", "chromium-browser"]),
        program("AIRGLYPH_CHROMEDRIVER", &["chromedriver"]),
    ) else {
        println!(
            "SKIPPED: chromium or chromedriver is not installed (scripts/setup installs them)"
        );
        return;
    };
    let _one = one_at_a_time();
    let p = Isolated::new();
    let addr = free_addr();
    let mut supervisor = p
        .command("airglyph")
        .args(["run", "--view", "--listen", &addr.to_string()])
        .args(["--source", "synthetic:draw:0123", "--loop", "--json"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let events = json_lines(supervisor.stdout.take().unwrap());

    // What the gesture stage published, as another subscriber (the supervisor) saw it.
    let event = events
        .recv_timeout(Duration::from_secs(60))
        .expect("a gesture is spotted within a minute");
    let label = event["label"].as_str().unwrap().to_owned();
    let score = format!("{:.2}", event["score"].as_f64().unwrap());
    let frames = format!("frames {}–{}", event["start_frame"], event["end_frame"]);
    let deadline = Instant::now() + Duration::from_secs(10);
    let seen = loop {
        let s = state(addr);
        if let Some(s) = s.filter(|s| {
            s["skeleton"]["person_found"] == true && !s["gestures"].as_array().unwrap().is_empty()
        }) {
            break s;
        }
        assert!(
            Instant::now() < deadline,
            "the viewer never showed a person and a gesture"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(seen["gestures"][0]["label"], label.as_str(), "{seen}");
    assert_eq!(
        seen["gestures"][0]["bezier_points"], 15,
        "the gesture event carries the model's Bezier points: {seen}"
    );

    // The trail is the gesture stage's: the newest hand point the viewer shows is, bit
    // for bit, the one the gesture stage's decision on that frame carried, as another
    // subscriber saw it (the viewer follows no hand of its own).
    let (probe, decisions) = start_probe(&p, &["--stream", "decision", "--idle", "30"]);
    let mut sent = std::collections::HashMap::new();
    let deadline = Instant::now() + Duration::from_secs(15);
    let (shown, point) = loop {
        while let Ok(d) = decisions.try_recv() {
            if !d["hand_point"].is_null() {
                sent.insert(d["sequence"].as_u64().unwrap(), d["hand_point"].clone());
            }
        }
        let newest = state_soon(addr)["recognizer"]["newest"].clone();
        if let Some(point) = newest["sequence"].as_u64().and_then(|s| sent.get(&s)) {
            break (newest, point.clone());
        }
        assert!(
            Instant::now() < deadline,
            "the viewer never showed a hand point the gesture stage sent: {newest}"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    stop(probe);
    assert_eq!(shown["at"], point, "{shown}");

    // The page as a browser renders it: its script filled in the panels from the viewer.
    let browser = Browser::start(&chromium, &chromedriver);
    browser.open(&format!("http://{addr}/"));
    let item = format!(
        r#"<li class="gesture" data-label="{label}"><span class="label">{label}</span> <span class="score">{score}</span> <span class="frames">{frames}</span>"#
    );
    let skeleton = r#"id="skeleton" data-person="true" data-joints="16""#;
    let picture = r#"src="blob:"#;
    let latency = r#"<tr data-stage="pose">"#;
    let dom = browser.source_when(|dom| {
        [skeleton, &item, picture, latency]
            .iter()
            .all(|s| dom.contains(s))
    });
    assert!(
        dom.contains("person found · 16 joints"),
        "the skeleton panel: {dom}"
    );
    assert!(dom.contains(r#"id="picture""#), "the picture: {dom}");

    // The picture itself, in the browser's screenshot: the skeleton's joints are there
    // (a colour the depth map never takes), over a colour-mapped depth image.
    let page = browser.screenshot();
    drop(browser);
    let shot = tempfile::tempdir().unwrap();
    let joints = count_near(&page, JOINT, 60);
    println!("{joints} joint-coloured pixels in the page's screenshot");
    assert!(
        joints > 150,
        "{joints} joint-coloured pixels in the page's screenshot"
    );

    // `airglyph snapshot`: the same renderer into a PNG, exact colours.
    let snap = shot.path().join("snapshot.png");
    let out = succeed(
        p.command("airglyph")
            .args(["snapshot", "--out", snap.to_str().unwrap()]),
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("with its skeleton"));
    let snap = image::open(&snap).unwrap().to_rgb8();
    assert_eq!(snap.dimensions(), (640, 480));
    let exact = count_near(&snap, JOINT, 0);
    println!("{exact} joint-coloured pixels in the snapshot");
    assert!(exact > 200, "{exact} joint-coloured pixels in the snapshot");

    // A frozen viewer (a browser that hangs it, a stopped process) holds nothing back:
    // capture and pose keep their rate, and the viewer catches up when it runs again.
    let viewer = stage_children(supervisor.id(), "viewer");
    assert_eq!(viewer.len(), 1, "one viewer child: {viewer:?}");
    let before = state_soon(addr)["viewer"]["frames_in"].as_u64().unwrap();
    // SAFETY: kill(2) on the viewer child we just found.
    unsafe { libc::kill(viewer[0] as i32, libc::SIGSTOP) };
    std::thread::sleep(Duration::from_secs(2));
    let stats = top(&p);
    // SAFETY: as above.
    unsafe { libc::kill(viewer[0] as i32, libc::SIGCONT) };
    let fps = |s: &str| stats["stages"][s]["fps"].as_f64().unwrap_or(0.0);
    assert!(
        fps("capture") > 27.0 && fps("pose") > 20.0,
        "with the viewer stopped: {stats}"
    );
    let deadline = Instant::now() + Duration::from_secs(5);
    while state(addr).and_then(|s| s["viewer"]["frames_in"].as_u64()) <= Some(before + 30) {
        assert!(Instant::now() < deadline, "the viewer did not resume");
        std::thread::sleep(Duration::from_millis(100));
    }
    shut_down(&p, supervisor);
}

/// A person holding an open hand before them at 2 m (a recording through the sensor
/// model): the state the viewer pushes names each hand's posture as the pose stage
/// classified it, and the page, in a browser, writes it in the skeleton panel.
#[test]
fn the_page_shows_each_hands_posture() {
    let (Some(chromium), Some(chromedriver)) = (
        program("AIRGLYPH_CHROMIUM", &["chromium", "chromium-browser"]),
        program("AIRGLYPH_CHROMEDRIVER", &["chromedriver"]),
    ) else {
        println!(
            "SKIPPED: chromium or chromedriver is not installed (scripts/setup installs them)"
        );
        return;
    };
    let _one = one_at_a_time();
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("open");
    succeed(
        p.command("airglyph")
            .args(["synth", "--motion", "pose:hands-in-front"])
            .args(["--hand-posture", "right=open"])
            .args(["--distance", "2", "--noise"])
            .args(["--frames", "60", "--out"])
            .arg(&rec),
    );
    let addr = free_addr();
    let supervisor = p
        .command("airglyph")
        .args(["run", "--view", "--listen", &addr.to_string()])
        .args(["--stages", "capture,pose", "--loop", "--source"])
        .arg(format!("recording:{}", rec.display()))
        .spawn()
        .unwrap();
    let labels = ["open", "fist", "point", "thumb-up", "v", "pinch"];
    let deadline = Instant::now() + Duration::from_secs(30);
    let right = loop {
        let s = state_soon(addr);
        let r = &s["skeleton"]["postures"]["right"];
        if let Some(label) = r["label"].as_str() {
            assert!(labels.contains(&label), "{s}");
            let c = r["confidence"].as_f64().unwrap();
            assert!(c > 0.0 && c <= 1.0, "{s}");
            break label.to_owned();
        }
        assert!(
            Instant::now() < deadline,
            "the viewer never showed the right hand's posture: {s}"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    println!("the viewer's state: the right hand holds {right}");

    let browser = Browser::start(&chromium, &chromedriver);
    browser.open(&format!("http://{addr}/"));
    let shown = |dom: &str| -> Option<String> {
        let at = dom.find("id=\"postures\"")?;
        let tag = &dom[dom[..at].rfind('<')?..];
        let tag = &tag[..tag.find('>')?];
        let label = tag.split("data-right=\"").nth(1)?.split('"').next()?;
        (!label.is_empty()).then(|| label.to_owned())
    };
    let dom = browser.source_when(|dom| shown(dom).is_some());
    drop(browser);
    let label = shown(&dom).unwrap();
    assert!(labels.contains(&label.as_str()), "{dom}");
    assert!(
        dom.contains(&format!("right hand {label} ")),
        "the panel writes the label it marks: {dom}"
    );
    shut_down(&p, supervisor);
}

#[test]
fn a_viewer_that_cannot_listen_is_given_up_and_the_pipeline_runs_on() {
    let _one = one_at_a_time();
    let p = Isolated::new();
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap();
    let mut supervisor = p
        .command("airglyph")
        .args(["run", "--view", "--listen", &addr.to_string()])
        .args(["--source", "synthetic:poses", "--max-restarts", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let err = supervisor.stderr.take().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let deadline = Instant::now() + Duration::from_secs(15);
    let mut log = Vec::new();
    while !log
        .iter()
        .any(|l: &String| l.contains("giving it up") && l.contains("viewer"))
    {
        let left = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok(line) => log.push(line),
            Err(_) => panic!("the viewer was not given up: {log:#?}"),
        }
    }
    assert!(
        log.iter().any(|l| l.contains("cannot serve the viewer on")),
        "the viewer said why: {log:#?}"
    );
    assert!(
        supervisor.try_wait().unwrap().is_none(),
        "the pipeline runs on"
    );
    let stats = top(&p);
    assert!(
        stats["stages"]["capture"]["fps"].as_f64().unwrap_or(0.0) > 20.0,
        "{stats}"
    );
    assert!(stage_children(supervisor.id(), "viewer").is_empty());
    drop(taken);
    shut_down(&p, supervisor);
}

#[test]
fn a_snapshot_without_a_pipeline_fails_clearly_and_soon() {
    let p = Isolated::new();
    let dir = tempfile::tempdir().unwrap();
    let out_png = dir.path().join("none.png");
    let t = Instant::now();
    let out = p
        .command("airglyph")
        .args([
            "snapshot",
            "--timeout",
            "1",
            "--out",
            out_png.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no depth frame within 1.0 s") && err.contains("airglyph run"),
        "{err}"
    );
    assert!(!out_png.exists());
    assert!(p.shm_files().is_empty(), "left behind: {:?}", p.shm_files());
}
