//! Pose error against ground truth: the seed's per-frame mean error e_m and largest
//! error e_h (Eq. 16.20, 16.21), the per-joint mean error e_j (Eq. 16.22), the share of
//! joints within 10 cm, and mean average precision at 10 cm (Shotton et al. 2011), over
//! the joints in the camera's view ([`Skeleton::visible`] of the truth); and how well
//! the estimate says which joints are in view.
//!
//! The seed scores only frames that hold the whole body; a camera at a desk never sees
//! one. So every frame is scored on the joints it shows, and the seed's figure is kept
//! beside it ([`Summary::mean_error_whole_cm`]) for the frames that hold all sixteen.

use crate::PoseResult;
use airglyph_core::{Intrinsics, Joint, Skeleton};
use serde::Serialize;
use std::collections::BTreeMap;

/// Errors of one frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameErrors {
    /// Whether the estimator found a person.
    pub person_found: bool,
    /// Each joint's error, for the joints the truth has in view (`None`: out of view,
    /// not scored). Infinite when no person was found.
    pub joint: [Option<f32>; Joint::COUNT],
    /// The estimate's confidence of each joint.
    pub confidence: [f32; Joint::COUNT],
    /// Per joint: (in view in the truth, reported visible by the estimate).
    pub visible: [(bool, bool); Joint::COUNT],
    /// The estimate reports visible a joint that projects outside the image.
    pub visible_outside: usize,
}

impl FrameErrors {
    fn scored(&self) -> impl Iterator<Item = f32> + '_ {
        self.joint.iter().flatten().copied()
    }

    /// e_m: mean error of the joints in view (0 when none is).
    pub fn mean(&self) -> f32 {
        let n = self.scored().count();
        if n == 0 {
            0.0
        } else {
            self.scored().sum::<f32>() / n as f32
        }
    }

    /// e_h: largest error of the joints in view.
    pub fn max(&self) -> f32 {
        self.scored().fold(0.0, f32::max)
    }

    /// Whether the truth has every joint in view (the seed's setting).
    pub fn whole(&self) -> bool {
        self.joint.iter().all(Option::is_some)
    }
}

/// Collects frames; [`PoseEval::summary`] gives the figures.
#[derive(Debug, Clone, Default)]
pub struct PoseEval {
    /// The frames added so far.
    pub frames: Vec<FrameErrors>,
    /// Seconds spent estimating, for frames/s.
    pub seconds: f64,
}

/// The figures of an evaluation (`eval-pose --json` prints exactly these keys).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Frames scored.
    pub frames: usize,
    /// Mean over frames of e_m over the joints in view, cm (frames with a person found).
    pub mean_error_cm: f64,
    /// Mean over frames of e_h over the joints in view, cm.
    pub max_error_cm: f64,
    /// The seed's e_m: over the frames that hold the whole body (all 16 joints in view),
    /// cm; `None` when there is no such frame.
    pub mean_error_whole_cm: Option<f64>,
    /// Frames that hold the whole body.
    pub frames_whole: usize,
    /// e_j per joint over the frames that have it in view, cm (`None`: never in view).
    pub per_joint_cm: BTreeMap<String, Option<f64>>,
    /// Share of the joints in view, over all frames, within 10 cm (a frame without a
    /// person counts its joints as misses).
    pub within_10cm: f64,
    /// Mean over joints of the average precision at 10 cm, predictions ranked by
    /// confidence (joints ever in view).
    pub map_10cm: f64,
    /// Of the joints the truth has out of view, the share reported not visible (`None`:
    /// the truth had every joint in view).
    pub out_of_view_reported: Option<f64>,
    /// Of the frames whose truth has a lower joint (pelvis, hips, knees, feet) out of
    /// view, the share in which every such joint is reported not visible (`None`: no
    /// such frame). A body seen from the waist up must not have legs invented for it.
    pub lower_hidden_frames: Option<f64>,
    /// Of the joints the truth has in view, the share reported visible.
    pub in_view_reported: f64,
    /// Joints reported visible that project outside the image (should be 0).
    pub visible_outside_image: usize,
    /// Frames a second of the estimator alone.
    pub fps: f64,
}

/// Whether every ground-truth joint projects into the image.
pub fn in_view(truth: &Skeleton, k: &Intrinsics) -> bool {
    truth.joints.iter().all(|p| inside(p, k))
}

/// Whether a point projects inside the image.
fn inside(p: &nalgebra::Point3<f32>, k: &Intrinsics) -> bool {
    k.project(p).is_some_and(|(u, v)| {
        u >= 0.0 && v >= 0.0 && u <= k.width as f32 - 1.0 && v <= k.height as f32 - 1.0
    })
}

