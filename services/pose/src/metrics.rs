//! Pose error against ground truth: the seed's per-frame mean error e_m and largest
//! error e_h (Eq. 16.20, 16.21), the per-joint mean error e_j (Eq. 16.22), the share of
//! joints within 10 cm, and mean average precision at 10 cm (Shotton et al. 2011).

use crate::PoseResult;
use airglyph_core::{Joint, Skeleton};
use serde::Serialize;

/// Errors of one frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameErrors {
    /// Whether the estimator found a person in the frame.
    pub person_found: bool,
    /// Each joint's error, metres.
    pub joint: [f32; Joint::COUNT],
    /// Each joint's confidence as the estimator gave it.
    pub confidence: [f32; Joint::COUNT],
}

impl FrameErrors {
    /// e_m: mean joint error of the frame.
    pub fn mean(&self) -> f32 {
        self.joint.iter().sum::<f32>() / Joint::COUNT as f32
    }
    /// e_h: largest joint error of the frame.
    pub fn max(&self) -> f32 {
        self.joint.iter().copied().fold(0.0, f32::max)
    }
}

/// Collects frames; [`PoseEval::summary`] gives the figures.
#[derive(Debug, Clone, Default)]
pub struct PoseEval {
    /// Every frame scored, in order.
    pub frames: Vec<FrameErrors>,
    /// Seconds spent estimating, for frames/s.
    pub seconds: f64,
}

/// The figures of an evaluation (`eval-pose --json` prints exactly these keys).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Frames scored.
    pub frames: usize,
    /// Mean over frames of e_m, cm (frames with a person found).
    pub mean_error_cm: f64,
    /// Mean over frames of e_h, cm (frames with a person found).
    pub max_error_cm: f64,
    /// e_j per joint, cm.
    pub per_joint_cm: std::collections::BTreeMap<String, f64>,
    /// Share of all joints of all frames within 10 cm (a frame without a person counts
    /// all its joints as misses).
    pub within_10cm: f64,
    /// Mean over joints of the average precision at 10 cm, predictions ranked by
    /// confidence.
    pub map_10cm: f64,
    /// Frames estimated a second (of the estimator alone).
    pub fps: f64,
}

/// Whether every ground-truth joint projects into the image: frames where the person
/// is partly out of view are left out of an evaluation (the seed's setting).
pub fn in_view(truth: &Skeleton, k: &airglyph_core::Intrinsics) -> bool {
    truth.joints.iter().all(|p| {
        k.project(p).is_some_and(|(u, v)| {
            u >= 0.0 && v >= 0.0 && u <= k.width as f32 - 1.0 && v <= k.height as f32 - 1.0
        })
    })
}

impl PoseEval {
    /// Scores one frame's estimate against its truth; the frame's errors.
    pub fn add(&mut self, est: &PoseResult, truth: &Skeleton) -> FrameErrors {
        let mut joint = [0.0; Joint::COUNT];
        for (j, e) in joint.iter_mut().enumerate() {
            *e = if est.person_found {
                (est.skeleton.joints[j] - truth.joints[j]).norm()
            } else {
                f32::INFINITY
            };
        }
        let fe = FrameErrors {
            person_found: est.person_found,
            joint,
            confidence: est.skeleton.confidence,
        };
        self.frames.push(fe);
        fe
    }

