//! The batched shading kernel: a packed work list of samples (structure of arrays, 16-item vectors) against a list
//! of lights (one cache-line record each). The outer loop walks vectors, the next loop lights; the lanes of a vector
//! are one [`Lanes`] value, so the kernel is written once and compiled for AVX-512, for AVX2+FMA and for any other
//! x86-64 CPU, picked at run time, and for NEON on aarch64, where it is part of the baseline ([`instruction_set`]).
//!
//! The formulas are those of `brdf.rs` / `falloff.rs` in f32, with per-light and per-sample constants hoisted.
//! Every light's contribution to a sample is added in light-index order whatever the culling, and a light that
//! cannot reach a sample adds exactly 0 (it may be skipped for a whole vector), so the image is bit-identical across
//! culling methods, tile sizes and thread counts.

use super::brdf::{DIELECTRIC_F0, MIN_ALPHA, MIN_HALF_LENGTH, MIN_NDOTV};
use super::config::{Brdf, Falloff};
use super::falloff::MIN_DISTANCE;
use super::lights::{LightRec, LightTable, LUMA};
pub use super::simd::BLOCK;
use super::simd::{lanes_for, BaselineLanes, Lanes, Portable, Two};
use super::worklist::{Items, QuadSoa};
use crate::base::fastmath::POW_MIN_BASE;
use crate::base::isa::Isa;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;
/// Which variant of the kernel: BRDF, falloff, per-sample quad test, light pre-pass accumulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variant {
    /// The BRDF.
    pub brdf: Brdf,
    /// The falloff.
    pub falloff: Falloff,
    /// Apply the per-sample rectangle + depth test of quad culling.
    pub quad: bool,
    /// Write light pre-pass buffers (diffuse light RGB in `or..ob`, monochrome specular in `ls`) instead of colour.
    pub prepass: bool,
}

/// Shades items `range` of `it` (a whole number of vectors) against every light of `lights` (and, for quad
/// culling, `quad`), overwriting the items' outputs, with the kernel compiled for `isa` (or the widest level
/// below it that this CPU has; on aarch64 every level is the NEON kernel).
pub fn shade(isa: Isa, it: &mut Items, range: std::ops::Range<usize>, lights: &LightTable, quad: &QuadSoa, v: Variant) {
    shade_with(Some(isa), it, range, lights, quad, v);
}

/// [`shade`] on the portable path whatever the CPU (to compare the vector paths against it).
#[cfg_attr(not(test), allow(dead_code))] // the bound / scalar path the tests check against
fn shade_portable(it: &mut Items, range: std::ops::Range<usize>, lights: &LightTable, quad: &QuadSoa, v: Variant) {
    shade_with(None, it, range, lights, quad, v);
}

/// [`shade`] with the lanes of `isa`, or the portable lanes for `None`.
fn shade_with(
    isa: Option<Isa>,
    it: &mut Items,
    range: std::ops::Range<usize>,
    lights: &LightTable,
    quad: &QuadSoa,
    v: Variant,
) {
    macro_rules! pick {
        ($b:literal, $f:literal) => {
            match (v.quad, v.prepass) {
                (false, false) => dispatch::<$b, $f, false, false>(isa, it, range, lights, quad),
                (true, false) => dispatch::<$b, $f, true, false>(isa, it, range, lights, quad),
                (false, true) => dispatch::<$b, $f, false, true>(isa, it, range, lights, quad),
                (true, true) => dispatch::<$b, $f, true, true>(isa, it, range, lights, quad),
            }
        };
    }
    match (v.brdf, v.falloff) {
        (Brdf::Lambert, Falloff::Gltf) => pick!(0, 0),
        (Brdf::Lambert, Falloff::Linear) => pick!(0, 1),
        (Brdf::BlinnPhong, Falloff::Gltf) => pick!(1, 0),
        (Brdf::BlinnPhong, Falloff::Linear) => pick!(1, 1),
        (Brdf::Ggx, Falloff::Gltf) => pick!(2, 0),
        (Brdf::Ggx, Falloff::Linear) => pick!(2, 1),
    }
}

/// The instruction set the kernel runs with on this CPU ([`Isa::detect`], shared with the codecs' slice paths):
/// `avx512`, `avx2` (with FMA) or `baseline` (the portable kernel) on x86-64; `neon` on aarch64, whose baseline
/// has it (there `Isa::detect` is `baseline`, and the codecs run their portable code).
#[must_use]
pub fn instruction_set() -> &'static str {
    if cfg!(target_arch = "aarch64") {
        "neon"
    } else {
        Isa::detect().name()
    }
}

/// Runs the kernel with the lanes of `isa` (capped at [`Isa::detect`]), or the portable lanes for `None`.
fn dispatch<const B: u8, const F: u8, const Q: bool, const P: bool>(
    isa: Option<Isa>,
    it: &mut Items,
    range: std::ops::Range<usize>,
    lights: &LightTable,
    quad: &QuadSoa,
) {
    match isa {
        None => run::<Portable<false>, B, F, Q, P>(it, range, lights, quad),
        Some(isa) => crate::base::isa::run(isa, ShadeKernel::<B, F, Q, P> { it, range, lights, quad }),
    }
}

/// [`run`] under [`crate::base::isa::run`], with the lanes of the level it is compiled for.
struct ShadeKernel<'a, const B: u8, const F: u8, const Q: bool, const P: bool> {
    it: &'a mut Items,
    range: std::ops::Range<usize>,
    lights: &'a LightTable,
    quad: &'a QuadSoa,
}

