//! Which BVH joint drives which canonical bone, whatever the conversion called it.
//!
//! Motion-capture files name the same joints in many ways: CMU's clips alone come in a
//! MotionBuilder-friendly conversion (`LeftUpLeg`, `LeftForeArm`, `Spine1`), in ASF
//! names (`lfemur`, `lradius`, `lowerback`, `thorax`, `lowerneck`), with `Chest`/`Ab`
//! and `LeftCollar`/`LeftElbow`/`LeftWrist`, and DAZ-style (`lShldr`, `lForeArm`);
//! other tools add namespaces (`mixamorig:LeftArm`), spaces (`Bip01 L Thigh`) or side
//! suffixes (`upperarm_l`). Limbs are therefore found by the words in a name, after its
//! side is taken off, and the spine by the skeleton's shape: the chest is where the two
//! arms branch off, the spine bone the first joint above the hips on the way there, the
//! neck the first one on from the chest towards the head. So `Spine`, `Spine1`,
//! `Spine2`, `upperback` or `thorax` need no table of their own.
//!
//! A joint whose name says nothing known stays in the chain (its rotation still moves
//! everything below it) and drives no bone. Only what cannot be a body is refused: no
//! arm on either side, or a limb whose parts do not hang one below the other.

use super::BvhJoint;
use crate::canon::Bone;

/// Which side of the body a name is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    Left,
    Right,
}

/// What a joint's name says it is, before the skeleton's shape is looked at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    Hips,
    Neck,
    Head,
    Collar,
    /// `Shoulder`: the collar when the side also has an upper arm by another name
    /// (MotionBuilder's `LeftShoulder` → `LeftArm`), else the upper arm (`LeftCollar` →
    /// `LeftShoulder` → `LeftElbow`).
    Shoulder,
    UpperArm,
    Forearm,
    /// `Wrist` before `Hand` when a side has both (ASF's `lwrist` → `lhand`).
    Wrist,
    Hand,
    Thigh,
    Shin,
    Foot,
    /// Known to drive nothing: fingers, toes, helper and end joints.
    Nothing,
}

