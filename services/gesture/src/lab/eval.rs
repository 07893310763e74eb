//! Evaluation: confusion matrices, accuracy, per-class recall, and the confusion-matrix
//! picture (plotters, through airglyph-plot).

use airglyph_plot::PlotError;
use plotters::prelude::*;
use std::path::Path;

/// A confusion matrix: `m[truth][predicted]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Confusion {
    /// The labels, in the order of the rows and columns.
    pub labels: Vec<String>,
    /// The counts.
    pub m: Vec<Vec<u32>>,
}

impl Confusion {
    /// A matrix of zeros over `labels`.
    pub fn new(labels: Vec<String>) -> Self {
        let n = labels.len();
        Self {
            labels,
            m: vec![vec![0; n]; n],
        }
    }

    /// Counts one decision (indices out of range are left out).
    pub fn add(&mut self, truth: usize, predicted: usize) {
        if truth < self.m.len() && predicted < self.m.len() {
            self.m[truth][predicted] += 1;
        }
    }

    /// Decisions counted.
    pub fn total(&self) -> u64 {
        self.m.iter().flatten().map(|&v| v as u64).sum()
    }

    /// Decisions right.
    pub fn correct(&self) -> u64 {
        (0..self.m.len()).map(|i| self.m[i][i] as u64).sum()
    }

    /// The fraction right (0 with no decision).
    pub fn accuracy(&self) -> f64 {
        self.correct() as f64 / self.total().max(1) as f64
    }

    /// Recall of every label (None for labels without test samples).
    pub fn recall(&self) -> Vec<(String, Option<f64>)> {
        self.labels
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let n: u64 = self.m[i].iter().map(|&v| v as u64).sum();
                (l.clone(), (n > 0).then(|| self.m[i][i] as f64 / n as f64))
            })
            .collect()
    }

    /// The most frequent confusions (truth, predicted, count), largest first.
    pub fn top_confusions(&self, k: usize) -> Vec<(String, String, u32)> {
        let mut v = Vec::new();
        for i in 0..self.m.len() {
            for j in 0..self.m.len() {
                if i != j && self.m[i][j] > 0 {
                    v.push((self.labels[i].clone(), self.labels[j].clone(), self.m[i][j]));
                }
            }
        }
        v.sort_by_key(|x| std::cmp::Reverse(x.2));
        v.truncate(k);
        v
    }

    /// Draws the row-normalized matrix as a PNG heat map.
    pub fn plot(&self, path: &Path, title: &str) -> Result<(), PlotError> {
        airglyph_plot::confusion(path, title, &self.labels, &self.m, false)
    }
}

/// A labelled frame interval on a stream timeline.
#[derive(Debug, Clone, PartialEq)]
pub struct Span {
    /// What it is.
    pub label: String,
    /// Its first frame…
    pub start: u64,
    /// …and its last.
    pub end: u64,
}

