//! The frame a gesture is measured in: origin between the shoulders, x towards the right
//! shoulder, y down the spine, scaled by the shoulder width; held steady while the
//! person draws.
//!
//! A skeleton's own frame is not steady enough. An estimated chest turns a little with
//! the drawing arm (the pose stage fits the torso and the arm together), and a frame
//! that turns with the hand squeezes the hand's path along the way it moves, enough to
//! read a "5" as an "S" (README, "Why the body frame is held steady"). A person
//! drawing does not turn or walk, so the frame is smoothed with a time constant longer
//! than a symbol. A real turn or step is not a wobble of a few degrees or centimetres:
//! the further the skeleton's frame is from the smoothed one, the faster the smoothed
//! one follows, so a person who turns or walks is followed within a fraction of a
//! second.

use airglyph_core::{Joint, Skeleton};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// How the body frame is smoothed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FrameSmoothing {
    /// Time constant (seconds) while the skeleton's frame stays close to the smoothed
    /// one; 0 takes every skeleton's own frame.
    pub seconds: f64,
    /// A turn this large (degrees) is followed twice as fast, and the rate grows with
    /// its fourth power…
    pub turn_degrees: f64,
    /// …and so is a shift of the origin this large (shoulder widths).
    pub shift: f64,
}

impl Default for FrameSmoothing {
    fn default() -> Self {
        // The demo's 36 symbols through the pose stage (`airglyph spot --poses`): their
        // height for their width against the truth's 1.106 → 0.996, the rms difference
        // of their shapes 0.066 → 0.062 of a symbol's size; at 1 s 0.990 and 0.064.
        // The drawing arm turns the estimated chest by a few degrees: 15° is beyond it.
        Self {
            seconds: 4.0,
            turn_degrees: 8.0,
            shift: 0.1,
        }
    }
}

/// A body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyFrame {
    /// Between the shoulders, camera frame, metres.
    pub origin: Vector3<f32>,
    /// Unit vector towards the right shoulder.
    pub ex: Vector3<f32>,
    /// Unit vector down the spine, orthogonal to `ex`.
    pub ey: Vector3<f32>,
    /// Shoulder width, metres.
    pub width: f32,
}

impl BodyFrame {
    /// The frame of one skeleton, or None when its shoulders or spine are degenerate.
    pub fn of(s: &Skeleton) -> Option<Self> {
        let ls = s[Joint::LeftShoulder].coords;
        let rs = s[Joint::RightShoulder].coords;
        let width = (rs - ls).norm();
        if width < 0.05 {
            return None;
        }
        let ex = (rs - ls) / width;
        let down = s[Joint::Pelvis].coords - s[Joint::Neck].coords;
        let ey = down - ex * ex.dot(&down);
        if ey.norm() < 1e-3 {
            return None;
        }
        Some(Self {
            origin: (ls + rs) * 0.5,
            ex,
            ey: ey.normalize(),
            width,
        })
    }

    /// A camera-frame point in this frame: (x right, y down, forward), shoulder widths.
    pub fn project(&self, p: Vector3<f32>) -> [f32; 3] {
        let d = p - self.origin;
        // Right × down is the way the person faces (the camera frame is right-handed).
        let forward = self.ex.cross(&self.ey);
        [self.ex.dot(&d), self.ey.dot(&d), forward.dot(&d)].map(|c| c / self.width)
    }

    /// This frame moved a share `axes` of the way to `to` in orientation and scale and
    /// a share `origin` of the way in position.
    fn towards(&self, to: &Self, axes: f32, origin: f32) -> Self {
        let ex = (self.ex + (to.ex - self.ex) * axes).normalize();
        let ey = self.ey + (to.ey - self.ey) * axes;
        Self {
            origin: self.origin + (to.origin - self.origin) * origin,
            ex,
            ey: (ey - ex * ex.dot(&ey)).normalize(),
            width: self.width + (to.width - self.width) * axes,
        }
    }
}

/// Smooths a stream of body frames (see the module's documentation).
#[derive(Debug, Clone)]
pub struct FrameSmoother {
    cfg: FrameSmoothing,
    last: Option<(BodyFrame, f64)>,
}

impl FrameSmoother {
    pub fn new(cfg: FrameSmoothing) -> Self {
        Self { cfg, last: None }
    }

    /// Forgets the frame: the next one passes unchanged.
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// The smoothed frame after the skeleton's frame `now` at `t` seconds.
    pub fn update(&mut self, now: BodyFrame, t: f64) -> BodyFrame {
        let frame = match self.last {
            Some((f, t0)) if self.cfg.seconds > 0.0 => {
                let dt = (t - t0).max(0.0);
                let turn = f.ex.angle(&now.ex).max(f.ey.angle(&now.ey)).to_degrees() as f64;
                let shift = ((now.origin - f.origin).norm() / f.width) as f64;
                let axes = self.share(dt, turn, self.cfg.turn_degrees);
                let origin = self.share(dt, shift, self.cfg.shift);
                f.towards(&now, axes, origin)
            }
            _ => now,
        };
        self.last = Some((frame, t));
        frame
    }

    /// How far an exponential filter moves in `dt` when the new value is `away` from
    /// the filtered one, its rate growing with (away / `scale`)⁴: a sharp knee between
    /// the wobble it holds and the turn it follows.
    fn share(&self, dt: f64, away: f64, scale: f64) -> f32 {
        let speedup = if scale > 0.0 {
            1.0 + (away / scale).powi(4)
        } else {
            1.0
        };
        (1.0 - (-dt * speedup / self.cfg.seconds).exp()) as f32
    }
}

