//! Stiff and extreme input for every codec family, each with its documented result.

use gbuf::codec::normal::{ispc_spheremap_decode, ispc_spheremap_encode, Lambert, SpheremapCry};
use gbuf::codec::{angle_deg, color_codec, depth_codec, normal_codec, scalar_codec, NormalScheme};
use glam::{Vec2, Vec3};

/// f32 rounding of the literal spheremap formulas near their rim (see the unit test in spheremap.rs).
const SPHEREMAP_AGREE_DEG: f32 = 0.05;
/// Mittring's literal `sqrt(n.z·0.5+0.5)` cancels near −Z: an f32 rounding δ ≈ 6e-8 under the root becomes up to
/// √δ ≈ 2.4e-4 in |g| at the centre of the disc (the Lambert form we use on z ≥ 0 does not cancel).
const PLANE_AGREE: f32 = 3e-4;

#[test]
fn the_three_spheremap_formulations_agree_on_normalized_input() {
    // CryEngine 3 (Mittring), Lambert azimuthal equal-area (mirrored in z) and ISPC's decode, on a dense sweep.
    for n in gbuf::codec::eval::evaluation_set(20_000, 5_000) {
        let g = SpheremapCry::project(n);
        let cry = SpheremapCry::unproject(g).normalize();
        let ispc = ispc_spheremap_decode(ispc_spheremap_encode(n)).normalize();
        let mirrored = Vec3::new(n.x, n.y, -n.z);
        let lam = Lambert::unproject(Lambert::project(mirrored)).normalize();
        let lam = Vec3::new(lam.x, lam.y, -lam.z);
        for (what, v) in [("cry", cry), ("ispc", ispc), ("lambert", lam)] {
            assert!(angle_deg(n, v) < SPHEREMAP_AGREE_DEG, "{what} of {n}: {v}");
        }
        let dg = (Lambert::project(mirrored) - g).length();
        assert!(dg < PLANE_AGREE, "{n}: lambert plane ≠ cry plane by {dg}");
    }
    // And the quantized codecs built on them decode every 16-bit code identically up to rounding.
    let (cry, ispc) = (normal_codec("spheremap-cry-16").unwrap(), normal_codec("spheremap-ispc-16").unwrap());
    for n in gbuf::codec::eval::fibonacci_sphere(2_000) {
        let (a, b) = (cry.decode(cry.encode(n)), ispc.decode(ispc.encode(n)));
        // Different quantization grids (snorm g vs unorm g·½+½): both within their bounds of n.
        assert!(angle_deg(n, a) <= cry.max_error_deg() && angle_deg(n, b) <= ispc.max_error_deg(), "{n}: {a} {b}");
    }
}

#[test]
fn spheremap_singularity_and_near_pole_vectors() {
    for bits in [16, 24, 32] {
        for name in ["spheremap-cry", "spheremap-ispc", "lambert", "stereo", "oct", "spherical"] {
            let c = normal_codec(&format!("{name}-{bits}")).unwrap();
            for n in [
                Vec3::NEG_Z,
                Vec3::Z,
                Vec3::new(1e-7, 0.0, -1.0),
                Vec3::new(0.0, -1e-7, 1.0),
                Vec3::new(-1e-7, 1e-7, -1.0),
            ] {
                let d = c.decode(c.encode(n));
                assert!(d.is_finite() && (d.length() - 1.0).abs() < 1e-6, "{}: {n} → {d}", c.name());
                if c.in_domain(n.normalize()) {
                    let e = angle_deg(n, d);
                    assert!(e <= c.max_error_deg(), "{}: {n} → {d} ({e}°)", c.name());
                }
            }
        }
    }
    // The singular point of the CryEngine encode is exact, not merely finite.
    let cry = normal_codec("spheremap-cry-16").unwrap();
    assert_eq!(cry.decode(cry.encode(Vec3::NEG_Z)), Vec3::NEG_Z);
    assert_eq!(cry.decode(cry.encode(Vec3::Z)), Vec3::Z);
    assert_eq!(ispc_spheremap_decode(Vec2::splat(0.5)).normalize(), Vec3::NEG_Z);
}

#[test]
fn hemisphere_codecs_mirror_the_back_hemisphere_as_documented() {
    for s in [NormalScheme::XyHemi, NormalScheme::XyHemiF16] {
        let c = s.codec(s.valid_bits()[s.valid_bits().len() - 1]).unwrap();
        let n = Vec3::new(0.6, 0.0, -0.8);
        let d = c.decode(c.encode(n));
        assert!(angle_deg(d, Vec3::new(0.6, 0.0, 0.8)) < 0.5, "{}: {d}", c.name());
        assert!(!c.in_domain(n) && c.in_domain(Vec3::Z));
    }
}

