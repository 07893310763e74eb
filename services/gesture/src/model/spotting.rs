//! The spotting part of a model file: one HMM per label over the stream's direction
//! codes (for Lee & Kim's threshold model) and the verifier; and those codes, the
//! direction of the hand's path at every chord step.

use super::{LabelledHmm, Verifier};
use crate::bezier::{direction_code, sphere_code, Directions};
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};

/// The HMMs over stream codes, stored in the model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpottingModel {
    /// Chord step as a fraction of the gesture's larger side.
    pub step: f64,
    /// The directions the codes name: the circle, or the sphere for a model of 3-D
    /// gestures (a push is then a code of its own, not a hand standing still).
    #[serde(default, skip_serializing_if = "Directions::is_circle")]
    pub directions: Directions,
    /// One a label.
    pub models: Vec<LabelledHmm>,
    /// Judge of candidate segments: not a gesture, or a whole gesture of which label.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verifier: Option<Verifier>,
}

impl SpottingModel {
    /// Checks the step, the HMMs' shapes and the verifier's sizes, networks and bars: a
    /// model file is not trusted.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.step > 0.0 && self.step < 1.0) {
            return Err(format!("spotting step {} is not in (0, 1)", self.step));
        }
        if let Some(v) = &self.verifier {
            if v.nets.is_empty() {
                return Err("spotting verifier has no network".into());
            }
            use crate::limits::{within, MAX_NETS, MAX_TIMING};
            v.features.validate("spotting verifier's features")?;
            within("spotting verifier's timing points", v.timing, 0, MAX_TIMING)?;
            within("spotting verifier's networks", v.nets.len(), 1, MAX_NETS)?;
            for net in &v.nets {
                net.validate()
                    .map_err(|e| format!("spotting verifier: {e}"))?;
                if net.inputs() != v.dim() || net.outputs() != v.classes.len() + 1 {
                    return Err("spotting verifier has the wrong dimensions".into());
                }
            }
            for (label, bar) in &v.label_bars {
                if !v.classes.contains(label) {
                    return Err(format!(
                        "spotting verifier has a bar for label {label:?}, which the model does not have"
                    ));
                }
                if !(0.0..=1.0).contains(bar) {
                    return Err(format!(
                        "spotting verifier's bar {bar} for label {label:?} is not a probability"
                    ));
                }
            }
        }
        for m in &self.models {
            m.hmm
                .validate()
                .map_err(|e| format!("spotting HMM of label {:?}: {e}", m.label))?;
            if m.hmm.n_symbols() != stream_symbols(self.directions) {
                return Err(format!(
                    "spotting HMM of label {:?} has {} symbols, expected {}",
                    m.label,
                    m.hmm.n_symbols(),
                    stream_symbols(self.directions)
                ));
            }
        }
        Ok(())
    }
}

/// Symbols of the spotting HMMs: the direction codes and a resting code after them
/// (which a segment between two breaks never holds: rests are breaks; it stays so that
/// the models keep their shape). On the circle 9.
pub fn stream_symbols(directions: Directions) -> usize {
    directions.count() + 1
}

/// Quantizes a path into direction codes at equal chord steps: on the circle the step is
/// measured across (the depth is not read), on the sphere in space.
#[derive(Debug, Clone)]
pub struct Quantizer {
    pub step: f32,
    directions: Directions,
    anchor: Option<[f32; 3]>,
}

impl Quantizer {
    pub fn new(step: f32, directions: Directions) -> Self {
        Self {
            step,
            directions,
            anchor: None,
        }
    }

    /// Feeds a point (x, y and depth); calls `emit(code)` for every full step the path
    /// made.
    pub fn push(&mut self, p: [f32; 3], mut emit: impl FnMut(usize)) {
        let Some(mut a) = self.anchor else {
            self.anchor = Some(p);
            return;
        };
        let space = !self.directions.is_circle();
        loop {
            let (dx, dy) = (p[0] - a[0], p[1] - a[1]);
            let dz = if space { p[2] - a[2] } else { 0.0 };
            let d = (dx * dx + dy * dy + dz * dz).sqrt();
            if d < self.step {
                break;
            }
            emit(if space {
                sphere_code([dx as f64, dy as f64, dz as f64], 0.0)
            } else {
                direction_code(dx as f64, dy as f64, 8, 0.0)
            });
            a = [
                a[0] + dx / d * self.step,
                a[1] + dy / d * self.step,
                a[2] + dz / d * self.step,
            ];
        }
        self.anchor = Some(a);
    }
}

