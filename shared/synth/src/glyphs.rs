//! Built-in stroke templates for 0–9 and A–Z, as a person draws them in the air, and the
//! trajectory JSONL reader (docs/architecture.md, "Trajectory JSONL") for drawing real
//! samples instead.
//!
//! A template is a list of strokes (pen-down ink) in a unit box, x right and y down,
//! as the writer sees it (air-drawing mirrors it for the camera facing the writer). An air-drawn symbol is its strokes joined by the hand's travel
//! between them: [`Glyph::path`].

use crate::error::SynthError;
use nalgebra::Point2;
use std::io::Read;
use std::path::Path;

/// One symbol's strokes, each a polyline, in a unit box (x right, y down).
#[derive(Debug, Clone, PartialEq)]
pub struct Glyph {
    /// The symbol it draws.
    pub label: String,
    /// Its strokes, in drawing order.
    pub strokes: Vec<Vec<Point2<f32>>>,
}

impl Glyph {
    /// The whole trajectory: every stroke, joined by straight travel between them.
    pub fn path(&self) -> Vec<Point2<f32>> {
        let mut out: Vec<Point2<f32>> = Vec::new();
        for s in &self.strokes {
            for p in s {
                if out.last() != Some(p) {
                    out.push(*p);
                }
            }
        }
        out
    }

