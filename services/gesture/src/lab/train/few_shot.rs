//! Vocabularies trained from a few samples a label: whether the network ensemble gets a
//! template member, which samples become its templates, and how many augmented copies of
//! each sample the networks see an epoch.
//!
//! From a few samples a label a network sees too little of each label's variation and
//! too few steps of training, while a template matcher is at its best: each sample is
//! a template. So a vocabulary whose smallest label has at most
//! [`FewShotConfig::max_samples`] samples gets both: templates mixed into the ensemble's
//! posterior, and networks trained on as many augmented copies as make an epoch of
//! [`FewShotConfig::min_epoch_samples`]. Larger vocabularies train exactly as before, with
//! no member they would pay for at every decision.

use crate::lab::data::Sample;
use crate::templates::{Template, Templates};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt;

/// How training treats labels with few samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FewShotConfig {
    /// A vocabulary whose smallest label has at most this many samples is few-shot.
    pub max_samples: usize,
    /// Templates kept of each label (spread evenly over its samples).
    pub templates_per_label: usize,
    /// Points every path is resampled to for matching.
    pub points: usize,
    /// DTW band half-width, in points.
    pub band: usize,
    /// Weight of direction against position in the matching cost.
    pub direction_weight: f32,
    /// Softness of the template member's posterior.
    pub temperature: f32,
    /// The template member's share of the ensemble's posterior.
    pub weight: f32,
    /// [`FewShotConfig::direction_weight`] for trajectories with depth, matched in
    /// space: a depth camera measures depth several times less precisely than across,
    /// and a direction taken over one resampled step carries that noise whole.
    pub direction_weight_in_space: f32,
    /// [`FewShotConfig::weight`] for trajectories with depth.
    pub weight_in_space: f32,
    /// Augmented samples each network sees an epoch at least (copies of every sample).
    pub min_epoch_samples: usize,
    /// A vocabulary with depth and more samples a label than `max_samples`, drawn by
    /// three people or more: the template member's shares tried by leaving each person
    /// out (`share.rs`); the best is kept, 0 meaning networks only. All 0: not tried.
    pub shares_by_person: [f32; 3],
    /// Templates kept of each label when a share was chosen so.
    pub templates_by_person: usize,
}

// Chosen on the user-dependent protocol's tune writers (`eval-gestures --per-writer 3,9
// --writers tune --few-shot …`), never on the writers reported; the NOTES say what each
// alternative gave.
impl Default for FewShotConfig {
    fn default() -> Self {
        Self {
            max_samples: 10,
            templates_per_label: 10,
            points: 32,
            band: 4,
            direction_weight: 0.5,
            temperature: 0.05,
            weight: 0.7,
            direction_weight_in_space: 0.0,
            weight_in_space: 0.85,
            min_epoch_samples: 1024,
            shares_by_person: [0.0, 0.5, 0.85],
            templates_by_person: 50,
        }
    }
}

impl FewShotConfig {
    /// Every setting within bounds; `airglyph train` and `eval-gestures` name it so.
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::{finite_within, within, MAX_FEATURE_POINTS, MAX_TEMPLATES};
        within("few_shot.max_samples", self.max_samples, 0, 1 << 20)?;
        within(
            "few_shot.templates_per_label",
            self.templates_per_label,
            1,
            MAX_TEMPLATES,
        )?;
        within("few_shot.points", self.points, 2, MAX_FEATURE_POINTS)?;
        within("few_shot.band", self.band, 0, MAX_FEATURE_POINTS)?;
        finite_within(
            "few_shot.direction_weight",
            self.direction_weight as f64,
            0.0,
            100.0,
        )?;
        finite_within("few_shot.temperature", self.temperature as f64, 1e-6, 1e6)?;
        finite_within("few_shot.weight", self.weight as f64, 0.0, 1.0)?;
        finite_within(
            "few_shot.direction_weight_in_space",
            self.direction_weight_in_space as f64,
            0.0,
            100.0,
        )?;
        finite_within(
            "few_shot.weight_in_space",
            self.weight_in_space as f64,
            0.0,
            1.0,
        )?;
        within(
            "few_shot.min_epoch_samples",
            self.min_epoch_samples,
            0,
            1 << 24,
        )?;
        for (i, w) in self.shares_by_person.iter().enumerate() {
            finite_within(
                &format!("few_shot.shares_by_person[{i}]"),
                *w as f64,
                0.0,
                1.0,
            )?;
        }
        within(
            "few_shot.templates_by_person",
            self.templates_by_person,
            1,
            MAX_TEMPLATES,
        )?;
        Ok(())
    }
}

