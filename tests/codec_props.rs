//! Property tests for every codec × bit count: round trips within the documented bound, decode∘encode∘decode =
//! decode, finite (and for normals unit) output for any input including NaN, ±Inf, zero, denormals and huge
//! values.

#[path = "../src/codec/strategies.rs"]
mod strategies;

use gbuf::codec::eval::UNIT_LENGTH_TOL;
use gbuf::codec::{angle_deg, color_codec, depth_codec, scalar_codec, NormalCodec, NormalScheme};
use glam::Vec3;
use proptest::prelude::*;
use strategies::{adversarial_unit_vector, any_scalar, any_vector};

/// Every normal codec at every valid bit count (≈ 150 codecs; each proptest case runs through all of them).
fn all_normal_codecs() -> Vec<Box<dyn NormalCodec>> {
    NormalScheme::ALL.iter().flat_map(|&s| s.valid_bits().into_iter().map(move |b| s.codec(b).unwrap())).collect()
}

/// Scalar codecs by name, covering every family and the ends of the bit ranges.
const SCALARS: &[&str] = &[
    "unorm-1",
    "unorm-4",
    "unorm-8",
    "unorm-10",
    "unorm-16",
    "unorm-24",
    "f16",
    "f32",
    "log2-unorm-2",
    "log2-unorm-8",
    "log2-unorm-16",
    "specpow-unorm-8",
    "specpow-unorm-16",
    "snorm-2",
    "snorm-8",
    "snorm-10",
    "snorm-16",
    "snorm-24",
    "snorm-8:32",
    "snorm-12:0.001",
    "snorm-16:1000000",
];
const COLORS: &[&str] =
    &["unorm8", "unorm-1", "unorm-5", "unorm-10", "unorm-16", "srgb8", "r11g11b10f", "rgb9e5", "f16", "f32"];
const DEPTHS: &[&str] =
    &["f32", "f16", "unorm16", "unorm24", "unorm16-reversed", "unorm24-reversed", "f32-reversed", "f32-standard"];

fn cases() -> ProptestConfig {
    ProptestConfig { cases: 512, ..ProptestConfig::default() }
}

fn is_unit(v: Vec3) -> bool {
    v.is_finite() && (v.length() - 1.0).abs() <= UNIT_LENGTH_TOL
}

proptest! {
    #![proptest_config(cases())]

    #[test]
    fn normals_round_trip_within_bound(n in adversarial_unit_vector()) {
        for c in all_normal_codecs() {
            let d = c.decode(c.encode(n));
            prop_assert!(is_unit(d), "{}: {n} → {d}", c.name());
            if c.in_domain(n) {
                let e = angle_deg(n, d);
                prop_assert!(e <= c.max_error_deg(), "{}: {n} → {d}: {e}° > {}°", c.name(), c.max_error_deg());
            }
        }
    }

    #[test]
    fn any_input_gives_a_finite_unit_normal(n in any_vector()) {
        for c in all_normal_codecs() {
            let code = c.encode(n);
            prop_assert!(code >> c.bits() == 0, "{}: code {code:#x} wider than {} bits", c.name(), c.bits());
            let d = c.decode(code);
            prop_assert!(is_unit(d), "{}: {n} → {d}", c.name());
        }
    }

    #[test]
    fn every_code_decodes_to_a_unit_normal_and_reencodes_stably(code in any::<u64>()) {
        for c in all_normal_codecs() {
            let d = c.decode(code);
            prop_assert!(is_unit(d), "{}: {code:#x} → {d}", c.name());
            let d2 = c.decode(c.encode(d));
            if c.is_idempotent() {
                prop_assert_eq!(d2, d, "{}: code {:#x}", c.name(), code);
            } else {
                prop_assert!(angle_deg(d, d2) <= c.max_error_deg(), "{}: {d} → {d2}", c.name());
            }
        }
    }

    #[test]
    fn scalars_round_trip_within_bound(v in any_scalar()) {
        for name in SCALARS {
            let c = scalar_codec(name).unwrap();
            let code = c.encode(v);
            prop_assert!(code >> c.bits() == 0, "{name}: code too wide");
            let d = c.decode(code);
            prop_assert!(d.is_finite(), "{name}: {v} → {d}");
            let (lo, hi) = c.domain();
            prop_assert!(d >= lo && d <= hi, "{name}: {v} → {d} outside [{lo}, {hi}]");
            // Out-of-domain input is clamped first; NaN has its own documented value, checked in codec_stiff.
            if !v.is_nan() {
                let t = v.clamp(lo, hi);
                prop_assert!((d - t).abs() <= c.error_bound(t), "{name}: {v} → {d}, |err| {} > {}", (d - t).abs(), c.error_bound(t));
            }
            let d2 = c.decode(c.encode(d));
            prop_assert_eq!(d2, d, "{}: decode∘encode∘decode", name);
        }
    }

    #[test]
    fn colors_round_trip_within_bound(r in any_scalar(), g in any_scalar(), b in any_scalar()) {
        let v = Vec3::new(r, g, b);
        for name in COLORS {
            let c = color_codec(name).unwrap();
            let d = c.decode_wide(c.encode_wide(v));
            prop_assert!(d.is_finite(), "{name}: {v} → {d}");
            let (lo, hi) = c.domain();
            let t = v.map(|x| if x.is_nan() { 0.0f32.clamp(lo, hi) } else { x.clamp(lo, hi) });
            let bound = c.error_bound(t);
            prop_assert!((d - t).abs().cmple(bound).all(), "{name}: {v} → {d}, bound {bound}");
            let d2 = c.decode_wide(c.encode_wide(d));
            prop_assert_eq!(d2, d, "{}: decode∘encode∘decode", name);
        }
    }

    #[test]
    fn depths_round_trip_within_bound(z in any_scalar(), near in 0.01f32..1.0, ratio in 2.0f32..100_000.0) {
        let far = near * ratio;
        for name in DEPTHS {
            let c = depth_codec(name, near, far).unwrap();
            let d = c.decode(c.encode(z));
            prop_assert!(d.is_finite() && d > 0.0, "{name}: {z} → {d}");
            let (lo, hi) = c.domain();
            if !z.is_nan() {
                let t = z.clamp(lo, hi);
                prop_assert!((d - t).abs() <= c.error_bound(t), "{name} [{near}, {far}]: {z} → {d}, bound {}", c.error_bound(t));
            }
            // Re-encoding the decoded depth lands within the bound: exact idempotence is impossible where the
            // f32 result has less precision than the code (unorm24 near the near plane).
            let d2 = c.decode(c.encode(d));
            prop_assert!((d2 - d).abs() <= c.error_bound(d), "{name}: {d} → {d2}");
        }
    }
}
