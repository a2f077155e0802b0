//! Octahedral normal encoding: project onto the octahedron |x|+|y|+|z| = 1, unfold the lower half over the
//! square's corners.
//!
//! Sources: Meyer, Sander, Munzner, Strong, "On Floating-Point Normal Vectors", EGSR 2010; Cigolle, Donow, Evangelakos,
//! Mara, McGuire, Meyer, "A Survey of Efficient Representations for Independent Unit Vectors", JCGT 3(2), 2014
//! (`float32x3_to_oct`, `oct_to_float32x3`, and the precise variant `float32x3_to_octn_precise`).
//!
//! Error bound: the decode map stretches plane distances by at most 3 (the largest singular value of its Jacobian,
//! reached at the face centres (±⅓, ±⅓)), so a plane error of (hx, hy) moves the normal by at most
//! 3·√(hx²+hy²) radians. With snorm k bits h = 1/(2·(2^(k−1)−1)): oct-16 ≤ 0.957°, oct-24 ≤ 0.0596°. The
//! precise variant never does worse (its candidate set contains the rounded code). Domain: the whole sphere.
//! Fold lines (x = 0 or y = 0 with z < 0) and −0.0 use `signNotZero`, so −0.0 folds like +0.0.

use super::{finish, sanitize, sign_not_zero, NormalCodec, Planar, Projection, Quant};
use crate::base::isa::Isa;
use crate::codec::mask;
use crate::codec::Codec;
use glam::{Vec2, Vec3};

/// The octahedral projection (plane coordinates in [−1, 1]², snorm or f16).
#[derive(Clone, Copy, Debug, Default)]
pub struct Oct;

/// Largest stretch of the octahedral decode map (radians per unit of plane distance).
pub const OCT_MAX_STRETCH: f32 = 3.0;

impl Oct {
    /// Unit vector → octahedral plane point in [−1, 1]².
    #[inline(always)]
    #[must_use]
    pub fn project(n: Vec3) -> Vec2 {
        let l1 = n.x.abs() + n.y.abs() + n.z.abs();
        let p = Vec2::new(n.x, n.y) / l1;
        if n.z >= 0.0 {
            p
        } else {
            Vec2::new((1.0 - p.y.abs()) * sign_not_zero(p.x), (1.0 - p.x.abs()) * sign_not_zero(p.y))
        }
    }

    /// Octahedral plane point → (unnormalised) vector.
    #[inline(always)]
    #[must_use]
    pub fn unproject(p: Vec2) -> Vec3 {
        let p = p.clamp(Vec2::NEG_ONE, Vec2::ONE);
        let z = 1.0 - p.x.abs() - p.y.abs();
        if z >= 0.0 {
            Vec3::new(p.x, p.y, z)
        } else {
            Vec3::new((1.0 - p.y.abs()) * sign_not_zero(p.x), (1.0 - p.x.abs()) * sign_not_zero(p.y), z)
        }
    }
}

impl Projection for Oct {
    fn scheme_name(&self, q: Quant) -> &'static str {
        if q == Quant::F16 {
            "oct-f16"
        } else {
            "oct"
        }
    }
    #[inline(always)]
    fn encode_plane(&self, n: Vec3) -> Vec2 {
        Oct::project(n)
    }
    #[inline(always)]
    fn decode_plane(&self, p: Vec2) -> Vec3 {
        Oct::unproject(p)
    }
    fn decode_ops(&self) -> u32 {
        // clamp ×2, abs ×2, z = 1 − |x| − |y| (2), z ≥ 0 (1); the fold: 1 − |·| ×2, signNotZero ×2 (compare +
        // select), mul ×2 (8); select x, y (2).
        17
    }
    fn bound_rad(&self, hx: f32, hy: f32, _q: Quant) -> f32 {
        OCT_MAX_STRETCH * hx.hypot(hy)
    }
    fn plane_map(&self) -> Option<super::PlaneMap> {
        Some(super::PlaneMap::Oct)
    }
}