impl<const B: u8, const F: u8, const Q: bool, const P: bool> crate::base::isa::Kernel for ShadeKernel<'_, B, F, Q, P> {
    type Output = ();
    #[inline(always)]
    fn run(self, isa: Isa) {
        let ShadeKernel { it, range, lights, quad } = self;
        lanes_for!(isa, BaselineLanes, |V| run::<V, B, F, Q, P>(it, range, lights, quad))
    }
}

#[inline(always)]
fn run<V: Lanes, const B: u8, const F: u8, const Q: bool, const P: bool>(
    it: &mut Items,
    range: std::ops::Range<usize>,
    lights: &LightTable,
    quad: &QuadSoa,
) {
    debug_assert!(range.len().is_multiple_of(V::N), "work lists are padded to whole vectors");
    // The lights reaching a vector: a buffer long enough for every light plus one vector's compressing store.
    // Quad culling tests every light per sample: its list is all of them, written once.
    let mut live = vec![0u32; lights.len() + V::N];
    if Q {
        for (i, l) in live[..lights.len()].iter_mut().enumerate() {
            *l = i as u32;
        }
    }
    let mut c = range.start;
    while c + V::N <= range.end {
        run_chunk::<V, B, F, Q, P>(it, c, lights, quad, &mut live);
        c += V::N;
    }
}

/// Per-sample constants of one vector of items, derived once and reused for every light.
struct Chunk<V> {
    p: [V; 3],
    n: [V; 3],
    /// Twice the unit vector to the eye, `2V` (`2 L·V` for the half vector in one dot product).
    v2: [V; 3],
    /// Raw N·V (for N·H through the half-vector identity).
    nv_raw: V,
    /// N·V floored at [`MIN_NDOTV`] (GGX visibility).
    nv: V,
    /// Blinn-Phong `specAmount · (p + 2)/8` and `p`.
    sn: V,
    pw: V,
    /// `p / (2 ln 2)` (Blinn-Phong's correction of the estimated 1/|H|, see [`step`]).
    pw_c: V,
    /// GGX α², `√((N·V)²(1 − α²) + α²)`, F0 and `c_diff/π`.
    a2: V,
    gv: V,
    f0: [V; 3],
    cd: [V; 3],
    /// Quad test inputs: `x/d`, `y/d`, `d`.
    t: [V; 3],
}

#[inline(always)]
fn dot<V: Lanes>(a: &[V; 3], b: &[V; 3]) -> V {
    a[0].mul_add(b[0], a[1].mul_add(b[1], a[2] * b[2]))
}

#[inline(always)]
fn load_chunk<V: Lanes, const B: u8, const Q: bool>(it: &Items, c: usize) -> Chunk<V> {
    let ld = |a: &[f32]| V::load(&a[c..]);
    let s = V::splat;
    let p = [ld(&it.px), ld(&it.py), ld(&it.pz)];
    let n = [ld(&it.nx), ld(&it.ny), ld(&it.nz)];
    let inv_len = dot(&p, &p).rsqrt();
    let m = s(0.0) - inv_len;
    let v = [p[0] * m, p[1] * m, p[2] * m];
    let nv_raw = dot(&n, &v);
    let m2 = m + m;
    let v2 = [p[0] * m2, p[1] * m2, p[2] * m2];
    let nv = nv_raw.max(s(MIN_NDOTV));
    let zero = s(0.0);
    let mut k = Chunk {
        p,
        n,
        v2,
        nv_raw,
        nv,
        sn: zero,
        pw: zero,
        pw_c: zero,
        a2: zero,
        gv: zero,
        f0: [zero; 3],
        cd: [zero; 3],
        t: [zero; 3],
    };
    if B == 1 {
        k.pw = ld(&it.pw);
        k.pw_c = k.pw * s(0.5 * std::f32::consts::LOG2_E);
        k.sn = ld(&it.spec) * (k.pw + s(2.0)) * s(0.125);
    }
    if B == 2 {
        let r = ld(&it.rough);
        let alpha = (r * r).max(s(MIN_ALPHA));
        k.a2 = alpha * alpha;
        let g2 = (nv * nv).mul_add(s(1.0) - k.a2, k.a2);
        k.gv = g2 * g2.rsqrt();
        let metal = ld(&it.metal);
        let albedo = [ld(&it.ar), ld(&it.ag), ld(&it.ab)];
        let diffuse = (s(1.0) - metal) * s(FRAC_1_PI);
        // Element by element: `array::map` is not inlined into the vector code.
        let f0 = |a: V| (a - s(DIELECTRIC_F0)).mul_add(metal, s(DIELECTRIC_F0));
        k.f0 = [f0(albedo[0]), f0(albedo[1]), f0(albedo[2])];
        k.cd = [albedo[0] * diffuse, albedo[1] * diffuse, albedo[2] * diffuse];
    }
    if Q {
        let d = zero - p[2];
        let inv_d = d.recip();
        k.t = [p[0] * inv_d, p[1] * inv_d, d];
    }
    k
}

/// One light's constants as vectors (for [`Two`], two lights', one per half).
struct LightK<V> {
    p: [V; 3],
    w: V,
    fa: V,
    fb: V,
    axis: [V; 3],
    cs: V,
    co: V,
    c: [V; 3],
    lum: V,
    /// Quad culling's rectangle and depth range (`x0, x1, y0, y1, z0, z1`).
    q: [V; 6],
    /// Evaluate the cone factor ([`LightTable::any_spot`]: the same for every light of the list).
    spot: bool,
}

