//! BVH motion capture: reading, naming conventions, resampling and retargeting onto the
//! canonical skeleton.
//!
//! Three naming conventions are understood (detected from the joint names):
//! - MotionBuilder-style, as in the CMU conversions: `Hips, LowerBack, Spine, Spine1,
//!   Neck, Neck1, Head, LeftShoulder (collar), LeftArm, LeftForeArm, LeftHand,
//!   LeftUpLeg, LeftLeg, LeftFoot, LeftToeBase, LHipJoint, …`
//! - CMU ASF-style: `Hips, Chest, Chest2, Neck, Head, LeftCollar, LeftShoulder (upper
//!   arm), LeftElbow, LeftWrist, LeftHip, LeftKnee, LeftAnkle, …`
//! - Ab-style: `Hips, Ab, Chest, Neck, Head, LeftCollar, LeftShoulder, LeftElbow,
//!   LeftWrist, LeftHip, LeftKnee, LeftAnkle, …`
//!
//! Fingers, thumbs, toes and helper joints (`LHipJoint`, `Neck1`, …) are read and
//! ignored; any other name is refused, naming the file and line.
//!
//! Retargeting works on world rotations relative to each skeleton's rest pose: for a
//! canonical bone driven by BVH joint `s`, `W = G_s(t) · A`, where `G_s(t)` is the
//! joint's world rotation in the clip and `A` the shortest arc from the canonical T-pose
//! direction of the bone to its direction in the clip's rest pose. So a clip whose rest
//! pose is an A-pose, or whose legs are spread, still drives a T-posed rig right: every
//! bone points where the clip's bone points. The clip is turned so that its first frame
//! faces the camera, its root translation is scaled by the ratio of hip heights, and it
//! is resampled to the scene's frame rate (spherical blends between frames).

use crate::canon::{frame_to_frame, shortest_arc, Bone, Pose, TposeSkeleton};
use crate::error::SynthError;
use nalgebra::{Point3, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};

/// One joint of a BVH hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhJoint {
    pub name: String,
    pub parent: Option<usize>,
    pub offset: Vector3<f32>,
    /// Channel kinds in file order; `channel_start` indexes a frame's values.
    pub channels: Vec<Channel>,
    pub channel_start: usize,
    /// `End Site` offsets under this joint.
    pub end_sites: Vec<Vector3<f32>>,
    /// The line of the `ROOT`/`JOINT` keyword.
    pub line: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    Xposition,
    Yposition,
    Zposition,
    Xrotation,
    Yrotation,
    Zrotation,
}

/// The naming conventions understood.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Convention {
    MotionBuilder,
    CmuAsf,
    Ab,
}

