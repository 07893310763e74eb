//! Whether a vocabulary drawn in space with many samples a label gets a template member,
//! and its share of the decision: chosen on the training data by leaving each person out.
//!
//! Networks learn what varies between people; templates match what people share. Which
//! wins depends on how alike the people draw, which the data tell and a default cannot:
//! on synthetic people who differ in depth and plane the networks alone are best, on
//! people who draw alike DTW 1-NN beats them. So each fold of people is held out in turn,
//! the ensemble's networks and a template member are built from the others, and the
//! share that reads the held-out people best is kept (ties to the smaller: templates
//! cost time at every decision).

use super::{train_networks, FewShotConfig, Labelled, TrainConfig, TrainError};
use crate::features::FeatureConfig;
use crate::lab::data::Sample;
use crate::model::{networks_posterior, TemplateShare};
use crate::templates::Templates;
use std::collections::BTreeMap;
use std::fmt;

/// Folds of people at most: more people are grouped.
pub const MAX_FOLDS: usize = 5;

impl fmt::Display for TemplateShare {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let tried: Vec<String> = self
            .correct
            .iter()
            .map(|&(s, c)| {
                let a = c as f64 / self.tested.max(1) as f64;
                format!("{:.0} % → {:.2} %", 100.0 * s, 100.0 * a)
            })
            .collect();
        write!(
            f,
            "templates' share chosen by leaving the {} people out ({} folds; share → accuracy: {}): ",
            self.people,
            self.folds,
            tried.join(", ")
        )?;
        if self.share > 0.0 {
            write!(
                f,
                "templates carry {:.0} % of the decision",
                100.0 * self.share
            )
        } else {
            write!(f, "networks only")
        }
    }
}

/// Leaves each fold of people out in turn (samples without a subject always train) and
/// keeps the share of [`FewShotConfig::shares_by_person`] that reads them best.
pub(super) fn choose(
    data: &Labelled,
    fcfg: &FeatureConfig,
    cfg: &TrainConfig,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<TemplateShare, TrainError> {
    let mut fold_of_person = BTreeMap::new();
    for s in data.samples.iter().filter(|s| !s.subject.is_empty()) {
        let next = fold_of_person.len();
        fold_of_person.entry(s.subject.as_str()).or_insert(next);
    }
    let people = fold_of_person.len();
    let folds = people.min(MAX_FOLDS);
    let fold_of = |s: &Sample| {
        (!s.subject.is_empty()).then(|| fold_of_person[s.subject.as_str()] % folds.max(1))
    };
    let shares = cfg.few_shot.shares_by_person;
    // The model's own ensemble a fold: one network reads people left out worse than
    // three, and the shares were then chosen for templates too often.
    let ensemble = cfg.ensemble.max(1);
    let mut correct = vec![0usize; shares.len()];
    let mut tested = 0usize;
    for k in 0..folds {
        let (train, test): (Vec<usize>, Vec<usize>) =
            (0..data.samples.len()).partition(|&i| fold_of(&data.samples[i]) != Some(k));
        if train.is_empty() || test.is_empty() {
            continue;
        }
        let trajs: Vec<_> = train.iter().map(|&i| data.trajs[i].clone()).collect();
        let class_of: Vec<usize> = train.iter().map(|&i| data.class_of[i]).collect();
        let done = (k * ensemble * cfg.mlp.epochs) as u64;
        let seeds = (0..ensemble).map(|e| {
            cfg.seed
                .wrapping_mul(1000)
                .wrapping_add((500 + k * ensemble + e) as u64)
        });
        let held: Vec<Sample> = train.iter().map(|&i| data.samples[i].clone()).collect();
        let others = Labelled {
            samples: &held,
            trajs: &trajs,
            class_of: &class_of,
            classes: data.classes,
        };
        let nets = train_networks(&others, 1, fcfg, cfg, seeds, &|d| progress(done + d))?;
        let member = template_member(&held, &class_of, data.classes, 1.0, &cfg.few_shot);
        for &i in &test {
            let t = &data.trajs[i];
            let by_nets = networks_posterior(&nets, fcfg, t, data.classes);
            let by_templates = member.posterior(t, data.classes);
            for (c, &w) in correct.iter_mut().zip(&shares) {
                let mixed = |j: usize| (1.0 - w as f64) * by_nets[j] + w as f64 * by_templates[j];
                let best = (0..data.classes)
                    .max_by(|&a, &b| mixed(a).total_cmp(&mixed(b)))
                    .unwrap_or(0);
                *c += usize::from(best == data.class_of[i]);
            }
            tested += 1;
        }
    }
    let correct: Vec<(f32, usize)> = shares.into_iter().zip(correct).collect();
    Ok(TemplateShare {
        share: best_share(&correct),
        people,
        folds,
        tested,
        correct,
    })
}

/// The share that read the most right, the smaller of equals.
fn best_share(correct: &[(f32, usize)]) -> f32 {
    correct
        .iter()
        .copied()
        .min_by(|a, b| b.1.cmp(&a.1).then(a.0.total_cmp(&b.0)))
        .map_or(0.0, |(w, _)| w)
}

/// A template member matching in space, of at most [`FewShotConfig::templates_by_person`]
/// samples a label, carrying `share` of the decision.
pub(super) fn template_member(
    samples: &[Sample],
    class_of: &[usize],
    classes: usize,
    share: f32,
    cfg: &FewShotConfig,
) -> Templates {
    let cfg = FewShotConfig {
        templates_per_label: cfg.templates_by_person,
        weight_in_space: share,
        ..*cfg
    };
    super::few_shot::template_member(samples, class_of, classes, true, &cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_best_share_wins_and_the_smaller_of_equals() {
        assert_eq!(best_share(&[(0.0, 90), (0.5, 95), (0.85, 93)]), 0.5);
        assert_eq!(best_share(&[(0.0, 95), (0.5, 95), (0.85, 96)]), 0.85);
        assert_eq!(best_share(&[(0.85, 95), (0.0, 95), (0.5, 95)]), 0.0);
        assert_eq!(best_share(&[]), 0.0);
    }
}
