//! The spotting part of a model file: one HMM per label over the stream's direction
//! codes (for Lee & Kim's threshold model) and the verifier; and those codes, the
//! direction of the hand's path at every chord step.

use super::{LabelledHmm, Verifier};
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};

/// The HMMs over stream codes, stored in the model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpottingModel {
    /// Chord step as a fraction of the gesture's larger side.
    pub step: f64,
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
            if m.hmm.n_symbols() != STREAM_SYMBOLS {
                return Err(format!(
                    "spotting HMM of label {:?} has {} symbols, expected {STREAM_SYMBOLS}",
                    m.label,
                    m.hmm.n_symbols()
                ));
            }
        }
        Ok(())
    }
}

/// Symbols of the spotting HMMs: direction codes 0..8 and a resting code 8 (which a
/// segment between two breaks never holds: rests are breaks; it stays so that the
/// models keep their shape).
pub const STREAM_SYMBOLS: usize = 9;

/// Quantizes a path into direction codes at equal chord steps.
#[derive(Debug, Clone)]
pub struct Quantizer {
    pub step: f32,
    anchor: Option<[f32; 2]>,
}

impl Quantizer {
    pub fn new(step: f32) -> Self {
        Self { step, anchor: None }
    }

    /// Feeds a point; calls `emit(code)` for every full step the path made.
    pub fn push(&mut self, p: [f32; 2], mut emit: impl FnMut(usize)) {
        let Some(mut a) = self.anchor else {
            self.anchor = Some(p);
            return;
        };
        loop {
            let (dx, dy) = (p[0] - a[0], p[1] - a[1]);
            let d = (dx * dx + dy * dy).sqrt();
            if d < self.step {
                break;
            }
            emit(crate::bezier::direction_code(dx as f64, dy as f64, 8, 0.0));
            a = [a[0] + dx / d * self.step, a[1] + dy / d * self.step];
        }
        self.anchor = Some(a);
    }
}

/// The stream codes of a whole trajectory scaled so that its larger side is 1.
pub fn sample_codes(t: &Trajectory, step: f64) -> Vec<usize> {
    let (x0, y0, x1, y1) = crate::features::bbox(&t.points);
    let s = (x1 - x0).max(y1 - y0).max(1e-6);
    let mut q = Quantizer::new(step as f32);
    let mut out = Vec::new();
    for p in &t.points {
        q.push([(p[0] - x0) / s, (p[1] - y0) / s], |c| out.push(c));
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
}
