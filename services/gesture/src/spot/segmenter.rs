//! Where a gesture can start or end: breaks of the hand's speed, and rests.

use super::SpotterConfig;
use crate::model::verifier::{context_steps, VerifierInput};

/// A place where a gesture may end (`end`) and the next begin (`start`): a dip of the
/// hand's speed (both the same point) or a rest (its first and last point).
#[derive(Debug, Clone, Copy)]
struct Break {
    end: usize,
    /// None while the rest goes on.
    start: Option<usize>,
}

/// Cuts the hand's path where a gesture can start or end: where the hand slows down
/// (a local minimum of its speed well below the fastest speed just before) or rests.
/// Points are numbered from the first one pushed (or since `reset`).
#[derive(Debug, Clone)]
pub struct Segmenter {
    cfg: SpotterConfig,
    /// Point index of the first element of `pts`.
    base: usize,
    /// Hand points (gesture-size units) with their frame sequence and time.
    pts: Vec<([f32; 2], u64, u64)>,
    /// The depth of every point of `pts` (0 when the model reads none).
    depth: Vec<f32>,
    /// Whether the hand's speed counts its depth: for a model of 3-D gestures, for
    /// which a push towards the camera is a movement and not a rest.
    in_depth: bool,
    /// `speed[k]`: the speed of point k − 2 (gesture sizes a second), centred over
    /// five points, so known two points late.
    speed: Vec<f32>,
    breaks: Vec<Break>,
    /// First point of the rest going on, if the hand rests.
    rest_from: Option<usize>,
}

impl Segmenter {
    pub fn new(cfg: &SpotterConfig) -> Self {
        Self {
            cfg: *cfg,
            base: 0,
            pts: Vec::new(),
            depth: Vec::new(),
            in_depth: false,
            speed: Vec::new(),
            breaks: Vec::new(),
            rest_from: None,
        }
    }

    /// Forgets the path; numbering goes on.
    pub fn reset(&mut self) {
        self.base += self.pts.len();
        self.pts.clear();
        self.depth.clear();
        self.speed.clear();
        self.breaks.clear();
        self.rest_from = None;
    }

    /// Index the next point will get.
    pub fn next_index(&self) -> usize {
        self.base + self.pts.len()
    }

    /// Counts the depth in the hand's speed from now on (see `in_depth`).
    pub fn set_in_depth(&mut self, on: bool) {
        self.in_depth = on;
    }

    /// Adds a point (gesture-size units) and its depth `z` (0 in the plane); returns the
    /// point where a gesture may end, when one was found (a few points back).
    pub fn push(&mut self, p: [f32; 2], z: f32, seq: u64, time_ns: u64) -> Option<usize> {
        self.pts.push((p, seq, time_ns));
        self.depth.push(z);
        let k = self.pts.len() - 1;
        if k >= 4 {
            let (a, b) = (self.pts[k - 4], self.pts[k]);
            let dt = (b.2.saturating_sub(a.2) as f64 * 1e-9).max(1e-4) as f32;
            let d = if self.in_depth {
                let dz = self.depth[k] - self.depth[k - 4];
                ((b.0[0] - a.0[0]).powi(2) + (b.0[1] - a.0[1]).powi(2) + dz * dz).sqrt()
            } else {
                ((b.0[0] - a.0[0]).powi(2) + (b.0[1] - a.0[1]).powi(2)).sqrt()
            };
            self.speed.push(d / dt);
        } else {
            self.speed.push(f32::NAN);
        }
        // The newest point whose speed is known, less the local-minimum window.
        let j = (self.base + k).checked_sub(2 + self.cfg.min_window)?;
        self.detect(j)
    }

    fn speed_at(&self, i: usize) -> f32 {
        i.checked_sub(self.base)
            .and_then(|k| self.speed.get(k + 2))
            .copied()
            .unwrap_or(f32::NAN)
    }