#[inline(always)]
fn light_k<V: Lanes, const Q: bool>(r: &LightRec, quad: &QuadSoa, l: usize, spot: bool) -> LightK<V> {
    let s = V::splat;
    let zero = s(0.0);
    LightK {
        p: [s(r.px), s(r.py), s(r.pz)],
        w: s(r.w),
        fa: s(r.fa),
        fb: s(r.fb),
        axis: [s(r.sx), s(r.sy), s(r.sz)],
        cs: s(r.cs),
        co: s(r.co),
        c: [s(r.cr), s(r.cg), s(r.cb)],
        lum: s(r.lum),
        q: if Q {
            [s(quad.x0[l]), s(quad.x1[l]), s(quad.y0[l]), s(quad.y1[l]), s(quad.z0[l]), s(quad.z1[l])]
        } else {
            [zero; 6]
        },
        spot,
    }
}

/// Two lights' constants side by side.
#[inline(always)]
fn light_pair<V: Lanes>(a: LightK<V>, b: LightK<V>) -> LightK<Two<V>> {
    let t3 = |x: [V; 3], y: [V; 3]| [Two(x[0], y[0]), Two(x[1], y[1]), Two(x[2], y[2])];
    LightK {
        p: t3(a.p, b.p),
        w: Two(a.w, b.w),
        fa: Two(a.fa, b.fa),
        fb: Two(a.fb, b.fb),
        axis: t3(a.axis, b.axis),
        cs: Two(a.cs, b.cs),
        co: Two(a.co, b.co),
        c: t3(a.c, b.c),
        lum: Two(a.lum, b.lum),
        q: [
            Two(a.q[0], b.q[0]),
            Two(a.q[1], b.q[1]),
            Two(a.q[2], b.q[2]),
            Two(a.q[3], b.q[3]),
            Two(a.q[4], b.q[4]),
            Two(a.q[5], b.q[5]),
        ],
        spot: a.spot || b.spot,
    }
}

/// What one light gives one vector of samples, before its colour: the energy `e` (falloff · N·L · cone, 0 outside
/// a quad), the lanes it lights and (quad culling) tests, and the BRDF's factors: Blinn-Phong `x[0]` = the
/// specular factor; GGX `x` = the three lobes (`x[0]` = F·D·V for the pre-pass).
struct Step<V: Lanes> {
    e: V,
    on: V::Mask,
    inside: V::Mask,
    x: [V; 3],
}

impl<V: Lanes> Step<Two<V>> {
    #[inline(always)]
    fn split(self) -> (Step<V>, Step<V>) {
        let x = self.x;
        (
            Step { e: self.e.0, on: self.on.0, inside: self.inside.0, x: [x[0].0, x[1].0, x[2].0] },
            Step { e: self.e.1, on: self.on.1, inside: self.inside.1, x: [x[0].1, x[1].1, x[2].1] },
        )
    }
}

/// Accumulators of one vector of samples.
struct Acc<V> {
    rgb: [V; 3],
    s: V,
    tested: V,
    lit: V,
}

/// Adds one light's step to the accumulators (in light order: the sums do not depend on how the lights were
/// grouped into steps).
#[inline(always)]
fn accumulate<V: Lanes, const B: u8, const Q: bool, const P: bool>(acc: &mut Acc<V>, st: &Step<V>, c: &[V; 3], lum: V) {
    if Q {
        acc.tested = acc.tested.count(st.inside);
    }
    acc.lit = acc.lit.count(st.on);
    let e = st.e;
    if B == 0 || P {
        for (a, &cc) in acc.rgb.iter_mut().zip(c) {
            *a = cc.mul_add(e, *a);
        }
        if B != 0 {
            acc.s = (lum * e).mul_add(st.x[0], acc.s);
        }
    } else if B == 1 {
        let kk = e.mul_add(st.x[0], e);
        for (a, &cc) in acc.rgb.iter_mut().zip(c) {
            *a = cc.mul_add(kk, *a);
        }
    } else {
        for ((a, &cc), &o) in acc.rgb.iter_mut().zip(c).zip(&st.x) {
            *a = (cc * e).mul_add(o, *a);
        }
    }
}

/// The per-sample constants in both halves.
#[inline(always)]
fn both<V: Lanes>(k: &Chunk<V>) -> Chunk<Two<V>> {
    let b = Two::both;
    let b3 = |x: [V; 3]| [b(x[0]), b(x[1]), b(x[2])];
    Chunk {
        p: b3(k.p),
        n: b3(k.n),
        v2: b3(k.v2),
        nv_raw: b(k.nv_raw),
        nv: b(k.nv),
        sn: b(k.sn),
        pw: b(k.pw),
        pw_c: b(k.pw_c),
        a2: b(k.a2),
        gv: b(k.gv),
        f0: b3(k.f0),
        cd: b3(k.cd),
        t: b3(k.t),
    }
}

