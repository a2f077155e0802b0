//! Encode and decode throughput of every normal scheme over 1,000,000 normals, beside a plain memcpy of the same
//! bytes in the same run, on one thread and on all threads (rayon).
//!
//! First two ratio tables are printed (best of 9 passes each): normals/s of each codec's slice path on one thread
//! (`encode_slice`/`decode_slice`, vectorised) and on all threads (`simd::par_encode` /
//! `par_decode`), and the ratio of its time to a memcpy of the 12-byte f32×3 normals (one thread:
//! `copy_from_slice`; all threads: the same copy split over the pool); then the same on one thread for a few
//! scalar, depth and colour codecs against a memcpy of their input. Then criterion measures the same
//! operations: `memcpy/normals-12B/1M`, `memcpy-par/...`, `encode/<codec>/1M`, `decode/<codec>/1M`,
//! `encode-par/<codec>/1M`, `decode-par/<codec>/1M`; throughput in normals/s. Run briefly with
//! `cargo bench --bench codecs -- --warm-up-time 1 --measurement-time 2`. Each scheme is benched at its first
//! default sweep size (8 bits per component, or its f16 size); speed barely depends on the bit count.

use criterion::{BenchmarkId, Criterion, Throughput};
use gbuf::base::isa::Isa;
use gbuf::base::rng::SplitMix64;
use gbuf::codec::eval::{best_time, random_unit_vectors};
use gbuf::codec::simd::{par_decode, par_encode, PAR_CHUNK};
use gbuf::codec::{color_codec, depth_codec, scalar_codec, NormalCodec, NormalScheme};
use glam::Vec3;
use rayon::prelude::*;
use std::hint::black_box;

const COUNT: usize = 1_000_000;
const SEED: u64 = 0x5eed;
/// Passes per entry of the ratio table (the fastest counts).
const REPS: usize = 9;

fn par_copy(dst: &mut [Vec3], src: &[Vec3]) {
    dst.par_chunks_mut(PAR_CHUNK).zip(src.par_chunks(PAR_CHUNK)).for_each(|(d, s)| d.copy_from_slice(s));
}

fn codecs() -> Vec<Box<dyn NormalCodec>> {
    NormalScheme::ALL.iter().map(|s| s.codec(s.sweep_bits()[0]).expect("sweep bits are valid")).collect()
}

/// The ratio table (see the module doc).
fn ratio_table(normals: &[Vec3]) {
    let mut copy = vec![Vec3::ZERO; COUNT];
    let memcpy = |copy: &mut Vec<Vec3>| best_time(REPS, || copy.copy_from_slice(black_box(normals)));
    let memcpy_par = |copy: &mut Vec<Vec3>| best_time(REPS, || par_copy(copy, black_box(normals)));
    let (m1, mp) = (memcpy(&mut copy), memcpy_par(&mut copy));
    let threads = rayon::current_num_threads();
    println!(
        "\n{COUNT} normals; {} slice path; memcpy of the 12-byte normals: 1 thread {:.2} ns/normal ({:.0} M/s), \
         {threads} threads {:.2} ns/normal ({:.0} M/s)",
        Isa::detect().name(),
        m1 * 1e9 / COUNT as f64,
        COUNT as f64 / m1 / 1e6,
        mp * 1e9 / COUNT as f64,
        COUNT as f64 / mp / 1e6
    );
    println!(
        "{:<20} {:>10} {:>7} {:>10} {:>7} | {:>10} {:>7} {:>10} {:>7}",
        "codec", "enc M/s", "×memcpy", "dec M/s", "×memcpy", "enc-par", "×memcpy", "dec-par", "×memcpy"
    );
    let mut codes = vec![0u64; COUNT];
    let mut out = vec![Vec3::ZERO; COUNT];
    for c in codecs() {
        let e1 = best_time(REPS, || c.encode_slice(black_box(normals), &mut codes));
        let d1 = best_time(REPS, || c.decode_slice(black_box(&codes), &mut out));
        let ep = best_time(REPS, || par_encode(c.as_ref(), black_box(normals), &mut codes));
        let dp = best_time(REPS, || par_decode(c.as_ref(), black_box(&codes), &mut out));
        let rate = |t: f64| COUNT as f64 / t / 1e6;
        println!(
            "{:<20} {:>10.0} {:>7.2} {:>10.0} {:>7.2} | {:>10.0} {:>7.2} {:>10.0} {:>7.2}",
            c.name(),
            rate(e1),
            e1 / m1,
            rate(d1),
            d1 / m1,
            rate(ep),
            ep / mp,
            rate(dp),
            dp / mp
        );
    }
    // The memcpy once more at the end: if the machine got busier, the ratios above are suspect.
    let (m1b, mpb) = (memcpy(&mut copy), memcpy_par(&mut copy));
    println!(
        "memcpy again after the table: 1 thread {:.2} ns/normal, {threads} threads {:.2} ns/normal (was {:.2}, {:.2})\n",
        m1b * 1e9 / COUNT as f64,
        mpb * 1e9 / COUNT as f64,
        m1 * 1e9 / COUNT as f64,
        mp * 1e9 / COUNT as f64
    );
}

