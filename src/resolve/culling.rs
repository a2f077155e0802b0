//! Conservative light culling geometry: bounding volumes of a group of samples (a tile or a cluster) and of a
//! light's sphere of influence, and the tests between them.
//!
//! A group of samples is bounded by four planes through the eye and a depth slab. The planes are fitted to the
//! samples themselves (min/max of `x/d` and `y/d`, `d` = view depth), not to the tile's pixel rectangle, so the
//! test is conservative for any positions (a dump's own position plane, a fitted camera) and needs no camera.
//! For a pinhole camera, `x/d` is an affine function of the pixel column, so this *is* the tile frustum tightened
//! to the covered samples.
//!
//! A light's influence is the sphere of radius `range` (∞ for directional and unbounded lights: never culled).
//! Both falloffs are exactly 0 at and beyond `range`; the sphere is grown by [`CULL_MARGIN`] so f32 rounding in
//! the tests cannot drop a light whose rounded contribution is not exactly 0.

use super::simd::Lanes;
use super::worklist::{Items, QuadSoa};
use crate::light::Light;
use glam::Vec3;

/// Relative growth of light radii and of screen rectangles before culling tests (f32 rounding headroom).
pub const CULL_MARGIN: f32 = 1e-4;

/// Bounds of a group of samples: tangent-space rectangle (`x/d`, `y/d`) and depth range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// min x/d.
    pub tx0: f32,
    /// max x/d.
    pub tx1: f32,
    /// min y/d.
    pub ty0: f32,
    /// max y/d.
    pub ty1: f32,
    /// min view depth.
    pub d0: f32,
    /// max view depth.
    pub d1: f32,
    planes: [Vec3; 4],
}

impl Bounds {
    /// Bounds of `items[range]`; `None` when the range is empty.
    #[must_use]
    pub fn of_items(it: &Items, range: std::ops::Range<usize>) -> Option<Bounds> {
        if range.is_empty() {
            return None;
        }
        // Sixteen running minima/maxima per quantity, folded at the end: the loop vectorises (positions are
        // finite, so plain comparisons are enough).
        const W: usize = 16;
        let (px, py, pz) = (&it.px[range.clone()], &it.py[range.clone()], &it.pz[range]);
        let mut lo = [[f32::INFINITY; W]; 3];
        let mut hi = [[f32::NEG_INFINITY; W]; 3];
        let min = |a: f32, b: f32| if b < a { b } else { a };
        let max = |a: f32, b: f32| if b > a { b } else { a };
        for ((x, y), z) in px.chunks(W).zip(py.chunks(W)).zip(pz.chunks(W)) {
            for k in 0..x.len() {
                // One division: x·(1/d) is within an ulp or two of x/d, far inside the culling margin.
                let d = -z[k];
                let inv = 1.0 / d;
                let v = [x[k] * inv, y[k] * inv, d];
                for q in 0..3 {
                    lo[q][k] = min(lo[q][k], v[q]);
                    hi[q][k] = max(hi[q][k], v[q]);
                }
            }
        }
        let fold_lo = |a: &[f32; W]| a.iter().fold(f32::INFINITY, |m, &v| min(m, v));
        let fold_hi = |a: &[f32; W]| a.iter().fold(f32::NEG_INFINITY, |m, &v| max(m, v));
        let d1 = fold_hi(&hi[2]).max(0.0);
        Some(Bounds::new(fold_lo(&lo[0]), fold_hi(&hi[0]), fold_lo(&lo[1]), fold_hi(&hi[1]), fold_lo(&lo[2]), d1))
    }

    /// [`Bounds::of_items`] a vector of [`Lanes::N`] items at a time when `range` is a whole number of vectors (work
    /// lists are padded to whole vectors with copies of a real item, which change no bound). `1/d` comes from
    /// [`Lanes::recip`] (within an ulp or two of the division: far inside [`CULL_MARGIN`]).
    #[inline(always)]
    #[must_use]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))] // the AVX-512 tile bounds and the tests
    pub fn of_items_in<V: Lanes>(it: &Items, range: std::ops::Range<usize>) -> Option<Bounds> {
        if range.is_empty() || !range.len().is_multiple_of(V::N) {
            return Bounds::of_items(it, range);
        }
        let s = V::splat;
        let zero = s(0.0);
        let (mut lo, mut hi) = ([s(f32::INFINITY); 3], [s(f32::NEG_INFINITY); 3]);
        let mut c = range.start;
        while c < range.end {
            let d = zero - V::load(&it.pz[c..]);
            let inv = d.recip();
            let (tx, ty) = (V::load(&it.px[c..]) * inv, V::load(&it.py[c..]) * inv);
            (lo[0], hi[0]) = (lo[0].min(tx), hi[0].max(tx));
            (lo[1], hi[1]) = (lo[1].min(ty), hi[1].max(ty));
            (lo[2], hi[2]) = (lo[2].min(d), hi[2].max(d));
            c += V::N;
        }
        let d1 = hi[2].hmax().max(0.0);
        Some(Bounds::new(lo[0].hmin(), hi[0].hmax(), lo[1].hmin(), hi[1].hmax(), lo[2].hmin(), d1))
    }

