//! Each arm found by search, not by following: the registration is a local method, and
//! from a start whose arm lies elsewhere (after a geodesic maximum that was an ear, or
//! with the arm hanging against the body where no maximum marks the hand) it stays
//! there. Here every arm pose on a grid of directions is scored against the frame with
//! the rest of the body held, coarse to fine, and the best goes into a start.
//!
//! The score is the registration's own energy, kept to what an arm changes: the
//! person's points within the arm's reach, each explained by the arm or by the rest of
//! the body, whichever is nearer; the arm's front where the camera sees background
//! (pulled to the person) or sees past it (free space).

use super::capsules::{place, sphere_beyond, Placed};
use super::energy::{cauchy_cost, front_surface, huber};
use super::{Frame, RegisterConfig, Registration};
use crate::body::{shortest_turn, BodyPose, BodyTemplate, Posed, Segment};
use airglyph_core::{Joint, Skeleton};
use nalgebra::{Point3, Rotation3, Vector3};

/// One arm's segments and its hand joint.
#[derive(Debug, Clone, Copy)]
struct Arm {
    upper: Segment,
    fore: Segment,
    hand: Joint,
}

const ARMS: [Arm; 2] = [
    Arm {
        upper: Segment::LeftUpperArm,
        fore: Segment::LeftForearm,
        hand: Joint::LeftHand,
    },
    Arm {
        upper: Segment::RightUpperArm,
        fore: Segment::RightForearm,
        hand: Joint::RightHand,
    },
];

/// Directions spread evenly over the sphere (a Fibonacci lattice).
fn sphere(n: usize) -> Vec<Vector3<f32>> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let a = golden * i as f32;
            Vector3::new(r * a.cos(), y, r * a.sin())
        })
        .collect()
}

/// Directions within `angle` (radians) of `d`: `d` itself and a ring of six around it.
fn around(d: &Vector3<f32>, angle: f32) -> Vec<Vector3<f32>> {
    let any = if d.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let a = d.cross(&any).normalize();
    let b = d.cross(&a);
    let mut out = vec![*d];
    for k in 0..6 {
        let t = k as f32 * std::f32::consts::TAU / 6.0;
        out.push((d * angle.cos() + (a * t.cos() + b * t.sin()) * angle.sin()).normalize());
    }
    out
}

impl Registration {
    /// `start` with its arms moved to the best poses of a search over directions (the
    /// rest of the body as it is): each arm searched on its own and, when that puts
    /// the hands together or crossed, also the right arm searched with the left as
    /// found and the other way round. An arm searched on its own can take the other's
    /// hand, when it explains more points there than on itself (its own hanging
    /// against the body): both then hold one hand. One searched with the other held
    /// counts the other's points as explained; but two hands close together can then
    /// end swapped, each forearm on the other's points, which the energy scores as
    /// well, so the caller drops a fit of those whose hands cross ([`hands_crossed`]).
    pub fn search_arms(
        &self,
        f: &Frame,
        t: &BodyTemplate,
        start: &BodyPose,
        cfg: &RegisterConfig,
    ) -> Searched {
        let [left, right] = ARMS;
        let alone = |arm| self.search_arm(f, t, start, arm, Others::Unseen, cfg);
        let (left_alone, right_alone) = (alone(left), alone(right));
        let mut both_alone = left_alone;
        for s in [right.upper, right.fore] {
            both_alone.rotation[s.index()] = right_alone.rotation[s.index()];
        }
        // Hands found apart and uncrossed are each arm's own: the second search would
        // double the cost of a detection for nothing.
        let together = {
            let s = Posed::new(t, &both_alone).skeleton(t);
            (s[Joint::LeftHand] - s[Joint::RightHand]).norm() < TOGETHER || hands_crossed(&s)
        };
        let held = together.then(|| {
            [
                self.search_arm(f, t, &left_alone, right, Others::Held, cfg),
                self.search_arm(f, t, &right_alone, left, Others::Held, cfg),
            ]
        });
        Searched {
            alone: both_alone,
            held,
        }
    }

