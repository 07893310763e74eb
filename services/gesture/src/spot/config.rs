//! The spotter's run-time settings, and how overlapping candidates are ranked.

use super::pen::Pen;
use crate::tracker::TrackerConfig;
use serde::{Deserialize, Serialize};

/// What overlapping accepted candidates are ranked by: the classifier's confidence
/// times the verifier's probability of…
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RankBy {
    /// …a whole gesture of any label (what acceptance tests).
    Gesture,
    /// …a whole gesture of the classifier's label: a stretch the verifier takes for a
    /// whole gesture, but less surely for the one the classifier names, ranks lower
    /// (an approach and a "1" that the classifier calls a "7"). The held-out digits
    /// lose fewer competitions (gesture README, "Spotting").
    #[default]
    Label,
}

impl RankBy {
    /// The log of the evidence that ranks a candidate among overlapping ones.
    pub fn rank(self, p_gesture: f64, p_label: f64, score: f64) -> f64 {
        let verifier = match self {
            RankBy::Gesture => p_gesture,
            RankBy::Label => p_label,
        };
        verifier.max(1e-9).ln() + score.max(1e-9).ln()
    }
}

/// Run-time settings of the spotter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SpotterConfig {
    /// Expected size of a drawn gesture (its larger side) in shoulder widths.
    pub gesture_size: f32,
    /// A break is a local minimum of the hand's speed over this many frames each side…
    pub min_window: usize,
    /// …below this fraction of the fastest speed of the last `peak_seconds`.
    pub break_ratio: f32,
    /// See `break_ratio`.
    pub peak_seconds: f64,
    /// Below this speed (gesture sizes a second) the hand is at rest.
    pub rest_speed: f32,
    /// Shortest and longest gesture, seconds.
    pub min_seconds: f64,
    /// See `min_seconds`.
    pub max_seconds: f64,
    /// Smallest and largest gesture (larger side), in gesture sizes.
    pub min_size: f32,
    /// See `min_size`.
    pub max_size: f32,
    /// Lee & Kim as a hard test: the best gesture HMM must beat the threshold model
    /// by this log-likelihood margin per code (None: the ratio is only evidence for
    /// the verifier).
    pub margin: Option<f64>,
    /// [`SpotterConfig::margin`] for a model without a verifier whose gesture HMMs read
    /// codes on the sphere (trained on 3-D gestures): nothing else tells a reach from a
    /// gesture there, and the classifier names any movement confidently. A model whose
    /// HMMs read the circle's codes is not tested (a push is a standing hand there).
    /// `margin`, when set, takes its place.
    pub margin_without_verifier: Option<f64>,
    /// Smallest classifier confidence to publish a gesture.
    pub min_score: f64,
    /// Smallest verifier probability that the segment is a whole gesture (None: the
    /// verifier's own, [`crate::model::Verifier::min_gesture_prob`]).
    pub min_gesture_prob: Option<f64>,
    /// Whether the labels the model's calibration found ordinary movement passing for
    /// must reach their higher bars ([`crate::model::Verifier::label_bars`]).
    pub label_bars: bool,
    /// How long after a candidate's end to wait for a longer, better one (seconds);
    /// a rest of `rest_seconds` after it decides at once.
    pub hold_seconds: f64,
    /// See `hold_seconds`.
    pub rest_seconds: f64,
    /// What overlapping candidates are ranked by.
    pub rank_by: RankBy,
    /// How the drawing hand is followed.
    pub tracker: TrackerConfig,
    /// For a model of 3-D gestures without a verifier (its streams are drawn in the
    /// plane; `SpottingModel::train`): a stretch is a gesture only if the hand stays
    /// this far in front of the shoulders all along it (shoulder widths), as one draws
    /// in the air; reaches from and back to a rest are not. Unused otherwise.
    pub min_forward: f32,
    /// For a model without a verifier, which cannot tell a whole gesture from a part of
    /// one: a stretch that holds the pending gesture whole takes its place when its
    /// evidence is at least this fraction of the best stretch ending with it (the
    /// classifier's confidence). A zigzag towards the camera is cut at its corner into a
    /// swipe and a push, each surer than the whole; the whole is what was drawn (None:
    /// the surer part wins). Unused with a verifier.
    pub whole_over_part: Option<f64>,
    /// For a model of symbols drawn in the plane: a stretch along which the hand moves
    /// further in depth (towards or away from the camera) than this many times its
    /// larger side across is not one: a symbol is drawn facing the camera, a reach from
    /// a hanging arm or a hand to the face is not (None: depth is not looked at).
    pub max_depth_ratio: Option<f32>,
    /// What puts the pen down: the motion (every setting above) or a posture of the
    /// drawing hand ([`Pen::Posture`]; `min_seconds`, `max_seconds`, `min_size`,
    /// `max_size`, `max_depth_ratio` and `min_score` still reject its spans).
    pub pen: Pen,
}

