//! The synthetic hands the examples train and test on: bodies calibrated so that the
//! raised right hand's palm faces the camera at each distance (the wave scene), and
//! the same bodies drawing symbols with the hand before the chest (the drawing scene),
//! every posture rendered at every distance and turn, with and without the sensor model, the hand
//! and elbow joints moved by Gaussian noise standing in for the pose estimate's error.

// Shared by the examples, each of which reads only part of what a shot holds.
#![allow(dead_code)]

use airglyph_core::{Intrinsics, Joint};
use airglyph_posture::{describe, ArmJoints, Hand, SegmentParams};
use airglyph_synth::{
    BodySpec, Bone, HandPosture, MotionSpec, ProceduralBody, SceneConfig, ScriptedPose, Synthesizer,
};
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// The palm's distances from the camera, metres.
pub const DISTANCES: [f32; 4] = [0.8, 1.2, 2.0, 2.7];
/// The hand's turn at the wrist on top of palm-to-camera: (roll, pitch) degrees.
pub const TURNS: [(f32, f32); 7] = [
    (0.0, 0.0),
    (45.0, 0.0),
    (-45.0, 0.0),
    (90.0, 0.0),
    (180.0, 0.0),
    (0.0, 40.0),
    (0.0, -40.0),
];
/// The drawing hand's turn at the wrist on top of the draw motion's own (which holds
/// the palm down and forward, the forearm forward and up): (roll, pitch) degrees —
/// palm down, half and fully sideways either way, bent up and down.
pub const DRAW_TURNS: [(f32, f32); 7] = [
    (0.0, 0.0),
    (45.0, 0.0),
    (-45.0, 0.0),
    (90.0, 0.0),
    (-90.0, 0.0),
    (0.0, 40.0),
    (0.0, -40.0),
];
/// What the training bodies draw: letters, so that the digits the end-to-end check
/// draws (`airglyph synth --motion draw:0123456789`) are strokes never trained on.
pub const TRAIN_SYMBOLS: &str = "ACEKMRSWZ";
/// What the held-out bodies draw in the eval.
pub const EVAL_SYMBOLS: &str = "BDGLNPUVX";
/// The pose estimate's error stood in for: per coordinate, metres.
pub const JOINT_NOISE_M: f32 = 0.02;

/// Where the hand is: raised beside the head (the wave pose, palm to the camera) or
/// before the chest drawing (a frame of the draw motion's strokes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scene {
    Wave,
    Drawing,
}

impl Scene {
    /// The turns `Setting::turn` indexes for this scene.
    pub fn turns(self) -> &'static [(f32, f32)] {
        match self {
            Scene::Wave => &TURNS,
            Scene::Drawing => &DRAW_TURNS,
        }
    }
}

/// One scene's setting, all that a sample varies by.
#[derive(Debug, Clone, Copy)]
pub struct Setting {
    pub scene: Scene,
    pub posture: HandPosture,
    pub distance: usize,
    pub turn: usize,
    pub noise: bool,
    pub seed: u64,
}

/// A body and the scene calibrated for it at each distance: the roll that turns the
/// palm to the camera and the placement that puts the palm at the distance.
pub struct Subject {
    pub name: String,
    pub group: u32,
    pub base: Vec<SceneConfig>,
    /// The drawing scenes, one a distance, and the frames of their strokes.
    pub draw: Vec<(SceneConfig, Vec<usize>)>,
}

pub fn calibrate(body: &BodySpec) -> Option<Vec<SceneConfig>> {
    let mut out = Vec::new();
    for &d in &DISTANCES {
        let mut cfg = SceneConfig {
            body: body.clone(),
            motion: MotionSpec::Pose(ScriptedPose::Wave),
            ..SceneConfig::default()
        };
        cfg.placement.distance_m = d;
        cfg = cfg.framing_upper_body().ok()?;
        cfg.hands.right.posture = Some(HandPosture::Open);
        let truth = |cfg: &SceneConfig| Some(Synthesizer::new(cfg.clone()).ok()?.render(0).1);
        let h = truth(&cfg)?.hands.right;
        cfg.hands.right.roll_deg = (-h.thumb_side.z).atan2(-h.palm_normal.z).to_degrees();
        for _ in 0..2 {
            let z = truth(&cfg)?.hands.right.palm_centre.z;
            cfg.placement.distance_m += d - z;
        }
        out.push(cfg);
    }
    Some(out)
}