impl Convention {
    pub fn name(self) -> &'static str {
        match self {
            Convention::MotionBuilder => "MotionBuilder-style (LeftUpLeg/LeftLeg/LeftFoot)",
            Convention::CmuAsf => "CMU ASF-style (LeftHip/LeftKnee/LeftAnkle/Chest/LeftCollar)",
            Convention::Ab => "Ab-style (Ab/Chest/LeftCollar/LeftElbow/LeftWrist)",
        }
    }

    fn detect(names: &[&str]) -> Convention {
        let has = |n: &str| names.iter().any(|x| x.eq_ignore_ascii_case(n));
        if has("LeftUpLeg") || has("LeftForeArm") || has("LeftArm") {
            Convention::MotionBuilder
        } else if has("Ab") {
            Convention::Ab
        } else {
            Convention::CmuAsf
        }
    }

    /// The canonical bone a joint name drives, `Ok(None)` for a known joint that is
    /// ignored, `Err(())` for an unknown name.
    fn map(self, name: &str, has_chest2: bool) -> Result<Option<Bone>, ()> {
        use Bone::*;
        let lower = name.to_ascii_lowercase();
        let common = |n: &str| -> Option<Bone> {
            Some(match n {
                "hips" | "hip" | "pelvis" | "root" => Hips,
                "neck" => Neck,
                "head" => Head,
                _ => return None,
            })
        };
        if let Some(b) = common(&lower) {
            return Ok(Some(b));
        }
        let side = |n: &str| -> Option<(bool, String)> {
            for (p, left) in [("left", true), ("right", false)] {
                if let Some(rest) = n.strip_prefix(p) {
                    return Some((left, rest.to_string()));
                }
            }
            None
        };
        let pick = |left: bool, l: Bone| if left { l } else { l.mirror() };
        let mapped = match self {
            Convention::MotionBuilder => match lower.as_str() {
                "lowerback" => Some(Spine),
                "spine1" => Some(Chest),
                _ => side(&lower).and_then(|(left, rest)| {
                    Some(pick(
                        left,
                        match rest.as_str() {
                            "shoulder" => LeftCollar,
                            "arm" => LeftUpperArm,
                            "forearm" => LeftForearm,
                            "hand" => LeftHand,
                            "upleg" => LeftThigh,
                            "leg" => LeftShin,
                            "foot" => LeftFoot,
                            _ => return None,
                        },
                    ))
                }),
            },
            Convention::CmuAsf | Convention::Ab => match lower.as_str() {
                "ab" | "abdomen" => Some(Spine),
                "chest" if self == Convention::CmuAsf && has_chest2 => Some(Spine),
                "chest" => Some(Chest),
                "chest2" => Some(Chest),
                _ => side(&lower).and_then(|(left, rest)| {
                    Some(pick(
                        left,
                        match rest.as_str() {
                            "collar" => LeftCollar,
                            "shoulder" => LeftUpperArm,
                            "elbow" => LeftForearm,
                            "wrist" | "hand" => LeftHand,
                            "hip" => LeftThigh,
                            "knee" => LeftShin,
                            "ankle" | "foot" => LeftFoot,
                            _ => return None,
                        },
                    ))
                }),
            },
        };
        if mapped.is_some() {
            return Ok(mapped);
        }
        let ignorable = [
            "finger", "thumb", "toe", "index", "middle", "ring", "pinky", "hipjoint", "end", "nub",
            "site",
        ];
        let extra: &[&str] = match self {
            Convention::MotionBuilder => &["spine", "spine2", "spine3", "neck1", "neck2"],
            Convention::CmuAsf => &["chest3", "chest4", "neck1", "neck2"],
            Convention::Ab => &["neck1", "neck2"],
        };
        if ignorable.iter().any(|k| lower.contains(k)) || extra.contains(&lower.as_str()) {
            Ok(None)
        } else {
            Err(())
        }
    }
}

/// A parsed BVH clip.
#[derive(Debug, Clone)]
pub struct BvhClip {
    pub path: PathBuf,
    pub joints: Vec<BvhJoint>,
    pub frame_time: f32,
    /// Channel values, one row a frame, `channels` wide.
    pub frames: Vec<Vec<f32>>,
    pub channels: usize,
    pub convention: Convention,
    /// BVH joint index driving each canonical bone.
    pub drives: [Option<usize>; Bone::COUNT],
}

struct Tokens<'a> {
    path: &'a Path,
    toks: Vec<(usize, &'a str)>,
    pos: usize,
}

impl<'a> Tokens<'a> {
    fn new(path: &'a Path, text: &'a str) -> Self {
        let toks = text
            .lines()
            .enumerate()
            .flat_map(|(i, l)| l.split_whitespace().map(move |t| (i + 1, t)))
            .collect();
        Self { path, toks, pos: 0 }
    }

    fn line(&self) -> usize {
        self.toks
            .get(self.pos)
            .or(self.toks.last())
            .map_or(1, |t| t.0)
    }

    fn err(&self, reason: impl Into<String>) -> SynthError {
        SynthError::parse(self.path, self.line(), reason)
    }

    fn next(&mut self, what: &str) -> Result<&'a str, SynthError> {
        match self.toks.get(self.pos) {
            Some(t) => {
                self.pos += 1;
                Ok(t.1)
            }
            None => Err(self.err(format!("unexpected end of file, expected {what}"))),
        }
    }

    fn expect(&mut self, word: &str) -> Result<(), SynthError> {
        let line = self.line();
        let t = self.next(word)?;
        if t.eq_ignore_ascii_case(word) {
            Ok(())
        } else {
            Err(SynthError::parse(
                self.path,
                line,
                format!("expected {word:?}, found {t:?}"),
            ))
        }
    }

    fn number(&mut self, what: &str) -> Result<f32, SynthError> {
        let line = self.line();
        let t = self.next(what)?;
        t.parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                SynthError::parse(self.path, line, format!("expected {what}, found {t:?}"))
            })
    }

    fn peek(&self) -> Option<&'a str> {
        self.toks.get(self.pos).map(|t| t.1)
    }
}

impl BvhClip {
    /// Reads and checks a BVH file.
    pub fn load(path: &Path) -> Result<Self, SynthError> {
        let text = std::fs::read_to_string(path).map_err(|e| SynthError::io(path, e))?;
        Self::parse(path, &text)
    }

