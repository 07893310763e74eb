//! What a posture classifier would read of a synthetic stream's hands, a frame each:
//! for measuring the pen by posture on the same streams as the pen by motion.
//!
//! The person's true posture: "point" while drawing, formed up to 0.3 s before the
//! first frame of the symbol or up to 0.1 s after it, and released up to 0.1 s before
//! its last frame or up to 0.3 s after it; "point" too in the stretches where the
//! generator lets them point at something ([`SyntheticStream::pointing`]), from
//! somewhere along the reach to up to 0.5 s after it; otherwise a relaxed hand, open
//! or fist, changing every 0.5–3 s. The other hand rests open or as a fist all along.
//!
//! What the classifier reads: the true posture, misread as the posture crate's k-NN
//! confuses the six postures on bodies it was not trained on (its measured confusion
//! matrix, [`CONFUSION`]), at a mean rate over the postures of `error_rate` (the
//! matrix's off-diagonal scaled to it). Errors come in runs: a misread hand stays
//! misread for `run_frames` frames on average (geometric), as a hand held in a pose
//! the classifier gets wrong stays wrong. The classifier's confidence is not modelled:
//! every read has confidence 1.

use crate::lab::stream::SyntheticStream;
use crate::spot::{HandPosture, PostureLabel, Postures};
use rand::Rng;

/// The six postures of the synthetic hands and the posture classifier, in
/// [`CONFUSION`]'s order.
pub const POSTURES: [&str; 6] = ["open", "fist", "point", "thumb-up", "v", "pinch"];

const OPEN: usize = 0;
const FIST: usize = 1;
/// "point", the pen's posture unless another is named.
pub const POINT: usize = 2;

/// The posture crate's k-NN (k = 1) on the held-out bodies, all distances, turns and
/// with and without the sensor model: row the true posture, column the one read
/// (`cargo run --release -p airglyph-posture --example eval`, 2026-12-05;
/// services/posture/eval/confusion.png). 955 of 1008 right: 5.3 % misread.
pub const CONFUSION: [[u32; 6]; 6] = [
    [164, 0, 0, 0, 2, 2],
    [0, 158, 3, 2, 1, 4],
    [2, 1, 159, 2, 2, 2],
    [0, 4, 6, 155, 0, 3],
    [0, 0, 2, 0, 162, 4],
    [4, 1, 3, 2, 1, 157],
];

/// The mean misread rate of [`CONFUSION`] over the postures.
pub fn measured_error_rate() -> f64 {
    let (mut right, mut all) = (0u32, 0u32);
    for (i, row) in CONFUSION.iter().enumerate() {
        right += row[i];
        all += row.iter().sum::<u32>();
    }
    1.0 - right as f64 / all as f64
}

/// How the posture classifier's reads are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PostureNoise {
    /// Mean fraction of frames misread, over the postures (0: the truth).
    pub error_rate: f64,
    /// Mean length of a run of misread frames.
    pub run_frames: f64,
    /// Frames a second of the stream.
    pub fps: f32,
}

/// The true posture of the drawing hand a frame (indices into [`POSTURES`]); it draws
/// holding `drawing` (the pen's posture, [`POINT`] for the pen's default).
pub fn true_postures<R: Rng>(
    s: &SyntheticStream,
    drawing: usize,
    fps: f32,
    rng: &mut R,
) -> Vec<usize> {
    let n = s.points.len();
    let frames = |secs: f32| (secs * fps).round() as i64;
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let len = frames(rng.gen_range(0.5..3.0)).max(1) as usize;
        let relaxed = if rng.gen_bool(0.5) { OPEN } else { FIST };
        out.extend(std::iter::repeat_n(relaxed, len.min(n - out.len())));
    }
    let mut set = |from: i64, to: i64, posture: usize| {
        let (a, b) = (
            from.max(0) as usize,
            (to.max(-1) + 1).min(n as i64) as usize,
        );
        if a < b {
            out[a..b].fill(posture);
        }
    };
    for &(first, last, chance) in &s.pointing {
        if rng.gen_bool(chance.clamp(0.0, 1.0)) {
            let along = rng.gen_range(0.3..0.9);
            let from = first as i64 + ((last - first) as f64 * along) as i64;
            let to = last as i64 + frames(rng.gen_range(0.0..0.5));
            set(from, to, POINT);
        }
    }
    for t in &s.truth {
        let from = t.start as i64 - frames(rng.gen_range(-0.1..0.3));
        let to = t.end as i64 + frames(rng.gen_range(-0.1..0.3));
        set(from, to, drawing);
    }
    out
}

