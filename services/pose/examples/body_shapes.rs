//! A look at MakeHuman body shapes: each shape in a few poses, the depth image with the
//! true skeleton over it (green), one PNG each, and the body's height, its waist's
//! width and where its head and hands are.
//!
//! `cargo run --release -p airglyph-pose --example body_shapes -- OUT_DIR
//!  [NAME:SHAPE…]` (SHAPE as `airglyph synth --body-shape` reads it; default: the base
//! mesh, a woman, a heavy man, a tall thin man, an older short woman).

use airglyph_core::Joint;
use airglyph_pose::overlay;
use airglyph_synth::{
    Background, BodySpec, MakeHumanShape, MotionSpec, Placement, SceneConfig, ScriptedPose,
    Synthesizer,
};
use std::path::PathBuf;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = PathBuf::from(args.first().expect("OUT_DIR"));
    std::fs::create_dir_all(&out).expect("out dir");
    let mut shapes: Vec<(String, String)> = args[1..]
        .iter()
        .map(|a| {
            let (n, s) = a.split_once(':').expect("NAME:SHAPE");
            (n.to_string(), s.to_string())
        })
        .collect();
    if shapes.is_empty() {
        for (n, s) in [
            ("base", ""),
            ("woman", "gender=0"),
            ("heavy-man", "gender=1,weight=0.95,muscle=0.4,age=0.6"),
            ("tall-thin-man", "gender=1,height=0.95,weight=0.1"),
            (
                "older-short-woman",
                "gender=0,age=0.85,height=0.1,weight=0.65",
            ),
        ] {
            shapes.push((n.into(), s.into()));
        }
    }
    for (name, text) in &shapes {
        let shape = MakeHumanShape::parse(text).expect("a shape");
        let body = BodySpec::MakeHuman {
            assets: None,
            shape,
        };
        let loaded = body.load().expect("the body loads");
        let verts = loaded.rest_vertices();
        let joints = loaded.rest_joints();
        let top = verts.iter().map(|v| v.y).fold(f32::MIN, f32::max);
        // The waist: the span in x of the vertices within 1 cm of 10 cm above the
        // pelvis, between the elbows (the arms left out).
        let waist_y = joints[Joint::Pelvis.index()].y + 0.10;
        let arm = joints[Joint::LeftElbow.index()]
            .x
            .abs()
            .min(joints[Joint::RightElbow.index()].x.abs())
            * 0.8;
        let xs = verts
            .iter()
            .filter(|v| (v.y - waist_y).abs() < 0.01 && v.x.abs() < arm)
            .map(|v| v.x);
        let (lo, hi) = xs.fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(x), b.max(x)));
        let depth = verts
            .iter()
            .filter(|v| (v.y - waist_y).abs() < 0.01 && v.x.abs() < arm)
            .map(|v| v.z);
        let (zlo, zhi) = depth.fold((f32::MAX, f32::MIN), |(a, b), z| (a.min(z), b.max(z)));
        let j = |n: Joint| joints[n.index()];
        println!(
            "{name} ({}): height {top:.3} m, waist {:.3} × {:.3} m, head {:.3}, neck {:.3}, shoulders {:.3} m apart, shoulder–hand {:.3} m",
            if text.is_empty() { "default" } else { text },
            hi - lo,
            zhi - zlo,
            j(Joint::Head).y,
            j(Joint::Neck).y,
            (j(Joint::LeftShoulder) - j(Joint::RightShoulder)).norm(),
            (j(Joint::LeftShoulder) - j(Joint::LeftHand)).norm(),
        );
        for pose in [
            ScriptedPose::Neutral,
            ScriptedPose::TPose,
            ScriptedPose::Sideways,
            ScriptedPose::HandsNearFace,
        ] {
            let cfg = SceneConfig {
                body: body.clone(),
                motion: MotionSpec::Pose(pose),
                background: Background::FloorAndWall,
                placement: Placement {
                    distance_m: 2.7,
                    ..Placement::default()
                },
                ..SceneConfig::default()
            };
            let mut synth = Synthesizer::new(cfg).expect("a scene");
            let k = synth.intrinsics();
            let (img, truth) = synth.render(0);
            let mut im = overlay::depth_image(&img.view(), None);
            overlay::skeleton(&mut im, &k, &truth.skeleton, overlay::GREEN);
            im.save(out.join(format!("{name}_{}.png", pose.name())))
                .expect("written");
        }
    }
}
