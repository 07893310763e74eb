//! Where the registration starts: the tracked body, the geodesic estimate, the tracked
//! body with its strayed limbs taken from the geodesic estimate, standing side-on
//! bodies, and a start offered from outside.

use super::RegisterConfig;
use crate::body::{BodyPose, BodyTemplate, Posed, Segment};
use crate::neck::NeckBase;
use crate::Limb;
use airglyph_core::Skeleton;
use nalgebra::{Point3, Vector3};
use std::borrow::Cow;

/// A pose offered to the next frame's registration from outside, for experiments
/// that ask whether finding the pose or the energy limits the error (the truth of a
/// synthetic frame, say: `examples/devloop.rs oracle`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OfferedStart {
    /// Raced beside the estimator's own starts.
    Also(Skeleton),
    /// The only start.
    Only(Skeleton),
}

/// The starts of one frame's registration and the settings and tips they race with.
#[derive(Debug, Clone)]
pub struct Starts<'a> {
    /// Each is moved [`super::SolverConfig::race_iterations`] steps; the best goes on.
    pub poses: Vec<BodyPose>,
    /// Poses of the person's own making, not the tips': each races with only the
    /// tips that lie near its own limbs' ends.
    pub free: Vec<BodyPose>,
    /// The registration's settings for this race (the configured ones but for a person
    /// perhaps side-on).
    pub cfg: Cow<'a, RegisterConfig>,
    /// The limbs' tips the tip term pulls to.
    pub tips: [Option<Point3<f32>>; 5],
    /// The neck's base the person's outline shows, which holds the torso's height.
    pub neck: Option<NeckBase>,
}

/// The starts of a frame: the last frame's body `tracked`, the geodesic estimate
/// `geodesic` (when the seed's steps ran), the tracked body with the limbs whose tip
/// strayed taken from the geodesic estimate ([`super::RaceConfig::hybrid`]), and,
/// for a person perhaps side-on (`side_on`: the person's centroid), standing side-on
/// bodies, raced for every step and without the tips (they were assigned to the limbs
/// of the frontal body). A person found afresh is also looked for at rest on the
/// geodesic estimate's torso and on `upright` (the torso step's own, upright), if any. An
/// `offered` start is added, or replaces them all.
#[allow(clippy::too_many_arguments)]
pub fn starts<'a>(
    tpl: &BodyTemplate,
    tracked: Option<BodyPose>,
    geodesic: Option<BodyPose>,
    upright: Option<BodyPose>,
    tips: &[Option<Point3<f32>>; 5],
    side_on: Option<Point3<f32>>,
    offered: Option<OfferedStart>,
    neck: Option<NeckBase>,
    cfg: &'a RegisterConfig,
) -> Starts<'a> {
    let hybrid = tracked
        .zip(geodesic.filter(|_| cfg.race.hybrid))
        .and_then(|(prev, geo)| hybrid_start(tpl, &prev, &geo, tips, cfg));
    let mut poses: Vec<BodyPose> = [tracked, hybrid, geodesic].into_iter().flatten().collect();
    // Arms at rest lie against the body: no geodesic maximum marks their hands, and the
    // estimate sends them after whatever maximum there is; a leg's maximum may be its
    // knee, or the legs may be out of view. So a person found afresh is also looked for
    // standing straight, head upright, with either arm or both hanging or the hands
    // together ([`ArmAtRest::STARTS`]). (Raced against a tracked
    // body, these won frames they should not: tracking keeps its own starts.) Close
    // up, with the arms merged into the torso's silhouette, the estimate's torso is
    // tilted, and no local step from there reaches arms hanging: so, when asked
    // ([`super::RaceConfig::upright_rest`]), at rest on an upright torso too.
    let mut free = Vec::new();
    if let Some(geo) = geodesic.filter(|_| tracked.is_none()) {
        for body in [Some(geo), upright].iter().flatten() {
            for arms in ArmAtRest::STARTS {
                free.extend(resting(tpl, body, arms));
            }
        }
    }
    let (register_cfg, tips_now, neck) = match geodesic.zip(side_on) {
        Some((g, centroid)) => {
            poses.extend(side_on_starts(&g, &centroid));
            let mut side_on_cfg = cfg.clone();
            side_on_cfg.solver.race_iterations = cfg.solver.iterations;
            (Cow::Owned(side_on_cfg), [None; 5], None)
        }
        None => (Cow::Borrowed(cfg), *tips, neck),
    };
    match offered {
        Some(OfferedStart::Also(s)) => free.extend(BodyPose::from_skeleton(tpl, &s)),
        Some(OfferedStart::Only(s)) => {
            if let Some(b) = BodyPose::from_skeleton(tpl, &s) {
                poses = vec![b];
                free.clear();
            }
        }
        None => {}
    }
    Starts {
        poses,
        free,
        cfg: register_cfg,
        tips: tips_now,
        neck,
    }
}

