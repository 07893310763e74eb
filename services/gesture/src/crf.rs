//! A linear-chain conditional random field over the same direction codes as the HMMs.
//! Every position of a sequence is labelled with the gesture's class; the sequence's
//! class is the one with the largest summed marginal. Features: the code at t, at t−1
//! and t+1 (with a boundary symbol), and the code at t in one of three time bins;
//! label–label transitions and a start weight. Trained by maximizing the L2-regularized
//! conditional log-likelihood with our own L-BFGS.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Crf {
    pub labels: usize,
    pub symbols: usize,
    pub time_bins: usize,
    /// features × labels, row-major.
    pub w_obs: Vec<f64>,
    /// labels × labels (from, to).
    pub w_trans: Vec<f64>,
    pub w_start: Vec<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CrfTrainConfig {
    pub l2: f64,
    pub iterations: usize,
    pub time_bins: usize,
}

impl Default for CrfTrainConfig {
    fn default() -> Self {
        Self {
            l2: 1.0,
            iterations: 80,
            time_bins: 3,
        }
    }
}

impl Crf {
    /// Saturates instead of wrapping: an overflowing size never matches the weights.
    pub fn n_features(symbols: usize, time_bins: usize) -> usize {
        symbols
            .saturating_add(symbols.saturating_add(1).saturating_mul(2))
            .saturating_add(time_bins.saturating_mul(symbols))
    }

