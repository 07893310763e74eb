//! `gestures.csv`: the symbols drawn in a recording, for the tools that score what was
//! spotted against what was drawn (docs/architecture.md, "Recordings").
//!
//! ```text
//! label,start_frame,end_frame
//! 7,120,151
//! ```
//!
//! One row a drawn symbol, its frames inclusive. The reader and the writer live here
//! together so that what one writes the other reads; every error names the file and
//! the line.

use crate::recording::RecordingError;
use std::path::Path;

/// The header line of `gestures.csv`.
pub const HEADER: &str = "label,start_frame,end_frame";

/// A drawn symbol's label and its frames, inclusive.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GestureTruth {
    /// What was drawn.
    pub label: String,
    /// Its first frame.
    pub start_frame: usize,
    /// Its last frame.
    pub end_frame: usize,
}

/// Of the drawn symbols `truth`, the one a gesture reported over frames `start..=end`
/// overlaps most, if any: how a recognized gesture is matched to what was drawn.
pub fn drawn_for(truth: &[GestureTruth], start: u64, end: u64) -> Option<usize> {
    truth
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let lo = start.max(t.start_frame as u64);
            let hi = end.min(t.end_frame as u64);
            (i, hi.saturating_sub(lo))
        })
        .filter(|&(_, overlap)| overlap > 0)
        .max_by_key(|&(_, overlap)| overlap)
        .map(|(i, _)| i)
}

/// Why a label cannot be a field of the file: the format has no quoting, so a comma or
/// a line break would shift the columns of every reader.
fn unwritable(label: &str) -> Option<&'static str> {
    if label.is_empty() {
        Some("an empty label")
    } else if label.contains([',', '\n', '\r']) {
        Some("a label with a comma or a line break")
    } else {
        None
    }
}

/// Writes `gestures` to `path` whole (`file::write_whole`): a header, then one row a
/// gesture. A label the format cannot carry is refused before anything is written.
pub fn write_gestures_csv(path: &Path, gestures: &[GestureTruth]) -> Result<(), RecordingError> {
    let mut text = format!("{HEADER}\n");
    for (i, g) in gestures.iter().enumerate() {
        if let Some(what) = unwritable(&g.label) {
            return Err(RecordingError::Csv {
                path: path.to_owned(),
                // The line the row would have been written on.
                line: i + 2,
                reason: format!("{what} ({:?}) cannot be written", g.label),
            });
        }
        text.push_str(&format!("{},{},{}\n", g.label, g.start_frame, g.end_frame));
    }
    crate::file::write_whole(path, text).map_err(|source| RecordingError::Io {
        path: path.to_owned(),
        source,
    })
}

/// Reads a `gestures.csv` written by [`write_gestures_csv`]: the header, then rows of a
/// non-empty label and two frame numbers, the first not after the second.
pub fn read_gestures_csv(path: &Path) -> Result<Vec<GestureTruth>, RecordingError> {
    let text = std::fs::read_to_string(path).map_err(|source| RecordingError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse_gestures_csv(&text).map_err(|(line, reason)| RecordingError::Csv {
        path: path.to_owned(),
        line,
        reason,
    })
}

/// The rows of a `gestures.csv`'s text, or the 1-based line that is wrong and why.
fn parse_gestures_csv(text: &str) -> Result<Vec<GestureTruth>, (usize, String)> {
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    match lines.next() {
        Some((_, header)) if header.trim() == HEADER => {}
        Some((line, header)) => {
            return Err((
                line,
                format!("expected the header {HEADER:?}, found {header:?}"),
            ))
        }
        None => return Err((1, format!("empty file; expected the header {HEADER:?}"))),
    }
    let mut out = Vec::new();
    for (line, row) in lines {
        if row.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = row.split(',').collect();
        let [label, start, end] = fields[..] else {
            return Err((
                line,
                format!("expected {HEADER}, found {} fields", fields.len()),
            ));
        };
        let frame = |what: &str, v: &str| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| (line, format!("{what} {v:?} is not a frame number")))
        };
        let (start_frame, end_frame) = (frame("start_frame", start)?, frame("end_frame", end)?);
        if label.is_empty() {
            return Err((line, "empty label".into()));
        }
        if start_frame > end_frame {
            return Err((
                line,
                format!("start_frame {start_frame} is after end_frame {end_frame}"),
            ));
        }
        out.push(GestureTruth {
            label: label.to_owned(),
            start_frame,
            end_frame,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth(label: &str, start_frame: usize, end_frame: usize) -> GestureTruth {
        GestureTruth {
            label: label.into(),
            start_frame,
            end_frame,
        }
    }

    #[test]
    fn what_is_written_is_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("gestures.csv");
        let drawn = vec![
            truth("7", 120, 151),
            truth("Ω", 160, 160),
            truth("circle", 200, 260),
        ];
        write_gestures_csv(&path, &drawn).unwrap();
        assert!(std::fs::read_to_string(&path)
            .unwrap()
            .starts_with("label,start_frame,end_frame\n7,120,151\n"));
        assert_eq!(read_gestures_csv(&path).unwrap(), drawn);
        // None drawn: a header alone.
        write_gestures_csv(&path, &[]).unwrap();
        assert_eq!(read_gestures_csv(&path).unwrap(), vec![]);
    }

    #[test]
    fn a_label_the_format_cannot_carry_is_refused_and_nothing_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("gestures.csv");
        for bad in ["a,b", "two\nlines", ""] {
            let err = write_gestures_csv(&path, &[truth("7", 1, 2), truth(bad, 3, 4)]).unwrap_err();
            assert!(matches!(err, RecordingError::Csv { line: 3, .. }), "{err}");
            assert!(!path.exists(), "nothing written for {bad:?}");
        }
    }

    #[test]
    fn bad_files_are_refused_with_their_line() {
        let cases: &[(&str, usize, &str)] = &[
            ("", 1, "empty file"),
            ("index,capture_time_ns\n", 1, "expected the header"),
            ("label,start_frame,end_frame\n7,1\n", 2, "2 fields"),
            (
                "label,start_frame,end_frame\n7,1,2\n8,x,3\n",
                3,
                "not a frame number",
            ),
            (
                "label,start_frame,end_frame\n7,-1,2\n",
                2,
                "not a frame number",
            ),
            ("label,start_frame,end_frame\n7,9,2\n", 2, "after end_frame"),
            ("label,start_frame,end_frame\n,1,2\n", 2, "empty label"),
            ("label,start_frame,end_frame\n7,1,2,3\n", 2, "4 fields"),
        ];
        for (text, line, why) in cases {
            let (at, reason) = parse_gestures_csv(text).unwrap_err();
            assert_eq!(
                (at, reason.contains(why)),
                (*line, true),
                "{text:?}: {reason}"
            );
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("gestures.csv");
        std::fs::write(&path, "label,start_frame,end_frame\n7,9,2\n").unwrap();
        let err = read_gestures_csv(&path).unwrap_err().to_string();
        assert!(err.contains("gestures.csv:2:"), "{err}");
        let missing = read_gestures_csv(&dir.path().join("none.csv")).unwrap_err();
        assert!(matches!(missing, RecordingError::Io { .. }));
    }

    #[test]
    fn a_gesture_is_matched_to_the_drawn_symbol_it_overlaps_most() {
        let drawn = [truth("1", 10, 20), truth("2", 30, 50)];
        assert_eq!(drawn_for(&drawn, 15, 40), Some(1));
        assert_eq!(drawn_for(&drawn, 12, 31), Some(0));
        assert_eq!(drawn_for(&drawn, 21, 29), None);
    }
}