/// A skeleton of a person facing the camera at `distance` metres with the right hand at
/// body-frame point (x, y) (shoulder widths; x to the person's right, y down) and the
/// left hand hanging. For tests and synthetic streams.
pub fn skeleton_with_hand(x: f32, y: f32, distance: f32) -> Skeleton {
    use nalgebra::Point3;
    let sw = 0.36f32;
    let z = distance;
    // Facing the camera: the person's right is the camera's left (−x); y down.
    let mut j = [Point3::new(0.0, 0.0, z); Joint::COUNT];
    let set = |j: &mut [Point3<f32>; Joint::COUNT], k: Joint, p: [f32; 3]| {
        j[k.index()] = Point3::new(p[0], p[1], p[2]);
    };
    set(&mut j, Joint::Head, [0.0, -0.55, z]);
    set(&mut j, Joint::Neck, [0.0, -0.35, z]);
    set(&mut j, Joint::Torso, [0.0, -0.1, z]);
    set(&mut j, Joint::Pelvis, [0.0, 0.2, z]);
    set(&mut j, Joint::LeftShoulder, [sw / 2.0, -0.3, z]);
    set(&mut j, Joint::RightShoulder, [-sw / 2.0, -0.3, z]);
    set(&mut j, Joint::LeftElbow, [0.22, -0.05, z]);
    set(&mut j, Joint::LeftHand, [0.24, 0.2, z]);
    set(&mut j, Joint::RightHand, [-x * sw, -0.3 + y * sw, z - 0.35]);
    set(
        &mut j,
        Joint::RightElbow,
        [-0.2 - x * sw * 0.3, -0.1, z - 0.15],
    );
    set(&mut j, Joint::LeftHip, [0.1, 0.22, z]);
    set(&mut j, Joint::RightHip, [-0.1, 0.22, z]);
    set(&mut j, Joint::LeftKnee, [0.1, 0.65, z]);
    set(&mut j, Joint::RightKnee, [-0.1, 0.65, z]);
    set(&mut j, Joint::LeftFoot, [0.1, 1.05, z]);
    set(&mut j, Joint::RightFoot, [-0.1, 1.05, z]);
    Skeleton::new(j)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    /// The frame of a person facing the camera 2.5 m away, turned by `yaw` (radians,
    /// about the vertical) and moved `dx` metres along the camera's x axis.
    fn frame(yaw: f32, dx: f32) -> BodyFrame {
        let mut s = skeleton_with_hand(0.0, 0.0, 2.5);
        let centre = Vector3::new(0.0, 0.0, 2.5);
        let r = Rotation3::from_axis_angle(&Vector3::y_axis(), yaw);
        for p in s.joints.iter_mut() {
            p.coords = r * (p.coords - centre) + centre + Vector3::new(dx, 0.0, 0.0);
        }
        BodyFrame::of(&s).unwrap()
    }

    fn degrees_apart(a: &BodyFrame, b: &BodyFrame) -> f32 {
        a.ex.angle(&b.ex).to_degrees()
    }

    #[test]
    fn a_wobble_of_a_few_degrees_is_held_steady() {
        let mut f = FrameSmoother::new(FrameSmoothing::default());
        let still = frame(0.0, 0.0);
        let mut worst = 0.0f32;
        // ±3° at 1 Hz, as the drawing arm turns an estimated chest, for 10 s.
        for i in 0..300 {
            let t = i as f64 / 30.0;
            let wobble = 3f32.to_radians() * (std::f32::consts::TAU * t as f32).sin();
            let out = f.update(frame(wobble, 0.0), t);
            if i > 30 {
                worst = worst.max(degrees_apart(&out, &still));
            }
        }
        assert!(worst < 0.3, "the frame wobbles by {worst}°");
    }

    /// A person standing still for a second, turning a quarter turn in half a second,
    /// standing for half a second, then walking a metre sideways in a second and
    /// standing for half a second: how far (degrees) the smoothed frame is from the
    /// turned one after the turn, and how far (metres) its origin is behind after the
    /// walk.
    fn turn_and_walk(cfg: FrameSmoothing) -> (f32, f32) {
        let mut f = FrameSmoother::new(cfg);
        let quarter = 90f32.to_radians();
        let mut out = frame(0.0, 0.0);
        let mut after_turn = 0.0;
        for i in 0..120 {
            let t = i as f32 / 30.0;
            let yaw = ((t - 1.0) * 2.0).clamp(0.0, 1.0) * quarter;
            let dx = (t - 2.0).clamp(0.0, 1.0);
            out = f.update(frame(yaw, dx), t as f64);
            if i == 59 {
                after_turn = degrees_apart(&out, &frame(quarter, 0.0));
            }
        }
        (after_turn, (out.origin - frame(quarter, 1.0).origin).norm())
    }

    #[test]
    fn a_person_who_turns_or_walks_is_followed() {
        let (turn, walk) = turn_and_walk(FrameSmoothing::default());
        assert!(turn < 10.0, "{turn}° behind half a second after a turn");
        assert!(walk < 0.05, "{walk} m behind half a second after a walk");
        // A plain exponential filter of the same time constant would still lag far.
        let plain = FrameSmoothing {
            turn_degrees: 0.0,
            shift: 0.0,
            ..FrameSmoothing::default()
        };
        let (turn, walk) = turn_and_walk(plain);
        assert!(turn > 45.0 && walk > 0.5, "{turn}° {walk} m");
    }

    #[test]
    fn without_smoothing_each_skeleton_gives_its_own_frame() {
        let mut f = FrameSmoother::new(FrameSmoothing {
            seconds: 0.0,
            ..FrameSmoothing::default()
        });
        f.update(frame(0.0, 0.0), 0.0);
        let turned = frame(0.2, 0.1);
        assert_eq!(f.update(turned, 1.0 / 30.0), turned);
    }
}