/// The draw motion at each distance: the body placed so that the palm is at the
/// distance in the middle of the strokes (it moves some 20 cm about that), the hand
/// as the motion holds it, and the frames of the strokes (not the rest between them).
pub fn calibrate_drawing(body: &BodySpec, symbols: &str) -> Option<Vec<(SceneConfig, Vec<usize>)>> {
    let mut out = Vec::new();
    for &d in &DISTANCES {
        let mut cfg = SceneConfig {
            body: body.clone(),
            motion: MotionSpec::parse(&format!("draw:{symbols}"), None, false).ok()?,
            ..SceneConfig::default()
        };
        cfg.placement.distance_m = d;
        cfg = cfg.framing_upper_body().ok()?;
        cfg.hands.right.posture = Some(HandPosture::Open);
        let frames: Vec<usize> = Synthesizer::new(cfg.clone())
            .ok()?
            .gestures()
            .iter()
            .flat_map(|g| g.start_frame..=g.end_frame)
            .collect();
        let mid = *frames.get(frames.len() / 2)?;
        for _ in 0..2 {
            let z = Synthesizer::new(cfg.clone())
                .ok()?
                .render(mid)
                .1
                .hands
                .right
                .palm_centre
                .z;
            cfg.placement.distance_m += d - z;
        }
        out.push((cfg, frames));
    }
    Some(out)
}

/// A rendered hand: what the segmentation got and the truth's own hand pixels.
pub struct Shot {
    pub k: Intrinsics,
    pub depth: Vec<u16>,
    pub truth_hand: Vec<bool>,
    pub arm: ArmJoints,
    pub hand: Option<Hand>,
    pub palm: Point3<f32>,
    /// Seconds the segmentation, frame and features took.
    pub cost_s: f64,
}

pub fn shoot(subject: &Subject, s: Setting, params: &SegmentParams) -> Option<Shot> {
    let (mut cfg, frame) = match s.scene {
        Scene::Wave => {
            let mut cfg = subject.base[s.distance].clone();
            // The seed moves the sensor noise; the pose holds still.
            cfg.seed = s.seed;
            (cfg, 0)
        }
        Scene::Drawing => {
            // The seed picks the frame; the scene's own seed stays, as the draw
            // motion's timing follows it.
            let (cfg, frames) = &subject.draw[s.distance];
            let pick = ChaCha8Rng::seed_from_u64(s.seed).gen_range(0..frames.len());
            (cfg.clone(), frames[pick])
        }
    };
    let (roll, pitch) = s.scene.turns()[s.turn];
    cfg.hands.right.posture = Some(s.posture);
    cfg.hands.right.roll_deg += roll;
    cfg.hands.right.pitch_deg += pitch;
    cfg.sensor_noise = s.noise;
    let mut synth = Synthesizer::new(cfg).ok()?;
    let k = synth.intrinsics();
    let (img, truth) = synth.render(frame);
    let truth_hand: Vec<bool> = synth
        .labels()
        .iter()
        .zip(img.pixels())
        .map(|(&l, &z)| l == Bone::RightHand as u8 && z > 0)
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(s.seed ^ 0x9e37_79b9);
    let mut jitter = |p: Point3<f32>| {
        let n = Vector3::from_fn(|_, _| {
            // Box–Muller: a Gaussian from two uniforms.
            let (a, b): (f32, f32) = (rng.gen_range(1e-6..1.0), rng.gen());
            (-2.0 * a.ln()).sqrt() * (std::f32::consts::TAU * b).cos() * JOINT_NOISE_M
        });
        p + n
    };
    let arm = ArmJoints {
        hand: jitter(truth.skeleton.get(Joint::RightHand)),
        elbow: jitter(truth.skeleton.get(Joint::RightElbow)),
    };
    let started = Instant::now();
    let hand = describe(img.view(), &k, arm, params);
    let cost_s = started.elapsed().as_secs_f64();
    if let Err(e) = &hand {
        if std::env::var_os("POSTURE_DEBUG").is_some() {
            eprintln!("{:?} {:?}: {e}", subject.name, s);
        }
    }
    let hand = hand.ok();
    Some(Shot {
        k,
        depth: img.pixels().to_vec(),
        truth_hand,
        arm,
        hand,
        palm: truth.hands.right.palm_centre,
        cost_s,
    })
}

