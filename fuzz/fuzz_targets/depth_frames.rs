//! The pose estimator on arbitrary depth frames, several in a row through one
//! estimator: what it carries from frame to frame (the window it segments first, the
//! tracked body) must not make a later frame panic or give non-finite joints.
#![no_main]

use airglyph_core::{DepthImage, Intrinsics};
use airglyph_pose::{PoseConfig, PoseEstimator};
use libfuzzer_sys::fuzz_target;

const W: u32 = 48;
const H: u32 = 36;

fuzz_target!(|data: &[u8]| {
    let k = Intrinsics::default().scaled_to(W, H);
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    let frame_bytes = (W * H * 2) as usize;
    // Each frame: its bytes as little-endian millimetres, the last frame's where the
    // input ran out (a frame a byte long still changes one pixel of the last).
    let mut pixels = vec![0u16; (W * H) as usize];
    for chunk in data.chunks(frame_bytes).take(6) {
        for (p, b) in pixels.iter_mut().zip(chunk.chunks(2)) {
            *p = u16::from_le_bytes([b[0], *b.get(1).unwrap_or(&0)]);
        }
        let img = DepthImage::new(W, H, pixels.clone()).expect("size");
        let r = est.estimate(img.view());
        assert!(r.skeleton.is_finite(), "{r:?}");
    }
});
