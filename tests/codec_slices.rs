//! The slice (batch) paths are bit-identical to the scalar path: for every codec × bit count × instruction set
//! this CPU has (baseline, AVX2, AVX-512; see `gbuf::codec::simd`), and for the rayon-parallel wrappers, on the
//! stiff and degenerate vectors (NaN, ±Inf, −0.0, poles, fold lines, denormals, non-unit), arbitrary bit
//! patterns, arbitrary codes (garbage above the code's bits included) and random input. Slice lengths straddle
//! the block size so that both the vectorised blocks and the scalar remainder run.

#[path = "../src/codec/strategies.rs"]
mod strategies;

use gbuf::base::isa::Isa;
use gbuf::base::rng::SplitMix64;
use gbuf::codec::simd::{self, BLOCK, PAR_CHUNK};
use gbuf::codec::ScalarCodec;
use gbuf::codec::{color_codec, depth_codec, scalar_codec, ColorCodec, DepthCodec, NormalCodec, NormalScheme};
use glam::Vec3;
use proptest::prelude::*;
use strategies::{any_scalar, any_vector, degenerate_vectors, stiff_unit_vectors};

fn all_normal_codecs() -> Vec<Box<dyn NormalCodec>> {
    NormalScheme::ALL.iter().flat_map(|&s| s.valid_bits().into_iter().map(move |b| s.codec(b).unwrap())).collect()
}

const COLORS: &[&str] =
    &["unorm8", "unorm-1", "unorm-5", "unorm-10", "unorm-16", "srgb8", "r11g11b10f", "rgb9e5", "f16", "f32"];
const DEPTHS: &[&str] =
    &["f32", "f16", "unorm16", "unorm24", "unorm16-reversed", "unorm24-reversed", "f32-reversed", "f32-standard"];
const PLANES: [(f32, f32); 2] = [(0.1, 1000.0), (0.01, 50.0)];

fn bits3(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

/// Vectors that stress every branch the scalar code used to take, repeated to fill whole blocks, plus random
/// bit patterns and random unit vectors.
fn adversarial_vectors() -> Vec<Vec3> {
    let mut v = stiff_unit_vectors();
    v.extend(degenerate_vectors());
    let specials = [0.0, -0.0, 1e-45, -1e-40, 1e-30, 1e30, f32::MAX, f32::MIN, f32::NAN, f32::INFINITY];
    for &a in &specials {
        for &b in &specials {
            v.push(Vec3::new(a, b, -1.0));
            v.push(Vec3::new(a, -b, 1.0));
            v.push(Vec3::new(1.0, a, b));
            v.push(Vec3::new(a, b, -0.0));
        }
    }
    let mut rng = SplitMix64::new(0x51ce);
    for _ in 0..4 * BLOCK {
        v.push(Vec3::new(
            f32::from_bits(rng.next_u64() as u32),
            f32::from_bits(rng.next_u64() as u32),
            f32::from_bits(rng.next_u64() as u32),
        ));
        let n = Vec3::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0));
        v.push(n.normalize_or(Vec3::Z));
    }
    v
}

fn adversarial_scalars() -> Vec<f32> {
    let mut v = vec![
        0.0,
        -0.0,
        1e-45,
        -1e-45,
        1e-40,
        5.9e-8,
        2.9e-8,
        0.5,
        1.0,
        -1.0,
        1.5,
        4096.0,
        65504.0,
        65520.0,
        1e6,
        -1e6,
        f32::MAX,
        f32::MIN,
        f32::NAN,
        -f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.1,
        1000.0,
        50.0,
        0.01,
    ];
    let mut rng = SplitMix64::new(0x5ca1);
    for _ in 0..4 * BLOCK {
        v.push(f32::from_bits(rng.next_u64() as u32));
        v.push(rng.range_f32(-2.0, 2.0));
        v.push(rng.range_f32(0.0, 2000.0));
    }
    v
}

/// Codes: every small code, random codes with garbage above the code's bits, and the codes of `encoded`.
fn codes(encoded: &[u64]) -> Vec<u64> {
    let mut rng = SplitMix64::new(0xc0de);
    let mut c: Vec<u64> = (0..4096).collect();
    c.extend((0..4 * BLOCK).map(|_| rng.next_u64()));
    c.extend((0..4 * BLOCK).map(|_| rng.next_u64() & 0xffff_ffff));
    c.extend_from_slice(encoded);
    c
}

fn check_normal(c: &dyn NormalCodec, input: &[Vec3]) -> Result<(), String> {
    let want: Vec<u64> = input.iter().map(|&n| c.encode(n)).collect();
    let mut got = vec![0u64; input.len()];
    for isa in Isa::available() {
        got.fill(!0);
        c.encode_slice_isa(isa, input, &mut got);
        if let Some(i) = (0..input.len()).find(|&i| got[i] != want[i]) {
            return Err(format!(
                "{} {}: encode {:?} → {:#x}, scalar {:#x}",
                c.name(),
                isa.name(),
                input[i],
                got[i],
                want[i]
            ));
        }
    }
    let cs = codes(&want);
    let want_d: Vec<Vec3> = cs.iter().map(|&k| c.decode(k)).collect();
    let mut got_d = vec![Vec3::ZERO; cs.len()];
    for isa in Isa::available() {
        got_d.fill(Vec3::NAN);
        c.decode_slice_isa(isa, &cs, &mut got_d);
        if let Some(i) = (0..cs.len()).find(|&i| bits3(got_d[i]) != bits3(want_d[i])) {
            return Err(format!(
                "{} {}: decode {:#x} → {}, scalar {}",
                c.name(),
                isa.name(),
                cs[i],
                got_d[i],
                want_d[i]
            ));
        }
    }
    Ok(())
}

