//! The procedural hand as solids: a palm of metacarpal capsules and five fingers of
//! tapered capsules, bent as a posture says, in the hand's own frame.
//!
//! The hand's frame (metres, origin at the wrist joint): `a` runs from the wrist
//! along the fingers, `b` towards the thumb, `c = a × b` out of the palm. It is the
//! left hand's frame; the right hand is its mirror image (see [`super::attach`]).
//! Proportions are fractions of the hand's length (wrist to middle fingertip) after
//! anthropometric tables, so the hand scales with the body.

use super::posture::{FingerAngles, HandPosture, ThumbAngles, ThumbPlacement};
use nalgebra::{Unit, UnitQuaternion, Vector3};

/// A tapered capsule: the segment from `p` (radius `rp`) to `q` (radius `rq`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Capsule {
    pub p: Vector3<f32>,
    pub q: Vector3<f32>,
    pub rp: f32,
    pub rq: f32,
}

/// The solids of a hand in a posture, and where its fingertips are.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct HandShape {
    pub capsules: Vec<Capsule>,
    /// The outermost point of each finger's last phalanx, thumb first.
    pub fingertips: [Vector3<f32>; 5],
}

/// Proportions of a long finger (index, middle, ring, little), fractions of the hand's
/// length.
struct LongFinger {
    /// The knuckle (metacarpophalangeal joint) in the hand's frame.
    knuckle: [f32; 2],
    /// Proximal, middle and distal phalanx.
    phalanges: [f32; 3],
    /// Radius at the knuckle; each phalanx narrows by `TAPER`.
    radius: f32,
}

const LONG: [LongFinger; 4] = [
    LongFinger {
        knuckle: [0.45, 0.14],
        phalanges: [0.245, 0.14, 0.10],
        radius: 0.05,
    },
    LongFinger {
        knuckle: [0.46, 0.047],
        phalanges: [0.27, 0.165, 0.105],
        radius: 0.052,
    },
    LongFinger {
        knuckle: [0.44, -0.047],
        phalanges: [0.25, 0.155, 0.105],
        radius: 0.048,
    },
    LongFinger {
        knuckle: [0.40, -0.135],
        phalanges: [0.20, 0.115, 0.095],
        radius: 0.042,
    },
];
const TAPER: f32 = 0.9;
/// Where the metacarpals meet the wrist (along `a`), and how far their bases fan out
/// compared with the knuckles.
const CARPAL_A: f32 = 0.07;
const CARPAL_FAN: f32 = 0.75;
/// The palm's half-thickness.
const METACARPAL_RADIUS: f32 = 0.06;
/// The thumb's base (carpometacarpal joint), its metacarpal and two phalanges, radii.
const THUMB_BASE: [f32; 3] = [0.09, 0.11, 0.035];
const THUMB_BONES: [f32; 3] = [0.23, 0.16, 0.125];
const THUMB_RADII: [f32; 4] = [0.068, 0.058, 0.052, 0.046];

fn a() -> Vector3<f32> {
    Vector3::x()
}
fn b() -> Vector3<f32> {
    Vector3::y()
}
fn c() -> Vector3<f32> {
    Vector3::z()
}

fn rot(axis: &Vector3<f32>, deg: f32) -> UnitQuaternion<f32> {
    UnitQuaternion::from_axis_angle(&Unit::new_normalize(*axis), deg.to_radians())
}

/// A chain of phalanges from `start`, first pointing along `dir`, each joint bending
/// by its angle about `axis`: the capsules and the outermost point of the tip.
fn chain(
    start: Vector3<f32>,
    dir: Vector3<f32>,
    axis: &Vector3<f32>,
    bends: &[f32],
    lengths: &[f32],
    radii: &[f32],
    out: &mut Vec<Capsule>,
) -> Vector3<f32> {
    let mut p = start;
    let mut bent = 0.0;
    let mut d = dir;
    for (i, (&bend, &len)) in bends.iter().zip(lengths).enumerate() {
        bent += bend;
        d = rot(axis, bent) * dir;
        let q = p + d * len;
        out.push(Capsule {
            p,
            q,
            rp: radii[i],
            rq: radii[i + 1],
        });
        p = q;
    }
    p + d * radii[bends.len()]
}

/// A long finger from its knuckle: spread in the palm's plane, then bent towards the
/// palm at each joint.
fn long_finger(
    f: &LongFinger,
    ang: &FingerAngles,
    length: f32,
    out: &mut Vec<Capsule>,
) -> Vector3<f32> {
    let knuckle = (a() * f.knuckle[0] + b() * f.knuckle[1]) * length;
    let dir = rot(&c(), ang.spread) * a();
    // Bending about dir × c turns the finger towards c, the palm's side.
    let axis = dir.cross(&c());
    let lengths = f.phalanges.map(|l| l * length);
    let r0 = f.radius * length;
    let radii = [
        r0,
        r0 * TAPER,
        r0 * TAPER * TAPER,
        r0 * TAPER * TAPER * TAPER,
    ];
    chain(
        knuckle,
        dir,
        &axis,
        &[ang.mcp, ang.pip, ang.dip],
        &lengths,
        &radii,
        out,
    )
}