/// One light (or, for [`Two`], two) against one vector of samples. A light that cannot reach a lane (out of range,
/// behind the surface, outside its cone or quad) gives exactly `e = 0` there, and its contribution `e·x` is exactly
/// 0 because every factor of `x` is finite *by construction*, in range or not: N·H is clamped to [0, 1] before
/// anything is raised to a power or divided by (the half vector can be almost zero — a light behind the surface
/// near the view ray has L̂ ≈ −V, |H| is floored at [`MIN_HALF_LENGTH`] and N·H, a rounding residual divided by
/// that floor, came out up to 10¹²: `(N·H)^p` overflowed to ∞ and 0·∞ was NaN; GGX's `D` divides by
/// `((N·H)²(α² − 1) + 1)²`, which is 0 just above N·H = 1).
#[inline(always)]
fn step<V: Lanes, const B: u8, const F: u8, const Q: bool, const P: bool>(k: &Chunk<V>, l: &LightK<V>) -> Step<V> {
    let s = V::splat;
    let zero = s(0.0);
    // L = pos − w·p (w = 0 for directional lights).
    let lv = [k.p[0].nmul_add(l.w, l.p[0]), k.p[1].nmul_add(l.w, l.p[1]), k.p[2].nmul_add(l.w, l.p[2])];
    // d = max(|L|, MIN_DISTANCE): clamping d² first keeps rsqrt away from 0.
    let d2 = dot(&lv, &lv).max(s(MIN_DISTANCE * MIN_DISTANCE));
    // The dot products with L̂ are taken with the unnormalised L, then scaled by 1/|L|: they need not wait for the
    // reciprocal square root (a shorter dependency chain).
    let ndl_l = dot(&k.n, &lv);
    let ldv2_l = dot(&lv, &k.v2);
    let inv = d2.rsqrt();
    let ndl_raw = ndl_l * inv;
    let ndl = ndl_raw.max(zero);
    let atten = if F == 0 {
        let win = (d2 * d2).nmul_add(l.fa, s(1.0)).saturate();
        win * win * (inv * inv)
    } else {
        (d2 * inv).nmul_add(l.fb, l.fa).saturate()
    };
    let mut e = atten * ndl;
    if l.spot {
        // Non-spot lights have scale 0 and offset 1: a factor of exactly 1.
        let sl = dot(&l.axis, &lv) * inv;
        let cone = sl.nmul_add(l.cs, l.co).saturate();
        e = e * (cone * cone);
    }
    let inside = if Q {
        let t = &k.t;
        let inside = V::and(
            V::and(V::and(t[0].ge(l.q[0]), t[0].le(l.q[1])), V::and(t[1].ge(l.q[2]), t[1].le(l.q[3]))),
            V::and(t[2].ge(l.q[4]), t[2].le(l.q[5])),
        );
        e = e.keep(inside);
        inside
    } else {
        zero.gt(zero)
    };
    let on = e.gt(zero);
    let mut x = [zero; 3];
    if B == 0 {
        return Step { e, on, inside, x };
    }
    // H = normalize(L̂ + V): |L̂ + V|² = 2 + 2 L̂·V, N·H = (N·L̂ + N·V)/|H|, V·H = (L̂·V + 1)/|H|.
    let h2_raw = ldv2_l.mul_add(inv, s(2.0));
    let h2 = h2_raw.max(s(MIN_HALF_LENGTH * MIN_HALF_LENGTH));
    if B == 1 {
        // (N·H)^p = 2^(p·log2 N·H) with 1/|H| only estimated (y, relative error δ: 2⁻¹⁴ on AVX-512, 1.5·2⁻¹² on
        // AVX2, `rsqrt_estimate`) and the estimate's error taken out in the log domain: log2 N·H =
        // log2((N·L̂ + N·V)·y) − ½ log2(y²|H|²), and ½ log2(y²|H|²) = (y²|H|² − 1)/(2 ln 2) to within ε²/ln 2 with
        // ε = y²|H|² − 1 ≈ 2δ: < 6e-9 on AVX-512, < 8e-7 on AVX2, inside log2's own 2e-6. Several instructions fewer
        // than a Newton step (one on AVX-512, five per half on AVX2), and off the dependency chain. pow's floor POW_MIN_BASE also clamps N·H below at (about) 0, and
        // the exponent is clamped at 0 above: N·H ≤ 1 (Cauchy–Schwarz), so (N·H)^p ≤ 1 and the factor stays finite
        // whatever rounding did to a near-zero half vector (see above). Clamping the exponent rather than N·H
        // keeps the estimate's correction exact below 1, and `exp2_nonpositive` folds the clamp into exp2's own
        // (no extra instruction on the portable and AVX2 paths).
        let y = h2.rsqrt_estimate();
        let ndh_est = (ndl_raw + k.nv_raw) * y;
        let eps2 = (y * y).mul_add(h2, s(-1.0));
        let x_p = eps2.nmul_add(k.pw_c, k.pw * ndh_est.max(s(POW_MIN_BASE)).log2());
        x[0] = k.sn * x_p.exp2_nonpositive();
        return Step { e, on, inside, x };
    }
    let hinv = h2.rsqrt();
    // N·H in [0, 1] (see above): then `t ≥ α² > 0` and `D·Vis` is finite.
    let ndh = ((ndl_raw + k.nv_raw) * hinv).saturate();
    let vdh = (h2_raw * s(0.5) * hinv).max(zero);
    let a2 = k.a2;
    let t = (ndh * ndh).mul_add(a2 - s(1.0), s(1.0));
    let gl2 = (ndl * ndl).mul_add(s(1.0) - a2, a2);
    let vis_den = ndl.mul_add(k.gv, k.nv * (gl2 * gl2.rsqrt())).max(s(1e-12));
    let dv = a2 * s(0.5 * FRAC_1_PI) * (t * t * vis_den).recip();
    let m = s(1.0) - vdh;
    let m2 = m * m;
    let m5 = m2 * m2 * m;
    if P {
        let f0 = k.f0[0].mul_add(s(LUMA.x), k.f0[1].mul_add(s(LUMA.y), k.f0[2] * s(LUMA.z)));
        x[0] = (s(1.0) - f0).mul_add(m5, f0) * dv;
    } else {
        x = [lobe(k.f0[0], k.cd[0], m5, dv), lobe(k.f0[1], k.cd[1], m5, dv), lobe(k.f0[2], k.cd[2], m5, dv)];
    }
    Step { e, on, inside, x }
}

/// GGX's lobe for one colour channel: Schlick's `F = F0 + (1 − F0)(1 − V·H)⁵` (`m5` = the fifth power), then
/// `(1 − F) c_diff/π + F·D·V`.
#[inline(always)]
fn lobe<V: Lanes>(f0: V, cd: V, m5: V, dv: V) -> V {
    let one = V::splat(1.0);
    let f = (one - f0).mul_add(m5, f0);
    (one - f).mul_add(cd, f * dv)
}