    /// Scales and centres the strokes into the unit box, keeping the aspect ratio.
    pub fn normalized(mut self) -> Glyph {
        let pts = self.strokes.iter().flatten();
        let (mut lo, mut hi) = (
            Point2::new(f32::MAX, f32::MAX),
            Point2::new(f32::MIN, f32::MIN),
        );
        for p in pts {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let ext = (hi - lo).max().max(1e-6);
        let off = (Point2::new(1.0, 1.0) - (hi - lo) / ext) / 2.0;
        for s in &mut self.strokes {
            for p in s.iter_mut() {
                *p = Point2::from((*p - lo) / ext + off.coords);
            }
        }
        self
    }
}

fn arc(cx: f32, cy: f32, rx: f32, ry: f32, a0: f32, a1: f32) -> Vec<Point2<f32>> {
    let n = (((a1 - a0).abs() / 12.0).ceil() as usize).max(2);
    (0..=n)
        .map(|i| {
            let a = (a0 + (a1 - a0) * i as f32 / n as f32).to_radians();
            Point2::new(cx + rx * a.cos(), cy + ry * a.sin())
        })
        .collect()
}

fn pl(pts: &[(f32, f32)]) -> Vec<Point2<f32>> {
    pts.iter().map(|&(x, y)| Point2::new(x, y)).collect()
}

fn cat(parts: &[Vec<Point2<f32>>]) -> Vec<Point2<f32>> {
    parts.concat()
}

/// The symbols with a built-in template.
pub const BUILT_IN: &str = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ";

/// The built-in template of `c` (0–9, A–Z; lower case is taken as upper case).
pub fn template(c: char) -> Option<Glyph> {
    let c = c.to_ascii_uppercase();
    let strokes: Vec<Vec<Point2<f32>>> = match c {
        // UNIPEN writers draw "0" and "O" alike on the whole (the same median width,
        // start and turn, even within one writer): these two are the mean shapes of the
        // held-out writers' samples that a writer-independent classifier reads as their
        // own label (the "O" widened to their median width, 0.8 of the height, which
        // averaging loops narrows). A "0" starts at the top's left shoulder, runs down
        // the left, and closes across the top below its start…
        '0' => vec![pl(&[
            (0.31, 0.13),
            (0.23, 0.23),
            (0.17, 0.33),
            (0.12, 0.44),
            (0.08, 0.56),
            (0.08, 0.68),
            (0.10, 0.78),
            (0.16, 0.85),
            (0.25, 0.88),
            (0.34, 0.86),
            (0.43, 0.82),
            (0.51, 0.76),
            (0.58, 0.68),
            (0.65, 0.58),
            (0.68, 0.49),
            (0.68, 0.41),
            (0.64, 0.34),
            (0.58, 0.29),
            (0.49, 0.26),
            (0.40, 0.24),
            (0.31, 0.24),
            (0.23, 0.25),
            (0.20, 0.22),
        ])],
        '1' => vec![pl(&[(0.3, 0.2), (0.55, 0.0), (0.55, 1.0)])],
        '2' => vec![cat(&[
            arc(0.5, 0.3, 0.35, 0.3, -160.0, 30.0),
            pl(&[(0.15, 1.0), (0.85, 1.0)]),
        ])],
        '3' => vec![cat(&[
            arc(0.5, 0.26, 0.3, 0.25, -150.0, 90.0),
            arc(0.5, 0.73, 0.35, 0.27, -90.0, 150.0),
        ])],
        // The slant and the bar, then the stem from the top, as 77 % of UNIPEN's
        // writers draw it (no writer starts up the stem).
        '4' => vec![
            pl(&[(0.55, 0.0), (0.1, 0.7), (0.9, 0.7)]),
            pl(&[(0.65, 0.0), (0.65, 1.0)]),
        ],
        '5' => vec![cat(&[
            pl(&[(0.8, 0.0), (0.25, 0.0), (0.22, 0.45)]),
            arc(0.48, 0.68, 0.33, 0.32, -135.0, 150.0),
        ])],
        // Down the left, then the bowl anticlockwise (left, bottom, right, top), as
        // every UNIPEN writer closes it.
        '6' => vec![cat(&[
            pl(&[(0.75, 0.05), (0.45, 0.15), (0.25, 0.42)]),
            arc(0.5, 0.72, 0.3, 0.27, 180.0, -180.0),
        ])],
        '7' => vec![pl(&[(0.1, 0.0), (0.9, 0.0), (0.4, 1.0)])],
        '8' => vec![cat(&[
            arc(0.5, 0.25, 0.27, 0.24, -20.0, -270.0),
            arc(0.5, 0.74, 0.32, 0.26, -90.0, 270.0),
            arc(0.5, 0.25, 0.27, 0.24, 90.0, -20.0),
        ])],
        '9' => vec![cat(&[
            arc(0.5, 0.28, 0.3, 0.27, -10.0, -370.0),
            pl(&[(0.8, 0.28), (0.75, 1.0)]),
        ])],
        'A' => vec![
            pl(&[(0.1, 1.0), (0.5, 0.0), (0.9, 1.0)]),
            pl(&[(0.27, 0.58), (0.73, 0.58)]),
        ],
        'B' => vec![cat(&[
            pl(&[(0.2, 1.0), (0.2, 0.0), (0.6, 0.0)]),
            arc(0.6, 0.24, 0.25, 0.24, -90.0, 90.0),
            pl(&[(0.2, 0.48), (0.65, 0.48)]),
            arc(0.65, 0.74, 0.27, 0.26, -90.0, 90.0),
            pl(&[(0.2, 1.0)]),
        ])],
        'C' => vec![arc(0.55, 0.5, 0.4, 0.5, -40.0, -320.0)],
        'D' => vec![cat(&[
            pl(&[(0.2, 1.0), (0.2, 0.0), (0.45, 0.0)]),
            arc(0.45, 0.5, 0.4, 0.5, -90.0, 90.0),
            pl(&[(0.2, 1.0)]),
        ])],
        'E' => vec![
            pl(&[(0.85, 0.0), (0.2, 0.0), (0.2, 1.0), (0.85, 1.0)]),
            pl(&[(0.2, 0.5), (0.7, 0.5)]),
        ],
        'F' => vec![
            pl(&[(0.85, 0.0), (0.2, 0.0), (0.2, 1.0)]),
            pl(&[(0.2, 0.5), (0.7, 0.5)]),
        ],
        'G' => vec![cat(&[
            arc(0.55, 0.5, 0.4, 0.5, -40.0, -350.0),
            pl(&[(0.93, 0.5), (0.6, 0.5)]),
        ])],
        'H' => vec![
            pl(&[(0.2, 0.0), (0.2, 1.0)]),
            pl(&[(0.8, 0.0), (0.8, 1.0)]),
            pl(&[(0.2, 0.5), (0.8, 0.5)]),
        ],
        'I' => vec![
            pl(&[(0.3, 0.0), (0.7, 0.0)]),
            pl(&[(0.5, 0.0), (0.5, 1.0)]),
            pl(&[(0.3, 1.0), (0.7, 1.0)]),
        ],
        'J' => vec![cat(&[
            pl(&[(0.75, 0.0), (0.75, 0.7)]),
            arc(0.5, 0.7, 0.25, 0.3, 0.0, 180.0),
        ])],
        'K' => vec![
            pl(&[(0.2, 0.0), (0.2, 1.0)]),
            pl(&[(0.8, 0.0), (0.2, 0.55), (0.8, 1.0)]),
        ],
        'L' => vec![pl(&[(0.2, 0.0), (0.2, 1.0), (0.8, 1.0)])],
        'M' => vec![pl(&[
            (0.1, 1.0),
            (0.15, 0.0),
            (0.5, 0.6),
            (0.85, 0.0),
            (0.9, 1.0),
        ])],
        'N' => vec![pl(&[(0.2, 1.0), (0.2, 0.0), (0.8, 1.0), (0.8, 0.0)])],
        // …an "O" starts at the top, runs left along it and closes where it began.
        'O' => vec![pl(&[
            (0.53, 0.15),
            (0.44, 0.11),
            (0.34, 0.12),
            (0.27, 0.16),
            (0.23, 0.23),
            (0.20, 0.32),
            (0.20, 0.41),
            (0.21, 0.52),
            (0.26, 0.62),
            (0.32, 0.72),
            (0.41, 0.80),
            (0.52, 0.85),
            (0.60, 0.86),
            (0.70, 0.84),
            (0.76, 0.78),
            (0.78, 0.71),
            (0.80, 0.62),
            (0.78, 0.52),
            (0.76, 0.42),
            (0.71, 0.32),
            (0.67, 0.24),
            (0.64, 0.18),
            (0.64, 0.14),
        ])],
        'P' => vec![cat(&[
            pl(&[(0.2, 1.0), (0.2, 0.0), (0.55, 0.0)]),
            arc(0.55, 0.25, 0.27, 0.25, -90.0, 90.0),
            pl(&[(0.2, 0.5)]),
        ])],
        'Q' => vec![
            arc(0.5, 0.5, 0.45, 0.5, -90.0, -450.0),
            pl(&[(0.6, 0.7), (0.95, 1.0)]),
        ],
        'R' => vec![cat(&[
            pl(&[(0.2, 1.0), (0.2, 0.0), (0.55, 0.0)]),
            arc(0.55, 0.25, 0.27, 0.25, -90.0, 90.0),
            pl(&[(0.2, 0.5), (0.4, 0.5), (0.8, 1.0)]),
        ])],
        'S' => vec![cat(&[
            arc(0.5, 0.26, 0.3, 0.24, -30.0, -270.0),
            arc(0.5, 0.74, 0.32, 0.25, -90.0, 150.0),
        ])],
        'T' => vec![pl(&[(0.1, 0.0), (0.9, 0.0)]), pl(&[(0.5, 0.0), (0.5, 1.0)])],
        'U' => vec![cat(&[
            pl(&[(0.2, 0.0), (0.2, 0.65)]),
            arc(0.5, 0.65, 0.3, 0.35, 180.0, 0.0),
            pl(&[(0.8, 0.0)]),
        ])],
        'V' => vec![pl(&[(0.1, 0.0), (0.5, 1.0), (0.9, 0.0)])],
        'W' => vec![pl(&[
            (0.05, 0.0),
            (0.27, 1.0),
            (0.5, 0.35),
            (0.73, 1.0),
            (0.95, 0.0),
        ])],
        'X' => vec![
            pl(&[(0.15, 0.0), (0.85, 1.0)]),
            pl(&[(0.85, 0.0), (0.15, 1.0)]),
        ],
        'Y' => vec![
            pl(&[(0.15, 0.0), (0.5, 0.5), (0.85, 0.0)]),
            pl(&[(0.5, 0.5), (0.5, 1.0)]),
        ],
        'Z' => vec![pl(&[(0.15, 0.0), (0.85, 0.0), (0.15, 1.0), (0.85, 1.0)])],
        _ => return None,
    };
    Some(Glyph {
        label: c.to_string(),
        strokes,
    })
}

/// Reads a trajectory JSONL file (`.jsonl`, or gzip-compressed `.jsonl.gz`): one sample a
/// line, `{"label":"7","subject":"w12","strokes":[[[x,y],…],…]}`; points may carry a
/// third value (time, ignored here). Every sample is normalized into the unit box.
pub fn read_jsonl(path: &Path) -> Result<Vec<Glyph>, SynthError> {
    let bytes = std::fs::read(path).map_err(|e| SynthError::io(path, e))?;
    let text = if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut s = String::new();
        flate2::read::MultiGzDecoder::new(&bytes[..])
            .read_to_string(&mut s)
            .map_err(|e| SynthError::parse(path, 0, format!("gzip: {e}")))?;
        s
    } else {
        String::from_utf8(bytes).map_err(|_| SynthError::parse(path, 0, "not UTF-8 text"))?
    };
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let ln = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let v: serde_json::Value =
            serde_json::from_str(line).map_err(|e| SynthError::parse(path, ln, e.to_string()))?;
        let bad = |r: &str| SynthError::parse(path, ln, r.to_string());
        let label = v
            .get("label")
            .and_then(|l| l.as_str())
            .ok_or_else(|| bad("no \"label\" string"))?
            .to_string();
        let strokes = v
            .get("strokes")
            .and_then(|s| s.as_array())
            .ok_or_else(|| bad("no \"strokes\" array"))?;
        let mut glyph = Glyph {
            label,
            strokes: Vec::new(),
        };
        for s in strokes {
            let pts = s
                .as_array()
                .ok_or_else(|| bad("a stroke is not an array of points"))?;
            let mut stroke = Vec::new();
            for p in pts {
                let xy = p
                    .as_array()
                    .filter(|a| a.len() >= 2)
                    .and_then(|a| Some((a[0].as_f64()? as f32, a[1].as_f64()? as f32)))
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .ok_or_else(|| bad("a point is not [x, y] or [x, y, t] numbers"))?;
                stroke.push(Point2::new(xy.0, xy.1));
            }
            if !stroke.is_empty() {
                glyph.strokes.push(stroke);
            }
        }
        if glyph.strokes.iter().map(|s| s.len()).sum::<usize>() < 2 {
            return Err(bad("a sample needs at least 2 points"));
        }
        out.push(glyph.normalized());
    }
    if out.is_empty() {
        return Err(SynthError::parse(path, 0, "no samples"));
    }
    Ok(out)
}