/// Draws a stretch of a hand stream as a PNG: x, y and speed against the frame, with
/// the drawn gestures (green bands, labelled above) and the spotted ones (bars at the
/// bottom: blue when the label matches the band they overlap, red otherwise).
/// `points` are body-frame hand points, one a frame, starting at frame `first`.
pub fn plot_timeline(
    path: &Path,
    title: &str,
    points: &[[f32; 2]],
    first: u64,
    fps: f32,
    drawn: &[Span],
    spotted: &[Span],
) -> Result<(), PlotError> {
    let n = points.len().max(2);
    let x0 = first as f64;
    let x1 = (first + n as u64 - 1) as f64;
    let width = (n as u32 * 3).clamp(800, 6000);
    airglyph_plot::png(path, (width, 620), |root| {
        let root = root.titled(title, ("sans-serif", 18))?;
        let panels = root.split_evenly((3, 1));
        let speed: Vec<f64> = (0..points.len())
            .map(|i| {
                let (a, b) = (points[i.saturating_sub(1)], points[i]);
                (((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt() * fps) as f64
            })
            .collect();
        let series: [(&str, Vec<f64>); 3] = [
            ("x (sw)", points.iter().map(|p| p[0] as f64).collect()),
            ("y (sw)", points.iter().map(|p| p[1] as f64).collect()),
            ("speed (sw/s)", speed),
        ];
        for (k, (panel, (name, v))) in panels.iter().zip(series.iter()).enumerate() {
            let lo = v.iter().cloned().fold(f64::MAX, f64::min).min(0.0);
            let hi = v.iter().cloned().fold(f64::MIN, f64::max).max(lo + 0.1);
            let pad = 0.25 * (hi - lo);
            let (lo, hi) = (lo - pad, hi + 0.1 * (hi - lo));
            let mut chart = ChartBuilder::on(panel)
                .margin(6)
                .x_label_area_size(if k == 2 { 30 } else { 0 })
                .y_label_area_size(60)
                .build_cartesian_2d(x0..x1, lo..hi)?;
            chart
                .configure_mesh()
                .y_desc(*name)
                .x_labels(20)
                .light_line_style(WHITE)
                .draw()?;
            let inside = |s: &Span| (s.end as f64) >= x0 && (s.start as f64) <= x1;
            chart.draw_series(drawn.iter().filter(|s| inside(s)).map(|s| {
                Rectangle::new(
                    [(s.start as f64, lo), (s.end as f64, hi)],
                    RGBColor(200, 240, 200).filled(),
                )
            }))?;
            chart.draw_series(LineSeries::new(
                v.iter().enumerate().map(|(i, &y)| (x0 + i as f64, y)),
                &BLACK,
            ))?;
            if k == 0 {
                chart.draw_series(drawn.iter().filter(|s| inside(s)).map(|s| {
                    Text::new(
                        s.label.clone(),
                        (s.start as f64, hi - 0.02 * (hi - lo)),
                        ("sans-serif", 16).into_font().color(&RGBColor(0, 120, 0)),
                    )
                }))?;
            }
            let bar = lo + 0.1 * (hi - lo);
            let h = 0.08 * (hi - lo);
            for s in spotted.iter().filter(|s| inside(s)) {
                let ok = drawn
                    .iter()
                    .any(|d| d.label == s.label && d.start.max(s.start) < d.end.min(s.end));
                let c = if ok { BLUE } else { RED };
                chart.draw_series([Rectangle::new(
                    [
                        (s.start as f64, bar - h / 2.0),
                        (s.end as f64, bar + h / 2.0),
                    ],
                    c.mix(0.6).filled(),
                )])?;
                if k == 2 {
                    chart.draw_series([Text::new(
                        s.label.clone(),
                        (s.start as f64, bar + h),
                        ("sans-serif", 16).into_font().color(&c),
                    )])?;
                }
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn confusion_counts_and_plot() {
        let mut c = Confusion::new(vec!["a".into(), "b".into(), "c".into()]);
        c.add(0, 0);
        c.add(0, 1);
        c.add(1, 1);
        c.add(2, 2);
        assert_eq!(c.total(), 4);
        assert!((c.accuracy() - 0.75).abs() < 1e-12);
        assert_eq!(c.recall()[0].1, Some(0.5));
        assert_eq!(c.top_confusions(1), vec![("a".into(), "b".into(), 1)]);
        let dir = std::env::temp_dir().join(format!("ag-conf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("c.png");
        c.plot(&path, "test").unwrap();
        assert!(std::fs::metadata(&path).unwrap().len() > 100);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn timeline_plot_draws_a_stretch_of_stream() {
        let points: Vec<[f32; 2]> = (0..300)
            .map(|i| [(i as f32 * 0.1).sin(), (i as f32 * 0.07).cos()])
            .collect();
        let span = |l: &str, a, b| Span {
            label: l.into(),
            start: a,
            end: b,
        };
        let dir = std::env::temp_dir().join(format!("ag-timeline-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.png");
        plot_timeline(
            &path,
            "test",
            &points,
            100,
            30.0,
            &[span("7", 120, 180), span("1", 500, 520)],
            &[span("7", 118, 182), span("Z", 300, 340)],
        )
        .unwrap();
        let img = image::open(&path).unwrap();
        assert_eq!((img.width(), img.height()), (900, 620));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
