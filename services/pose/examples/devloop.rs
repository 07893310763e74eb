//! Development loop: renders a synthetic scene, estimates every frame, prints the
//! figures and writes overlays (green = truth, red = estimate).
//!
//! `cargo run --release -p airglyph-pose --example devloop -- [pose:NAME|bvh:FILE|draw:SYMBOLS]
//!  [mh|mhshape:SLIDERS|proc:HEIGHT,BUILD] [seed:N] [follow] [noise] [floor|room] [seated] [table] [mug]
//!  [upper] [partial] [single] [qvga] [lateral:M] [dist:M] [yaw:DEG] [frames] [oracle|oracle-only]
//!  [overlays:DIR] [from:N] [every:N] [set:FIELD=VALUE]`; with `SERIES=FILE` a line a frame,
//!  `DUMP=FILE` the joints, `TORSO=1` the torso step's error each frame, `HIDDENDBG=1` each
//!  joint out of view but reported visible (its confidence, where the estimate and the
//!  truth project).
#![allow(clippy::needless_range_loop)]

mod support;

use airglyph_core::{Intrinsics, Joint};
use airglyph_pose::metrics::PoseEval;
use airglyph_pose::{overlay, OfferedStart, PoseConfig, PoseEstimator};
use airglyph_synth::{Background, MotionSpec, SceneConfig, ScriptedPose, Synthesizer};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut cfg = SceneConfig::default();
    let mut frames = 60usize;
    let mut out: Option<String> = None;
    let mut every = 10usize;
    let mut from = 0usize;
    // oracle: the true pose also raced each frame; oracle-only: the only start.
    let mut oracle: Option<fn(airglyph_core::Skeleton) -> OfferedStart> = None;
    // upper: framed from the waist up; partial: frames without the whole body scored too.
    // single: every frame estimated afresh, without history.
    let (mut upper, mut partial, mut single) = (false, false, false);
    for a in &args {
        if let Some(f) = a.strip_prefix("bvh:") {
            cfg.motion = MotionSpec::Bvh(f.into());
        } else if let Some(p) = a.strip_prefix("pose:") {
            let p = ScriptedPose::ALL
                .into_iter()
                .find(|x| format!("{x:?}").eq_ignore_ascii_case(p))
                .expect("pose name");
            cfg.motion = MotionSpec::Pose(p);
        } else if a == "rest" || a == "poses" {
            cfg.motion = MotionSpec::parse(a, None, false).expect("a motion");
        } else if a.starts_with("draw:") {
            cfg.motion = MotionSpec::parse(a, None, false).expect("draw spec");
        } else if a == "mh" {
            cfg.body = airglyph_synth::BodySpec::MakeHuman {
                assets: None,
                shape: Default::default(),
            };
        } else if let Some(text) = a.strip_prefix("mhshape:") {
            cfg.body = airglyph_synth::BodySpec::MakeHuman {
                assets: None,
                shape: airglyph_synth::MakeHumanShape::parse(text).expect("a shape"),
            };
        } else if let Some(hb) = a.strip_prefix("proc:") {
            let (h, b) = hb.split_once(',').expect("proc:HEIGHT,BUILD");
            cfg.body = airglyph_synth::BodySpec::Procedural(airglyph_synth::ProceduralBody {
                height_m: h.parse().expect("a height"),
                build: b.parse().expect("a build"),
            });
        } else if let Some(n) = a.strip_prefix("seed:") {
            cfg.seed = n.parse().expect("a seed");
        } else if a == "follow" {
            cfg.placement.follow = true;
        } else if a == "noise" {
            cfg.sensor_noise = true;
        } else if a == "floor" {
            cfg.background = Background::FloorAndWall;
        } else if a == "room" {
            cfg.background = Background::Room;
        } else if a == "seated" {
            let chair = airglyph_synth::Chair::default();
            cfg.props.push(airglyph_synth::Prop::Chair(chair));
            cfg.posture = airglyph_synth::Posture::Seated {
                seat_height_m: chair.seat_height_m,
            };
        } else if a == "table" {
            cfg.props
                .push(airglyph_synth::Prop::Table(airglyph_synth::Table::default()));
        } else if a == "mug" {
            cfg.props
                .push(airglyph_synth::Prop::Mug(airglyph_synth::Mug::default()));
        } else if a == "upper" {
            upper = true;
        } else if a == "partial" {
            partial = true;
        } else if a == "single" {
            single = true;
        } else if a == "qvga" {
            cfg.intrinsics = Intrinsics::default().scaled_to(320, 240);
        } else if let Some(d) = a.strip_prefix("overlays:") {
            out = Some(d.to_string());
        } else if let Some(y) = a.strip_prefix("yaw:") {
            cfg.placement.yaw_deg = y.parse().unwrap();
        } else if let Some(x) = a.strip_prefix("lateral:") {
            cfg.placement.lateral_m = x.parse().unwrap();
        } else if let Some(y) = a.strip_prefix("dist:") {
            cfg.placement.distance_m = y.parse().unwrap();
        } else if a == "oracle" {
            oracle = Some(OfferedStart::Also);
        } else if a == "oracle-only" {
            oracle = Some(OfferedStart::Only);
        } else if let Some(n) = a.strip_prefix("from:") {
            from = n.parse().unwrap();
        } else if let Some(n) = a.strip_prefix("every:") {
            every = n.parse().unwrap();
        } else if let Ok(n) = a.parse() {
            frames = n;
        }
    }
    if upper {
        cfg = cfg.framing_upper_body().expect("the body loads");
    }
    let mut synth = Synthesizer::new(cfg).expect("scene");
    let k = synth.intrinsics();
    let n = synth.len().map_or(frames, |l| l.min(frames));
    let mut pcfg = PoseConfig::default();
    support::apply_sets(&mut pcfg, &args);
    for a in &args {
        if let Some(f) = a.strip_prefix("shape:") {
            let text = std::fs::read_to_string(f).expect("shape file");
            pcfg.register.shape = serde_json::from_str(&text).expect("a Shape");
        }
    }
    let pcfg_torso = pcfg.torso.clone();
    let mut est = PoseEstimator::new(k, pcfg);
    let mut ev = PoseEval::default();
    if let Some(d) = &out {
        std::fs::create_dir_all(d).unwrap();
    }
    let mut local = [nalgebra::Vector3::<f32>::zeros(); Joint::COUNT];
    let mut nlocal = [0f32; Joint::COUNT];
    let mut cpu = 0.0f64;
    let mut steps = [0.0f64; 6];
    let (mut npass, mut npts, mut nrace) = (0usize, 0usize, 0usize);
    let mut ncpu = 0usize;
    let mut bias = [nalgebra::Vector3::<f32>::zeros(); Joint::COUNT];
    let mut neck_rows: Vec<(f32, f32, f32, f32)> = Vec::new();
    // Per joint: frames it was hidden, and of those the frames it was reported visible.
    let mut hidden = [(0usize, 0usize); Joint::COUNT];
    let mut series = std::env::var("SERIES")
        .ok()
        .map(|f| std::io::BufWriter::new(std::fs::File::create(f).unwrap()));
    // DUMP_JOINT=NAME: the joint DUMP's rows start with (default the right hand).
    let dump_first = std::env::var("DUMP_JOINT")
        .ok()
        .and_then(|n| Joint::ALL.into_iter().find(|j| j.name() == n))
        .unwrap_or(Joint::RightHand);
    let mut dump = std::env::var("DUMP")
        .ok()
        .map(|f| std::io::BufWriter::new(std::fs::File::create(f).unwrap()));
    let (mut vis_err, mut vis_n, mut vis_far) = ([0.0f64; 2], [0usize; 2], [0usize; 2]);
    let mut tdiff = [nalgebra::Vector3::<f32>::zeros(); Joint::COUNT];
    let mut tn = [0f32; Joint::COUNT];
    for i in 0..n {
        let (img, truth) = synth.render(i);
        if std::env::var("PROBE").is_ok() {
            probe(&img, 320);
            probe(&img, 300);
        }
        let t = Instant::now();
        let c0 = cpu_seconds();
        if single {
            est.reset();
        }
        if let Some(offer) = oracle {
            est.offer_start(offer(truth.skeleton));
        }
        let r = est.estimate(img.view());
        let c1 = cpu_seconds();
        if !partial && !airglyph_pose::metrics::in_view(&truth.skeleton, &k) {
            continue;
        }
        ev.seconds += t.elapsed().as_secs_f64();
        cpu += c1 - c0;
        ncpu += 1;
        npass += est.debug().register_passes;
        nrace += usize::from(est.debug().raced);
        npts += est.debug().register_points;
        let st = est.step_times();
        for (a, b) in steps.iter_mut().zip([
            st.segment,
            st.torso,
            st.graph,
            st.geodesic,
            st.limbs,
            st.register,
        ]) {
            *a += b;
        }
        let fe = ev.add(&r, &truth.skeleton, &k);
        // Joints out of view count as no error here (`partial` frames).
        let err = fe.joint.map(|e| e.unwrap_or(0.0));
        for j in 0..Joint::COUNT {
            let k = usize::from(!truth.visible[j]);
            vis_err[k] += err[j] as f64;
            vis_n[k] += 1;
            if err[j] >= 0.1 {
                vis_far[k] += 1;
            }
        }
        if let Some(f) = &mut series {
            use std::io::Write;
            let worst = (0..Joint::COUNT)
                .max_by(|&a, &b| err[a].total_cmp(&err[b]))
                .unwrap_or(0);
            writeln!(
                f,
                "{i} {:.2} {:.2} {} {} {:.3}",
                fe.mean() * 100.0,
                fe.max() * 100.0,
                Joint::ALL[worst].name(),
                u8::from(est.debug().raced),
                est.debug().register_energy * 1e4
            )
            .unwrap();
        }
        if std::env::var("TORSO").is_ok() {
            if let Some(tp) = est.debug().torso_pose {
                let kp = pcfg_torso
                    .keypoints
                    .map(|[x, y, z]| tp.apply(&nalgebra::Point3::new(x, y, z)));
                let e = |p: nalgebra::Point3<f32>, j: Joint| (p - truth.skeleton[j]).norm() * 100.0;
                println!(
                    "TORSO {i} reinit {} res {:.1} neck {:.0} ls {:.0} rs {:.0} torso {:.0}",
                    est.debug().torso_reinit,
                    est.debug().torso_residual * 100.0,
                    e(kp.neck, Joint::Neck),
                    e(kp.left_shoulder, Joint::LeftShoulder),
                    e(kp.right_shoulder, Joint::RightShoulder),
                    e(kp.torso, Joint::Torso)
                );
                // The fit's error in its own frame (left, up, forward), cm, and its tilt.
                let d = tp.r.inverse() * (kp.neck - truth.skeleton[Joint::Neck]) * 100.0;
                let tup = (truth.skeleton[Joint::Neck] - truth.skeleton[Joint::Pelvis]).normalize();
                let tl = (truth.skeleton[Joint::LeftShoulder]
                    - truth.skeleton[Joint::RightShoulder])
                    .normalize();
                let up = tp.r * nalgebra::Vector3::y();
                let left = tp.r * nalgebra::Vector3::x();
                println!(
                    "  neck off (l,u,f) ({:.0} {:.0} {:.0}) up off {:.0} deg left off {:.0} deg",
                    d.x,
                    d.y,
                    d.z,
                    up.angle(&tup).to_degrees(),
                    left.angle(&tl).to_degrees()
                );
            }
        }
        if let Some(d) = &mut dump {
            use std::io::Write;
            let g = est.debug().geodesic.unwrap_or(r.skeleton);
            let mut row = format!("{i}");
            for s in [&truth.skeleton, &r.skeleton, &g] {
                for j in [
                    dump_first,
                    Joint::LeftShoulder,
                    Joint::RightShoulder,
                    Joint::RightElbow,
                    Joint::Neck,
                    Joint::Pelvis,
                ] {
                    row += &format!(",{:.4},{:.4},{:.4}", s[j].x, s[j].y, s[j].z);
                }
            }
            for j in [dump_first, Joint::LeftShoulder, Joint::Neck, Joint::Pelvis] {
                row += &format!(",{:.3}", r.skeleton.confidence[j.index()]);
            }
            writeln!(d, "{row}").unwrap();
        }
        if let Some((bp, tpl)) = &est.debug().body {
            let posed = airglyph_pose::body::Posed::new(tpl, bp);
            for j in Joint::ALL {
                let (seg, local) = tpl.joints[j.index()];
                let g = posed.rotation[seg.index()].inverse()
                    * (truth.skeleton[j] - posed.joint[seg.index()]);
                tdiff[j.index()] += g - local.coords;
                tn[j.index()] += 1.0;
            }
        }
        // The outline's neck base against the true neck and the estimate's, along the
        // torso's up (cm; positive: the base lies above).
        if let (Some(nb), Some(tp)) = (&est.debug().neck_base, est.debug().torso_pose) {
            let up = tp.r * nalgebra::Vector3::y();
            let along = |j: Joint, s: &airglyph_core::Skeleton| (nb.point - s[j]).dot(&up) * 100.0;
            neck_rows.push((
                along(Joint::Neck, &truth.skeleton),
                along(Joint::Neck, &r.skeleton),
                nb.head_width,
                nb.neck_width,
            ));
        }
        if let (true, Some(tp)) = (r.person_found, est.debug().torso_pose) {
            let inv = tp.inverse();
            for j in 0..Joint::COUNT {
                local[j] += inv.apply(&truth.skeleton.joints[j]).coords;
                nlocal[j] += 1.0;
            }
            for j in 0..Joint::COUNT {
                bias[j] += (r.skeleton.joints[j] - truth.skeleton.joints[j]) / n as f32;
                if !truth.skeleton.visible[j] {
                    hidden[j].0 += 1;
                    hidden[j].1 += usize::from(r.skeleton.visible[j]);
                    if r.skeleton.visible[j] && std::env::var_os("HIDDENDBG").is_some() {
                        let (e, t) = (r.skeleton.joints[j], truth.skeleton.joints[j]);
                        eprintln!(
                            "frame {i} {:?} shown: conf {:.2} est {:.2?} px {:?} truth {:.2?} px {:?}",
                            Joint::ALL[j],
                            r.skeleton.confidence[j],
                            e.coords.as_slice(),
                            k.project(&e),
                            t.coords.as_slice(),
                            k.project(&t)
                        );
                    }
                }
            }
        }
        if let Some(d) = &out {
            if i >= from && i % every == 0 {
                let mut im = overlay::depth_image(&img.view(), Some(est.mask()));
                // CLEAN=1: the truth and the estimate only (for pictures in the docs).
                if std::env::var("CLEAN").is_ok() {
                    overlay::skeleton(&mut im, &k, &truth.skeleton, overlay::GREEN);
                    overlay::skeleton(&mut im, &k, &r.skeleton, overlay::RED);
                    im.save(format!("{d}/{i:04}.png")).unwrap();
                    continue;
                }
                overlay::skeleton(&mut im, &k, &truth.skeleton, overlay::GREEN);
                if let Some(g) = &est.debug().geodesic {
                    overlay::skeleton(&mut im, &k, g, [255, 160, 0]);
                }
                if r.person_found {
                    overlay::skeleton(&mut im, &k, &r.skeleton, overlay::RED);
                }
                for l in 0..5 {
                    for p in est.debug().targets[l].iter().step_by(7) {
                        if let Some(q) = k.project(p) {
                            overlay::dot(&mut im, q, 0, overlay::YELLOW);
                        }
                    }
                }
                let palette = [
                    [255u8, 0, 255],
                    [0, 255, 255],
                    [255, 255, 0],
                    [255, 128, 0],
                    [0, 255, 0],
                    [255, 255, 255],
                    [128, 128, 255],
                    [255, 0, 0],
                ];
                let only: Option<usize> =
                    std::env::var("PATH_OF").ok().and_then(|v| v.parse().ok());
                for (pi, path) in est.debug().paths.iter().enumerate() {
                    if only.is_some_and(|o| o != pi) {
                        continue;
                    }
                    let ww = est.debug().work_size.0.max(1);
                    let f = (k.width / ww) as f32;
                    for &px in path.iter() {
                        let (u, v) = ((px % ww) as f32 * f, (px / ww) as f32 * f);
                        overlay::dot(&mut im, (u, v), 1, palette[pi % palette.len()]);
                    }
                }
                for &m in &est.debug().maxima {
                    let ww = est.debug().work_size.0.max(1);
                    let f = (k.width / ww) as f32;
                    let (u, v) = ((m % ww) as f32 * f, (m / ww) as f32 * f);
                    overlay::dot(&mut im, (u, v), 4, overlay::BLUE);
                }
                im.save(format!("{d}/{i:04}.png")).unwrap();
                eprintln!(
                    "frame {i}: e_m {:.1} cm e_h {:.1} cm maxima {} assign {:?} torso res {:.3} reinit {} joins {} bridges {}",
                    fe.mean() * 100.0,
                    fe.max() * 100.0,
                    est.debug().maxima.len(),
                    est.debug().assignment,
                    est.debug().torso_residual,
                    est.debug().torso_reinit,
                    est.debug().joins,
                    est.debug().bridges,
                );
                eprintln!("  maxima dist {:?}", est.debug().maxima_dist);
                let ww = est.debug().work_size.0.max(1);
                let f = k.width / ww;
                eprintln!(
                    "  maxima at {:?}",
                    est.debug()
                        .maxima
                        .iter()
                        .map(|m| ((m % ww) * f, (m / ww) * f))
                        .collect::<Vec<_>>()
                );
                eprintln!(
                    "  targets {:?}",
                    est.debug()
                        .targets
                        .iter()
                        .map(|t| t.len())
                        .collect::<Vec<_>>()
                );
                let show = match std::env::var("SHOW").as_deref() {
                    Ok("right_arm") => [Joint::RightShoulder, Joint::RightElbow, Joint::RightHand],
                    Ok("left_arm") => [Joint::LeftShoulder, Joint::LeftElbow, Joint::LeftHand],
                    Ok("head") => [Joint::Neck, Joint::Head, Joint::Torso],
                    _ => [Joint::LeftHip, Joint::LeftKnee, Joint::LeftFoot],
                };
                for j in show {
                    eprintln!(
                        "  {j:?} est {:?} truth {:?}",
                        r.skeleton[j].coords.as_slice(),
                        truth.skeleton[j].coords.as_slice()
                    );
                }
                for row in &est.debug().cost {
                    eprintln!("  cost {row:?}");
                }
            }
        }
    }
    for j in Joint::ALL {
        let d = tdiff[j.index()] / tn[j.index()].max(1.0) * 100.0;
        eprintln!(
            "truth - template, segment frame, {:15} ({:6.2} {:6.2} {:6.2}) cm",
            j.name(),
            d.x,
            d.y,
            d.z
        );
    }
    let shown: Vec<String> = Joint::ALL
        .iter()
        .filter(|j| hidden[j.index()].1 > 0)
        .map(|j| {
            format!(
                "{} {}/{}",
                j.name(),
                hidden[j.index()].1,
                hidden[j.index()].0
            )
        })
        .collect();
    eprintln!("hidden but reported visible: {}", shown.join(", "));
    eprintln!(
        "visible joints: {} mean {:.2} cm, {:.1} % beyond 10 cm; hidden: {} mean {:.2} cm, {:.1} % beyond",
        vis_n[0],
        vis_err[0] / vis_n[0].max(1) as f64 * 100.0,
        vis_far[0] as f64 / vis_n[0].max(1) as f64 * 100.0,
        vis_n[1],
        vis_err[1] / vis_n[1].max(1) as f64 * 100.0,
        vis_far[1] as f64 / vis_n[1].max(1) as f64 * 100.0
    );
    let s = ev.summary();
    println!("{}", serde_json::to_string(&s).unwrap());
    {
        let mut line = String::from("beyond 10 cm:");
        for j in Joint::ALL {
            let n = ev
                .frames
                .iter()
                .filter(|f| f.joint[j.index()].is_none_or(|e| e >= 0.10))
                .count();
            line += &format!(
                " {} {:.1}%",
                j.name(),
                n as f64 / ev.frames.len().max(1) as f64 * 100.0
            );
        }
        println!("{line}");
        // Frames with any joint beyond 20 cm, as runs.
        let bad: Vec<usize> = ev
            .frames
            .iter()
            .enumerate()
            .filter(|(_, f)| f.max() >= 0.2)
            .map(|(i, _)| i)
            .collect();
        println!(
            "frames (in view) with a joint beyond 20 cm: {} {:?}",
            bad.len(),
            &bad[..bad.len().min(40)]
        );
    }
    if !neck_rows.is_empty() {
        let m = |f: fn(&(f32, f32, f32, f32)) -> f32| {
            let mut v: Vec<f32> = neck_rows.iter().map(f).collect();
            v.sort_by(f32::total_cmp);
            let mean = v.iter().sum::<f32>() / v.len() as f32;
            (mean, v[v.len() / 10], v[v.len() / 2], v[v.len() * 9 / 10])
        };
        println!(
            "neck base in {} frames: over the true neck {:?}, over the estimate's {:?}, head width {:?}, neck width {:?} (mean, p10, median, p90)",
            neck_rows.len(),
            m(|r| r.0),
            m(|r| r.1),
            m(|r| r.2),
            m(|r| r.3)
        );
    }
    for j in Joint::ALL {
        let b = bias[j.index()] * 100.0;
        let lo = local[j.index()] / nlocal[j.index()].max(1.0);
        println!("{:15} e_j {:6.2} cm  bias ({:6.2} {:6.2} {:6.2}) cm  truth in torso frame [{:.3}, {:.3}, {:.3}]", j.name(), s.per_joint_cm[j.name()].unwrap_or(f64::NAN), b.x, b.y, b.z, lo.x, lo.y, lo.z);
    }
    eprintln!(
        "thread CPU time per frame {:.3} ms = {:.0} frames/s on one core",
        cpu / ncpu.max(1) as f64 * 1e3,
        ncpu as f64 / cpu.max(1e-9)
    );
    eprintln!("body ratios (arms, legs): {:?}", est.body_ratios());
    eprintln!(
        "registration: {:.0} points, {:.1} passes a frame, raced in {:.0} % of frames",
        npts as f64 / ncpu.max(1) as f64,
        npass as f64 / ncpu.max(1) as f64,
        nrace as f64 / ncpu.max(1) as f64 * 100.0
    );
    eprintln!(
        "mean step ms: segment {:.2} torso {:.2} graph {:.2} geodesic {:.2} limbs {:.2} register {:.2}",
        steps[0] / ncpu.max(1) as f64 * 1e3,
        steps[1] / ncpu.max(1) as f64 * 1e3,
        steps[2] / ncpu.max(1) as f64 * 1e3,
        steps[3] / ncpu.max(1) as f64 * 1e3,
        steps[4] / ncpu.max(1) as f64 * 1e3,
        steps[5] / ncpu.max(1) as f64 * 1e3
    );
    let t = est.step_times();
    eprintln!("last frame steps: {t:?}");
}

#[allow(dead_code)]
pub fn probe(img: &airglyph_core::DepthImage, u: u32) {
    let mut s = String::new();
    for v in (0..img.height()).step_by(4) {
        s += &format!("{} ", img.get(u, v));
    }
    eprintln!("col {u}: {s}");
}

/// CPU time of this thread, seconds (unaffected by other processes on the machine).
fn cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes into the timespec we own.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}
