//! The pose estimator on every kind of scene a camera at a desk, a screen or a robot
//! sees, with and without the sensor model: one table, and a JSON line a row.
//!
//! `cargo run --release -p airglyph-pose --example scenes -- [KIND…] [frames:N]
//!  [every:N] [single] [seeds:+K] [json:FILE] [overlays:DIR] [set:FIELD=VALUE]` (default: every
//! kind, whole clips; `scripts/eval pose` runs it). KIND filters rows by name prefix;
//! `single` estimates every frame afresh, with no history (as single real frames are
//! scored); `every:N` scores every Nth frame only.
//!
//! The rows marked "held out" use bodies, seeds, symbols and distances that no setting
//! was chosen on: a figure measured only on the tuned rows is not a result. The 2-D
//! column is the mean image distance, in pixels at 640×480, of the eight joints people
//! label by hand (head, neck, shoulders, elbows, hands), as real frames are scored.

mod support;

use airglyph_core::{Joint, Skeleton};
use airglyph_pose::metrics::{PoseEval, Summary};
use airglyph_pose::{overlay, PoseConfig, PoseEstimator};
use airglyph_synth::{
    Background, BodySpec, Chair, DrawSpec, MakeHumanShape, MotionSpec, Mug, Placement, Posture,
    ProceduralBody, Prop, SceneConfig, Synthesizer, Table,
};
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// One row of the table: a scene and whether any setting was chosen on it.
struct Kind {
    name: &'static str,
    scene: SceneConfig,
    held_out: bool,
}

const UPPER: [Joint; 8] = [
    Joint::Head,
    Joint::Neck,
    Joint::LeftShoulder,
    Joint::RightShoulder,
    Joint::LeftElbow,
    Joint::RightElbow,
    Joint::LeftHand,
    Joint::RightHand,
];

fn bvh(name: &str) -> PathBuf {
    PathBuf::from("/usr/share/assimp/models/BVH").join(name)
}

fn draw(symbols: &str) -> MotionSpec {
    MotionSpec::Draw(DrawSpec {
        symbols: symbols.into(),
        samples: None,
        repeat: false,
        rest: None,
    })
}

