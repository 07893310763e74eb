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

use crate::body::{rotation_vector, BodyConfig};
use crate::register::{Fit, LengthsConfig, PriorsConfig};
use crate::Limb;
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
        learned.map_or(1.0, |x| x.clamp(MIN_RATIO, MAX_RATIO))
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
