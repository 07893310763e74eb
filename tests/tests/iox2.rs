//! iceoryx2's own tools see a running pipeline through the configuration
//! `airglyph echo iceoryx2-config` prints, put where iceoryx2 looks for one.

use airglyph_system_tests::{one_at_a_time, shut_down, succeed, top, Isolated};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// `iox2` of iceoryx2-cli 0.10, as scripts/test installs it (`target/iox2`), or on PATH.
fn iox2_dir() -> Option<PathBuf> {
    let installed = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/iox2/bin");
    if installed.join("iox2").exists() {
        return Some(installed);
    }
    std::env::split_paths(&std::env::var_os("PATH")?).find(|d| d.join("iox2-service").exists())
}

#[test]
fn iox2_lists_the_pipelines_services_and_measures_their_rate() {
    let Some(bin) = iox2_dir() else {
        eprintln!("skipped: iox2 is not installed (cargo install --locked iceoryx2-cli@0.10.0; scripts/test does, into target/iox2)");
        return;
    };
    let _one = one_at_a_time();
    let p = Isolated::new();
    let run = p
        .command("airglyph")
        .args(["run", "--source", "synthetic", "--truth"])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    assert!(top(&p)["stages"]["gesture"]["fps"].as_f64().unwrap_or(0.0) > 0.0);
    // A folder of iceoryx2's "project local" configuration: config/iceoryx2.toml.
    let here = tempfile::tempdir().unwrap();
    std::fs::create_dir(here.path().join("config")).unwrap();
    let toml = succeed(p.command("airglyph").args(["echo", "iceoryx2-config"])).stdout;
    std::fs::write(here.path().join("config/iceoryx2.toml"), toml).unwrap();
    let path = std::env::join_paths(std::iter::once(bin.clone()).chain(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    )))
    .unwrap();
    let iox2 = |args: &[&str]| {
        let mut c = Command::new(bin.join("iox2"));
        c.args(args).current_dir(here.path()).env("PATH", &path);
        c
    };

    let list = succeed(&mut iox2(&["service", "list"]));
    let list = String::from_utf8_lossy(&list.stdout);
    for service in [
        "airglyph/depth",
        "airglyph/skeleton",
        "airglyph/gesture",
        "airglyph/decision",
    ] {
        assert!(
            list.contains(&format!("PublishSubscribe(\"{service}\")")),
            "{service} in {list}"
        );
    }

    // The decisions come one a frame: about capture's 30 a second.
    let mut hz = iox2(&["service", "hz", "airglyph/decision"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let lines = BufReader::new(hz.stdout.take().unwrap()).lines();
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut rates = Vec::new();
    for line in lines.map_while(Result::ok) {
        if let Some(v) = line.trim().strip_prefix("rate_hz:") {
            rates.push(v.trim().trim_end_matches(',').parse::<f64>().unwrap());
        }
        if rates.len() >= 3 || Instant::now() > deadline {
            break;
        }
    }
    let _ = hz.kill();
    let _ = hz.wait();
    let last = *rates.last().expect("iox2 service hz printed a rate");
    assert!(
        (15.0..60.0).contains(&last),
        "airglyph/decision at {last} Hz ({rates:?})"
    );
    shut_down(&p, run);
}
