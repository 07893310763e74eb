//! The template member of the network ensemble: a few resampled, normalized examples of
//! each label, matched to a trajectory by dynamic time warping over positions and
//! directions. Networks need many samples per label; a template matcher is strong from
//! the first few, so a model trained on a few samples per label carries one and mixes
//! its posterior with the networks'. What a model file holds of it and its decision;
//! which samples become templates, and with what weight, is the lab's training.
//!
//! A member trained on trajectories with depth matches them in space: without it a push
//! and a pull, or a circle and a helix, are the same path, and the member would outvote
//! networks that tell them apart.

use crate::dtw::dtw;
use crate::features::resample;
use crate::features3d::resample3;
use crate::trajectory::{Point3, Trajectory};
use serde::{Deserialize, Serialize};
use std::sync::OnceLock;

/// One example: its class (an index into the classifier's classes) and its path,
/// resampled to [`Templates::points`] points at equal arc length and normalized as the
/// networks' features are (centred on its bounding box, divided by its larger side).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Template {
    /// Index into the classifier's classes.
    pub class: usize,
    /// The normalized points (in the frontal plane).
    pub path: Vec<[f32; 2]>,
    /// The normalized depth of each point, in a member that matches in space
    /// ([`Templates::depth`]); absent in one that matches in the plane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth: Option<Vec<f32>>,
}

impl Template {
    /// A template of class `class` made from a trajectory, in space when `depth` (a
    /// trajectory without depth is then a flat one).
    pub fn of(class: usize, points: usize, depth: bool, t: &Trajectory) -> Self {
        if depth {
            let p = resample3(t, points).points;
            Self {
                class,
                path: p.iter().map(|q| [q[0], q[1]]).collect(),
                depth: Some(p.iter().map(|q| q[2]).collect()),
            }
        } else {
            Self {
                class,
                path: resample(t, points).points,
                depth: None,
            }
        }
    }
}

/// The template member: its matching settings, its share of the ensemble's decision and
/// its templates.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Templates {
    /// Points every trajectory is resampled to before matching.
    pub points: usize,
    /// Whether it matches in space (trained on trajectories with depth). Members
    /// without the field, every one made before it, match in the plane.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub depth: bool,
    /// Sakoe–Chiba band half-width, in points: how far one path may run ahead of the
    /// other.
    pub band: usize,
    /// How much a difference of direction (unit vectors) counts against a difference of
    /// position (fractions of the larger side): directions tell apart shapes whose
    /// points lie close but that are drawn another way round.
    pub direction_weight: f32,
    /// Softness of the posterior over the per-class distances (mean cost per point).
    pub temperature: f32,
    /// Its share of the ensemble's posterior (the networks share the rest).
    pub weight: f32,
    /// At least one a class.
    pub templates: Vec<Template>,
    /// The templates' steps, made on first use (not in the file): a decision then only
    /// matches.
    #[serde(skip)]
    pub(crate) cache: OnceLock<Steps>,
}

/// The templates' steps: a point's position and unit direction, the direction scaled
/// by the member's weight for it; in the plane or in space. The plane keeps its own
/// (shorter) steps, so that a member matching in the plane costs what it did.
#[derive(Debug, Clone)]
pub(crate) enum Steps {
    Plane(Vec<Vec<[f32; 4]>>),
    Space(Vec<Vec<[f32; 6]>>),
}

impl Templates {
    /// Checks sizes, finiteness and that every one of `classes` classes has a template:
    /// a model file is not trusted.
    pub fn validate(&self, classes: usize) -> Result<(), String> {
        use crate::limits::{finite_within, within, MAX_FEATURE_POINTS, MAX_TEMPLATES};
        within("templates.points", self.points, 2, MAX_FEATURE_POINTS)?;
        within("templates.band", self.band, 0, MAX_FEATURE_POINTS)?;
        finite_within(
            "templates.direction_weight",
            self.direction_weight as f64,
            0.0,
            100.0,
        )?;
        finite_within("templates.temperature", self.temperature as f64, 1e-6, 1e6)?;
        finite_within("templates.weight", self.weight as f64, 0.0, 1.0)?;
        within(
            "the number of templates",
            self.templates.len(),
            1,
            MAX_TEMPLATES,
        )?;
        let mut has = vec![false; classes];
        for (i, t) in self.templates.iter().enumerate() {
            if t.path.len() != self.points {
                return Err(format!(
                    "template {i} has {} points; the member resamples to {}",
                    t.path.len(),
                    self.points
                ));
            }
            match (&t.depth, self.depth) {
                (Some(d), true) if d.len() != self.points => {
                    return Err(format!(
                        "template {i} has {} depths for its {} points",
                        d.len(),
                        self.points
                    ))
                }
                (None, true) => {
                    return Err(format!(
                        "template {i} has no depth; the member matches in space"
                    ))
                }
                (Some(_), false) => {
                    return Err(format!(
                        "template {i} has a depth; the member matches in the plane"
                    ))
                }
                _ => {}
            }
            let depth = t.depth.iter().flatten();
            if t.path.iter().flatten().chain(depth).any(|v| !v.is_finite()) {
                return Err(format!("template {i} holds a non-finite point"));
            }
            match has.get_mut(t.class) {
                Some(h) => *h = true,
                None => {
                    return Err(format!(
                        "template {i} is of class {}; the classifier has {classes}",
                        t.class
                    ))
                }
            }
        }
        if let Some(c) = has.iter().position(|h| !h) {
            return Err(format!("class {c} has no template"));
        }
        Ok(())
    }