fn kinds() -> Vec<Kind> {
    let mh = BodySpec::MakeHuman {
        assets: None,
        shape: Default::default(),
    };
    let base = |body: &BodySpec, motion: MotionSpec, distance_m: f32| SceneConfig {
        body: body.clone(),
        motion,
        background: Background::FloorAndWall,
        placement: Placement {
            distance_m,
            ..Placement::default()
        },
        ..SceneConfig::default()
    };
    // A body that does not load (no asset cache) is left unframed: its rows are then
    // skipped, saying why.
    let near = |cfg: SceneConfig| {
        let framed = SceneConfig {
            background: Background::Room,
            ..cfg
        };
        framed.clone().framing_upper_body().unwrap_or(framed)
    };
    let seated = |cfg: SceneConfig, table: bool| {
        let chair = Chair::default();
        let mut props = vec![Prop::Chair(chair)];
        if table {
            props.push(Prop::Table(Table::default()));
        }
        SceneConfig {
            posture: Posture::Seated {
                seat_height_m: chair.seat_height_m,
            },
            props,
            ..cfg
        }
    };
    let with_mug = |mut cfg: SceneConfig| {
        cfg.props.push(Prop::Mug(Mug::default()));
        cfg
    };
    let follow = |mut cfg: SceneConfig| {
        cfg.placement.follow = true;
        cfg
    };
    let short = BodySpec::Procedural(ProceduralBody {
        height_m: 1.58,
        build: 0.85,
    });
    let tall = BodySpec::Procedural(ProceduralBody {
        height_m: 1.92,
        build: 1.25,
    });
    // MakeHuman bodies of other shapes (MakeHuman's macro sliders, see
    // airglyph_synth::makehuman::shape); rows skipped when the cache lacks the targets.
    let mh_shape = |text: &str| BodySpec::MakeHuman {
        assets: None,
        shape: MakeHumanShape::parse(text).expect("a shape"),
    };
    let woman = mh_shape("gender=0,height=0.45");
    let heavy_man = mh_shape("gender=1,weight=0.95,muscle=0.4,age=0.6");
    let tall_thin_man = mh_shape("gender=1,height=0.7,weight=0.15,muscle=0.4");
    let older_short_woman = mh_shape("gender=0,age=0.85,height=0.3,weight=0.7");
    let seeded = |mut cfg: SceneConfig, seed: u64| {
        cfg.seed = seed;
        cfg
    };
    vec![
        Kind {
            name: "standing-far (CMU 01_01)",
            scene: follow(base(&mh, MotionSpec::Bvh(bvh("01_01.bvh")), 2.7)),
            held_out: false,
        },
        Kind {
            name: "side-on (CMU 01_03)",
            scene: follow(base(&mh, MotionSpec::Bvh(bvh("01_03.bvh")), 2.7)),
            held_out: false,
        },
        Kind {
            name: "fast (boxing)",
            scene: follow(base(&mh, MotionSpec::Bvh(bvh("Boxing_Toes.bvh")), 2.7)),
            held_out: true,
        },
        Kind {
            name: "close-upper (1.2 m, drawing)",
            scene: near(base(&mh, draw("0123456789"), 1.2)),
            held_out: false,
        },
        Kind {
            name: "close-rest (1.0 m, arms at rest)",
            scene: near(base(&mh, MotionSpec::Rest, 1.0)),
            held_out: false,
        },
        Kind {
            name: "seated-desk (1.4 m, drawing)",
            scene: near(seated(base(&mh, draw("ABCDEFGHIJ"), 1.4), true)),
            held_out: false,
        },
        Kind {
            name: "seated-rest (1.2 m, no table)",
            scene: near(seated(base(&mh, MotionSpec::Rest, 1.2), false)),
            held_out: false,
        },
        Kind {
            name: "seated-rest by a mug (1.4 m, table)",
            scene: near(with_mug(seated(base(&mh, MotionSpec::Rest, 1.4), true))),
            held_out: true,
        },
        Kind {
            name: "far-rest (3.6 m)",
            scene: base(&mh, MotionSpec::Rest, 3.6),
            held_out: false,
        },
        Kind {
            name: "close-upper short body (0.9 m)",
            scene: near(seeded(base(&short, draw("KLMNOPQRST"), 0.9), 11)),
            held_out: true,
        },
        Kind {
            name: "seated-desk tall body (1.6 m)",
            scene: near(seeded(
                seated(base(&tall, draw("UVWXYZ2468"), 1.6), true),
                12,
            )),
            held_out: true,
        },
        Kind {
            name: "close-rest tall body (1.5 m)",
            scene: near(seeded(base(&tall, MotionSpec::Rest, 1.5), 13)),
            held_out: true,
        },
        Kind {
            name: "seated-rest short body (1.0 m)",
            scene: near(seeded(
                seated(base(&short, MotionSpec::Rest, 1.0), false),
                14,
            )),
            held_out: true,
        },
        Kind {
            name: "close-upper woman (1.2 m, drawing)",
            scene: near(seeded(base(&woman, draw("97531ZXVTR"), 1.2), 21)),
            held_out: true,
        },
        Kind {
            name: "close-rest heavy man (1.3 m)",
            scene: near(seeded(base(&heavy_man, MotionSpec::Rest, 1.3), 22)),
            held_out: true,
        },
        Kind {
            name: "seated-desk tall thin man (1.5 m, drawing)",
            scene: near(seeded(
                seated(base(&tall_thin_man, draw("SQOMKIGECA"), 1.5), true),
                23,
            )),
            held_out: true,
        },
        Kind {
            name: "seated-rest at a table heavy man (1.6 m)",
            scene: near(seeded(
                seated(base(&heavy_man, MotionSpec::Rest, 1.6), true),
                25,
            )),
            held_out: true,
        },
        Kind {
            name: "seated-rest older short woman (1.1 m, no table)",
            scene: near(seeded(
                seated(base(&older_short_woman, MotionSpec::Rest, 1.1), false),
                24,
            )),
            held_out: true,
        },
    ]
}

/// Frames of endless motion (arms at rest) scored.
const ENDLESS_FRAMES: usize = 450;

