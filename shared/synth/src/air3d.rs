//! Synthetic people drawing the 3-D vocabulary ([`crate::shapes3d`]) in the air, as the
//! gesture stage's tracker sees the hand: body-frame paths (x right, y down, z towards
//! the camera, shoulder widths) sampled at 30 frames a second. A development set for
//! classifiers of 3-D gestures that needs no camera and no rendering.
//!
//! What varies, by person: the size they draw at, how much of the depth they really put
//! in (people draw depth shallower than width), the plane they draw on (turned about
//! the vertical and the horizontal axis), its stretch, their speed and timing (constant
//! speed or the two-thirds power law), how sloppily they round corners, and the
//! tracker's noise, larger in depth as a depth camera's is. By repetition: the shape's
//! points moved a little, the plane turned a few degrees more, the speed ±15 %, and a
//! little of the hand's way in and out cut with the gesture.

use crate::shapes3d::{shape, VOCABULARY};
use nalgebra::{Point3, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One gesture as drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawnGesture {
    /// Its name in [`VOCABULARY`].
    pub label: String,
    /// Who drew it: `s{seed}-p{person}`, so that sets made with other seeds have other
    /// people.
    pub person: String,
    /// The hand's path, one point a frame.
    pub points: Vec<[f32; 3]>,
}

/// How one synthetic person draws.
#[derive(Debug, Clone, Copy)]
struct Person {
    size: f32,
    depth_gain: f32,
    yaw: f32,
    pitch: f32,
    stretch: [f32; 2],
    speed: f32,
    power_law: bool,
    sloppiness: usize,
    noise_xy: f32,
    noise_z: f32,
}

impl Person {
    fn draw<R: Rng>(rng: &mut R) -> Self {
        Self {
            size: rng.gen_range(0.7..1.2),
            depth_gain: rng.gen_range(0.3..1.0),
            yaw: rng.gen_range(-35.0f32..35.0).to_radians(),
            pitch: rng.gen_range(-30.0f32..30.0).to_radians(),
            stretch: [rng.gen_range(0.85..1.15), rng.gen_range(0.85..1.15)],
            speed: rng.gen_range(0.9..2.0),
            power_law: rng.gen_bool(0.5),
            sloppiness: rng.gen_range(0..4),
            noise_xy: rng.gen_range(0.003..0.01),
            noise_z: rng.gen_range(0.01..0.04),
        }
    }
}

/// `persons` people, each drawing every gesture of the vocabulary `repetitions` times
/// (in a shuffled order); all of it follows from `seed`.
pub fn draw_vocabulary(persons: usize, repetitions: usize, seed: u64) -> Vec<DrawnGesture> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x3D3D_0001);
    let mut out = Vec::new();
    for k in 0..persons {
        let person = Person::draw(&mut rng);
        let mut order: Vec<&str> = (0..repetitions)
            .flat_map(|_| VOCABULARY.iter().copied())
            .collect();
        rand::seq::SliceRandom::shuffle(&mut order[..], &mut rng);
        for label in order {
            let points = draw_one(label, &person, &mut rng);
            out.push(DrawnGesture {
                label: label.to_string(),
                person: format!("s{seed}-p{k:02}"),
                points,
            });
        }
    }
    out
}

fn draw_one<R: Rng>(label: &str, who: &Person, rng: &mut R) -> Vec<[f32; 3]> {
    let Some(path) = shape(label) else {
        return Vec::new();
    };
    let turn = Rotation3::from_euler_angles(
        who.pitch + rng.gen_range(-0.14..0.14),
        who.yaw + rng.gen_range(-0.14..0.14),
        rng.gen_range(-0.1..0.1),
    );
    let scale = Vector3::new(
        who.size * who.stretch[0],
        who.size * who.stretch[1],
        who.size * who.depth_gain,
    );
    let placed: Vec<Point3<f32>> = path
        .iter()
        .map(|q| {
            let q = Vector3::new(
                q.x - 0.5 + gauss(rng, 0.06),
                q.y - 0.5 + gauss(rng, 0.06),
                q.z - 0.5 + gauss(rng, 0.06),
            );
            Point3::from(turn * q.component_mul(&scale))
        })
        .collect();
    // Whoever cuts the gesture out of the stream (the spotter, `collect`) cuts a little
    // early or late: a bit of the hand's way in and out is part of it.
    let hooked: Vec<Point3<f32>> = std::iter::once(hook(placed[0], who.size, rng))
        .chain(placed.iter().copied())
        .chain(std::iter::once(hook(
            placed[placed.len() - 1],
            who.size,
            rng,
        )))
        .collect();
    let dense = rounded(&densify(&hooked, 0.01), 2 * who.sloppiness);
    let speed = who.speed * rng.gen_range(0.85..1.15);
    let timed = timed(&dense, speed, who.power_law);
    let (nxy, nz) = (who.noise_xy, who.noise_z);
    timed
        .iter()
        .map(|q| {
            [
                q.x + gauss(rng, nxy),
                q.y + gauss(rng, nxy),
                q.z + gauss(rng, nz),
            ]
        })
        .collect()
}

