//! `airglyph train --postures FILE… --out MODEL`: a posture model from posture sample
//! JSONL (`airglyph collect --posture`). The classifier (k-NN or softmax) and its
//! setting are chosen by cross-validation grouped by subject, the pairs of postures it
//! confuses are named, and the model is written as posture model JSON.

use airglyph_posture::model::check_labels;
use airglyph_posture::{
    choose, cross_validate, cross_validated_confusion, Classifier, Method, PostureModel,
    PostureSample, SegmentParams, TrainingSet,
};
use anyhow::{bail, Context};
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// The settings cross-validation chooses among.
fn candidates() -> Vec<Method> {
    [1, 3, 5, 9]
        .map(|k| Method::Knn { k })
        .into_iter()
        .chain([1e-4, 1e-3, 1e-2, 1e-1].map(|l2| Method::Softmax { l2 }))
        .collect()
}

/// The samples of every file, labels numbered as they first appear and subjects as
/// cross-validation's groups.
struct Samples {
    set: TrainingSet,
    subjects: Vec<String>,
}

fn read(files: &[PathBuf]) -> anyhow::Result<Samples> {
    let mut lines = Vec::new();
    let (mut labels, mut subjects): (Vec<String>, Vec<String>) = (Vec::new(), Vec::new());
    for path in files {
        let file = std::fs::File::open(path)
            .with_context(|| format!("{}: cannot read posture samples", path.display()))?;
        for (i, line) in std::io::BufReader::new(file).lines().enumerate() {
            let at = || format!("{}:{}", path.display(), i + 1);
            let line = line.with_context(at)?;
            if line.trim().is_empty() {
                continue;
            }
            let (s, features) =
                PostureSample::parse_line(&line).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
            let label = index_of(&mut labels, &s.label);
            let group = index_of(&mut subjects, &s.subject);
            lines.push((features, label, group as u32));
        }
    }
    if lines.is_empty() {
        bail!("no posture samples in {}", list(files));
    }
    check_labels(&labels).map_err(|e| {
        anyhow::anyhow!("{}: {e} (labels found: {})", list(files), labels.join(", "))
    })?;
    let mut set = TrainingSet::new(labels);
    for (f, label, group) in &lines {
        set.add(f, *label, *group)?;
    }
    Ok(Samples { set, subjects })
}

/// The position of `name` in `names`, added at the end when new.
fn index_of(names: &mut Vec<String>, name: &str) -> usize {
    names.iter().position(|n| n == name).unwrap_or_else(|| {
        names.push(name.to_string());
        names.len() - 1
    })
}

