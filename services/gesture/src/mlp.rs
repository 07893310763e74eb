//! A small multilayer perceptron (ReLU hidden layers, softmax output): what a model file
//! holds of it and its forward pass. Its training (mini-batch SGD) is the lab's
//! (`lab::train`). Plain `f32` loops: a forward pass over a few hundred inputs takes
//! microseconds.

use serde::{Deserialize, Serialize};

/// One fully connected layer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Layer {
    /// Its inputs (the previous layer's outputs)…
    pub inputs: usize,
    /// …and outputs.
    pub outputs: usize,
    /// Row-major outputs × inputs.
    pub w: Vec<f32>,
    /// One an output.
    pub b: Vec<f32>,
}

/// A trained network.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Mlp {
    /// Input standardization: x' = (x − mean) / std.
    pub mean: Vec<f32>,
    /// See `mean`.
    pub std: Vec<f32>,
    /// From the input on; ReLU between them, softmax after the last.
    pub layers: Vec<Layer>,
}

impl Mlp {
    /// Checks sizes within [`crate::limits`], layers that fit together and finite
    /// weights: a model file is not trusted.
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::{product, within, MAX_LAYERS, MAX_UNITS};
        let Some(first) = self.layers.first() else {
            return Err("network has no layers".into());
        };
        within("network layers", self.layers.len(), 1, MAX_LAYERS)?;
        if self.mean.len() != first.inputs || self.std.len() != first.inputs {
            return Err("network input normalization does not match its first layer".into());
        }
        let mut prev = first.inputs;
        for (i, l) in self.layers.iter().enumerate() {
            within(
                &format!("network layer {i}'s inputs"),
                l.inputs,
                1,
                MAX_UNITS,
            )?;
            within(
                &format!("network layer {i}'s outputs"),
                l.outputs,
                1,
                MAX_UNITS,
            )?;
            let weights = product(&format!("network layer {i}'s weights"), l.inputs, l.outputs)?;
            if l.inputs != prev || l.w.len() != weights || l.b.len() != l.outputs {
                return Err(format!("network layer {i} has inconsistent dimensions"));
            }
            prev = l.outputs;
        }
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        if !finite(&self.mean)
            || !finite(&self.std)
            || self.layers.iter().any(|l| !finite(&l.w) || !finite(&l.b))
        {
            return Err("network holds a non-finite weight".into());
        }
        Ok(())
    }

    /// The size of its input.
    pub fn inputs(&self) -> usize {
        self.layers.first().map_or(0, |l| l.inputs)
    }

    /// The number of classes it tells apart.
    pub fn outputs(&self) -> usize {
        self.layers.last().map_or(0, |l| l.outputs)
    }

    /// Log-probabilities of the classes (log-softmax of the last layer).
    pub fn log_probs(&self, x: &[f32]) -> Vec<f32> {
        let mut acts = Vec::new();
        self.forward(x, &mut acts);
        let mut z = acts.pop().unwrap_or_default();
        log_softmax(&mut z);
        z
    }

    /// Activations of every layer (input standardized first, ReLU on hidden layers).
    pub(crate) fn forward(&self, x: &[f32], acts: &mut Vec<Vec<f32>>) {
        acts.clear();
        acts.push(
            x.iter()
                .zip(self.mean.iter().zip(&self.std))
                .map(|(v, (m, s))| (v - m) / s)
                .collect(),
        );
        for (li, l) in self.layers.iter().enumerate() {
            let inp = &acts[li];
            let mut out = l.b.clone();
            for (o, ov) in out.iter_mut().enumerate() {
                let row = &l.w[o * l.inputs..(o + 1) * l.inputs];
                *ov += dot(row, inp);
            }
            if li + 1 < self.layers.len() {
                out.iter_mut().for_each(|v| *v = v.max(0.0));
            }
            acts.push(out);
        }
    }
}

#[inline]
fn dot(a: &[f32], b: &[f32]) -> f32 {
    // Four accumulators let the compiler vectorize.
    let mut s = [0.0f32; 8];
    let chunks = a.len() / 8;
    for c in 0..chunks {
        for k in 0..8 {
            s[k] += a[c * 8 + k] * b[c * 8 + k];
        }
    }
    let mut t: f32 = s.iter().sum();
    for k in chunks * 8..a.len() {
        t += a[k] * b[k];
    }
    t
}

/// Turns scores into log-probabilities, in place.
pub fn log_softmax(z: &mut [f32]) {
    let m = z.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
    let s: f32 = z.iter().map(|v| (v - m).exp()).sum();
    let l = m + s.ln();
    z.iter_mut().for_each(|v| *v -= l);
}