struct Row {
    name: String,
    noise: bool,
    held_out: bool,
    summary: Summary,
    px_upper: f64,
    /// The same by joint, as real frames are scored against Skeltrack's.
    px_by_joint: [Option<f64>; UPPER.len()],
    at_rest_cm: Option<f64>,
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut pcfg = PoseConfig::default();
    support::apply_sets(&mut pcfg, &args);
    let max_frames = args
        .iter()
        .find_map(|a| a.strip_prefix("frames:"))
        .map(|n| n.parse::<usize>().expect("frames:N"));
    let json = args.iter().find_map(|a| a.strip_prefix("json:"));
    let overlays = args.iter().find_map(|a| a.strip_prefix("overlays:"));
    let single = args.iter().any(|a| a == "single");
    let every = args
        .iter()
        .find_map(|a| a.strip_prefix("every:"))
        .map_or(1, |n| n.parse::<usize>().expect("every:N").max(1));
    // seeds:+K: every row's seed moved by K (another draw of the same scene: motion,
    // noise), to tell a change's effect from one first frame's luck.
    let seed_shift = args
        .iter()
        .find_map(|a| a.strip_prefix("seeds:+"))
        .map_or(0, |n| n.parse::<u64>().expect("seeds:+K"));
    let filters: Vec<&String> = args
        .iter()
        .filter(|a| !a.contains(':') && *a != "single")
        .collect();
    let mut json = json.map(|f| std::fs::File::create(f).expect("json file"));
    let mut rows = Vec::new();
    for kind in kinds() {
        if !filters.is_empty() && !filters.iter().any(|f| kind.name.starts_with(f.as_str())) {
            continue;
        }
        for noise in [false, true] {
            let scene = SceneConfig {
                sensor_noise: noise,
                seed: kind.scene.seed + seed_shift,
                ..kind.scene.clone()
            };
            let mut synth = match Synthesizer::new(scene) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("{}: skipped: {e}", kind.name);
                    continue;
                }
            };
            let n = synth.len().unwrap_or(ENDLESS_FRAMES);
            let n = max_frames.map_or(n, |m| n.min(m));
            let how = Run {
                frames: n,
                every,
                single,
            };
            let row = run(&kind, noise, &mut synth, how, &pcfg, overlays);
            print_row(&row);
            if let Some(f) = json.as_mut() {
                let mut v = serde_json::to_value(&row.summary).expect("a summary");
                v["scene"] = row.name.clone().into();
                v["noise"] = row.noise.into();
                v["held_out"] = row.held_out.into();
                v["px_upper"] = row.px_upper.into();
                v["px_by_joint"] = UPPER
                    .iter()
                    .zip(&row.px_by_joint)
                    .map(|(j, px)| (j.name().to_string(), serde_json::json!(px)))
                    .collect::<serde_json::Map<_, _>>()
                    .into();
                v["at_rest_cm"] = row.at_rest_cm.into();
                writeln!(f, "{v}").expect("json written");
            }
            rows.push(row);
        }
    }
    println!();
    print_table(&rows);
}

/// Which frames are estimated and scored, and how.
struct Run {
    frames: usize,
    every: usize,
    /// Every frame estimated afresh.
    single: bool,
}

fn run(
    kind: &Kind,
    noise: bool,
    synth: &mut Synthesizer,
    how: Run,
    pcfg: &PoseConfig,
    overlays: Option<&str>,
) -> Row {
    let k = synth.intrinsics();
    let mut est = PoseEstimator::new(k, pcfg.clone());
    let mut ev = PoseEval::default();
    let mut px_by_joint = [(0.0f64, 0usize); UPPER.len()];
    let (mut rest_sum, mut rest_n) = (0.0f64, 0usize);
    let scale = 640.0 / k.width as f64;
    for i in (0..how.frames).step_by(if how.single { how.every } else { 1 }) {
        let (img, truth) = synth.render(i);
        if how.single {
            est = PoseEstimator::new(k, pcfg.clone());
        }
        let t = Instant::now();
        let r = est.estimate(img.view());
        if i % how.every != 0 {
            continue;
        }
        ev.seconds += t.elapsed().as_secs_f64();
        let fe = ev.add(&r, &truth.skeleton, &k);
        if r.person_found {
            for (j, (sum, n)) in UPPER.iter().zip(&mut px_by_joint) {
                if let Some(d) = pixel_distance(&k, &truth.skeleton, &r.skeleton, *j) {
                    *sum += d * scale;
                    *n += 1;
                }
            }
            // At rest: neither drawing nor moving the hand about (the rest motion,
            // or the drawing's frames between symbols with the hand low).
            if truth.gesture.is_none() && hands_low(&truth.skeleton) {
                rest_sum += fe.mean() as f64;
                rest_n += 1;
            }
        }
        if let Some(dir) = overlays {
            if i % (30 * how.every) == 0 {
                let slug: String = kind
                    .name
                    .chars()
                    .map(|c| if c.is_alphanumeric() { c } else { '_' })
                    .collect();
                let dir = PathBuf::from(dir);
                std::fs::create_dir_all(&dir).expect("overlay dir");
                let mut im = overlay::depth_image(&img.view(), Some(est.mask()));
                overlay::skeleton(&mut im, &k, &truth.skeleton, overlay::GREEN);
                if r.person_found {
                    overlay::skeleton(&mut im, &k, &r.skeleton, overlay::RED);
                }
                im.save(dir.join(format!("{slug}_{}_{i:05}.png", u8::from(noise))))
                    .expect("overlay written");
            }
        }
    }
    Row {
        name: kind.name.to_string(),
        noise,
        held_out: kind.held_out,
        summary: ev.summary(),
        px_upper: {
            let (sum, n) = px_by_joint
                .iter()
                .fold((0.0, 0), |(s, n), (js, jn)| (s + js, n + jn));
            sum / n.max(1) as f64
        },
        px_by_joint: px_by_joint.map(|(sum, n)| (n > 0).then(|| sum / n as f64)),
        at_rest_cm: (rest_n > 0).then(|| rest_sum / rest_n as f64 * 100.0),
    }
}