/// Shades one vector of `V::N` items against every light. First the lights that can reach the vector at all
/// are listed (16 lights at a time against the vector's bounding box; a light whose sphere misses it adds exactly
/// 0 to every lane, and its pair still counts as tested: tile culling passed it — quad culling counts its own
/// tests, so it keeps every light); then the listed lights are shaded [`Lanes::INTERLEAVE`] at a time (four for
/// the x86 vectors, `Two<Two<V>>`: four independent dependency chains interleaved — one light's chain of rsqrt,
/// log2, exp2 is far longer than its throughput cost, so one light at a time left the vector units mostly idle;
/// the rest two or one at a time), with per-sample constants and accumulators in registers. Each light's
/// contribution is added in light order, so the sums do not depend on which lights were listed.
#[inline(always)]
fn run_chunk<V: Lanes, const B: u8, const F: u8, const Q: bool, const P: bool>(
    it: &mut Items,
    c: usize,
    lights: &LightTable,
    quad: &QuadSoa,
    live: &mut [u32],
) {
    let s = V::splat;
    let k = load_chunk::<V, B, Q>(it, c);
    let zero = s(0.0);
    let n = if Q {
        lights.len()
    } else {
        let reaching = list_reaching(&k, lights, live);
        if keep_all() {
            reaching
        } else {
            keep_lighting(&k, lights, &mut live[..reaching])
        }
    };
    let live = &live[..n];
    let mut acc = Acc { rgb: [zero; 3], s: zero, tested: zero, lit: zero };
    let mut rest: &[u32] = live;
    if interleave::<V, B>() >= 2 {
        // A constant condition: the two- and four-light code is only generated for lane types that use it.
        rest = groups_of_lights::<V, B, F, Q, P>(&k, live, lights, quad, &mut acc);
    }
    let spot = lights.any_spot;
    for &a in rest {
        let la = light_k::<V, Q>(&lights.rec[a as usize], quad, a as usize, spot);
        let sa = step::<V, B, F, Q, P>(&k, &la);
        accumulate::<V, B, Q, P>(&mut acc, &sa, &la.c, la.lum);
    }
    let tested = if Q { acc.tested } else { s(lights.len() as f32) };
    // Lambert and Blinn-Phong accumulate light only; the albedo (and Lambert's 1/π) multiplies the sum.
    let [mut r, mut g, mut b] = acc.rgb;
    if B == 0 {
        (r, g, b) = (r * s(FRAC_1_PI), g * s(FRAC_1_PI), b * s(FRAC_1_PI));
    }
    if B < 2 && !P {
        let ld = |a: &[f32]| V::load(&a[c..]);
        (r, g, b) = (r * ld(&it.ar), g * ld(&it.ag), b * ld(&it.ab));
    }
    r.store(&mut it.or[c..]);
    g.store(&mut it.og[c..]);
    b.store(&mut it.ob[c..]);
    acc.s.store(&mut it.ls[c..]);
    tested.store(&mut it.tested[c..]);
    acc.lit.store(&mut it.lit[c..]);
}

/// Lights per step of the kernel of BRDF `B` on lanes `V` ([`Lanes::INTERLEAVE`], [`Lanes::INTERLEAVE_GGX`]).
#[inline(always)]
const fn interleave<V: Lanes, const B: u8>() -> usize {
    if B == 2 {
        V::INTERLEAVE_GGX
    } else {
        V::INTERLEAVE
    }
}

/// Shades `live` four lights at a time (when [`Lanes::INTERLEAVE`] is 4 or more), then two at a time; returns the
/// lights left (at most one).
#[inline(always)]
fn groups_of_lights<'a, V: Lanes, const B: u8, const F: u8, const Q: bool, const P: bool>(
    k: &Chunk<V>,
    live: &'a [u32],
    lights: &LightTable,
    quad: &QuadSoa,
    acc: &mut Acc<V>,
) -> &'a [u32] {
    let k2 = both(k);
    let k4 = both(&k2);
    let spot = lights.any_spot;
    // A constant condition: with two lights per step, the pairs below take every light.
    let in_quads = if interleave::<V, B>() >= 4 { live.len() / 4 * 4 } else { 0 };
    let (quads, rest) = live.split_at(in_quads);
    for q in quads.chunks_exact(4) {
        let (i0, i1, i2, i3) = (q[0] as usize, q[1] as usize, q[2] as usize, q[3] as usize);
        let l0 = light_k::<V, Q>(&lights.rec[i0], quad, i0, spot);
        let l1 = light_k::<V, Q>(&lights.rec[i1], quad, i1, spot);
        let l2 = light_k::<V, Q>(&lights.rec[i2], quad, i2, spot);
        let l3 = light_k::<V, Q>(&lights.rec[i3], quad, i3, spot);
        let (c0, c1, c2, c3) = (l0.c, l1.c, l2.c, l3.c);
        let (u0, u1, u2, u3) = (l0.lum, l1.lum, l2.lum, l3.lum);
        let lk = light_pair(light_pair(l0, l1), light_pair(l2, l3));
        let (s01, s23) = step::<Two<Two<V>>, B, F, Q, P>(&k4, &lk).split();
        let (s0, s1) = s01.split();
        let (s2, s3) = s23.split();
        accumulate::<V, B, Q, P>(acc, &s0, &c0, u0);
        accumulate::<V, B, Q, P>(acc, &s1, &c1, u1);
        accumulate::<V, B, Q, P>(acc, &s2, &c2, u2);
        accumulate::<V, B, Q, P>(acc, &s3, &c3, u3);
    }
    let mut pairs = rest.chunks_exact(2);
    for pair in &mut pairs {
        let (a, b) = (pair[0] as usize, pair[1] as usize);
        let (la, lb) = (light_k::<V, Q>(&lights.rec[a], quad, a, spot), light_k::<V, Q>(&lights.rec[b], quad, b, spot));
        let (ca, cb, luma, lumb) = (la.c, lb.c, la.lum, lb.lum);
        let (sa, sb) = step::<Two<V>, B, F, Q, P>(&k2, &light_pair(la, lb)).split();
        accumulate::<V, B, Q, P>(acc, &sa, &ca, luma);
        accumulate::<V, B, Q, P>(acc, &sb, &cb, lumb);
    }
    pairs.remainder()
}

