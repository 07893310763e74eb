//! The BVH reader on arbitrary text.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = airglyph_synth::bvh::BvhClip::parse(std::path::Path::new("fuzz.bvh"), text);
    }
});