fn check_scalar_like(
    name: &str,
    enc: impl Fn(f32) -> u64,
    dec: impl Fn(u64) -> f32,
    enc_slice: impl Fn(Isa, &[f32], &mut [u64]),
    dec_slice: impl Fn(Isa, &[u64], &mut [f32]),
    input: &[f32],
) -> Result<(), String> {
    let want: Vec<u64> = input.iter().map(|&v| enc(v)).collect();
    let mut got = vec![0u64; input.len()];
    for isa in Isa::available() {
        got.fill(!0);
        enc_slice(isa, input, &mut got);
        if let Some(i) = (0..input.len()).find(|&i| got[i] != want[i]) {
            return Err(format!("{name} {}: encode {:e} → {:#x}, scalar {:#x}", isa.name(), input[i], got[i], want[i]));
        }
    }
    let cs = codes(&want);
    let want_d: Vec<u32> = cs.iter().map(|&k| dec(k).to_bits()).collect();
    let mut got_d = vec![0f32; cs.len()];
    for isa in Isa::available() {
        got_d.fill(f32::NAN);
        dec_slice(isa, &cs, &mut got_d);
        if let Some(i) = (0..cs.len()).find(|&i| got_d[i].to_bits() != want_d[i]) {
            return Err(format!(
                "{name} {}: decode {:#x} → {:e}, scalar {:e}",
                isa.name(),
                cs[i],
                got_d[i],
                f32::from_bits(want_d[i])
            ));
        }
    }
    Ok(())
}

fn check_scalar(c: &dyn ScalarCodec, input: &[f32]) -> Result<(), String> {
    check_scalar_like(
        &c.name(),
        |v| c.encode(v),
        |k| c.decode(k),
        |isa, i, o| c.encode_slice_isa(isa, i, o),
        |isa, i, o| c.decode_slice_isa(isa, i, o),
        input,
    )
}

fn check_depth(c: &dyn DepthCodec, input: &[f32]) -> Result<(), String> {
    check_scalar_like(
        &c.name(),
        |v| c.encode(v),
        |k| c.decode(k),
        |isa, i, o| c.encode_slice_isa(isa, i, o),
        |isa, i, o| c.decode_slice_isa(isa, i, o),
        input,
    )
}

fn check_color(c: &dyn ColorCodec, input: &[Vec3]) -> Result<(), String> {
    let want: Vec<u64> = input.iter().map(|&v| c.encode(v)).collect();
    let mut got = vec![0u64; input.len()];
    for isa in Isa::available() {
        got.fill(!0);
        c.encode_slice_isa(isa, input, &mut got);
        if let Some(i) = (0..input.len()).find(|&i| got[i] != want[i]) {
            return Err(format!(
                "{} {}: encode {} → {:#x}, scalar {:#x}",
                c.name(),
                isa.name(),
                input[i],
                got[i],
                want[i]
            ));
        }
    }
    let cs = codes(&want);
    let want_d: Vec<Vec3> = cs.iter().map(|&k| c.decode(k)).collect();
    let mut got_d = vec![Vec3::ZERO; cs.len()];
    for isa in Isa::available() {
        got_d.fill(Vec3::NAN);
        c.decode_slice_isa(isa, &cs, &mut got_d);
        if let Some(i) = (0..cs.len()).find(|&i| bits3(got_d[i]) != bits3(want_d[i])) {
            return Err(format!(
                "{} {}: decode {:#x} → {}, scalar {}",
                c.name(),
                isa.name(),
                cs[i],
                got_d[i],
                want_d[i]
            ));
        }
    }
    Ok(())
}

fn colors() -> Vec<Box<dyn ColorCodec>> {
    COLORS.iter().map(|n| color_codec(n).unwrap()).collect()
}

/// Every scalar codec at every bit count, and the signed ones at a few ranges.
fn scalars() -> Vec<Box<dyn ScalarCodec>> {
    let mut names = vec!["f16".to_string(), "f32".to_string()];
    for n in 1..=24 {
        names.push(format!("unorm-{n}"));
    }
    for n in 2..=24 {
        names.extend([format!("log2-unorm-{n}"), format!("specpow-unorm-{n}"), format!("snorm-{n}")]);
        names.extend([format!("snorm-{n}:32"), format!("snorm-{n}:0.001")]);
    }
    names.iter().map(|n| scalar_codec(n).unwrap_or_else(|| panic!("{n}"))).collect()
}

