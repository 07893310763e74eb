//! Makes the built-in posture model (`models/postures-6.json`): the six postures of
//! the synthetic hands, rendered on four procedural bodies at 0.8–2.7 m, at the seven
//! turns of the wrist, with and without the sensor model (the eval's training set,
//! with one body more), in two scenes: the hand raised beside the head, palm to the
//! camera, and the hand before the chest drawing letters (a frame of the strokes each),
//! the hand and elbow joints jittered by 2 cm as the pose estimate would be. The
//! classifier and its setting are chosen by leave-one-body-out cross-validation; it
//! prints every candidate's accuracy and what it kept.
//!
//! cargo run --release -p airglyph-posture --example train-builtin -- [OUT] [--quick]
//!
//! `--quick`: three turns only (wave 0, +45, 180; drawing 0, +45, −90), for a first
//! model in a minute.
//!
//! Then, when the MakeHuman assets are there (`airglyph fetch-assets`), the model is
//! tested on the eval's two MakeHuman bodies, which no training body resembles, with
//! the eval's test seeds: what the file is not made from.

mod synthetic;

use airglyph_posture::{
    choose, cross_validate, Classifier, Method, PostureModel, SegmentParams, TrainingSet,
};
use airglyph_synth::{BodySpec, HandPosture, MakeHumanShape};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;
use synthetic::{
    collect, label_of, procedural, scene_settings, subjects, Scene, DISTANCES, DRAW_TURNS,
    EVAL_SYMBOLS, TRAIN_SYMBOLS, TURNS,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let out = PathBuf::from(
        args.iter()
            .find(|a| !a.starts_with("--"))
            .cloned()
            .unwrap_or_else(|| "models/postures-6.json".into()),
    );
    let t0 = Instant::now();
    // The eval's cuts, chosen there by segmentation IoU on the training bodies.
    let params = SegmentParams::default();
    let bodies = vec![
        ("procedural 1.60 m build 0.9".into(), procedural(1.60, 0.9)),
        ("procedural 1.75 m build 1.0".into(), procedural(1.75, 1.0)),
        ("procedural 1.90 m build 1.2".into(), procedural(1.90, 1.2)),
        (
            "procedural 1.68 m build 1.35".into(),
            procedural(1.68, 1.35),
        ),
    ];
    let subjects = subjects(bodies, 0, TRAIN_SYMBOLS);
    let turns: Vec<usize> = if quick {
        vec![0, 1, 4]
    } else {
        (0..TURNS.len()).collect()
    };
    let labels: Vec<String> = HandPosture::ALL
        .iter()
        .map(|p| p.name().to_string())
        .collect();
    let mut set = TrainingSet::new(labels);
    let mut missed = 0;
    for subj in &subjects {
        let seed0 = subj.group as u64 * 10_000;
        let mut all = scene_settings(Scene::Wave, seed0, &turns);
        all.extend(scene_settings(Scene::Drawing, seed0 + 5_000, &turns));
        for row in collect(subj, &all, &params) {
            match &row.hand {
                Some(h) => set.add(&h.features, label_of(row.setting.posture), subj.group)?,
                None => missed += 1,
            }
        }
    }
    eprintln!(
        "{} hands from {} bodies ({missed} not found) in {:.1} s",
        set.len(),
        subjects.len(),
        t0.elapsed().as_secs_f32()
    );

    let candidates: Vec<Method> = [1, 3, 5, 9]
        .map(|k| Method::Knn { k })
        .into_iter()
        .chain([1e-4, 1e-3, 1e-2, 1e-1].map(|l2| Method::Softmax { l2 }))
        .collect();
    let mut accuracies = serde_json::Map::new();
    for &m in &candidates {
        let a = cross_validate(&set, m).ok_or("nothing to cross-validate")?;
        println!("{m:<20} leave-one-body-out {:.1}%", 100.0 * a);
        accuracies.insert(m.to_string(), json!(rounded(a, 1e3)));
    }
    let (method, accuracy) = choose(&set, &candidates).ok_or("no classifier")?;
    println!(
        "Chose {method}: leave-one-body-out {:.1}% on {} hands of {} bodies",
        100.0 * accuracy,
        set.len(),
        subjects.len()
    );
    let classifier = Classifier::train(&set, method)?;
    let training = json!({
        "command": format!(
            "cargo run --release -p airglyph-posture --example train-builtin -- {}{}",
            out.display(),
            if quick { " --quick" } else { "" }
        ),
        "bodies": subjects.iter().map(|s| s.name.clone()).collect::<Vec<_>>(),
        "distances_m": DISTANCES.map(|d| rounded(d, 1e2)),
        "turns_deg": turns.iter().map(|&t| [TURNS[t].0, TURNS[t].1].map(|a| rounded(a, 1.0))).collect::<Vec<_>>(),

        "drawing_turns_deg": turns.iter().map(|&t| [DRAW_TURNS[t].0, DRAW_TURNS[t].1].map(|a| rounded(a, 1.0))).collect::<Vec<_>>(),
        "drawing_symbols": TRAIN_SYMBOLS,
        "hands": set.len(),
        "not_found": missed,
        "chosen": method.to_string(),
        "leave_one_body_out": accuracies,
    });
    let model = PostureModel::new(classifier, params, training);
    model.save(&out)?;
    let bytes = std::fs::metadata(&out)?.len();
    println!("wrote {} ({} KB)", out.display(), bytes / 1000);

    let shapes = ["gender=0,height=0.45", "gender=1,height=0.6,weight=0.6"];
    let mut held_out = Vec::new();
    for shape in shapes {
        let s = MakeHumanShape::parse(shape)?;
        held_out.push((
            format!("MakeHuman {shape}"),
            BodySpec::MakeHuman {
                assets: None,
                shape: s,
            },
        ));
    }
    // The eval's held-out MakeHuman bodies, with its test seeds and its own letters.
    let held_out = synthetic::subjects(held_out, 101, EVAL_SYMBOLS);
    for (scene, offset) in [(Scene::Wave, 0), (Scene::Drawing, 5_000)] {
        let (mut right, mut total) = (0, 0);
        for subj in &held_out {
            let seed0 = 1_000_000 + subj.group as u64 * 10_000 + offset;
            let (mut r, mut n) = (0, 0);
            for row in collect(subj, &scene_settings(scene, seed0, &turns), model.params()) {
                // No hand found counts as wrong.
                let said = row
                    .hand
                    .map(|h| model.classifier().predict(&h.features).label);
                r += (said == Some(label_of(row.setting.posture))) as usize;
                n += 1;
            }
            println!(
                "held out, {scene:?}, {}: {r}/{n} = {:.1}%",
                subj.name,
                100.0 * r as f32 / n.max(1) as f32
            );
            (right, total) = (right + r, total + n);
        }
        if total > 0 {
            println!(
                "held out, {scene:?}, both: {right}/{total} = {:.1}%",
                100.0 * right as f32 / total as f32
            );
        }
    }
    eprintln!("done in {:.1} s", t0.elapsed().as_secs_f32());
    Ok(())
}

/// `x` to the nearest `1 / per`, as the f64 that prints so (an f32 widened prints its
/// binary tail: 0.800000011920929).
fn rounded(x: f32, per: f64) -> f64 {
    (x as f64 * per).round() / per
}