/// The octahedral fold, shared with the full-sphere azimuthal maps ([`super::LambertSphere`],
/// [`super::StereoSphere`]): a point of the square [−1, 1]² is a hemisphere (z ≥ 0 inside the diamond
/// |x| + |y| ≤ 1, z < 0 in the four corners), the signs of x and y, and magnitudes `(a, b)` in the quadrant of
/// the diamond, a + b ≤ 1. The lower hemisphere is reflected over the diamond's edge (`(a, b)` ↦
/// `(1 − b, 1 − a)`), an isometry of the plane, so a map that is Lipschitz on the diamond is Lipschitz on the
/// square with the same constant, and the two halves meet continuously on the edge (the equator).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Diamond {
    /// |x| of the point in the upper diamond.
    pub a: f32,
    /// |y| of the point in the upper diamond.
    pub b: f32,
    /// Sign of x (`signNotZero`: −0.0 counts as +).
    pub sx: f32,
    /// Sign of y.
    pub sy: f32,
    /// In the lower hemisphere (the square's corners)?
    pub lower: bool,
}

impl Diamond {
    /// [`Codec::decode_ops`] of [`Self::of_square`]: clamp ×2, abs ×2, |x| + |y| > 1 (add, compare),
    /// 1 − |y|, 1 − |x| (2), select a, b (2), signNotZero ×2 (compare + select each: 4).
    pub(crate) const OF_SQUARE_OPS: u32 = 14;

    /// Splits a square point (clamped to [−1, 1]² first).
    #[inline(always)]
    #[must_use]
    pub(crate) fn of_square(p: Vec2) -> Diamond {
        let p = p.clamp(Vec2::NEG_ONE, Vec2::ONE);
        let (ax, ay) = (p.x.abs(), p.y.abs());
        let lower = ax + ay > 1.0;
        let (a, b) = if lower { (1.0 - ay, 1.0 - ax) } else { (ax, ay) };
        Diamond { a, b, sx: sign_not_zero(p.x), sy: sign_not_zero(p.y), lower }
    }

    /// The square point: `(sx·a, sy·b)`, or its fold into the corner for the lower hemisphere.
    #[inline(always)]
    #[must_use]
    pub(crate) fn to_square(self) -> Vec2 {
        if self.lower {
            Vec2::new(self.sx * (1.0 - self.b), self.sy * (1.0 - self.a))
        } else {
            Vec2::new(self.sx * self.a, self.sy * self.b)
        }
    }
}

/// Precise octahedral encoding (Cigolle et al. 2014, "octP"): of the four codes around the projected point, keep
/// the one whose decoded normal is closest to the input. Same decoder, same code layout as [`Oct`] with snorm.
#[derive(Clone, Copy, Debug)]
pub struct OctPrecise {
    plain: Planar<Oct>,
    k: u32,
}

impl OctPrecise {
    /// Precise octahedral with `k` snorm bits per component.
    #[must_use]
    pub fn new(k: u32) -> Self {
        OctPrecise { plain: Planar::new(Oct, Quant::Snorm(k)), k }
    }
}