    /// Parses BVH text; `path` is only used in messages.
    pub fn parse(path: &Path, text: &str) -> Result<Self, SynthError> {
        let mut t = Tokens::new(path, text);
        t.expect("HIERARCHY")?;
        t.expect("ROOT")?;
        let mut joints = Vec::new();
        let mut channels = 0usize;
        parse_joint(&mut t, &mut joints, None, &mut channels)?;
        if t.peek().is_some_and(|w| w.eq_ignore_ascii_case("ROOT")) {
            return Err(t.err("more than one ROOT: one skeleton a file is supported"));
        }
        t.expect("MOTION")?;
        t.expect("Frames:")?;
        let line = t.line();
        let n = t.number("the frame count")?;
        if n < 1.0 || n.fract() != 0.0 || n > 10_000_000.0 {
            return Err(SynthError::parse(
                path,
                line,
                format!("frame count {n} must be a positive integer"),
            ));
        }
        let n = n as usize;
        t.expect("Frame")?;
        t.expect("Time:")?;
        let line = t.line();
        let frame_time = t.number("the frame time")?;
        if !(frame_time > 1e-5 && frame_time < 10.0) {
            return Err(SynthError::parse(
                path,
                line,
                format!("frame time {frame_time} s is not plausible"),
            ));
        }
        let mut frames = Vec::with_capacity(n);
        for f in 0..n {
            let mut row = Vec::with_capacity(channels);
            for _ in 0..channels {
                row.push(t.number(&format!("a channel value of frame {}", f + 1))?);
            }
            frames.push(row);
        }
        // Some exporters write one frame more than they announce: whole extra frames
        // are ignored, anything else is an error.
        let extra = t.toks.len() - t.pos;
        if !extra.is_multiple_of(channels.max(1)) || (channels == 0 && extra > 0) {
            return Err(t.err(format!(
                "{extra} values after the {n} frames the header announced ({channels} channels each)"
            )));
        }
        for k in 0..extra {
            t.number(&format!(
                "a channel value after frame {}",
                n + k / channels.max(1)
            ))?;
        }
        let names: Vec<&str> = joints.iter().map(|j: &BvhJoint| j.name.as_str()).collect();
        let convention = Convention::detect(&names);
        let has_chest2 = names.iter().any(|n| n.eq_ignore_ascii_case("chest2"));
        let mut drives = [None; Bone::COUNT];
        for (i, j) in joints.iter().enumerate() {
            match convention.map(&j.name, has_chest2) {
                Ok(Some(b)) => {
                    if drives[b.index()].is_some() {
                        return Err(SynthError::parse(
                            path,
                            j.line,
                            format!("joint {:?} drives the {} a second time", j.name, b.name()),
                        ));
                    }
                    drives[b.index()] = Some(i);
                }
                Ok(None) => {}
                Err(()) => {
                    return Err(SynthError::parse(
                        path,
                        j.line,
                        format!(
                            "unknown joint {:?} for the {} naming convention; rename it, or use MotionBuilder-style, CMU ASF-style or Ab-style names",
                            j.name,
                            convention.name()
                        ),
                    ))
                }
            }
        }
        use Bone::*;
        for b in [
            Hips,
            LeftUpperArm,
            LeftForearm,
            RightUpperArm,
            RightForearm,
            LeftThigh,
            LeftShin,
            RightThigh,
            RightShin,
        ] {
            if drives[b.index()].is_none() {
                return Err(SynthError::parse(
                    path,
                    0,
                    format!(
                        "no joint drives the {} (naming convention: {})",
                        b.name(),
                        convention.name()
                    ),
                ));
            }
        }
        if drives[Hips.index()] != Some(0) {
            return Err(SynthError::parse(
                path,
                joints[0].line,
                "the ROOT must be the hips",
            ));
        }
        Ok(Self {
            path: path.to_owned(),
            joints,
            frame_time,
            frames,
            channels,
            convention,
            drives,
        })
    }

    /// Clip length in seconds.
    pub fn duration(&self) -> f32 {
        (self.frames.len().saturating_sub(1)) as f32 * self.frame_time
    }