/// One thread, slice paths of the scalar, depth and colour codecs over a million values, against a memcpy of the
/// input (4-byte f32 values, 12-byte colours).
fn other_codecs_table() {
    let mut rng = SplitMix64::new(SEED);
    let values: Vec<f32> = (0..COUNT).map(|_| rng.range_f32(-0.1, 1.1)).collect();
    let depths: Vec<f32> = (0..COUNT).map(|_| rng.range_f32(0.05, 120.0)).collect();
    let colors: Vec<Vec3> = (0..COUNT).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())).collect();
    let mut codes = vec![0u64; COUNT];
    let (mut fout, mut vout) = (vec![0f32; COUNT], vec![Vec3::ZERO; COUNT]);
    let m4 = best_time(REPS, || fout.copy_from_slice(black_box(&values)));
    let m12 = best_time(REPS, || vout.copy_from_slice(black_box(&colors)));
    println!(
        "other codecs, 1 thread; memcpy of the input: f32 {:.2} ns/value, rgb f32×3 {:.2} ns/colour",
        m4 * 1e9 / COUNT as f64,
        m12 * 1e9 / COUNT as f64
    );
    println!("{:<24} {:>10} {:>7} {:>10} {:>7}", "codec", "enc M/s", "×memcpy", "dec M/s", "×memcpy");
    let rate = |t: f64| COUNT as f64 / t / 1e6;
    let row = |name: String, e: f64, d: f64, m: f64| {
        println!("{name:<24} {:>10.0} {:>7.2} {:>10.0} {:>7.2}", rate(e), e / m, rate(d), d / m);
    };
    for name in ["unorm-8", "unorm-16", "snorm-8:32", "f16", "log2-unorm-8"] {
        let c = scalar_codec(name).expect("a scalar codec");
        let e = best_time(REPS, || c.encode_slice(black_box(&values), &mut codes));
        let d = best_time(REPS, || c.decode_slice(black_box(&codes), &mut fout));
        row(format!("scalar {name}"), e, d, m4);
    }
    for name in ["unorm24", "unorm24-reversed", "unorm16", "f32-reversed", "f32", "f16"] {
        let c = depth_codec(name, 0.1, 100.0).expect("a depth codec");
        let e = best_time(REPS, || c.encode_slice(black_box(&depths), &mut codes));
        let d = best_time(REPS, || c.decode_slice(black_box(&codes), &mut fout));
        row(format!("depth {name}"), e, d, m4);
    }
    for name in ["unorm8", "srgb8", "f16", "r11g11b10f", "rgb9e5"] {
        let c = color_codec(name).expect("a colour codec");
        let e = best_time(REPS, || c.encode_slice(black_box(&colors), &mut codes));
        let d = best_time(REPS, || c.decode_slice(black_box(&codes), &mut vout));
        row(format!("colour {name}"), e, d, m12);
    }
    println!();
}

fn bench(c: &mut Criterion, normals: &[Vec3]) {
    let mut group = c.benchmark_group("codecs");
    group.throughput(Throughput::Elements(COUNT as u64));
    group.sample_size(10);

    let mut copy = vec![Vec3::ZERO; COUNT];
    group.bench_function(BenchmarkId::new("memcpy", "normals-12B/1M"), |b| {
        b.iter(|| copy.copy_from_slice(black_box(normals)));
    });
    group.bench_function(BenchmarkId::new("memcpy-par", "normals-12B/1M"), |b| {
        b.iter(|| par_copy(&mut copy, black_box(normals)));
    });
    for codec in codecs() {
        let name = codec.name();
        let mut codes = vec![0u64; COUNT];
        group.bench_function(BenchmarkId::new("encode", format!("{name}/1M")), |b| {
            b.iter(|| codec.encode_slice(black_box(normals), black_box(&mut codes)));
        });
        let mut out = vec![Vec3::ZERO; COUNT];
        group.bench_function(BenchmarkId::new("decode", format!("{name}/1M")), |b| {
            b.iter(|| codec.decode_slice(black_box(&codes), black_box(&mut out)));
        });
        group.bench_function(BenchmarkId::new("encode-par", format!("{name}/1M")), |b| {
            b.iter(|| par_encode(codec.as_ref(), black_box(normals), black_box(&mut codes)));
        });
        group.bench_function(BenchmarkId::new("decode-par", format!("{name}/1M")), |b| {
            b.iter(|| par_decode(codec.as_ref(), black_box(&codes), black_box(&mut out)));
        });
    }
    group.finish();
}

fn main() {
    let normals = random_unit_vectors(COUNT, SEED);
    ratio_table(&normals);
    other_codecs_table();
    let mut c = Criterion::default().configure_from_args();
    bench(&mut c, &normals);
    c.final_summary();
}