impl Codec for OctPrecise {
    type Value = Vec3;
    fn name(&self) -> String {
        format!("oct-precise-{}", 2 * self.k)
    }
    fn bits(&self) -> u32 {
        2 * self.k
    }
    fn encode(&self, n: Vec3) -> u64 {
        let n = sanitize(n);
        let m = ((1u32 << (self.k - 1)) - 1) as f32;
        let p = Oct::project(n) * m;
        let base = p.floor();
        let mut best = (f32::INFINITY, 0u64);
        for dy in [0.0, 1.0] {
            for dx in [0.0, 1.0] {
                let s = (base + Vec2::new(dx, dy)).clamp(Vec2::splat(-m), Vec2::splat(m));
                let code = ((s.x as i64 as u64) & mask(self.k)) | (((s.y as i64 as u64) & mask(self.k)) << self.k);
                // Squared chord distance: unlike 1 − dot it still separates neighbours at 16 bits in f32.
                let d = (self.decode(code) - n).length_squared();
                if d < best.0 {
                    best = (d, code);
                }
            }
        }
        best.1
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> Vec3 {
        finish(Oct::unproject(self.plain.plane_of(code)))
    }
    fn decode_ops(&self) -> u32 {
        // The plain snorm octahedral decoder: only the encoder searches.
        self.plain.decode_ops()
    }
    fn recipe(&self) -> Option<crate::codec::Recipe> {
        Some(crate::codec::Recipe::NormalOctPrecise { k: self.k })
    }
    fn decode_slice_isa(&self, isa: Isa, codes: &[u64], out: &mut [Vec3]) {
        // The same decoder as plain snorm octahedral, so its vectorised slice path (the encode search stays
        // scalar: the precise variant does not need to be cheap).
        self.plain.decode_slice_isa(isa, codes, out);
    }
}

impl NormalCodec for OctPrecise {
    fn max_error_deg(&self) -> f32 {
        self.plain.max_error_deg()
    }
}

/// The octahedral layout's fixed points, shared by every codec built on [`Diamond`]: +Z at the centre, −Z at the
/// four corners, the equator on the diamond's edge with the axes at its vertices and the 45° meridian mid-edge,
/// and −0.0 folding like +0.0.
#[cfg(test)]
pub(crate) fn assert_octahedral_layout(project: fn(Vec3) -> Vec2, unproject: fn(Vec2) -> Vec3) {
    assert_eq!(project(Vec3::Z), Vec2::ZERO);
    assert_eq!(project(Vec3::NEG_Z), Vec2::ONE);
    assert_eq!(finish(unproject(Vec2::ZERO)), Vec3::Z);
    for corner in [Vec2::ONE, Vec2::NEG_ONE, Vec2::new(1.0, -1.0), Vec2::new(-1.0, 1.0)] {
        assert_eq!(finish(unproject(corner)), Vec3::NEG_Z, "{corner}");
    }
    assert_eq!(project(Vec3::X), Vec2::X);
    assert_eq!(finish(unproject(Vec2::NEG_Y)), Vec3::NEG_Y);
    let e = project(Vec3::new(1.0, 1.0, 0.0).normalize());
    assert!((e - Vec2::splat(0.5)).length() < 1e-6, "{e}");
    let (a, b) = (Vec3::new(-0.0, 0.6, -0.8), Vec3::new(0.0, 0.6, -0.8));
    assert_eq!(project(a), project(b));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::normal::angle_deg;

    #[test]
    fn fold_lines_and_negative_zero_fold_like_positive_zero() {
        // x = −0.0 on the lower hemisphere: signNotZero treats it as +0.
        let a = Oct::project(Vec3::new(-0.0, 0.6, -0.8));
        let b = Oct::project(Vec3::new(0.0, 0.6, -0.8));
        assert_eq!(a, b);
        assert_eq!(Oct::project(Vec3::NEG_Z), Vec2::new(1.0, 1.0));
        assert_eq!(finish(Oct::unproject(Vec2::new(-1.0, -1.0))), Vec3::NEG_Z);
        assert_eq!(finish(Oct::unproject(Vec2::ZERO)), Vec3::Z);
    }

    #[test]
    fn precise_is_never_worse_than_rounding() {
        let plain = Planar::new(Oct, Quant::Snorm(8));
        let precise = OctPrecise::new(8);
        let mut rng = crate::base::rng::SplitMix64::new(7);
        let mut better = 0;
        for _ in 0..20_000 {
            let n = Vec3::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0));
            let n = sanitize(n);
            let e_plain = angle_deg(n, plain.decode(plain.encode(n)));
            let e_precise = angle_deg(n, precise.decode(precise.encode(n)));
            assert!(e_precise <= e_plain + 1e-4, "{n}: precise {e_precise} > plain {e_plain}");
            better += usize::from(e_precise + 1e-4 < e_plain);
        }
        assert!(better > 1000, "the precise search should often improve on rounding, improved {better}");
    }
}