    fn search_arm(
        &self,
        f: &Frame,
        t: &BodyTemplate,
        start: &BodyPose,
        arm: Arm,
        other: Others,
        cfg: &RegisterConfig,
    ) -> BodyPose {
        let posed = Posed::new(t, start);
        let shoulder = posed.joint[arm.upper.index()];
        let upper_bone = t.origin[arm.fore.index()];
        let fore_bone = t.joints[arm.hand.index()].1.coords;
        let reach = upper_bone.norm() + fore_bone.norm() * 1.4 + 0.1;
        // The points the arm could explain, and how well the rest of the body does.
        let rest: Vec<Placed> = place(t, &posed)
            .into_iter()
            .filter(|c| match other {
                Others::Unseen => !is_arm(c.segment),
                Others::Held => c.segment != arm.upper && c.segment != arm.fore,
            })
            .collect();
        let sigma = cfg.energy.sigma;
        let near: Vec<Near> = self
            .data
            .iter()
            .filter(|(p, _)| (p - shoulder).norm() < reach)
            .map(|(p, area)| {
                let d_rest = rest
                    .iter()
                    .map(|c| c.nearest(p).2)
                    .fold(f32::INFINITY, f32::min);
                Near {
                    p: *p,
                    area: *area,
                    d_rest,
                    rest_cost: area * cauchy_cost(d_rest, sigma),
                }
            })
            .collect();
        let turned = |u: &Vector3<f32>, v: &Vector3<f32>| {
            let mut p = *start;
            let ru = turn_onto(&start.rotation[arm.upper.index()], &upper_bone, u);
            // The forearm keeps its twist about the upper arm's.
            let rf = turn_onto(&ru, &fore_bone, v);
            p.rotation[arm.upper.index()] = ru;
            p.rotation[arm.fore.index()] = rf;
            p
        };
        let score = |p: &BodyPose| self.arm_energy(f, t, p, arm, &near, cfg);
        // Coarse: the upper arm over the sphere, the forearm straight on or hanging.
        let down = -(posed.rotation[Segment::Chest.index()] * Vector3::y());
        let mut best: Vec<(f32, Vector3<f32>, Vector3<f32>)> = Vec::new();
        for u in sphere(40) {
            for v in [u, down, (u + down).normalize()] {
                if u.angle(&v) > 150f32.to_radians() || !v.iter().all(|c| c.is_finite()) {
                    continue;
                }
                best.push((score(&turned(&u, &v)), u, v));
            }
        }
        best.sort_by(|a, b| a.0.total_cmp(&b.0));
        best.truncate(4);
        // Finer: the forearm over the sphere for the best upper arms, then both about
        // the best pair.
        let mut found = best[0];
        for &(_, u, _) in &best {
            for v in sphere(40) {
                if u.angle(&v) > 150f32.to_radians() {
                    continue;
                }
                let e = score(&turned(&u, &v));
                if e < found.0 {
                    found = (e, u, v);
                }
            }
        }
        for angle in [0.2f32, 0.1] {
            let (_, u0, v0) = found;
            for u in around(&u0, angle) {
                for v in around(&v0, angle) {
                    if u.angle(&v) > 150f32.to_radians() {
                        continue;
                    }
                    let e = score(&turned(&u, &v));
                    if e < found.0 {
                        found = (e, u, v);
                    }
                }
            }
        }
        turned(&found.1, &found.2)
    }

