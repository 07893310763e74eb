//! `airglyph synth`: render a synthetic person into a recording with exact ground truth
//! (depth PNGs, frames.csv, joints.csv, and gestures.csv for air-drawing).

use crate::interrupt::Interrupted;
use airglyph_core::camera::Preset;
use airglyph_core::gestures::write_gestures_csv;
use airglyph_core::Intrinsics;
use airglyph_ipc::shutdown;
use airglyph_synth::{
    Background, BodySpec, Chair, GestureTruth, HandPosture, HandSpec, Hands, MakeHumanShape,
    MotionSpec, Mug, Placement, Posture, ProceduralBody, Prop, SceneConfig, ScriptedPose,
    SynthError, Table,
};
use anyhow::{bail, Context};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::sync::mpsc;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The body: `procedural` (built in) or `makehuman` (fetched by `airglyph fetch-assets`).
    #[arg(long, default_value = "procedural")]
    pub body: String,
    /// What the person does: `poses` (the hard cases in turn), `rest` (arms at rest:
    /// hanging, on the thighs, in the lap, crossed, on the table if there is one, a few
    /// seconds each), `pose:NAME` (one of neutral, t-pose, point-at-camera,
    /// arm-across-torso, hands-near-face, sideways, wave, hands-in-front, arms-at-sides,
    /// hands-on-thighs, hands-on-table, hands-in-lap, arms-crossed), `draw:SYMBOLS`
    /// (air-draw e.g. `draw:0123ABC`), or a BVH file (any CMU conversion, Mixamo, DAZ,
    /// 3ds Max Biped names).
    #[arg(long, default_value = "poses")]
    pub motion: String,
    /// With draw:SYMBOLS, where the arms rest between symbols (a pose name, e.g.
    /// arms-at-sides); default: neutral standing, on the table or else on the thighs
    /// seated.
    #[arg(long, value_name = "POSE")]
    pub rest: Option<String>,
    /// The person sits on a chair (seat 0.46 m high) instead of standing.
    #[arg(long)]
    pub seated: bool,
    /// A table (0.74 m high, 1.2 × 0.7 m) in front of the person, 0.22 m from their hips.
    #[arg(long)]
    pub table: bool,
    /// A mug (8 × 8 × 10 cm) on the table just beyond the right hand's place of rest:
    /// an object the person touches. Needs --table.
    #[arg(long, requires = "table")]
    pub mug: bool,
    /// Frames to write (at most the clip's length); default: the whole clip or symbol
    /// list, 300 for endless motion.
    #[arg(long, value_parser = airglyph_ipc::options::within(1usize, 1_000_000), allow_negative_numbers = true)]
    pub frames: Option<usize>,
    /// The recording directory to create.
    #[arg(long)]
    pub out: PathBuf,
    /// Apply the Kinect-like sensor model (quantization, noise, lost edge pixels).
    #[arg(long)]
    pub noise: bool,
    /// `none` (the person alone), `floor-wall` or `room` (floor, the wall behind, a wall
    /// to the person's right and a cabinet to their left).
    #[arg(long, default_value = "none")]
    pub background: String,
    /// 640x480 or 320x240 (Kinect v1 optics), or any WxH scaled from the camera preset.
    #[arg(long, default_value = "640x480")]
    pub resolution: String,
    /// Camera preset: kinect-v1-640x480, kinect-v1-320x240, realsense-d435.
    #[arg(long, default_value = "kinect-v1-640x480")]
    pub camera: String,
    /// Frames a second (1–240).
    #[arg(long, default_value_t = 30.0, value_parser = airglyph_ipc::options::within(1.0f32, 240.0), allow_negative_numbers = true)]
    pub fps: f32,
    /// Random seed: everything is deterministic given it.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Procedural body height, metres.
    #[arg(long, default_value_t = 1.75)]
    pub height: f32,
    /// Procedural body build: 0.8 slim, 1.0 average, 1.3 heavy.
    #[arg(long, default_value_t = 1.0)]
    pub build: f32,
    /// Distance from the camera to the person, metres.
    #[arg(long, default_value_t = 2.7)]
    pub distance: f32,
    /// Camera height above the floor, metres (ignored with --framing upper-body).
    #[arg(long, default_value_t = 1.0)]
    pub camera_height: f32,
    /// Camera pitch down, degrees (ignored with --framing upper-body).
    #[arg(long, default_value_t = 0.0)]
    pub tilt: f32,
    /// `fixed` (the camera at --camera-height, tilted --tilt) or `upper-body` (at the
    /// person's face height, the top of the image just above their head: from the waist
    /// or chest up at 0.8–1.5 m, like a camera on a desk, a screen or a robot).
    #[arg(long, default_value = "fixed")]
    pub framing: String,
    /// The person's turn to their left, degrees.
    #[arg(long, default_value_t = 0.0)]
    pub yaw: f32,
    /// The camera follows the person across the floor (a motion clip's horizontal
    /// travel removed, its turns and jumps kept), so a clip that walks away stays in view.
    #[arg(long)]
    pub follow: bool,
    /// With --body makehuman, its shape as MakeHuman's macro sliders, each 0–1:
    /// NAME=VALUE,… with gender (0 female, 1 male), age (0 one year old, 0.1875 ten,
    /// 0.5 twenty-five, 1 ninety), muscle, weight (0 thinnest, 0.5 average, 1
    /// heaviest), height (0 shortest, 1 tallest for that gender, age and build),
    /// proportions (0 uncommon, 1 ideal), african, asian, caucasian (the ethnic mix,
    /// normalized); the others stay 0.5 (1/3 each ethnic), where the body is the plain
    /// base mesh. E.g. `gender=0,weight=0.8,height=0.3`. Needs the macro targets that
    /// `airglyph fetch-assets` extracts.
    #[arg(long, value_name = "NAME=VALUE,…", value_parser = parse_shape)]
    pub body_shape: Option<MakeHumanShape>,
    /// The hands' postures, drawn by a procedural hand in place of the body's own:
    /// HAND=POSTURE,… with HAND left, right or both and POSTURE one of open, fist,
    /// point, thumb-up, v, pinch; e.g. `right=point,left=open`. A hand not named keeps
    /// the body's own hand. joints.csv is unchanged; the posture is the scene's.
    #[arg(long, value_name = "HAND=POSTURE,…", value_parser = parse_postures)]
    pub hand_posture: Option<Hands<Option<HandPosture>>>,
    /// With draw:SYMBOLS, the drawing (right) hand's shape lifts the pen:
    /// DRAWING,BETWEEN, two postures (open, fist, point, thumb-up, v, pinch), the first
    /// held exactly over each symbol's frames (gestures.csv), the second everywhere
    /// else; e.g. `point,open`. hands.csv gives the posture of every frame. Instead of
    /// --hand-posture for the right hand.
    #[arg(long, value_name = "DRAWING,BETWEEN", value_parser = parse_pen_postures)]
    pub pen_posture: Option<(HandPosture, HandPosture)>,
    /// The hands' turn about the fingers' axis, degrees, on top of the motion's:
    /// HAND=DEGREES,… (positive turns the palm towards the thumb), e.g. `right=45`.
    #[arg(long, value_name = "HAND=DEGREES,…", value_parser = parse_angles, allow_hyphen_values = true)]
    pub hand_roll: Option<Hands<f32>>,
    /// The hands' bend at the wrist, degrees, on top of the motion's: HAND=DEGREES,…
    /// (positive bends the fingers towards the palm), e.g. `both=-30`.
    #[arg(long, value_name = "HAND=DEGREES,…", value_parser = parse_angles, allow_hyphen_values = true)]
    pub hand_pitch: Option<Hands<f32>>,
    /// Folder holding the MakeHuman assets (mpfb2/); default $AIRGLYPH_ASSETS, else
    /// ~/.cache/airglyph/assets.
    #[arg(long)]
    pub assets: Option<PathBuf>,
    /// With draw:SYMBOLS, take the shapes from this trajectory JSONL (.jsonl or .jsonl.gz).
    #[arg(long)]
    pub samples: Option<PathBuf>,
    /// Print the summary as one JSON object.
    #[arg(long)]
    pub json: bool,
}