/// Both hands below the elbows: arms hanging or resting, not drawing.
fn hands_low(s: &Skeleton) -> bool {
    // Camera frame: y grows down.
    s.get(Joint::LeftHand).y > s.get(Joint::LeftElbow).y
        && s.get(Joint::RightHand).y > s.get(Joint::RightElbow).y
}

/// Image distance between the truth's and the estimate's joint, when the truth has it
/// in view.
fn pixel_distance(
    k: &airglyph_core::Intrinsics,
    truth: &Skeleton,
    est: &Skeleton,
    j: Joint,
) -> Option<f64> {
    if !truth.visible[j.index()] {
        return None;
    }
    let (a, b) = (k.project(&truth.get(j))?, k.project(&est.get(j))?);
    Some(((a.0 - b.0) as f64).hypot((a.1 - b.1) as f64))
}

fn worst(s: &Summary) -> (String, f64) {
    s.per_joint_cm
        .iter()
        .filter_map(|(j, e)| e.map(|e| (j.clone(), e)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or_default()
}

fn print_row(r: &Row) {
    let (wj, we) = worst(&r.summary);
    eprintln!(
        "{}{}: e_m {:.2} cm, worst {wj} {we:.1} cm, {:.1} % within 10 cm, 2-D {:.1} px, out of view reported {}, lower hidden frames {}, visible outside {}",
        r.name,
        if r.noise { " + sensor" } else { "" },
        r.summary.mean_error_cm,
        r.summary.within_10cm * 100.0,
        r.px_upper,
        r.summary
            .out_of_view_reported
            .map_or("-".into(), |v| format!("{:.1} %", v * 100.0)),
        r.summary
            .lower_hidden_frames
            .map_or("-".into(), |v| format!("{:.1} %", v * 100.0)),
        r.summary.visible_outside_image
    );
}

fn print_table(rows: &[Row]) {
    println!("| scene | sensor | frames | e_m (cm) | whole-body e_m | worst joint (e_j) | within 10 cm | 2-D, 8 joints | at rest e_m | out of view reported hidden | frames with lower joints all reported hidden | visible outside image |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let s = &r.summary;
        let (wj, we) = worst(s);
        println!(
            "| {}{} | {} | {} | {:.2} | {} | {wj} {we:.1} | {:.1} % | {:.1} px | {} | {} | {} | {} |",
            r.name,
            if r.held_out { " (held out)" } else { "" },
            if r.noise { "yes" } else { "no" },
            s.frames,
            s.mean_error_cm,
            s.mean_error_whole_cm
                .map_or("-".into(), |e| format!("{e:.2} ({})", s.frames_whole)),
            s.within_10cm * 100.0,
            r.px_upper,
            r.at_rest_cm.map_or("-".into(), |e| format!("{e:.2}")),
            s.out_of_view_reported
                .map_or("-".into(), |v| format!("{:.1} %", v * 100.0)),
            s.lower_hidden_frames
                .map_or("-".into(), |v| format!("{:.1} %", v * 100.0)),
            s.visible_outside_image,
        );
    }
}
