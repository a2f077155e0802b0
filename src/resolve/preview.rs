//! A preview of the lighting before anything is lit: per pixel, the luminance of the colour the light loop would give
//! its first covered sample, displayed (tone mapped, sRGB-encoded: a value in [0, 1] where 1/255 is one code of an
//! 8-bit display). The shading-rate rule reads it to see what the G-buffer alone cannot: the lighting's own gradients
//! (a light close to a wall, a highlight sliding along a glossy floor at grazing angles).
//!
//! Per light, with the resolve's falloffs, cones and uniform light representation ([`LightRec`]): `colour × intensity
//! × falloff × cone × max(N·L̂, 0)` times the BRDF per channel — Lambert `albedo/π`; GGX `(1 − F)·albedo(1 − m)/π +
//! F·D·Vis` with Schlick's F; Blinn-Phong `albedo(1 + s(p + 2)/8 (N·H)^p)` — plus each hemisphere environment over
//! the normal's hemisphere times the diffuse factor. The light loop's formulas, not its bits or its cost: plain f32
//! over arrays (no estimates, no sanitising counts), one evaluation per pixel, lights culled per block. It equals the
//! resolve's luminance as shown to within a twentieth of an 8-bit code on the room frame (`detect::rate`'s tests).

use super::brdf::{DIELECTRIC_F0, MIN_ALPHA, MIN_NDOTV};
use super::config::{Brdf, Falloff};
use super::falloff::MIN_DISTANCE;
use super::lights::{sanitize, Hemisphere, LightRec, LightTable, LUMA};
use super::surface::{
    roughness_from_power, usable_position, SurfaceReader, DEFAULT_ALBEDO, DEFAULT_SPECULAR, DEFAULT_SPECULAR_POWER,
    MAX_SPECULAR_POWER,
};
use crate::base::fastmath::pow_clamped;
use crate::base::isa::{Isa, Kernel};
use crate::detect::rate::{Gathered, Preview};
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::image::ToneMap;
use crate::light::Light;
use glam::Vec3;

/// Reads a frame's surfaces and previews their displayed lighting ([`Preview::pixels`]).
pub struct LightPreview<'a> {
    reader: SurfaceReader<'a>,
    lights: LightTable,
    environment: Vec<Hemisphere>,
    falloff: Falloff,
    brdf: Brdf,
    tone: ToneMap,
}

/// One band's surfaces as structure of arrays (one entry per pixel).
#[derive(Default)]
struct Surfaces {
    /// Position (−1 where unusable).
    p: [Vec<f32>; 3],
    n: [Vec<f32>; 3],
    /// The view direction (unit, towards the eye).
    v: [Vec<f32>; 3],
    /// The diffuse factor per channel.
    diffuse: [Vec<f32>; 3],
    /// Specular: GGX's F0 per channel; Blinn-Phong's `albedo·s(p + 2)/8` per channel.
    spec: [Vec<f32>; 3],
    /// GGX's α²; Blinn-Phong's power.
    s1: Vec<f32>,
    /// GGX: `max(N·V, MIN_NDOTV)`.
    nv: Vec<f32>,
    valid: Vec<bool>,
}

impl Surfaces {
    fn clear(&mut self) {
        let [p, n, v, d, sp] = [&mut self.p, &mut self.n, &mut self.v, &mut self.diffuse, &mut self.spec];
        for a in p.iter_mut().chain(n).chain(v).chain(d).chain(sp) {
            a.clear();
        }
        self.s1.clear();
        self.nv.clear();
        self.valid.clear();
    }
}

