//! A gesture model on arbitrary text, run: loaded, then classifying a trajectory and
//! spotting in a stream of it. A model that passes validation must run without a panic
//! or an allocation it cannot make (`features.grid = 2^60 + 6` once passed the loader
//! and panicked the stage at its first gesture).
//!
//! Input: the model's JSON, then optionally a NUL byte and the trajectory as pairs of
//! little-endian f32 (x, y); without it, a fixed circle.
#![no_main]

use airglyph_gesture::{Hand, HandPoint, Model, Spotter, SpotterConfig, Trajectory};
use libfuzzer_sys::fuzz_target;

fn circle() -> Vec<[f32; 2]> {
    (0..40)
        .map(|i| {
            let a = i as f32 * 0.16;
            [a.cos(), a.sin()]
        })
        .collect()
}

fuzz_target!(|data: &[u8]| {
    let (json, points) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let Ok(text) = std::str::from_utf8(json) else {
        return;
    };
    let Ok(model) = Model::from_json_str(text, std::path::Path::new("fuzz.json")) else {
        return;
    };
    let mut points: Vec<[f32; 2]> = points
        .chunks_exact(8)
        .take(512)
        .map(|c| {
            let f = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            [f(&c[..4]), f(&c[4..])]
        })
        // The tracker hands out finite points only.
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .collect();
    if points.is_empty() {
        points = circle();
    }
    let t = Trajectory::from_points(points.clone());
    let c = model.classify(&t);
    assert!(c.class < model.labels.len());
    let Ok(mut spotter) = Spotter::new(model, SpotterConfig::default()) else {
        return;
    };
    // The trajectory drawn twice with rests around, at 30 Hz, in the body frame.
    let rest = std::iter::repeat_n([0.0f32, 0.0], 20);
    let stream = rest
        .clone()
        .chain(points.iter().map(|p| [p[0] * 0.2, p[1] * 0.2]))
        .chain(rest.clone())
        .chain(points.iter().map(|p| [p[0] * 0.2, p[1] * 0.2]))
        .chain(rest);
    for (i, [x, y]) in stream.enumerate() {
        let p = HandPoint {
            x,
            y,
            forward: 0.3,
            z: 0.3,
            hand: Hand::Right,
        };
        let _ = spotter.push_point(p, i as u64, i as u64 * 33_333_333);
    }
    let _ = spotter.finish();
});
