//! Measures posture recognition on synthetic hands: trains on procedural bodies and
//! tests on MakeHuman bodies (and a procedural body of its own) never seen in
//! training, with other seeds; prints accuracy by distance, by the hand's turn at the
//! wrist and with and without the sensor model, for both classifiers; writes the
//! confusion matrix and a few segmentation overlays as PNGs. Then the same held-out
//! bodies drawing (the hand before the chest, other symbols than the training bodies
//! draw), by distance and with and without the sensor model.
//!
//! cargo run --release -p airglyph-posture --example eval -- [OUT_DIR] [--quick] [--wave-only]
//!
//! `--wave-only`: train on the wave scene alone (the built-in model's training before
//! the drawing scene was added), to compare.
//!
//! The hand joint and elbow given to the segmentation are the truth's moved by
//! Gaussian noise (2 cm a coordinate), standing in for the pose estimate's error.
//! Classifier settings are chosen by leave-one-body-out cross-validation on the
//! training bodies only.

mod synthetic;

use airglyph_posture::{choose, Classifier, Method, SegmentParams, TrainingSet};
use airglyph_synth::{BodySpec, HandPosture, MakeHumanShape};
use image::{Rgb, RgbImage};
use std::path::PathBuf;
use std::time::Instant;
use synthetic::{
    collect, label_of, procedural, scene_settings, settings, shoot, subjects, Row, Scene, Setting,
    Shot, DISTANCES, DRAW_TURNS, EVAL_SYMBOLS, TRAIN_SYMBOLS, TURNS,
};

impl Shot {
    /// A close-up around the palm: depth grey, the truth's hand pixels the
    /// segmentation found green, those it missed blue, pixels it took that are not
    /// the hand's red; the jittered joint yellow.
    fn overlay(&self, pic: &mut RgbImage, col: u32, row: u32, cell: u32) {
        let k = &self.k;
        let Some((cu, cv)) = k.project(&self.palm) else {
            return;
        };
        let scale = 0.32 * k.fx / self.palm.z / cell as f32;
        let z0 = self.palm.z * 1000.0;
        for y in 0..cell {
            for x in 0..cell {
                let u = (cu + (x as f32 - cell as f32 / 2.0) * scale).round();
                let v = (cv + (y as f32 - cell as f32 / 2.0) * scale).round();
                let px = if u < 0.0 || v < 0.0 || u >= k.width as f32 || v >= k.height as f32 {
                    Rgb([40, 0, 0])
                } else {
                    let (u, v) = (u as u32, v as u32);
                    let i = (v * k.width + u) as usize;
                    let seg = self.hand.as_ref().is_some_and(|h| h.region.contains(u, v));
                    let t = self.truth_hand[i];
                    let g = match self.depth[i] {
                        0 => 0,
                        mm => ((z0 + 200.0 - mm as f32) / 400.0 * 200.0).clamp(0.0, 200.0) as u8,
                    };
                    match (seg, t) {
                        (true, true) => Rgb([0, 120 + g / 2, 0]),
                        (true, false) => Rgb([230, 40, 40]),
                        (false, true) => Rgb([40, 80, 240]),
                        (false, false) => Rgb([g, g, g]),
                    }
                };
                pic.put_pixel(col * cell + x, row * cell + y, px);
            }
        }
        if let Some((u, v)) = k.project(&self.arm.hand) {
            let x = ((u - cu) / scale + cell as f32 / 2.0) as i64;
            let y = ((v - cv) / scale + cell as f32 / 2.0) as i64;
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1), (-1, 0), (0, -1)] {
                let (x, y) = (x + dx, y + dy);
                if (0..cell as i64).contains(&x) && (0..cell as i64).contains(&y) {
                    pic.put_pixel(
                        col * cell + x as u32,
                        row * cell + y as u32,
                        Rgb([255, 230, 0]),
                    );
                }
            }
        }
    }
}

/// A tally of right and wrong by some key.
#[derive(Default, Clone)]
struct Tally {
    right: usize,
    total: usize,
}

