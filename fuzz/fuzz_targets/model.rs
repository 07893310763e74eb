//! The model loader on arbitrary text: a bad model is refused, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = airglyph_gesture::Model::from_json_str(text, std::path::Path::new("fuzz.json"));
    }
});
