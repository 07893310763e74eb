//! Time of each step and of the whole estimator at 320×240 and 640×480, on a synthetic
//! person (airglyph-synth, procedural body, waving before floor and wall with sensor noise),
//! and of the whole estimator on a person air-drawing (tracking from frame to frame).
//!
//! The estimator bins frames wider than `PoseConfig::work_width` (320) before it starts,
//! so its 640×480 figure is binning plus the 320×240 work; the steps at 640×480 are timed
//! at full resolution to show what skipping the binning would cost.

use airglyph_core::{DepthImage, Intrinsics};
use airglyph_pose::config::RegisterConfig;
use airglyph_pose::steps::{
    Dijkstra, DistanceTransform, GeoGraph, Graph, Segmentation, Segmenter, TorsoEstimator,
    TorsoStart,
};
use airglyph_pose::{PoseConfig, PoseEstimator};
use airglyph_synth::{Background, MotionSpec, SceneConfig, ScriptedPose, Synthesizer};
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Point3, Vector3};
use std::hint::black_box;
use std::time::Duration;

fn frame(k: Intrinsics) -> DepthImage {
    let cfg = SceneConfig {
        intrinsics: k,
        motion: MotionSpec::Pose(ScriptedPose::Wave),
        background: Background::FloorAndWall,
        sensor_noise: true,
        ..SceneConfig::default()
    };
    Synthesizer::new(cfg).expect("scene").render(0).0
}

/// `n` frames of the procedural person air-drawing before floor and wall, with sensor
/// noise.
fn moving(k: Intrinsics, n: usize) -> Vec<DepthImage> {
    let cfg = SceneConfig {
        intrinsics: k,
        motion: MotionSpec::parse("draw:25", None, false).expect("a drawing"),
        background: Background::FloorAndWall,
        sensor_noise: true,
        ..SceneConfig::default()
    };
    let mut synth = Synthesizer::new(cfg).expect("scene");
    // Skip the approach to the first symbol.
    (30..30 + n).map(|i| synth.render(i).0).collect()
}

fn bench(c: &mut Criterion) {
    for (w, h) in [(320u32, 240u32), (640, 480)] {
        let k = Intrinsics::default().scaled_to(w, h);
        let img = frame(k);
        let cfg = PoseConfig::default();
        let mut g = c.benchmark_group(format!("{w}x{h}"));
        g.measurement_time(Duration::from_secs(3))
            .warm_up_time(Duration::from_millis(500))
            .sample_size(30);

        let mut seg = Segmenter::default();
        let mut points: Vec<Point3<f32>> = Vec::new();
        let mut mask: Vec<bool> = Vec::new();
        let mut run = |last: Option<&Segmentation>| {
            let (floor, centroid) = (last.and_then(|s| s.floor), last.map(|s| s.centroid));
            let bbox = last.map(|s| s.bbox);
            seg.run(
                &img.view(),
                &k,
                &cfg.segment,
                floor,
                centroid,
                bbox,
                &mut points,
                &mut mask,
            )
        };
        g.bench_function("1 segment (whole image)", |b| {
            b.iter(|| black_box(run(None)))
        });
        let s = run(None);
        assert!(s.found);
        g.bench_function("1b segment (around the last frame's person)", |b| {
            b.iter(|| black_box(run(Some(&s))))
        });
        assert!(run(Some(&s)).windowed);
        let (wu, hu) = (w as usize, h as usize);
        let mut dt = DistanceTransform::default();
        let mut dist = Vec::new();
        g.bench_function("2a distance transform", |b| {
            b.iter(|| dt.compute(black_box(&mask), wu, hu, &mut dist))
        });
        let mut torso = TorsoEstimator::new(&cfg.torso);
        let up = -Vector3::y();
        g.bench_function("2 torso (DT + PCA + registration from PCA)", |b| {
            b.iter(|| {
                black_box(torso.fit(&points, &mask, wu, hu, &cfg.torso, TorsoStart::Fresh, up))
            })
        });
        let fit = torso
            .fit(&points, &mask, wu, hu, &cfg.torso, TorsoStart::Fresh, up)
            .expect("torso");
        g.bench_function("2b torso registration from last frame", |b| {
            b.iter(|| {
                black_box(torso.fit(
                    &points,
                    &mask,
                    wu,
                    hu,
                    &cfg.torso,
                    TorsoStart::Track(fit.pose, Vector3::zeros()),
                    up,
                ))
            })
        });
        let mut graph = GeoGraph::default();
        g.bench_function("3 geodesic graph", |b| {
            b.iter(|| graph.build(&points, &mask, wu, hu, &k, &cfg.graph))
        });
        graph.build(&points, &mask, wu, hu, &k, &cfg.graph);
        let root = graph
            .nearest_node(&k, &Point3::from(fit.pose.t), 12)
            .expect("root");
        let mut dij = Dijkstra::default();
        g.bench_function("4 Dijkstra + 8 incremental maxima", |b| {
            b.iter(|| {
                dij.reset(graph.node_count());
                dij.add_source(root);
                dij.run(&graph);
                for _ in 0..8 {
                    let (m, _) = dij
                        .dist
                        .iter()
                        .enumerate()
                        .filter(|(_, &d)| d != u32::MAX)
                        .max_by_key(|(_, &d)| d)
                        .unwrap();
                    dij.add_source(m as u32);
                    dij.run(&graph);
                }
            })
        });
        let mut est = PoseEstimator::new(k, cfg.clone());
        est.estimate(img.view());
        g.bench_function("whole estimator, the same frame again", |b| {
            b.iter(|| black_box(est.estimate(img.view())))
        });
        // A person moving (air-drawing, as the demo): tracking frame to frame, the
        // seed's full steps every tenth frame and when a limb strays.
        let clip = moving(k, 90);
        let seed_only = PoseConfig {
            register: RegisterConfig {
                enabled: false,
                ..RegisterConfig::default()
            },
            ..cfg.clone()
        };
        for (name, c) in [
            ("whole estimator, a person drawing", &cfg),
            (
                "seed's steps alone (no registration), a person drawing",
                &seed_only,
            ),
        ] {
            let mut est = PoseEstimator::new(k, c.clone());
            let mut i = 0;
            g.bench_function(name, |b| {
                b.iter(|| {
                    if i % clip.len() == 0 {
                        est.reset();
                    }
                    let r = est.estimate(clip[i % clip.len()].view());
                    i += 1;
                    black_box(r)
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