    /// The posterior over `classes` classes (sums to 1): a softmax of each class's
    /// distance to the trajectory (its nearest template's), relative to the nearest.
    pub fn posterior(&self, t: &Trajectory, classes: usize) -> Vec<f64> {
        let query = Template::of(0, self.points, self.depth, t);
        let best = match self.cache.get_or_init(|| self.steps()) {
            Steps::Plane(s) => self.nearest_by_class(&plane_steps(&query, self), s, classes),
            Steps::Space(s) => self.nearest_by_class(&space_steps(&query, self), s, classes),
        };
        let n = self.points.max(1) as f32;
        let dmin = best.iter().copied().fold(f32::INFINITY, f32::min);
        if !dmin.is_finite() {
            return vec![1.0 / classes.max(1) as f64; classes];
        }
        let e: Vec<f64> = best
            .iter()
            .map(|&d| (-((d - dmin) / n / self.temperature) as f64).exp())
            .collect();
        let s: f64 = e.iter().sum();
        e.iter().map(|v| v / s).collect()
    }

    /// Each class's distance to `query`: its nearest template's.
    fn nearest_by_class<const D: usize>(
        &self,
        query: &[[f32; D]],
        steps: &[Vec<[f32; D]>],
        classes: usize,
    ) -> Vec<f32> {
        let mut best = vec![f32::INFINITY; classes];
        let mut buf = Vec::new();
        for (tpl, s) in self.templates.iter().zip(steps) {
            let Some(b) = best.get_mut(tpl.class) else {
                continue;
            };
            // A template no nearer than its class's nearest so far changes nothing:
            // abandoned as soon as it cannot be.
            let d = dtw(query, s, self.band, *b, &mut buf);
            *b = b.min(d);
        }
        best
    }

    fn steps(&self) -> Steps {
        if self.depth {
            Steps::Space(
                self.templates
                    .iter()
                    .map(|t| space_steps(t, self))
                    .collect(),
            )
        } else {
            Steps::Plane(
                self.templates
                    .iter()
                    .map(|t| plane_steps(t, self))
                    .collect(),
            )
        }
    }
}

/// A template's points in space (z = 0 where it has no depth).
fn points3(t: &Template) -> Vec<Point3> {
    let z = |i: usize| t.depth.as_ref().and_then(|d| d.get(i)).copied();
    (t.path.iter().enumerate())
        .map(|(i, p)| [p[0], p[1], z(i).unwrap_or(0.0)])
        .collect()
}

/// Positions with their directions (central differences, as the networks' features
/// take them), the directions scaled by [`Templates::direction_weight`]: in the plane,
/// the steps in space without their depth (a depth of 0 changes no other component).
fn plane_steps(t: &Template, m: &Templates) -> Vec<[f32; 4]> {
    space_steps(t, m)
        .into_iter()
        .map(|s| [s[0], s[1], s[3], s[4]])
        .collect()
}

