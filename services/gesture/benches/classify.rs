//! Classifying one gesture against the 36-symbol vocabulary with the shipped default
//! model (models/unipen-36.json, built in), and one spotter step.

use airglyph_gesture::{ModelSource, Trajectory};
use criterion::{black_box, criterion_group, criterion_main, Criterion};

fn bench(c: &mut Criterion) {
    let model = ModelSource::Shipped
        .load()
        .expect("the shipped model loads");
    // A hand-drawn-like "8": two loops, 60 points.
    let pts: Vec<[f32; 2]> = (0..60)
        .map(|i| {
            let t = i as f32 / 59.0 * std::f32::consts::TAU;
            [100.0 * (t).sin() * (t).cos(), -150.0 * (t).cos()]
        })
        .collect();
    let traj = Trajectory::from_points(pts);
    c.bench_function("classify one gesture, 36 symbols (default model)", |b| {
        b.iter(|| black_box(model.classify(black_box(&traj))))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
