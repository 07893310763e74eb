//! Trajectory JSONL datasets (docs/architecture.md, "Trajectory JSONL"): reading (plain or
//! gzip), validation, strokes joined by the hand's travel, and writer-independent splits.

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Deserialize;
use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use crate::trajectory::{Point, Trajectory};

/// One labelled gesture sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// What it is.
    pub label: String,
    /// Who drew it ("" when the data does not say); folds keep a writer's samples
    /// together.
    pub subject: String,
    /// Pen-down ink, one list of points a stroke.
    pub strokes: Vec<Vec<Point>>,
    /// For a sample drawn in 3-D, the depth of every point (z towards the camera), one
    /// list a stroke as `strokes`; None for 2-D data.
    pub depth: Option<Vec<Vec<f32>>>,
}

impl Sample {
    /// The strokes joined by the hand's travel between them, with their depth if the
    /// sample has one.
    pub fn trajectory(&self) -> Trajectory {
        let t = Trajectory::from_strokes(&self.strokes);
        match &self.depth {
            Some(d) => t.with_depth(d.concat()),
            None => t,
        }
    }

    /// Whether it was drawn in 3-D.
    pub fn has_depth(&self) -> bool {
        self.depth.is_some()
    }

    /// The same sample without its depth (as a 2-D camera would have seen it).
    pub fn flattened(&self) -> Sample {
        Sample {
            depth: None,
            ..self.clone()
        }
    }

    /// The sample as a line of trajectory JSONL (without the line's end): points
    /// `[x, y]`, or with depth `"dims":3` and points `[x, y, z]`.
    pub fn to_jsonl(&self) -> String {
        let strokes: Vec<Vec<Vec<f32>>> = match &self.depth {
            None => self
                .strokes
                .iter()
                .map(|s| s.iter().map(|p| p.to_vec()).collect())
                .collect(),
            Some(d) => self
                .strokes
                .iter()
                .zip(d)
                .map(|(s, z)| s.iter().zip(z).map(|(p, z)| vec![p[0], p[1], *z]).collect())
                .collect(),
        };
        let mut v = serde_json::json!({"label": self.label, "subject": self.subject});
        if self.depth.is_some() {
            v["dims"] = 3.into();
        }
        v["strokes"] = serde_json::json!(strokes);
        v.to_string()
    }
}

/// What can be wrong with a dataset; every variant names the file and the line.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    // The reason is the source, which error reports print after this (`{:#}`).
    /// The file could not be read.
    #[error("{path}: cannot read")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A line is not JSON of a sample's shape.
    #[error("{path}:{line}: not a trajectory JSON object: {msg}")]
    Json {
        /// The file.
        path: PathBuf,
        /// The line, from 1.
        line: usize,
        /// What the parser said.
        msg: String,
    },
    /// A sample without a label or strokes, or with a point that is not one.
    #[error("{path}:{line}: {msg}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The line, from 1.
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// A file without a sample.
    #[error("{path}: no samples")]
    Empty {
        /// The file.
        path: PathBuf,
    },
}

#[derive(Deserialize)]
struct RawSample {
    label: String,
    #[serde(default)]
    subject: Option<String>,
    /// 3 for points `[x, y, z]` or `[x, y, z, t]`; 2 (the default) for `[x, y]` or
    /// `[x, y, t]`: a third value is a time unless the sample says it is in 3-D.
    #[serde(default)]
    dims: Option<u8>,
    strokes: Vec<Vec<Vec<f64>>>,
}

/// Validates one parsed line into a sample. `line` is 1-based.
fn validate(raw: RawSample, path: &Path, line: usize) -> Result<Sample, DataError> {
    let invalid = |msg: String| DataError::Invalid {
        path: path.to_path_buf(),
        line,
        msg,
    };
    if raw.label.is_empty() {
        return Err(invalid("empty label".into()));
    }
    if raw.strokes.is_empty() {
        return Err(invalid(format!("sample {:?} has no strokes", raw.label)));
    }
    let dims = match raw.dims {
        None | Some(2) => 2,
        Some(3) => 3,
        Some(d) => {
            return Err(invalid(format!(
                "sample {:?}: \"dims\" is {d}; it is 2 (points [x, y] or [x, y, t]) or 3 ([x, y, z] or [x, y, z, t])",
                raw.label
            )))
        }
    };
    let mut strokes = Vec::with_capacity(raw.strokes.len());
    let mut depth = Vec::new();
    for (si, s) in raw.strokes.iter().enumerate() {
        if s.is_empty() {
            return Err(invalid(format!(
                "sample {:?}: stroke {si} is empty",
                raw.label
            )));
        }
        let mut pts = Vec::with_capacity(s.len());
        let mut zs = Vec::new();
        for (pi, p) in s.iter().enumerate() {
            if dims == 2 && (p.len() < 2 || p.len() > 3) {
                return Err(invalid(format!(
                    "sample {:?}: stroke {si} point {pi} has {} values, expected [x, y] or [x, y, t]",
                    raw.label,
                    p.len()
                )));
            }
            if dims == 3 && (p.len() < 3 || p.len() > 4) {
                return Err(invalid(format!(
                    "sample {:?}: stroke {si} point {pi} has {} values, expected [x, y, z] or [x, y, z, t] (\"dims\":3)",
                    raw.label,
                    p.len()
                )));
            }
            if !p.iter().all(|v| v.is_finite()) {
                return Err(invalid(format!(
                    "sample {:?}: stroke {si} point {pi} is not a finite number",
                    raw.label
                )));
            }
            // Beyond f32 a coordinate would be read as infinite: the augmentation's
            // ranges and every size computed from it would be too.
            if let Some(v) = p[..dims].iter().find(|v| v.abs() > f64::from(f32::MAX)) {
                return Err(invalid(format!(
                    "sample {:?}: stroke {si} point {pi} has the coordinate {v:e}, beyond what is read (±{:e})",
                    raw.label,
                    f32::MAX
                )));
            }
            pts.push([p[0] as f32, p[1] as f32]);
            if dims == 3 {
                zs.push(p[2] as f32);
            }
        }
        strokes.push(pts);
        depth.push(zs);
    }
    // A depth that is the same at every point is a recorder's constant (a pen's plane
    // written as [x, y, 0]), not a hand's: read as drawn in the plane. A classifier of
    // depth would learn from it only what augmentation turns into it.
    let mut zs = depth.iter().flatten();
    let flat = zs.next().is_some_and(|&z0| zs.all(|&z| z == z0));
    Ok(Sample {
        label: raw.label,
        subject: raw.subject.unwrap_or_default(),
        strokes,
        depth: (dims == 3 && !flat).then_some(depth),
    })
}