    /// Bounds from explicit extents.
    #[must_use]
    pub fn new(tx0: f32, tx1: f32, ty0: f32, ty1: f32, d0: f32, d1: f32) -> Bounds {
        // Inside ⇔ n · p ≥ 0 for each (unit) normal; with d = −z: x ≥ tx0·d ⇔ x + tx0·z ≥ 0, and so on.
        let planes = [
            Vec3::new(1.0, 0.0, tx0).normalize(),
            Vec3::new(-1.0, 0.0, -tx1).normalize(),
            Vec3::new(0.0, 1.0, ty0).normalize(),
            Vec3::new(0.0, -1.0, -ty1).normalize(),
        ];
        Bounds { tx0, tx1, ty0, ty1, d0, d1, planes }
    }

    /// Can a sphere at `c` with radius `r` (already grown by the margin) reach a point inside the bounds?
    #[inline(always)]
    #[must_use]
    pub fn may_touch(&self, c: Vec3, r: f32) -> bool {
        // Non-short-circuit `&` so a loop over lights compiles to branch-free vector code.
        let depth = -c.z;
        let [a, b, e, f] = self.planes;
        (depth + r >= self.d0)
            & (depth - r <= self.d1)
            & (a.dot(c) >= -r)
            & (b.dot(c) >= -r)
            & (e.dot(c) >= -r)
            & (f.dot(c) >= -r)
    }

    /// Appends to `out` the indices of the spheres (centres `x, y, z`, radii `r`) for which [`Bounds::may_touch`]
    /// holds, in increasing order: the same arithmetic, [`Lanes::N`] spheres at a time, the survivors written by
    /// [`Lanes::compress_indices`] (no branch per sphere). No closures: they are not inlined into the vector code.
    #[inline(always)]
    pub fn touching<V: Lanes>(&self, x: &[f32], y: &[f32], z: &[f32], r: &[f32], out: &mut Vec<u32>) {
        let n = x.len();
        let start = out.len();
        out.resize(start + n + V::N, 0);
        let mut len = start;
        let p = TouchPlanes::<V>::new(self);
        let mut base = 0;
        while base + V::N <= n {
            let c = [V::load(&x[base..]), V::load(&y[base..]), V::load(&z[base..])];
            len += p.group(c, V::load(&r[base..]), base, &mut out[len..]);
            base += V::N;
        }
        if base < n {
            // The last partial group, padded with spheres of radius −∞ (never touching).
            let mut t = [[0.0f32; 64]; 4];
            t[3] = [f32::NEG_INFINITY; 64];
            for (dst, src) in t.iter_mut().zip([x, y, z, r]) {
                dst[..n - base].copy_from_slice(&src[base..n]);
            }
            let c = [V::load(&t[0]), V::load(&t[1]), V::load(&t[2])];
            len += p.group(c, V::load(&t[3]), base, &mut out[len..]);
        }
        out.truncate(len);
    }

    /// Does a quad rectangle (light `i` of `q`) overlap these bounds (rectangle and depth)?
    #[inline]
    #[must_use]
    pub fn overlaps_quad(&self, q: &QuadSoa, i: usize) -> bool {
        q.x0[i] <= self.tx1
            && q.x1[i] >= self.tx0
            && q.y0[i] <= self.ty1
            && q.y1[i] >= self.ty0
            && q.z0[i] <= self.d1
            && q.z1[i] >= self.d0
    }
}

/// [`Bounds`] as vectors, for [`Bounds::touching`].
struct TouchPlanes<V> {
    planes: [[V; 3]; 4],
    d0: V,
    d1: V,
}

impl<V: Lanes> TouchPlanes<V> {
    #[inline(always)]
    fn new(b: &Bounds) -> Self {
        let s = V::splat;
        let p = |i: usize| [s(b.planes[i].x), s(b.planes[i].y), s(b.planes[i].z)];
        TouchPlanes { planes: [p(0), p(1), p(2), p(3)], d0: s(b.d0), d1: s(b.d1) }
    }