impl FewShotConfig {
    /// These settings with the fields of the JSON object `over` replaced (a command
    /// line's `--few-shot '{"weight":0.7}'`); an unknown field or a value out of bounds
    /// is an error naming it.
    pub fn overridden(&self, over: &str) -> Result<Self, String> {
        let mut v = serde_json::to_value(self).map_err(|e| e.to_string())?;
        let o: serde_json::Value =
            serde_json::from_str(over).map_err(|e| format!("not a JSON object: {e}"))?;
        let (Some(fields), Some(obj)) = (v.as_object_mut(), o.as_object()) else {
            return Err("not a JSON object".into());
        };
        for (k, x) in obj {
            if !fields.contains_key(k) {
                return Err(format!(
                    "unknown field {k:?} (fields: {})",
                    fields.keys().cloned().collect::<Vec<_>>().join(", ")
                ));
            }
            fields.insert(k.clone(), x.clone());
        }
        let cfg: Self = serde_json::from_value(v).map_err(|e| e.to_string())?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// The member's direction weight and share, matching in space or in the plane.
    fn member(&self, depth: bool) -> (f32, f32) {
        if depth {
            (self.direction_weight_in_space, self.weight_in_space)
        } else {
            (self.direction_weight, self.weight)
        }
    }
}

/// What training does for a vocabulary, and why: `airglyph train` prints it.
#[derive(Debug, Clone, PartialEq)]
pub enum FewShotPlan {
    /// Every label has more samples than the bar: networks only.
    NetworksOnly {
        /// The label with the fewest samples…
        fewest: String,
        /// …its count…
        samples: usize,
        /// …and the bar it is above.
        max_samples: usize,
    },
    /// Every label above the bar, in space, three people or more: networks, and a
    /// template member if leaving each person out says so (`share.rs`).
    ByPerson {
        /// The label with the fewest samples…
        fewest: String,
        /// …its count…
        samples: usize,
        /// …and the bar it is above.
        max_samples: usize,
        /// People who drew the samples.
        people: usize,
    },
    /// A label at or under the bar: a template member, and networks trained on copies.
    WithTemplates {
        /// The label with the fewest samples…
        fewest: String,
        /// …its count…
        samples: usize,
        /// …and the bar.
        max_samples: usize,
        /// Templates of the member.
        templates: usize,
        /// Whether they are matched in space (the samples have depth).
        depth: bool,
        /// Its share of the posterior.
        weight: f32,
        /// Augmented copies of each sample a network sees an epoch.
        copies: usize,
    },
}

impl FewShotPlan {
    /// The plan for samples of these labels (every label has a sample).
    pub fn new(samples: &[Sample], labels: &[String], cfg: &FewShotConfig) -> Self {
        let mut count: BTreeMap<&str, usize> = labels.iter().map(|l| (l.as_str(), 0)).collect();
        for s in samples {
            if let Some(c) = count.get_mut(s.label.as_str()) {
                *c += 1;
            }
        }
        let (fewest, n) = count
            .iter()
            .min_by_key(|(l, c)| (**c, **l))
            .map_or((String::new(), 0), |(l, c)| (l.to_string(), *c));
        let depth = samples.iter().any(Sample::has_depth);
        let people = people(samples);
        if n > cfg.max_samples
            && depth
            && people >= 3
            && cfg.shares_by_person.iter().any(|&w| w > 0.0)
        {
            return FewShotPlan::ByPerson {
                fewest,
                samples: n,
                max_samples: cfg.max_samples,
                people,
            };
        }
        if n > cfg.max_samples {
            return FewShotPlan::NetworksOnly {
                fewest,
                samples: n,
                max_samples: cfg.max_samples,
            };
        }
        let templates = count
            .values()
            .map(|&c| c.min(cfg.templates_per_label))
            .sum();
        FewShotPlan::WithTemplates {
            fewest,
            samples: n,
            max_samples: cfg.max_samples,
            templates,
            depth,
            weight: cfg.member(depth).1,
            copies: cfg.min_epoch_samples.div_ceil(samples.len().max(1)).max(1),
        }
    }