impl Tally {
    fn add(&mut self, ok: bool) {
        self.right += ok as usize;
        self.total += 1;
    }
    fn pct(&self) -> String {
        if self.total == 0 {
            "   -  ".into()
        } else {
            format!("{:5.1}%", 100.0 * self.right as f32 / self.total as f32)
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let wave_only = args.iter().any(|a| a == "--wave-only");
    let out = PathBuf::from(
        args.iter()
            .find(|a| !a.starts_with("--"))
            .cloned()
            .unwrap_or_else(|| "services/posture/eval".into()),
    );
    std::fs::create_dir_all(&out)?;
    let mut params = SegmentParams::default();
    let t0 = Instant::now();

    let train_bodies: Vec<(String, BodySpec)> = vec![
        ("procedural 1.60 m build 0.9".into(), procedural(1.60, 0.9)),
        ("procedural 1.75 m build 1.0".into(), procedural(1.75, 1.0)),
        ("procedural 1.90 m build 1.2".into(), procedural(1.90, 1.2)),
    ];
    let mut test_bodies: Vec<(String, BodySpec)> = vec![(
        "procedural 1.68 m build 1.35".into(),
        procedural(1.68, 1.35),
    )];
    for shape in ["gender=0,height=0.45", "gender=1,height=0.6,weight=0.6"] {
        match MakeHumanShape::parse(shape) {
            Ok(s) => test_bodies.push((
                format!("MakeHuman {shape}"),
                BodySpec::MakeHuman {
                    assets: None,
                    shape: s,
                },
            )),
            Err(e) => eprintln!("skipping MakeHuman {shape}: {e}"),
        }
    }
    let train_subjects = subjects(train_bodies, 0, TRAIN_SYMBOLS);
    let test_subjects = subjects(test_bodies, 100, EVAL_SYMBOLS);
    eprintln!("calibrated in {:.1} s", t0.elapsed().as_secs_f32());

    // Where the forearm is cut: chosen by the segmentation's IoU on the training
    // bodies (a few turns), never on the test bodies.
    let mut best_cut = (f32::NEG_INFINITY, params.wrist_back, params.palm_back);
    for (wrist_back, palm_back) in [0.15, 0.2, 0.25]
        .into_iter()
        .flat_map(|w| [0.15, 0.18, 0.21].map(|p| (w, p)))
    {
        let p = SegmentParams {
            wrist_back,
            palm_back,
            ..params
        };
        let (mut sum, mut n) = (0.0, 0);
        for subj in &train_subjects {
            for Row { iou, .. } in
                collect(subj, &settings(subj.group as u64 * 10_000, &[0, 3, 5]), &p)
            {
                sum += iou;
                n += 1;
            }
        }
        let mean = sum / n.max(1) as f32;
        println!("wrist cut {wrist_back} of elbow–hand back, {palm_back} of it behind the palm's centre: training IoU {mean:.3}");
        if mean > best_cut.0 {
            best_cut = (mean, wrist_back, palm_back);
        }
    }
    params.wrist_back = best_cut.1;
    params.palm_back = best_cut.2;
    println!(
        "Kept wrist cut {}, palm cut {} (training IoU {:.3})",
        best_cut.1, best_cut.2, best_cut.0
    );

    let all_turns: Vec<usize> = (0..TURNS.len()).collect();
    let turns: Vec<usize> = if quick { vec![0, 1, 4] } else { all_turns };
    let labels: Vec<String> = HandPosture::ALL
        .iter()
        .map(|p| p.name().to_string())
        .collect();
    let mut train = TrainingSet::new(labels.clone());
    let mut missed_train = 0;
    let mut train_rows = Vec::new();
    for subj in &train_subjects {
        let seed0 = subj.group as u64 * 10_000;
        let mut all = scene_settings(Scene::Wave, seed0, &turns);
        if !wave_only {
            all.extend(scene_settings(Scene::Drawing, seed0 + 5_000, &turns));
        }
        for row in collect(subj, &all, &params) {
            match &row.hand {
                Some(h) => {
                    train.add(&h.features, label_of(row.setting.posture), subj.group)?;
                    train_rows.push((subj.group, row.setting, h.features));
                }
                None => missed_train += 1,
            }
        }
    }
    eprintln!(
        "training: {} hands from {} bodies ({} not found) in {:.1} s",
        train.len(),
        train_subjects.len(),
        missed_train,
        t0.elapsed().as_secs_f32()
    );

    let knn = [1, 3, 5, 9].map(|k| Method::Knn { k });
    let softmax = [1e-4, 1e-3, 1e-2, 1e-1].map(|l2| Method::Softmax { l2 });
    let (best_knn, cv_knn) = choose(&train, &knn).ok_or("no k-NN")?;
    let (best_soft, cv_soft) = choose(&train, &softmax).ok_or("no softmax")?;
    println!(
        "Trained on {} (seeds 1..), {} hands{}.",
        train_subjects
            .iter()
            .map(|s| s.name.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        train.len(),
        if wave_only {
            ", the wave scene only"
        } else {
            ", the wave and drawing scenes"
        }
    );
    println!(
        "Leave-one-body-out on training: {best_knn} {:.1}%, {best_soft} {:.1}%",
        100.0 * cv_knn,
        100.0 * cv_soft
    );
    let kept = if cv_knn >= cv_soft {
        best_knn
    } else {
        best_soft
    };
    println!("Kept (by training cross-validation): {kept}");
    let classifiers = [
        Classifier::train(&train, best_knn)?,
        Classifier::train(&train, best_soft)?,
    ];
    eprintln!("trained in {:.1} s", t0.elapsed().as_secs_f32());

    // Test: other bodies, other seeds.
    let mut by_distance = vec![vec![Tally::default(); DISTANCES.len()]; 2];
    let mut by_turn = vec![vec![Tally::default(); TURNS.len()]; 2];
    let mut by_noise = vec![vec![Tally::default(); 2]; 2];
    let mut by_body = vec![vec![Tally::default(); test_subjects.len()]; 2];
    let mut overall = vec![Tally::default(); 2];
    let mut confusion = vec![vec![0u32; labels.len()]; labels.len()];
    let mut iou_by_distance = vec![(0.0f32, 0usize); DISTANCES.len()];
    let mut not_found = 0;
    let test_turns: Vec<usize> = if quick {
        vec![0, 1, 4]
    } else {
        (0..TURNS.len()).collect()
    };
    let mut test_rows = Vec::new();
    let mut cost_by_distance = vec![Vec::new(); DISTANCES.len()];
    for (bi, subj) in test_subjects.iter().enumerate() {
        for Row {
            setting: s,
            hand,
            iou,
            cost_s,
        } in collect(
            subj,
            &settings(1_000_000 + subj.group as u64 * 10_000, &test_turns),
            &params,
        ) {
            test_rows.push((s, hand.as_ref().map(|h| h.features)));
            cost_by_distance[s.distance].push(cost_s);
            iou_by_distance[s.distance].0 += iou;
            iou_by_distance[s.distance].1 += 1;
            let truth = label_of(s.posture);
            for (ci, c) in classifiers.iter().enumerate() {
                // No hand found counts as wrong.
                let pred = hand.as_ref().map(|h| c.predict(&h.features).label);
                let ok = pred == Some(truth);
                by_distance[ci][s.distance].add(ok);
                by_turn[ci][s.turn].add(ok);
                by_noise[ci][s.noise as usize].add(ok);
                by_body[ci][bi].add(ok);
                overall[ci].add(ok);
                if c.method() == kept {
                    if let Some(p) = pred {
                        confusion[truth][p] += 1;
                    }
                }
            }
            not_found += hand.is_none() as usize;
        }
    }
    let names = [best_knn.to_string(), best_soft.to_string()];
    println!(
        "\nTest: {} ({} hands, {} with no hand found, counted wrong)",
        test_subjects
            .iter()
            .map(|s| s.name.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        overall[0].total,
        not_found
    );
    println!("{:<34} {:>16} {:>20}", "", names[0], names[1]);
    println!(
        "{:<34} {:>16} {:>20}",
        "all",
        overall[0].pct(),
        overall[1].pct()
    );
    for (i, d) in DISTANCES.iter().enumerate() {
        let iou = iou_by_distance[i].0 / iou_by_distance[i].1.max(1) as f32;
        println!(
            "{:<34} {:>16} {:>20}",
            format!("{d} m (mean IoU {iou:.2})"),
            by_distance[0][i].pct(),
            by_distance[1][i].pct()
        );
    }
    for &t in &test_turns {
        let (r, p) = TURNS[t];
        println!(
            "{:<34} {:>16} {:>20}",
            format!("roll {r:+} pitch {p:+}"),
            by_turn[0][t].pct(),
            by_turn[1][t].pct()
        );
    }
    for (n, name) in ["no sensor model", "sensor model"].iter().enumerate() {
        println!(
            "{:<34} {:>16} {:>20}",
            name,
            by_noise[0][n].pct(),
            by_noise[1][n].pct()
        );
    }
    for (bi, subj) in test_subjects.iter().enumerate() {
        println!(
            "{:<34} {:>16} {:>20}",
            subj.name,
            by_body[0][bi].pct(),
            by_body[1][bi].pct()
        );
    }
    for (i, d) in DISTANCES.iter().enumerate() {
        let c = &mut cost_by_distance[i];
        c.sort_by(f64::total_cmp);
        if let (Some(med), Some(max)) = (c.get(c.len() / 2), c.last()) {
            println!(
                "describe (segment, frame, features) at {d} m: median {:.3} ms, max {:.3} ms",
                med * 1e3,
                max * 1e3
            );
        }
    }

    // Turns held out: trained on some of the wrist's turns, tested on the others
    // (other bodies and seeds as well).
    if !quick {
        let (seen, unseen) = ([0usize, 1, 4, 5], [2usize, 3, 6]);
        let mut part = TrainingSet::new(labels.clone());
        for (g, s, f) in &train_rows {
            if s.scene == Scene::Wave && seen.contains(&s.turn) {
                part.add(f, label_of(s.posture), *g)?;
            }
        }
        let methods: Vec<Method> = knn.iter().chain(softmax.iter()).copied().collect();
        let (m_knn, _) = choose(&part, &knn).ok_or("no k-NN")?;
        let (m_soft, _) = choose(&part, &softmax).ok_or("no softmax")?;
        let (m_kept, cv) = choose(&part, &methods).ok_or("no method")?;
        let cs = [
            Classifier::train(&part, m_knn)?,
            Classifier::train(&part, m_soft)?,
        ];
        let describe_turns = |ts: &[usize]| {
            ts.iter()
                .map(|&t| format!("roll {:+} pitch {:+}", TURNS[t].0, TURNS[t].1))
                .collect::<Vec<_>>()
                .join(", ")
        };
        println!(
            "\nTurns held out: trained on {} ({} hands; kept {m_kept}, cross-validated {:.1}%), tested on {}",
            describe_turns(&seen),
            part.len(),
            100.0 * cv,
            describe_turns(&unseen)
        );
        println!(
            "{:<34} {:>16} {:>20}",
            "",
            m_knn.to_string(),
            m_soft.to_string()
        );
        let mut all = [Tally::default(), Tally::default()];
        for &t in &unseen {
            let mut tally = [Tally::default(), Tally::default()];
            for (s, f) in test_rows.iter().filter(|(s, _)| s.turn == t) {
                for (ci, c) in cs.iter().enumerate() {
                    let ok = f.as_ref().map(|f| c.predict(f).label) == Some(label_of(s.posture));
                    tally[ci].add(ok);
                    all[ci].add(ok);
                }
            }
            let (r, p) = TURNS[t];
            println!(
                "{:<34} {:>16} {:>20}",
                format!("roll {r:+} pitch {p:+}"),
                tally[0].pct(),
                tally[1].pct()
            );
        }
        println!(
            "{:<34} {:>16} {:>20}",
            "all unseen turns",
            all[0].pct(),
            all[1].pct()
        );
    }

    drawing_test(&test_subjects, &test_turns, &params, &classifiers);

    let path = out.join("confusion.png");
    airglyph_plot::confusion(
        &path,
        &format!("{kept}, test bodies, all settings"),
        &labels,
        &confusion,
        true,
    )?;
    println!("wrote {}", path.display());

    // Overlays: every posture at each distance, the first test body, no turn, with
    // the sensor model.
    if let Some(subj) = test_subjects.first() {
        for noise in [false, true] {
            let cell = 128;
            let mut pic = RgbImage::new(
                cell * HandPosture::ALL.len() as u32,
                cell * DISTANCES.len() as u32,
            );
            for (row, _) in DISTANCES.iter().enumerate() {
                for (col, &posture) in HandPosture::ALL.iter().enumerate() {
                    let s = Setting {
                        scene: Scene::Wave,
                        posture,
                        distance: row,
                        turn: 0,
                        noise,
                        seed: 7 + col as u64,
                    };
                    if let Some(shot) = shoot(subj, s, &params) {
                        shot.overlay(&mut pic, col as u32, row as u32, cell);
                    }
                }
            }
            let path = out.join(if noise {
                "overlay_noise.png"
            } else {
                "overlay.png"
            });
            pic.save(&path)?;
            println!("wrote {}", path.display());
        }
    }
    // Overlays of the turns: rows are the turns, at 1.2 m, with the sensor model.
    if let Some(subj) = test_subjects.first() {
        let cell = 128;
        let mut pic = RgbImage::new(
            cell * HandPosture::ALL.len() as u32,
            cell * TURNS.len() as u32,
        );
        for row in 0..TURNS.len() {
            for (col, &posture) in HandPosture::ALL.iter().enumerate() {
                let s = Setting {
                    scene: Scene::Wave,
                    posture,
                    distance: 1,
                    turn: row,
                    noise: true,
                    seed: 11 + col as u64,
                };
                if let Some(shot) = shoot(subj, s, &params) {
                    shot.overlay(&mut pic, col as u32, row as u32, cell);
                }
            }
        }
        let path = out.join("overlay_turns.png");
        pic.save(&path)?;
        println!("wrote {}", path.display());
    }
    eprintln!("done in {:.1} s", t0.elapsed().as_secs_f32());
    Ok(())
}

/// The held-out bodies drawing: every posture, at each distance and turn of the
/// drawing hand, with and without the sensor model, a frame of the strokes each.
fn drawing_test(
    subjects: &[synthetic::Subject],
    turns: &[usize],
    params: &SegmentParams,
    classifiers: &[Classifier; 2],
) {
    let mut by_cell = vec![vec![vec![Tally::default(); 2]; DISTANCES.len()]; 2];
    let mut by_turn = vec![vec![Tally::default(); DRAW_TURNS.len()]; 2];
    let mut overall = vec![Tally::default(); 2];
    let mut not_found = 0;
    for subj in subjects {
        let seed0 = 2_000_000 + subj.group as u64 * 10_000;
        for row in collect(subj, &scene_settings(Scene::Drawing, seed0, turns), params) {
            let s = row.setting;
            for (ci, c) in classifiers.iter().enumerate() {
                let pred = row.hand.as_ref().map(|h| c.predict(&h.features).label);
                let ok = pred == Some(label_of(s.posture));
                by_cell[ci][s.distance][s.noise as usize].add(ok);
                by_turn[ci][s.turn].add(ok);
                overall[ci].add(ok);
            }
            not_found += row.hand.is_none() as usize;
        }
    }
    println!(
        "\nDrawing, test bodies ({} hands, {} with no hand found, counted wrong)",
        overall[0].total, not_found
    );
    let names = classifiers.each_ref().map(|c| c.method().to_string());
    println!("{:<34} {:>16} {:>20}", "", names[0], names[1]);
    println!(
        "{:<34} {:>16} {:>20}",
        "all",
        overall[0].pct(),
        overall[1].pct()
    );
    for (i, d) in DISTANCES.iter().enumerate() {
        for (n, name) in ["no sensor model", "sensor model"].iter().enumerate() {
            println!(
                "{:<34} {:>16} {:>20}",
                format!("{d} m, {name}"),
                by_cell[0][i][n].pct(),
                by_cell[1][i][n].pct()
            );
        }
    }
    for &t in turns {
        let (r, p) = DRAW_TURNS[t];
        println!(
            "{:<34} {:>16} {:>20}",
            format!("drawing roll {r:+} pitch {p:+}"),
            by_turn[0][t].pct(),
            by_turn[1][t].pct()
        );
    }
}