    /// [`Bounds::may_touch`] for `N` spheres; their indices (`base + lane`) written to `out`, the count returned.
    #[inline(always)]
    fn group(&self, c: [V; 3], r: V, base: usize, out: &mut [u32]) -> usize {
        let zero = V::splat(0.0);
        let depth = zero - c[2];
        let neg_r = zero - r;
        let [a, b, e, f] = &self.planes;
        let m = V::and(
            V::and((depth + r).ge(self.d0), (depth - r).le(self.d1)),
            V::and(
                V::and(dot3(a, &c).ge(neg_r), dot3(b, &c).ge(neg_r)),
                V::and(dot3(e, &c).ge(neg_r), dot3(f, &c).ge(neg_r)),
            ),
        );
        V::compress_indices(m, base as u32, out)
    }
}

/// `Vec3::dot` lane by lane: (x·x' + y·y') + z·z', no fused multiply-add.
#[inline(always)]
fn dot3<V: Lanes>(p: &[V; 3], c: &[V; 3]) -> V {
    p[0] * c[0] + p[1] * c[1] + p[2] * c[2]
}

/// Culling sphere of a (sanitised) light: centre and grown radius (∞ for directional / unbounded lights).
#[must_use]
pub fn light_sphere(l: &Light) -> (Vec3, f32) {
    if l.is_directional() || !l.range.is_finite() {
        return (l.position, f32::INFINITY);
    }
    let r = l.range * (1.0 + CULL_MARGIN) + CULL_MARGIN * l.position.abs().max_element();
    (l.position, r)
}

/// Tangent-space interval `[m0, m1]` covering a circle of radius `r` centred at lateral offset `c` and depth
/// `d`, seen from the eye; the whole line when the circle reaches the eye plane.
fn tangent_interval(c: f32, d: f32, r: f32) -> (f32, f32) {
    let den = d * d - r * r;
    if d.is_nan() || d <= r || den.is_nan() || den <= 0.0 || !r.is_finite() {
        return (f32::NEG_INFINITY, f32::INFINITY);
    }
    let root = (c * c + den).sqrt();
    let (m0, m1) = ((c * d - r * root) / den, (c * d + r * root) / den);
    let grow = |m: f32| CULL_MARGIN * (1.0 + m.abs());
    (m0 - grow(m0), m1 + grow(m1))
}

