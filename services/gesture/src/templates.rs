//! The template member of the network ensemble: a few resampled, normalized examples of
//! each label, matched to a trajectory by dynamic time warping over positions and
//! directions. Networks need many samples per label; a template matcher is strong from
//! the first few, so a model trained on a few samples per label carries one and mixes
//! its posterior with the networks'. What a model file holds of it and its decision;
//! which samples become templates, and with what weight, is the lab's training.

use crate::dtw::dtw;
use crate::features::resample;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::sync::OnceLock;

/// One example: its class (an index into the classifier's classes) and its path,
/// resampled to [`Templates::points`] points at equal arc length and normalized as the
/// networks' features are (centred on its bounding box, divided by its larger side).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Template {
    /// Index into the classifier's classes.
    pub class: usize,
    /// The normalized points.
    pub path: Vec<[f32; 2]>,
}

/// The template member: its matching settings, its share of the ensemble's decision and
/// its templates.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Templates {
    /// Points every trajectory is resampled to before matching.
    pub points: usize,
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
    pub(crate) cache: OnceLock<Vec<Vec<Step>>>,
}

/// One point of a matched path: position and unit direction, the direction scaled by
/// the member's weight for it.
type Step = [f32; 4];

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
            if t.path.iter().flatten().any(|v| !v.is_finite()) {
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

    /// The path a trajectory is matched by (what a template holds).
    pub fn path_of(points: usize, t: &Trajectory) -> Vec<[f32; 2]> {
        resample(t, points).points
    }

    /// The posterior over `classes` classes (sums to 1): a softmax of each class's
    /// distance to the trajectory (its nearest template's), relative to the nearest.
    pub fn posterior(&self, t: &Trajectory, classes: usize) -> Vec<f64> {
        let q = self.steps(&Self::path_of(self.points, t));
        let steps = self
            .cache
            .get_or_init(|| self.templates.iter().map(|t| self.steps(&t.path)).collect());
        let mut best = vec![f32::INFINITY; classes];
        let mut buf = Vec::new();
        for (tpl, s) in self.templates.iter().zip(steps) {
            let Some(b) = best.get_mut(tpl.class) else {
                continue;
            };
            // A template no nearer than its class's nearest so far changes nothing:
            // abandoned as soon as it cannot be.
            let d = dtw(&q, s, self.band, *b, &mut buf);
            *b = b.min(d);
        }
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

    /// Positions with their directions (central differences, as the networks' features
    /// take them), the directions scaled by [`Templates::direction_weight`].
    fn steps(&self, path: &[[f32; 2]]) -> Vec<Step> {
        let n = path.len();
        (0..n)
            .map(|i| {
                let (a, b) = (path[i.saturating_sub(1)], path[(i + 1).min(n - 1)]);
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                let l = (dx * dx + dy * dy).sqrt();
                let w = if l > 1e-6 {
                    self.direction_weight / l
                } else {
                    0.0
                };
                [path[i][0], path[i][1], dx * w, dy * w]
            })
            .collect()
    }
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
        Templates {
            points: 24,
            band: 3,
            direction_weight: 0.5,
            temperature: 0.05,
            weight: 1.0,
            templates: templates
                .iter()
                .map(|(c, t)| Template {
                    class: *c,
                    path: Templates::path_of(24, t),
                })
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
}