/// A point up to a fifth of `size` from `at`, in any direction.
fn hook<R: Rng>(at: Point3<f32>, size: f32, rng: &mut R) -> Point3<f32> {
    let d = Vector3::new(gauss(rng, 1.0), gauss(rng, 1.0), gauss(rng, 1.0));
    at + d.try_normalize(1e-6).unwrap_or_else(Vector3::x) * size * rng.gen_range(0.0..0.2)
}

/// A normal draw of standard deviation `s` (Box–Muller).
fn gauss<R: Rng>(rng: &mut R, s: f32) -> f32 {
    let u: f32 = rng.gen_range(f32::EPSILON..1.0);
    let v: f32 = rng.gen();
    s * (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * v).cos()
}

/// Points along the polyline no further apart than `step`.
fn densify(path: &[Point3<f32>], step: f32) -> Vec<Point3<f32>> {
    let mut out = vec![path[0]];
    for w in path.windows(2) {
        let n = (((w[1] - w[0]).norm() / step).ceil() as usize).max(1);
        out.extend((1..=n).map(|i| w[0] + (w[1] - w[0]) * (i as f32 / n as f32)));
    }
    out
}

/// A moving average over `window` points either side: corners rounded as a hand
/// rounds them, the ends kept.
fn rounded(path: &[Point3<f32>], window: usize) -> Vec<Point3<f32>> {
    if window == 0 {
        return path.to_vec();
    }
    (0..path.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(window), (i + window).min(path.len() - 1));
            let sum = path[a..=b]
                .iter()
                .fold(Vector3::zeros(), |s, q| s + q.coords);
            Point3::from(sum / (b - a + 1) as f32)
        })
        .collect()
}

/// The hand's positions 30 times a second along `path` at a mean `speed` (shoulder
/// widths a second): slowing in and out at the ends, and with `power_law` slower in
/// curves (speed ∝ curvature^−1/3), else at an even pace between them.
fn timed(path: &[Point3<f32>], speed: f32, power_law: bool) -> Vec<Point3<f32>> {
    let n = path.len();
    if n < 2 {
        return path.to_vec();
    }
    let mut cum = vec![0.0f32];
    for w in path.windows(2) {
        cum.push(cum.last().copied().unwrap_or(0.0) + (w[1] - w[0]).norm());
    }
    let total = cum[n - 1].max(1e-6);
    // The relative speed at each point.
    let rel: Vec<f32> = (0..n)
        .map(|i| {
            let ends = (cum[i] / total).min(1.0 - cum[i] / total);
            let ease = (ends / 0.12).clamp(0.15, 1.0);
            let bend = if power_law && i > 0 && i + 1 < n {
                let (a, b) = (path[i] - path[i - 1], path[i + 1] - path[i]);
                let cos = a.dot(&b) / (a.norm() * b.norm()).max(1e-9);
                let curvature = cos.clamp(-1.0, 1.0).acos() / a.norm().max(1e-4);
                (1.0 + curvature * 0.3).powf(-1.0 / 3.0)
            } else {
                1.0
            };
            ease * bend
        })
        .collect();
    // Time to cover each span at the relative speed, scaled to the mean speed.
    let mut times = vec![0.0f32];
    for i in 1..n {
        let v = (rel[i - 1] + rel[i]) / 2.0;
        times.push(times[i - 1] + (cum[i] - cum[i - 1]) / v.max(1e-3));
    }
    let scale = (total / speed) / times[n - 1].max(1e-6);
    let dt = 1.0 / 30.0;
    let frames = ((times[n - 1] * scale) / dt).ceil() as usize;
    let mut out = Vec::with_capacity(frames + 1);
    let mut j = 1;
    for f in 0..=frames {
        let t = (f as f32 * dt / scale).min(times[n - 1]);
        while j < n - 1 && times[j] < t {
            j += 1;
        }
        let span = (times[j] - times[j - 1]).max(1e-9);
        let u = ((t - times[j - 1]) / span).clamp(0.0, 1.0);
        out.push(path[j - 1] + (path[j] - path[j - 1]) * u);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_are_reproducible_and_people_differ_by_seed() {
        let a = draw_vocabulary(2, 1, 7);
        assert_eq!(a, draw_vocabulary(2, 1, 7));
        assert_eq!(a.len(), 2 * VOCABULARY.len());
        let b = draw_vocabulary(2, 1, 8);
        assert!(a.iter().all(|g| g.person.starts_with("s7-")));
        assert!(b.iter().all(|g| g.person.starts_with("s8-")));
        for g in &a {
            // At 0.9–2.3 shoulder widths a second, a gesture takes a few dozen frames.
            assert!(
                (8..400).contains(&g.points.len()),
                "{} {}",
                g.label,
                g.points.len()
            );
        }
    }

    #[test]
    fn a_push_goes_towards_the_camera_and_a_pull_away() {
        for g in draw_vocabulary(3, 2, 1) {
            let (first, last) = (g.points[0], g.points[g.points.len() - 1]);
            let dz = last[2] - first[2];
            match g.label.as_str() {
                "push" => assert!(dz > 0.2, "{dz}"),
                "pull" => assert!(dz < -0.2, "{dz}"),
                _ => {}
            }
        }
    }
}