/// [`plane_steps`] in space.
fn space_steps(t: &Template, m: &Templates) -> Vec<[f32; 6]> {
    let path = points3(t);
    let n = path.len();
    (0..n)
        .map(|i| {
            let (a, b) = (path[i.saturating_sub(1)], path[(i + 1).min(n - 1)]);
            let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let w = if l > 1e-6 {
                m.direction_weight / l
            } else {
                0.0
            };
            let p = path[i];
            [p[0], p[1], p[2], d[0] * w, d[1] * w, d[2] * w]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arc(from: f32, to: f32) -> Trajectory {
        Trajectory::from_points(
            (0..40)
                .map(|i| {
                    let a = from + (to - from) * i as f32 / 39.0;
                    [a.cos(), a.sin()]
                })
                .collect(),
        )
    }

    fn member(templates: &[(usize, Trajectory)]) -> Templates {
        member_in(false, templates)
    }

    fn member_in(depth: bool, templates: &[(usize, Trajectory)]) -> Templates {
        Templates {
            points: 24,
            depth,
            band: 3,
            direction_weight: 0.5,
            temperature: 0.05,
            weight: 1.0,
            templates: templates
                .iter()
                .map(|(c, t)| Template::of(*c, 24, depth, t))
                .collect(),
            cache: OnceLock::new(),
        }
    }

    #[test]
    fn the_nearest_class_wins_and_direction_tells_a_path_from_its_reverse() {
        let clockwise = arc(0.0, 5.0);
        let anticlockwise = arc(5.0, 0.0);
        let line = Trajectory::from_points(vec![[0.0, 0.0], [1.0, 0.0]]);
        let m = member(&[(0, clockwise.clone()), (1, anticlockwise), (2, line)]);
        m.validate(3).unwrap();
        let p = m.posterior(&arc(0.1, 5.1), 3);
        assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        assert!(p[0] > 0.9, "{p:?}");
        let p = m.posterior(&arc(5.1, 0.1), 3);
        assert!(p[1] > 0.9, "{p:?}");
    }

    #[test]
    fn a_class_without_template_or_a_path_of_another_length_is_refused() {
        let m = member(&[(0, arc(0.0, 5.0))]);
        assert!(m.validate(2).unwrap_err().contains("class 1"));
        let mut m = member(&[(0, arc(0.0, 5.0)), (1, arc(5.0, 0.0))]);
        m.templates[1].path.pop();
        assert!(m.validate(2).unwrap_err().contains("template 1"));
        m.templates[1].path.push([f32::NAN, 0.0]);
        assert!(m.validate(2).unwrap_err().contains("non-finite"));
    }

    /// A stroke to the right that also goes `dz` towards the camera over its length.
    fn push(dz: f32) -> Trajectory {
        let p: Vec<Point3> = (0..30)
            .map(|i| {
                let a = i as f32 / 29.0;
                [a, 0.1 * (a * 6.0).sin(), dz * a]
            })
            .collect();
        Trajectory::from_points3(&p)
    }

    #[test]
    fn a_member_in_space_tells_shapes_apart_that_differ_in_depth_only() {
        let (towards, away) = (push(0.8), push(-0.8));
        let space = member_in(true, &[(0, towards.clone()), (1, away.clone())]);
        space.validate(2).unwrap();
        assert!(space.posterior(&push(0.6), 2)[0] > 0.9);
        assert!(space.posterior(&push(-0.6), 2)[1] > 0.9);
        // In the plane the two are one path: the member cannot choose.
        let plane = member(&[(0, towards), (1, away)]);
        let p = plane.posterior(&push(0.6), 2);
        assert!((p[0] - p[1]).abs() < 1e-6, "{p:?}");
    }

    #[test]
    fn a_member_reads_back_from_its_file_and_one_without_depth_matches_in_the_plane() {
        let space = member_in(true, &[(0, push(0.8)), (1, push(-0.8))]);
        let text = serde_json::to_string(&space).unwrap();
        let back: Templates = serde_json::from_str(&text).unwrap();
        back.validate(2).unwrap();
        assert_eq!(
            back.posterior(&push(0.5), 2),
            space.posterior(&push(0.5), 2)
        );
        // Written before depth existed: no field, read as a member in the plane.
        let plane = member(&[(0, push(0.8)), (1, push(-0.8))]);
        let text = serde_json::to_string(&plane).unwrap();
        assert!(!text.contains("depth"), "{text}");
        assert!(!serde_json::from_str::<Templates>(&text).unwrap().depth);
    }

    #[test]
    fn a_template_whose_depth_does_not_fit_its_member_is_refused() {
        let mut m = member_in(true, &[(0, push(0.8)), (1, push(-0.8))]);
        m.templates[1].depth.as_mut().unwrap().pop();
        assert!(m.validate(2).unwrap_err().contains("depths"));
        m.templates[1].depth = None;
        assert!(m.validate(2).unwrap_err().contains("no depth"));
        m.templates[1].depth = Some(vec![f32::INFINITY; 24]);
        assert!(m.validate(2).unwrap_err().contains("non-finite"));
        let mut m = member(&[(0, push(0.8)), (1, push(-0.8))]);
        m.templates[0].depth = Some(vec![0.0; 24]);
        assert!(m.validate(2).unwrap_err().contains("in the plane"));
    }
}
