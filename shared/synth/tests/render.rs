//! Rendering and ground truth on the procedural body (no external file needed).

use airglyph_core::{Intrinsics, Joint};
use airglyph_synth::raster::Raster;
use airglyph_synth::{
    Background, BodySpec, MotionSpec, Placement, ProceduralBody, SceneConfig, ScriptedPose,
    Synthesizer,
};
use nalgebra::{Point3, Vector3};

fn kinect() -> Intrinsics {
    airglyph_core::camera::Preset::KinectV1Vga.intrinsics()
}

#[test]
fn a_plane_renders_to_its_exact_depth() {
    let k = kinect();
    // A tilted plane n·p = d through (0, 0, 2) covering the whole view.
    let n = Vector3::new(0.2, -0.3, -1.0).normalize();
    let p0 = Point3::new(0.0, 0.0, 2.0);
    let d = n.dot(&p0.coords);
    let (e1, e2) = {
        let a = n.cross(&Vector3::x()).normalize();
        (a, n.cross(&a))
    };
    let corners: Vec<Point3<f32>> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|(s, t)| p0 + e1 * (s * 2.5) + e2 * (t * 2.5))
        .collect();
    let mut depth = vec![0u16; (k.width * k.height) as usize];
    Raster::new().rasterize(
        &k,
        &corners,
        &[[0, 1, 2], [0, 2, 3]],
        &[],
        false,
        &mut depth,
        None,
    );
    let mut worst = 0.0f32;
    for v in 0..k.height {
        for u in 0..k.width {
            let ray = Vector3::new((u as f32 - k.cx) / k.fx, (v as f32 - k.cy) / k.fy, 1.0);
            let z = d / n.dot(&ray) * 1000.0;
            let got = depth[(v * k.width + u) as usize];
            assert!(got != 0, "hole at ({u}, {v})");
            worst = worst.max((got as f32 - z).abs());
        }
    }
    assert!(worst < 1.0, "worst error {worst} mm");
}

#[test]
fn a_sphere_renders_within_a_millimetre() {
    let k = kinect();
    let c = Point3::new(0.1, -0.05, 2.0);
    let r = 0.3f32;
    // A finely tessellated UV sphere (chord error ~0.02 mm).
    let (nu, nv) = (400usize, 200usize);
    let mut verts = Vec::new();
    for i in 0..=nv {
        let th = std::f32::consts::PI * i as f32 / nv as f32;
        for j in 0..nu {
            let ph = std::f32::consts::TAU * j as f32 / nu as f32;
            verts.push(c + Vector3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()) * r);
        }
    }
    let mut tris = Vec::new();
    for i in 0..nv as u32 {
        for j in 0..nu as u32 {
            let j1 = (j + 1) % nu as u32;
            let a = i * nu as u32 + j;
            let b = i * nu as u32 + j1;
            let cc = (i + 1) * nu as u32 + j;
            let dd = (i + 1) * nu as u32 + j1;
            tris.push([a, cc, dd]);
            tris.push([a, dd, b]);
        }
    }
    let mut depth = vec![0u16; (k.width * k.height) as usize];
    Raster::new().rasterize(&k, &verts, &tris, &[], false, &mut depth, None);
    let (mut worst, mut checked) = (0.0f32, 0);
    for v in 0..k.height {
        for u in 0..k.width {
            let ray = Vector3::new((u as f32 - k.cx) / k.fx, (v as f32 - k.cy) / k.fy, 1.0);
            // |t·ray - c|² = r²
            let a = ray.norm_squared();
            let b = -2.0 * ray.dot(&c.coords);
            let cc = c.coords.norm_squared() - r * r;
            let disc = b * b - 4.0 * a * cc;
            let got = depth[(v * k.width + u) as usize];
            if disc < 0.0 {
                continue;
            }
            let t = (-b - disc.sqrt()) / (2.0 * a);
            // Away from the silhouette, where the surface is not grazing.
            let p = ray * t;
            let normal = (p - c.coords) / r;
            if normal.dot(&(-ray.normalize())) < 0.3 {
                continue;
            }
            worst = worst.max((got as f32 - t * 1000.0).abs());
            checked += 1;
        }
    }
    assert!(checked > 10_000, "{checked}");
    assert!(worst < 1.0, "worst error {worst} mm");
}

fn scene(pose: ScriptedPose, body: ProceduralBody) -> SceneConfig {
    SceneConfig {
        body: BodySpec::Procedural(body),
        motion: MotionSpec::Pose(pose),
        ..SceneConfig::default()
    }
}

/// Every joint not hidden by another body part projects into the silhouette, with its
/// depth behind the visible surface (joints are centres inside the body).
#[test]
fn visible_joints_lie_inside_the_silhouette_behind_the_surface() {
    for body in [
        ProceduralBody::default(),
        ProceduralBody {
            height_m: 1.5,
            build: 0.8,
        },
        ProceduralBody {
            height_m: 2.0,
            build: 1.4,
        },
    ] {
        for pose in ScriptedPose::ALL {
            let mut synth = Synthesizer::new(scene(pose, body)).unwrap();
            let k = synth.intrinsics();
            let (depth, truth) = synth.render(0);
            let mut seen = 0;
            for j in Joint::ALL {
                let p = truth.skeleton.get(j);
                if !truth.visible[j.index()] {
                    continue;
                }
                seen += 1;
                let (u, v) = k.project(&p).unwrap();
                let d = depth.get(u.round() as u32, v.round() as u32);
                assert!(d > 0, "{pose:?} {body:?}: {j:?} outside the silhouette");
                assert!(
                    (d as f32) < p.z * 1000.0,
                    "{pose:?} {body:?}: {j:?} at {} mm is not behind the surface at {d} mm",
                    p.z * 1000.0
                );
            }
            let min_seen = match pose {
                ScriptedPose::Sideways => 8,
                // The forearms hide the torso joint, one hand lies behind the other arm.
                ScriptedPose::ArmsCrossed => 12,
                _ => 14,
            };
            assert!(seen >= min_seen, "{pose:?}: only {seen} joints visible");
        }
    }
}