impl PoseEval {
    /// Scores one frame's estimate against its truth, seen through the camera `k`.
    pub fn add(&mut self, est: &PoseResult, truth: &Skeleton, k: &Intrinsics) -> FrameErrors {
        let mut joint = [None; Joint::COUNT];
        let mut visible = [(false, false); Joint::COUNT];
        let mut visible_outside = 0;
        for j in 0..Joint::COUNT {
            let reported = est.person_found && est.skeleton.visible[j];
            visible[j] = (truth.visible[j], reported);
            if reported && !inside(&est.skeleton.joints[j], k) {
                visible_outside += 1;
            }
            if truth.visible[j] {
                joint[j] = Some(if est.person_found {
                    (est.skeleton.joints[j] - truth.joints[j]).norm()
                } else {
                    f32::INFINITY
                });
            }
        }
        let fe = FrameErrors {
            person_found: est.person_found,
            joint,
            confidence: est.skeleton.confidence,
            visible,
            visible_outside,
        };
        self.frames.push(fe);
        fe
    }

    /// The figures of every frame added.
    pub fn summary(&self) -> Summary {
        let found: Vec<&FrameErrors> = self
            .frames
            .iter()
            .filter(|f| f.person_found && f.scored().next().is_some())
            .collect();
        let mean_of = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
        let means: Vec<f64> = found.iter().map(|f| f.mean() as f64).collect();
        let maxes: Vec<f64> = found.iter().map(|f| f.max() as f64).collect();
        let whole: Vec<f64> = found
            .iter()
            .filter(|f| f.whole())
            .map(|f| f.mean() as f64)
            .collect();
        let mut per_joint = BTreeMap::new();
        for j in Joint::ALL {
            let e: Vec<f64> = found
                .iter()
                .filter_map(|f| f.joint[j.index()])
                .map(f64::from)
                .collect();
            per_joint.insert(j.name().to_string(), mean_of(&e).map(|e| round(e * 100.0)));
        }
        let scored: Vec<f32> = self.frames.iter().flat_map(|f| f.scored()).collect();
        let within =
            scored.iter().filter(|&&e| e < 0.10).count() as f64 / scored.len().max(1) as f64;
        let mut ap = Vec::new();
        for j in 0..Joint::COUNT {
            let positives = self.frames.iter().filter(|f| f.joint[j].is_some()).count();
            if positives == 0 {
                continue;
            }
            let mut preds: Vec<(f32, bool)> = self
                .frames
                .iter()
                .filter(|f| f.person_found && f.visible[j].1)
                .map(|f| (f.confidence[j], f.joint[j].is_some_and(|e| e < 0.10)))
                .collect();
            preds.sort_by(|a, b| b.0.total_cmp(&a.0));
            ap.push(average_precision(&preds, positives));
        }
        let pairs = || self.frames.iter().flat_map(|f| f.visible.iter().copied());
        let lower = |f: &FrameErrors| Joint::LOWER.map(|j| f.visible[j.index()]);
        let lower_hidden: Vec<bool> = self
            .frames
            .iter()
            .map(lower)
            .filter(|v| v.iter().any(|v| !v.0))
            .map(|v| v.iter().all(|v| v.0 || !v.1))
            .collect();
        let out_of_view = pairs().filter(|v| !v.0).count();
        let in_view = pairs().filter(|v| v.0).count();
        let fps = if self.seconds > 0.0 {
            self.frames.len() as f64 / self.seconds
        } else {
            0.0
        };
        Summary {
            frames: self.frames.len(),
            mean_error_cm: round(mean_of(&means).unwrap_or(f64::NAN) * 100.0),
            max_error_cm: round(mean_of(&maxes).unwrap_or(f64::NAN) * 100.0),
            mean_error_whole_cm: mean_of(&whole).map(|e| round(e * 100.0)),
            frames_whole: self.frames.iter().filter(|f| f.whole()).count(),
            per_joint_cm: per_joint,
            within_10cm: round(within),
            map_10cm: round(mean_of(&ap).unwrap_or(0.0)),
            out_of_view_reported: (out_of_view > 0).then(|| {
                round(pairs().filter(|v| !v.0 && !v.1).count() as f64 / out_of_view as f64)
            }),
            lower_hidden_frames: (!lower_hidden.is_empty()).then(|| {
                round(
                    lower_hidden.iter().filter(|&&h| h).count() as f64 / lower_hidden.len() as f64,
                )
            }),
            in_view_reported: round(
                pairs().filter(|v| v.0 && v.1).count() as f64 / in_view.max(1) as f64,
            ),
            visible_outside_image: self.frames.iter().map(|f| f.visible_outside).sum(),
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
        let k = Intrinsics::default();
        ev.add(&r, &truth, &k);
        ev.add(&r, &truth, &k);
        ev.seconds = 0.5;
        let s = ev.summary();
        assert_eq!(s.frames, 2);
        assert!((s.mean_error_cm - (20.0 + 15.0 * 5.0) / 16.0).abs() < 1e-3);
        assert_eq!(s.mean_error_whole_cm, Some(s.mean_error_cm));
        assert!((s.max_error_cm - 20.0).abs() < 1e-3);
        assert!((s.per_joint_cm["head"].unwrap() - 20.0).abs() < 1e-3);
        assert!((s.within_10cm - 15.0 / 16.0).abs() < 1e-3);
        assert!((s.map_10cm - 15.0 / 16.0).abs() < 1e-3);
        assert!((s.fps - 4.0).abs() < 1e-9);
        assert_eq!(s.out_of_view_reported, None);
        assert_eq!(s.lower_hidden_frames, None);
    }

    #[test]
    fn joints_out_of_view_are_not_scored_but_their_visibility_is() {
        let mut truth = Skeleton::new([Point3::new(0.0, 0.0, 2.0); Joint::COUNT]);
        // The legs out of view; the estimate puts them 1 m off and calls two of six
        // visible, one of those outside the image.
        let legs = [10, 11, 12, 13, 14, 15];
        let mut est = truth;
        for j in legs {
            truth.visible[j] = false;
            est.joints[j] += Vector3::new(0.0, 1.0, 0.0);
            est.visible[j] = false;
        }
        est.visible[11] = true;
        est.joints[11] = Point3::new(0.0, 0.2, 2.0);
        est.visible[12] = true;
        est.joints[12] = Point3::new(0.0, 5.0, 2.0);
        est.joints[0] += Vector3::new(0.04, 0.0, 0.0);
        let r = PoseResult {
            person_found: true,
            skeleton: est,
        };
        let mut ev = PoseEval::default();
        ev.add(&r, &truth, &Intrinsics::default());
        let s = ev.summary();
        assert!((s.mean_error_cm - 4.0 / 10.0).abs() < 1e-3, "{s:?}");
        assert_eq!(s.mean_error_whole_cm, None);
        assert_eq!(s.frames_whole, 0);
        assert_eq!(s.per_joint_cm["left_foot"], None);
        assert_eq!(s.within_10cm, 1.0);
        assert!((s.out_of_view_reported.unwrap() - 4.0 / 6.0).abs() < 1e-3);
        assert_eq!(s.in_view_reported, 1.0);
        assert_eq!(s.visible_outside_image, 1);
        // Legs out of view with two of them reported visible: the frame fails.
        assert_eq!(s.lower_hidden_frames, Some(0.0));
    }

    #[test]
    fn a_frame_counts_for_lower_joints_only_when_all_its_hidden_ones_are_said_so() {
        let k = Intrinsics::default();
        let mut truth = Skeleton::new([Point3::new(0.0, 0.0, 2.0); Joint::COUNT]);
        for j in Joint::LOWER {
            truth.visible[j.index()] = false;
        }
        let frame = |reported_visible: &[Joint]| {
            let mut est = truth;
            for j in Joint::LOWER {
                est.visible[j.index()] = reported_visible.contains(&j);
            }
            PoseResult {
                person_found: true,
                skeleton: est,
            }
        };
        let mut ev = PoseEval::default();
        // Three frames with every lower joint said hidden, one with a knee said seen.
        for _ in 0..3 {
            ev.add(&frame(&[]), &truth, &k);
        }
        ev.add(&frame(&[Joint::LeftKnee]), &truth, &k);
        // A hand hidden (under a table) and said visible does not count here.
        let mut under = truth;
        under.visible[Joint::LeftHand.index()] = false;
        ev.add(&frame(&[]), &under, &k);
        // A frame with the whole body in view does not count either way.
        let whole = Skeleton::new(truth.joints);
        ev.add(&frame(&Joint::LOWER), &whole, &k);
        let s = ev.summary();
        assert_eq!(s.lower_hidden_frames, Some(0.8));
        assert!(s.out_of_view_reported.unwrap() < 1.0);
    }

    #[test]
    fn average_precision_ranks_by_confidence() {
        assert!((average_precision(&[(0.9, true), (0.5, false)], 2) - 0.5).abs() < 1e-9);
        assert!((average_precision(&[(0.9, true), (0.5, true)], 2) - 1.0).abs() < 1e-9);
        assert!((average_precision(&[(0.9, false), (0.5, true)], 1) - 0.5).abs() < 1e-9);
    }
}
