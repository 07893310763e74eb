//! The default scene (no hand posture asked) renders exactly what it rendered before
//! hand postures existed: checksums of depth and labels taken on the code before them.
//!
//! A checksum moves with any change of a rendered pixel, so an intended change of the
//! body's look must update them (and say so in its commit).

use airglyph_synth::{
    Background, BodySpec, DrawSpec, MotionSpec, SceneConfig, ScriptedPose, Synthesizer,
};

/// FNV-1a over the depth (little-endian) and the labels of one frame.
fn checksum(hash: &mut u64, depth: &[u16], labels: &[u8]) {
    let mut eat = |b: u8| {
        *hash ^= b as u64;
        *hash = hash.wrapping_mul(0x100_0000_01b3);
    };
    for d in depth {
        eat(*d as u8);
        eat((d >> 8) as u8);
    }
    for l in labels {
        eat(*l);
    }
}

fn render_all(scenes: &[(SceneConfig, usize)]) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325;
    for (cfg, index) in scenes {
        let mut synth = Synthesizer::new(cfg.clone()).expect("scene");
        let (img, _) = synth.render(*index);
        checksum(&mut hash, img.pixels(), synth.labels());
    }
    hash
}

fn procedural_scenes() -> Vec<(SceneConfig, usize)> {
    let mut scenes: Vec<(SceneConfig, usize)> = ScriptedPose::ALL
        .iter()
        .map(|p| {
            let cfg = SceneConfig {
                motion: MotionSpec::Pose(*p),
                ..SceneConfig::default()
            };
            (cfg, 0)
        })
        .collect();
    scenes.push((
        SceneConfig {
            motion: MotionSpec::Pose(ScriptedPose::Wave),
            background: Background::FloorAndWall,
            sensor_noise: true,
            seed: 7,
            ..SceneConfig::default()
        },
        3,
    ));
    scenes.push((
        SceneConfig {
            motion: MotionSpec::Draw(DrawSpec {
                symbols: "3".into(),
                samples: None,
                repeat: false,
                rest: None,
            }),
            ..SceneConfig::default()
        },
        25,
    ));
    scenes
}

#[test]
fn the_default_procedural_body_renders_as_before() {
    let got = render_all(&procedural_scenes());
    assert_eq!(got, PROCEDURAL, "got {got:#018x}");
}

#[test]
fn the_default_makehuman_body_renders_as_before() {
    let dir = airglyph_synth::makehuman::default_assets_dir();
    if !airglyph_synth::makehuman::assets_present(&dir) {
        eprintln!("skipped: no MakeHuman assets in {}", dir.display());
        return;
    }
    let body = BodySpec::MakeHuman {
        assets: None,
        shape: Default::default(),
    };
    let scenes: Vec<(SceneConfig, usize)> = [
        ScriptedPose::Wave,
        ScriptedPose::HandsNearFace,
        ScriptedPose::PointAtCamera,
    ]
    .iter()
    .map(|p| {
        let cfg = SceneConfig {
            body: body.clone(),
            motion: MotionSpec::Pose(*p),
            ..SceneConfig::default()
        };
        (cfg, 0)
    })
    .collect();
    let got = render_all(&scenes);
    assert_eq!(got, MAKEHUMAN, "got {got:#018x}");
}

const PROCEDURAL: u64 = 0x1bee_270f_c1cf_beea;
const MAKEHUMAN: u64 = 0x0ac6_8ef2_669e_d12c;
