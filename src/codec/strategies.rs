//! Shared proptest strategies for codec tests: adversarial vectors and scalars.
//!
//! Included with `#[path]` by `tests/codec_props.rs`, `tests/codec_slices.rs` and `tests/codec_sphere.rs`, so it
//! depends only on `glam` and `proptest`. `codec/mod.rs` also compiles it into the library's unit-test build
//! (`#[cfg(test)]`), where no unit test calls it.
#![allow(dead_code)] // each test binary uses a subset

use glam::Vec3;
use proptest::prelude::*;

/// Hand-picked stiff unit (or nearly unit) vectors: poles, axes, octahedron fold lines, −0.0, vectors within
/// 1e-7 of the poles, denormal components.
#[must_use]
pub fn stiff_unit_vectors() -> Vec<Vec3> {
    let mut v = vec![
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
        Vec3::new(-0.0, -0.0, 1.0),
        Vec3::new(-0.0, -0.0, -1.0),
        Vec3::new(-0.0, 0.6, -0.8),
        Vec3::new(0.6, -0.0, -0.8),
        Vec3::new(0.0, -0.6, -0.8),
        Vec3::new(-0.6, 0.0, -0.8),
        Vec3::new(1e-7, 0.0, 1.0),
        Vec3::new(0.0, -1e-7, -1.0),
        Vec3::new(1e-7, 1e-7, -1.0),
        Vec3::new(-1e-7, 1e-7, 1.0),
        Vec3::new(1e-40, 0.0, -1.0),
        Vec3::new(0.0, 1e-45, 1.0),
        Vec3::new(0.5, 0.5, 0.0),
        Vec3::new(-0.5, 0.5, -0.0),
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(1.0, -1.0, -1.0),
        Vec3::new(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0),
    ];
    for s in [1.0f32, -1.0] {
        // On the fold lines: x = 0 or y = 0 with z < 0, at many heights.
        for i in 1..8 {
            let z = -(i as f32) / 8.0;
            let r = (1.0 - z * z).sqrt();
            v.push(Vec3::new(0.0, s * r, z));
            v.push(Vec3::new(s * r, 0.0, z));
        }
    }
    v.into_iter().map(|n| if n.is_finite() && n.length() > 0.0 { n.normalize_or(n) } else { n }).collect()
}

/// Degenerate inputs: zero, tiny, huge, NaN and ±Inf components.
#[must_use]
pub fn degenerate_vectors() -> Vec<Vec3> {
    vec![
        Vec3::ZERO,
        Vec3::new(-0.0, -0.0, -0.0),
        Vec3::new(1e-30, -1e-30, 1e-30),
        Vec3::new(1e-45, 0.0, 0.0),
        Vec3::new(1e30, 1e30, -1e30),
        Vec3::new(f32::MAX, f32::MAX, f32::MAX),
        Vec3::new(f32::NAN, 0.0, 1.0),
        Vec3::NAN,
        Vec3::new(f32::INFINITY, 0.0, 0.0),
        Vec3::new(f32::NEG_INFINITY, f32::INFINITY, 1.0),
        Vec3::new(1.0, 2.0, f32::NEG_INFINITY),
        Vec3::INFINITY,
        Vec3::new(0.0, 0.0, 7.0),
        Vec3::new(0.0, 0.0, -1e-20),
    ]
}

/// A uniformly random unit vector (normalised Gaussian-free: z uniform, azimuth uniform).
pub fn unit_vector() -> impl Strategy<Value = Vec3> {
    (-1.0f32..=1.0, 0.0f32..std::f32::consts::TAU).prop_map(|(z, phi)| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    })
}

/// Unit vectors, weighted towards the stiff ones and the neighbourhoods of poles and fold lines.
pub fn adversarial_unit_vector() -> impl Strategy<Value = Vec3> {
    let near_pole = (-1e-6f32..1e-6, -1e-6f32..1e-6, prop::bool::ANY)
        .prop_map(|(x, y, up)| Vec3::new(x, y, if up { 1.0 } else { -1.0 }).normalize());
    let near_fold = (-1e-5f32..1e-5, -1.0f32..0.0, prop::bool::ANY, prop::bool::ANY).prop_map(|(e, z, swap, neg)| {
        let r = (1.0 - z * z).max(0.0).sqrt() * if neg { -1.0 } else { 1.0 };
        let v = if swap { Vec3::new(e, r, z) } else { Vec3::new(r, e, z) };
        v.normalize()
    });
    prop_oneof![
        4 => unit_vector(),
        2 => prop::sample::select(stiff_unit_vectors()),
        1 => near_pole,
        1 => near_fold,
    ]
}

/// Anything, including non-unit, zero, NaN and infinite vectors.
pub fn any_vector() -> impl Strategy<Value = Vec3> {
    let comp = prop_oneof![
        4 => -2.0f32..2.0,
        1 => prop::sample::select(vec![0.0, -0.0, 1e-40, -1e-45, 1e-30, 1e30, -1e30, f32::MAX, f32::NAN,
            f32::INFINITY, f32::NEG_INFINITY]),
        1 => any::<f32>(),
    ];
    prop_oneof![
        3 => adversarial_unit_vector(),
        1 => prop::sample::select(degenerate_vectors()),
        2 => (comp.clone(), comp.clone(), comp).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
    ]
}

/// Adversarial scalars: zero, −0.0, denormals, f16 overflow/underflow, NaN, ±Inf, plus ordinary values.
pub fn any_scalar() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => -2.0f32..2.0,
        2 => 0.0f32..70_000.0,
        1 => prop::sample::select(vec![0.0, -0.0, 1e-45, 1e-40, 5.9e-8, 2.9e-8, 65504.0, 65520.0, 1e6, -1e6,
            f32::MAX, f32::MIN, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1.0, 4096.0, 1e-30]),
        1 => any::<f32>(),
    ]
}