    fn n_params(&self) -> usize {
        self.w_obs.len() + self.w_trans.len() + self.w_start.len()
    }

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
    fn active(&self, obs: &[usize], t: usize) -> [usize; 4] {
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
    fn marginals(&self, obs: &[usize], params: &[f64]) -> (Vec<f64>, Vec<f64>, f64, Vec<f64>) {
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

    /// Negative log-likelihood of one sequence labelled `y` throughout, and its gradient
    /// added to `grad`.
    fn nll_grad(&self, obs: &[usize], y: usize, params: &[f64], grad: &mut [f64]) -> f64 {
        let l = self.labels;
        if obs.is_empty() {
            return 0.0;
        }
        let (marg, pair, log_z, u) = self.marginals(obs, params);
        let no = self.w_obs.len();
        let trans_yy = params[no + y * l + y];
        let mut score = 0.0;
        for t in 0..obs.len() {
            score += u[t * l + y];
            if t > 0 {
                score += trans_yy;
            }
            for f in self.active(obs, t) {
                grad[f * l + y] -= 1.0;
                for yy in 0..l {
                    grad[f * l + yy] += marg[t * l + yy];
                }
            }
        }
        grad[no + y * l + y] -= (obs.len() - 1) as f64;
        for k in 0..l * l {
            grad[no + k] += pair[k];
        }
        grad[no + l * l + y] -= 1.0;
        for yy in 0..l {
            grad[no + l * l + yy] += marg[yy];
        }
        log_z - score
    }

    fn params(&self) -> Vec<f64> {
        let mut p = self.w_obs.clone();
        p.extend_from_slice(&self.w_trans);
        p.extend_from_slice(&self.w_start);
        p
    }

    fn set_params(&mut self, p: &[f64]) {
        let no = self.w_obs.len();
        let l = self.labels;
        self.w_obs.copy_from_slice(&p[..no]);
        self.w_trans.copy_from_slice(&p[no..no + l * l]);
        self.w_start.copy_from_slice(&p[no + l * l..]);
    }

    /// Trains on code sequences with class labels.
    pub fn train(
        seqs: &[Vec<usize>],
        labels: &[usize],
        n_labels: usize,
        symbols: usize,
        cfg: &CrfTrainConfig,
        mut progress: impl FnMut(usize),
    ) -> Crf {
        let tb = cfg.time_bins.max(1);
        let nf = Self::n_features(symbols, tb);
        let mut crf = Crf {
            labels: n_labels,
            symbols,
            time_bins: tb,
            w_obs: vec![0.0; nf * n_labels],
            w_trans: vec![0.0; n_labels * n_labels],
            w_start: vec![0.0; n_labels],
        };
        let np = crf.n_params();
        let f = |p: &[f64]| -> (f64, Vec<f64>) {
            // Fixed chunks summed in order: the result does not depend on threads.
            let parts: Vec<(f64, Vec<f64>)> = seqs
                .par_chunks(256)
                .zip(labels.par_chunks(256))
                .map(|(ss, ys)| {
                    let mut g = vec![0.0; np];
                    let mut v = 0.0;
                    for (s, &y) in ss.iter().zip(ys) {
                        v += crf.nll_grad(s, y, p, &mut g);
                    }
                    (v, g)
                })
                .collect();
            let mut v = 0.0;
            let mut g = vec![0.0; np];
            for (pv, pg) in parts {
                v += pv;
                g.iter_mut().zip(pg).for_each(|(a, b)| *a += b);
            }
            for k in 0..np {
                v += 0.5 * cfg.l2 * p[k] * p[k];
                g[k] += cfg.l2 * p[k];
            }
            (v, g)
        };
        let p0 = crf.params();
        let p = lbfgs(f, p0, cfg.iterations, 7, &mut progress);
        crf.set_params(&p);
        crf
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

/// Limited-memory BFGS with a backtracking (Armijo) line search; minimizes `f`.
pub fn lbfgs<F>(
    f: F,
    mut x: Vec<f64>,
    iterations: usize,
    memory: usize,
    progress: &mut impl FnMut(usize),
) -> Vec<f64>
where
    F: Fn(&[f64]) -> (f64, Vec<f64>),
{
    let n = x.len();
    let (mut fx, mut g) = f(&x);
    let mut s_hist: Vec<Vec<f64>> = Vec::new();
    let mut y_hist: Vec<Vec<f64>> = Vec::new();
    let dotp = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| p * q).sum::<f64>();
    for it in 0..iterations {
        // Two-loop recursion: d = −H g.
        let mut q = g.clone();
        let k = s_hist.len();
        let mut alphas = vec![0.0; k];
        for i in (0..k).rev() {
            let rho = 1.0 / dotp(&y_hist[i], &s_hist[i]);
            alphas[i] = rho * dotp(&s_hist[i], &q);
            for j in 0..n {
                q[j] -= alphas[i] * y_hist[i][j];
            }
        }
        let gamma = if k > 0 {
            dotp(&s_hist[k - 1], &y_hist[k - 1]) / dotp(&y_hist[k - 1], &y_hist[k - 1])
        } else {
            1.0 / dotp(&g, &g).sqrt().max(1e-12)
        };
        q.iter_mut().for_each(|v| *v *= gamma);
        for i in 0..k {
            let rho = 1.0 / dotp(&y_hist[i], &s_hist[i]);
            let beta = rho * dotp(&y_hist[i], &q);
            for j in 0..n {
                q[j] += s_hist[i][j] * (alphas[i] - beta);
            }
        }
        let d: Vec<f64> = q.iter().map(|v| -v).collect();
        let mut dg = dotp(&d, &g);
        let d = if dg >= 0.0 {
            s_hist.clear();
            y_hist.clear();
            let d: Vec<f64> = g.iter().map(|v| -v).collect();
            dg = dotp(&d, &g);
            d
        } else {
            d
        };
        let mut step = 1.0;
        let mut accepted = None;
        for _ in 0..30 {
            let xn: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + step * b).collect();
            let (fn_, gn) = f(&xn);
            if fn_.is_finite() && fn_ <= fx + 1e-4 * step * dg {
                accepted = Some((xn, fn_, gn));
                break;
            }
            step *= 0.5;
        }
        let Some((xn, fn_, gn)) = accepted else {
            break;
        };
        let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
        if dotp(&s, &y) > 1e-10 {
            s_hist.push(s);
            y_hist.push(y);
            if s_hist.len() > memory {
                s_hist.remove(0);
                y_hist.remove(0);
            }
        }
        let rel = (fx - fn_).abs() / fx.abs().max(1.0);
        x = xn;
        fx = fn_;
        g = gn;
        progress(it);
        if rel < 1e-7 {
            break;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lbfgs_minimizes_a_quadratic() {
        let f = |x: &[f64]| {
            let v = (x[0] - 3.0).powi(2) + 10.0 * (x[1] + 1.0).powi(2);
            (v, vec![2.0 * (x[0] - 3.0), 20.0 * (x[1] + 1.0)])
        };
        let x = lbfgs(f, vec![0.0, 0.0], 100, 5, &mut |_| {});
        assert!(
            (x[0] - 3.0).abs() < 1e-4 && (x[1] + 1.0).abs() < 1e-4,
            "{x:?}"
        );
    }

    #[test]
    fn crf_gradient_matches_finite_differences() {
        let seqs = [vec![0, 1, 2, 2], vec![3, 3, 0]];
        let labels = [1usize, 0];
        let mut crf = Crf::train(
            &seqs,
            &labels,
            2,
            4,
            &CrfTrainConfig {
                iterations: 2,
                ..Default::default()
            },
            |_| {},
        );
        crf.w_trans[1] = 0.3;
        let p = crf.params();
        let mut g = vec![0.0; p.len()];
        let f0 = crf.nll_grad(&seqs[0], labels[0], &p, &mut g);
        for k in [0usize, 5, 17, p.len() - 1, p.len() - 3] {
            let mut q = p.clone();
            q[k] += 1e-6;
            let mut tmp = vec![0.0; p.len()];
            let f1 = crf.nll_grad(&seqs[0], labels[0], &q, &mut tmp);
            assert!(((f1 - f0) / 1e-6 - g[k]).abs() < 1e-4, "param {k}");
        }
    }
}
