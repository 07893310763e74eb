//! Air-drawing: the right hand traces each symbol on a plane in front of the body by
//! arm IK (written as the person sees it, so mirrored in the camera's view), at a natural speed (1–1.5 s a symbol, minimum-jerk timing), with idle and
//! random non-gesture hand movement between symbols. The left arm stays where the rest
//! pose puts it (hanging, standing; on the table or the thighs, seated).
//!
//! Timeline of one symbol: idle at rest (0.4–1.0 s), in half the cases a random
//! non-gesture movement (1–3 reaches to the face, the chest, the side …), a move to the
//! symbol's first point, the symbol itself (the gesture's frames), a move back to rest.

use crate::canon::{Bone, Pose, TposeSkeleton};
use crate::error::SynthError;
use crate::glyphs::{self, Glyph};
use crate::motion::{DrawSpec, Setting};
use crate::poses::{self, Side};
use crate::shapes3d;
use airglyph_core::gestures::GestureTruth;
use airglyph_core::Joint;
use nalgebra::{Point, Point2, Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub(crate) struct Drawing {
    rest: Pose,
    sk: TposeSkeleton,
    /// The right palm's target, one a frame (body frame).
    targets: Vec<Point3<f32>>,
    gestures: Vec<GestureTruth>,
    repeat: bool,
    pole: Vector3<f32>,
    sway: crate::motion::Sway,
}

/// Minimum-jerk timing: 0 → 1 with zero speed and acceleration at both ends.
fn min_jerk(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * t * (10.0 - 15.0 * t + 6.0 * t * t)
}

/// The point at arc-length fraction `s` along a polyline (in the plane or in space).
fn along<const D: usize>(path: &[Point<f32, D>], s: f32) -> Point<f32, D> {
    let total: f32 = path.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    if path.len() < 2 || total <= 0.0 {
        return path[0];
    }
    let mut want = s.clamp(0.0, 1.0) * total;
    for w in path.windows(2) {
        let l = (w[1] - w[0]).norm();
        if want <= l && l > 0.0 {
            return w[0] + (w[1] - w[0]) * (want / l);
        }
        want -= l;
    }
    path[path.len() - 1]
}

/// What the person draws: a symbol on a pane (a glyph's strokes), or a gesture of the
/// 3-D vocabulary, which goes towards and away from the camera too.
enum Shape {
    Flat(Glyph),
    /// Its name and path in a unit box (x right, y down, z towards the camera).
    Deep(String, Vec<Point3<f32>>),
}

/// The symbols of a draw script: names separated by commas (`push,circle-up,7`), one
/// gesture of the 3-D vocabulary (`push`), or else one a character (`0123ABC`).
pub(crate) fn script_names(symbols: &str) -> Vec<String> {
    if symbols.contains(',') || shapes3d::shape(symbols.trim()).is_some() {
        symbols
            .split(',')
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .map(str::to_string)
            .collect()
    } else {
        symbols
            .chars()
            .filter(|c| !c.is_whitespace())
            .map(String::from)
            .collect()
    }
}

impl Drawing {
    pub(crate) fn new(
        d: &DrawSpec,
        sk: &TposeSkeleton,
        setting: Setting,
        fps: f32,
        seed: u64,
    ) -> Result<Self, SynthError> {
        let samples = match &d.samples {
            Some(p) => Some((p, glyphs::read_jsonl(p)?)),
            None => None,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xA1B2_C3D4);
        let mut glyph_list = Vec::new();
        for name in script_names(&d.symbols) {
            if let (None, Some(path)) = (&samples, shapes3d::shape(&name)) {
                glyph_list.push(Shape::Deep(name, path));
                continue;
            }
            let g = match &samples {
                Some((path, all)) => {
                    let label = name.clone();
                    let pool: Vec<&Glyph> = all
                        .iter()
                        .filter(|g| g.label.eq_ignore_ascii_case(&label))
                        .collect();
                    if pool.is_empty() {
                        return Err(SynthError::Config(format!(
                            "{}: no sample of symbol {label:?}",
                            path.display()
                        )));
                    }
                    pool[rng.gen_range(0..pool.len())].clone()
                }
                None => {
                    let mut chars = name.chars();
                    let c = chars.next().filter(|_| chars.next().is_none());
                    c.and_then(glyphs::template).ok_or_else(|| {
                        // A character as a character ('#'), a name as a string.
                        let shown = c.map_or(format!("{name:?}"), |c| format!("{c:?}"));
                        SynthError::Config(format!(
                            "no built-in template for symbol {shown} (built in: {} and the 3-D gestures {}); give a trajectory JSONL",
                            glyphs::BUILT_IN,
                            shapes3d::VOCABULARY.join(",")
                        ))
                    })?
                }
            };
            glyph_list.push(Shape::Flat(g));
        }
        if glyph_list.is_empty() {
            return Err(SynthError::Config(
                "air-drawing needs at least one symbol".into(),
            ));
        }
        let h = poses::height(sk);
        let rest = d
            .rest
            .unwrap_or(setting.default_rest())
            .pose_in(sk, setting.posture);
        let heads = sk.posed_heads(&rest);
        let rest_hand = sk.posed_point(&heads, &rest, Bone::RightHand, sk.joint(Joint::RightHand));
        // Where the upper body is: the T-pose's, moved with the hips (seated).
        let lift = rest.root - sk.head(Bone::Hips);
        let shoulder = sk.joint(Joint::RightShoulder) + lift;
        let chest = sk.joint(Joint::Torso) + lift;
        let head = sk.skull + lift;
        let frames = |secs: f32| (secs * fps).round().max(1.0) as usize;
        let mut targets: Vec<Point3<f32>> = Vec::new();
        let mut gestures = Vec::new();
        let mut at = rest_hand;
        let move_to =
            |targets: &mut Vec<Point3<f32>>, from: Point3<f32>, to: Point3<f32>, n: usize| {
                for i in 1..=n {
                    targets.push(from + (to - from) * min_jerk(i as f32 / n as f32));
                }
            };
        for g in &glyph_list {
            // Idle.
            let n = frames(rng.gen_range(0.4..1.0));
            targets.extend(std::iter::repeat_n(at, n));
            // Random non-gesture movement.
            if rng.gen_bool(0.5) {
                for _ in 0..rng.gen_range(1..=3) {
                    let to = match rng.gen_range(0..4) {
                        0 => head + Vector3::new(-0.05, -0.02, 0.09) * h, // touch the face
                        1 => chest + Vector3::new(0.03, 0.0, 0.1) * h,    // hand to chest
                        2 => shoulder + Vector3::new(-0.2, -0.15, 0.05) * h, // out to the side
                        _ => {
                            rest_hand
                                + Vector3::new(
                                    rng.gen_range(-0.05..0.05),
                                    rng.gen_range(0.0..0.1),
                                    rng.gen_range(0.0..0.1),
                                ) * h
                        }
                    };
                    let n = frames(rng.gen_range(0.4..0.8));
                    move_to(&mut targets, at, to, n);
                    at = to;
                    let n = frames(rng.gen_range(0.1..0.4));
                    targets.extend(std::iter::repeat_n(at, n));
                }
            }
            // The drawing plane: in front of the right shoulder, symbol 0.3–0.4 m tall.
            let size = h * rng.gen_range(0.17..0.23);
            let mut centre = Point3::new(
                shoulder.x * 0.55 + rng.gen_range(-0.03..0.03),
                shoulder.y - 0.1 * h + rng.gen_range(-0.03..0.03),
                shoulder.z + 0.26 * h + rng.gen_range(-0.02..0.02),
            );
            // Over a table, the symbol's foot clears the table top by a hand.
            if let Some(top) = setting.table_m {
                centre.y = centre.y.max(top + 0.1 + size / 2.0);
            }
            // The person writes as they see it, on a pane in front of them: the symbol's
            // right is the person's right (−x), its down is −y. From the camera it
            // appears mirrored, as writing on a window does from outside.
            let place = |p: Point2<f32>| {
                centre + Vector3::new(-(p.x - 0.5) * size, -(p.y - 0.5) * size, 0.0)
            };
            // A 3-D gesture's depth: 0.8 of its size towards and away from the camera
            // (z up towards the camera), around the pane.
            let place3 = |p: Point3<f32>| {
                centre
                    + Vector3::new(
                        -(p.x - 0.5) * size,
                        -(p.y - 0.5) * size,
                        (p.z - 0.5) * size * 0.8,
                    )
            };
            let first;
            match g {
                Shape::Flat(g) => {
                    let path = g.path();
                    let start = place(path[0]);
                    move_to(&mut targets, at, start, frames(rng.gen_range(0.35..0.5)));
                    let length: f32 = path.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
                    let secs = (0.75 + 0.2 * length).clamp(1.0, 1.5) * rng.gen_range(0.92..1.08);
                    let n = frames(secs);
                    first = targets.len();
                    for i in 0..n {
                        let s = min_jerk(i as f32 / (n - 1).max(1) as f32);
                        targets.push(place(along(&path, s)));
                    }
                }
                Shape::Deep(_, path) => {
                    let start = place3(path[0]);
                    move_to(&mut targets, at, start, frames(rng.gen_range(0.35..0.5)));
                    let length: f32 = path.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
                    let secs = (0.75 + 0.2 * length).clamp(1.0, 1.5) * rng.gen_range(0.92..1.08);
                    let n = frames(secs);
                    first = targets.len();
                    for i in 0..n {
                        let s = min_jerk(i as f32 / (n - 1).max(1) as f32);
                        targets.push(place3(along(path, s)));
                    }
                }
            }
            gestures.push(GestureTruth {
                label: match g {
                    Shape::Flat(g) => g.label.clone(),
                    Shape::Deep(name, _) => name.clone(),
                },
                start_frame: first,
                end_frame: targets.len() - 1,
            });
            at = *targets.last().unwrap();
            move_to(&mut targets, at, rest_hand, frames(rng.gen_range(0.4..0.6)));
            at = rest_hand;
        }
        targets.extend(std::iter::repeat_n(at, frames(0.5)));
        Ok(Self {
            rest,
            sk: sk.clone(),
            targets,
            gestures,
            repeat: d.repeat,
            pole: Vector3::new(-1.0, -1.2, -0.4),
            sway: crate::motion::Sway::new(seed, fps),
        })
    }

    pub(crate) fn len(&self) -> Option<usize> {
        (!self.repeat).then_some(self.targets.len())
    }

    fn cycle(&self, frame: usize) -> (usize, usize) {
        let n = self.targets.len();
        if self.repeat {
            (frame / n, frame % n)
        } else {
            (0, frame.min(n - 1))
        }
    }

    pub(crate) fn pose(&self, frame: usize) -> Pose {
        let (_, i) = self.cycle(frame);
        let mut p = self.rest;
        poses::arm_ik(&self.sk, &mut p, Side::Right, self.targets[i], &self.pole);
        self.sway.apply(&mut p, frame);
        p
    }

    pub(crate) fn gesture(&self, frame: usize) -> Option<GestureTruth> {
        let (c, i) = self.cycle(frame);
        if !self.repeat && frame >= self.targets.len() {
            return None;
        }
        let off = c * self.targets.len();
        self.gestures
            .iter()
            .find(|g| (g.start_frame..=g.end_frame).contains(&i))
            .map(|g| GestureTruth {
                label: g.label.clone(),
                start_frame: g.start_frame + off,
                end_frame: g.end_frame + off,
            })
    }

    pub(crate) fn gestures(&self) -> Vec<GestureTruth> {
        self.gestures.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripts_name_symbols_by_character_or_by_comma() {
        assert_eq!(script_names("07 A"), ["0", "7", "A"]);
        assert_eq!(script_names("push"), ["push"]);
        assert_eq!(
            script_names("push, circle-up,,7"),
            ["push", "circle-up", "7"]
        );
    }

    #[test]
    fn a_push_goes_towards_the_camera_and_a_symbol_stays_on_its_pane() {
        let body = crate::body::Body::procedural(&crate::body::ProceduralBody::default()).unwrap();
        let sk = body.tpose();
        let spec = |symbols: &str| DrawSpec {
            symbols: symbols.into(),
            samples: None,
            repeat: false,
            rest: None,
        };
        let depth = |symbols: &str| {
            let d = Drawing::new(&spec(symbols), sk, Setting::default(), 30.0, 1).unwrap();
            let g = &d.gestures()[0];
            let z: Vec<f32> = (g.start_frame..=g.end_frame)
                .map(|i| d.targets[i].z)
                .collect();
            (
                z[0],
                z[z.len() - 1],
                z.iter().cloned().fold(f32::MIN, f32::max),
            )
        };
        let (first, last, _) = depth("push");
        assert!(last - first > 0.2, "{first} → {last}");
        let (first, last, deepest) = depth("7");
        assert_eq!((first, last), (deepest, deepest));
        assert!(matches!(
            Drawing::new(&spec("nudge,7"), sk, Setting::default(), 30.0, 1),
            Err(SynthError::Config(_))
        ));
    }
}
