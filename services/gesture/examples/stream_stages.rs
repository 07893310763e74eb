//! What drawing a symbol in the air stream does to the classifier: the samples that
//! `airglyph eval-spotting` draws (same streams for the same seed) classified after each
//! step of the drawing in turn, so that each step's cost shows.
//!
//! usage: cargo run --release -p airglyph-gesture --example stream_stages --
//!        MODEL DATA.jsonl [GESTURES (1000)] [SEED (1)]
use airglyph_gesture::lab::{build_stream, load_many, resample, Sample, StreamConfig};
use airglyph_gesture::{skeleton_with_hand, HandTracker, Model, Trajectory};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::path::PathBuf;

/// The stream's points as the spotter sees them: as skeletons through the hand tracker
/// (body frame, One Euro filter), as `eval-spotting` feeds them.
fn tracked(points: &[[f32; 2]], cfg: &StreamConfig) -> Vec<[f32; 2]> {
    let mut tr = HandTracker::new(Default::default());
    let dt = (1e9 / cfg.fps as f64) as u64;
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let sk = skeleton_with_hand(p[0], p[1], cfg.distance);
            tr.update(&sk, i as u64 * dt).map_or(*p, |h| [h.x, h.y])
        })
        .collect()
}

const STAGES: [&str; 8] = [
    "the sample itself",
    "resampled at 200 points (the stream's template)",
    "timed (power law, 30 fps), drawn frames",
    "  + tracking noise",
    "  + hand tracker, no noise",
    "  + noise and hand tracker (eval-spotting's 'alone')",
    "  the same, cut 1 frame late",
    "  the same, cut 2 frames late",
];

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        anyhow::bail!("usage: stream_stages MODEL DATA.jsonl [GESTURES] [SEED]");
    }
    let model = Model::load(&PathBuf::from(&args[1]))?;
    let samples = load_many(&[PathBuf::from(&args[2])])?;
    let gestures: usize = args.get(3).map_or(Ok(1000), |s| s.parse())?;
    let seed: u64 = args.get(4).map_or(Ok(1), |s| s.parse())?;
    // The samples and streams eval-spotting draws for this seed.
    let mut known: Vec<&Sample> = samples
        .iter()
        .filter(|s| model.label_index(&s.label).is_some())
        .collect();
    known.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    known.truncate(gestures.max(1));
    let cfg = StreamConfig::default();
    // Noise is added last, after the stream's other random draws: the same seed gives
    // the same stream without it.
    let clean_cfg = StreamConfig { noise: 0.0, ..cfg };
    let right: Vec<[bool; STAGES.len()]> = known
        .par_chunks(20)
        .enumerate()
        .flat_map_iter(|(i, chunk)| {
            let s = seed.wrapping_mul(7919).wrapping_add(i as u64);
            let clean = build_stream(chunk, &clean_cfg, &mut ChaCha8Rng::seed_from_u64(s));
            let noisy = build_stream(chunk, &cfg, &mut ChaCha8Rng::seed_from_u64(s));
            let (tracked_clean, tracked_noisy) =
                (tracked(&clean.points, &cfg), tracked(&noisy.points, &cfg));
            let last = noisy.points.len() - 1;
            let model = &model;
            let trajectory = |points: &[[f32; 2]]| Trajectory::from_points(points.to_vec());
            chunk.iter().zip(clean.truth).map(move |(sample, t)| {
                let ok = |t: Trajectory| model.labels[model.classify(&t).class] == sample.label;
                let (a, b) = (t.start as usize, t.end as usize);
                let late =
                    |k: usize| trajectory(&tracked_noisy[(a + k).min(b)..=(b + k).min(last)]);
                [
                    ok(sample.trajectory()),
                    ok(trajectory(&resample(&sample.trajectory(), 200).points)),
                    ok(trajectory(&clean.points[a..=b])),
                    ok(trajectory(&noisy.points[a..=b])),
                    ok(trajectory(&tracked_clean[a..=b])),
                    ok(trajectory(&tracked_noisy[a..=b])),
                    ok(late(1)),
                    ok(late(2)),
                ]
            })
        })
        .collect();
    let n = right.len();
    for (k, name) in STAGES.iter().enumerate() {
        let c = right.iter().filter(|r| r[k]).count();
        println!("{:6.2} % ({c}/{n})  {name}", 100.0 * c as f64 / n as f64);
    }
    Ok(())
}
