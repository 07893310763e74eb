//! Runs the estimator over the bench's scenes a fixed number of times, for a profiler:
//! criterion's adaptive iteration counts make instruction counts hard to compare, this
//! does the same work every run. Prints a checksum of the joints, so a change that should
//! keep the results can be checked to keep them bit for bit, and each step's time a
//! frame (`PoseEstimator::step_times`), to see which step a change made slower.
//!
//! `valgrind --tool=callgrind --toggle-collect='*PoseEstimator*estimate_at*'
//!  target/release/examples/profile [static|drawing] [320|640] [frames]`
//! (defaults: drawing 320 90; static repeats one frame, drawing runs a clip once).

use airglyph_core::{DepthImage, Intrinsics};
use airglyph_pose::{PoseConfig, PoseEstimator};
use airglyph_synth::{Background, MotionSpec, SceneConfig, ScriptedPose, Synthesizer};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let which = args.first().map_or("drawing", String::as_str);
    let width: u32 = args.get(1).map_or(320, |a| a.parse().expect("width"));
    let n: usize = args.get(2).map_or(90, |a| a.parse().expect("frames"));
    let k = Intrinsics::default().scaled_to(width, width * 3 / 4);
    let frames = match which {
        "static" => vec![scene(k, MotionSpec::Pose(ScriptedPose::Wave)).render(0).0],
        // The bench's clip: skip the approach to the first symbol.
        "drawing" => render_clip(k, n),
        other => panic!("unknown scene {other}: static or drawing"),
    };
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    let (mut sum, mut windowed) = (0f64, 0);
    let mut steps = [0f64; 6];
    let t0 = Instant::now();
    for i in 0..n {
        let r = est.estimate(frames[i % frames.len()].view());
        let t = est.step_times();
        for (s, x) in steps
            .iter_mut()
            .zip([t.segment, t.torso, t.graph, t.geodesic, t.limbs, t.register])
        {
            *s += x;
        }
        windowed += usize::from(est.debug().windowed);
        for (j, c) in r.skeleton.joints.iter().zip(r.skeleton.confidence) {
            sum += (j.x + 2.0 * j.y + 3.0 * j.z + 4.0 * c) as f64;
        }
    }
    let dt = t0.elapsed().as_secs_f64();
    println!(
        "{which} {width}: {n} frames, {:.3} ms a frame, checksum {sum:.9}, \
         {windowed} segmented around the last person",
        dt * 1e3 / n as f64
    );
    let names = ["segment", "torso", "graph", "geodesic", "limbs", "register"];
    let per_frame: Vec<String> = names
        .iter()
        .zip(steps)
        .map(|(name, s)| format!("{name} {:.3}", s * 1e3 / n as f64))
        .collect();
    println!("steps, ms a frame: {}", per_frame.join(", "));
}

fn scene(k: Intrinsics, motion: MotionSpec) -> Synthesizer {
    Synthesizer::new(SceneConfig {
        intrinsics: k,
        motion,
        background: Background::FloorAndWall,
        sensor_noise: true,
        ..SceneConfig::default()
    })
    .expect("scene")
}

fn render_clip(k: Intrinsics, n: usize) -> Vec<DepthImage> {
    let mut s = scene(
        k,
        MotionSpec::parse("draw:25", None, false).expect("a drawing"),
    );
    (30..30 + n).map(|i| s.render(i).0).collect()
}
