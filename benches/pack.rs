//! Whole-G-buffer pack and unpack (rayon-parallel) for a few layouts at 1280×720×4, beside a memcpy of the same
//! number of packed bytes. Run: `cargo bench --bench pack -- --warm-up-time 1 --measurement-time 2`.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use gbuf::gbuffer::GBuffer;
use gbuf::layout::Layout;
use gbuf::util::SplitMix64;
use gbuf::Camera;
use glam::{Vec2, Vec3};

const W: u32 = 1280;
const H: u32 = 720;
const S: u32 = 4;

/// A fixed-seed G-buffer with every attribute and a handful of materials.
fn gbuffer() -> GBuffer {
    let mut rng = SplitMix64::new(42);
    let mut gb = GBuffer::new(W, H, S).unwrap();
    let n = gb.len();
    gb.camera = Some(Camera::identity(0.9, W as f32 / H as f32, 0.1, 200.0));
    gb.coverage = (0..n).map(|_| rng.next_f32() > 0.05).collect();
    gb.depth = Some((0..n).map(|_| rng.range_f32(0.2, 150.0)).collect());
    gb.normal = Some(
        (0..n)
            .map(|_| {
                Vec3::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), rng.next_f32()).normalize_or(Vec3::Z)
            })
            .collect(),
    );
    gb.albedo = Some((0..n).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())).collect());
    let mats: Vec<u32> = (0..n).map(|_| (rng.next_u64() % 40) as u32).collect();
    gb.specular = Some(mats.iter().map(|m| 0.02 * (*m % 10) as f32).collect());
    gb.specular_power = Some(mats.iter().map(|m| 4.0 * (1 + m) as f32).collect());
    gb.roughness = Some(mats.iter().map(|m| (*m % 20) as f32 / 19.0).collect());
    gb.metallic = Some(mats.iter().map(|m| (*m % 2) as f32).collect());
    gb.material_id = Some(mats);
    gb.object_id = Some((0..n).map(|_| (rng.next_u64() % 500) as u32).collect());
    gb.primitive_id = Some((0..n).map(|_| rng.next_u64() as u32).collect());
    gb.motion = Some((0..n).map(|_| Vec2::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0))).collect());
    gb
}

fn bench(c: &mut Criterion) {
    let gb = gbuffer();
    let mut group = c.benchmark_group("pack");
    group.sample_size(10);
    for name in ["fat-20", "lauritzen-15", "destiny-96", "bevy-deferred", "reference-f32"] {
        let layout = Layout::by_name(name).unwrap();
        let bytes = gb.len() * layout.bytes_per_sample();
        group.throughput(Throughput::Bytes(bytes as u64));
        let src = vec![0x5au8; bytes];
        let mut dst = vec![0u8; bytes];
        group.bench_function(format!("memcpy/{name}/{W}x{H}x{S}"), |b| {
            b.iter(|| {
                dst.copy_from_slice(black_box(&src));
                black_box(&dst);
            })
        });
        group.bench_function(format!("pack/{name}/{W}x{H}x{S}"), |b| b.iter(|| layout.pack(black_box(&gb)).unwrap()));
        let packed = layout.pack(&gb).unwrap();
        group.bench_function(format!("unpack/{name}/{W}x{H}x{S}"), |b| {
            b.iter(|| layout.unpack(black_box(&packed), &gb).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
