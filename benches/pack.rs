//! Whole-G-buffer pack and unpack (rayon-parallel over blocks of rows, each field through its codec's slice path)
//! for a few layouts at 1280×720×4, beside a memcpy of the same number of packed bytes in the same run.
//!
//! First a ratio table (best of 7 passes each): pack and unpack time on one thread (a one-thread rayon pool) and
//! on all threads, and the ratio to a memcpy of the packed bytes (one thread: `copy_from_slice`; all threads:
//! the copy split over the pool). Pack and unpack include allocating their output (and for destiny-96 building
//! the material table; for unpack, re-deriving position from depth). Then criterion measures the all-thread
//! operations. A second table times the report's path, the banded roundtrip with its output reused across runs
//! (`Layout::roundtrip_for_lighting`: positions of depth-only layouts left to the lighting), in GB/s of packed
//! bytes. Run:
//! `cargo bench --bench pack -- --warm-up-time 1 --measurement-time 2`.

use criterion::{Criterion, Throughput};
use gbuf::base::rng::SplitMix64;
use gbuf::codec::eval::best_time;
use gbuf::gbuffer::GBuffer;
use gbuf::layout::Layout;
use gbuf::Camera;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::hint::black_box;

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

const LAYOUTS: [&str; 5] = ["fat-20", "lauritzen-15", "destiny-96", "bevy-deferred", "reference-f32"];
/// Passes per entry of the ratio table (the fastest counts).
const REPS: usize = 7;
/// Bytes per parallel memcpy work item.
const COPY_CHUNK: usize = 1 << 20;

fn par_copy(dst: &mut [u8], src: &[u8]) {
    dst.par_chunks_mut(COPY_CHUNK).zip(src.par_chunks(COPY_CHUNK)).for_each(|(d, s)| d.copy_from_slice(s));
}

/// The ratio table (see the module doc).
fn ratio_table(gb: &GBuffer) {
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    let threads = rayon::current_num_threads();
    println!("\n{W}×{H}×{S} samples; times in ms; ratio = time / memcpy of the packed bytes (same thread count)");
    println!(
        "{:<14} {:>6} {:>8} {:>8} {:>6} {:>8} {:>6} | {:>8} {:>8} {:>6} {:>8} {:>6}",
        "layout", "MB", "memcpy1", "pack1", "×", "unpack1", "×", "memcpyN", "packN", "×", "unpackN", "×"
    );
    for name in LAYOUTS {
        let layout = Layout::by_name(name).unwrap();
        let bytes = gb.len() * layout.bytes_per_sample();
        let src = vec![0x5au8; bytes];
        let mut dst = vec![0u8; bytes];
        let packed = layout.pack(gb).unwrap();
        let pack = || black_box(layout.pack(black_box(gb)).unwrap());
        let unpack = || black_box(layout.unpack(black_box(&packed), gb).unwrap());
        let (m1, p1, u1) = one.install(|| {
            (
                best_time(REPS, || dst.copy_from_slice(black_box(&src))),
                best_time(REPS, || drop(pack())),
                best_time(REPS, || drop(unpack())),
            )
        });
        let mn = best_time(REPS, || par_copy(&mut dst, black_box(&src)));
        let pn = best_time(REPS, || drop(pack()));
        let un = best_time(REPS, || drop(unpack()));
        let ms = |t: f64| t * 1e3;
        println!(
            "{name:<14} {:>6.1} {:>8.2} {:>8.2} {:>6.1} {:>8.2} {:>6.1} | {:>8.2} {:>8.2} {:>6.1} {:>8.2} {:>6.1}",
            bytes as f64 / 1e6,
            ms(m1),
            ms(p1),
            p1 / m1,
            ms(u1),
            u1 / m1,
            ms(mn),
            ms(pn),
            pn / mn,
            ms(un),
            un / mn
        );
    }
    println!("(N = {threads} threads)\n");
    // What a report measures: the banded roundtrip (`Layout::roundtrip_for_lighting`), output planes reused from run
    // to run, so the best of its runs has no fresh-memory page faults. GB/s of packed bytes, N threads.
    println!("banded roundtrip (report's path), best of 5 runs, N threads; GB/s of packed bytes (issue 14: ≥ 2)");
    println!("(encode writes each sample's material index; the table is built once before the runs: `table`)");
    println!(
        "{:<14} {:>6} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "layout", "MB", "memcpyN", "encode", "GB/s", "decode", "GB/s", "table"
    );
    for name in LAYOUTS {
        let layout = Layout::by_name(name).unwrap();
        let bytes = gb.len() * layout.bytes_per_sample();
        let src = vec![0x5au8; bytes];
        let mut dst = vec![0u8; bytes];
        let mn = best_time(REPS, || par_copy(&mut dst, black_box(&src)));
        let r = layout.roundtrip_for_lighting(gb, 5).unwrap();
        let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let (e, d) = (best(&r.encode_ms), best(&r.decode_ms));
        let gbs = |ms: f64| bytes as f64 / (ms * 1e-3) / 1e9;
        let table = r.table_ms.map_or("—".to_string(), |t| format!("{t:.2}"));
        println!(
            "{name:<14} {:>6.1} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {table:>8}",
            bytes as f64 / 1e6,
            mn * 1e3,
            e,
            gbs(e),
            d,
            gbs(d)
        );
    }
    println!();
}