/// The stream codes of a whole trajectory scaled so that its larger side is 1 (in space
/// on the sphere).
pub fn sample_codes(t: &Trajectory, step: f64, directions: Directions) -> Vec<usize> {
    let mut q = Quantizer::new(step as f32, directions);
    let mut out = Vec::new();
    if directions.is_circle() {
        let (x0, y0, x1, y1) = crate::features::bbox(&t.points);
        let s = (x1 - x0).max(y1 - y0).max(1e-6);
        for p in &t.points {
            q.push([(p[0] - x0) / s, (p[1] - y0) / s, 0.0], |c| out.push(c));
        }
        return out;
    }
    let p3 = t.points3();
    let (lo, hi) = crate::features3d::bbox3(&p3);
    let s = (0..3).map(|k| hi[k] - lo[k]).fold(1e-6f32, f32::max);
    for p in &p3 {
        q.push([0, 1, 2].map(|k| (p[k] - lo[k]) / s), |c| out.push(c));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::verifier::tests::constant_verifier;

    #[test]
    fn bad_label_bars_are_refused() {
        let mut v = constant_verifier(&[[0.0, 0.0, 0.0]]);
        v.label_bars.insert("b".into(), 0.6);
        let model = |v: &Verifier| SpottingModel {
            step: 0.1,
            directions: Directions::Circle8,
            models: Vec::new(),
            verifier: Some(v.clone()),
        };
        assert_eq!(model(&v).validate(), Ok(()));
        let mut unknown = v.clone();
        unknown.label_bars.insert("zz".into(), 0.5);
        let e = model(&unknown).validate().unwrap_err();
        assert!(e.contains("\"zz\"") && e.contains("does not have"), "{e}");
        let mut broken = v.clone();
        broken.label_bars.insert("a".into(), f64::NAN);
        let e = model(&broken).validate().unwrap_err();
        assert!(e.contains("not a probability"), "{e}");
    }

    #[test]
    fn codes_on_the_sphere_name_a_push_that_the_circle_does_not_see() {
        let push: Vec<[f32; 3]> = (0..20).map(|i| [0.0, 0.0, i as f32 * 0.05]).collect();
        let t = Trajectory::from_points3(&push);
        assert!(sample_codes(&t, 0.1, Directions::Circle8).is_empty());
        let codes = sample_codes(&t, 0.1, Directions::Sphere26);
        // A path of length 1 in steps of 0.1 (the last one may fall short by rounding).
        assert!((9..=10).contains(&codes.len()), "{codes:?}");
        assert!(codes.iter().all(|&c| c == codes[0]), "{codes:?}");
        // A pull is another code; a stroke across is the circle's count of steps.
        let pull: Vec<[f32; 3]> = push.iter().rev().copied().collect();
        let pulled = sample_codes(&Trajectory::from_points3(&pull), 0.1, Directions::Sphere26);
        assert_ne!(pulled[0], codes[0]);
        let across = Trajectory::from_points((0..20).map(|i| [i as f32, 0.0]).collect());
        assert_eq!(
            sample_codes(&across, 0.1, Directions::Sphere26).len(),
            sample_codes(&across, 0.1, Directions::Circle8).len()
        );
    }

    #[test]
    fn hmms_of_the_circle_in_a_model_of_the_sphere_are_refused() {
        let hmm = crate::hmm::DiscreteHmm {
            pi: vec![1.0],
            a: vec![vec![1.0]],
            b: vec![vec![1.0 / 9.0; 9]],
        };
        let mut m = SpottingModel {
            step: 0.1,
            directions: Directions::Circle8,
            models: vec![LabelledHmm {
                label: "a".into(),
                hmm,
            }],
            verifier: None,
        };
        assert_eq!(m.validate(), Ok(()));
        m.directions = Directions::Sphere26;
        let e = m.validate().unwrap_err();
        assert!(e.contains("9 symbols, expected 27"), "{e}");
        // A file without the field reads the circle.
        let mut v = serde_json::to_value(&m).unwrap();
        v.as_object_mut().unwrap().remove("directions");
        let back: SpottingModel = serde_json::from_value(v).unwrap();
        assert_eq!(back.directions, Directions::Circle8);
    }
}
