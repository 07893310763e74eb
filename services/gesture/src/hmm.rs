//! Discrete hidden Markov models as a model file holds them, and their decoding: the
//! scaled forward algorithm and Viterbi in log space. Their training (Baum–Welch) is
//! the lab's (`lab::train`).

use serde::{Deserialize, Serialize};

/// A discrete HMM in probabilities: initial `pi`, transitions `a[i][j]`, emissions
/// `b[i][k]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiscreteHmm {
    /// Initial state distribution.
    pub pi: Vec<f64>,
    /// Transition probabilities, from state i (row) to j.
    pub a: Vec<Vec<f64>>,
    /// Emission probabilities of each symbol (column) in state i.
    pub b: Vec<Vec<f64>>,
}

/// The HMM with logarithms precomputed, for fast decoding.
#[derive(Debug, Clone)]
pub struct LogHmm {
    /// States.
    pub n: usize,
    /// Symbols.
    pub m: usize,
    /// ln of the initial distribution (−∞ where it is 0).
    pub log_pi: Vec<f64>,
    /// Row-major n×n.
    pub log_a: Vec<f64>,
    /// Row-major n×m.
    pub log_b: Vec<f64>,
}

impl DiscreteHmm {
    /// The number of states.
    pub fn n_states(&self) -> usize {
        self.pi.len()
    }

    /// The number of symbols it emits.
    pub fn n_symbols(&self) -> usize {
        self.b.first().map_or(0, |r| r.len())
    }

    /// Checks shapes and that every row is a probability distribution.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.pi.len();
        if n == 0 {
            return Err("HMM has no states".into());
        }
        crate::limits::within("HMM states", n, 1, crate::limits::MAX_STATES)?;
        if self.a.len() != n || self.b.len() != n {
            return Err(format!(
                "HMM has {n} states but {} transition rows and {} emission rows",
                self.a.len(),
                self.b.len()
            ));
        }
        let m = self.n_symbols();
        if m == 0 {
            return Err("HMM has no symbols".into());
        }
        crate::limits::within("HMM symbols", m, 1, crate::limits::MAX_SYMBOLS)?;
        let check = |row: &[f64], what: &str| -> Result<(), String> {
            if row.iter().any(|p| !p.is_finite() || *p < 0.0) {
                return Err(format!("{what} holds a negative or non-finite probability"));
            }
            let s: f64 = row.iter().sum();
            if (s - 1.0).abs() > 1e-6 {
                return Err(format!("{what} sums to {s}, not 1"));
            }
            Ok(())
        };
        check(&self.pi, "initial distribution")?;
        for i in 0..n {
            if self.a[i].len() != n {
                return Err(format!(
                    "transition row {i} has {} entries, expected {n}",
                    self.a[i].len()
                ));
            }
            if self.b[i].len() != m {
                return Err(format!(
                    "emission row {i} has {} entries, expected {m}",
                    self.b[i].len()
                ));
            }
            check(&self.a[i], &format!("transition row {i}"))?;
            check(&self.b[i], &format!("emission row {i}"))?;
        }
        Ok(())
    }

    /// The model in logarithms, to decode with.
    pub fn to_log(&self) -> LogHmm {
        let n = self.n_states();
        let m = self.n_symbols();
        let ln = |p: f64| if p > 0.0 { p.ln() } else { f64::NEG_INFINITY };
        LogHmm {
            n,
            m,
            log_pi: self.pi.iter().map(|&p| ln(p)).collect(),
            log_a: self.a.iter().flatten().map(|&p| ln(p)).collect(),
            log_b: self.b.iter().flatten().map(|&p| ln(p)).collect(),
        }
    }

    /// log P(O | λ) by the scaled forward algorithm. Symbols out of range give −∞.
    pub fn forward_log(&self, obs: &[usize]) -> f64 {
        let n = self.n_states();
        let m = self.n_symbols();
        if obs.is_empty() {
            return 0.0;
        }
        if obs.iter().any(|&o| o >= m) {
            return f64::NEG_INFINITY;
        }
        let mut alpha: Vec<f64> = (0..n).map(|i| self.pi[i] * self.b[i][obs[0]]).collect();
        let mut logp = 0.0;
        let mut next = vec![0.0; n];
        for t in 0..obs.len() {
            if t > 0 {
                for (j, nx) in next.iter_mut().enumerate() {
                    let mut s = 0.0;
                    for (i, al) in alpha.iter().enumerate() {
                        s += al * self.a[i][j];
                    }
                    *nx = s * self.b[j][obs[t]];
                }
                std::mem::swap(&mut alpha, &mut next);
            }
            let c: f64 = alpha.iter().sum();
            if c <= 0.0 {
                return f64::NEG_INFINITY;
            }
            logp += c.ln();
            alpha.iter_mut().for_each(|x| *x /= c);
        }
        logp
    }

    /// The most likely state path and its log probability.
    pub fn viterbi(&self, obs: &[usize]) -> (f64, Vec<usize>) {
        self.to_log().viterbi(obs)
    }
}

