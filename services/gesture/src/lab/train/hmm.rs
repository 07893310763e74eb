//! Training discrete HMMs: a left-right banded topology, Baum–Welch over many
//! sequences with scaling, Dirichlet priors and emission floors (so that no state is
//! left without statistics).

use crate::hmm::DiscreteHmm;
use serde::{Deserialize, Serialize};

/// Baum–Welch settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HmmTrainConfig {
    /// States of each model.
    pub states: usize,
    /// Symbols it emits.
    pub symbols: usize,
    /// Allowed forward jumps: 1 = stay or move to the next state.
    pub band: usize,
    /// Baum–Welch iterations after the uniform segmentation.
    pub iterations: usize,
    /// Dirichlet pseudo-count added to every emission of every state.
    pub emission_prior: f64,
    /// Pseudo-count added to every allowed transition.
    pub transition_prior: f64,
    /// Smallest emission probability after re-estimation.
    pub floor: f64,
}

impl Default for HmmTrainConfig {
    fn default() -> Self {
        Self {
            states: 14,
            symbols: 8,
            band: 1,
            iterations: 20,
            emission_prior: 0.5,
            transition_prior: 0.5,
            floor: 1e-3,
        }
    }
}

impl DiscreteHmm {
    /// A left-right banded model with uniform emissions.
    pub fn banded(states: usize, symbols: usize, band: usize) -> Self {
        let mut pi = vec![0.0; states];
        pi[0] = 1.0;
        let mut a = vec![vec![0.0; states]; states];
        for (i, row) in a.iter_mut().enumerate() {
            let last = (i + band).min(states - 1);
            let k = (last - i + 1) as f64;
            for p in row.iter_mut().take(last + 1).skip(i) {
                *p = 1.0 / k;
            }
        }
        let b = vec![vec![1.0 / symbols as f64; symbols]; states];
        Self { pi, a, b }
    }

    /// Baum–Welch re-estimation from many sequences, starting from a banded model
    /// initialized by segmenting every sequence uniformly over the states.
    pub fn train(seqs: &[Vec<usize>], cfg: &HmmTrainConfig) -> Self {
        let mut hmm = Self::uniform_segmentation_init(seqs, cfg);
        for _ in 0..cfg.iterations {
            hmm = hmm.baum_welch_step(seqs, cfg);
        }
        hmm
    }

    /// Banded topology; emissions counted from each sequence cut into equal parts.
    pub fn uniform_segmentation_init(seqs: &[Vec<usize>], cfg: &HmmTrainConfig) -> Self {
        let (n, m) = (cfg.states.max(1), cfg.symbols.max(1));
        let mut hmm = Self::banded(n, m, cfg.band.max(1));
        let mut counts = vec![vec![cfg.emission_prior.max(1e-3); m]; n];
        let mut stay = vec![0.0; n];
        let mut leave = vec![0.0; n];
        for s in seqs {
            let t_len = s.len();
            if t_len == 0 {
                continue;
            }
            let mut prev = usize::MAX;
            for (t, &o) in s.iter().enumerate() {
                let st = (t * n / t_len).min(n - 1);
                if o < m {
                    counts[st][o] += 1.0;
                }
                if prev != usize::MAX {
                    if prev == st {
                        stay[st] += 1.0;
                    } else {
                        leave[prev] += 1.0;
                    }
                }
                prev = st;
            }
        }
        for i in 0..n {
            let tot: f64 = counts[i].iter().sum();
            for k in 0..m {
                hmm.b[i][k] = counts[i][k] / tot;
            }
            if i + 1 < n {
                // Expected dwell from the segmentation, with a prior of one stay, one leave.
                let p_stay = (stay[i] + 1.0) / (stay[i] + leave[i] + 2.0);
                let last = (i + cfg.band.max(1)).min(n - 1);
                for j in 0..n {
                    hmm.a[i][j] = 0.0;
                }
                hmm.a[i][i] = p_stay;
                let rest = (1.0 - p_stay) / (last - i) as f64;
                for j in i + 1..=last {
                    hmm.a[i][j] = rest;
                }
            }
        }
        apply_floor(&mut hmm.b, cfg.floor);
        hmm
    }