/// The words of a joint's name, lower case: split at separators, namespaces and
/// lower-to-upper case changes (`LeftUpLeg` → left, up, leg; `LHipJoint` → l, hip, joint).
fn words(name: &str) -> Vec<String> {
    let name = name.rsplit([':', '|']).next().unwrap_or(name);
    let chars: Vec<char> = name.chars().collect();
    let mut out = Vec::new();
    let mut cur = String::new();
    for (i, &c) in chars.iter().enumerate() {
        if !c.is_alphanumeric() {
            if !cur.is_empty() {
                out.push(std::mem::take(&mut cur));
            }
            continue;
        }
        let prev = i.checked_sub(1).map(|k| chars[k]);
        let next = chars.get(i + 1).copied();
        let boundary = c.is_uppercase()
            && (prev.is_some_and(|p| p.is_lowercase() || p.is_ascii_digit())
                || (prev.is_some_and(char::is_uppercase) && next.is_some_and(char::is_lowercase)));
        if boundary && !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
        cur.extend(c.to_lowercase());
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// The part a run of words names (side already taken off), `None` when unknown.
fn part_of(stem: &str) -> Option<Part> {
    use Part::*;
    const NOTHING: [&str; 17] = [
        "finger", "thumb", "toe", "index", "middle", "ring", "pinky", "little", "hipjoint", "end",
        "nub", "site", "eye", "jaw", "roll", "twist", "carpal",
    ];
    if NOTHING.iter().any(|w| stem.contains(w)) {
        return Some(Nothing);
    }
    Some(match stem {
        "hips" | "hip" | "pelvis" | "root" => Hips,
        "neck" | "lowerneck" => Neck,
        "head" | "skull" => Head,
        "collar" | "clavicle" => Collar,
        "shoulder" => Shoulder,
        "arm" | "upperarm" | "uparm" | "humerus" | "shldr" => UpperArm,
        "forearm" | "lowerarm" | "elbow" | "radius" | "ulna" | "forarm" => Forearm,
        "wrist" => Wrist,
        "hand" => Hand,
        "upleg" | "upperleg" | "thigh" | "femur" => Thigh,
        "leg" | "lowerleg" | "knee" | "shin" | "tibia" | "calf" | "lowleg" => Shin,
        "foot" | "ankle" => Foot,
        _ => return None,
    })
}

/// Side and part of a joint name (`None` part: unknown, drives nothing).
fn read(name: &str) -> (Option<Side>, Option<Part>) {
    let mut w = words(name);
    // Rig prefixes that are no part of the body's name.
    w.retain(|x| !(x.starts_with("bip0") || x == "mixamorig" || x == "def" || x == "jnt"));
    let side_word = |x: &str| match x {
        "left" | "l" | "lft" => Some(Side::Left),
        "right" | "r" | "rt" | "rgt" => Some(Side::Right),
        _ => None,
    };
    let mut side = None;
    if let Some(i) = w.iter().position(|x| side_word(x).is_some()) {
        side = side_word(&w[i]);
        w.remove(i);
    }
    let stem: String = w.concat();
    // A side glued to the part: `lhumerus`, `rclavicle`, `leftarm`.
    let (side, stem) = match (side, part_of(&stem)) {
        (Some(s), _) => (Some(s), stem),
        (None, Some(_)) => (None, stem),
        (None, None) => {
            let glued = [
                ("left", Side::Left),
                ("right", Side::Right),
                ("l", Side::Left),
                ("r", Side::Right),
            ]
            .into_iter()
            .find_map(|(p, s)| {
                stem.strip_prefix(p)
                    .filter(|rest| part_of(rest).is_some())
                    .map(|rest| (Some(s), rest.to_string()))
            });
            glued.unwrap_or((None, stem))
        }
    };
    // Hand + finger words (`LeftHandThumb1`) name fingers.
    let part = part_of(&stem).or_else(|| {
        stem.strip_prefix("hand")
            .filter(|rest| part_of(rest) == Some(Part::Nothing))
            .map(|_| Part::Nothing)
    });
    (side, part)
}

/// Why a skeleton cannot drive a body, for the caller to name the file with.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NotABody {
    /// The joint's line, 0 when the reason is no single joint.
    pub line: usize,
    pub reason: String,
}

/// The BVH joint driving each canonical bone (`None`: the bone follows its parent), and
/// the joint whose position is the hips'.
pub(crate) fn drives(joints: &[BvhJoint]) -> Result<[Option<usize>; Bone::COUNT], NotABody> {
    let read: Vec<(Option<Side>, Option<Part>)> = joints.iter().map(|j| read(&j.name)).collect();
    let depth = |mut i: usize| {
        let mut d = 0;
        while let Some(p) = joints[i].parent {
            i = p;
            d += 1;
        }
        d
    };
    let is_below = |mut i: usize, ancestor: usize| loop {
        if i == ancestor {
            return true;
        }
        match joints[i].parent {
            Some(p) => i = p,
            None => return false,
        }
    };
    // The shallowest joint of a part on a side (so `lwrist` before `lhand`, `Neck`
    // before `Neck1`).
    let first = |side: Option<Side>, parts: &[Part]| {
        (0..joints.len())
            .filter(|&i| read[i].0 == side && read[i].1.is_some_and(|p| parts.contains(&p)))
            .min_by_key(|&i| (depth(i), i))
    };
    let mut out = [None; Bone::COUNT];
    let mut arms = [None; 2];
    for (k, (side, bones)) in [
        (
            Side::Left,
            [
                Bone::LeftCollar,
                Bone::LeftUpperArm,
                Bone::LeftForearm,
                Bone::LeftHand,
            ],
        ),
        (
            Side::Right,
            [
                Bone::RightCollar,
                Bone::RightUpperArm,
                Bone::RightForearm,
                Bone::RightHand,
            ],
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let s = Some(side);
        let collar = first(s, &[Part::Collar]);
        let upper = first(s, &[Part::UpperArm]);
        let (collar, upper) = match (collar, upper, first(s, &[Part::Shoulder])) {
            (None, Some(u), Some(sh)) => (Some(sh), Some(u)),
            (c, None, Some(sh)) => (c, Some(sh)),
            (c, u, _) => (c, u),
        };
        let forearm = first(s, &[Part::Forearm]);
        let hand = first(s, &[Part::Wrist]).or_else(|| first(s, &[Part::Hand]));
        let side_name = if side == Side::Left { "left" } else { "right" };
        let (Some(u), Some(f)) = (upper, forearm) else {
            return Err(NotABody {
                line: 0,
                reason: format!(
                    "no {side_name} arm: a body needs a joint named like an upper arm (Arm, UpperArm, humerus, Shoulder under a Collar) and one like a forearm (ForeArm, LowerArm, Elbow, radius) on each side"
                ),
            });
        };
        let chain = [collar, Some(u), Some(f), hand];
        for pair in chain.windows(2) {
            if let [Some(a), Some(b)] = *pair {
                if !is_below(b, a) || a == b {
                    return Err(NotABody {
                        line: joints[b].line,
                        reason: format!(
                            "joint {:?} ({side_name} arm) does not hang below {:?}",
                            joints[b].name, joints[a].name
                        ),
                    });
                }
            }
        }
        for (b, j) in bones.into_iter().zip(chain) {
            out[b.index()] = j;
        }
        arms[k] = Some(collar.unwrap_or(u));
    }
    let [Some(la), Some(ra)] = arms else {
        unreachable!("both sides returned above or set");
    };
    // The chest: where the arms branch off (stepping up past a neck the collars hang
    // from, as in 3ds Max's Biped).
    let ancestors = |mut i: usize| {
        let mut v = vec![i];
        while let Some(p) = joints[i].parent {
            v.push(p);
            i = p;
        }
        v
    };
    let (al, ar) = (ancestors(la), ancestors(ra));
    let mut chest = *al
        .iter()
        .find(|i| ar.contains(i))
        .expect("every joint descends from the ROOT");
    if chest == la || chest == ra {
        return Err(NotABody {
            line: joints[chest].line,
            reason: "one arm hangs below the other".into(),
        });
    }
    while matches!(read[chest].1, Some(Part::Neck | Part::Head)) {
        match joints[chest].parent {
            Some(p) => chest = p,
            None => break,
        }
    }
    // The hips: the deepest joint named so above the chest, else the ROOT.
    let above_chest = ancestors(chest);
    let hips = above_chest
        .iter()
        .copied()
        .find(|&i| i != chest && read[i].0.is_none() && read[i].1 == Some(Part::Hips))
        .unwrap_or(0);
    out[Bone::Hips.index()] = Some(hips);
    if chest != hips {
        out[Bone::Chest.index()] = Some(chest);
        // The spine: the first joint after the hips on the way to the chest.
        let path: Vec<usize> = above_chest
            .iter()
            .copied()
            .take_while(|&i| i != hips)
            .collect();
        if let Some(&s) = path.last().filter(|&&s| s != chest) {
            out[Bone::Spine.index()] = Some(s);
        }
    }
    let head = (0..joints.len())
        .filter(|&i| read[i].0.is_none() && read[i].1 == Some(Part::Head) && is_below(i, chest))
        .min_by_key(|&i| (depth(i), i));
    out[Bone::Head.index()] = head;
    let neck = match head {
        Some(h) => ancestors(h)
            .into_iter()
            .take_while(|&i| i != chest)
            .last()
            .filter(|&n| n != h),
        None => (0..joints.len())
            .filter(|&i| read[i].1 == Some(Part::Neck) && joints[i].parent == Some(chest))
            .min(),
    };
    out[Bone::Neck.index()] = neck;
    for (side, bones) in [
        (
            Side::Left,
            [Bone::LeftThigh, Bone::LeftShin, Bone::LeftFoot],
        ),
        (
            Side::Right,
            [Bone::RightThigh, Bone::RightShin, Bone::RightFoot],
        ),
    ] {
        let s = Some(side);
        let thigh = first(s, &[Part::Thigh])
            .or_else(|| first(s, &[Part::Hips]))
            .filter(|&t| !is_below(t, chest));
        let chain = [
            thigh,
            thigh.and_then(|t| first(s, &[Part::Shin]).filter(|&k| is_below(k, t) && k != t)),
            thigh.and_then(|t| first(s, &[Part::Foot]).filter(|&k| is_below(k, t) && k != t)),
        ];
        for (b, j) in bones.into_iter().zip(chain) {
            out[b.index()] = j;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_read_whatever_the_convention() {
        use Part::*;
        let l = Some(Side::Left);
        let r = Some(Side::Right);
        for (name, want) in [
            ("LeftUpLeg", (l, Some(Thigh))),
            ("LeftForeArm", (l, Some(Forearm))),
            ("RightShoulder", (r, Some(Shoulder))),
            ("LHipJoint", (l, Some(Nothing))),
            ("LThumb", (l, Some(Nothing))),
            ("lhumerus", (l, Some(UpperArm))),
            ("rclavicle", (r, Some(Collar))),
            ("lradius", (l, Some(Forearm))),
            ("lwrist", (l, Some(Wrist))),
            ("lhand", (l, Some(Hand))),
            ("lowerback", (None, None)),
            ("lowerneck", (None, Some(Neck))),
            ("lShldr", (l, Some(UpperArm))),
            ("rForeArm", (r, Some(Forearm))),
            ("mixamorig:LeftArm", (l, Some(UpperArm))),
            ("Bip01 L Thigh", (l, Some(Thigh))),
            ("Bip01 R Calf", (r, Some(Shin))),
            ("upperarm_l", (l, Some(UpperArm))),
            ("L_Elbow", (l, Some(Forearm))),
            ("RightHandThumb1", (r, Some(Nothing))),
            ("LeftToeBase", (l, Some(Nothing))),
            ("Neck1", (None, None)),
            ("Hips", (None, Some(Hips))),
            ("Spine1", (None, None)),
        ] {
            assert_eq!(read(name), want, "{name}");
        }
    }
}
