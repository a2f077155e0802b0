//! `scene/<name>/<W>x<H>`: rendering the analytic scenes at 4× MSAA (ray casting plus plane filling).
//! Run briefly: `cargo bench --bench scene -- --warm-up-time 1 --measurement-time 2`.

use criterion::{criterion_group, criterion_main, Criterion};
use gbuf::scene::{render, SceneName};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("scene");
    g.sample_size(10);
    for (name, w, h) in [(SceneName::Room, 1920, 1080), (SceneName::Room, 640, 360), (SceneName::Stress, 1920, 1080)] {
        g.bench_function(format!("{}/{w}x{h}", name.name()), |b| {
            b.iter(|| render(black_box(name), black_box(w), black_box(h), 4).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
