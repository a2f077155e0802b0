//! The batched shading kernel: a packed work list of samples (structure of arrays) against a list of lights
//! (structure of arrays). The outer loop walks lights, the inner loop walks samples with no branches, so the
//! compiler vectorises it; on x86_64 a copy compiled for AVX-512 or AVX2+FMA is picked at run time.
//!
//! The formulas are those of `brdf.rs` / `falloff.rs` in f32, with per-light and per-sample constants hoisted.
//! Every light's contribution to a sample is added in light-index order whatever the culling, so a culled light
//! (whose contribution is exactly 0) changes nothing: the image is bit-identical across culling methods, tile
//! sizes and thread counts.

use super::brdf::{DIELECTRIC_F0, MIN_ALPHA, MIN_HALF_LENGTH, MIN_NDOTV};
use super::config::{Brdf, Falloff};
use super::falloff::MIN_DISTANCE;
use super::fastmath::pow_clamped;
use super::lights::{LightSoa, LUMA};
use super::surface::Surface;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// Work lists are padded to a multiple of this many items (the widest vector: 16 f32 lanes of AVX-512).
pub const LANES: usize = 16;
/// `pixel` of padding items.
pub const PAD_PIXEL: u32 = u32::MAX;

/// Per-light screen rectangle (tangent units x/d, y/d) and depth bounds for quad culling.
#[derive(Clone, Debug, Default)]
pub struct QuadSoa {
    /// Rectangle left.
    pub x0: Vec<f32>,
    /// Rectangle right.
    pub x1: Vec<f32>,
    /// Rectangle bottom.
    pub y0: Vec<f32>,
    /// Rectangle top.
    pub y1: Vec<f32>,
    /// Nearest depth.
    pub z0: Vec<f32>,
    /// Farthest depth.
    pub z1: Vec<f32>,
}

impl QuadSoa {
    /// Appends light `i` of `o`.
    pub fn push_from(&mut self, o: &QuadSoa, i: usize) {
        self.x0.push(o.x0[i]);
        self.x1.push(o.x1[i]);
        self.y0.push(o.y0[i]);
        self.y1.push(o.y1[i]);
        self.z0.push(o.z0[i]);
        self.z1.push(o.z1[i]);
    }
    /// Empties the arrays.
    pub fn clear(&mut self) {
        for v in [&mut self.x0, &mut self.x1, &mut self.y0, &mut self.y1, &mut self.z0, &mut self.z1] {
            v.clear();
        }
    }
}

