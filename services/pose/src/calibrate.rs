//! Body-size calibration: the person's arm and leg lengths, learned from the geodesic
//! lengths of their limbs while they move.
//!
//! The bone lengths of [`BodyConfig::default`] are one body's. A longer-armed person's
//! hand then lies beyond the fitted chain's reach, and a geodesic maximum on a knee can
//! look more like a foot than the foot does. The geodesic length of a limb, from its
//! root to its extremity, hardly changes as the limb bends, so each frame in which a
//! limb is assigned a maximum measures the limb. Occlusion and bridges over occluding
//! foreground only ever shorten such a path, and a wrong assignment to a nearer maximum
//! too, so the estimate is a high percentile of recent measurements, not their mean.
//!
//! Once the articulated registration runs, it refines the lengths instead: one ratio a
//! limb pair for the whole reach and, for the arms only and when
//! [`crate::config::LengthsConfig::bone_evidence`] is set, the split between upper arm
//! and forearm, from the frames whose bent elbow tells the two bones apart (a straight
//! limb cannot; legs are rarely seen bent enough, so they keep one ratio).

use crate::body::{limb_segments, rotation_vector, BodyConfig, BodyPose, BodyTemplate, Posed};
use crate::register::{distance_off_others, place, Fit, LengthsConfig, PriorsConfig};
use crate::Limb;
use nalgebra::Point3;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Settings of the body-size calibration (part of [`crate::PoseConfig`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CalibrateConfig {
    /// Learn the person's arm and leg lengths instead of keeping
    /// [`crate::body::BodyConfig`]'s.
    pub enabled: bool,
    /// What the geodesic measurement gives on the body the bone lengths were measured on
    /// (arms, legs): the geodesic path over the surface, fingers and toes is longer than
    /// the bones. Measured on the MakeHuman body standing, drawing and walking.
    pub geodesic_reach_ratio: [f32; 2],
}

impl Default for CalibrateConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            geodesic_reach_ratio: [1.32, 1.21],
        }
    }
}

/// How many measurements each length remembers (about four seconds at 30 fps of
/// both limbs of a pair).
const WINDOW: usize = 240;
/// Measurements needed before the length departs from the default.
const MIN_SAMPLES: usize = 20;
/// The percentile taken: measurements shortened by occlusion or bridges fall below it.
const PERCENTILE: f32 = 0.8;
/// Bounds on the ratio to the default body: children to tall adults, and no runaway
/// when the measurements are poor.
const MIN_RATIO: f32 = 0.75;
const MAX_RATIO: f32 = 1.4;
/// Bound on the log of the upper arm's ratio over the forearm's (about ±20 %).
const MAX_SPLIT: f32 = 0.2;

/// The last [`WINDOW`] values a frame asked for.
#[derive(Debug, Clone, Default)]
struct Recent(VecDeque<f32>);

impl Recent {
    fn push(&mut self, x: f32) {
        if self.0.len() == WINDOW {
            self.0.pop_front();
        }
        self.0.push_back(x);
    }

    fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The `q` quantile (0.5: the median), or None before [`MIN_SAMPLES`] values.
    fn quantile(&self, q: f32) -> Option<f32> {
        if self.0.len() < MIN_SAMPLES {
            return None;
        }
        let mut v: Vec<f32> = self.0.iter().copied().collect();
        let k = ((v.len() - 1) as f32 * q).round() as usize;
        let (_, x, _) = v.select_nth_unstable_by(k, f32::total_cmp);
        Some(*x)
    }
}

/// The ratio of one limb pair's length to the default body's.
#[derive(Debug, Clone, Default)]
struct PairRatio {
    samples: Recent,
    /// The registration's estimates (the ratio each frame's fit asks for); once there
    /// are any, the geodesic samples are not used.
    fitted: Recent,
    /// What the person's arms were seen to reach at least ([`arms_reaching`]): a
    /// straight line from shoulder to fingertip is never longer than the arm, bent or
    /// not, so no frame asks for less. 0 until seen.
    floor: f32,
}

impl PairRatio {
    fn add(&mut self, ratio: f32) {
        if ratio.is_finite() && (0.3..3.0).contains(&ratio) {
            self.samples.push(ratio);
        }
    }

    fn refine(&mut self, step: f32) {
        if step.is_finite() {
            // The ratio this frame asks for: the one it was fitted with, moved by its
            // step.
            self.fitted
                .push(self.ratio() * (1.0 + step.clamp(-0.2, 0.2)));
        }
    }