impl Default for SpotterConfig {
    fn default() -> Self {
        Self {
            gesture_size: 1.0,
            min_window: 3,
            break_ratio: 0.6,
            peak_seconds: 0.5,
            rest_speed: 0.15,
            min_seconds: 0.3,
            // Not 4 s: slow drawers take longer over a symbol; the verifier is trained
            // on candidates up to this length (`Verifier::train`), so the two go together.
            max_seconds: 6.0,
            min_size: 0.3,
            max_size: 2.5,
            margin: None,
            // Chosen on standing and seated recordings of the 3-D vocabulary (NOTES,
            // 2026-12-07): −1 loses no standing symbol and finds seated ones that the
            // reach from the table hid; 0 loses standing ones.
            margin_without_verifier: Some(-1.0),
            min_score: 0.5,
            min_gesture_prob: None,
            label_bars: true,
            // Not 1.5 s: a better candidate overlapping the pending one may end more than
            // 1.5 s after it (fewer substitutions and insertions); 3 s is no better
            // (NOTES.md, the hold).
            hold_seconds: 2.5,
            rest_seconds: 0.4,
            rank_by: RankBy::default(),
            tracker: TrackerConfig::default(),
            // Not 0.7, chosen on the exact skeleton: the pose stage puts the shoulders
            // on the body's front and the hand nearer the wrist, 0.1 shoulder widths
            // less forward in the median, and lost 3-D gestures whose ends dip below
            // 0.7 (NOTES, 2026-12-07).
            min_forward: 0.5,
            whole_over_part: Some(0.95),
            // tan 35°: a symbol drawn on a plane turned as far from facing the camera as
            // the 3-D synthetic people turn theirs (`airglyph_synth::air3d`) still passes.
            max_depth_ratio: Some(0.7),
            pen: Pen::Motion,
        }
    }
}

/// Why spotter settings given as JSON were refused.
#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    /// The text is not JSON.
    #[error("{json:?} is not JSON")]
    NotJson {
        /// The text given.
        json: String,
        /// What the parser said.
        #[source]
        source: serde_json::Error,
    },
    /// The JSON is not an object of settings.
    #[error("{json:?} is not a JSON object of settings")]
    NotAnObject {
        /// The text given.
        json: String,
    },
    /// A setting the spotter does not have: refused rather than ignored, so that a
    /// misspelt setting does not silently leave its default in place.
    #[error("unknown setting {0:?}")]
    Unknown(String),
    /// A setting of the wrong kind (text for a number, …).
    #[error("a setting has the wrong type")]
    Value(#[source] serde_json::Error),
}

impl SpotterConfig {
    /// The default settings with the fields of `overrides`, a JSON object, replaced
    /// (`{"min_score":0.6}`; `tracker` is replaced whole), or the defaults when there
    /// are none: how the commands take spotter settings on their command line.
    pub fn with_overrides(overrides: Option<&str>) -> Result<SpotterConfig, SettingsError> {
        let mut v = serde_json::to_value(SpotterConfig::default()).map_err(SettingsError::Value)?;
        if let Some(json) = overrides {
            let given: serde_json::Value =
                serde_json::from_str(json).map_err(|source| SettingsError::NotJson {
                    json: json.to_owned(),
                    source,
                })?;
            let (Some(settings), Some(given)) = (v.as_object_mut(), given.as_object()) else {
                return Err(SettingsError::NotAnObject {
                    json: json.to_owned(),
                });
            };
            for (k, x) in given {
                if !settings.contains_key(k) {
                    return Err(SettingsError::Unknown(k.clone()));
                }
                settings.insert(k.clone(), x.clone());
            }
        }
        serde_json::from_value(v).map_err(SettingsError::Value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranking_by_label_prefers_the_stretch_the_verifier_names_as_the_classifier_does() {
        // Both whole gestures to the verifier, equally sure to the classifier; the first
        // the verifier reads as the classifier's label, the second mostly as another.
        let (named, other) = ((0.9, 0.88, 0.99), (0.95, 0.6, 0.99));
        let rank = |by: RankBy, (g, l, s): (f64, f64, f64)| by.rank(g, l, s);
        assert!(rank(RankBy::Gesture, other) > rank(RankBy::Gesture, named));
        assert!(rank(RankBy::Label, named) > rank(RankBy::Label, other));
        // Nothing is -inf.
        assert!(RankBy::Label.rank(1.0, 0.0, 0.0).is_finite());
    }

    #[test]
    fn settings_without_the_ranking_field_still_load() {
        let mut v = serde_json::to_value(SpotterConfig::default()).unwrap();
        v.as_object_mut().unwrap().remove("rank_by");
        let cfg: SpotterConfig = serde_json::from_value(v).unwrap();
        assert_eq!(cfg.rank_by, RankBy::Label);
    }

    #[test]
    fn overrides_replace_the_fields_they_name_and_refuse_the_others() {
        let cfg =
            SpotterConfig::with_overrides(Some(r#"{"min_score":0.6,"hold_seconds":1}"#)).unwrap();
        assert_eq!(
            cfg,
            SpotterConfig {
                min_score: 0.6,
                hold_seconds: 1.0,
                ..SpotterConfig::default()
            }
        );
        assert_eq!(
            SpotterConfig::with_overrides(None).unwrap(),
            SpotterConfig::default()
        );
        let refused = |json: &str| {
            SpotterConfig::with_overrides(Some(json))
                .unwrap_err()
                .to_string()
        };
        assert_eq!(refused(r#"{"nope":1}"#), r#"unknown setting "nope""#);
        assert!(refused("[1]").contains("not a JSON object"));
        assert!(refused("x").contains("not JSON"));
        assert!(refused(r#"{"min_score":"high"}"#).contains("wrong type"));
    }
}
