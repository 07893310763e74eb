//! Which model of how people move makes the synthetic streams: the lab generator
//! ([`crate::lab::build_stream`]: two-thirds power law, flowing in and out of symbols,
//! reaches, fidgets and rests) or the everyday one ([`crate::lab::everyday_stream`]:
//! one person a stream, constant speed or another power law, pauses at corners,
//! everyday actions), or both, a stream each in turn. A spotter trained on one and
//! measured on the other shows what it learned of the generator rather than of
//! gestures.

use crate::lab::data::Sample;
use crate::lab::everyday::{everyday_movement, everyday_stream};
use crate::lab::stream::{
    build_stream, random_movement, training_stream, StreamConfig, SyntheticStream,
};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// A generator of synthetic streams.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Generator {
    /// The lab generator (the evaluation's and training's of before).
    #[default]
    Lab,
    /// The everyday generator.
    Everyday,
    /// Both: even-numbered streams the lab generator's, odd ones the everyday one's.
    Mixed,
}

impl Generator {
    /// The generator a name on the command line means.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "lab" => Some(Self::Lab),
            "everyday" => Some(Self::Everyday),
            "mixed" => Some(Self::Mixed),
            _ => None,
        }
    }

    /// Its name on the command line and in model files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Lab => "lab",
            Self::Everyday => "everyday",
            Self::Mixed => "mixed",
        }
    }

    /// Whether it is the lab generator (which model files do not name).
    pub fn is_lab(&self) -> bool {
        *self == Self::Lab
    }

    /// Whether stream number `index` is the lab generator's.
    fn lab_for(self, index: usize) -> bool {
        match self {
            Self::Lab => true,
            Self::Everyday => false,
            Self::Mixed => index.is_multiple_of(2),
        }
    }

    /// Stream number `index` of an evaluation: the samples drawn in order (`cfg`
    /// describes the lab generator's streams; the everyday one draws its own person).
    pub fn stream<R: Rng>(
        self,
        samples: &[&Sample],
        cfg: &StreamConfig,
        index: usize,
        rng: &mut R,
    ) -> SyntheticStream {
        if self.lab_for(index) {
            build_stream(samples, cfg, rng)
        } else {
            everyday_stream(samples, rng)
        }
    }

    /// Stream number `index` for training: the lab generator's with the varied
    /// settings of [`training_stream`] (drawn first from `rng`), the everyday one's as
    /// it is (its people vary already). `samples` gives the samples to draw once the
    /// settings are drawn (so that the lab generator's draws stay in their order).
    pub fn training<R: Rng>(
        self,
        index: usize,
        rng: &mut R,
        samples: impl FnOnce(&mut R) -> Vec<Sample>,
    ) -> SyntheticStream {
        let cfg = self.lab_for(index).then(|| training_stream(rng));
        let s = samples(rng);
        let refs: Vec<&Sample> = s.iter().collect();
        match cfg {
            Some(cfg) => build_stream(&refs, &cfg, rng),
            None => everyday_stream(&refs, rng),
        }
    }

    /// `seconds` of ordinary movement alone (the mixed generator: half of each).
    pub fn movement<R: Rng>(
        self,
        seconds: f32,
        cfg: &StreamConfig,
        rng: &mut R,
    ) -> Vec<SyntheticStream> {
        match self {
            Self::Lab => vec![random_movement(seconds, cfg, rng)],
            Self::Everyday => vec![everyday_movement(seconds, rng)],
            Self::Mixed => vec![
                random_movement(seconds / 2.0, cfg, rng),
                everyday_movement(seconds / 2.0, rng),
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn sample(label: &str, points: Vec<[f32; 2]>) -> Sample {
        Sample {
            label: label.into(),
            subject: "w".into(),
            strokes: vec![points],
            depth: None,
        }
    }

    #[test]
    fn the_everyday_generator_draws_every_symbol_in_its_frames() {
        let l = sample("L", vec![[0.0, 0.0], [0.0, 0.6], [0.4, 0.6]]);
        let o: Vec<[f32; 2]> = (0..=40)
            .map(|i| {
                let a = i as f32 / 40.0 * std::f32::consts::TAU;
                [a.cos(), a.sin()]
            })
            .collect();
        let o = sample("O", o);
        let refs = vec![&l, &o, &l, &o, &l];
        for seed in 0..20 {
            let s = Generator::Everyday.stream(
                &refs,
                &StreamConfig::default(),
                1,
                &mut ChaCha8Rng::seed_from_u64(seed),
            );
            assert_eq!(s.truth.len(), 5);
            let body = s
                .body
                .as_ref()
                .expect("the everyday generator models the body");
            assert_eq!(body.forward.len(), s.points.len());
            assert!((1.8..3.2).contains(&body.distance));
            let mut last = 0;
            for t in &s.truth {
                assert!(t.start >= last && t.end > t.start, "seed {seed}: {t:?}");
                last = t.end;
                // A symbol 0.6–1.6 shoulder widths large, drawn at 0.6–2.8 a second:
                // at most a few seconds, at least a few frames.
                let frames = t.end - t.start;
                assert!((5..300).contains(&frames), "seed {seed}: {frames} frames");
                // Drawn where the hand is held out in front.
                assert!(body.forward[t.start as usize] > 0.2);
            }
            assert!(s.points.iter().all(|p| p.iter().all(|c| c.is_finite())));
        }
    }

    #[test]
    fn the_lab_generator_is_the_one_of_before_and_mixed_takes_turns() {
        let l = sample("L", vec![[0.0, 0.0], [0.0, 0.6], [0.4, 0.6]]);
        let refs = vec![&l, &l];
        let cfg = StreamConfig::default();
        let before = build_stream(&refs, &cfg, &mut ChaCha8Rng::seed_from_u64(3));
        for (g, i) in [(Generator::Lab, 1), (Generator::Mixed, 0)] {
            let s = g.stream(&refs, &cfg, i, &mut ChaCha8Rng::seed_from_u64(3));
            assert_eq!(s.points, before.points);
            assert!(s.body.is_none());
        }
        let s = Generator::Mixed.stream(&refs, &cfg, 1, &mut ChaCha8Rng::seed_from_u64(3));
        assert!(s.body.is_some());
        let m = Generator::Everyday.movement(20.0, &cfg, &mut ChaCha8Rng::seed_from_u64(4));
        assert_eq!(m[0].points.len(), 600);
        assert!(m[0].truth.is_empty());
        for name in ["lab", "everyday", "mixed"] {
            assert_eq!(Generator::parse(name).map(Generator::name), Some(name));
        }
        assert_eq!(Generator::parse("other"), None);
    }
}
