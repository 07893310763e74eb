//! Trajectory JSONL on arbitrary bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = airglyph_gesture::lab::parse_jsonl(data, std::path::Path::new("fuzz.jsonl"));
});
