//! Articulated registration: the body template ([`crate::body`]) fitted to the person's
//! points by Gauss–Newton, beyond the seed.
//!
//! The seed's limbs are two-joint chains fitted one by one to target points around a
//! geodesic path, on a torso registered alone; a torso model that turns a few degrees
//! when an arm is raised before the chest, or slides along its own axis, then carries
//! every key point with it. Here the whole body is fitted at once, from the geodesic
//! estimate and from the last frame's fit, whichever explains the frame better:
//!
//! * data term: every sampled person point lies on the surface of the nearest capsule
//!   (signed distance, Cauchy-weighted so points the body does not explain — a bag, a
//!   second person's arm — cannot drag it);
//! * silhouette term: the body's front surface, seen from the camera, projects onto the
//!   person's pixels (a limb outside them is pulled to the nearest one);
//! * free-space term: where the camera sees a surface behind the body's front, the body
//!   cannot be (it would hide that surface);
//! * extremity term: the limbs' tips near the geodesic maxima assigned to them.
//!
//! Bone lengths and the torso's shape are fixed by the template, so no step can stretch
//! a limb or shear the torso. The unknowns are the pelvis position and a rotation per
//! segment (36 numbers); a step moves each segment by a twist that is linear in them, so
//! the normal equations are accumulated per segment (6×6) and assembled once.

mod arm_search;
mod capsules;
mod config;
mod energy;
mod priors;
mod sampling;
mod solver;
mod starts;
#[cfg(test)]
mod tests;
mod tips;

pub(crate) use capsules::{distance_off_others, nearest_is, place, Placed};
pub use config::{
    EnergyConfig, LengthsConfig, PriorsConfig, RaceConfig, RegisterConfig, SamplingConfig,
    SolverConfig,
};
pub use priors::hidden_limbs;
pub use starts::{starts, OfferedStart, Starts};
pub use tips::{drop_borrowed_tips, tips_strayed};

use crate::body::{BodyPose, BodyTemplate, Segment};
use crate::neck::NeckBase;
use nalgebra::{Point3, SMatrix, SVector};
use sampling::NearestPixel;

/// Unknowns of a step: the pelvis's translation, then a rotation per segment.
pub(super) const N: usize = 3 + 3 * Segment::COUNT;
pub(super) type Normal = SMatrix<f64, N, N>;
pub(super) type Gradient = SVector<f64, N>;
pub(super) type Local = SMatrix<f64, 6, 6>;

pub use crate::view::Frame;

/// The result of one registration.
#[derive(Debug, Clone, Copy)]
pub struct Fit {
    pub pose: BodyPose,
    /// The robust energy at the end (lower explains the frame better).
    pub energy: f32,
    /// The part of `energy` the guides make, not evidence of the fit: the tips' term
    /// (a maximum given to the wrong limb costs the right pose) and the neck's base's
    /// (it holds the torso's height; which arms a start has is for the frame to say).
    pub guide_energy: f32,
    /// Per segment, the share of its front surface the camera sees where the body puts
    /// it (1 = all of it; hidden or contradicted parts lower it).
    pub seen: [f32; Segment::COUNT],
    /// The change of the arms' and the legs' length ratio that would explain the frame
    /// best (one Gauss–Newton step at the final pose), when the frame says enough.
    pub length_step: [Option<f32>; 2],
    /// Per arm (left, right): the change of the upper arm's and the forearm's length
    /// ratios apart that would explain the frame best, only when the frame tells the
    /// two bones apart (a bent elbow; see `bone_steps`).
    pub arm_bone_steps: [Option<[f32; 2]>; 2],
    /// Passes over the data this fit took (all starts).
    pub passes: usize,
}

/// Reusable state: the sampled data and the nearest-person-pixel map of a frame.
#[derive(Debug, Default)]
pub struct Registration {
    /// Sampled person points and the number of pixels each stands for.
    data: Vec<(Point3<f32>, f32)>,
    nearest: NearestPixel,
}

/// What one registration fits, to what, and how.
pub(super) struct Problem<'a> {
    pub(super) frame: &'a Frame<'a>,
    pub(super) body: &'a BodyTemplate,
    pub(super) tips: &'a [Option<Point3<f32>>; 5],
    /// The neck's base the outline shows.
    pub(super) neck: Option<&'a NeckBase>,
    /// Per segment, how hidden it was last frame (1 − seen, squared): what the pull
    /// towards hanging acts on.
    pub(super) hidden: &'a [f32; Segment::COUNT],
    pub(super) cfg: &'a RegisterConfig,
}