#[test]
fn f16_overflow_and_underflow() {
    let h = scalar_codec("f16").unwrap();
    assert_eq!(h.decode(h.encode(65504.0)), 65504.0);
    assert_eq!(h.decode(h.encode(65519.0)), 65504.0); // would round to Inf in IEEE; clamped
    assert_eq!(h.decode(h.encode(1e30)), 65504.0);
    assert_eq!(h.decode(h.encode(f32::INFINITY)), 65504.0);
    assert_eq!(h.decode(h.encode(f32::NEG_INFINITY)), -65504.0);
    assert_eq!(h.decode(h.encode(f32::NAN)), 0.0);
    assert_eq!(h.decode(h.encode(2f32.powi(-24))), 2f32.powi(-24)); // smallest subnormal survives
    assert_eq!(h.decode(h.encode(2f32.powi(-26))), 0.0); // below half of it flushes to zero
    assert_eq!(h.decode(h.encode(1e-40)), 0.0);
    let c = color_codec("f16").unwrap();
    assert_eq!(c.decode(c.encode(Vec3::new(1e9, -1e9, f32::NAN))), Vec3::new(65504.0, -65504.0, 0.0));
    let d = depth_codec("f16", 0.1, 1e6).unwrap();
    assert_eq!(d.decode(d.encode(1e6)), 65504.0);
    assert_eq!(d.decode(d.encode(1e-12)), 2f32.powi(-24));
    assert_eq!(d.decode(d.encode(f32::NAN)), 65504.0); // NaN → far plane, clamped to the f16 range
    let n = normal_codec("xyz-f16-48").unwrap();
    assert_eq!(n.decode(n.encode(Vec3::new(0.0, 0.0, 1e9))), Vec3::Z);
    // Every f16 bit pattern, including Inf and NaN, decodes to something finite in every f16 codec.
    for bits in 0..=u16::MAX {
        let code = u64::from(bits);
        assert!(h.decode(code).is_finite());
        assert!(d.decode(code).is_finite() && d.decode(code) > 0.0);
        for name in ["oct-f16-32", "stereo-f16-32", "xy-hemi-f16-32"] {
            let c = normal_codec(name).unwrap();
            assert!(c.decode(code | (code << 16)).is_finite());
        }
    }
}

#[test]
fn depth_at_and_beyond_the_planes() {
    let (near, far) = (0.1, 500.0);
    for name in ["unorm16", "unorm24", "unorm16-reversed", "unorm24-reversed", "f32-reversed", "f32-standard"] {
        let c = depth_codec(name, near, far).unwrap();
        let rt = |z: f32| c.decode(c.encode(z));
        assert!((rt(near) - near).abs() <= c.error_bound(near), "{name} at near: {}", rt(near));
        assert!((rt(far) - far).abs() <= c.error_bound(far), "{name} at far: {}", rt(far));
        for beyond in [far * 1.0001, far * 10.0, f32::MAX, f32::INFINITY, f32::NAN] {
            assert_eq!(rt(beyond), rt(far), "{name}: {beyond} should read as the far plane");
        }
        for before in [near * 0.999, 0.0, -0.0, -1.0, f32::NEG_INFINITY, 1e-40] {
            assert_eq!(rt(before), rt(near), "{name}: {before} should read as the near plane");
        }
        // Every decoded value of the 16-bit codecs lies within the planes.
        if c.bits() == 16 {
            for code in 0..=0xffff {
                let z = c.decode(code);
                assert!(z >= near && z <= far, "{name}: code {code} → {z}");
            }
        }
    }
    let lin = depth_codec("f32", near, far).unwrap();
    assert_eq!(lin.decode(lin.encode(far * 10.0)), far * 10.0); // linear f32 keeps depths beyond the far plane
    assert_eq!(lin.decode(lin.encode(f32::NAN)), far);
    assert_eq!(lin.decode(lin.encode(-5.0)), f32::MIN_POSITIVE);
    assert_eq!(lin.decode(lin.encode(f32::INFINITY)), f32::MAX);
}

#[test]
fn standard_unorm16_precision_collapses_towards_far_as_documented() {
    let c = depth_codec("unorm16", 0.1, 1000.0).unwrap();
    let rel = c.error_bound(1000.0) / 1000.0;
    assert!(rel > 0.03 && rel < 0.2, "documented ≈7%, bound says {rel}");
    let c24 = depth_codec("unorm24", 0.1, 1000.0).unwrap();
    let rel24 = c24.error_bound(1000.0) / 1000.0;
    assert!(rel24 < 1e-3, "{rel24}");
}

#[test]
fn colour_codecs_clamp_and_flush_as_documented() {
    let r11 = color_codec("r11g11b10f").unwrap();
    assert_eq!(r11.decode(r11.encode(Vec3::new(-1.0, f32::NAN, f32::INFINITY))), Vec3::new(0.0, 0.0, 64512.0));
    assert_eq!(r11.decode(r11.encode(Vec3::splat(1e-30))), Vec3::ZERO);
    let e5 = color_codec("rgb9e5").unwrap();
    assert_eq!(e5.decode(e5.encode(Vec3::new(f32::INFINITY, -3.0, 0.5))), Vec3::new(65408.0, 0.0, 0.0));
    let srgb = color_codec("srgb8").unwrap();
    assert_eq!(srgb.decode(srgb.encode(Vec3::new(2.0, -1.0, f32::NAN))), Vec3::new(1.0, 0.0, 0.0));
    // sRGB spends its codes on dark values: 0.002 survives far better than in linear unorm8.
    let lin = color_codec("unorm8").unwrap();
    let v = Vec3::splat(0.002);
    assert!((srgb.decode(srgb.encode(v)) - v).abs().max_element() < 2e-4);
    assert!((lin.decode(lin.encode(v)) - v).abs().max_element() > 1e-3);
}
