//! Training the multilayer perceptron: mini-batch SGD with momentum, weight decay and a
//! cosine learning-rate schedule.

use crate::mlp::{log_softmax, Layer, Mlp};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Network training settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MlpTrainConfig {
    /// Units of the hidden layer.
    pub hidden: usize,
    /// Passes over the data.
    pub epochs: usize,
    /// Samples a step.
    pub batch: usize,
    /// The step size at the start (it falls to 0 on a cosine).
    pub learning_rate: f32,
    /// SGD momentum.
    pub momentum: f32,
    /// L2 decay of the weights a step.
    pub weight_decay: f32,
    /// Initial weights and the order of the samples.
    pub seed: u64,
}

impl Default for MlpTrainConfig {
    fn default() -> Self {
        Self {
            hidden: 192,
            epochs: 30,
            batch: 64,
            learning_rate: 0.05,
            momentum: 0.9,
            weight_decay: 5e-5,
            seed: 1,
        }
    }
}

impl Mlp {
    /// Trains on feature vectors produced per epoch by `features(epoch, i)` (to allow
    /// fresh augmentation every epoch); `labels[i]` in 0..classes. `progress` is called
    /// after every epoch.
    pub fn train<F>(
        n: usize,
        dim: usize,
        labels: &[usize],
        classes: usize,
        cfg: &MlpTrainConfig,
        features: F,
        mut progress: impl FnMut(usize),
    ) -> Mlp
    where
        F: Fn(usize, usize) -> Vec<f32> + Sync,
    {
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        // Standardization from the un-augmented features (epoch index usize::MAX).
        let base: Vec<Vec<f32>> = (0..n)
            .into_par_iter()
            .map(|i| features(usize::MAX, i))
            .collect();
        let mut mean = vec![0.0f64; dim];
        let mut var = vec![0.0f64; dim];
        for f in &base {
            for d in 0..dim {
                mean[d] += f[d] as f64;
            }
        }
        mean.iter_mut().for_each(|m| *m /= n.max(1) as f64);
        for f in &base {
            for d in 0..dim {
                var[d] += (f[d] as f64 - mean[d]).powi(2);
            }
        }
        let std: Vec<f32> = var
            .iter()
            .map(|v| ((v / n.max(1) as f64).sqrt() as f32).max(1e-3))
            .collect();
        let mean: Vec<f32> = mean.iter().map(|&m| m as f32).collect();
        let sizes = [dim, cfg.hidden, classes];
        let layers = sizes
            .windows(2)
            .map(|w| {
                let scale = (2.0 / w[0] as f32).sqrt();
                Layer {
                    inputs: w[0],
                    outputs: w[1],
                    w: (0..w[0] * w[1])
                        .map(|_| {
                            // Approximately normal from the sum of uniforms.
                            let u: f32 = (0..4).map(|_| rng.gen_range(-1.0..1.0f32)).sum();
                            u * scale * 0.866
                        })
                        .collect(),
                    b: vec![0.0; w[1]],
                }
            })
            .collect();
        let mut net = Mlp { mean, std, layers };
        let mut vel: Vec<(Vec<f32>, Vec<f32>)> = net
            .layers
            .iter()
            .map(|l| (vec![0.0; l.w.len()], vec![0.0; l.b.len()]))
            .collect();
        let mut order: Vec<usize> = (0..n).collect();
        let total_steps = (cfg.epochs * n.div_ceil(cfg.batch.max(1))).max(1);
        let mut step = 0usize;
        for epoch in 0..cfg.epochs {
            let feats: Vec<Vec<f32>> = if epoch == 0 {
                base.clone()
            } else {
                (0..n).into_par_iter().map(|i| features(epoch, i)).collect()
            };
            order.shuffle(&mut rng);
            for batch in order.chunks(cfg.batch.max(1)) {
                let lr = cfg.learning_rate
                    * 0.5
                    * (1.0 + (std::f32::consts::PI * step as f32 / total_steps as f32).cos());
                step += 1;
                let grads = net.batch_gradient(batch, &feats, labels);
                let scale = 1.0 / batch.len() as f32;
                for (li, l) in net.layers.iter_mut().enumerate() {
                    let (gw, gb) = &grads[li];
                    let (vw, vb) = &mut vel[li];
                    for k in 0..l.w.len() {
                        let g = gw[k] * scale + cfg.weight_decay * l.w[k];
                        vw[k] = cfg.momentum * vw[k] - lr * g;
                        l.w[k] += vw[k];
                    }
                    for k in 0..l.b.len() {
                        vb[k] = cfg.momentum * vb[k] - lr * gb[k] * scale;
                        l.b[k] += vb[k];
                    }
                }
            }
            progress(epoch);
        }
        net
    }

