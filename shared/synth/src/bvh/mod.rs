//! BVH motion capture: reading, resampling and retargeting onto the canonical skeleton.
//!
//! Any naming convention is understood ([`naming`]): limbs by the words in their names,
//! the spine by where the arms branch off. Joints that drive no canonical bone
//! (fingers, toes, helpers such as `LHipJoint`, `lowerneck`, `lhand`, anything unknown)
//! stay in the chain: their rotations still move what hangs below them.
//!
//! Retargeting works on world rotations relative to each skeleton's rest pose: for a
//! canonical bone driven by BVH joint `s`, `W = G_s(t) · A`, where `G_s(t)` is the
//! joint's world rotation in the clip and `A` the shortest arc from the canonical T-pose
//! direction of the bone to its direction in the clip's rest pose. So a clip whose rest
//! pose is an A-pose, or whose legs are spread, still drives a T-posed rig right: every
//! bone points where the clip's bone points. The clip is turned so that its first frame
//! faces the camera, its root translation is scaled by the ratio of hip heights (of
//! torso lengths, for a clip without legs), and it is resampled to the scene's frame
//! rate (spherical blends between frames).

mod naming;

use crate::canon::{frame_to_frame, shortest_arc, Bone, Pose, TposeSkeleton};
use crate::error::SynthError;
use nalgebra::{Point3, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};

/// One joint of a BVH hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhJoint {
    /// As written after `ROOT`/`JOINT` (the rest of that line: names may hold spaces).
    pub name: String,
    /// Always an earlier joint.
    pub parent: Option<usize>,
    /// From the parent's head to this joint's, at rest, in the file's units.
    pub offset: Vector3<f32>,
    /// Channel kinds in file order; `channel_start` indexes a frame's values.
    pub channels: Vec<Channel>,
    /// Where this joint's channels start among a frame's values.
    pub channel_start: usize,
    /// `End Site` offsets under this joint.
    pub end_sites: Vec<Vector3<f32>>,
    /// The line of the `ROOT`/`JOINT` keyword.
    pub line: usize,
}

/// What one channel of a joint moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// Translation along x.
    Xposition,
    /// Translation along y.
    Yposition,
    /// Translation along z.
    Zposition,
    /// Rotation about x, degrees.
    Xrotation,
    /// Rotation about y, degrees.
    Yrotation,
    /// Rotation about z, degrees.
    Zrotation,
}

/// A parsed BVH clip.
#[derive(Debug, Clone)]
pub struct BvhClip {
    /// The file it was read from.
    pub path: PathBuf,
    /// The hierarchy, parents before children.
    pub joints: Vec<BvhJoint>,
    /// Seconds a frame.
    pub frame_time: f32,
    /// Channel values of every frame, one after the other, `channels` a frame.
    values: Vec<f32>,
    /// Values a frame.
    pub channels: usize,
    /// BVH joint index driving each canonical bone (`None`: it follows its parent;
    /// the hips, both upper arms and both forearms are always driven).
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

    /// The words left on the current word's line, joined by single spaces (a joint's
    /// name: `Bip01 L Thigh`).
    fn rest_of_line(&mut self, what: &str) -> Result<String, SynthError> {
        let line = self.line();
        let mut words = vec![self.next(what)?];
        while let Some(&(_, w)) = self.toks.get(self.pos).filter(|t| t.0 == line) {
            words.push(w);
            self.pos += 1;
        }
        Ok(words.join(" "))
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
        if n < 1.0 || n.fract() != 0.0 {
            return Err(SynthError::parse(
                path,
                line,
                format!("frame count {n} must be a positive integer"),
            ));
        }
        if channels == 0 {
            return Err(SynthError::parse(
                path,
                line,
                "no joint has a channel: the file holds no motion",
            ));
        }
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
        // Some exporters write one frame more than they announce: whole extra frames
        // are ignored, a frame short is an error. The count is checked against the
        // values there are before anything is allocated for it.
        let left = t.toks.len() - t.pos;
        let n = n as usize;
        if n.saturating_mul(channels) > left {
            let f = left / channels + 1;
            t.pos = t.toks.len();
            return Err(t.err(format!(
                "unexpected end of file, expected a channel value of frame {f} (the header announced {n} frames of {channels} values)"
            )));
        }
        let mut values = Vec::with_capacity(n * channels);
        for f in 0..n {
            for _ in 0..channels {
                values.push(t.number(&format!("a channel value of frame {}", f + 1))?);
            }
        }
        let extra = t.toks.len() - t.pos;
        if !extra.is_multiple_of(channels) {
            return Err(t.err(format!(
                "{extra} values after the {n} frames the header announced ({channels} channels each)"
            )));
        }
        for k in 0..extra {
            t.number(&format!("a channel value after frame {}", n + k / channels))?;
        }
        let drives =
            naming::drives(&joints).map_err(|e| SynthError::parse(path, e.line, e.reason))?;
        Ok(Self {
            path: path.to_owned(),
            joints,
            frame_time,
            values,
            channels,
            drives,
        })
    }