fn depths() -> Vec<Box<dyn DepthCodec>> {
    PLANES.iter().flat_map(|&(n, f)| DEPTHS.iter().map(move |d| depth_codec(d, n, f).unwrap())).collect()
}

#[test]
fn every_normal_codec_slice_path_is_bit_identical_on_adversarial_input() {
    let input = adversarial_vectors();
    for c in all_normal_codecs() {
        check_normal(c.as_ref(), &input).unwrap();
    }
}

#[test]
fn scalar_depth_and_colour_slice_paths_are_bit_identical_on_adversarial_input() {
    let input = adversarial_scalars();
    for c in scalars() {
        check_scalar(c.as_ref(), &input).unwrap();
    }
    for c in depths() {
        check_depth(c.as_ref(), &input).unwrap();
    }
    let rgb: Vec<Vec3> = input.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    let mut rgb2 = rgb.clone();
    rgb2.extend(adversarial_vectors());
    for c in colors() {
        check_color(c.as_ref(), &rgb2).unwrap();
    }
}

#[test]
fn parallel_wrappers_equal_the_scalar_path() {
    let n = 3 * PAR_CHUNK + 17;
    let mut rng = SplitMix64::new(99);
    let normals: Vec<Vec3> = (0..n)
        .map(|_| Vec3::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), rng.range_f32(-2.0, 2.0)))
        .collect();
    for name in ["oct-16", "xyz-snorm-30", "oct-precise-20", "spherical-16", "lambert-f16-32"] {
        let c = gbuf::codec::normal_codec(name).unwrap();
        let mut codes = vec![0u64; n];
        simd::par_encode(c.as_ref(), &normals, &mut codes);
        assert!(codes.iter().zip(&normals).all(|(k, v)| *k == c.encode(*v)), "{name}");
        let mut back = vec![Vec3::ZERO; n];
        simd::par_decode(c.as_ref(), &codes, &mut back);
        assert!(back.iter().zip(&codes).all(|(b, k)| bits3(*b) == bits3(c.decode(*k))), "{name}");
    }
    let vals: Vec<f32> = (0..n).map(|_| rng.range_f32(-0.5, 1.5)).collect();
    let c = scalar_codec("unorm-8").unwrap();
    let mut codes = vec![0u64; n];
    simd::par_encode(c.as_ref(), &vals, &mut codes);
    assert!(codes.iter().zip(&vals).all(|(k, v)| *k == c.encode(*v)));
    let mut back = vec![0f32; n];
    simd::par_decode(c.as_ref(), &codes, &mut back);
    assert!(back.iter().zip(&codes).all(|(b, k)| b.to_bits() == c.decode(*k).to_bits()));
    let d = depth_codec("unorm24", 0.1, 100.0).unwrap();
    simd::par_encode(d.as_ref(), &vals, &mut codes);
    assert!(codes.iter().zip(&vals).all(|(k, v)| *k == d.encode(*v)));
    simd::par_decode(d.as_ref(), &codes, &mut back);
    assert!(back.iter().zip(&codes).all(|(b, k)| b.to_bits() == d.decode(*k).to_bits()));
    let col = color_codec("unorm8").unwrap();
    simd::par_encode(col.as_ref(), &normals, &mut codes);
    assert!(codes.iter().zip(&normals).all(|(k, v)| *k == col.encode(*v)));
    let mut back = vec![Vec3::ZERO; n];
    simd::par_decode(col.as_ref(), &codes, &mut back);
    assert!(back.iter().zip(&codes).all(|(b, k)| bits3(*b) == bits3(col.decode(*k))));
}

#[test]
#[should_panic(expected = "encode_slice")]
fn mismatched_lengths_panic_with_a_message() {
    let c = gbuf::codec::normal_codec("oct-16").unwrap();
    c.encode_slice(&[Vec3::Z; 3], &mut [0u64; 2]);
}

fn cases() -> ProptestConfig {
    ProptestConfig { cases: 64, ..ProptestConfig::default() }
}

proptest! {
    #![proptest_config(cases())]

    #[test]
    fn normal_slices_equal_scalar_on_random_input(v in prop::collection::vec(any_vector(), 0..2 * BLOCK + 7)) {
        for c in all_normal_codecs() {
            prop_assert!(check_normal(c.as_ref(), &v).is_ok(), "{}", check_normal(c.as_ref(), &v).unwrap_err());
        }
    }

    #[test]
    fn scalar_like_slices_equal_scalar_on_random_input(v in prop::collection::vec(any_scalar(), 0..2 * BLOCK + 7)) {
        for c in scalars() {
            let r = check_scalar(c.as_ref(), &v);
            prop_assert!(r.is_ok(), "{}", r.unwrap_err());
        }
        for c in depths() {
            let r = check_depth(c.as_ref(), &v);
            prop_assert!(r.is_ok(), "{}", r.unwrap_err());
        }
        let rgb: Vec<Vec3> = v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        for c in colors() {
            let r = check_color(c.as_ref(), &rgb);
            prop_assert!(r.is_ok(), "{}", r.unwrap_err());
        }
    }
}
