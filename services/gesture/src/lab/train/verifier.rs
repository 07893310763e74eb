//! Training the verifier on the stretches the spotter itself cuts from synthetic
//! streams of the training samples.

use crate::features::FeatureConfig;
use crate::lab::augment::augment;
use crate::lab::data::Sample;
use crate::lab::movement::Generator;
use crate::lab::stream::StreamConfig;
use crate::lab::train::mlp::MlpTrainConfig;
use crate::mlp::Mlp;
use crate::model::verifier::{verifier_features, VerifierInput};
use crate::model::{Model, SpottingModel, Verifier};
use crate::spot::{size_ok, LeeKim, Segmenter, SpotterConfig};
use crate::tracker::HandTracker;
use crate::trajectory::Trajectory;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// The segment's coarse shape the verifier sees (the classifier has the fine one).
const SHAPE: FeatureConfig = FeatureConfig {
    pen_up: false,
    points: 12,
    grid: 3,
    depth: false,
};

/// Training examples for every drawn gesture (each sample is drawn this many times, in
/// different streams and a little distorted each time)…
const VERIFIER_REPEATS: usize = 3;
/// …and this many other segments for each whole gesture.
const VERIFIER_NEGATIVES: f64 = 4.0;
/// A segment is a whole gesture when it covers a drawn one this closely (intersection
/// over union)…
const WHOLE_IOU: f64 = 0.85;
/// …and not one below this.
const NOT_WHOLE_IOU: f64 = 0.6;
/// Points of the timing profile a newly trained verifier sees: a coarse profile. With
/// 10 the held-out digits gain as much, but parts of letters (the "R" in a "B"),
/// drawn like whole symbols, win more often (gesture README, "Spotting").
const TIMING_POINTS: usize = 4;

impl Verifier {
    /// Trains on the segments the spotter will judge: the samples are drawn in
    /// synthetic continuous streams ([`crate::lab::build_stream`]), the spotter's
    /// segmenter cuts them, and every segment between two of its breaks is an example —
    /// a whole gesture of its label when it covers a drawn gesture closely
    /// (intersection over union ≥ 0.85), not a gesture when it does not (< 0.6:
    /// movement, part of a gesture, a gesture with movement before or after it); those
    /// in between are left out. `classifier` gives the posterior the verifier sees, and
    /// its labels; `generator` makes the streams.
    pub fn train(
        samples: &[Sample],
        classifier: &Model,
        spotting: &SpottingModel,
        seeds: &[u64],
        generator: Generator,
    ) -> Verifier {
        let mut shell = Verifier {
            features: SHAPE,
            classes: classifier.labels.clone(),
            timing: TIMING_POINTS,
            nets: Vec::new(),
            label_bars: BTreeMap::new(),
        };
        let lee_kim = LeeKim::new(spotting);
        shell.nets = seeds
            .iter()
            .map(|&seed| shell.train_net(samples, classifier, &lee_kim, seed, generator))
            .collect();
        shell
    }

    /// One network, on streams of its own drawn from `seed`.
    fn train_net(
        &self,
        samples: &[Sample],
        classifier: &Model,
        lee_kim: &LeeKim,
        seed: u64,
        generator: Generator,
    ) -> Mlp {
        let mut examples = stream_examples(samples, classifier, lee_kim, seed, generator);
        let pos = examples.iter().filter(|e| e.1 > 0).count().max(1);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED);
        let keep =
            (VERIFIER_NEGATIVES * pos as f64 / (examples.len() - pos).max(1) as f64).min(1.0);
        examples.retain(|e| e.1 > 0 || rng.gen_bool(keep));
        let targets: Vec<usize> = examples.iter().map(|e| e.1).collect();
        let cfg = MlpTrainConfig {
            hidden: 128,
            epochs: 20,
            seed,
            ..MlpTrainConfig::default()
        };
        let feats = |epoch: usize, i: usize| {
            let input = &examples[i].0;
            let mut f = Vec::new();
            if epoch == usize::MAX {
                verifier_features(input, self, &mut f);
                return f;
            }
            // A little rotation and scale, fresh every epoch.
            let mut rng = ChaCha8Rng::seed_from_u64(
                seed ^ ((epoch as u64).wrapping_mul(0x1000_0001))
                    ^ (i as u64).wrapping_mul(0x9E37_79B9),
            );
            let scale = rng.gen_range(0.85..1.15f32);
            let rot = rng.gen_range(-0.1..0.1f32);
            let (c, s) = (rot.cos(), rot.sin());
            let tf = |p: &[f32; 2]| [scale * (c * p[0] - s * p[1]), scale * (s * p[0] + c * p[1])];
            let moved = VerifierInput {
                segment: input.segment.iter().map(tf).collect(),
                times: input.times.clone(),
                before: input.before.map(|p| tf(&p)),
                after: input.after.map(|p| tf(&p)),
                posterior: input.posterior.clone(),
                ratio: input.ratio,
            };
            verifier_features(&moved, self, &mut f);
            f
        };
        Mlp::train(
            examples.len(),
            self.dim(),
            &targets,
            self.classes.len() + 1,
            &cfg,
            feats,
            |_| {},
        )
    }
}