/// Starts for a person who may be side-on: standing, arms hanging, turned a quarter
/// either way from the camera, about the person's centroid a little behind its surface,
/// upright as the geodesic estimate's pelvis. The seed's torso step fits its frontal
/// model to a flank and nothing later turns the body by a quarter; from these the
/// registration's energy tells the two apart (a side-on person's energy is lower for
/// the side-on start than for the frontal one).
fn side_on_starts(geodesic: &BodyPose, centroid: &Point3<f32>) -> [BodyPose; 2] {
    // The centroid of the surface the camera sees lies in front of the body's axis.
    const BEHIND_SURFACE: f32 = 0.05;
    let up = geodesic.rotation[Segment::Pelvis.index()] * Vector3::y();
    [1.0f32, -1.0].map(|side| {
        let toward = Vector3::new(0.0, 0.0, side);
        let x = (toward - up * up.dot(&toward))
            .try_normalize(1e-6)
            .unwrap_or(toward);
        let r = nalgebra::Rotation3::from_basis_unchecked(&[x, up, x.cross(&up)]);
        BodyPose {
            pelvis: centroid + Vector3::new(0.0, 0.0, BEHIND_SURFACE),
            rotation: [r; Segment::COUNT],
        }
    })
}

/// The tracked body `prev` with every limb whose tip strayed (lies farther than
/// [`super::RaceConfig::gap`] from the geodesic maximum given to it) taken from the
/// geodesic estimate `geo`: an arm dropped from a T-pose within a frame, say, while the
/// rest is tracked well. None when no tip strayed.
fn hybrid_start(
    tpl: &BodyTemplate,
    prev: &BodyPose,
    geo: &BodyPose,
    tips: &[Option<Point3<f32>>; 5],
    cfg: &RegisterConfig,
) -> Option<BodyPose> {
    let posed = Posed::new(tpl, prev);
    let mut h = *prev;
    let mut changed = false;
    for l in Limb::ALL {
        let (seg, local) = tpl.tips[l.index()];
        if tips[l.index()].is_some_and(|m| (posed.point(seg, &local) - m).norm() > cfg.race.gap) {
            h = h.with_limb_of(geo, l);
            changed = true;
        }
    }
    changed.then_some(h)
}

/// Where a start puts an arm of a person at rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ArmAtRest {
    /// Where the geodesic estimate has it.
    Estimated,
    /// Hanging along the body down from the shoulder, a little out from the side, the
    /// elbow a little bent.
    Hanging,
    /// The upper arm down and a little in, the forearm down, forward and in: the hands
    /// together before the lap (a heavy body's arms rest so, around the belly).
    Clasped,
}

impl ArmAtRest {
    /// The arm pairs (left, right) a person found afresh is also looked for in.
    const STARTS: [[ArmAtRest; 2]; 5] = {
        use ArmAtRest::*;
        [
            [Estimated, Estimated],
            [Hanging, Hanging],
            [Hanging, Estimated],
            [Estimated, Hanging],
            [Clasped, Clasped],
        ]
    };
}

/// `geo` standing straight, with the left (`arms[0]`) and right (`arms[1]`) arm at rest
/// as asked.
fn resting(tpl: &BodyTemplate, geo: &BodyPose, arms: [ArmAtRest; 2]) -> Option<BodyPose> {
    use airglyph_core::Joint;
    let mut s = Posed::new(tpl, geo).skeleton(tpl);
    let down = (s[Joint::Pelvis] - s[Joint::Neck]).try_normalize(1e-6)?;
    let left = s[Joint::LeftHip] - s[Joint::RightHip];
    let left = (left - down * down.dot(&left)).try_normalize(1e-6)?;
    // The body's frame is (left, up, forward), right-handed.
    let forward = down.cross(&left);
    // Standing straight, the head upright: the geodesic estimate tilts it onto the
    // shoulder when the head's maximum lies beside its top (an ear, a cheek).
    let neck_to_head = (s[Joint::Head] - s[Joint::Neck]).norm();
    s.set(Joint::Head, s[Joint::Neck] - down * neck_to_head);
    for (hip, knee, foot, shin) in [
        (
            Joint::LeftHip,
            Joint::LeftKnee,
            Joint::LeftFoot,
            Segment::LeftShin,
        ),
        (
            Joint::RightHip,
            Joint::RightKnee,
            Joint::RightFoot,
            Segment::RightShin,
        ),
    ] {
        let thigh_len = tpl.origin[shin.index()].norm();
        let shin_len = tpl.joints[foot.index()].1.coords.norm();
        let k = s[hip] + down * thigh_len;
        s.set(knee, k);
        s.set(foot, k + down * shin_len);
    }
    for ((side, (shoulder, elbow, hand, fore)), arm) in [
        (
            1.0f32,
            (
                Joint::LeftShoulder,
                Joint::LeftElbow,
                Joint::LeftHand,
                Segment::LeftForearm,
            ),
        ),
        (
            -1.0,
            (
                Joint::RightShoulder,
                Joint::RightElbow,
                Joint::RightHand,
                Segment::RightForearm,
            ),
        ),
    ]
    .into_iter()
    .zip(arms)
    {
        let upper_len = tpl.origin[fore.index()].norm();
        let fore_len = tpl.joints[hand.index()].1.coords.norm();
        let out = left * side;
        let (upper, forearm) = match arm {
            ArmAtRest::Estimated => continue,
            ArmAtRest::Hanging => (down + out * 0.15, down + out * 0.1),
            ArmAtRest::Clasped => (
                down + forward * 0.1 - out * 0.2,
                down + forward * 0.3 - out * 0.3,
            ),
        };
        let e = s[shoulder] + upper.normalize() * upper_len;
        s.set(elbow, e);
        s.set(hand, e + forearm.normalize() * fore_len);
    }
    BodyPose::from_skeleton(tpl, &s)
}