    /// Frames a second, from the timestamps of the last second.
    pub fn fps(&self) -> f64 {
        let k = self.pts.len();
        if k < 2 {
            return 30.0;
        }
        let (a, b) = (self.pts[k.saturating_sub(30)], self.pts[k - 1]);
        let n = (k - 1 - k.saturating_sub(30)) as f64;
        let secs = (b.2.saturating_sub(a.2) as f64 * 1e-9).max(1e-3);
        (n / secs).clamp(5.0, 240.0)
    }

    fn detect(&mut self, j: usize) -> Option<usize> {
        let w = self.cfg.min_window;
        let v = self.speed_at(j);
        if v.is_nan() {
            return None;
        }
        let resting = v < self.cfg.rest_speed;
        match (resting, self.rest_from) {
            (true, None) => {
                self.rest_from = Some(j);
                self.breaks.push(Break {
                    end: j,
                    start: None,
                });
                return Some(j);
            }
            (true, Some(_)) => return None,
            (false, Some(_)) => {
                self.rest_from = None;
                if let Some(b) = self.breaks.last_mut() {
                    b.start = Some(j.saturating_sub(1).max(b.end));
                }
                return None;
            }
            (false, None) => {}
        }
        for i in j.saturating_sub(w).max(self.base)..=j + w {
            let u = self.speed_at(i);
            if (i < j && u <= v) || (i > j && u < v) {
                return None;
            }
        }
        let back = (self.cfg.peak_seconds * self.fps()) as usize;
        let peak = (j.saturating_sub(back).max(self.base)..=j + w)
            .map(|i| self.speed_at(i))
            .filter(|u| !u.is_nan())
            .fold(0.0f32, f32::max);
        if v > self.cfg.break_ratio * peak {
            return None;
        }
        self.breaks.push(Break {
            end: j,
            start: Some(j),
        });
        Some(j)
    }

    /// Points where a gesture ending at `end` may start: at least `from`, between
    /// `min_len` and `max_len` points before `end`.
    pub fn starts(&self, end: usize, from: usize, min_len: usize, max_len: usize) -> Vec<usize> {
        self.breaks
            .iter()
            .filter_map(|b| b.start)
            .filter(|&s| s >= from && s < end && end - s >= min_len && end - s <= max_len)
            .collect()
    }

    /// The point `i` with its frame sequence and time, while it is kept.
    pub fn point(&self, i: usize) -> Option<([f32; 2], u64, u64)> {
        self.pts.get(i.checked_sub(self.base)?).copied()
    }

    /// The points s..=e (gesture-size units), while they are kept.
    pub fn points(&self, s: usize, e: usize) -> Option<Vec<[f32; 2]>> {
        let (a, b) = (s.checked_sub(self.base)?, e.checked_sub(self.base)?);
        (a <= b && b < self.pts.len()).then(|| self.pts[a..=b].iter().map(|p| p.0).collect())
    }

    /// The verifier's input for the segment s..=e: its points, and the hand's path just
    /// before and after it ([`VerifierInput::cut`]; as far as kept).
    /// The depths of the points s..=e.
    pub fn depths(&self, s: usize, e: usize) -> Option<Vec<f32>> {
        let (a, b) = (s.checked_sub(self.base)?, e.checked_sub(self.base)?);
        (a <= b && b < self.depth.len()).then(|| self.depth[a..=b].to_vec())
    }

    pub fn input(&self, s: usize, e: usize, fps: f64) -> Option<VerifierInput> {
        let (i0, i1) = (s.checked_sub(self.base)?, e.checked_sub(self.base)?);
        if i0 > i1 || i1 >= self.pts.len() {
            return None;
        }
        // The context walks at most this many points from either end: only that window
        // is copied, not every point kept (this runs for every candidate).
        let reach = context_steps(fps);
        let from = i0.saturating_sub(reach);
        let to = (i1 + reach + 1).min(self.pts.len());
        let window: Vec<[f32; 2]> = self.pts[from..to].iter().map(|p| p.0).collect();
        let t0 = self.pts[i0].2;
        let times = self.pts[i0..=i1]
            .iter()
            .map(|p| (p.2.saturating_sub(t0) as f64 * 1e-9) as f32)
            .collect();
        Some(VerifierInput::cut(
            &window,
            i0 - from,
            i1 - from,
            times,
            fps,
        ))
    }