/// A thread's working arrays of [`LightPreview::pixels_impl`], kept from band to band (the report's 1080p bands
/// otherwise allocated and faulted in some 25 arrays each).
#[derive(Default)]
struct Scratch {
    surfaces: Surfaces,
    order: Vec<usize>,
    ends: Vec<usize>,
    sum: [Vec<f32>; 3],
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

impl<'a> LightPreview<'a> {
    /// Prepares `gb` lit by `lights` (view space, sanitised here as the resolve sanitises them) with `falloff` and
    /// `brdf`, displayed through `tone`. Fails as the resolve does when covered samples have no position.
    pub fn new(gb: &'a GBuffer, lights: &[Light], falloff: Falloff, brdf: Brdf, tone: ToneMap) -> Result<Self> {
        let clean = sanitize(lights);
        Ok(LightPreview {
            reader: SurfaceReader::new(gb)?,
            lights: LightTable::new(&clean.lights, falloff),
            environment: clean.environment,
            falloff,
            brdf,
            tone,
        })
    }

    /// The surfaces of the pixels `p0 + order[j]` at their samples `at[order[j]]`, in the order of `order`, into `s`
    /// (cleared first: its arrays keep their capacity from band to band), from what the caller gathered (`g`, per
    /// pixel of the band) and the planes it did not, with the resolve's defaults and clamps (not its counts: a
    /// preview). One pass over the pixels.
    #[inline(always)]
    fn surfaces(&self, p0: usize, order: &[usize], at: &[usize], g: &Gathered<'_>, s: &mut Surfaces) {
        let gb = self.reader.gbuffer();
        let (w, spp) = (gb.width as usize, gb.samples as usize);
        s.clear();
        let plane = |v: Option<&Vec<f32>>, i: usize, default: f32, hi: f32| match v {
            Some(v) if !v[i].is_nan() => v[i].clamp(0.0, hi),
            _ => default,
        };
        let rays = self.reader.rays();
        let pi = std::f32::consts::PI;
        for &k in order {
            let i = at[k];
            // Positions: the plane's, or the camera ray through the sample times its depth.
            let pos = match (&gb.position, gb.depth.is_some(), &rays) {
                (Some(pos), _, _) => pos[i],
                (None, true, Some(rays)) => {
                    let p = p0 + k;
                    let o = gb.sample_positions[i - p * spp];
                    super::surface::position_from_depth(rays, (p % w) as u32, (p / w) as u32, o, g.depth[k])
                }
                _ => Vec3::NAN,
            };
            let valid = usable_position(pos);
            let n = Vec3::new(g.normal[0][k], g.normal[1][k], g.normal[2][k]);
            let n = if n == Vec3::ZERO { Vec3::Z } else { n };
            let v = -pos.normalize_or(Vec3::NEG_Z);
            for c in 0..3 {
                s.p[c].push(if valid { pos[c] } else { -1.0 });
                s.n[c].push(n[c]);
                s.v[c].push(v[c]);
            }
            s.nv.push(n.dot(v).max(MIN_NDOTV));
            s.valid.push(valid);
            // As the resolve: a channel that is not a finite non-negative number is 0.
            let albedo = match gb.albedo {
                Some(_) => Vec3::from_array([0, 1, 2].map(|c| g.albedo[c][k]).map(|a| {
                    if a.is_finite() && a >= 0.0 {
                        a
                    } else {
                        0.0
                    }
                })),
                None => Vec3::splat(DEFAULT_ALBEDO),
            };
            let power = || plane(gb.specular_power.as_ref(), i, DEFAULT_SPECULAR_POWER, MAX_SPECULAR_POWER);
            let (diffuse, spec, s1) = match self.brdf {
                Brdf::Lambert => (albedo / pi, Vec3::ZERO, 0.0),
                Brdf::Ggx => {
                    let m = g.metallic[k];
                    let m = if m.is_nan() { 0.0 } else { m.clamp(0.0, 1.0) };
                    let rough = if gb.roughness.is_some() { g.roughness[k] } else { roughness_from_power(power()) };
                    let f0 = Vec3::splat(DIELECTRIC_F0).lerp(albedo, m);
                    (albedo * (1.0 - m) / pi, f0, (rough * rough).max(MIN_ALPHA).powi(2))
                }
                Brdf::BlinnPhong => {
                    let (sp, pw) = (plane(gb.specular.as_ref(), i, DEFAULT_SPECULAR, f32::MAX), power());
                    (albedo, albedo * (sp * (pw + 2.0) / 8.0), pw)
                }
            };
            for c in 0..3 {
                s.diffuse[c].push(diffuse[c]);
                s.spec[c].push(spec[c]);
            }
            s.s1.push(s1);
        }
    }

