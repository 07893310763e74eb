//! Frames a second of skinning + rendering at 640×480 on one thread.
//!
//! `cargo bench -p airglyph-synth` — the MakeHuman body when the asset cache is there
//! (scripts/fetch-assets), and the procedural body always.

use airglyph_synth::makehuman;
use airglyph_synth::{BodySpec, MotionSpec, SceneConfig, Synthesizer};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::time::Instant;

fn scene(body: BodySpec) -> SceneConfig {
    SceneConfig {
        body,
        motion: MotionSpec::Poses,
        ..SceneConfig::default()
    }
}

fn bench(c: &mut Criterion) {
    let mut bodies = vec![("procedural", BodySpec::Procedural(Default::default()))];
    let dir = makehuman::default_assets_dir();
    if makehuman::assets_present(&dir) {
        bodies.insert(
            0,
            (
                "makehuman",
                BodySpec::MakeHuman {
                    assets: Some(dir),
                    shape: Default::default(),
                },
            ),
        );
    } else {
        println!(
            "MakeHuman assets missing in {}: run scripts/fetch-assets; benchmarking the procedural body only",
            dir.display()
        );
    }
    let mut group = c.benchmark_group("skin+render 640x480");
    group.throughput(Throughput::Elements(1));
    for (name, body) in bodies {
        let mut synth = Synthesizer::new(scene(body.clone())).expect("scene");
        let k = synth.intrinsics();
        let mut depth = vec![0u16; (k.width * k.height) as usize];
        let mut frame = 0usize;
        group.bench_function(name, |b| {
            b.iter(|| {
                frame = (frame + 1) % 600;
                synth.render_into(frame, &mut depth).expect("render")
            })
        });
        // Plain figures too, for the report: wall clock, and this thread's CPU time
        // (which a busy shared machine disturbs much less).
        let n = 600;
        let t = Instant::now();
        let c = thread_cpu_s();
        for i in 0..n {
            synth.render_into(i, &mut depth).expect("render");
        }
        let fps = n as f64 / t.elapsed().as_secs_f64();
        let cpu_fps = n as f64 / (thread_cpu_s() - c);
        println!(
            "{name}: {} vertices, {} triangles: {fps:.0} frames/s wall clock, {cpu_fps:.0} frames per CPU second (skinning + rendering, 640x480, one thread)",
            synth.body().vertex_count(),
            synth.body().triangle_count()
        );
    }
    group.finish();
}

fn thread_cpu_s() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

criterion_group!(benches, bench);
criterion_main!(benches);