macro_rules! soa {
    ($(#[$doc:meta])* $name:ident { f32: [$($f:ident),* $(,)?], u32: [$($u:ident),* $(,)?] }) => {
        $(#[$doc])*
        #[derive(Clone, Debug, Default)]
        pub struct $name {
            $(#[doc = concat!("Per-item `", stringify!($f), "`.")] pub $f: Vec<f32>,)*
            $(#[doc = concat!("Per-item `", stringify!($u), "`.")] pub $u: Vec<u32>,)*
        }
        impl $name {
            /// Empties every array, keeping capacity.
            pub fn clear(&mut self) {
                $(self.$f.clear();)*
                $(self.$u.clear();)*
            }
            /// Appends a copy of its own item `i`.
            pub fn push_copy(&mut self, i: usize) {
                $(let v = self.$f[i]; self.$f.push(v);)*
                $(let v = self.$u[i]; self.$u.push(v);)*
            }
            /// Appends item `i` of `o` (used to reorder a work list).
            pub fn push_from(&mut self, o: &$name, i: usize) {
                $(self.$f.push(o.$f[i]);)*
                $(self.$u.push(o.$u[i]);)*
            }
        }
    };
}

soa! {
    /// A packed work list: one entry per sample to shade. Inputs are set by [`Items::push`]; `or..ls`, `tested`
    /// and `lit` are accumulated by [`shade`]; `pixel` and `weight` say where the result goes (box filter).
    Items {
        f32: [px, py, pz, nx, ny, nz, vx, vy, vz, ar, ag, ab, sn, pw, a2, nv, f0r, f0g, f0b, dr, dg, db, tx, ty, dep,
              or, og, ob, ls, weight],
        u32: [tested, lit, pixel]
    }
}

impl Items {
    /// Number of items.
    #[must_use]
    pub fn len(&self) -> usize {
        self.px.len()
    }

    /// True when empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.px.is_empty()
    }

    /// Pads the list to a multiple of [`LANES`] with copies of item `template` that go nowhere (`pixel` =
    /// [`PAD_PIXEL`], weight 0): the kernel then runs whole vectors only, with no scalar remainder loop.
    pub fn pad_to_lanes(&mut self, template: usize) {
        while !self.len().is_multiple_of(LANES) {
            self.push_copy(template);
            let last = self.len() - 1;
            self.pixel[last] = PAD_PIXEL;
            self.weight[last] = 0.0;
        }
    }

    /// Appends a sample with its destination pixel (index within the tile) and box-filter weight.
    pub fn push(&mut self, s: &Surface, pixel: u32, weight: f32) {
        let v = -s.p / s.p.length();
        let d = -s.p.z;
        self.px.push(s.p.x);
        self.py.push(s.p.y);
        self.pz.push(s.p.z);
        self.nx.push(s.n.x);
        self.ny.push(s.n.y);
        self.nz.push(s.n.z);
        self.vx.push(v.x);
        self.vy.push(v.y);
        self.vz.push(v.z);
        self.ar.push(s.albedo.x);
        self.ag.push(s.albedo.y);
        self.ab.push(s.albedo.z);
        self.sn.push(s.specular * (s.power + 2.0) / 8.0);
        self.pw.push(s.power);
        let alpha = (s.roughness * s.roughness).max(MIN_ALPHA);
        self.a2.push(alpha * alpha);
        self.nv.push(s.n.dot(v).max(MIN_NDOTV));
        let f0 = Vec3::splat(DIELECTRIC_F0).lerp(s.albedo, s.metallic);
        self.f0r.push(f0.x);
        self.f0g.push(f0.y);
        self.f0b.push(f0.z);
        let c_diff = s.albedo * (1.0 - s.metallic) * FRAC_1_PI;
        self.dr.push(c_diff.x);
        self.dg.push(c_diff.y);
        self.db.push(c_diff.z);
        self.tx.push(s.p.x / d);
        self.ty.push(s.p.y / d);
        self.dep.push(d);
        self.or.push(0.0);
        self.og.push(0.0);
        self.ob.push(0.0);
        self.ls.push(0.0);
        self.weight.push(weight);
        self.tested.push(0);
        self.lit.push(0);
        self.pixel.push(pixel);
    }
}

/// Which variant of the kernel: BRDF, falloff, per-sample quad test, light pre-pass accumulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variant {
    /// The BRDF.
    pub brdf: Brdf,
    /// The falloff.
    pub falloff: Falloff,
    /// Apply the per-sample rectangle + depth test of quad culling.
    pub quad: bool,
    /// Accumulate light pre-pass buffers (diffuse RGB in `or..ob`, monochrome specular in `ls`).
    pub prepass: bool,
}

/// Shades items `range` of `it` against every light of `lights` (and, for quad culling, `quad`), accumulating.
pub fn shade(it: &mut Items, range: std::ops::Range<usize>, lights: &LightSoa, quad: &QuadSoa, v: Variant) {
    macro_rules! pick {
        ($b:literal, $f:literal) => {
            match (v.quad, v.prepass) {
                (false, false) => dispatch::<$b, $f, false, false>(it, range, lights, quad),
                (true, false) => dispatch::<$b, $f, true, false>(it, range, lights, quad),
                (false, true) => dispatch::<$b, $f, false, true>(it, range, lights, quad),
                (true, true) => dispatch::<$b, $f, true, true>(it, range, lights, quad),
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

fn dispatch<const B: u8, const F: u8, const Q: bool, const P: bool>(
    it: &mut Items,
    range: std::ops::Range<usize>,
    lights: &LightSoa,
    quad: &QuadSoa,
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512vl") {
            // SAFETY: the CPU supports the features the function was compiled for (checked just above).
            return unsafe { run_avx512::<B, F, Q, P>(it, range, lights, quad) };
        }
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            // SAFETY: as above.
            return unsafe { run_avx2::<B, F, Q, P>(it, range, lights, quad) };
        }
    }
    run::<B, F, Q, P>(it, range, lights, quad);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
fn run_avx512<const B: u8, const F: u8, const Q: bool, const P: bool>(
    it: &mut Items,
    range: std::ops::Range<usize>,
    lights: &LightSoa,
    quad: &QuadSoa,
) {
    run::<B, F, Q, P>(it, range, lights, quad);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn run_avx2<const B: u8, const F: u8, const Q: bool, const P: bool>(
    it: &mut Items,
    range: std::ops::Range<usize>,
    lights: &LightSoa,
    quad: &QuadSoa,
) {
    run::<B, F, Q, P>(it, range, lights, quad);
}

#[inline(always)]
fn run<const B: u8, const F: u8, const Q: bool, const P: bool>(
    it: &mut Items,
    range: std::ops::Range<usize>,
    lights: &LightSoa,
    quad: &QuadSoa,
) {
    debug_assert!(range.len().is_multiple_of(LANES), "work lists are padded to whole vectors");
    let mut c = range.start;
    while c + LANES <= range.end {
        run_chunk::<B, F, Q, P>(it, c, lights, quad);
        c += LANES;
    }
}

/// Loads `LANES` values starting at `c`.
#[inline(always)]
fn ld(a: &[f32], c: usize) -> [f32; LANES] {
    let mut out = [0.0; LANES];
    out.copy_from_slice(&a[c..c + LANES]);
    out
}

/// Shades one vector of `LANES` items against every light. Inputs and accumulators live in fixed-size local
/// arrays, so the lane loop compiles to straight vector code (no aliasing checks, no remainder) and the
/// accumulators stay in registers across the light loop.
#[inline(always)]
fn run_chunk<const B: u8, const F: u8, const Q: bool, const P: bool>(
    it: &mut Items,
    c: usize,
    lights: &LightSoa,
    quad: &QuadSoa,
) {
    let (px, py, pz) = (ld(&it.px, c), ld(&it.py, c), ld(&it.pz, c));
    let (nx, ny, nz) = (ld(&it.nx, c), ld(&it.ny, c), ld(&it.nz, c));
    let (vx, vy, vz) = (ld(&it.vx, c), ld(&it.vy, c), ld(&it.vz, c));
    let (ar, ag, ab) = (ld(&it.ar, c), ld(&it.ag, c), ld(&it.ab, c));
    let (sn, pw, a2s, nvs) = (ld(&it.sn, c), ld(&it.pw, c), ld(&it.a2, c), ld(&it.nv, c));
    let (f0r, f0g, f0b) = (ld(&it.f0r, c), ld(&it.f0g, c), ld(&it.f0b, c));
    let (dr, dg, db) = (ld(&it.dr, c), ld(&it.dg, c), ld(&it.db, c));
    let (tx, ty, dep) = (ld(&it.tx, c), ld(&it.ty, c), ld(&it.dep, c));
    let (mut or, mut og, mut ob, mut ls) = (ld(&it.or, c), ld(&it.og, c), ld(&it.ob, c), ld(&it.ls, c));
    let mut tested = [0u32; LANES];
    let mut lit = [0u32; LANES];
    let min_d = MIN_DISTANCE;
    for l in 0..lights.len() {
        let (lx, ly, lz, w) = (lights.px[l], lights.py[l], lights.pz[l], lights.w[l]);
        let (cr, cg, cb, lum) = (lights.cr[l], lights.cg[l], lights.cb[l], lights.lum[l]);
        let (fa, fb) = (lights.fa[l], lights.fb[l]);
        let (sx, sy, sz, cs, co) = (lights.sx[l], lights.sy[l], lights.sz[l], lights.cs[l], lights.co[l]);
        let (qx0, qx1, qy0, qy1, qz0, qz1) = if Q {
            (quad.x0[l], quad.x1[l], quad.y0[l], quad.y1[l], quad.z0[l], quad.z1[l])
        } else {
            (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        };
        for j in 0..LANES {
            let inside = if Q {
                (tx[j] >= qx0) & (tx[j] <= qx1) & (ty[j] >= qy0) & (ty[j] <= qy1) & (dep[j] >= qz0) & (dep[j] <= qz1)
            } else {
                true
            };
            let mut lvx = lx - w * px[j];
            let mut lvy = ly - w * py[j];
            let mut lvz = lz - w * pz[j];
            let d2 = lvx * lvx + lvy * lvy + lvz * lvz;
            let d = d2.sqrt().max(min_d);
            let inv = 1.0 / d;
            lvx *= inv;
            lvy *= inv;
            lvz *= inv;
            let ndl = (nx[j] * lvx + ny[j] * lvy + nz[j] * lvz).max(0.0);
            let atten = if F == 0 {
                let dd = d * d;
                let win = (1.0 - dd * dd * fa).clamp(0.0, 1.0);
                win * win / dd
            } else {
                (fa - fb * d).clamp(0.0, 1.0)
            };
            let cone = (-(sx * lvx + sy * lvy + sz * lvz) * cs + co).clamp(0.0, 1.0);
            let e = if inside { atten * cone * cone * ndl } else { 0.0 };
            if Q {
                tested[j] += u32::from(inside);
            }
            lit[j] += u32::from(e > 0.0);
            if B == 0 {
                let k = e * FRAC_1_PI;
                if P {
                    or[j] += cr * k;
                    og[j] += cg * k;
                    ob[j] += cb * k;
                } else {
                    or[j] += ar[j] * cr * k;
                    og[j] += ag[j] * cg * k;
                    ob[j] += ab[j] * cb * k;
                }
                continue;
            }
            let mut hx = lvx + vx[j];
            let mut hy = lvy + vy[j];
            let mut hz = lvz + vz[j];
            let hinv = 1.0 / (hx * hx + hy * hy + hz * hz).sqrt().max(MIN_HALF_LENGTH);
            hx *= hinv;
            hy *= hinv;
            hz *= hinv;
            let ndh = (nx[j] * hx + ny[j] * hy + nz[j] * hz).max(0.0);
            if B == 1 {
                let spec = sn[j] * pow_clamped(ndh, pw[j]);
                if P {
                    or[j] += cr * e;
                    og[j] += cg * e;
                    ob[j] += cb * e;
                    ls[j] += lum * e * spec;
                } else {
                    let k = e * (1.0 + spec);
                    or[j] += ar[j] * cr * k;
                    og[j] += ag[j] * cg * k;
                    ob[j] += ab[j] * cb * k;
                }
            } else {
                let a2 = a2s[j];
                let nv = nvs[j];
                let vdh = (vx[j] * hx + vy[j] * hy + vz[j] * hz).max(0.0);
                let t = ndh * ndh * (a2 - 1.0) + 1.0;
                let dist = a2 * FRAC_1_PI / (t * t);
                let vis_den = ndl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (ndl * ndl * (1.0 - a2) + a2).sqrt();
                let dv = dist * 0.5 / vis_den.max(1e-12);
                let m = 1.0 - vdh;
                let m5 = m * m * m * m * m;
                if P {
                    let f0 = LUMA.x * f0r[j] + LUMA.y * f0g[j] + LUMA.z * f0b[j];
                    or[j] += cr * e;
                    og[j] += cg * e;
                    ob[j] += cb * e;
                    ls[j] += lum * e * (f0 + (1.0 - f0) * m5) * dv;
                } else {
                    let fr = f0r[j] + (1.0 - f0r[j]) * m5;
                    let fg = f0g[j] + (1.0 - f0g[j]) * m5;
                    let fb_ = f0b[j] + (1.0 - f0b[j]) * m5;
                    or[j] += cr * e * ((1.0 - fr) * dr[j] + fr * dv);
                    og[j] += cg * e * ((1.0 - fg) * dg[j] + fg * dv);
                    ob[j] += cb * e * ((1.0 - fb_) * db[j] + fb_ * dv);
                }
            }
        }
    }
    if !Q {
        tested = [lights.len() as u32; LANES];
    }
    it.or[c..c + LANES].copy_from_slice(&or);
    it.og[c..c + LANES].copy_from_slice(&og);
    it.ob[c..c + LANES].copy_from_slice(&ob);
    it.ls[c..c + LANES].copy_from_slice(&ls);
    for j in 0..LANES {
        it.tested[c + j] += tested[j];
        it.lit[c + j] += lit[j];
    }
}

/// Light pre-pass second pass: turns the accumulated buffers (diffuse light `D` in `or..ob`, monochrome specular
/// `S` in `ls`) into colour. Blinn-Phong: `albedo ⊙ (D + S · D/lum(D))`; Lambert: `albedo/π` was already folded into
/// `D` except the albedo, so `albedo ⊙ D`; GGX: `c_diff/π ⊙ (1 − F0) ⊙ D + S · D/lum(D)`. The specular takes the
/// chromaticity of the diffuse light, which is exact when all lights share one colour.
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
                let c_diff = Vec3::new(it.dr[j], it.dg[j], it.db[j]);
                let f0 = Vec3::new(it.f0r[j], it.f0g[j], it.f0b[j]);
                c_diff * (Vec3::ONE - f0) * d + spec
            }
        };
        (it.or[j], it.og[j], it.ob[j]) = (c.x, c.y, c.z);
    }
}