/// Lists (in increasing order) the lights of `lights` whose culling sphere touches the bounding box of the
/// vector's positions.
#[inline(always)]
fn list_reaching<V: Lanes>(k: &Chunk<V>, lights: &LightTable, live: &mut [u32]) -> usize {
    let s = V::splat;
    let lo = [s(k.p[0].hmin()), s(k.p[1].hmin()), s(k.p[2].hmin())];
    let hi = [s(k.p[0].hmax()), s(k.p[1].hmax()), s(k.p[2].hmax())];
    let n = lights.len();
    let mut len = 0;
    let mut base = 0;
    while base + V::N <= n {
        let ld = |a: &[f32]| V::load(&a[base..]);
        len +=
            reach_bits(&lo, &hi, [ld(&lights.x), ld(&lights.y), ld(&lights.z)], ld(&lights.r2), base, &mut live[len..]);
        base += V::N;
    }
    if base < n {
        // The last partial group, padded with lights that reach nothing (r² = −1).
        let mut t = [[0.0f32; 64]; 4];
        t[3] = [-1.0; 64];
        for (dst, src) in t.iter_mut().zip([&lights.x, &lights.y, &lights.z, &lights.r2]) {
            dst[..n - base].copy_from_slice(&src[base..n]);
        }
        len += reach_bits(
            &lo,
            &hi,
            [V::load(&t[0]), V::load(&t[1]), V::load(&t[2])],
            V::load(&t[3]),
            base,
            &mut live[len..],
        );
    }
    len
}

/// Keeps, in order, the lights of `live` that may light some lane of the vector, and drops those that give every
/// lane exactly `e = 0`: each lane is beyond the light's culling sphere (`d² > r²`, `d²` as [`step`] computes it,
/// before its floor) or faces away from it (`N·L ≤ 0`, the same `N·L`). Such a light would add exactly 0 to every
/// sum ([`step`]), so the image and counts are the same bits; it costs a sixth of a Blinn-Phong step per light.
/// Returns how many are kept.
#[inline(always)]
fn keep_lighting<V: Lanes>(k: &Chunk<V>, lights: &LightTable, live: &mut [u32]) -> usize {
    let s = V::splat;
    let zero = s(0.0);
    let mut len = 0;
    for i in 0..live.len() {
        let l = live[i];
        let r = &lights.rec[l as usize];
        let w = s(r.w);
        let lv = [k.p[0].nmul_add(w, s(r.px)), k.p[1].nmul_add(w, s(r.py)), k.p[2].nmul_add(w, s(r.pz))];
        let lit = V::and(dot(&lv, &lv).le(s(r.r2)), dot(&k.n, &lv).gt(zero));
        // Branch-free: written at the end of the kept ones, counted when kept.
        live[len] = l;
        len += usize::from(V::any(lit));
    }
    len
}

/// Whether [`keep_lighting`] is skipped (tests only: they compare the bits with and without it).
#[cfg(not(test))]
#[inline(always)]
fn keep_all() -> bool {
    false
}

#[cfg(test)]
fn keep_all() -> bool {
    tests::KEEP_ALL.with(std::cell::Cell::get)
}

/// Writes to the start of `live` the lights `base..base + N` whose sphere (centre `c`, squared radius `r2`)
/// touches the box `lo..hi`; returns how many.
#[inline(always)]
fn reach_bits<V: Lanes>(lo: &[V; 3], hi: &[V; 3], c: [V; 3], r2: V, base: usize, live: &mut [u32]) -> usize {
    let zero = V::splat(0.0);
    let gap = |i: usize| (lo[i] - c[i]).max(c[i] - hi[i]).max(zero);
    let (gx, gy, gz) = (gap(0), gap(1), gap(2));
    let d2 = gx * gx + gy * gy + gz * gz;
    V::compress_indices(d2.le(r2), base as u32, live)
}

/// Light pre-pass second pass: turns the buffers (diffuse light `D` in `or..ob`, monochrome specular `S` in `ls`)
/// into colour. Blinn-Phong: `albedo ⊙ (D + S · D/lum(D))`; Lambert: `albedo ⊙ D` (`D` already holds 1/π); GGX:
/// `c_diff/π ⊙ (1 − F0) ⊙ D + S · D/lum(D)`. The specular takes the chromaticity of the diffuse light, which is
/// exact when all lights share one colour.
pub fn finish_prepass(it: &mut Items, brdf: Brdf) {
    for j in 0..it.len() {
        let d = Vec3::new(it.or[j], it.og[j], it.ob[j]);
        let lum = d.dot(LUMA);
        let chroma = if lum > 0.0 { d / lum } else { Vec3::ONE };
        let spec = chroma * it.ls[j];
        let albedo = Vec3::new(it.ar[j], it.ag[j], it.ab[j]);
        let c = match brdf {
            Brdf::Lambert => albedo * d,
            Brdf::BlinnPhong => albedo * (d + spec),
            Brdf::Ggx => {
                let metal = it.metal[j];
                let c_diff = albedo * (1.0 - metal) * FRAC_1_PI;
                let f0 = Vec3::splat(DIELECTRIC_F0).lerp(albedo, metal);
                c_diff * (Vec3::ONE - f0) * d + spec
            }
        };
        (it.or[j], it.og[j], it.ob[j]) = (c.x, c.y, c.z);
    }
}