    /// `out[k]`: the displayed preview of sample `at[k]`, a flat index of pixel `p0 + k` (0 where that sample is
    /// uncovered or has no usable position). The pixels are whole rows of the frame starting at pixel `p0`; they are
    /// lit in blocks `block` pixels wide, each against the lights whose sphere reaches the box of its positions
    /// (the others add exactly 0). `g` holds the planes the caller has gathered at `at` already. Inlined into the
    /// kernel of [`Preview::pixels`], so that it is compiled for the CPU's widest instruction set.
    #[inline(always)]
    fn pixels_impl(&self, p0: usize, at: &[usize], g: &Gathered<'_>, block: usize, out: &mut Vec<f32>) {
        let w = self.reader.gbuffer().width as usize;
        let n = at.len();
        let rows = n / w.max(1);
        debug_assert_eq!(rows * w, n, "whole rows");
        // Block-major order: each block's pixels contiguous, so that a light's pass runs over all of them at once.
        let block = block.max(1);
        // Only covered samples: the others stay 0.
        let coverage = &self.reader.gbuffer().coverage;
        SCRATCH.with_borrow_mut(|scratch| {
            let Scratch { surfaces: s, order, ends, sum } = scratch;
            order.clear();
            ends.clear();
            for x0 in (0..w).step_by(block) {
                for r in 0..rows {
                    order.extend((r * w + x0..r * w + (x0 + block).min(w)).filter(|&k| coverage[at[k]]));
                }
                ends.push(order.len());
            }
            self.surfaces(p0, order, at, g, s);
            let s = &*s;
            for a in sum.iter_mut() {
                a.clear();
                a.resize(order.len(), 0.0);
            }
            let mut culled = Vec::with_capacity(self.lights.len());
            let mut start = 0;
            for &end in ends.iter() {
                let span = start..end;
                start = end;
                let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                for k in span.clone() {
                    if s.valid[k] {
                        let p = Vec3::new(s.p[0][k], s.p[1][k], s.p[2][k]);
                        (lo, hi) = (lo.min(p), hi.max(p));
                    }
                }
                // Each light's sphere against the box (directional lights have an infinite radius).
                culled.clear();
                culled.extend(self.lights.rec.iter().filter(|l| {
                    let c = Vec3::new(l.px, l.py, l.pz);
                    l.w == 0.0 || c.clamp(lo, hi).distance_squared(c) < l.r2
                }));
                for l in &culled {
                    match (self.brdf, self.falloff) {
                        (Brdf::Lambert, Falloff::Gltf) => light_pass::<0, 0>(l, s, span.clone(), sum),
                        (Brdf::Lambert, Falloff::Linear) => light_pass::<0, 1>(l, s, span.clone(), sum),
                        (Brdf::Ggx, Falloff::Gltf) => light_pass::<1, 0>(l, s, span.clone(), sum),
                        (Brdf::Ggx, Falloff::Linear) => light_pass::<1, 1>(l, s, span.clone(), sum),
                        (Brdf::BlinnPhong, Falloff::Gltf) => light_pass::<2, 0>(l, s, span.clone(), sum),
                        (Brdf::BlinnPhong, Falloff::Linear) => light_pass::<2, 1>(l, s, span.clone(), sum),
                    }
                }
            }
            for env in &self.environment {
                for k in 0..order.len() {
                    let c = (s.n[0][k] * env.up.x + s.n[1][k] * env.up.y + s.n[2][k] * env.up.z).clamp(-1.0, 1.0);
                    // The resolve's environment factor is the diffuse lobe times π (irradiance = π × mean radiance).
                    let mean = env.sky * (0.5 + 0.5 * c) + env.ground * (0.5 - 0.5 * c);
                    for (ch, (total, diffuse)) in sum.iter_mut().zip(&s.diffuse).enumerate() {
                        // GGX's diffuse lobe at normal incidence keeps 1 − F0 (`s.spec` is F0 there).
                        let kept = if self.brdf == Brdf::Ggx { 1.0 - s.spec[ch][k] } else { 1.0 };
                        total[k] += diffuse[k] * kept * std::f32::consts::PI * mean[ch];
                    }
                }
            }
            out.clear();
            out.resize(n, 0.0);
            let [r, g, b] = &*sum;
            for ((((&k, r), g), b), &valid) in order.iter().zip(r).zip(g).zip(b).zip(&s.valid) {
                let shown = shown_luminance(self.tone, Vec3::new(*r, *g, *b));
                out[k] = if valid { shown } else { 0.0 };
            }
        });
    }
}

impl Preview for LightPreview<'_> {
    fn pixels(&self, p0: usize, at: &[usize], g: &Gathered<'_>, block: usize, out: &mut Vec<f32>) {
        struct Pixels<'s, 'a, 'g> {
            preview: &'s LightPreview<'a>,
            p0: usize,
            at: &'s [usize],
            g: &'s Gathered<'g>,
            block: usize,
            out: &'s mut Vec<f32>,
        }
        impl Kernel for Pixels<'_, '_, '_> {
            type Output = ();
            #[inline(always)]
            fn run(self, _: Isa) {
                self.preview.pixels_impl(self.p0, self.at, self.g, self.block, self.out);
            }
        }
        crate::base::isa::run(Isa::detect(), Pixels { preview: self, p0, at, g, block, out });
    }
}