fn list(files: &[PathBuf]) -> String {
    files
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Pairs of labels where held-out samples of the first were read as the second at
/// least `threshold` of the time: (truth, read as, share, count).
pub fn confused_pairs(
    labels: &[String],
    confusion: &[Vec<usize>],
    threshold: f64,
) -> Vec<(String, String, f64, usize)> {
    let mut out = Vec::new();
    for (t, row) in confusion.iter().enumerate() {
        let total: usize = row.iter().sum();
        for (p, &n) in row.iter().enumerate() {
            let share = n as f64 / total.max(1) as f64;
            if p != t && n > 0 && share >= threshold {
                out.push((labels[t].clone(), labels[p].clone(), share, n));
            }
        }
    }
    out
}

pub fn run(files: &[PathBuf], out: &Path, confusable: f64) -> anyhow::Result<()> {
    let Samples { set, subjects } = read(files)?;
    let by = if subjects.len() >= 2 {
        format!("leave one subject out ({} subjects)", subjects.len())
    } else {
        // Five folds by sample: neighbouring frames of one session are near copies, so
        // this says little about a new person.
        "five folds by sample (one subject only: the accuracy is optimistic; collect with --subject for each person)".to_string()
    };
    eprintln!(
        "{} samples of {} postures ({}) from {}; cross-validation: {by}",
        set.len(),
        set.labels().len(),
        set.labels().join(", "),
        list(files)
    );
    let candidates = candidates();
    let mut accuracies = serde_json::Map::new();
    for &m in &candidates {
        match cross_validate(&set, m) {
            Some(a) => {
                eprintln!("  {:<22} {:5.1} %", m.to_string(), 100.0 * a);
                accuracies.insert(
                    m.to_string(),
                    serde_json::json!((a as f64 * 1e4).round() / 1e4),
                );
            }
            None => eprintln!(
                "  {:<22} not measured (a fold had too few labels)",
                m.to_string()
            ),
        }
    }
    let (method, accuracy) = choose(&set, &candidates).context(
        "no fold could be trained: every subject needs samples of two postures at least",
    )?;
    eprintln!(
        "chose {method}: the best cross-validated accuracy, {:.1} %",
        100.0 * accuracy
    );
    if let Some(confusion) = cross_validated_confusion(&set, method) {
        let pairs = confused_pairs(set.labels(), &confusion, confusable);
        if pairs.is_empty() {
            eprintln!(
                "no posture read as another {:.0} % of the time or more",
                100.0 * confusable
            );
        }
        for (t, p, share, n) in pairs {
            eprintln!(
                "warning: {:.0} % of {t:?} ({n}) read as {p:?} in cross-validation: the two are hard to tell apart",
                100.0 * share
            );
        }
    }
    let classifier = Classifier::train(&set, method)?;
    let training = serde_json::json!({
        "data": files.iter().map(|p| p.file_name().map_or(p.display().to_string(), |f| f.to_string_lossy().into_owned())).collect::<Vec<_>>(),
        "samples": set.len(),
        "subjects": subjects,
        "cross_validation": by,
        "chosen": method.to_string(),
        "accuracy": accuracies,
    });
    // The samples were cut as `collect --posture` cuts hands: with the default settings.
    let model = PostureModel::new(classifier, SegmentParams::default(), training);
    model
        .save(out)
        .with_context(|| format!("{}: cannot write posture model", out.display()))?;
    eprintln!(
        "wrote {} ({} postures, {method}, {} bytes)",
        out.display(),
        model.labels().len(),
        std::fs::metadata(out).map(|m| m.len()).unwrap_or(0)
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels() -> Vec<String> {
        ["open", "fist", "v"].map(String::from).to_vec()
    }

    #[test]
    fn pairs_above_the_threshold_are_named() {
        let confusion = vec![vec![8, 2, 0], vec![0, 10, 0], vec![1, 0, 19]];
        let pairs = confused_pairs(&labels(), &confusion, 0.1);
        assert_eq!(pairs.len(), 1);
        assert_eq!(
            (pairs[0].0.as_str(), pairs[0].1.as_str(), pairs[0].3),
            ("open", "fist", 2)
        );
        assert!(confused_pairs(&labels(), &confusion, 0.25).is_empty());
    }

    #[test]
    fn bad_lines_are_named_by_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.jsonl");
        let good = |label: &str| {
            let f = airglyph_posture::Features::from_slice(&[0.1; airglyph_posture::FEATURE_LEN])
                .unwrap();
            PostureSample::new(label, "me", airglyph_posture::Side::Right, 1.0, &f).to_line()
        };
        std::fs::write(&path, format!("{}\n\n{{\"label\": 3}}\n", good("open"))).unwrap();
        let e = read(std::slice::from_ref(&path)).err().unwrap().to_string();
        assert!(
            e.starts_with(&format!("{}:3: not a posture sample", path.display())),
            "{e}"
        );
        std::fs::write(&path, format!("{}\n{}\n", good("open"), good("open"))).unwrap();
        let e = read(std::slice::from_ref(&path)).err().unwrap().to_string();
        assert!(
            e.contains("1 label(s)") && e.contains("labels found: open"),
            "{e}"
        );
        std::fs::write(&path, "").unwrap();
        let e = read(std::slice::from_ref(&path)).err().unwrap().to_string();
        assert!(e.starts_with("no posture samples in"), "{e}");
        std::fs::write(&path, format!("{}\n{}\n", good("open"), good("fist"))).unwrap();
        let s = read(&[path]).unwrap();
        assert_eq!(s.set.labels(), ["open", "fist"]);
        assert_eq!(s.subjects, ["me"]);
    }
}