/// What a pass over the data does besides the normal equations.
#[derive(Debug, Clone, Copy)]
pub(super) struct Pass {
    /// Search every point's nearest capsule (else keep the last pass's).
    pub(super) search: bool,
    /// Sum the energy (only the last pass of a run needs it).
    pub(super) energy: bool,
}

/// Passes between two nearest-capsule searches.
pub(super) const REASSIGN: usize = 2;

impl Registration {
    /// How many person points the data term uses.
    pub fn data_len(&self) -> usize {
        self.data.len()
    }

    /// Fits the body from the best of several starts: each is moved
    /// [`SolverConfig::race_iterations`] steps, and the one whose energy is then
    /// lowest goes on to [`SolverConfig::iterations`] in all, with the settings and the
    /// tips of `s` (per limb of [`crate::Limb::ALL`], the geodesic maximum assigned to
    /// it, camera frame, if any). Its `free` starts race with only the tips near their own limbs' ends, and the
    /// starts are judged without the tips' term: a tip is a guide, not evidence. With
    /// `search`, the arms are also searched for on the winner of the starts
    /// ([`Registration::search_arms`]: each arm alone and, when that puts the hands
    /// together, each with the other held), each result then racing once more (as a
    /// free start).
    /// `None` without a start.
    pub fn fit(
        &self,
        f: &Frame,
        t: &BodyTemplate,
        s: &Starts,
        hidden: &[f32; Segment::COUNT],
        search: bool,
    ) -> Option<Fit> {
        let (starts, free, tips, cfg) = (&s.poses[..], &s.free[..], &s.tips, &*s.cfg);
        let problem = Problem {
            frame: f,
            body: t,
            tips,
            neck: s.neck.as_ref(),
            hidden,
            cfg,
        };
        if let ([only], [], false) = (starts, free, search) {
            return Some(self.run(&problem, *only, cfg.solver.iterations, true));
        }
        let race = cfg
            .solver
            .race_iterations
            .clamp(1, cfg.solver.iterations.max(1));
        let mut best: Option<Fit> = None;
        let mut passes = 0;
        // The starts race on their whole energy, the tips' pull with it. (Racing on
        // the frame's evidence alone, without the tips, lost the drawing hand before
        // the chest for seconds at a time: the frame hardly tells that forearm from
        // one hanging, its hand's maximum does.)
        let evidence = |f: &Fit| {
            if search {
                f.energy - f.guide_energy
            } else {
                f.energy
            }
        };
        // A tip far from a pose's limb end is not that limb's for it: each start races
        // with the tips it agrees with.
        let agreeing = |pose: &BodyPose| {
            let posed = crate::body::Posed::new(t, pose);
            let mut kept = *tips;
            for (tip, (seg, local)) in kept.iter_mut().zip(&t.tips) {
                if tip.is_some_and(|m| (posed.point(*seg, local) - m).norm() > cfg.race.gap) {
                    *tip = None;
                }
            }
            kept
        };
        let followers = starts.iter().map(|s| (s, *tips));
        let free = free.iter().map(|s| (s, agreeing(s)));
        for (&s, own) in followers.chain(free) {
            // Each start's energy at its own final pose: the energy before the last
            // step would favour the start that moved least.
            let fit = self.run(
                &Problem {
                    tips: &own,
                    ..problem
                },
                s,
                race,
                true,
            );
            passes += fit.passes;
            if best.is_none_or(|b| evidence(&fit) < evidence(&b)) {
                best = Some(fit);
            }
        }
        let mut b = best?;
        // The arms searched for on the winner's body (its torso by now fitted): a
        // local method keeps an arm where its start put it.
        if search {
            let searched = self.search_arms(f, t, &b.pose, cfg);
            // A held search's fit whose hands end crossed has each forearm on the
            // other's points: not a pose the search was for.
            let held_poses = searched.held.into_iter().flatten().map(|p| (p, true));
            for (pose, held) in std::iter::once((searched.alone, false)).chain(held_poses) {
                let own = agreeing(&pose);
                let fit = self.run(
                    &Problem {
                        tips: &own,
                        ..problem
                    },
                    pose,
                    race,
                    true,
                );
                passes += fit.passes;
                let crossed = held
                    && arm_search::hands_crossed(
                        &crate::body::Posed::new(t, &fit.pose).skeleton(t),
                    );
                if !crossed && evidence(&fit) < evidence(&b) {
                    b = fit;
                }
            }
        }
        let kept = agreeing(&b.pose);
        let problem = Problem {
            tips: &kept,
            ..problem
        };
        let mut fit = self.run(
            &problem,
            b.pose,
            cfg.solver.iterations.saturating_sub(race),
            true,
        );
        fit.passes += passes;
        Some(fit)
    }
}
