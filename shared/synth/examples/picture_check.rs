//! Renders the picture check of docs/synth/: colour-mapped depth of hard-case poses, a
//! BVH frame and an air-drawing frame, with the ground-truth skeleton drawn on top
//! (green = visible joint, orange = hidden by another body part, red = out of the
//! camera's view: behind furniture; joints outside the image are not drawn).
//!
//! cargo run -p airglyph-synth --example picture_check -- [OUT_DIR] [--makehuman]
//!
//! The white trail of an air-drawing frame is the ground-truth right hand since the
//! symbol began.

use airglyph_core::{Joint, Skeleton};
use airglyph_synth::{
    Background, BodySpec, Chair, DrawSpec, FrameTruth, MotionSpec, Placement, Posture, Prop,
    SceneConfig, ScriptedPose, Synthesizer, Table,
};
use image::{Rgb, RgbImage};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = PathBuf::from(
        args.iter()
            .find(|a| !a.starts_with("--"))
            .cloned()
            .unwrap_or_else(|| "docs/synth".into()),
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
    let base = SceneConfig {
        body: body.clone(),
        ..SceneConfig::default()
    };
    let scene = |motion: MotionSpec| SceneConfig {
        motion,
        ..base.clone()
    };
    let mut shots: Vec<(String, SceneConfig, usize)> = ScriptedPose::ALL
        .iter()
        .map(|p| (p.name().to_string(), scene(MotionSpec::Pose(*p)), 0))
        .collect();
    shots.push((
        "noise-floor-wall".into(),
        SceneConfig {
            background: Background::FloorAndWall,
            sensor_noise: true,
            ..scene(MotionSpec::Pose(ScriptedPose::Wave))
        },
        0,
    ));
    let bvh = PathBuf::from("/usr/share/assimp/models/BVH/01_01.bvh");
    if bvh.exists() {
        shots.push(("bvh-01_01".into(), scene(MotionSpec::Bvh(bvh)), 90));
    } else {
        eprintln!("skipping the BVH frame: install assimp-testmodels");
    }
    let draw = |symbols: &str| {
        MotionSpec::Draw(DrawSpec {
            symbols: symbols.into(),
            samples: None,
            repeat: false,
            rest: None,
        })
    };
    shots.push(("draw-3".into(), scene(draw("3")), usize::MAX));
    // The scenes of a camera at a desk or on a robot: near, from the waist up, seated
    // behind a table, arms at rest, in a furnished room, through the sensor model.
    let near = |distance_m: f32, cfg: SceneConfig| {
        SceneConfig {
            background: Background::Room,
            sensor_noise: true,
            placement: Placement {
                distance_m,
                ..cfg.placement
            },
            ..cfg
        }
        .framing_upper_body()
    };
    let seated = |cfg: SceneConfig, table: bool| {
        let mut props = vec![Prop::Chair(Chair::default())];
        if table {
            props.push(Prop::Table(Table::default()));
        }
        SceneConfig {
            posture: Posture::Seated {
                seat_height_m: Chair::default().seat_height_m,
            },
            props,
            ..cfg
        }
    };
    for (name, cfg, frame) in [
        (
            "close-arms-at-sides",
            near(1.2, scene(MotionSpec::Pose(ScriptedPose::ArmsAtSides))),
            0,
        ),
        ("close-draw-3", near(1.2, scene(draw("3"))), usize::MAX),
        (
            "seated-desk-hands-on-table",
            near(
                1.4,
                seated(scene(MotionSpec::Pose(ScriptedPose::HandsOnTable)), true),
            ),
            0,
        ),
        (
            "seated-desk-draw-3",
            near(1.4, seated(scene(draw("3")), true)),
            usize::MAX,
        ),
        (
            "seated-hands-on-thighs",
            near(
                1.0,
                seated(scene(MotionSpec::Pose(ScriptedPose::HandsOnThighs)), false),
            ),
            0,
        ),
    ] {
        match cfg {
            Ok(cfg) => shots.push((name.into(), cfg, frame)),
            Err(e) => eprintln!("{name}: {e}"),
        }
    }
    for (name, cfg, frame) in shots {
        let mut synth = match Synthesizer::new(cfg) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{name}: {e}");
                continue;
            }
        };
        // For air-drawing, show the middle of the first symbol.
        let frame = if frame == usize::MAX {
            synth
                .gestures()
                .first()
                .map(|g| (g.start_frame + g.end_frame * 3) / 4)
                .unwrap_or(0)
        } else {
            frame.min(synth.len().unwrap_or(usize::MAX).saturating_sub(1))
        };
        let trail: Vec<Skeleton> = match synth.gestures().first() {
            Some(g) => (g.start_frame..=frame)
                .map(|i| synth.render(i).1.skeleton)
                .collect(),
            None => Vec::new(),
        };
        let (depth, truth) = synth.render(frame);
        let img = overlay(&synth, depth.pixels(), &truth, &trail);
        let path = out.join(format!("{name}.png"));
        img.save(&path)?;
        println!("{}", path.display());
    }
    Ok(())
}