    fn ratio(&self) -> f32 {
        let learned = if self.fitted.is_empty() {
            self.samples.quantile(PERCENTILE)
        } else {
            // The median: a bad stretch of frames (a limb mistaken for another, a
            // person half out of view) cannot drag it.
            self.fitted.quantile(0.5)
        };
        learned
            .map_or(1.0, |x| x.clamp(MIN_RATIO, MAX_RATIO))
            .max(self.floor.min(MAX_RATIO))
    }
}

/// The learned arm and leg lengths of the person in view, as ratios to the default
/// body's.
#[derive(Debug, Clone, Default)]
pub struct BodyCalibration {
    arms: PairRatio,
    legs: PairRatio,
    /// The collarbones' rest turns against the chest (left, right), rotation vectors.
    collars: [[f32; 3]; 2],
    /// What frames that tell an arm's bones apart asked for the log of the upper arm's
    /// ratio over the forearm's ([`Self::refine_arm_bones`]).
    arm_split: Recent,
}

impl BodyCalibration {
    /// Records one frame's geodesic length (metres, from the limb root to the assigned
    /// maximum) of a limb; `base` is the body the ratios refer to.
    pub fn measure(
        &mut self,
        cfg: &CalibrateConfig,
        base: &BodyConfig,
        limb: Limb,
        geodesic_length: f32,
    ) {
        let (l1, l2) = base.bones(limb);
        let reach = l1 + l2 + base.extremity_extra(limb);
        let [arm_ref, leg_ref] = cfg.geodesic_reach_ratio;
        match limb {
            Limb::LeftArm | Limb::RightArm => self.arms.add(geodesic_length / reach / arm_ref),
            Limb::LeftLeg | Limb::RightLeg => self.legs.add(geodesic_length / reach / leg_ref),
            Limb::Head => {}
        }
    }

    /// Records the registration's relative length steps of a frame
    /// ([`crate::register::Fit::length_step`]): each asks for the ratio it was fitted
    /// with times (1 + step), and the ratios become the median of what recent frames
    /// asked for. Once refined, a ratio follows the registration only.
    pub fn refine(&mut self, steps: [Option<f32>; 2]) {
        if let Some(s) = steps[0] {
            self.arms.refine(s);
        }
        if let Some(s) = steps[1] {
            self.legs.refine(s);
        }
    }

    /// Records the registration's steps of one arm's upper arm and forearm apart
    /// ([`crate::register::Fit::arm_bone_steps`], from frames with the elbow bent): each
    /// asks for the split it was fitted with, moved by the difference of its steps.
    /// People's upper arms and forearms are not in one proportion (the procedural
    /// body's are not the template's); one ratio for
    /// the whole reach leaves the elbow short, and the arm then reaches its hand by
    /// turning the chest. Legs keep one ratio: they are seen bent too rarely.
    pub fn refine_arm_bones(&mut self, steps: [f32; 2]) {
        if !steps.iter().all(|s| s.is_finite()) {
            return;
        }
        let [s1, s2] = steps.map(|s| (1.0 + s.clamp(-0.2, 0.2)).ln());
        self.arm_split.push(self.arm_split().ln() + s1 - s2);
    }

    /// The ratio of the person's upper arm to forearm over the default body's; 1 until
    /// enough has been seen.
    pub fn arm_split(&self) -> f32 {
        self.arm_split
            .quantile(0.5)
            .map_or(1.0, |x| x.clamp(-MAX_SPLIT, MAX_SPLIT).exp())
    }

    /// The ratio of the person's arms (and legs) to the default body's; 1 until enough
    /// has been seen.
    pub fn arm_ratio(&self) -> f32 {
        self.arms.ratio()
    }

    pub fn leg_ratio(&self) -> f32 {
        self.legs.ratio()
    }

    /// Holds the arms at least `ratio` times the default body's from now on: a frame
    /// showed them reaching that far ([`arms_reaching`]).
    pub fn arms_at_least(&mut self, ratio: f32) {
        if ratio.is_finite() {
            self.arms.floor = self.arms.floor.max(ratio.min(MAX_RATIO));
        }
    }