    /// The first point of the rest going on, if the hand rests.
    pub fn resting_since(&self) -> Option<usize> {
        self.rest_from
    }

    /// Forgets points before `keep_from`.
    pub fn forget_before(&mut self, keep_from: usize) {
        let cut = keep_from.saturating_sub(self.base).min(self.pts.len());
        if cut == 0 {
            return;
        }
        self.pts.drain(..cut);
        self.depth.drain(..cut);
        self.speed.drain(..cut.min(self.speed.len()));
        self.base += cut;
        let base = self.base;
        self.breaks
            .retain(|b| b.start.is_none_or(|s| s >= base) && b.end >= base);
    }

    pub fn len(&self) -> usize {
        self.pts.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points one a frame at 30 fps; times in ns.
    fn feed(seg: &mut Segmenter, pts: &[[f32; 2]]) -> Vec<usize> {
        let mut ends = Vec::new();
        for (i, p) in pts.iter().enumerate() {
            ends.extend(seg.push(*p, 0.0, i as u64, i as u64 * 33_333_333));
        }
        ends
    }

    /// A minimum-jerk stroke from a to b in n frames (bell-shaped speed).
    fn stroke(a: [f32; 2], b: [f32; 2], n: usize) -> Vec<[f32; 2]> {
        (1..=n)
            .map(|i| {
                let t = i as f32 / n as f32;
                let s = t * t * t * (10.0 - 15.0 * t + 6.0 * t * t);
                [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])]
            })
            .collect()
    }

    #[test]
    fn breaks_fall_where_the_hand_slows_down_or_rests() {
        let mut seg = Segmenter::new(&SpotterConfig::default());
        // Rest, three strokes (two corners, where the hand stops an instant), rest.
        let mut pts = vec![[0.0, 0.0]; 20];
        pts.extend(stroke([0.0, 0.0], [1.0, 0.0], 15));
        pts.extend(stroke([1.0, 0.0], [1.0, 1.0], 15));
        pts.extend(stroke([1.0, 1.0], [0.0, 1.0], 15));
        pts.extend(vec![[0.0, 1.0]; 30]);
        let ends = feed(&mut seg, &pts);
        // A rest's first point, each corner (frames 34 and 49, ±2), the last rest.
        let near = |want: usize| ends.iter().any(|&e| e.abs_diff(want) <= 2);
        assert!(near(34) && near(49) && near(64), "{ends:?}");
        assert!(ends.len() <= 5, "{ends:?}");
        // The first rest ended where the first stroke starts: a gesture may start there.
        let starts = seg.starts(64, 0, 10, 100);
        assert!(starts.iter().any(|&s| s.abs_diff(19) <= 2), "{starts:?}");
    }

    /// Rest, a push towards the camera (depth only), rest: the break points found.
    fn push_breaks(in_depth: bool) -> Vec<usize> {
        let mut seg = Segmenter::new(&SpotterConfig::default());
        seg.set_in_depth(in_depth);
        let mut z = vec![0.0f32; 20];
        z.extend(stroke([0.0, 0.0], [1.0, 0.0], 20).iter().map(|p| p[0]));
        z.extend(vec![1.0; 30]);
        let mut ends = Vec::new();
        for (i, &d) in z.iter().enumerate() {
            ends.extend(seg.push([0.0, 0.0], d, i as u64, i as u64 * 33_333_333));
        }
        ends
    }

    #[test]
    fn a_push_is_a_movement_in_depth_and_a_rest_in_the_plane() {
        // In depth: the rest before it is cut where the push starts, and the rest after
        // it where it ends: a stretch that can be a gesture.
        let deep = push_breaks(true);
        assert!(deep.iter().any(|&e| e.abs_diff(40) <= 3), "{deep:?}");
        // In the plane the hand never moved: one rest from the first frame on.
        let flat = push_breaks(false);
        assert!(flat.iter().all(|&e| e < 10), "{flat:?}");
    }
}