    /// The part of the registration's energy an arm changes: the points near it, each
    /// on the nearer of the arm and the rest of the body, and the arm's front against
    /// the silhouette and the surface seen.
    fn arm_energy(
        &self,
        f: &Frame,
        t: &BodyTemplate,
        pose: &BodyPose,
        arm: Arm,
        near: &[Near],
        cfg: &RegisterConfig,
    ) -> f32 {
        let capsules: Vec<Placed> = place(t, &Posed::new(t, pose))
            .into_iter()
            .filter(|c| c.segment == arm.upper || c.segment == arm.fore)
            .collect();
        let sigma = cfg.energy.sigma;
        // One sphere around both capsules: most points lie nearer the rest of the
        // body than it, and cost what the search started with.
        let centre = Point3::from(
            capsules
                .iter()
                .map(|c| c.centre.coords)
                .sum::<Vector3<f32>>()
                / capsules.len().max(1) as f32,
        );
        let bound = capsules
            .iter()
            .map(|c| (c.centre - centre).norm() + c.bound)
            .fold(0.0, f32::max);
        let mut e = 0.0;
        for n in near {
            if sphere_beyond(&centre, bound, &n.p, n.d_rest) {
                e += n.rest_cost;
                continue;
            }
            let mut d = n.d_rest;
            for c in &capsules {
                if !sphere_beyond(&c.centre, c.bound, &n.p, d) {
                    d = d.min(c.nearest(&n.p).2);
                }
            }
            e += if d < n.d_rest {
                n.area * cauchy_cost(d, sigma)
            } else {
                n.rest_cost
            };
        }
        let (w, h) = (f.width as i32, f.height as i32);
        let scale = cfg.energy.silhouette_scale;
        for c in &capsules {
            for s in front_surface(c) {
                let Some((u, v)) = f.k.project(&s) else {
                    continue;
                };
                let (u, v) = (u.round() as i32, v.round() as i32);
                if u < 0 || v < 0 || u >= w || v >= h {
                    continue;
                }
                let idx = (v * w + u) as usize;
                if f.mask[idx] {
                    let z = f.points[idx].z;
                    let gap = z - s.z;
                    if z > 0.0 && gap > cfg.energy.free_space_margin {
                        let (_, cost) = huber(cfg.energy.free_space_margin - gap, scale);
                        e += cfg.energy.free_space_weight * cost;
                    }
                } else if let Some((qu, qv)) = self.nearest.get(u as usize, v as usize) {
                    let weight = if f.occluded(idx, s.z) {
                        cfg.energy.occluded_weight
                    } else {
                        1.0
                    };
                    let target = f.k.back_project(qu as f32, qv as f32, s.z);
                    let (_, cost) = huber((s - target).norm(), scale);
                    e += weight * cfg.energy.silhouette_weight * cost;
                }
            }
        }
        e
    }
}

/// A person's point within an arm's reach, with how well the rest of the body explains
/// it: its distance to the nearest other capsule's surface and the cost of that.
#[derive(Debug, Clone, Copy)]
struct Near {
    p: Point3<f32>,
    area: f32,
    d_rest: f32,
    rest_cost: f32,
}

/// Hands nearer each other than this, metres, may be one hand taken by both arms.
const TOGETHER: f32 = 0.2;

/// How far the hands may lie past each other along the shoulders' line before they
/// count as crossed, metres.
const CROSSED: f32 = 0.05;

/// The arms of [`Registration::search_arms`].
#[derive(Debug, Clone, Copy)]
pub struct Searched {
    /// Each arm searched on its own.
    pub alone: BodyPose,
    /// The right arm searched with the left held, and the left with the right, when
    /// the arms searched alone put the hands together or crossed.
    pub held: Option<[BodyPose; 2]>,
}

/// The left hand on the right of the right one, along the shoulders' line.
pub fn hands_crossed(s: &Skeleton) -> bool {
    let Some(across) = (s[Joint::LeftShoulder] - s[Joint::RightShoulder]).try_normalize(1e-6)
    else {
        return false;
    };
    (s[Joint::LeftHand] - s[Joint::RightHand]).dot(&across) < -CROSSED
}

/// Whether an arm's search counts the other arm as part of the rest of the body.
#[derive(Debug, Clone, Copy)]
enum Others {
    /// Not: its pose is the start's, which may be wrong.
    Unseen,
    /// As it is: it was searched already.
    Held,
}

fn is_arm(s: Segment) -> bool {
    ARMS.iter().any(|a| a.upper == s || a.fore == s)
}

/// `r` turned the shortest way so that its `bone` (segment frame) points along `want`.
fn turn_onto(r: &Rotation3<f32>, bone: &Vector3<f32>, want: &Vector3<f32>) -> Rotation3<f32> {
    shortest_turn(&(r * bone), want) * r
}
