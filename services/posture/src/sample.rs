//! Posture sample JSONL: one labelled hand a line, as `airglyph collect --posture`
//! writes it and `airglyph train --postures` reads it. The features are stored, not
//! the depth image: a line is about a kilobyte, and a sample of other features (another
//! [`FEATURE_VERSION`]) is refused rather than compared.

use crate::features::{Features, FEATURE_LEN, FEATURE_VERSION};
use crate::model::check_label;
use crate::segment::Side;
use serde::{Deserialize, Serialize};

/// One line of posture sample JSONL.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PostureSample {
    /// The posture's name.
    pub label: String,
    /// Whose hand: cross-validation keeps each subject's samples together.
    pub subject: String,
    /// `"left"` or `"right"`: the person's hand.
    pub hand: String,
    /// How far the hand was from the camera, metres (the palm's centre).
    pub depth_m: f32,
    /// The [`FEATURE_VERSION`] the features were computed by.
    pub feature_version: u32,
    /// The hand's features, in the order of [`crate::feature_names`].
    pub features: Vec<f32>,
}

impl PostureSample {
    /// A sample of `features` of the hand on `side`.
    pub fn new(label: &str, subject: &str, side: Side, depth_m: f32, features: &Features) -> Self {
        Self {
            label: label.into(),
            subject: subject.into(),
            hand: side_name(side).into(),
            depth_m,
            feature_version: FEATURE_VERSION,
            features: features.values().to_vec(),
        }
    }

    /// The line (without its newline). The depth is rounded to the millimetre.
    pub fn to_line(&self) -> String {
        let mut s = self.clone();
        s.depth_m = (s.depth_m * 1000.0).round() / 1000.0;
        // Strings and finite numbers only: this cannot fail.
        serde_json::to_string(&s).unwrap_or_default()
    }

    /// Parses and checks one line; the error says what is wrong (the caller adds
    /// where).
    pub fn parse_line(line: &str) -> Result<(PostureSample, Features), String> {
        let s: PostureSample =
            serde_json::from_str(line).map_err(|e| format!("not a posture sample: {e}"))?;
        check_label(&s.label)?;
        if s.subject.is_empty() {
            return Err("the subject is empty".into());
        }
        if s.hand != "left" && s.hand != "right" {
            return Err(format!("hand {:?}: expected \"left\" or \"right\"", s.hand));
        }
        if !(s.depth_m.is_finite() && s.depth_m > 0.0) {
            return Err(format!("depth_m {} is not a distance", s.depth_m));
        }
        if s.feature_version != FEATURE_VERSION {
            return Err(format!(
                "feature_version {} (this build computes version {FEATURE_VERSION}; collect the samples again)",
                s.feature_version
            ));
        }
        if s.features.len() != FEATURE_LEN {
            return Err(format!(
                "{} features, expected {FEATURE_LEN}",
                s.features.len()
            ));
        }
        let f = Features::from_slice(&s.features).ok_or("a feature is not a finite number")?;
        Ok((s, f))
    }
}

/// How a side is written in a sample: `"left"`, `"right"`.
pub fn side_name(side: Side) -> &'static str {
    match side {
        Side::Left => "left",
        Side::Right => "right",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line() -> serde_json::Value {
        let f = Features::from_slice(&[0.5; FEATURE_LEN]).unwrap();
        let s = PostureSample::new("point", "me", Side::Left, 1.23456, &f);
        serde_json::from_str(&s.to_line()).unwrap()
    }

    #[test]
    fn a_line_reads_back_as_written() {
        let v = line();
        assert_eq!(v["depth_m"], 1.235);
        assert_eq!(v["hand"], "left");
        let (s, f) = PostureSample::parse_line(&v.to_string()).unwrap();
        assert_eq!(s.label, "point");
        assert_eq!(f.values(), &[0.5; FEATURE_LEN]);
    }

    #[test]
    fn bad_lines_say_what_is_wrong() {
        let cases: [(&str, serde_json::Value, &str); 7] = [
            ("label", "".into(), "a label is empty"),
            ("label", "a-label-of-17-byt".into(), "17 bytes long"),
            ("hand", "both".into(), "hand \"both\""),
            ("depth_m", (-1.0).into(), "depth_m -1 is not a distance"),
            ("feature_version", 9.into(), "feature_version 9"),
            (
                "features",
                serde_json::json!([1.0, 2.0]),
                "2 features, expected",
            ),
            ("subject", "".into(), "the subject is empty"),
        ];
        for (key, value, says) in cases {
            let mut v = line();
            v[key] = value;
            let e = PostureSample::parse_line(&v.to_string()).unwrap_err();
            assert!(e.contains(says), "{key}: {e}");
        }
        let mut v = line();
        v["features"][3] = serde_json::json!(1e39);
        let e = PostureSample::parse_line(&v.to_string()).unwrap_err();
        assert!(e.contains("not a finite number"), "{e}");
        let e = PostureSample::parse_line("{\"label\": \"x\"").unwrap_err();
        assert!(e.starts_with("not a posture sample"), "{e}");
    }
}
