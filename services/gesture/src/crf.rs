//! A linear-chain conditional random field over the same direction codes as the HMMs.
//! Every position of a sequence is labelled with the gesture's class; the sequence's
//! class is the one with the largest summed marginal. Features: the code at t, at t−1
//! and t+1 (with a boundary symbol), and the code at t in one of three time bins;
//! label–label transitions and a start weight. Its training (L2-regularized conditional
//! log-likelihood, our own L-BFGS) is the lab's (`lab::train`).

use serde::{Deserialize, Serialize};

/// A trained CRF: its sizes and weights.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Crf {
    /// Classes.
    pub labels: usize,
    /// Direction codes it reads (8, or 9 with the resting code).
    pub symbols: usize,
    /// Parts of a sequence with weights of their own for the code at t.
    pub time_bins: usize,
    /// features × labels, row-major.
    pub w_obs: Vec<f64>,
    /// labels × labels (from, to).
    pub w_trans: Vec<f64>,
    /// One a label, for the first position.
    pub w_start: Vec<f64>,
}

impl Crf {
    /// Saturates instead of wrapping: an overflowing size never matches the weights.
    pub fn n_features(symbols: usize, time_bins: usize) -> usize {
        symbols
            .saturating_add(symbols.saturating_add(1).saturating_mul(2))
            .saturating_add(time_bins.saturating_mul(symbols))
    }

    /// Checks sizes within [`crate::limits`], weights that match them and are finite: a
    /// model file is not trusted.
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::{product, within, MAX_LABELS, MAX_SYMBOLS, MAX_TIME_BINS};
        if self.labels == 0 || self.symbols == 0 {
            return Err("CRF has no labels or no symbols".into());
        }
        within("CRF labels", self.labels, 1, MAX_LABELS)?;
        within("CRF symbols", self.symbols, 1, MAX_SYMBOLS)?;
        within("CRF time bins", self.time_bins, 1, MAX_TIME_BINS)?;
        let f = Self::n_features(self.symbols, self.time_bins);
        if self.w_obs.len() != product("CRF observation weights", f, self.labels)?
            || self.w_trans.len() != self.labels * self.labels
            || self.w_start.len() != self.labels
        {
            return Err("CRF weights do not match its labels and symbols".into());
        }
        if self
            .w_obs
            .iter()
            .chain(&self.w_trans)
            .chain(&self.w_start)
            .any(|w| !w.is_finite())
        {
            return Err("CRF holds a non-finite weight".into());
        }
        Ok(())
    }

    /// The active feature ids at position t.
    pub(crate) fn active(&self, obs: &[usize], t: usize) -> [usize; 4] {
        let m = self.symbols;
        let tl = obs.len();
        let prev = if t == 0 { m } else { obs[t - 1].min(m) };
        let next = if t + 1 >= tl { m } else { obs[t + 1].min(m) };
        let bin = (t * self.time_bins / tl.max(1)).min(self.time_bins - 1);
        let o = obs[t].min(m - 1);
        [
            o,
            m + prev,
            m + (m + 1) + next,
            m + 2 * (m + 1) + bin * m + o,
        ]
    }

    /// Per-position unary potentials (T × L, log space).
    fn unaries(&self, obs: &[usize], w_obs: &[f64], w_start: &[f64]) -> Vec<f64> {
        let l = self.labels;
        let mut u = vec![0.0; obs.len() * l];
        for t in 0..obs.len() {
            for f in self.active(obs, t) {
                for y in 0..l {
                    u[t * l + y] += w_obs[f * l + y];
                }
            }
            if t == 0 {
                for y in 0..l {
                    u[y] += w_start[y];
                }
            }
        }
        u
    }

    /// Marginals P(y_t = y | x) (T × L) and log Z, by scaled forward–backward.
    pub(crate) fn marginals(
        &self,
        obs: &[usize],
        params: &[f64],
    ) -> (Vec<f64>, Vec<f64>, f64, Vec<f64>) {
        let l = self.labels;
        let (w_obs, rest) = params.split_at(self.w_obs.len());
        let (w_trans, w_start) = rest.split_at(l * l);
        let tl = obs.len();
        let u = self.unaries(obs, w_obs, w_start);
        // Exponentiated potentials with a per-position shift for stability.
        let mut eu = vec![0.0; tl * l];
        let mut shift = vec![0.0; tl];
        for t in 0..tl {
            let mx = u[t * l..(t + 1) * l]
                .iter()
                .cloned()
                .fold(f64::NEG_INFINITY, f64::max);
            shift[t] = mx;
            for y in 0..l {
                eu[t * l + y] = (u[t * l + y] - mx).exp();
            }
        }
        let et: Vec<f64> = w_trans.iter().map(|w| w.exp()).collect();
        let mut alpha = vec![0.0; tl * l];
        let mut scale = vec![0.0; tl];
        for t in 0..tl {
            for y in 0..l {
                let s = if t == 0 {
                    1.0
                } else {
                    let mut acc = 0.0;
                    for yp in 0..l {
                        acc += alpha[(t - 1) * l + yp] * et[yp * l + y];
                    }
                    acc
                };
                alpha[t * l + y] = s * eu[t * l + y];
            }
            let c: f64 = alpha[t * l..(t + 1) * l].iter().sum();
            scale[t] = c;
            alpha[t * l..(t + 1) * l].iter_mut().for_each(|v| *v /= c);
        }
        let mut beta = vec![0.0; tl * l];
        for y in 0..l {
            beta[(tl - 1) * l + y] = 1.0;
        }
        for t in (0..tl.saturating_sub(1)).rev() {
            for yp in 0..l {
                let mut acc = 0.0;
                for y in 0..l {
                    acc += et[yp * l + y] * eu[(t + 1) * l + y] * beta[(t + 1) * l + y];
                }
                beta[t * l + yp] = acc / scale[t + 1];
            }
        }
        let log_z: f64 = scale.iter().map(|c| c.ln()).sum::<f64>() + shift.iter().sum::<f64>();
        let mut marg = vec![0.0; tl * l];
        for k in 0..tl * l {
            marg[k] = alpha[k] * beta[k];
        }
        // Pairwise expected transition counts.
        let mut pair = vec![0.0; l * l];
        for t in 1..tl {
            for yp in 0..l {
                let a = alpha[(t - 1) * l + yp];
                for y in 0..l {
                    pair[yp * l + y] +=
                        a * et[yp * l + y] * eu[t * l + y] * beta[t * l + y] / scale[t];
                }
            }
        }
        (marg, pair, log_z, u)
    }

    /// The weights as one vector: observation, transition, start.
    pub(crate) fn params(&self) -> Vec<f64> {
        let mut p = self.w_obs.clone();
        p.extend_from_slice(&self.w_trans);
        p.extend_from_slice(&self.w_start);
        p
    }

    /// The class with the largest summed marginal, and that mean marginal.
    pub fn classify(&self, obs: &[usize]) -> (usize, Vec<f64>) {
        let l = self.labels;
        if obs.is_empty() {
            return (0, vec![1.0 / l as f64; l]);
        }
        let (marg, _, _, _) = self.marginals(obs, &self.params());
        let mut tot = vec![0.0; l];
        for t in 0..obs.len() {
            for y in 0..l {
                tot[y] += marg[t * l + y] / obs.len() as f64;
            }
        }
        let arg = (0..l)
            .max_by(|&a, &b| tot[a].total_cmp(&tot[b]))
            .unwrap_or(0);
        (arg, tot)
    }
}