impl Shot {
    /// The segmentation's overlap with the renderer's own hand pixels (0 when no
    /// hand was found).
    pub fn iou(&self) -> f32 {
        let Some(h) = &self.hand else { return 0.0 };
        let w = self.k.width;
        let (mut inter, mut union) = (0usize, 0usize);
        for (i, &t) in self.truth_hand.iter().enumerate() {
            let s = h.region.contains(i as u32 % w, i as u32 / w);
            inter += (s && t) as usize;
            union += (s || t) as usize;
        }
        inter as f32 / union.max(1) as f32
    }
}

/// What one setting gave: the hand (`None` where none was found), the segmentation's
/// IoU against the renderer's hand pixels, and the seconds describing it took.
pub struct Row {
    pub setting: Setting,
    pub hand: Option<Hand>,
    pub iou: f32,
    pub cost_s: f64,
}

/// Every setting for one subject.
pub fn collect(subject: &Subject, settings: &[Setting], params: &SegmentParams) -> Vec<Row> {
    settings
        .iter()
        .filter_map(|&s| {
            let shot = shoot(subject, s, params)?;
            let iou = shot.iou();
            Some(Row {
                setting: s,
                iou,
                cost_s: shot.cost_s,
                hand: shot.hand,
            })
        })
        .collect()
}

pub fn settings(seed0: u64, turns: &[usize]) -> Vec<Setting> {
    scene_settings(Scene::Wave, seed0, turns)
}

/// Every posture at every distance and the given turns, with and without the sensor
/// model, one seed each from `seed0 + 1` on.
pub fn scene_settings(scene: Scene, seed0: u64, turns: &[usize]) -> Vec<Setting> {
    let mut out = Vec::new();
    let mut seed = seed0;
    for posture in HandPosture::ALL {
        for distance in 0..DISTANCES.len() {
            for &turn in turns {
                for noise in [false, true] {
                    seed += 1;
                    out.push(Setting {
                        scene,
                        posture,
                        distance,
                        turn,
                        noise,
                        seed,
                    });
                }
            }
        }
    }
    out
}

pub fn label_of(p: HandPosture) -> usize {
    HandPosture::ALL.iter().position(|&q| q == p).unwrap_or(0)
}

/// A procedural body.
pub fn procedural(height_m: f32, build: f32) -> BodySpec {
    BodySpec::Procedural(ProceduralBody { height_m, build })
}

/// The bodies calibrated, numbered from `group0` on; those that do not load (MakeHuman
/// assets missing) are skipped with a word on stderr.
pub fn subjects(bodies: Vec<(String, BodySpec)>, group0: u32, symbols: &str) -> Vec<Subject> {
    bodies
        .into_iter()
        .enumerate()
        .filter_map(|(i, (name, body))| {
            match (calibrate(&body), calibrate_drawing(&body, symbols)) {
                (Some(base), Some(draw)) => Some(Subject {
                    name,
                    group: group0 + i as u32,
                    base,
                    draw,
                }),
                _ => {
                    eprintln!("skipping {name}: it does not load (MakeHuman assets missing?)");
                    None
                }
            }
        })
        .collect()
}