    fn zero_grads(&self) -> Vec<(Vec<f32>, Vec<f32>)> {
        self.layers
            .iter()
            .map(|l| (vec![0.0; l.w.len()], vec![0.0; l.b.len()]))
            .collect()
    }

    fn batch_gradient(
        &self,
        batch: &[usize],
        feats: &[Vec<f32>],
        labels: &[usize],
    ) -> Vec<(Vec<f32>, Vec<f32>)> {
        batch
            .par_chunks(batch.len().div_ceil(2).max(1))
            .map(|chunk| {
                let mut g = self.zero_grads();
                let mut acts = Vec::new();
                for &i in chunk {
                    self.accumulate(&feats[i], labels[i], &mut acts, &mut g);
                }
                g
            })
            .reduce_with(|mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    x.0.iter_mut().zip(y.0).for_each(|(p, q)| *p += q);
                    x.1.iter_mut().zip(y.1).for_each(|(p, q)| *p += q);
                }
                a
            })
            .unwrap_or_else(|| self.zero_grads())
    }

    fn accumulate(
        &self,
        x: &[f32],
        label: usize,
        acts: &mut Vec<Vec<f32>>,
        g: &mut [(Vec<f32>, Vec<f32>)],
    ) {
        self.forward(x, acts);
        let mut delta = acts[self.layers.len()].clone();
        log_softmax(&mut delta);
        delta.iter_mut().for_each(|v| *v = v.exp());
        if label < delta.len() {
            delta[label] -= 1.0;
        }
        for li in (0..self.layers.len()).rev() {
            let l = &self.layers[li];
            let inp = &acts[li];
            let (gw, gb) = &mut g[li];
            for o in 0..l.outputs {
                let d = delta[o];
                if d == 0.0 {
                    continue;
                }
                gb[o] += d;
                let row = &mut gw[o * l.inputs..(o + 1) * l.inputs];
                for (r, v) in row.iter_mut().zip(inp) {
                    *r += d * v;
                }
            }
            if li > 0 {
                let mut prev = vec![0.0f32; l.inputs];
                for o in 0..l.outputs {
                    let d = delta[o];
                    if d == 0.0 {
                        continue;
                    }
                    let row = &l.w[o * l.inputs..(o + 1) * l.inputs];
                    for (p, w) in prev.iter_mut().zip(row) {
                        *p += d * w;
                    }
                }
                // ReLU derivative of the previous layer's output.
                for (p, a) in prev.iter_mut().zip(&acts[li]) {
                    if *a <= 0.0 {
                        *p = 0.0;
                    }
                }
                delta = prev;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn learns_xor_like_classes() {
        let pts: Vec<([f32; 2], usize)> = (0..200)
            .map(|i| {
                let x = ((i * 37) % 100) as f32 / 50.0 - 1.0;
                let y = ((i * 71) % 100) as f32 / 50.0 - 1.0;
                ([x, y], usize::from((x > 0.0) != (y > 0.0)))
            })
            .collect();
        let labels: Vec<usize> = pts.iter().map(|p| p.1).collect();
        let cfg = MlpTrainConfig {
            hidden: 16,
            epochs: 200,
            batch: 16,
            learning_rate: 0.1,
            ..Default::default()
        };
        let net = Mlp::train(
            pts.len(),
            2,
            &labels,
            2,
            &cfg,
            |_, i| pts[i].0.to_vec(),
            |_| {},
        );
        net.validate().unwrap();
        let correct = pts
            .iter()
            .filter(|(x, l)| {
                let p = net.log_probs(x);
                usize::from(p[1] > p[0]) == *l
            })
            .count();
        assert!(correct >= 180, "{correct}");
    }
}