/// The thumb from its base: its metacarpal turned `spread` away from the fingers in
/// the palm's plane and `lift` out of it, its two joints bent towards its pad, which
/// faces the fingers and the palm's side.
fn thumb(ang: &ThumbAngles, length: f32, out: &mut Vec<Capsule>) -> Vector3<f32> {
    let base = Vector3::from(THUMB_BASE) * length;
    let (s, l) = (ang.spread.to_radians(), ang.lift.to_radians());
    let in_plane = a() * s.cos() + b() * s.sin();
    let outward = -a() * s.sin() + b() * s.cos();
    let dir = in_plane * l.cos() + c() * l.sin();
    let pad = (c() * 0.8 - outward * 0.6).normalize();
    let pad = (pad - dir * dir.dot(&pad)).normalize();
    let axis = dir.cross(&pad);
    let lengths = THUMB_BONES.map(|v| v * length);
    let radii = THUMB_RADII.map(|v| v * length);
    chain(
        base,
        dir,
        &axis,
        &[0.0, ang.mcp, ang.ip],
        &lengths,
        &radii,
        out,
    )
}

/// The thumb's base angles that bring its tip (the centre of its rounded end) nearest
/// `target`, on a one-degree grid over the joint's range.
fn reach(target: Vector3<f32>, mcp: f32, ip: f32, length: f32) -> ThumbAngles {
    let mut best = (
        f32::INFINITY,
        ThumbAngles {
            spread: 0.0,
            lift: 0.0,
            mcp,
            ip,
        },
    );
    let mut scratch = Vec::new();
    for spread in -20..=100 {
        for lift in -10..=90 {
            let ang = ThumbAngles {
                spread: spread as f32,
                lift: lift as f32,
                mcp,
                ip,
            };
            scratch.clear();
            thumb(&ang, length, &mut scratch);
            let end = scratch.last().expect("three phalanges").q;
            let d = (end - target).norm();
            if d < best.0 {
                best = (d, ang);
            }
        }
    }
    best.1
}

/// The palm's centre in the hand's frame: halfway from the wrist to the middle
/// finger's knuckle.
pub(crate) fn palm_centre(length: f32) -> Vector3<f32> {
    let k = LONG[1].knuckle;
    (a() * k[0] + b() * k[1]) * (0.5 * length)
}

/// The hand of the given length (wrist to middle fingertip, metres) in a posture.
pub(crate) fn build(posture: HandPosture, length: f32) -> HandShape {
    let angles = posture.angles();
    let mut capsules = Vec::new();
    let mut fingertips = [Vector3::zeros(); 5];
    // The palm: a metacarpal from the wrist to each knuckle, and the heel of the hand.
    let r = METACARPAL_RADIUS * length;
    for f in &LONG {
        let k = a() * f.knuckle[0] + b() * f.knuckle[1];
        let base = a() * CARPAL_A + b() * f.knuckle[1] * CARPAL_FAN;
        capsules.push(Capsule {
            p: base * length,
            q: k * length,
            rp: r,
            rq: r,
        });
    }
    capsules.push(Capsule {
        p: (a() * CARPAL_A - b() * 0.08) * length,
        q: (a() * CARPAL_A + b() * 0.08) * length,
        rp: r,
        rq: r,
    });
    let mut fingers = Vec::new();
    for (i, (f, ang)) in LONG.iter().zip(&angles.fingers).enumerate() {
        fingertips[i + 1] = long_finger(f, ang, length, &mut fingers);
    }
    let thumb_angles = match angles.thumb {
        ThumbPlacement::Angles(t) => t,
        ThumbPlacement::OnIndexTip { mcp, ip } => {
            // The pads meet: the thumb's tip centre off the index's tip on the side its
            // pad faces (a quarter turn further in the index's bend).
            let ix = &angles.fingers[0];
            let dir = rot(&c(), ix.spread) * a();
            let pad = rot(&dir.cross(&c()), ix.mcp + ix.pip + ix.dip + 90.0) * dir;
            let target = fingers[2].q + pad * (fingers[2].rq + THUMB_RADII[3] * length) * 0.9;
            reach(target, mcp, ip, length)
        }
        ThumbPlacement::OverFingers { mcp, ip } => {
            // On the curled index and middle fingers' middle phalanges, on their outer
            // side.
            let mid = |k: usize| (fingers[k].p + fingers[k].q) / 2.0;
            let (ix, mx) = (mid(1), mid(4));
            let target = (ix + mx) / 2.0 + c() * (fingers[1].rq + THUMB_RADII[3] * length) * 0.9;
            reach(target, mcp, ip, length)
        }
    };
    fingertips[0] = thumb(&thumb_angles, length, &mut capsules);
    capsules.extend(fingers);
    HandShape {
        capsules,
        fingertips,
    }
}
