//! Dynamic time warping between two sequences of points of any dimension: the template
//! member of the ensemble (positions and directions), and the lab's baselines in the
//! plane and in space.

/// The DTW distance (the sum of Euclidean step costs along the best warping path)
/// within a band of `band` steps (widened to the length difference), abandoned
/// (infinite) once a whole row exceeds `cutoff`. `buf` is scratch, reused across calls.
pub fn dtw<const D: usize>(
    a: &[[f32; D]],
    b: &[[f32; D]],
    band: usize,
    cutoff: f32,
    buf: &mut Vec<f32>,
) -> f32 {
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
            let (p, q) = (&a[i - 1], &b[j - 1]);
            let c = p
                .iter()
                .zip(q)
                .fold(0.0f32, |s, (x, y)| s + (x - y) * (x - y))
                .sqrt();
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

/// The class of the template nearest `q` by [`dtw`] (None without templates): a 1-NN
/// classifier's decision, each distance abandoned once it exceeds the best so far.
#[cfg(feature = "lab")]
pub fn nearest<const D: usize>(
    q: &[[f32; D]],
    templates: &[(Vec<[f32; D]>, usize)],
    band: usize,
) -> Option<usize> {
    let mut best = f32::INFINITY;
    let mut arg = None;
    let mut buf = Vec::new();
    for (tpl, c) in templates {
        let d = dtw(q, tpl, band, best, &mut buf);
        if d < best {
            best = d;
            arg = Some(*c);
        }
    }
    arg
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sequence_is_nearest_itself_and_a_far_one_is_abandoned() {
        let line = |k: f32| -> Vec<[f32; 3]> { (0..10).map(|i| [i as f32, k, 0.0]).collect() };
        let mut buf = Vec::new();
        assert_eq!(dtw(&line(0.0), &line(0.0), 2, f32::INFINITY, &mut buf), 0.0);
        // Every step 1 apart: 10 steps on the diagonal.
        assert!((dtw(&line(0.0), &line(1.0), 2, f32::INFINITY, &mut buf) - 10.0).abs() < 1e-5);
        assert_eq!(dtw(&line(0.0), &line(5.0), 2, 3.0, &mut buf), f32::INFINITY);
        assert_eq!(
            dtw::<3>(&[], &line(0.0), 2, f32::INFINITY, &mut buf),
            f32::INFINITY
        );
    }
}
