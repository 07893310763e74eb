//! Renders close-ups of the right hand in every posture (columns: open, fist, point,
//! thumb-up, v, pinch), palm to the camera, raised beside the head, so that what a
//! posture classifier gets can be looked at: depth shaded around the palm's depth
//! (nearer is brighter; the hand's pixels yellowish, the arm's bluish), each camera
//! pixel a block, 0.3 m across a cell; the truth marked (fingertips red, palm centre
//! green, wrist blue).
//!
//! cargo run --release -p airglyph-synth --example hand_postures -- [OUT_DIR] [--makehuman]
//!
//! Writes into OUT_DIR (default docs/synth/hands): hand_postures.png (rows: 0.8, 1.2,
//! 2 and 2.7 m from the camera), hand_postures_noise.png (the same through the sensor
//! model), hand_postures_turns.png (at 1.2 m, the wrist turned: roll 90°, 180°, −90°,
//! pitch 60°, −60°).

use airglyph_synth::{
    BodySpec, HandPosture, HandSpec, MotionSpec, SceneConfig, ScriptedPose, Synthesizer,
};
use image::{Rgb, RgbImage};
use std::path::PathBuf;

const DISTANCES: [f32; 4] = [0.8, 1.2, 2.0, 2.7];
/// The side of a cell in the picture, pixels, and of the scene it shows, metres.
const CELL: u32 = 128;
const SPAN_M: f32 = 0.30;

/// The right hand raised beside the head in `posture`, its palm `hand_m` from the
/// camera and turned to face it (the roll found by trying).
fn scene(body: &BodySpec, posture: HandPosture, hand_m: f32) -> SceneConfig {
    let mut cfg = SceneConfig {
        body: body.clone(),
        motion: MotionSpec::Pose(ScriptedPose::Wave),
        ..SceneConfig::default()
    };
    cfg.placement.distance_m = hand_m;
    cfg = cfg.framing_upper_body().expect("body");
    let truth = |cfg: &SceneConfig| {
        let mut s = Synthesizer::new(cfg.clone()).expect("scene");
        s.render(0).1.hands.right
    };
    let mut best = (f32::INFINITY, 0.0);
    for roll in (-180..180).step_by(10) {
        cfg.hands.right = HandSpec {
            posture: Some(posture),
            roll_deg: roll as f32,
            pitch_deg: 0.0,
            drawing: None,
        };
        let facing = truth(&cfg).palm_normal.z;
        if facing < best.0 {
            best = (facing, roll as f32);
        }
    }
    cfg.hands.right.roll_deg = best.1;
    for _ in 0..3 {
        let z = truth(&cfg).palm_centre.z;
        cfg.placement.distance_m += hand_m - z;
    }
    cfg
}