/// Candidate segments of synthetic streams of the samples, each with its verifier
/// target: 0 = not a whole gesture, 1 + i = a whole gesture of the classifier's label i
/// (see [`Verifier::train`]).
pub fn stream_examples(
    samples: &[Sample],
    classifier: &Model,
    lee_kim: &LeeKim,
    seed: u64,
    generator: Generator,
) -> Vec<(VerifierInput, usize)> {
    let labels = &classifier.labels;
    let mut order: Vec<&Sample> = (0..VERIFIER_REPEATS).flat_map(|_| samples.iter()).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let chunks: Vec<(usize, Vec<&Sample>)> =
        order.chunks(20).map(|c| c.to_vec()).enumerate().collect();
    let scfg = SpotterConfig::default();
    chunks
        .par_iter()
        .flat_map_iter(|(k, chunk)| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(31).wrapping_add(*k as u64));
            // Writer variation (as the classifier is trained with): every sample a
            // little rotated, sheared and stretched.
            let varied = |rng: &mut ChaCha8Rng| -> Vec<Sample> {
                chunk
                    .iter()
                    .map(|s| {
                        let t = augment(&s.trajectory(), rng, 1.0);
                        Sample {
                            label: s.label.clone(),
                            subject: s.subject.clone(),
                            strokes: vec![t.points],
                            depth: None,
                        }
                    })
                    .collect()
            };
            let stream = generator.training(*k, &mut rng, varied);
            let cfg = StreamConfig::default();
            let mut tracker = HandTracker::new(scfg.tracker);
            let mut seg = Segmenter::new(&scfg);
            let dt = (1e9 / cfg.fps as f64) as u64;
            let mut ends = Vec::new();
            for i in 0..stream.points.len() {
                let sk = stream.skeleton(i, cfg.distance);
                let Some(p) = tracker.update(&sk, i as u64 * dt) else {
                    continue;
                };
                ends.extend(seg.push([p.x, p.y], 0.0, i as u64, i as u64 * dt));
            }
            let fps = cfg.fps as f64;
            let min_len = (scfg.min_seconds * fps) as usize;
            let max_len = (scfg.max_seconds * fps) as usize;
            let mut out = Vec::new();
            for e in ends {
                for s in seg.starts(e, 0, min_len, max_len) {
                    let Some(mut input) = seg.input(s, e, fps) else {
                        continue;
                    };
                    if !size_ok(&input.segment, &scfg) {
                        continue;
                    }
                    let t = Trajectory::from_points(input.segment.clone());
                    input.posterior = classifier.posterior(&t).iter().map(|&p| p as f32).collect();
                    input.ratio = lee_kim.ratio(&t);
                    let (Some(a), Some(b)) = (seg.point(s), seg.point(e)) else {
                        continue;
                    };
                    // The drawn gesture it overlaps most (intersection over union).
                    let best = stream
                        .truth
                        .iter()
                        .map(|t| {
                            let inter = b.1.min(t.end) as f64 - a.1.max(t.start) as f64;
                            let union = b.1.max(t.end) as f64 - a.1.min(t.start) as f64;
                            ((inter / union.max(1.0)).max(0.0), t)
                        })
                        .max_by(|x, y| x.0.total_cmp(&y.0));
                    match best {
                        Some((iou, t)) if iou >= WHOLE_IOU => {
                            if let Some(c) = labels.iter().position(|l| *l == t.label) {
                                out.push((input, 1 + c));
                            }
                        }
                        Some((iou, _)) if iou >= NOT_WHOLE_IOU => {}
                        _ => out.push((input, 0)),
                    }
                }
            }
            out
        })
        .collect()
}
