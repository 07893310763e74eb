//! The template baseline: dynamic time warping 1-nearest-neighbour over every training
//! sample (trajectories resampled to equal arc length and normalized).

use crate::features::resample;
use crate::trajectory::Trajectory;

/// Templates: resampled, normalized point sequences with their class index.
#[derive(Debug, Clone, Default)]
pub struct DtwClassifier {
    /// Points every trajectory is resampled to.
    pub points: usize,
    /// Sakoe–Chiba band half-width in samples.
    pub band: usize,
    /// Every training sample, resampled, with its class.
    pub templates: Vec<(Vec<[f32; 2]>, usize)>,
}

impl DtwClassifier {
    /// A classifier without templates yet.
    pub fn new(points: usize, band: usize) -> Self {
        Self {
            points,
            band,
            templates: Vec::new(),
        }
    }

    /// Adds a training sample of class `class`.
    pub fn add(&mut self, t: &Trajectory, class: usize) {
        self.templates
            .push((resample(t, self.points).points, class));
    }

    /// The class of the nearest template (None without templates).
    pub fn classify(&self, t: &Trajectory) -> Option<usize> {
        let q = resample(t, self.points).points;
        let mut best = f32::INFINITY;
        let mut arg = None;
        let mut buf = Vec::new();
        for (tpl, c) in &self.templates {
            let d = dtw(&q, tpl, self.band, best, &mut buf);
            if d < best {
                best = d;
                arg = Some(*c);
            }
        }
        arg
    }
}

/// DTW distance with a band and early abandoning once a whole row exceeds `cutoff`.
pub fn dtw(a: &[[f32; 2]], b: &[[f32; 2]], band: usize, cutoff: f32, buf: &mut Vec<f32>) -> f32 {
    let (n, m) = (a.len(), b.len());
    if n == 0 || m == 0 {
        return f32::INFINITY;
    }
    let w = band.max(n.abs_diff(m));
    buf.clear();
    buf.resize(2 * (m + 1), f32::INFINITY);
    let (prev, cur) = buf.split_at_mut(m + 1);
    let (mut prev, mut cur) = (prev, cur);
    prev[0] = 0.0;
    for i in 1..=n {
        cur.iter_mut().for_each(|v| *v = f32::INFINITY);
        let lo = i.saturating_sub(w).max(1);
        let hi = (i + w).min(m);
        let mut row_min = f32::INFINITY;
        for j in lo..=hi {
            let dx = a[i - 1][0] - b[j - 1][0];
            let dy = a[i - 1][1] - b[j - 1][1];
            let c = (dx * dx + dy * dy).sqrt();
            let v = c + prev[j - 1].min(prev[j]).min(cur[j - 1]);
            cur[j] = v;
            row_min = row_min.min(v);
        }
        if row_min > cutoff {
            return f32::INFINITY;
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[m]
}