fn bench(c: &mut Criterion, gb: &GBuffer) {
    let mut group = c.benchmark_group("pack");
    group.sample_size(10);
    for name in LAYOUTS {
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
        group.bench_function(format!("pack/{name}/{W}x{H}x{S}"), |b| b.iter(|| layout.pack(black_box(gb)).unwrap()));
        let packed = layout.pack(gb).unwrap();
        group.bench_function(format!("unpack/{name}/{W}x{H}x{S}"), |b| {
            b.iter(|| layout.unpack(black_box(&packed), gb).unwrap())
        });
    }
    group.finish();
}

/// The material table on a 640×360×4 dump (issue 14's target: ≤ 100 ms whatever the tuple count), beside a
/// memcpy of its parameter planes: keyed by the engine's 40 material IDs, and as a palette when every covered
/// sample's (specular, power, roughness, metallic) tuple is distinct and there are no IDs (the worst case: clustered
/// into 256 entries).
fn material_table() {
    use gbuf::gbuffer::Attribute;
    use gbuf::layout::material::MaterialTable;
    let (w, h, s) = (640, 360, 4);
    let mut rng = SplitMix64::new(7);
    let mut gb = GBuffer::new(w, h, s).unwrap();
    let n = gb.len();
    gb.coverage = (0..n).map(|_| rng.next_f32() > 0.05).collect();
    let mats: Vec<u32> = (0..n).map(|_| (rng.next_u64() % 40) as u32).collect();
    let wanted = [Attribute::Specular, Attribute::SpecularPower, Attribute::Roughness, Attribute::Metallic];
    let bytes = 4 * wanted.len() * n;
    let src = vec![0x5au8; bytes];
    let mut dst = vec![0u8; bytes];
    let copy = best_time(REPS, || par_copy(&mut dst, black_box(&src)));
    println!(
        "\nmaterial table, {w}×{h}×{s}, 256 entries; ms (ratio to a memcpy of the 4 parameter planes, {:.2} ms)",
        copy * 1e3
    );
    for distinct in [false, true] {
        if distinct {
            gb.specular = Some((0..n).map(|_| rng.next_f32() * 0.2).collect());
            gb.specular_power = Some((0..n).map(|_| rng.range_f32(1.0, 512.0)).collect());
            gb.roughness = Some((0..n).map(|_| rng.next_f32()).collect());
            gb.metallic = Some((0..n).map(|_| rng.next_f32()).collect());
            gb.material_id = None;
        } else {
            gb.specular = Some(mats.iter().map(|m| 0.02 * (*m % 10) as f32).collect());
            gb.specular_power = Some(mats.iter().map(|m| 4.0 * (1 + m) as f32).collect());
            gb.roughness = Some(mats.iter().map(|m| (*m % 20) as f32 / 19.0).collect());
            gb.metallic = Some(mats.iter().map(|m| (*m % 2) as f32).collect());
            gb.material_id = Some(mats.clone());
        }
        let key = gbuf::layout::spec::MaterialKey::MaterialId;
        let mut table = None;
        let t = best_time(3, || table = Some(MaterialTable::build_keyed(black_box(&gb), &wanted, 8, key)));
        let table = table.expect("built").0;
        println!(
            "  {:<40} {:>8.1} ms ({:>5.1}×)  {} distinct tuples, key {}, mean |error| {:?}  target ≤ 100 ms: {}",
            if distinct { "palette, every tuple distinct, no IDs" } else { "40 material IDs" },
            t * 1e3,
            t / copy,
            table.distinct_tuples,
            table.key,
            table.mean_abs_error,
            if t <= 0.1 { "met" } else { "NOT met" }
        );
    }
}

fn main() {
    let roundtrip_only = std::env::var_os("GBUF_BENCH_ROUNDTRIP").is_some();
    if !roundtrip_only {
        material_table();
    }
    if std::env::var_os("GBUF_BENCH_MATERIAL_ONLY").is_some() {
        return;
    }
    let gb = gbuffer();
    // `GBUF_BENCH_ROUNDTRIP=fat-20,…`: only the banded roundtrip of those layouts, 50 runs each (for a profiler).
    if let Ok(names) = std::env::var("GBUF_BENCH_ROUNDTRIP") {
        for name in names.split(',') {
            let layout = Layout::by_name(name).expect("a built-in layout");
            let r = layout.roundtrip_for_lighting(&gb, 50).unwrap();
            let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
            let bytes = gb.len() * layout.bytes_per_sample();
            let gbs = |ms: f64| bytes as f64 / (ms * 1e-3) / 1e9;
            let (e, d) = (best(&r.encode_ms), best(&r.decode_ms));
            println!("{name}: encode {e:.2} ms ({:.2} GB/s), decode {d:.2} ms ({:.2} GB/s)", gbs(e), gbs(d));
        }
        return;
    }
    ratio_table(&gb);
    let mut c = Criterion::default().configure_from_args();
    bench(&mut c, &gb);
    c.final_summary();
}