    /// World rotations and positions of every joint in frame `f` (None: rest pose).
    pub fn forward(&self, f: Option<usize>) -> (Vec<UnitQuaternion<f32>>, Vec<Point3<f32>>) {
        let mut rot = Vec::with_capacity(self.joints.len());
        let mut pos = Vec::with_capacity(self.joints.len());
        for j in &self.joints {
            let mut local = UnitQuaternion::identity();
            let mut trans = Vector3::zeros();
            if let Some(f) = f {
                let row = &self.frames[f];
                for (k, c) in j.channels.iter().enumerate() {
                    let v = row[j.channel_start + k];
                    let axis = match c {
                        Channel::Xposition => {
                            trans.x = v;
                            continue;
                        }
                        Channel::Yposition => {
                            trans.y = v;
                            continue;
                        }
                        Channel::Zposition => {
                            trans.z = v;
                            continue;
                        }
                        Channel::Xrotation => Vector3::x_axis(),
                        Channel::Yrotation => Vector3::y_axis(),
                        Channel::Zrotation => Vector3::z_axis(),
                    };
                    local *= UnitQuaternion::from_axis_angle(&axis, v.to_radians());
                }
            }
            match j.parent {
                None => {
                    rot.push(local);
                    pos.push(Point3::from(j.offset + trans));
                }
                Some(p) => {
                    let g = rot[p] * local;
                    let q = pos[p] + rot[p] * j.offset;
                    rot.push(g);
                    pos.push(q);
                }
            }
        }
        (rot, pos)
    }

    /// The clip's rest direction of each driven canonical bone (clip coordinates).
    fn rest_dirs(&self) -> [Option<Vector3<f32>>; Bone::COUNT] {
        let (_, pos) = self.forward(None);
        let mut dirs = [None; Bone::COUNT];
        for b in Bone::ALL {
            let Some(s) = self.drives[b.index()] else {
                continue;
            };
            // Toward the next driven joint down the canonical chain that is not at the
            // same place, else toward the joint's first child or end site.
            let mut c = b.child();
            let mut dir = None;
            while let Some(cb) = c {
                if let Some(cj) = self.drives[cb.index()] {
                    let d = pos[cj] - pos[s];
                    if d.norm() > 1e-4 {
                        dir = Some(d);
                        break;
                    }
                }
                c = cb.child();
            }
            if dir.is_none() {
                dir = self
                    .joints
                    .iter()
                    .enumerate()
                    .filter(|(_, j)| j.parent == Some(s))
                    .map(|(i, _)| pos[i] - pos[s])
                    .chain(self.joints[s].end_sites.iter().copied())
                    .find(|d| d.norm() > 1e-4);
            }
            dirs[b.index()] = dir.map(|d| d.normalize());
        }
        dirs
    }

    /// The clip on the canonical skeleton of a body, one pose a source frame, in the body
    /// frame: turned so the first frame faces +z, the hips starting above the origin.
    pub fn canonical_frames(&self, sk: &TposeSkeleton) -> Vec<Pose> {
        let (_, rest_pos) = self.forward(None);
        let dirs = self.rest_dirs();
        // The clip's axes: up from hips to head (or chest), left from right to left hip.
        let hips = rest_pos[0];
        let top = [Bone::Head, Bone::Neck, Bone::Chest, Bone::Spine]
            .iter()
            .find_map(|b| self.drives[b.index()])
            .map(|i| rest_pos[i])
            .unwrap_or(hips + Vector3::y());
        let lt = rest_pos[self.drives[Bone::LeftThigh.index()].unwrap_or(0)];
        let rt = rest_pos[self.drives[Bone::RightThigh.index()].unwrap_or(0)];
        let up = top - hips;
        let left = lt - rt;
        let q0 = if up.norm() > 1e-6 && left.norm() > 1e-6 {
            frame_to_frame(&up, &left, &Vector3::y(), &Vector3::x())
        } else {
            UnitQuaternion::identity()
        };
        let q0i = q0.inverse();
        // Standing hip height of the clip's skeleton: rest hips above its lowest point.
        let (mut lo, mut hip_y) = (f32::INFINITY, 0.0);
        for (i, j) in self.joints.iter().enumerate() {
            let p = q0 * (rest_pos[i] - hips);
            lo = lo.min(p.y);
            for e in &j.end_sites {
                lo = lo.min((q0 * (rest_pos[i] - hips + e)).y);
            }
            if i == 0 {
                hip_y = p.y;
            }
        }
        let src_h = (hip_y - lo).max(1e-6);
        let scale = sk.head(Bone::Hips).y / src_h;
        // The clip's floor: the lowest point it ever reaches (sampled).
        let stride = (self.frames.len() / 200).max(1);
        let mut floor = f32::INFINITY;
        for f in (0..self.frames.len()).step_by(stride) {
            let (rot, pos) = self.forward(Some(f));
            for (i, j) in self.joints.iter().enumerate() {
                floor = floor.min((q0 * pos[i]).y);
                for e in &j.end_sites {
                    floor = floor.min((q0 * (pos[i] + rot[i] * e)).y);
                }
            }
        }
        let align: Vec<UnitQuaternion<f32>> = Bone::ALL
            .iter()
            .map(|b| match dirs[b.index()] {
                Some(d) => shortest_arc(&b.tpose_dir(), &(q0 * d)),
                None => UnitQuaternion::identity(),
            })
            .collect();
        let mut out = Vec::with_capacity(self.frames.len());
        for f in 0..self.frames.len() {
            let (rot, pos) = self.forward(Some(f));
            let mut p = Pose::tpose(Point3::origin());
            for b in Bone::ALL {
                let w = match self.drives[b.index()] {
                    Some(s) => q0 * rot[s] * q0i * align[b.index()],
                    None => match b.parent() {
                        Some(pb) => p.get(pb),
                        None => UnitQuaternion::identity(),
                    },
                };
                p.set(b, w);
            }
            let r = q0 * pos[0];
            p.root = Point3::new(r.x * scale, (r.y - floor) * scale, r.z * scale);
            out.push(p);
        }
        // Face the camera in the first frame, start above the origin.
        if let Some(first) = out.first().copied() {
            let fwd = first.get(Bone::Hips) * Vector3::z();
            let heading = fwd.x.atan2(fwd.z);
            let turn = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -heading);
            let start = first.root;
            for p in &mut out {
                p.root -= Vector3::new(start.x, 0.0, start.z);
                p.rotate_all(turn);
            }
        }
        out
    }

    /// The clip retargeted onto a body and resampled to `fps`.
    pub fn retarget(&self, sk: &TposeSkeleton, fps: f32) -> Vec<Pose> {
        let src = self.canonical_frames(sk);
        let n = (self.duration() * fps).floor() as usize + 1;
        (0..n)
            .map(|i| {
                let t = i as f32 / fps / self.frame_time;
                let a = (t.floor() as usize).min(src.len() - 1);
                let b = (a + 1).min(src.len() - 1);
                src[a].lerp(&src[b], t - a as f32)
            })
            .collect()
    }
}