impl LogHmm {
    /// Viterbi: the best path's log probability and the path (empty when impossible).
    pub fn viterbi(&self, obs: &[usize]) -> (f64, Vec<usize>) {
        let n = self.n;
        if obs.is_empty() {
            return (0.0, Vec::new());
        }
        if obs.iter().any(|&o| o >= self.m) {
            return (f64::NEG_INFINITY, Vec::new());
        }
        let tl = obs.len();
        let mut delta: Vec<f64> = (0..n)
            .map(|i| self.log_pi[i] + self.log_b[i * self.m + obs[0]])
            .collect();
        let mut back = vec![0usize; tl * n];
        let mut next = vec![0.0; n];
        for t in 1..tl {
            for (j, nx) in next.iter_mut().enumerate() {
                let mut best = f64::NEG_INFINITY;
                let mut arg = 0;
                for (i, d) in delta.iter().enumerate() {
                    let v = d + self.log_a[i * n + j];
                    if v > best {
                        best = v;
                        arg = i;
                    }
                }
                *nx = best + self.log_b[j * self.m + obs[t]];
                back[t * n + j] = arg;
            }
            std::mem::swap(&mut delta, &mut next);
        }
        let (mut arg, mut best) = (0, f64::NEG_INFINITY);
        for (i, &d) in delta.iter().enumerate() {
            if d > best {
                best = d;
                arg = i;
            }
        }
        if best == f64::NEG_INFINITY {
            return (best, Vec::new());
        }
        let mut path = vec![0; tl];
        path[tl - 1] = arg;
        for t in (1..tl).rev() {
            path[t - 1] = back[t * n + path[t]];
        }
        (best, path)
    }

    /// Viterbi log probability only (no path), without allocation beyond two rows.
    pub fn viterbi_score(&self, obs: &[usize], buf: &mut Vec<f64>) -> f64 {
        let n = self.n;
        if obs.is_empty() {
            return 0.0;
        }
        if obs.iter().any(|&o| o >= self.m) {
            return f64::NEG_INFINITY;
        }
        buf.clear();
        buf.resize(2 * n, f64::NEG_INFINITY);
        let (cur, nxt) = buf.split_at_mut(n);
        let (mut cur, mut nxt) = (cur, nxt);
        for i in 0..n {
            cur[i] = self.log_pi[i] + self.log_b[i * self.m + obs[0]];
        }
        for &o in &obs[1..] {
            for j in 0..n {
                let mut best = f64::NEG_INFINITY;
                for i in 0..n {
                    let v = cur[i] + self.log_a[i * n + j];
                    if v > best {
                        best = v;
                    }
                }
                nxt[j] = best + self.log_b[j * self.m + o];
            }
            std::mem::swap(&mut cur, &mut nxt);
        }
        cur.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn golden() -> DiscreteHmm {
        DiscreteHmm {
            pi: vec![1.0, 0.0, 0.0],
            a: vec![
                vec![0.7, 0.3, 0.0],
                vec![0.0, 0.6, 0.4],
                vec![0.0, 0.0, 1.0],
            ],
            b: vec![
                vec![0.5, 0.5, 0.0, 0.0],
                vec![0.0, 0.2, 0.8, 0.0],
                vec![0.1, 0.1, 0.1, 0.7],
            ],
        }
    }

    #[test]
    fn golden_forward_and_viterbi() {
        let h = golden();
        h.validate().unwrap();
        let o = [0, 1, 2, 2, 3];
        let f = h.forward_log(&o);
        assert!((f - (-4.6838498230645875)).abs() < 1e-12, "forward {f}");
        let (v, path) = h.viterbi(&o);
        assert!((v - (-5.177020511591857)).abs() < 1e-12, "viterbi {v}");
        assert_eq!(path, vec![0, 0, 1, 1, 2]);
        let mut buf = Vec::new();
        assert!((h.to_log().viterbi_score(&o, &mut buf) - v).abs() < 1e-12);
    }
}