    /// Copies of each sample a network sees an epoch.
    pub fn copies(&self) -> usize {
        match self {
            FewShotPlan::NetworksOnly { .. } | FewShotPlan::ByPerson { .. } => 1,
            FewShotPlan::WithTemplates { copies, .. } => *copies,
        }
    }
}

impl fmt::Display for FewShotPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FewShotPlan::NetworksOnly {
                fewest,
                samples,
                max_samples,
            } => write!(
                f,
                "networks only: every label has more than {max_samples} samples (the fewest, {fewest:?}, {samples}), \
                 enough for the networks; a template member would cost time at every decision for nothing"
            ),
            FewShotPlan::ByPerson {
                fewest,
                samples,
                max_samples,
                people,
            } => write!(
                f,
                "networks, and templates if they read people left out better: every label has more than \
                 {max_samples} samples (the fewest, {fewest:?}, {samples}), and {people} people drew them in \
                 space; whether DTW in space beats networks there depends on how alike they draw, so each \
                 person is left out in turn to choose"
            ),
            FewShotPlan::WithTemplates {
                fewest,
                samples,
                max_samples,
                templates,
                depth,
                weight,
                copies,
            } => write!(
                f,
                "networks and templates: label {fewest:?} has {samples} samples (at most {max_samples}), too few for \
                 networks alone; {templates} templates matched by DTW {} carry {:.0} % of the decision, and the \
                 networks see {copies} augmented copies of every sample an epoch",
                if *depth { "in space" } else { "in the plane" },
                100.0 * weight
            ),
        }
    }
}

/// People (non-empty subject names) in `samples`.
fn people(samples: &[Sample]) -> usize {
    let mut names: Vec<&str> = samples
        .iter()
        .map(|s| s.subject.as_str())
        .filter(|s| !s.is_empty())
        .collect();
    names.sort_unstable();
    names.dedup();
    names.len()
}

/// The template member for these samples (`class_of[i]` the class of sample `i`):
/// of each class at most [`FewShotConfig::templates_per_label`] samples, spread evenly
/// over its samples in their order; matching in space when `depth` (the classifier
/// reads depth).
pub fn template_member(
    samples: &[Sample],
    class_of: &[usize],
    classes: usize,
    depth: bool,
    cfg: &FewShotConfig,
) -> Templates {
    let mut by_class: Vec<Vec<usize>> = vec![Vec::new(); classes];
    for (i, &c) in class_of.iter().enumerate() {
        if let Some(v) = by_class.get_mut(c) {
            v.push(i);
        }
    }
    let mut templates = Vec::new();
    for (class, idx) in by_class.iter().enumerate() {
        let keep = idx.len().min(cfg.templates_per_label);
        for k in 0..keep {
            let i = idx[k * idx.len() / keep];
            let t = samples[i].trajectory();
            templates.push(Template::of(class, cfg.points, depth, &t));
        }
    }
    let (direction_weight, weight) = cfg.member(depth);
    Templates {
        points: cfg.points,
        depth,
        band: cfg.band,
        direction_weight,
        temperature: cfg.temperature,
        weight,
        templates,
        cache: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_overridden_field_by_field_and_checked() {
        let d = FewShotConfig::default();
        let o = d
            .overridden(r#"{"shares_by_person":[0,0,0],"weight":0.6}"#)
            .unwrap();
        assert_eq!(o.shares_by_person, [0.0; 3]);
        assert_eq!(o.weight, 0.6);
        assert_eq!(o.templates_by_person, d.templates_by_person);
        for (bad, says) in [
            (r#"{"wieght":0.6}"#, "unknown field \"wieght\""),
            (r#"{"shares_by_person":[0,2,0]}"#, "shares_by_person[1]"),
            ("[1]", "not a JSON object"),
            (r#"{"weight":"x"}"#, "invalid type"),
        ] {
            let e = d.overridden(bad).unwrap_err();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn people_are_named_subjects() {
        let s = |subject: &str| Sample {
            label: "a".into(),
            subject: subject.into(),
            strokes: vec![vec![[0.0, 0.0], [1.0, 1.0]]],
            depth: None,
        };
        assert_eq!(people(&[s("p1"), s("p2"), s("p1"), s("")]), 2);
    }
}
