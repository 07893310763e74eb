//! The `.oni` repair on arbitrary bytes: a damaged or hostile file is refused with the
//! byte it broke at, never a panic; a repaired file reads again with the same depth
//! nodes, and repairing it once more changes nothing.
#![no_main]

use airglyph_capture::onifile::{add_missing_cropping, depth_nodes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = depth_nodes(data);
    if let Ok(Some(repaired)) = add_missing_cropping(data) {
        let nodes = depth_nodes(&repaired).expect("a repaired file reads");
        assert_eq!(nodes.len(), depth_nodes(data).map_or(0, |n| n.len()));
        assert_eq!(add_missing_cropping(&repaired), Ok(None), "repaired twice");
    }
});
