//! Training the CRF: the L2-regularized conditional log-likelihood maximized with our
//! own L-BFGS.

use crate::crf::Crf;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// CRF training settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CrfTrainConfig {
    /// Weight of the L2 penalty on the weights.
    pub l2: f64,
    /// L-BFGS iterations.
    pub iterations: usize,
    /// Parts of a sequence with weights of their own ([`Crf::time_bins`]).
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
    fn n_params(&self) -> usize {
        self.w_obs.len() + self.w_trans.len() + self.w_start.len()
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