/// Quad-culling rectangles and depth bounds of every light (screen rectangle in tangent units `x/d`, `y/d`).
#[must_use]
pub fn quad_rects(lights: &[Light]) -> QuadSoa {
    let mut q = QuadSoa::default();
    for l in lights {
        let (c, r) = light_sphere(l);
        let d = -c.z;
        let (x0, x1) = tangent_interval(c.x, d, r);
        let (y0, y1) = tangent_interval(c.y, d, r);
        let (z0, z1) = if r.is_finite() { (d - r, d + r) } else { (f32::NEG_INFINITY, f32::INFINITY) };
        q.x0.push(x0);
        q.x1.push(x1);
        q.y0.push(y0);
        q.y1.push(y1);
        q.z0.push(z0);
        q.z1.push(z1);
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;

    #[test]
    fn vector_bounds_and_light_lists_match_the_scalar_ones() {
        use crate::resolve::simd::Portable;
        let mut rng = SplitMix64::new(5);
        let mut it = Items::default();
        it.resize(48);
        for j in 0..48 {
            (it.px[j], it.py[j], it.pz[j]) =
                (rng.range_f32(-5.0, 5.0), rng.range_f32(-3.0, 3.0), rng.range_f32(-40.0, -0.5));
        }
        let want = Bounds::of_items(&it, 0..48).unwrap();
        assert_eq!(Bounds::of_items_in::<Portable<false>>(&it, 0..48), Some(want));
        let (mut x, mut y, mut z, mut r) = (vec![], vec![], vec![], vec![]);
        for _ in 0..1000 {
            x.push(rng.range_f32(-20.0, 20.0));
            y.push(rng.range_f32(-20.0, 20.0));
            z.push(rng.range_f32(-60.0, 10.0));
            r.push(if rng.next_f32() < 0.01 { f32::INFINITY } else { rng.range_f32(0.1, 8.0) });
        }
        let scalar: Vec<u32> = (0..1000u32)
            .filter(|&i| want.may_touch(Vec3::new(x[i as usize], y[i as usize], z[i as usize]), r[i as usize]))
            .collect();
        assert!(!scalar.is_empty() && scalar.len() < 1000);
        let mut list = vec![7];
        want.touching::<Portable<false>>(&x, &y, &z, &r, &mut list);
        assert_eq!(list[0], 7, "appends");
        assert_eq!(&list[1..], &scalar[..]);
        #[cfg(target_arch = "x86_64")]
        if crate::base::isa::Isa::detect() == crate::base::isa::Isa::Avx512 {
            /// The AVX-512 lanes' culling and bounds, compiled for AVX-512.
            struct Run<'a>(&'a Items, &'a Bounds, [&'a [f32]; 4], &'a mut Vec<u32>);
            impl crate::base::isa::Kernel for Run<'_> {
                type Output = Option<Bounds>;
                #[inline(always)]
                fn run(self, _: crate::base::isa::Isa) -> Option<Bounds> {
                    use crate::resolve::simd::Avx512;
                    let Run(it, b, s, out) = self;
                    b.touching::<Avx512>(s[0], s[1], s[2], s[3], out);
                    Bounds::of_items_in::<Avx512>(it, 0..48)
                }
            }
            let mut list = Vec::new();
            let got =
                crate::base::isa::run(crate::base::isa::Isa::Avx512, Run(&it, &want, [&x, &y, &z, &r], &mut list))
                    .unwrap();
            assert_eq!(list, scalar);
            for (g, w) in [(got.tx0, want.tx0), (got.tx1, want.tx1), (got.ty0, want.ty0), (got.ty1, want.ty1)] {
                assert!((g - w).abs() <= 1e-6 * w.abs().max(1e-3), "{got:?} vs {want:?}");
            }
            assert_eq!((got.d0, got.d1), (want.d0, want.d1));
        }
    }

    #[test]
    fn sphere_touching_a_sample_is_never_culled() {
        let mut rng = SplitMix64::new(3);
        for _ in 0..2000 {
            let p = Vec3::new(rng.range_f32(-5.0, 5.0), rng.range_f32(-5.0, 5.0), rng.range_f32(-20.0, -0.5));
            let q = p + Vec3::new(rng.range_f32(-0.3, 0.3), rng.range_f32(-0.3, 0.3), rng.range_f32(-0.3, 0.0));
            let (d0, d1) = (-p.z, -q.z);
            let b = Bounds::new(
                (p.x / d0).min(q.x / d1),
                (p.x / d0).max(q.x / d1),
                (p.y / d0).min(q.y / d1),
                (p.y / d0).max(q.y / d1),
                d0.min(d1),
                d0.max(d1),
            );
            let c = p + Vec3::new(rng.range_f32(-3.0, 3.0), rng.range_f32(-3.0, 3.0), rng.range_f32(-3.0, 3.0));
            let (c, r) = light_sphere(&Light::point(c, Vec3::ONE, 1.0, (c - p).length()));
            assert!(b.may_touch(c, r), "sphere {c} r {r} contains {p} but was culled by {b:?}");
        }
    }

    #[test]
    fn far_spheres_are_culled() {
        let b = Bounds::new(-0.1, 0.1, -0.1, 0.1, 9.0, 10.0);
        assert!(b.may_touch(Vec3::new(0.0, 0.0, -9.5), 0.1));
        assert!(!b.may_touch(Vec3::new(0.0, 0.0, -5.0), 1.0)); // in front of the slab
        assert!(!b.may_touch(Vec3::new(5.0, 0.0, -9.5), 1.0)); // right of the frustum
        assert!(!b.may_touch(Vec3::new(0.0, -5.0, -9.5), 1.0)); // below
        assert!(b.may_touch(Vec3::new(5.0, 0.0, -9.5), f32::INFINITY));
    }

    #[test]
    fn quad_rectangle_contains_the_projected_sphere() {
        let l = Light::point(Vec3::new(1.0, -2.0, -10.0), Vec3::ONE, 1.0, 3.0);
        let q = quad_rects(&[l]);
        let mut rng = SplitMix64::new(9);
        for _ in 0..5000 {
            let dir = Vec3::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0));
            let p = l.position + dir.normalize_or_zero() * 3.0;
            let (tx, ty) = (p.x / -p.z, p.y / -p.z);
            assert!(tx >= q.x0[0] && tx <= q.x1[0] && ty >= q.y0[0] && ty <= q.y1[0], "{p}");
            assert!(-p.z >= q.z0[0] && -p.z <= q.z1[0]);
        }
        // A sphere around the eye covers the whole screen.
        let q = quad_rects(&[Light::point(Vec3::new(0.0, 0.0, -1.0), Vec3::ONE, 1.0, 3.0)]);
        assert_eq!((q.x0[0], q.x1[0]), (f32::NEG_INFINITY, f32::INFINITY));
    }
}
