//! The recording reader on arbitrary files: recording.toml, frames.csv, joints.csv and
//! one depth PNG, split from the input at the first three 0xFF bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("airglyph-fuzz-rec-{}", std::process::id()));
    std::fs::create_dir_all(d.join("depth")).unwrap();
    d
}

fuzz_target!(|data: &[u8]| {
    let d = dir();
    let mut parts = data.splitn(4, |&b| b == 0xFF);
    let names = ["recording.toml", "frames.csv", "joints.csv", "depth/000000.png"];
    for name in names {
        let path = d.join(name);
        match parts.next() {
            Some(bytes) => std::fs::write(&path, bytes).unwrap(),
            None => {
                let _ = std::fs::remove_file(&path);
            }
        }
    }
    if let Ok(rec) = airglyph_core::recording::Recording::open(&d) {
        for i in 0..rec.len().min(2) {
            let _ = rec.read_frame(i);
            let _ = rec.joints(i);
        }
    }
});
