//! Encode and decode throughput of every normal scheme over 1,000,000 normals, beside a plain memcpy of the same
//! bytes in the same run (`memcpy/normals-12B` copies the f32×3 input, `memcpy/codes-8B` the u64 codes).
//!
//! Names: `encode/<codec>/1M`, `decode/<codec>/1M`; throughput in normals/s. Run briefly with
//! `cargo bench --bench codecs -- --warm-up-time 1 --measurement-time 2`. Each scheme is benched at its
//! first default sweep size (8 bits per component, or its f16 size); speed barely depends on the bit count.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gbuf::codec::eval::random_unit_vectors;
use gbuf::codec::NormalScheme;
use glam::Vec3;

const COUNT: usize = 1_000_000;
const SEED: u64 = 0x5eed;

fn bench(c: &mut Criterion) {
    let normals = random_unit_vectors(COUNT, SEED);
    let mut group = c.benchmark_group("codecs");
    group.throughput(Throughput::Elements(COUNT as u64));
    group.sample_size(10);

    let mut copy = vec![Vec3::ZERO; COUNT];
    group.bench_function(BenchmarkId::new("memcpy", "normals-12B/1M"), |b| {
        b.iter(|| copy.copy_from_slice(black_box(&normals)));
    });
    let codes_src: Vec<u64> = (0..COUNT as u64).collect();
    let mut codes_dst = vec![0u64; COUNT];
    group.bench_function(BenchmarkId::new("memcpy", "codes-8B/1M"), |b| {
        b.iter(|| codes_dst.copy_from_slice(black_box(&codes_src)));
    });

    for scheme in NormalScheme::ALL {
        let codec = scheme.codec(scheme.sweep_bits()[0]).expect("sweep bits are valid");
        let name = codec.name();
        let mut codes = vec![0u64; COUNT];
        group.bench_function(BenchmarkId::new("encode", format!("{name}/1M")), |b| {
            b.iter(|| codec.encode_slice(black_box(&normals), black_box(&mut codes)));
        });
        let mut out = vec![Vec3::ZERO; COUNT];
        group.bench_function(BenchmarkId::new("decode", format!("{name}/1M")), |b| {
            b.iter(|| codec.decode_slice(black_box(&codes), black_box(&mut out)));
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