/// The luminance of linear colour `c` as shown: tone mapped by `tone`, sRGB-encoded (the crate's branch-free power).
#[inline(always)]
fn shown_luminance(tone: ToneMap, c: Vec3) -> f32 {
    let y = tone.apply(LUMA.x * c.x + LUMA.y * c.y + LUMA.z * c.z);
    if y <= 0.003_130_8 {
        12.92 * y
    } else {
        1.055 * pow_clamped(y, 1.0 / 2.4) - 0.055
    }
}

/// The rule's preview from a lit image instead of the lights: each pixel's luminance as shown, as a renderer holds
/// it in its previous frame (the one a static camera gives is the full-rate image; FidelityFX VRS reads the same).
/// Reading it costs the rule nothing beyond the image; [`LightPreview`] lights every pixel first.
pub struct ImagePreview {
    shown: Vec<f32>,
    size: (u32, u32),
}

impl ImagePreview {
    /// The displayed luminance of every pixel of `image` under `tone` (the rule refuses a frame of another size).
    #[must_use]
    pub fn new(image: &crate::image::HdrImage, tone: ToneMap) -> Self {
        use rayon::prelude::*;
        let shown = image.rgb.par_iter().map(|&c| shown_luminance(tone, c)).collect();
        ImagePreview { shown, size: (image.width, image.height) }
    }
}

impl Preview for ImagePreview {
    fn pixels(&self, p0: usize, at: &[usize], _: &Gathered<'_>, _: usize, out: &mut Vec<f32>) {
        // By the frame's pixel index (the rule has checked the size; a pixel beyond the image previews as black).
        out.clear();
        out.extend((p0..p0 + at.len()).map(|p| self.shown.get(p).copied().unwrap_or(0.0)));
    }

    fn size(&self) -> Option<(u32, u32)> {
        Some(self.size)
    }
}