/// Adds the hemisphere environments to items `0..n` after the light loop (and after [`finish_prepass`]): per item
/// [`super::brdf::environment`] in f32, the environments in input order. Per item and independent of the culling
/// and the schedule, so images stay bit-identical across them.
pub fn add_environment(it: &mut Items, n: usize, env: &[super::lights::Hemisphere], brdf: Brdf) {
    if env.is_empty() {
        return;
    }
    for j in 0..n {
        let nrm = Vec3::new(it.nx[j], it.ny[j], it.nz[j]);
        let albedo = Vec3::new(it.ar[j], it.ag[j], it.ab[j]);
        let k = match brdf {
            Brdf::Lambert => albedo,
            Brdf::BlinnPhong => albedo * std::f32::consts::PI,
            Brdf::Ggx => {
                let metal = it.metal[j];
                let f0 = Vec3::splat(DIELECTRIC_F0).lerp(albedo, metal);
                albedo * (1.0 - metal) * (Vec3::ONE - f0)
            }
        };
        let mut add = Vec3::ZERO;
        for e in env {
            let c = nrm.dot(e.up).clamp(-1.0, 1.0);
            add += e.sky * (0.5 + 0.5 * c) + e.ground * (0.5 - 0.5 * c);
        }
        let c = k * add;
        (it.or[j], it.og[j], it.ob[j]) = (it.or[j] + c.x, it.og[j] + c.y, it.ob[j] + c.z);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;
    use crate::light::Light;
    use crate::resolve::culling::quad_rects;
    use crate::resolve::worklist::Surface;

    /// Relative difference allowed between the vector paths and the portable one: rsqrt/recip differ by ~4e-7 and
    /// log2 by up to 2·2e-6 absolute, which Blinn-Phong's pow multiplies by p·ln 2 (p ≤ 128 here): ≲ 4e-4.
    const PATH_TOLERANCE: f32 = 1e-3;

    fn random_frame(rng: &mut SplitMix64) -> (Items, Vec<Light>) {
        let mut it = Items::default();
        for j in 0..4 * BLOCK {
            let p = Vec3::new(rng.range_f32(-3.0, 3.0), rng.range_f32(-2.0, 2.0), rng.range_f32(-12.0, -1.0));
            let n = Vec3::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), rng.range_f32(-0.2, 1.0));
            let s = Surface {
                p,
                n: n.try_normalize().unwrap_or(Vec3::Z),
                albedo: Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
                specular: rng.next_f32(),
                power: rng.range_f32(0.0, 128.0),
                roughness: rng.next_f32(),
                metallic: rng.next_f32(),
            };
            it.push(&s, j as u32, 1.0);
        }
        let mut lights = Vec::new();
        for k in 0..40 {
            let c = Vec3::new(rng.range_f32(-4.0, 4.0), rng.range_f32(-3.0, 3.0), rng.range_f32(-13.0, 0.0));
            let colour = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let mut l = Light::point(c, colour, rng.range_f32(0.5, 20.0), rng.range_f32(0.5, 6.0));
            l.begin = l.range * rng.next_f32();
            if k % 7 == 3 {
                l.kind = crate::light::LightKind::Spot {
                    direction: Vec3::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), -1.0),
                    inner_cone_angle: 0.2,
                    outer_cone_angle: 0.6,
                };
            }
            if k == 11 {
                l.kind = crate::light::LightKind::Directional { direction: Vec3::new(0.3, -1.0, -0.5) };
            }
            lights.push(l);
        }
        (it, crate::resolve::lights::sanitize(&lights).lights)
    }

    thread_local! {
        /// Set by a test to shade every light the bounding-box test lists ([`keep_all`]).
        pub(super) static KEEP_ALL: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }

    /// Dropping the lights that give every lane exactly 0 changes no bit of any output, for every BRDF, falloff,
    /// schedule and instruction set the CPU has (and the portable lanes), with lights whose spheres end right at
    /// samples and lights behind them; and it does drop lights (the test is not vacuous).
    #[test]
    fn dropping_unlit_lights_changes_no_bit() {
        let mut rng = SplitMix64::new(9);
        let mut dropped = 0;
        for round in 0..6 {
            let (items, mut lights) = random_frame(&mut rng);
            // Lights whose range ends at a sample (within rounding), and lights just behind a sample's surface.
            for j in (0..items.len()).step_by(7) {
                let p = Vec3::new(items.px[j], items.py[j], items.pz[j]);
                let n = Vec3::new(items.nx[j], items.ny[j], items.nz[j]);
                let dir = Vec3::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0));
                let range = rng.range_f32(0.2, 3.0);
                let at = p + dir.normalize_or(Vec3::X) * range * (1.0 + rng.range_f32(-1e-4, 1e-4));
                lights.push(Light::point(at, Vec3::ONE, 1.0, range));
                lights.push(Light::point(p - n * rng.range_f32(0.0, 0.01), Vec3::ONE, 1.0, 1.0));
            }
            let lights = crate::resolve::lights::sanitize(&lights).lights;
            for falloff in [Falloff::Gltf, Falloff::Linear] {
                let table = LightTable::new(&lights, falloff);
                let mut live = vec![0u32; table.len() + BLOCK];
                for c in (0..items.len()).step_by(BLOCK) {
                    let k = load_chunk::<Portable<false>, 1, false>(&items, c);
                    let reaching = list_reaching(&k, &table, &mut live);
                    dropped += reaching - keep_lighting(&k, &table, &mut live[..reaching]);
                }
                for brdf in [Brdf::Lambert, Brdf::BlinnPhong, Brdf::Ggx] {
                    for prepass in [false, true] {
                        let v = Variant { brdf, falloff, quad: false, prepass };
                        for isa in [Some(Isa::detect()), None] {
                            let n = items.len();
                            let run = |keep_all: bool| {
                                let mut it = items.clone();
                                KEEP_ALL.with(|k| k.set(keep_all));
                                match isa {
                                    Some(isa) => shade(isa, &mut it, 0..n, &table, &QuadSoa::default(), v),
                                    None => shade_portable(&mut it, 0..n, &table, &QuadSoa::default(), v),
                                }
                                KEEP_ALL.with(|k| k.set(false));
                                it
                            };
                            let (all, kept) = (run(true), run(false));
                            for (name, a, b) in [
                                ("r", &all.or, &kept.or),
                                ("g", &all.og, &kept.og),
                                ("b", &all.ob, &kept.ob),
                                ("s", &all.ls, &kept.ls),
                                ("tested", &all.tested, &kept.tested),
                                ("lit", &all.lit, &kept.lit),
                            ] {
                                for j in 0..n {
                                    assert_eq!(
                                        a[j].to_bits(),
                                        b[j].to_bits(),
                                        "round {round} {v:?} {isa:?} item {j} {name}: {} vs {}",
                                        a[j],
                                        b[j]
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(dropped > 1000, "only {dropped} lights dropped: the test would not see a wrong drop");
    }

    #[test]
    fn vector_paths_agree_with_the_portable_path() {
        let mut rng = SplitMix64::new(5);
        for round in 0..4 {
            let (items, lights) = random_frame(&mut rng);
            for brdf in [Brdf::Lambert, Brdf::BlinnPhong, Brdf::Ggx] {
                for falloff in [Falloff::Gltf, Falloff::Linear] {
                    for (quad, prepass) in [(false, false), (true, false), (false, true), (true, true)] {
                        let table = LightTable::new(&lights, falloff);
                        let rects = if quad { quad_rects(&lights) } else { QuadSoa::default() };
                        let v = Variant { brdf, falloff, quad, prepass };
                        let (mut a, mut b) = (items.clone(), items.clone());
                        let n = items.len();
                        shade(Isa::detect(), &mut a, 0..n, &table, &rects, v);
                        shade_portable(&mut b, 0..n, &table, &rects, v);
                        let (mut lit_a, mut lit_b) = (0.0, 0.0);
                        for j in 0..n {
                            for (x, y) in
                                [(a.or[j], b.or[j]), (a.og[j], b.og[j]), (a.ob[j], b.ob[j]), (a.ls[j], b.ls[j])]
                            {
                                let scale = x.abs().max(y.abs()).max(1e-6);
                                assert!(
                                    (x - y).abs() <= PATH_TOLERANCE * scale,
                                    "round {round} {v:?} item {j}: {x} vs {y} ({})",
                                    instruction_set()
                                );
                                assert!(x.is_finite());
                            }
                            assert!((a.tested[j] - b.tested[j]).abs() <= 1.0, "{v:?} tested");
                            (lit_a, lit_b) = (lit_a + a.lit[j], lit_b + b.lit[j]);
                        }
                        assert!((lit_a - lit_b).abs() <= 1e-3 * lit_b.max(1.0), "{v:?}: lit {lit_a} vs {lit_b}");
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod speed {
    use super::*;
    use crate::light::Light;
    use crate::resolve::worklist::Surface;

    /// Kernel throughput with every light reaching every sample (no skipping): ns per light-sample pair.
    /// `cargo test --release --lib kernel_pair_throughput -- --ignored --nocapture`.
    #[test]
    #[ignore = "measurement: prints ns per pair"]
    fn kernel_pair_throughput() {
        let mut it = Items::default();
        for j in 0..BLOCK * 8 {
            let x = j as f32 * 0.01;
            let s = Surface {
                p: Vec3::new(x, 0.0, -5.0),
                n: Vec3::new(0.1, 0.2, 1.0).normalize(),
                albedo: Vec3::splat(0.5),
                specular: 0.5,
                power: 32.0,
                roughness: 0.5,
                metallic: 0.0,
            };
            it.push(&s, j as u32, 1.0);
        }
        let lights: Vec<Light> = (0..1024)
            .map(|k| Light::point(Vec3::new((k % 32) as f32 * 0.1, 0.5, -4.0), Vec3::ONE, 1.0, 50.0))
            .collect();
        for (name, brdf) in [("lambert", Brdf::Lambert), ("blinn-phong", Brdf::BlinnPhong), ("ggx", Brdf::Ggx)] {
            let table = LightTable::new(&lights, Falloff::Linear);
            let v = Variant { brdf, falloff: Falloff::Linear, quad: false, prepass: false };
            let n = it.len();
            let reps = 200;
            let q = QuadSoa::default();
            type Path<'a> = (&'a str, Box<dyn Fn(&mut Items) + 'a>);
            let mut paths: Vec<Path> = Vec::new();
            paths.push((instruction_set(), Box::new(|it: &mut Items| shade(Isa::detect(), it, 0..n, &table, &q, v))));
            if Isa::detect() == Isa::Avx512 {
                paths.push(("avx2", Box::new(|it: &mut Items| shade(Isa::Avx2, it, 0..n, &table, &q, v))));
            }
            paths.push(("portable", Box::new(|it: &mut Items| shade_portable(it, 0..n, &table, &q, v))));
            for (isa, f) in &paths {
                let t = std::time::Instant::now();
                for _ in 0..reps {
                    f(&mut it);
                }
                let ns = t.elapsed().as_secs_f64() * 1e9 / (reps * n * lights.len()) as f64;
                println!("{name}: {ns:.3} ns per pair ({isa}), lit {}", it.lit[0]);
            }
        }
    }
}