    /// One Baum–Welch iteration (scaled forward–backward) over all sequences. Only
    /// transitions that the current model allows (non-zero) are re-estimated, so the
    /// topology is kept; priors keep rows without statistics well defined.
    pub fn baum_welch_step(&self, seqs: &[Vec<usize>], cfg: &HmmTrainConfig) -> Self {
        let n = self.n_states();
        let m = self.n_symbols();
        let mut num_a = vec![vec![0.0; n]; n];
        let mut num_b = vec![vec![0.0; m]; n];
        let mut num_pi = vec![0.0; n];
        let mut alpha: Vec<f64> = Vec::new();
        let mut beta: Vec<f64> = Vec::new();
        let mut scale: Vec<f64> = Vec::new();
        for s in seqs {
            let tl = s.len();
            if tl == 0 || s.iter().any(|&o| o >= m) {
                continue;
            }
            alpha.clear();
            alpha.resize(tl * n, 0.0);
            beta.clear();
            beta.resize(tl * n, 0.0);
            scale.clear();
            scale.resize(tl, 0.0);
            for i in 0..n {
                alpha[i] = self.pi[i] * self.b[i][s[0]];
            }
            let mut ok = true;
            for t in 0..tl {
                if t > 0 {
                    for j in 0..n {
                        let mut acc = 0.0;
                        for i in 0..n {
                            acc += alpha[(t - 1) * n + i] * self.a[i][j];
                        }
                        alpha[t * n + j] = acc * self.b[j][s[t]];
                    }
                }
                let c: f64 = alpha[t * n..(t + 1) * n].iter().sum();
                if c <= 0.0 || !c.is_finite() {
                    ok = false;
                    break;
                }
                scale[t] = c;
                alpha[t * n..(t + 1) * n].iter_mut().for_each(|x| *x /= c);
            }
            if !ok {
                continue;
            }
            for i in 0..n {
                beta[(tl - 1) * n + i] = 1.0;
            }
            for t in (0..tl - 1).rev() {
                for i in 0..n {
                    let mut acc = 0.0;
                    for j in 0..n {
                        acc += self.a[i][j] * self.b[j][s[t + 1]] * beta[(t + 1) * n + j];
                    }
                    beta[t * n + i] = acc / scale[t + 1];
                }
            }
            for t in 0..tl {
                for i in 0..n {
                    let g = alpha[t * n + i] * beta[t * n + i];
                    num_b[i][s[t]] += g;
                    if t == 0 {
                        num_pi[i] += g;
                    }
                }
                if t + 1 < tl {
                    for i in 0..n {
                        let ai = alpha[t * n + i];
                        if ai == 0.0 {
                            continue;
                        }
                        for j in 0..n {
                            if self.a[i][j] > 0.0 {
                                num_a[i][j] +=
                                    ai * self.a[i][j] * self.b[j][s[t + 1]] * beta[(t + 1) * n + j]
                                        / scale[t + 1];
                            }
                        }
                    }
                }
            }
        }
        let mut out = self.clone();
        // Initial distribution: keep the topology's zeros.
        let mut pis = 0.0;
        for i in 0..n {
            out.pi[i] = if self.pi[i] > 0.0 {
                num_pi[i] + cfg.transition_prior
            } else {
                0.0
            };
            pis += out.pi[i];
        }
        if pis > 0.0 {
            out.pi.iter_mut().for_each(|p| *p /= pis);
        } else {
            out.pi = self.pi.clone();
        }
        for i in 0..n {
            let mut tot = 0.0;
            for j in 0..n {
                out.a[i][j] = if self.a[i][j] > 0.0 {
                    num_a[i][j] + cfg.transition_prior
                } else {
                    0.0
                };
                tot += out.a[i][j];
            }
            if tot > 0.0 {
                out.a[i].iter_mut().for_each(|p| *p /= tot);
            } else {
                out.a[i] = self.a[i].clone();
            }
            let tot_b: f64 = num_b[i].iter().sum::<f64>() + cfg.emission_prior * m as f64;
            if tot_b > 0.0 {
                for k in 0..m {
                    out.b[i][k] = (num_b[i][k] + cfg.emission_prior) / tot_b;
                }
            } else {
                out.b[i] = self.b[i].clone();
            }
        }
        apply_floor(&mut out.b, cfg.floor);
        out
    }
}

fn apply_floor(b: &mut [Vec<f64>], floor: f64) {
    if floor <= 0.0 {
        return;
    }
    for row in b.iter_mut() {
        row.iter_mut().for_each(|p| *p = p.max(floor));
        let s: f64 = row.iter().sum();
        row.iter_mut().for_each(|p| *p /= s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn baum_welch_increases_likelihood_and_keeps_rows_valid() {
        let seqs: Vec<Vec<usize>> = (0..30)
            .map(|k| {
                let mut s = vec![0; 3 + k % 3];
                s.extend(vec![1; 4]);
                s.extend(vec![2; 2 + k % 2]);
                s
            })
            .collect();
        let cfg = HmmTrainConfig {
            states: 14,
            symbols: 4,
            iterations: 0,
            ..Default::default()
        };
        let h0 = DiscreteHmm::train(&seqs, &cfg);
        let h1 = DiscreteHmm::train(
            &seqs,
            &HmmTrainConfig {
                iterations: 10,
                ..cfg
            },
        );
        h1.validate().unwrap();
        let ll = |h: &DiscreteHmm| seqs.iter().map(|s| h.forward_log(s)).sum::<f64>();
        assert!(ll(&h1) >= ll(&h0) - 1e-6, "{} < {}", ll(&h1), ll(&h0));
        // 14 states, sequences as short as 9: the last rows still hold a distribution.
        assert!(h1.b[13].iter().all(|&p| p > 0.0));
    }
}