/// Adds light `l`'s previewed colour to `out` (by channel) over the entries `span` of `s`: `B` 0 Lambert, 1 GGX,
/// 2 Blinn-Phong; `F` 0 glTF's falloff, 1 linear. Branch-free over the arrays, so the compiler vectorises it (the
/// cone factor is computed for every light: exactly 1 for the others, whose scale is 0 and offset 1).
#[inline(always)]
fn light_pass<const B: u8, const F: u8>(
    l: &LightRec,
    s: &Surfaces,
    span: std::ops::Range<usize>,
    out: &mut [Vec<f32>; 3],
) {
    let m = span.len();
    fn part(v: &[f32], start: usize, m: usize) -> &[f32] {
        &v[start..start + m]
    }
    let r = |v| part(v, span.start, m);
    let [px, py, pz] = [r(&s.p[0]), r(&s.p[1]), r(&s.p[2])];
    let [nx, ny, nz] = [r(&s.n[0]), r(&s.n[1]), r(&s.n[2])];
    let [vx, vy, vz] = [r(&s.v[0]), r(&s.v[1]), r(&s.v[2])];
    let [dr, dg, db] = [r(&s.diffuse[0]), r(&s.diffuse[1]), r(&s.diffuse[2])];
    let [sr, sg, sb] = [r(&s.spec[0]), r(&s.spec[1]), r(&s.spec[2])];
    let (s1, nvs) = (r(&s.s1), r(&s.nv));
    let [or, og, ob] = out;
    let (or, og, ob) = (&mut or[span.clone()], &mut og[span.clone()], &mut ob[span]);
    for k in 0..m {
        let (lx, ly, lz) = (l.px - l.w * px[k], l.py - l.w * py[k], l.pz - l.w * pz[k]);
        let d2 = (lx * lx + ly * ly + lz * lz).max(MIN_DISTANCE * MIN_DISTANCE);
        let inv = 1.0 / d2.sqrt();
        let (lx, ly, lz) = (lx * inv, ly * inv, lz * inv);
        let ndl = (nx[k] * lx + ny[k] * ly + nz[k] * lz).max(0.0);
        let atten = if F == 0 {
            let win = (1.0 - d2 * d2 * l.fa).clamp(0.0, 1.0);
            win * win * (inv * inv)
        } else {
            (l.fa - d2 * inv * l.fb).clamp(0.0, 1.0)
        };
        let cone = (l.co - (l.sx * lx + l.sy * ly + l.sz * lz) * l.cs).clamp(0.0, 1.0);
        let e = atten * cone * cone * ndl;
        let (fr, fg, fb) = if B == 0 {
            (dr[k], dg[k], db[k])
        } else {
            // The half vector, floored as the resolve floors it.
            let (hx, hy, hz) = (lx + vx[k], ly + vy[k], lz + vz[k]);
            let ih = 1.0 / (hx * hx + hy * hy + hz * hz).sqrt().max(super::brdf::MIN_HALF_LENGTH);
            let ndh = ((nx[k] * hx + ny[k] * hy + nz[k] * hz) * ih).clamp(0.0, 1.0);
            if B == 1 {
                let (a2, nv) = (s1[k], nvs[k]);
                let vdh = ((vx[k] * hx + vy[k] * hy + vz[k] * hz) * ih).clamp(0.0, 1.0);
                let q = 1.0 - vdh;
                let q5 = (q * q) * (q * q) * q;
                let t = ndh * ndh * (a2 - 1.0) + 1.0;
                // D·Vis in one division, Vis the height-correlated Smith term as the resolve's (Hammon's
                // approximation without square roots left the preview 1.2 codes darker on average on the room).
                let vis_den = ndl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (ndl * ndl * (1.0 - a2) + a2).sqrt();
                let dv = a2 / (2.0 * std::f32::consts::PI * t * t * vis_den).max(1e-12);
                // (1 − F)·diffuse + F·D·Vis per channel, F = F0 + (1 − F0)(1 − V·H)⁵.
                let lobe = |d: f32, f0: f32| {
                    let f = f0 + (1.0 - f0) * q5;
                    d + f * (dv - d)
                };
                (lobe(dr[k], sr[k]), lobe(dg[k], sg[k]), lobe(db[k], sb[k]))
            } else {
                let pw = pow_clamped(ndh, s1[k]);
                (dr[k] + sr[k] * pw, dg[k] + sg[k] * pw, db[k] + sb[k] * pw)
            }
        };
        or[k] += l.cr * e * fr;
        og[k] += l.cg * e * fg;
        ob[k] += l.cb * e * fb;
    }
}