    /// Frames in the clip.
    pub fn frame_count(&self) -> usize {
        self.values.len() / self.channels
    }

    /// Clip length in seconds.
    pub fn duration(&self) -> f32 {
        (self.frame_count().saturating_sub(1)) as f32 * self.frame_time
    }

    /// World rotations and positions of every joint in frame `f` (None: rest pose).
    pub fn forward(&self, f: Option<usize>) -> (Vec<UnitQuaternion<f32>>, Vec<Point3<f32>>) {
        let mut rot = Vec::with_capacity(self.joints.len());
        let mut pos = Vec::with_capacity(self.joints.len());
        for j in &self.joints {
            let mut local = UnitQuaternion::identity();
            let mut trans = Vector3::zeros();
            if let Some(f) = f {
                let row = &self.values[f * self.channels..(f + 1) * self.channels];
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
        let at = |b: Bone| self.drives[b.index()];
        let hips_joint = at(Bone::Hips).expect("the hips are always driven");
        // The clip's axes: up from hips to head (or chest), left from the right hip (or
        // upper arm, in a clip without legs) to the left one.
        let hips = rest_pos[hips_joint];
        let top = [Bone::Head, Bone::Neck, Bone::Chest, Bone::Spine]
            .into_iter()
            .find(|&b| at(b).is_some());
        let legs = match (at(Bone::LeftThigh), at(Bone::RightThigh)) {
            (Some(l), Some(r)) => Some((l, r)),
            _ => None,
        };
        let (l, r) = legs.unwrap_or_else(|| {
            (
                at(Bone::LeftUpperArm).expect("arms are always driven"),
                at(Bone::RightUpperArm).expect("arms are always driven"),
            )
        });
        let up = top
            .and_then(at)
            .map_or(Vector3::y(), |i| rest_pos[i] - hips);
        let left = rest_pos[l] - rest_pos[r];
        let q0 = if up.norm() > 1e-6 && left.norm() > 1e-6 {
            frame_to_frame(&up, &left, &Vector3::y(), &Vector3::x())
        } else {
            UnitQuaternion::identity()
        };
        let q0i = q0.inverse();
        let frames = self.frame_count();
        let (scale, floor) = if legs.is_some() {
            // Standing hip height of the clip's skeleton: rest hips above its lowest point.
            let (mut lo, mut hip_y) = (f32::INFINITY, 0.0);
            for (i, j) in self.joints.iter().enumerate() {
                let p = q0 * (rest_pos[i] - hips);
                lo = lo.min(p.y);
                for e in &j.end_sites {
                    lo = lo.min((q0 * (rest_pos[i] - hips + e)).y);
                }
                if i == hips_joint {
                    hip_y = p.y;
                }
            }
            let src_h = (hip_y - lo).max(1e-6);
            let scale = sk.head(Bone::Hips).y / src_h;
            // The clip's floor: the lowest point it ever reaches (sampled).
            let stride = (frames / 200).max(1);
            let mut floor = f32::INFINITY;
            for f in (0..frames).step_by(stride) {
                let (rot, pos) = self.forward(Some(f));
                for (i, j) in self.joints.iter().enumerate() {
                    floor = floor.min((q0 * pos[i]).y);
                    for e in &j.end_sites {
                        floor = floor.min((q0 * (pos[i] + rot[i] * e)).y);
                    }
                }
            }
            (scale, floor)
        } else {
            // No legs to stand on: scaled by the torso's length, the hips where the
            // body's stand in the first frame.
            let src = top
                .and_then(at)
                .map_or(0.0, |i| (rest_pos[i] - hips).norm());
            let dst = top.map_or(0.0, |b| (sk.head(b) - sk.head(Bone::Hips)).norm());
            let scale = if src > 1e-6 && dst > 1e-6 {
                dst / src
            } else {
                1.0
            };
            let (_, pos) = self.forward(Some(0));
            let floor = (q0 * pos[hips_joint]).y - sk.head(Bone::Hips).y / scale;
            (scale, floor)
        };
        let align: Vec<UnitQuaternion<f32>> = Bone::ALL
            .iter()
            .map(|b| match dirs[b.index()] {
                Some(d) => shortest_arc(&b.tpose_dir(), &(q0 * d)),
                None => UnitQuaternion::identity(),
            })
            .collect();
        let mut out = Vec::with_capacity(frames);
        for f in 0..frames {
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
            let r = q0 * pos[hips_joint];
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
    let mut name = t.rest_of_line("a joint name")?;
    // `JOINT Name {` on one line.
    if let Some(n) = name.strip_suffix(" {") {
        name = n.to_string();
        t.pos -= 1;
    }
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