/// What the classifier reads of a hand whose true posture a frame is `truth`.
pub fn read<R: Rng>(truth: &[usize], noise: &PostureNoise, rng: &mut R) -> Vec<usize> {
    let scale = if measured_error_rate() > 0.0 {
        noise.error_rate / measured_error_rate()
    } else {
        0.0
    };
    let end = 1.0 / noise.run_frames.max(1.0);
    let mut misread: Option<usize> = None;
    let mut last_truth = usize::MAX;
    truth
        .iter()
        .map(|&t| {
            let row = &CONFUSION[t.min(POSTURES.len() - 1)];
            let total = row.iter().sum::<u32>() as f64;
            let wrong = (total - row[t] as f64) / total;
            // The row's misread rate at this scale, and the chance a run starts that
            // keeps the frames misread at that rate: start / (start + end).
            let e = (wrong * scale).clamp(0.0, 0.9);
            if t != last_truth {
                misread = None;
                last_truth = t;
            }
            if misread.is_some() && rng.gen_bool(end) {
                misread = None;
            } else if misread.is_none() && e > 0.0 && rng.gen_bool((e * end / (1.0 - e)).min(1.0)) {
                // Which posture it is misread as: the row's errors, in proportion.
                let mut k = rng.gen_range(0.0..total - row[t] as f64);
                let mut pick = t;
                for (j, &c) in row.iter().enumerate() {
                    if j == t {
                        continue;
                    }
                    if k < c as f64 {
                        pick = j;
                        break;
                    }
                    k -= c as f64;
                }
                misread = (pick != t).then_some(pick);
            }
            misread.unwrap_or(t)
        })
        .collect()
}

/// Both hands' postures a frame, as the classifier reads them: the drawing (right)
/// hand's from [`true_postures`] (drawing while it holds `drawing`), the other resting
/// open or as a fist.
pub fn posture_signal<R: Rng>(
    s: &SyntheticStream,
    drawing: usize,
    noise: &PostureNoise,
    rng: &mut R,
) -> Vec<Postures> {
    let right = read(&true_postures(s, drawing, noise.fps, rng), noise, rng);
    let rest = if rng.gen_bool(0.5) { OPEN } else { FIST };
    let left = read(&vec![rest; s.points.len()], noise, rng);
    let labels: Vec<Option<PostureLabel>> =
        POSTURES.iter().map(|p| PostureLabel::new(p).ok()).collect();
    let posture = |i: usize| {
        labels[i].map(|label| HandPosture {
            label,
            confidence: 1.0,
        })
    };
    right
        .iter()
        .zip(&left)
        .map(|(&r, &l)| Postures {
            left: posture(l),
            right: posture(r),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lab::stream::TruthGesture;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn reads_are_wrong_as_often_as_asked_and_in_runs() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let truth: Vec<usize> = (0..60_000).map(|i| (i / 1000) % 6).collect();
        let noise = PostureNoise {
            error_rate: 0.1,
            run_frames: 4.0,
            fps: 30.0,
        };
        let reads = read(&truth, &noise, &mut rng);
        let wrong = truth.iter().zip(&reads).filter(|(t, r)| t != r).count();
        let rate = wrong as f64 / truth.len() as f64;
        assert!((0.08..0.12).contains(&rate), "misread rate {rate}");
        // Runs: a misread frame is mostly followed by another.
        let runs = truth
            .windows(2)
            .zip(reads.windows(2))
            .filter(|(t, r)| t[0] == t[1] && r[0] == t[0] && r[1] != t[1])
            .count();
        let mean_run = wrong as f64 / runs.max(1) as f64;
        assert!((3.0..5.0).contains(&mean_run), "mean run {mean_run}");
        // An open hand is never read as pointing (the matrix has no such error).
        assert!(truth
            .iter()
            .zip(&reads)
            .all(|(&t, &r)| !(t == OPEN && r == POINT)));
        // No error asked: the truth.
        let clean = PostureNoise {
            error_rate: 0.0,
            ..noise
        };
        assert_eq!(read(&truth, &clean, &mut rng), truth);
        assert!((measured_error_rate() - 53.0 / 1008.0).abs() < 1e-9);
    }

    #[test]
    fn the_hand_points_while_drawing_and_rests_otherwise() {
        let s = SyntheticStream {
            points: vec![[0.0, 0.0]; 300],
            truth: vec![TruthGesture {
                label: "1".into(),
                subject: "w".into(),
                start: 100,
                end: 160,
            }],
            body: None,
            pointing: vec![(220, 250, 1.0)],
        };
        for seed in 0..10 {
            let t = true_postures(&s, POINT, 30.0, &mut ChaCha8Rng::seed_from_u64(seed));
            // Pointing over the drawing but for its first and last 3 frames at most…
            assert!(t[103..=157].iter().all(|&p| p == POINT), "seed {seed}");
            // …not before the 0.3 s lead, and pointing in the pointing stretch's end.
            assert!(t[..91].iter().all(|&p| p != POINT), "seed {seed}");
            assert_eq!(t[250], POINT);
            assert!(t.iter().all(|&p| [OPEN, FIST, POINT].contains(&p)));
        }
    }
}