fn parse_shape(text: &str) -> Result<MakeHumanShape, String> {
    MakeHumanShape::parse(text)
}

fn parse_postures(text: &str) -> Result<Hands<Option<HandPosture>>, String> {
    airglyph_synth::hand::parse_postures(text)
}

fn parse_pen_postures(text: &str) -> Result<(HandPosture, HandPosture), String> {
    airglyph_synth::hand::parse_pen_postures(text)
}

fn parse_angles(text: &str) -> Result<Hands<f32>, String> {
    airglyph_synth::hand::parse_angles(text)
}

/// Each hand's posture and turn from the four hand options.
fn hands(args: &Args) -> anyhow::Result<Hands<HandSpec>> {
    let mut postures = args.hand_posture.unwrap_or_default();
    let rolls = args.hand_roll.unwrap_or_default();
    let pitches = args.hand_pitch.unwrap_or_default();
    let mut drawing = None;
    if let Some((pen, between)) = args.pen_posture {
        if postures.right.is_some() {
            bail!("--pen-posture sets the right hand's postures: leave the right hand out of --hand-posture");
        }
        if !args.motion.starts_with("draw:") {
            bail!("--pen-posture is for --motion draw:SYMBOLS");
        }
        postures.right = Some(between);
        drawing = Some(pen);
    }
    let spec = |posture, roll_deg, pitch_deg, drawing| HandSpec {
        posture,
        roll_deg,
        pitch_deg,
        drawing,
    };
    Ok(Hands {
        left: spec(postures.left, rolls.left, pitches.left, None),
        right: spec(postures.right, rolls.right, pitches.right, drawing),
    })
}