    /// Moves the collarbones' rest turns a share `gain` of the way to the turns of the
    /// frame's fit (rotation vectors against the chest, left and right): a person's
    /// shoulders sit higher or lower than the template's, which the collarbone prior
    /// would otherwise hold them to.
    pub fn refine_collars(&mut self, fitted: [[f32; 3]; 2], gain: f32) {
        for (rest, f) in self.collars.iter_mut().zip(fitted) {
            if f.iter().all(|x| x.is_finite()) {
                for (r, x) in rest.iter_mut().zip(f) {
                    *r = (*r + gain * (x.clamp(-0.5, 0.5) - *r)).clamp(-0.5, 0.5);
                }
            }
        }
    }

    /// The bone lengths of `body` scaled to this person, and its collarbones' rest put
    /// in `priors`: the two sections of the settings the calibration changes, handed
    /// over alone (the settings gather this module's [`CalibrateConfig`]).
    pub fn apply(&self, body: &mut BodyConfig, priors: &mut PriorsConfig) {
        let (a, l) = (self.arm_ratio(), self.leg_ratio());
        // The split moves the elbow along the arm and keeps the reach (to first order).
        let (u, f) = (body.upper_arm, body.forearm);
        let k = self.arm_split();
        body.upper_arm = u * a * k.powf(f / (u + f));
        body.forearm = f * a * k.powf(-u / (u + f));
        body.thigh *= l;
        body.shin *= l;
        priors.collar_rest = self.collars;
    }

    /// Learns from a registered body `b`: the limb lengths (and the collarbones' rest)
    /// its frame asks for, from frames whose limbs the camera sees well (`cfg`: how
    /// well, and how fast the collarbones follow).
    pub fn learn(&mut self, b: &Fit, cfg: &LengthsConfig) {
        use crate::body::Segment::{self, *};
        let seen = |segs: &[Segment]| {
            segs.iter().map(|s| b.seen[s.index()]).sum::<f32>() / segs.len() as f32
        };
        let gate = cfg.seen;
        let arms = seen(&[LeftUpperArm, LeftForearm, RightUpperArm, RightForearm]);
        let legs = seen(&[LeftThigh, LeftShin, RightThigh, RightShin]);
        self.refine([
            b.length_step[0].filter(|_| arms >= gate),
            b.length_step[1].filter(|_| legs >= gate),
        ]);
        for (steps, upper, fore) in [
            (b.arm_bone_steps[0], LeftUpperArm, LeftForearm),
            (b.arm_bone_steps[1], RightUpperArm, RightForearm),
        ] {
            if let Some(s) = steps.filter(|_| seen(&[upper, fore]) >= gate) {
                self.refine_arm_bones(s);
            }
        }
        if arms >= gate {
            let rel = |s: Segment| {
                let r = b.pose.rotation[Chest.index()].inverse() * b.pose.rotation[s.index()];
                let v = rotation_vector(&r);
                [v.x, v.y, v.z]
            };
            self.refine_collars([rel(LeftCollar), rel(RightCollar)], cfg.collar_gain);
        }
    }