fn parse_joint(
    t: &mut Tokens<'_>,
    joints: &mut Vec<BvhJoint>,
    parent: Option<usize>,
    channels: &mut usize,
) -> Result<(), SynthError> {
    let line = t.line();
    let name = t.next("a joint name")?.to_string();
    if name == "{" {
        return Err(SynthError::parse(t.path, line, "joint without a name"));
    }
    if joints.len() >= 1000 {
        return Err(t.err("more than 1000 joints"));
    }
    t.expect("{")?;
    t.expect("OFFSET")?;
    let offset = Vector3::new(
        t.number("an OFFSET x")?,
        t.number("an OFFSET y")?,
        t.number("an OFFSET z")?,
    );
    t.expect("CHANNELS")?;
    let cl = t.line();
    let n = t.number("the channel count")?;
    if !(0.0..=6.0).contains(&n) || n.fract() != 0.0 {
        return Err(SynthError::parse(
            t.path,
            cl,
            format!("channel count {n} must be 0 to 6"),
        ));
    }
    let mut chans = Vec::new();
    for _ in 0..n as usize {
        let cl = t.line();
        let c = t.next("a channel name")?;
        chans.push(match c.to_ascii_lowercase().as_str() {
            "xposition" => Channel::Xposition,
            "yposition" => Channel::Yposition,
            "zposition" => Channel::Zposition,
            "xrotation" => Channel::Xrotation,
            "yrotation" => Channel::Yrotation,
            "zrotation" => Channel::Zrotation,
            _ => {
                return Err(SynthError::parse(
                    t.path,
                    cl,
                    format!("unknown channel {c:?}"),
                ));
            }
        });
    }
    let me = joints.len();
    joints.push(BvhJoint {
        name,
        parent,
        offset,
        channel_start: *channels,
        channels: chans,
        end_sites: Vec::new(),
        line,
    });
    *channels += n as usize;
    loop {
        let l = t.line();
        let w = t.next("JOINT, End Site or }")?;
        match w.to_ascii_lowercase().as_str() {
            "joint" => parse_joint(t, joints, Some(me), channels)?,
            "end" => {
                t.expect("Site")?;
                t.expect("{")?;
                t.expect("OFFSET")?;
                let e = Vector3::new(
                    t.number("an OFFSET x")?,
                    t.number("an OFFSET y")?,
                    t.number("an OFFSET z")?,
                );
                t.expect("}")?;
                joints[me].end_sites.push(e);
            }
            "}" => return Ok(()),
            _ => {
                return Err(SynthError::parse(
                    t.path,
                    l,
                    format!("expected JOINT, End Site or }}, found {w:?}"),
                ))
            }
        }
    }
}