    /// The figures of every frame scored so far.
    pub fn summary(&self) -> Summary {
        let found: Vec<&FrameErrors> = self.frames.iter().filter(|f| f.person_found).collect();
        let nf = found.len().max(1) as f64;
        let mean = found.iter().map(|f| f.mean() as f64).sum::<f64>() / nf;
        let max = found.iter().map(|f| f.max() as f64).sum::<f64>() / nf;
        let mut per_joint = std::collections::BTreeMap::new();
        for j in Joint::ALL {
            let e = found.iter().map(|f| f.joint[j.index()] as f64).sum::<f64>() / nf;
            per_joint.insert(j.name().to_string(), round(e * 100.0));
        }
        let total = (self.frames.len() * Joint::COUNT).max(1) as f64;
        let within = self
            .frames
            .iter()
            .flat_map(|f| f.joint.iter())
            .filter(|&&e| e < 0.10)
            .count() as f64
            / total;
        let mut ap_sum = 0.0;
        for j in 0..Joint::COUNT {
            let mut preds: Vec<(f32, bool)> = self
                .frames
                .iter()
                .filter(|f| f.person_found)
                .map(|f| (f.confidence[j], f.joint[j] < 0.10))
                .collect();
            preds.sort_by(|a, b| b.0.total_cmp(&a.0));
            ap_sum += average_precision(&preds, self.frames.len());
        }
        let map = ap_sum / Joint::COUNT as f64;
        let fps = if self.seconds > 0.0 {
            self.frames.len() as f64 / self.seconds
        } else {
            0.0
        };
        Summary {
            frames: self.frames.len(),
            mean_error_cm: round(mean * 100.0),
            max_error_cm: round(max * 100.0),
            per_joint_cm: per_joint,
            within_10cm: round(within),
            map_10cm: round(map),
            fps: round(fps),
        }
    }
}

fn round(x: f64) -> f64 {
    if x.is_finite() {
        (x * 10000.0).round() / 10000.0
    } else {
        -1.0
    }
}

/// Average precision of predictions ranked by confidence (`true` = within the
/// threshold) against `positives` ground-truth instances, with the precision envelope.
fn average_precision(ranked: &[(f32, bool)], positives: usize) -> f64 {
    if positives == 0 {
        return 0.0;
    }
    let mut tp = 0usize;
    let mut curve: Vec<(f64, f64)> = Vec::with_capacity(ranked.len());
    for (i, &(_, ok)) in ranked.iter().enumerate() {
        if ok {
            tp += 1;
        }
        curve.push((tp as f64 / positives as f64, tp as f64 / (i + 1) as f64));
    }
    // Precision envelope, then the area under it.
    for i in (0..curve.len().saturating_sub(1)).rev() {
        curve[i].1 = curve[i].1.max(curve[i + 1].1);
    }
    let mut ap = 0.0;
    let mut last_r = 0.0;
    for &(r, p) in &curve {
        ap += (r - last_r) * p;
        last_r = r;
    }
    ap
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Vector3};

    #[test]
    fn figures_of_a_known_offset() {
        let truth = Skeleton::new([Point3::new(0.0, 0.0, 2.0); Joint::COUNT]);
        let mut est = truth;
        est.joints[0] += Vector3::new(0.2, 0.0, 0.0);
        for j in 1..Joint::COUNT {
            est.joints[j] += Vector3::new(0.0, 0.05, 0.0);
        }
        let mut ev = PoseEval::default();
        let r = PoseResult {
            person_found: true,
            skeleton: est,
        };
        ev.add(&r, &truth);
        ev.add(&r, &truth);
        ev.seconds = 0.5;
        let s = ev.summary();
        assert_eq!(s.frames, 2);
        assert!((s.mean_error_cm - (20.0 + 15.0 * 5.0) / 16.0).abs() < 1e-3);
        assert!((s.max_error_cm - 20.0).abs() < 1e-3);
        assert!((s.per_joint_cm["head"] - 20.0).abs() < 1e-3);
        assert!((s.within_10cm - 15.0 / 16.0).abs() < 1e-3);
        assert!((s.map_10cm - 15.0 / 16.0).abs() < 1e-3);
        assert!((s.fps - 4.0).abs() < 1e-9);
    }

    #[test]
    fn average_precision_ranks_by_confidence() {
        assert!((average_precision(&[(0.9, true), (0.5, false)], 2) - 0.5).abs() < 1e-9);
        assert!((average_precision(&[(0.9, true), (0.5, true)], 2) - 1.0).abs() < 1e-9);
        assert!((average_precision(&[(0.9, false), (0.5, true)], 1) - 0.5).abs() < 1e-9);
    }
}