    /// Forgets the person (another may step in).
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

/// How far an arm's end may lie off the line from its fitted shoulder through its
/// fitted fingertip and still count as its own (metres): about a forearm's thickness.
/// Farther, the maximum may be another part's (the torso's, cut by the image's edge
/// between hanging arms).
const REACH_OFF_LINE: f32 = 0.08;

/// An arm's end this near the surface of another part of the fitted body (metres) may
/// be that part's: far away, arms hanging against the body are given maxima on the
/// thighs, along the arms' line below the hands.
const ON_ANOTHER_PART: f32 = 0.03;

/// The factor the arms of `tpl` must at least be lengthened by for the arms' ends seen
/// (`ends`, the limbs' geodesic maxima, at a cut or not) to lie within reach of the
/// shoulders of the body fitted at `pose`: the greatest, over the arms whose end lies
/// along their fitted arm, of the end's distance from the shoulder over the arm's
/// straight reach, shoulder to fingertip. A straight line is a lower bound on the arm's
/// length however the elbow bends, and the arm goes on beyond a cut, so this holds for
/// any pose. None when no arm's end lies along it.
///
/// A single frame learns nothing else of the arms' length: the data term explains a
/// hanging hand's points beyond a short arm as outliers, and a race over lengths cannot
/// tell them apart (pose NOTES).
pub fn arms_reaching(
    tpl: &BodyTemplate,
    pose: &BodyPose,
    ends: &[Option<Point3<f32>>; 5],
) -> Option<f32> {
    let posed = Posed::new(tpl, pose);
    let placed = place(tpl, &posed);
    [Limb::LeftArm, Limb::RightArm]
        .into_iter()
        .filter_map(|l| {
            let end = ends[l.index()]?;
            let &[upper, fore] = limb_segments(l) else {
                return None;
            };
            let (seg, local) = tpl.tips[l.index()];
            debug_assert_eq!(seg, fore);
            let shoulder = posed.joint[upper.index()];
            let to_end = end - shoulder;
            let along = (posed.point(seg, &local) - shoulder).try_normalize(1e-6)?;
            let off_line = (to_end - along * to_end.dot(&along)).norm();
            let reach = tpl.origin[fore.index()].norm() + local.coords.norm();
            let off_others = distance_off_others(&placed, &end, limb_segments(l));
            (off_others >= ON_ANOTHER_PART
                && to_end.dot(&along) > 0.0
                && off_line <= REACH_OFF_LINE)
                .then(|| to_end.norm() / reach)
        })
        .reduce(f32::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `base` with the bone lengths scaled by `c`.
    fn scaled_by(c: &BodyCalibration, base: &BodyConfig) -> BodyConfig {
        let mut body = base.clone();
        c.apply(&mut body, &mut PriorsConfig::default());
        body
    }

    #[test]
    fn default_until_enough_samples_then_the_high_percentile() {
        let (cfg, base) = (CalibrateConfig::default(), BodyConfig::default());
        let mut c = BodyCalibration::default();
        let (l1, l2) = base.bones(Limb::LeftArm);
        // What the configured body itself would measure.
        let reach = (l1 + l2 + base.extremity_extra(Limb::LeftArm)) * cfg.geodesic_reach_ratio[0];
        for _ in 0..MIN_SAMPLES - 1 {
            c.measure(&cfg, &base, Limb::LeftArm, reach * 1.2);
        }
        assert_eq!(c.arm_ratio(), 1.0);
        c.measure(&cfg, &base, Limb::RightArm, reach * 1.2);
        assert!((c.arm_ratio() - 1.2).abs() < 1e-4);
        // Shortened paths (occlusion, bridges) below the percentile do not pull it down.
        for _ in 0..MIN_SAMPLES / 2 {
            c.measure(&cfg, &base, Limb::LeftArm, reach * 0.5);
        }
        assert!((c.arm_ratio() - 1.2).abs() < 1e-4);
        assert_eq!(c.leg_ratio(), 1.0, "the legs are measured apart");
        let scaled = scaled_by(&c, &base);
        assert!((scaled.upper_arm - base.upper_arm * 1.2).abs() < 1e-5);
        assert_eq!(scaled.thigh, base.thigh);
    }

    #[test]
    fn bounded_and_deaf_to_nonsense() {
        let (cfg, base) = (CalibrateConfig::default(), BodyConfig::default());
        let mut c = BodyCalibration::default();
        for _ in 0..100 {
            c.measure(&cfg, &base, Limb::LeftLeg, 10.0);
            c.measure(&cfg, &base, Limb::LeftLeg, f32::NAN);
        }
        assert_eq!(c.leg_ratio(), 1.0);
        for _ in 0..100 {
            c.measure(&cfg, &base, Limb::LeftLeg, 0.5 * 0.95);
        }
        assert_eq!(c.leg_ratio(), MIN_RATIO);
    }

    #[test]
    fn an_end_beyond_an_arm_it_lies_along_asks_for_that_much_more_arm() {
        use crate::body::{Segment, Shape};
        use nalgebra::{Rotation3, Vector3};
        use std::f32::consts::FRAC_PI_2;
        let tpl = BodyTemplate::new(&Shape::makehuman(), &BodyConfig::default());
        // Facing the camera 2.5 m away (camera y down), both arms held out straight
        // to the sides, where nothing else of the body lies beyond the hands.
        let r = Rotation3::from_basis_unchecked(&[Vector3::x(), -Vector3::y(), -Vector3::z()]);
        let out = |a: f32| r * Rotation3::from_axis_angle(&Vector3::z_axis(), a);
        let mut rotation = [r; Segment::COUNT];
        for (s, a) in [
            (Segment::LeftUpperArm, FRAC_PI_2),
            (Segment::LeftForearm, FRAC_PI_2),
            (Segment::RightUpperArm, -FRAC_PI_2),
            (Segment::RightForearm, -FRAC_PI_2),
        ] {
            rotation[s.index()] = out(a);
        }
        let pose = BodyPose {
            pelvis: Point3::new(0.0, 0.1, 2.5),
            rotation,
        };
        let posed = Posed::new(&tpl, &pose);
        // The point `k` times the arm's reach from its shoulder, along the arm.
        let along = |l: Limb, k: f32| {
            let &[upper, _] = limb_segments(l) else {
                unreachable!()
            };
            let (seg, local) = tpl.tips[l.index()];
            let shoulder = posed.joint[upper.index()];
            Some(shoulder + (posed.point(seg, &local) - shoulder) * k)
        };
        let mut ends = [None; 5];
        assert_eq!(arms_reaching(&tpl, &pose, &ends), None, "no end seen");
        ends[Limb::LeftArm.index()] = along(Limb::LeftArm, 1.25);
        let k = arms_reaching(&tpl, &pose, &ends).unwrap();
        assert!((k - 1.25).abs() < 0.01, "{k}");
        // A nearer end asks for less; the longer of the two arms' asks wins.
        ends[Limb::RightArm.index()] = along(Limb::RightArm, 0.9);
        assert!((arms_reaching(&tpl, &pose, &ends).unwrap() - 1.25).abs() < 0.01);
        ends[Limb::LeftArm.index()] = None;
        assert!((arms_reaching(&tpl, &pose, &ends).unwrap() - 0.9).abs() < 0.01);
        // An end well off the arm's line is not taken for its own, nor one behind the
        // shoulder.
        ends = [None; 5];
        ends[Limb::LeftArm.index()] =
            along(Limb::LeftArm, 1.2).map(|p| p + Vector3::new(0.0, 0.1, 0.0));
        assert_eq!(arms_reaching(&tpl, &pose, &ends), None);
        ends[Limb::LeftArm.index()] = along(Limb::LeftArm, -1.2);
        assert_eq!(arms_reaching(&tpl, &pose, &ends), None);
        // Nor one on another part of the body: an arm hanging at the side, its line
        // running on down the thigh.
        let hanging = BodyPose {
            rotation: [r; Segment::COUNT],
            ..pose
        };
        let posed = Posed::new(&tpl, &hanging);
        let shoulder = posed.joint[Segment::LeftUpperArm.index()];
        let (seg, local) = tpl.tips[Limb::LeftArm.index()];
        let on_the_thigh = shoulder + (posed.point(seg, &local) - shoulder) * 1.3;
        ends[Limb::LeftArm.index()] = Some(on_the_thigh);
        assert_eq!(arms_reaching(&tpl, &hanging, &ends), None);
    }

    #[test]
    fn arms_held_at_least_as_long_as_seen_until_the_person_is_forgotten() {
        let mut c = BodyCalibration::default();
        c.arms_at_least(1.2);
        c.arms_at_least(1.1);
        assert!((c.arm_ratio() - 1.2).abs() < 1e-6, "the longest seen holds");
        for _ in 0..100 {
            c.refine([Some(-0.2), None]);
        }
        assert!((c.arm_ratio() - 1.2).abs() < 1e-6, "no fit asks for less");
        c.arms_at_least(5.0);
        assert_eq!(c.arm_ratio(), MAX_RATIO);
        assert_eq!(c.leg_ratio(), 1.0);
        c.reset();
        assert_eq!(c.arm_ratio(), 1.0);
    }

    #[test]
    fn bent_arms_split_the_bones_and_keep_the_reach() {
        let base = BodyConfig::default();
        let mut c = BodyCalibration::default();
        // Frames asking for a longer upper arm and a shorter forearm.
        for _ in 0..MIN_SAMPLES - 1 {
            c.refine_arm_bones([0.02, -0.02]);
        }
        assert_eq!(c.arm_split(), 1.0, "not before enough frames");
        for _ in 0..200 {
            c.refine_arm_bones([0.02, -0.02]);
            c.refine_arm_bones([f32::NAN, 0.0]);
        }
        assert!(c.arm_split() > 1.1, "{}", c.arm_split());
        assert!(c.arm_split() <= MAX_SPLIT.exp() + 1e-6);
        let scaled = scaled_by(&c, &base);
        assert!(scaled.upper_arm > base.upper_arm && scaled.forearm < base.forearm);
        let reach = |p: &BodyConfig| p.upper_arm + p.forearm;
        assert!((reach(&scaled) / reach(&base) - 1.0).abs() < 0.01);
        assert_eq!((scaled.thigh, scaled.shin), (base.thigh, base.shin));
    }
}