fn intrinsics(camera: &str, resolution: &str) -> anyhow::Result<Intrinsics> {
    let preset = Preset::from_name(camera).with_context(|| {
        let names: Vec<_> = Preset::ALL.iter().map(|p| p.name()).collect();
        format!(
            "--camera {camera:?}: known cameras are {}",
            names.join(", ")
        )
    })?;
    let (w, h) = resolution
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .with_context(|| format!("--resolution {resolution:?}: expected WxH, e.g. 640x480"))?;
    let k = match (preset, w, h) {
        (Preset::KinectV1Vga | Preset::KinectV1Qvga, 640, 480) => Preset::KinectV1Vga.intrinsics(),
        (Preset::KinectV1Vga | Preset::KinectV1Qvga, 320, 240) => Preset::KinectV1Qvga.intrinsics(),
        _ => preset.intrinsics().scaled_to(w, h),
    };
    k.validate()
        .with_context(|| format!("--resolution {resolution}"))?;
    Ok(k)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if args.body_shape.is_some() && args.body != "makehuman" {
        bail!("--body-shape is for --body makehuman");
    }
    let body = match args.body.as_str() {
        "procedural" => BodySpec::Procedural(ProceduralBody {
            height_m: args.height,
            build: args.build,
        }),
        "makehuman" => BodySpec::MakeHuman {
            assets: args.assets.clone(),
            shape: args.body_shape.unwrap_or_default(),
        },
        other => bail!("--body {other:?}: expected procedural or makehuman"),
    };
    let background = match args.background.as_str() {
        "none" => Background::None,
        "floor-wall" | "floor-and-wall" => Background::FloorAndWall,
        "room" => Background::Room,
        other => bail!("--background {other:?}: expected none, floor-wall or room"),
    };
    let mut motion = MotionSpec::parse(&args.motion, args.samples.clone(), false)?;
    if let Some(name) = &args.rest {
        let pose = ScriptedPose::from_name(name).with_context(|| {
            let names: Vec<_> = ScriptedPose::AT_REST.iter().map(|p| p.name()).collect();
            format!(
                "--rest {name:?}: expected a pose, e.g. {}",
                names.join(", ")
            )
        })?;
        match &mut motion {
            MotionSpec::Draw(d) => d.rest = Some(pose),
            _ => bail!("--rest is for --motion draw:SYMBOLS"),
        }
    }
    let mut props = Vec::new();
    let posture = if args.seated {
        let chair = Chair::default();
        props.push(Prop::Chair(chair));
        Posture::Seated {
            seat_height_m: chair.seat_height_m,
        }
    } else {
        Posture::Standing
    };
    if args.table {
        props.push(Prop::Table(Table::default()));
    }
    if args.mug {
        props.push(Prop::Mug(Mug::default()));
    }
    let cfg = SceneConfig {
        body,
        motion,
        intrinsics: intrinsics(&args.camera, &args.resolution)?,
        fps: args.fps,
        sensor_noise: args.noise,
        background,
        props,
        posture,
        placement: Placement {
            distance_m: args.distance,
            camera_height_m: args.camera_height,
            camera_tilt_deg: args.tilt,
            yaw_deg: args.yaw,
            follow: args.follow,
            ..Placement::default()
        },
        hands: hands(&args)?,
        seed: args.seed,
    };
    let missing_assets = |e: SynthError| {
        match e {
        SynthError::MissingAssets { missing } => anyhow::anyhow!(
            "the MakeHuman body is not there ({} is missing): fetch it with `airglyph fetch-assets`, or set AIRGLYPH_ASSETS to the folder that holds mpfb2/",
            missing.display()
        ),
        SynthError::MissingTargets { missing } => anyhow::anyhow!(
            "--body-shape needs MakeHuman's macro targets, and {} is missing: rerun `airglyph fetch-assets` (a cache fetched before shapes existed lacks them)",
            missing.display()
        ),
        e => e.into(),
    }
    };
    let cfg = match args.framing.as_str() {
        "fixed" => cfg,
        "upper-body" => cfg.framing_upper_body().map_err(missing_assets)?,
        other => bail!("--framing {other:?}: expected fixed or upper-body"),
    };
    // Learn the motion's length first, for the progress bar and the default count, and
    // its gestures, for a recording cut short.
    let motion = airglyph_synth::Synthesizer::new(cfg.clone()).map_err(missing_assets)?;
    let (len, gestures) = (motion.len(), motion.gestures());
    drop(motion);
    let frames = match (args.frames, len) {
        (Some(n), Some(len)) => n.min(len),
        (Some(n), None) => n,
        (None, Some(len)) => len,
        (None, None) => 300,
    };
    let bar = if args.json {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(frames as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} frames  {per_sec}  eta {eta}")
            .expect("valid template"),
    );
    let draws = matches!(cfg.motion, MotionSpec::Draw(_));
    let (stopped, stopped_at) = mpsc::channel();
    let writer = {
        let (bar, out) = (bar.clone(), args.out.clone());
        std::thread::spawn(move || {
            airglyph_synth::write_recording(cfg, frames, &out, |n| {
                bar.set_position(n as u64);
                if shutdown::requested() {
                    // write_recording cannot be stopped, so it is held here for good,
                    // between two frames, where the n it wrote are whole (each frame's
                    // CSV rows are flushed with it) while the process ends.
                    let _ = stopped.send(n);
                    loop {
                        std::thread::park();
                    }
                }
            })
        })
    };
    // Either the writer stops between two frames, or it finishes and drops the sender.
    if let Ok(n) = stopped_at.recv() {
        bar.finish_and_clear();
        let done: Vec<GestureTruth> = gestures.into_iter().filter(|g| g.end_frame < n).collect();
        if draws {
            write_gestures_csv(&args.out.join("gestures.csv"), &done)?;
        }
        return Err(Interrupted::new(format!(
            "kept the first {n} of {frames} frames in {}, a whole recording{}",
            args.out.display(),
            if draws {
                format!(" with the {} symbols drawn in them", done.len())
            } else {
                String::new()
            }
        ))
        .into());
    }
    let summary = writer
        .join()
        .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        .with_context(|| format!("writing {}", args.out.display()))?;
    bar.finish_and_clear();
    if args.json {
        let line = serde_json::json!({
            "out": args.out,
            "frames": summary.frames,
            "gestures": summary.gestures.iter().map(|g| serde_json::json!({
                "label": g.label, "start_frame": g.start_frame, "end_frame": g.end_frame
            })).collect::<Vec<_>>(),
        });
        println!("{line}");
    } else {
        println!(
            "wrote {} frames to {} (depth/, frames.csv, joints.csv{}{})",
            summary.frames,
            args.out.display(),
            if summary.gestures.is_empty() {
                String::new()
            } else {
                format!(", gestures.csv: {} symbols", summary.gestures.len())
            },
            if hands(&args)? == Hands::default() {
                ""
            } else {
                ", hands.csv"
            }
        );
    }
    Ok(())
}