/// Parses trajectory JSONL from a reader; `path` is only used in error messages.
/// Unknown fields are ignored; blank lines are skipped.
pub fn parse_jsonl<R: BufRead>(reader: R, path: &Path) -> Result<Vec<Sample>, DataError> {
    let mut out = Vec::new();
    for (i, line) in reader.lines().enumerate() {
        let line_no = i + 1;
        let line = line.map_err(|e| DataError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        // serde_json rejects NaN literals; name them plainly.
        let raw: RawSample = serde_json::from_str(trimmed).map_err(|e| {
            let msg = if trimmed.contains("NaN") || trimmed.contains("Infinity") {
                format!("a point is not a finite number (NaN/Infinity): {e}")
            } else {
                e.to_string()
            };
            DataError::Json {
                path: path.to_path_buf(),
                line: line_no,
                msg,
            }
        })?;
        out.push(validate(raw, path, line_no)?);
    }
    Ok(out)
}

/// Reads a trajectory JSONL file, gzip-compressed or not (detected by its magic bytes).
pub fn load_jsonl(path: &Path) -> Result<Vec<Sample>, DataError> {
    let io = |e| DataError::Io {
        path: path.to_path_buf(),
        source: e,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut magic = [0u8; 2];
    let n = file.read(&mut magic).map_err(io)?;
    drop(file);
    let file = std::fs::File::open(path).map_err(io)?;
    let samples = if n == 2 && magic == [0x1f, 0x8b] {
        parse_jsonl(
            BufReader::new(flate2::read::MultiGzDecoder::new(file)),
            path,
        )?
    } else {
        parse_jsonl(BufReader::new(file), path)?
    };
    if samples.is_empty() {
        return Err(DataError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(samples)
}

/// Reads several files into one list.
pub fn load_many<P: AsRef<Path>>(paths: &[P]) -> Result<Vec<Sample>, DataError> {
    let mut all = Vec::new();
    for p in paths {
        all.extend(load_jsonl(p.as_ref())?);
    }
    Ok(all)
}

/// The sorted distinct labels of a set of samples.
pub fn labels_of(samples: &[Sample]) -> Vec<String> {
    let set: BTreeSet<&str> = samples.iter().map(|s| s.label.as_str()).collect();
    set.into_iter().map(str::to_string).collect()
}

/// Assigns each subject to one of `k` folds (shuffled with `seed`, then balanced by
/// sample count, greedily largest first); returns the fold of every sample.
pub fn folds_by_subject(samples: &[Sample], k: usize, seed: u64) -> Vec<usize> {
    let k = k.max(1);
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for s in samples {
        *counts.entry(s.subject.as_str()).or_default() += 1;
    }
    let mut subjects: Vec<(&str, usize)> = counts.into_iter().collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    subjects.shuffle(&mut rng);
    subjects.sort_by_key(|s| std::cmp::Reverse(s.1));
    let mut load = vec![0usize; k];
    let mut fold_of: BTreeMap<&str, usize> = BTreeMap::new();
    for (subj, n) in subjects {
        let f = (0..k).min_by_key(|&f| (load[f], f)).unwrap_or(0);
        load[f] += n;
        fold_of.insert(subj, f);
    }
    samples
        .iter()
        .map(|s| fold_of.get(s.subject.as_str()).copied().unwrap_or(0))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Vec<Sample>, DataError> {
        parse_jsonl(s.as_bytes(), Path::new("mem.jsonl"))
    }

    #[test]
    fn reads_and_ignores_unknown_fields() {
        let v = parse(
            "{\"label\":\"7\",\"subject\":\"w1\",\"extra\":1,\"strokes\":[[[0,0],[1,1,5]],[[2,2]]]}\n\n",
        )
        .unwrap();
        assert_eq!(v.len(), 1);
        let t = v[0].trajectory();
        assert_eq!(t.points.len(), 3);
        assert_eq!(t.pen_up, vec![false, false, true]);
    }

    #[test]
    fn a_depth_the_same_at_every_point_is_read_as_the_plane() {
        let v = parse(concat!(
            "{\"label\":\"a\",\"dims\":3,\"strokes\":[[[0,0,0],[1,1,0]],[[2,2,0]]]}\n",
            "{\"label\":\"b\",\"dims\":3,\"strokes\":[[[0,0,0.5],[1,1,0.5]],[[2,2,0.501]]]}\n",
        ))
        .unwrap();
        assert!(!v[0].has_depth());
        assert_eq!(v[0].trajectory().points.len(), 3);
        assert!(v[1].has_depth());
    }

    #[test]
    fn three_values_are_a_time_unless_the_sample_is_in_3d() {
        let v = parse(concat!(
            "{\"label\":\"a\",\"strokes\":[[[0,0,5],[1,1,9]]]}\n",
            "{\"label\":\"b\",\"dims\":3,\"strokes\":[[[0,0,5],[1,1,9,40]],[[2,2,7]]]}\n",
        ))
        .unwrap();
        assert!(!v[0].has_depth());
        assert!(v[0].trajectory().depth.is_none());
        let t = v[1].trajectory();
        assert_eq!(t.depth, Some(vec![5.0, 9.0, 7.0]));
        assert_eq!(t.pen_up, vec![false, false, true]);
        // Written and read back, the same sample.
        for s in &v {
            assert_eq!(&parse(&s.to_jsonl()).unwrap()[0], s);
        }
        assert_eq!(v[1].flattened().trajectory(), t.flattened());
        let e = parse("{\"label\":\"b\",\"dims\":3,\"strokes\":[[[0,0]]]}")
            .unwrap_err()
            .to_string();
        assert!(e.contains("mem.jsonl:1") && e.contains("[x, y, z]"), "{e}");
        let e = parse("{\"label\":\"b\",\"dims\":4,\"strokes\":[[[0,0]]]}")
            .unwrap_err()
            .to_string();
        assert!(e.contains("dims"), "{e}");
    }

    #[test]
    fn a_coordinate_beyond_single_precision_is_an_error_naming_it() {
        // It once made `train` panic in the augmentation (a range from infinity).
        for (line, value) in [
            ("{\"label\":\"1\",\"strokes\":[[[0,0],[1e300,2]]]}", "1e300"),
            (
                "{\"label\":\"1\",\"dims\":3,\"strokes\":[[[0,0,0],[1,2,-4e38]]]}",
                "-4e38",
            ),
        ] {
            let e = parse(line).unwrap_err().to_string();
            assert!(
                e.contains("mem.jsonl:1") && e.contains("point 1") && e.contains(value),
                "{e}"
            );
        }
        // A time stamp is not a coordinate, and the largest f32 still is one.
        let v =
            parse("{\"label\":\"1\",\"strokes\":[[[0,0,1.7e300],[3.4e38,2,1.8e300]]]}").unwrap();
        assert_eq!(v[0].strokes[0][1], [3.4e38, 2.0]);
    }

    #[test]
    fn empty_stroke_is_an_error_with_line() {
        let e =
            parse("{\"label\":\"1\",\"strokes\":[[[0,0]]]}\n{\"label\":\"7\",\"strokes\":[[]]}")
                .unwrap_err()
                .to_string();
        assert!(e.contains("mem.jsonl:2"), "{e}");
        assert!(e.contains("empty"), "{e}");
    }

    #[test]
    fn no_strokes_is_an_error() {
        let e = parse("{\"label\":\"7\",\"strokes\":[]}")
            .unwrap_err()
            .to_string();
        assert!(e.contains("mem.jsonl:1") && e.contains("no strokes"), "{e}");
    }

    #[test]
    fn nan_point_is_an_error() {
        let e = parse("{\"label\":\"7\",\"strokes\":[[[0,NaN]]]}")
            .unwrap_err()
            .to_string();
        assert!(e.contains("mem.jsonl:1") && e.contains("NaN"), "{e}");
    }

    #[test]
    fn folds_keep_subjects_apart() {
        let mk = |s: &str| Sample {
            label: "a".into(),
            subject: s.into(),
            strokes: vec![vec![[0.0, 0.0]]],
            depth: None,
        };
        let samples: Vec<Sample> = (0..40).map(|i| mk(&format!("w{}", i % 7))).collect();
        let f = folds_by_subject(&samples, 3, 1);
        for i in 0..samples.len() {
            for j in 0..samples.len() {
                if samples[i].subject == samples[j].subject {
                    assert_eq!(f[i], f[j]);
                }
            }
        }
        assert!((0..3).all(|k| f.contains(&k)));
    }
}
