//! Evaluation: confusion matrices, accuracy, per-class recall, and the confusion-matrix
//! picture (plotters).

use plotters::prelude::*;
use std::path::Path;

/// A confusion matrix: `m[truth][predicted]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Confusion {
    pub labels: Vec<String>,
    pub m: Vec<Vec<u32>>,
}

impl Confusion {
    pub fn new(labels: Vec<String>) -> Self {
        let n = labels.len();
        Self {
            labels,
            m: vec![vec![0; n]; n],
        }
    }

    pub fn add(&mut self, truth: usize, predicted: usize) {
        if truth < self.m.len() && predicted < self.m.len() {
            self.m[truth][predicted] += 1;
        }
    }

    pub fn total(&self) -> u64 {
        self.m.iter().flatten().map(|&v| v as u64).sum()
    }

    pub fn correct(&self) -> u64 {
        (0..self.m.len()).map(|i| self.m[i][i] as u64).sum()
    }

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
    pub fn plot(&self, path: &Path, title: &str) -> Result<(), String> {
        let n = self.labels.len().max(1);
        let cell = if n <= 12 { 48 } else { 24 };
        let size = (cell * n as u32 + 120, cell * n as u32 + 140);
        let root = BitMapBackend::new(path, size).into_drawing_area();
        let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(40)
            .build_cartesian_2d((0..n - 1).into_segmented(), (0..n - 1).into_segmented())
            .map_err(|e| err(&e))?;
        let labels = self.labels.clone();
        let labels2 = self.labels.clone();
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(n)
            .y_labels(n)
            .x_desc("predicted")
            .y_desc("true")
            .x_label_formatter(&move |v| match v {
                SegmentValue::CenterOf(i) => labels.get(*i).cloned().unwrap_or_default(),
                _ => String::new(),
            })
            .y_label_formatter(&move |v| match v {
                SegmentValue::CenterOf(i) if *i < n => labels2[n - 1 - *i].clone(),
                _ => String::new(),
            })
            .draw()
            .map_err(|e| err(&e))?;
        let mut rects = Vec::new();
        for i in 0..self.m.len() {
            let tot: u32 = self.m[i].iter().sum::<u32>().max(1);
            for j in 0..self.m.len() {
                let v = self.m[i][j] as f64 / tot as f64;
                // White to dark blue; sqrt to make small confusions visible.
                let s = v.sqrt();
                let c = RGBColor(
                    (255.0 * (1.0 - s)) as u8,
                    (255.0 * (1.0 - 0.8 * s)) as u8,
                    255,
                );
                let y = n - 1 - i;
                rects.push(Rectangle::new(
                    [
                        (SegmentValue::Exact(j), SegmentValue::Exact(y)),
                        (SegmentValue::Exact(j + 1), SegmentValue::Exact(y + 1)),
                    ],
                    c.filled(),
                ));
            }
        }
        chart.draw_series(rects).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
        Ok(())
    }
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
}
