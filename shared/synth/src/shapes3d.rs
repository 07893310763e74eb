//! A vocabulary of gestures drawn in three dimensions, as one continuous path each in a
//! unit box: x to the person's right, y down, z towards where the person faces (the
//! camera). Several differ only in depth — a push and a pull, a swipe and a zigzag
//! whose teeth point at the camera, a circle and a helix — so a recognizer that drops
//! depth must confuse them, and one that keeps it need not.

use nalgebra::Point3;

/// The gestures of the vocabulary, in a fixed order.
pub const VOCABULARY: &[&str] = &[
    "push",
    "pull",
    "swipe",
    "zigzag",
    "zigzag-deep",
    "circle",
    "circle-up",
    "circle-side",
    "helix-in",
    "helix-out",
    "right-push",
    "right-pull",
    "down-push",
    "down-pull",
];

fn p(x: f32, y: f32, z: f32) -> Point3<f32> {
    Point3::new(x, y, z)
}

/// A full turn from the top, clockwise as the person sees it in its plane, with `at`
/// placing (cos, sin) of each angle, and `z` the depth along the turn (0 → 1).
fn turn(at: impl Fn(f32, f32, f32) -> Point3<f32>) -> Vec<Point3<f32>> {
    let n = 36;
    (0..=n)
        .map(|i| {
            let f = i as f32 / n as f32;
            let a = -std::f32::consts::FRAC_PI_2 + f * std::f32::consts::TAU;
            at(0.5 + 0.5 * a.cos(), 0.5 + 0.5 * a.sin(), f)
        })
        .collect()
}

/// The path of gesture `name` of [`VOCABULARY`] (None for another name).
pub fn shape(name: &str) -> Option<Vec<Point3<f32>>> {
    let zig = |deep: bool| -> Vec<Point3<f32>> {
        (0..=4)
            .map(|i| {
                let (x, t) = (i as f32 / 4.0, (i % 2) as f32);
                if deep {
                    p(x, 0.5, t)
                } else {
                    p(x, 0.25 + 0.5 * t, 0.5)
                }
            })
            .collect()
    };
    Some(match name {
        "push" => vec![p(0.5, 0.5, 0.0), p(0.5, 0.5, 1.0)],
        "pull" => vec![p(0.5, 0.5, 1.0), p(0.5, 0.5, 0.0)],
        "swipe" => vec![p(0.0, 0.5, 0.5), p(1.0, 0.5, 0.5)],
        "zigzag" => zig(false),
        "zigzag-deep" => zig(true),
        "circle" => turn(|c, s, _| p(c, s, 0.5)),
        // Facing up: in the horizontal plane, clockwise as seen from above.
        "circle-up" => turn(|c, s, _| p(c, 0.5, 1.0 - s)),
        // Facing the right: in the plane of the body's side.
        "circle-side" => turn(|c, s, _| p(0.5, s, c)),
        "helix-in" => turn(p),
        "helix-out" => turn(|c, s, f| p(c, s, 1.0 - f)),
        "right-push" => vec![p(0.0, 0.5, 0.0), p(1.0, 0.5, 0.0), p(1.0, 0.5, 1.0)],
        "right-pull" => vec![p(0.0, 0.5, 1.0), p(1.0, 0.5, 1.0), p(1.0, 0.5, 0.0)],
        "down-push" => vec![p(0.5, 0.0, 0.0), p(0.5, 1.0, 0.0), p(0.5, 1.0, 1.0)],
        "down-pull" => vec![p(0.5, 0.0, 1.0), p(0.5, 1.0, 1.0), p(0.5, 1.0, 0.0)],
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_gesture_has_a_path_in_the_unit_box_and_some_differ_only_in_depth() {
        for name in VOCABULARY {
            let path = shape(name).unwrap();
            assert!(path.len() >= 2, "{name}");
            assert!(path
                .iter()
                .all(|q| q.coords.iter().all(|c| (-1e-6..=1.0 + 1e-6).contains(c))));
        }
        assert!(shape("nothing").is_none());
        // Seen from the front (z dropped), a push and a pull are the same point and a
        // helix in and out the same circle.
        let front = |n: &str| -> Vec<(i32, i32)> {
            shape(n)
                .unwrap()
                .iter()
                .map(|q| ((q.x * 1000.0) as i32, (q.y * 1000.0) as i32))
                .collect()
        };
        assert_eq!(front("push"), front("pull"));
        assert_eq!(front("helix-in"), front("helix-out"));
        assert_eq!(front("helix-in"), front("circle"));
        assert_ne!(shape("helix-in"), shape("helix-out"));
    }
}