/// Draws the close-up of the right hand of `cfg` into cell (`col`, `row`) of `pic`.
fn draw_cell(pic: &mut RgbImage, col: u32, row: u32, cfg: SceneConfig) -> String {
    let mut synth = Synthesizer::new(cfg).expect("scene");
    let k = synth.intrinsics();
    let (img, truth) = synth.render(0);
    let h = truth.hands.right;
    let (cu, cv) = k.project(&h.palm_centre).expect("before the camera");
    let scale = SPAN_M * k.fx / h.palm_centre.z / CELL as f32;
    let z0 = h.palm_centre.z * 1000.0;
    for y in 0..CELL {
        for x in 0..CELL {
            let u = (cu + (x as f32 - CELL as f32 / 2.0) * scale).round();
            let v = (cv + (y as f32 - CELL as f32 / 2.0) * scale).round();
            let inside = u >= 0.0 && v >= 0.0 && u < k.width as f32 && v < k.height as f32;
            let px = if !inside {
                Rgb([40, 0, 0])
            } else {
                let i = v as usize * k.width as usize + u as usize;
                match img.pixels()[i] {
                    0 => Rgb([0, 0, 60]),
                    mm => {
                        // ±12 cm around the palm, nearer brighter; the hand bone's
                        // pixels tinted.
                        let t = ((z0 + 120.0 - mm as f32) / 240.0).clamp(0.0, 1.0);
                        let g = (t * 255.0) as u8;
                        if synth.labels()[i] == airglyph_synth::Bone::RightHand as u8 {
                            Rgb([g, g, (g as f32 * 0.8) as u8])
                        } else {
                            Rgb([(g as f32 * 0.8) as u8, g, g])
                        }
                    }
                }
            };
            pic.put_pixel(col * CELL + x, row * CELL + y, px);
        }
    }
    // The ground truth: fingertips red, palm centre green, wrist blue.
    let mut mark = |p: &nalgebra::Point3<f32>, c: Rgb<u8>| {
        if let Some((u, v)) = k.project(p) {
            let x = ((u - cu) / scale + CELL as f32 / 2.0) as i32;
            let y = ((v - cv) / scale + CELL as f32 / 2.0) as i32;
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (x, y) = (x + dx, y + dy);
                if (0..CELL as i32).contains(&x) && (0..CELL as i32).contains(&y) {
                    pic.put_pixel(col * CELL + x as u32, row * CELL + y as u32, c);
                }
            }
        }
    };
    mark(&h.palm_centre, Rgb([0, 255, 0]));
    mark(&h.wrist, Rgb([0, 128, 255]));
    for t in h.fingertips.iter().flatten() {
        mark(t, Rgb([255, 0, 0]));
    }
    format!(
        "palm z {:.3} m, roll {:>5}°, pitch {:>4}°, {:.1} px a cm",
        h.palm_centre.z,
        synth.config().hands.right.roll_deg,
        synth.config().hands.right.pitch_deg,
        k.fx / h.palm_centre.z / 100.0
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = PathBuf::from(
        args.iter()
            .find(|a| !a.starts_with("--"))
            .cloned()
            .unwrap_or_else(|| "docs/synth/hands".into()),
    );
    let body = if args.iter().any(|a| a == "--makehuman") {
        BodySpec::MakeHuman {
            assets: None,
            shape: Default::default(),
        }
    } else {
        BodySpec::Procedural(Default::default())
    };
    std::fs::create_dir_all(&out)?;
    let cols = HandPosture::ALL.len() as u32;
    for noise in [false, true] {
        let mut pic = RgbImage::new(cols * CELL, DISTANCES.len() as u32 * CELL);
        for (row, &d) in DISTANCES.iter().enumerate() {
            for (col, &posture) in HandPosture::ALL.iter().enumerate() {
                let cfg = SceneConfig {
                    sensor_noise: noise,
                    ..scene(&body, posture, d)
                };
                let said = draw_cell(&mut pic, col as u32, row as u32, cfg);
                eprintln!("{d:>4} m {:>9}: {said}", posture.name());
            }
        }
        let name = if noise {
            "hand_postures_noise.png"
        } else {
            "hand_postures.png"
        };
        pic.save(out.join(name))?;
        println!("wrote {}", out.join(name).display());
    }
    // Turned at the wrist, 1.2 m away: the side, the back, bent forward and back.
    let turns = [
        (90.0, 0.0),
        (180.0, 0.0),
        (-90.0, 0.0),
        (0.0, 60.0),
        (0.0, -60.0),
    ];
    let mut pic = RgbImage::new(cols * CELL, turns.len() as u32 * CELL);
    for (row, &(roll, pitch)) in turns.iter().enumerate() {
        for (col, &posture) in HandPosture::ALL.iter().enumerate() {
            let mut cfg = scene(&body, posture, 1.2);
            cfg.hands.right.roll_deg += roll;
            cfg.hands.right.pitch_deg += pitch;
            let said = draw_cell(&mut pic, col as u32, row as u32, cfg);
            eprintln!("turned {roll} {pitch} {:>9}: {said}", posture.name());
        }
    }
    pic.save(out.join("hand_postures_turns.png"))?;
    println!("wrote {}", out.join("hand_postures_turns.png").display());
    Ok(())
}
