//! `--source` specs on arbitrary text: a bad one is refused with a message, never a
//! panic; a good one prints back to a spec that parses to the same thing, and a camera
//! mode never names a frame larger than capture may allocate.
#![no_main]

use airglyph_capture::source::SourceSpec;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(spec) = text.parse::<SourceSpec>() else {
        return;
    };
    let printed = spec.to_string();
    let again: SourceSpec = printed
        .parse()
        .unwrap_or_else(|e| panic!("{text:?} printed as {printed:?}, which does not parse: {e}"));
    assert_eq!(again, spec, "{text:?} printed as {printed:?}");
    match &spec {
        SourceSpec::V4l2(_, o) | SourceSpec::OpenNi2(_, o) => {
            let side = airglyph_core::camera::MAX_SIDE;
            assert!(o.width.is_none_or(|w| (1..=side).contains(&w)));
            assert!(o.height.is_none_or(|h| (1..=side).contains(&h)));
        }
        // A script naming a file (a BVH clip) would read from disk: only the built-in
        // motions are run here.
        SourceSpec::Synthetic(Some(script)) if !script.contains('/') && !script.contains('.') => {
            let _ = airglyph_capture::synthetic::motion(Some(script), false);
        }
        _ => {}
    }
});