#[test]
fn facing_the_camera_every_joint_is_visible() {
    let mut synth =
        Synthesizer::new(scene(ScriptedPose::TPose, ProceduralBody::default())).unwrap();
    let (_, truth) = synth.render(0);
    for j in Joint::ALL {
        assert!(truth.visible[j.index()], "{j:?}");
    }
    // Left is the person's left: on the image's right when they face the camera.
    let k = synth.intrinsics();
    let l = k.project(&truth.skeleton.get(Joint::LeftHand)).unwrap();
    let r = k.project(&truth.skeleton.get(Joint::RightHand)).unwrap();
    assert!(l.0 > r.0);
    // Head above the feet in the image (y down).
    let h = k.project(&truth.skeleton.get(Joint::Head)).unwrap();
    let f = k.project(&truth.skeleton.get(Joint::LeftFoot)).unwrap();
    assert!(h.1 < f.1);
}

#[test]
fn height_parameter_scales_the_skeleton() {
    let tall = Synthesizer::new(scene(
        ScriptedPose::Neutral,
        ProceduralBody {
            height_m: 2.0,
            build: 1.0,
        },
    ))
    .unwrap();
    let short = Synthesizer::new(scene(
        ScriptedPose::Neutral,
        ProceduralBody {
            height_m: 1.5,
            build: 1.0,
        },
    ))
    .unwrap();
    let span = |s: &Synthesizer| {
        let t = s.body().tpose();
        t.joint(Joint::Head).y - t.joint(Joint::LeftFoot).y
    };
    let ratio = span(&tall) / span(&short);
    assert!((ratio - 2.0 / 1.5).abs() < 1e-3, "{ratio}");
}

#[test]
fn frames_are_deterministic_given_the_seed() {
    let cfg = SceneConfig {
        motion: MotionSpec::Poses,
        sensor_noise: true,
        background: Background::FloorAndWall,
        seed: 7,
        ..SceneConfig::default()
    };
    let mut a = Synthesizer::new(cfg.clone()).unwrap();
    let mut b = Synthesizer::new(cfg.clone()).unwrap();
    for i in [0, 17, 50] {
        let (da, ta) = a.render(i);
        let (db, tb) = b.render(i);
        assert_eq!(da, db);
        assert_eq!(ta, tb);
    }
    let mut c = Synthesizer::new(SceneConfig { seed: 8, ..cfg }).unwrap();
    assert_ne!(a.render(3).0, c.render(3).0);
}

#[test]
fn sensor_noise_keeps_depth_close_and_drops_edges() {
    let clean_cfg = scene(ScriptedPose::Neutral, ProceduralBody::default());
    let mut clean = Synthesizer::new(clean_cfg.clone()).unwrap();
    let mut noisy = Synthesizer::new(SceneConfig {
        sensor_noise: true,
        ..clean_cfg
    })
    .unwrap();
    let (c, _) = clean.render(0);
    let (n, _) = noisy.render(0);
    let (mut lost, mut both, mut err) = (0, 0, 0.0f64);
    for (a, b) in c.pixels().iter().zip(n.pixels()) {
        if *a > 0 && *b == 0 {
            lost += 1;
        }
        if *a > 0 && *b > 0 {
            both += 1;
            err += (*a as f64 - *b as f64).abs();
        }
    }
    assert!(lost > 100, "{lost} pixels lost");
    let mean = err / both as f64;
    assert!(mean > 1.0 && mean < 25.0, "mean error {mean} mm");
}

#[test]
fn bad_parameters_are_refused_with_a_reason() {
    let bad_height = scene(
        ScriptedPose::Neutral,
        ProceduralBody {
            height_m: 5.0,
            build: 1.0,
        },
    );
    let e = Synthesizer::new(bad_height).err().unwrap().to_string();
    assert!(e.contains("height"), "{e}");
    let bad_fps = SceneConfig {
        fps: 0.0,
        ..SceneConfig::default()
    };
    assert!(Synthesizer::new(bad_fps)
        .err()
        .unwrap()
        .to_string()
        .contains("fps"));
    let bad_place = SceneConfig {
        placement: Placement {
            distance_m: f32::NAN,
            ..Placement::default()
        },
        ..SceneConfig::default()
    };
    assert!(Synthesizer::new(bad_place).is_err());
    let mut s = Synthesizer::new(SceneConfig::default()).unwrap();
    let e = s.render_into(0, &mut [0u16; 10]).unwrap_err().to_string();
    assert!(e.contains("10 pixels"), "{e}");
}

#[test]
fn a_recording_round_trips_with_ground_truth() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("rec");
    let cfg = SceneConfig {
        intrinsics: airglyph_core::camera::Preset::KinectV1Qvga.intrinsics(),
        ..SceneConfig::default()
    };
    let mut calls = 0;
    let sum = airglyph_synth::write_recording(cfg.clone(), 5, &dir, |_| calls += 1).unwrap();
    assert_eq!((sum.frames, calls), (5, 5));
    let rec = airglyph_core::recording::Recording::open(&dir).unwrap();
    assert_eq!(rec.len(), 5);
    let mut synth = Synthesizer::new(cfg).unwrap();
    let (img, truth) = synth.render(3);
    assert_eq!(rec.read_frame(3).unwrap(), img);
    let j = rec.joints(3).unwrap();
    assert!((j.get(Joint::Head) - truth.skeleton.get(Joint::Head)).norm() < 1e-5);
}