fn colour(mm: u16, near: f32, far: f32) -> Rgb<u8> {
    if mm == 0 {
        return Rgb([0, 0, 0]);
    }
    let t = ((mm as f32 - near) / (far - near)).clamp(0.0, 1.0);
    // A short warm-to-cool ramp: near is yellow, far is blue.
    let r = (255.0 * (1.0 - t).powf(0.6)) as u8;
    let g = (220.0 * (1.0 - (2.0 * t - 0.6).abs()).max(0.0)) as u8 / 2 + (120.0 * (1.0 - t)) as u8;
    let b = (80.0 + 175.0 * t) as u8;
    Rgb([r, g, b])
}

fn overlay(synth: &Synthesizer, depth: &[u16], truth: &FrameTruth, trail: &[Skeleton]) -> RgbImage {
    let k = synth.intrinsics();
    let person: Vec<u16> = depth
        .iter()
        .zip(synth.labels())
        .filter(|(d, l)| **d > 0 && **l != airglyph_synth::raster::NO_LABEL)
        .map(|(d, _)| *d)
        .collect();
    let near = person.iter().copied().min().unwrap_or(1000) as f32;
    let far = (person.iter().copied().max().unwrap_or(4000) as f32).max(near + 300.0) + 150.0;
    let mut img = RgbImage::from_fn(k.width, k.height, |u, v| {
        colour(depth[(v * k.width + u) as usize], near, far)
    });
    let px = |p: &nalgebra::Point3<f32>| k.project(p);
    for w in trail.windows(2) {
        if let (Some(a), Some(b)) = (
            px(&w[0].get(Joint::RightHand)),
            px(&w[1].get(Joint::RightHand)),
        ) {
            line(&mut img, a, b, Rgb([255, 255, 255]));
        }
    }
    for (a, b) in Joint::BONES {
        if let (Some(pa), Some(pb)) = (px(&truth.skeleton.get(a)), px(&truth.skeleton.get(b))) {
            line(&mut img, pa, pb, Rgb([0, 255, 255]));
        }
    }
    for j in Joint::ALL {
        if let Some((u, v)) = px(&truth.skeleton.get(j)) {
            let c = if !truth.skeleton.visible[j.index()] {
                Rgb([255, 0, 0])
            } else if truth.visible[j.index()] {
                Rgb([0, 255, 0])
            } else {
                Rgb([255, 150, 0])
            };
            for dy in -2..=2 {
                for dx in -2..=2 {
                    put(&mut img, u + dx as f32, v + dy as f32, c);
                }
            }
        }
    }
    img
}

fn put(img: &mut RgbImage, u: f32, v: f32, c: Rgb<u8>) {
    let (u, v) = (u.round() as i64, v.round() as i64);
    if u >= 0 && v >= 0 && (u as u32) < img.width() && (v as u32) < img.height() {
        img.put_pixel(u as u32, v as u32, c);
    }
}

fn line(img: &mut RgbImage, a: (f32, f32), b: (f32, f32), c: Rgb<u8>) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).clamp(1, 4000);
    for i in 0..=n {
        let t = i as f32 / n as f32;
        put(img, a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t, c);
    }
}
