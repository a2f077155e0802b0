//! The reference image: the unpacked, unquantized G-buffer, every covered sample shaded against every light in
//! f64 (the formulas of `brdf.rs`, evaluated 8 samples at a time by `reference_lanes`: the same bits for Lambert
//! and GGX, `powf` within a tested bound of libm's for Blinn-Phong), box-filtered into pixels with background samples
//! contributing 0.
//! No schedule: the configuration's BRDF and falloff are used, its culling, tile size and schedule are ignored. A
//! light whose distance is at or beyond its range is skipped (both falloffs are exactly 0 there), and lights are
//! culled per tile only where that holds for the whole tile, so the image is the every-light one bit for bit.

#[cfg(test)]
use super::brdf;
use super::brdf::DIELECTRIC_F0;
use super::config::Brdf;
use super::config::ResolveConfig;
use super::lights::{sanitize, Hemisphere};
use super::reference_lanes::{self, LightLanes, LANES};
use super::surface::{SanitizedCounts, SurfaceReader};
use super::worklist::Surface;
use crate::base::isa::Isa;
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use crate::image::HdrImage;
use crate::light::Light;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Diffuse factor of `brdf` for a hemisphere environment: what multiplies the environment's mean radiance over the
/// normal's hemisphere (`sky·(1 + n·up)/2 + ground·(1 − n·up)/2`, that is irradiance / π). Lambert: `albedo`
/// (albedo/π × π); Blinn-Phong, whose diffuse lobe is `albedo` per unit irradiance (the ISPC convention, no 1/π):
/// `π·albedo`; GGX: `albedo·(1 − metallic)·(1 − F0)`, its diffuse lobe with the Fresnel factor at normal incidence
/// (the light pre-pass's approximation too). The specular response to an environment needs prefiltered maps and
/// is left out.
#[must_use]
fn environment_factor(albedo: DVec3, metallic: f64, brdf: Brdf) -> DVec3 {
    match brdf {
        Brdf::Lambert => albedo,
        Brdf::BlinnPhong => albedo * PI,
        Brdf::Ggx => {
            let f0 = DVec3::splat(f64::from(DIELECTRIC_F0)).lerp(albedo, metallic);
            albedo * (1.0 - metallic) * (DVec3::ONE - f0)
        }
    }
}

/// The radiance a hemisphere environment adds to surface `s` (f64): [`environment_factor`] × the environment's
/// mean radiance over the normal's hemisphere.
#[must_use]
pub fn environment(s: &Surface, env: &Hemisphere, brdf: Brdf) -> DVec3 {
    let c = s.n.as_dvec3().dot(env.up.as_dvec3()).clamp(-1.0, 1.0);
    let mean = env.sky.as_dvec3() * (0.5 + 0.5 * c) + env.ground.as_dvec3() * (0.5 - 0.5 * c);
    environment_factor(s.albedo.as_dvec3(), f64::from(s.metallic), brdf) * mean
}

/// Pixel tiles of the reference's light culling (side in pixels).
const REFERENCE_TILE: usize = 16;

/// Radiance of every sample in f64, plane-indexed like the G-buffer (`(y·width + x)·samples + s`); background
/// samples are 0.
///
/// Lights are culled per 16×16-pixel tile, conservatively: a positional light is left out of a tile when the box
/// around the tile's surface positions lies at or beyond its range, where `brdf::pair_geometry` returns exactly 0
/// for every sample of the tile anyway (the box's distance is at most each sample's, and the rounded operations
/// are monotone). The sums therefore add the same non-zero terms in the same order: the image is bit-identical to
/// shading every sample against every light (`culling_leaves_the_reference_bit_identical`).
fn per_sample_f64(gb: &GBuffer, lights: &[Light], cfg: &ResolveConfig) -> Result<Vec<DVec3>> {
    per_sample_f64_culled(gb, lights, cfg, true, Shading::Lanes(Some(Isa::detect())))
}

/// How the reference evaluates its pairs: [`LANES`] samples at a time (instruction set capped as in
/// `reference_lanes::shade`), or pair by pair through `brdf::shade`, the definition the lanes are tested
/// against.
#[derive(Clone, Copy, Debug)]
enum Shading {
    Lanes(Option<Isa>),
    #[cfg(test)]
    Scalar,
}

fn per_sample_f64_culled(
    gb: &GBuffer,
    lights: &[Light],
    cfg: &ResolveConfig,
    cull: bool,
    shading: Shading,
) -> Result<Vec<DVec3>> {
    let mut out = vec![DVec3::ZERO; gb.len()];
    shade_f64(gb, lights, cfg, cull, shading, Target::Samples(&mut out))?;
    Ok(out)
}

/// Where [`shade_f64`] puts its radiance: every sample, or (box-filtered band by band, the samples of one band of
/// tiles alive at a time) the pixels.
enum Target<'a> {
    Samples(&'a mut [DVec3]),
    Pixels(&'a mut [Vec3]),
}

/// The reference's shading, band of [`REFERENCE_TILE`] rows by band in parallel, into `target`.
fn shade_f64(
    gb: &GBuffer,
    lights: &[Light],
    cfg: &ResolveConfig,
    cull: bool,
    shading: Shading,
    target: Target<'_>,
) -> Result<()> {
    cfg.validate()?;
    let reader = SurfaceReader::new(gb)?;
    let clean = sanitize(lights);
    let (w, s) = (gb.width as usize, gb.samples as usize);
    if w == 0 || s == 0 {
        return Ok(());
    }
    let prepared: Vec<LightLanes> = clean.lights.iter().map(LightLanes::new).collect();
    let shade_band = |band: usize, rows: &mut [DVec3]| {
        let mut counts = SanitizedCounts::default();
        let y0 = band * REFERENCE_TILE;
        let band_rows = rows.len() / (w * s);
        // The tile's covered samples and where each goes in `rows`.
        let mut surfaces: Vec<Surface> = Vec::new();
        let mut at: Vec<usize> = Vec::new();
        let mut tile_lights: Vec<usize> = Vec::new();
        let mut lanes_lights: Vec<LightLanes> = Vec::new();
        for x0 in (0..w).step_by(REFERENCE_TILE) {
            surfaces.clear();
            at.clear();
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for dy in 0..band_rows {
                for x in x0..(x0 + REFERENCE_TILE).min(w) {
                    for k in 0..s {
                        if let Some(surf) = reader.read(x as u32, (y0 + dy) as u32, k as u32, &mut counts) {
                            let p = surf.p.as_dvec3();
                            (lo, hi) = (lo.min(p), hi.max(p));
                            surfaces.push(surf);
                            at.push((dy * w + x) * s + k);
                        }
                    }
                }
            }
            if surfaces.is_empty() {
                continue;
            }
            tile_lights.clear();
            tile_lights.extend(clean.lights.iter().enumerate().filter_map(|(i, l)| {
                if !cull || l.is_directional() {
                    return Some(i);
                }
                let c = l.position.as_dvec3();
                ((c.clamp(lo, hi) - c).length() < f64::from(l.range)).then_some(i)
            }));
            let finish = |surf: &Surface, mut sum: DVec3| {
                for e in &clean.environment {
                    sum += environment(surf, e, cfg.brdf);
                }
                if sum.is_finite() {
                    sum
                } else {
                    DVec3::ZERO
                }
            };
            match shading {
                Shading::Lanes(isa) => {
                    lanes_lights.clear();
                    lanes_lights.extend(tile_lights.iter().map(|&i| prepared[i]));
                    for (block, at) in surfaces.chunks(LANES).zip(at.chunks(LANES)) {
                        let sum = reference_lanes::shade(isa, block, &lanes_lights, cfg.brdf, cfg.falloff);
                        for (j, (surf, &i)) in block.iter().zip(at).enumerate() {
                            rows[i] = finish(surf, DVec3::new(sum[0][j], sum[1][j], sum[2][j]));
                        }
                    }
                }
                #[cfg(test)]
                Shading::Scalar => {
                    for (surf, &i) in surfaces.iter().zip(&at) {
                        let mut sum = DVec3::ZERO;
                        for &l in &tile_lights {
                            sum += brdf::shade(surf, &clean.lights[l], cfg.brdf, cfg.falloff);
                        }
                        rows[i] = finish(surf, sum);
                    }
                }
            }
        }
    };
    match target {
        Target::Samples(out) => {
            out.par_chunks_mut(w * s * REFERENCE_TILE).enumerate().for_each(|(band, rows)| shade_band(band, rows));
        }
        Target::Pixels(px) => {
            px.par_chunks_mut(w * REFERENCE_TILE).enumerate().for_each_init(Vec::new, |buf, (band, px)| {
                buf.clear();
                buf.resize(px.len() * s, DVec3::ZERO);
                shade_band(band, buf);
                for (p, o) in px.iter_mut().enumerate() {
                    let sum: DVec3 = buf[p * s..(p + 1) * s].iter().sum();
                    *o = (sum / s as f64).as_vec3();
                }
            });
        }
    }
    Ok(())
}

/// The radiance of every sample (f32 from f64 accumulation), plane-indexed like the G-buffer; background samples
/// are 0. What the edge detectors' shading ground truth compares against.
pub fn reference_per_sample(gb: &GBuffer, lights: &[Light], cfg: &ResolveConfig) -> Result<Vec<Vec3>> {
    Ok(per_sample_f64(gb, lights, cfg)?.into_iter().map(|c| c.as_vec3()).collect())
}

/// The reference image: every sample shaded in f64 and box-filtered (background = 0).
/// The samples of one band of tiles are filtered as soon as they are shaded: the f64 radiance of the whole frame
/// (24 B a sample, 200 MB at 1080p × 4) never exists.
pub fn reference(gb: &GBuffer, lights: &[Light], cfg: &ResolveConfig) -> Result<HdrImage> {
    let mut img = HdrImage::new(gb.width, gb.height);
    shade_f64(gb, lights, cfg, true, Shading::Lanes(Some(Isa::detect())), Target::Pixels(&mut img.rgb))?;
    Ok(img)
}

/// Refuses a lighting result that cannot be right: no covered sample to shade, no light, or a reference that is
/// black everywhere although samples are covered (no light reaches any surface: lights in the wrong space, out of
/// range, or behind every surface). A report on such a frame would rank layouts by an error of 0.
pub fn check_meaningful(gb: &GBuffer, lights: &[Light], reference: &HdrImage) -> Result<()> {
    let covered = gb.coverage.iter().filter(|c| **c).count();
    if covered == 0 {
        return Err(Error::Implausible(format!(
            "no covered sample: all {} samples are background, nothing to shade (is the background marker right?)",
            gb.len()
        )));
    }
    if lights.is_empty() {
        return Err(Error::Implausible("no lights: every image would be black".into()));
    }
    if reference.rgb.iter().all(|c| *c == Vec3::ZERO) {
        return Err(Error::Implausible(format!(
            "the reference image is black: none of the {} lights reaches any of the {covered} covered samples \
             (lights in another space than the G-buffer, out of range, or behind every surface?)",
            lights.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::LightKind;
    use crate::resolve::config::Falloff;
    use crate::scene::{render, scatter_lights, SceneName};

    /// Point lights (some with small ranges, so culling has something to cull), every 7th a spot, and one
    /// directional light.
    fn mixed_lights(gb: &GBuffer) -> Vec<Light> {
        let mut lights = scatter_lights(gb, 200, 5);
        for (i, l) in lights.iter_mut().enumerate().filter(|(i, _)| i % 7 == 0) {
            l.kind = LightKind::Spot {
                direction: Vec3::new(0.3, -1.0, -0.2 * (i % 3) as f32).normalize(),
                inner_cone_angle: 0.3,
                outer_cone_angle: 0.7,
            };
        }
        lights.push(Light {
            kind: LightKind::Directional { direction: Vec3::new(0.2, -1.0, -0.4).normalize() },
            ..Light::point(Vec3::ZERO, Vec3::ONE, 0.5, 1.0)
        });
        lights
    }

    /// The image, filtered band by band as it is shaded, is the box filter of every sample's f64 radiance bit for
    /// bit (a frame not a whole number of tiles, with background samples), on 1 and 3 threads.
    #[test]
    fn the_banded_filter_is_the_box_filter_of_every_sample() {
        let gb = render(SceneName::Room, 83, 37, 4).unwrap();
        assert!(gb.coverage.iter().any(|c| !c));
        let lights = mixed_lights(&gb);
        let cfg = ResolveConfig::default();
        let samples = per_sample_f64(&gb, &lights, &cfg).unwrap();
        let s = gb.samples as usize;
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let img = pool.install(|| reference(&gb, &lights, &cfg).unwrap());
            for (p, px) in img.rgb.iter().enumerate() {
                let want = (samples[p * s..(p + 1) * s].iter().sum::<DVec3>() / s as f64).as_vec3();
                assert_eq!(px.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "pixel {p}");
            }
            assert!(img.rgb.iter().any(|c| c.max_element() > 0.0));
        }
    }

    /// Per-tile culling only leaves out lights that add exactly 0 to every sample of the tile: the reference is
    /// bit for bit the every-light one, for each BRDF and falloff, with point, spot and directional lights — and
    /// culling did leave lights out.
    #[test]
    fn culling_leaves_the_reference_bit_identical() {
        let gb = render(SceneName::Room, 96, 64, 4).unwrap();
        let lights = mixed_lights(&gb);
        // Culling must have something to cull: some light misses some tile's box.
        assert!(lights.iter().any(|l| l.range < 5.0), "small ranges");
        for brdf in [Brdf::Lambert, Brdf::BlinnPhong, Brdf::Ggx] {
            for falloff in [Falloff::Gltf, Falloff::Linear] {
                let cfg = ResolveConfig { brdf, falloff, ..ResolveConfig::default() };
                let lanes = Shading::Lanes(Some(Isa::detect()));
                let culled = per_sample_f64_culled(&gb, &lights, &cfg, true, lanes).unwrap();
                let all = per_sample_f64_culled(&gb, &lights, &cfg, false, lanes).unwrap();
                let bits = |v: &[DVec3]| v.iter().flat_map(|c| c.to_array().map(f64::to_bits)).collect::<Vec<_>>();
                assert!(bits(&culled) == bits(&all), "{brdf:?} {falloff:?}");
                assert!(all.iter().any(|c| *c != DVec3::ZERO));
            }
        }
    }

    /// The lanes are the scalar definition (`brdf::shade` pair by pair): bit for bit for Lambert and GGX, and for
    /// Blinn-Phong within what the lanes' `pow` may differ from libm's, on every instruction set this CPU runs and
    /// the portable lanes; and bit-identical across instruction sets. The frame has a light at a sample
    /// (distance 0), lights out of range and behind surfaces, and unbounded lights.
    #[test]
    fn lanes_equal_the_scalar_definition() {
        let gb = render(SceneName::Room, 64, 48, 4).unwrap();
        let mut lights = mixed_lights(&gb);
        let on_a_sample = gb.position.as_ref().unwrap()[gb.coverage.iter().position(|c| *c).unwrap()];
        lights.push(Light::point(on_a_sample, Vec3::new(1.0, 0.5, 0.25), 2.0, 3.0));
        lights.push(Light::point(Vec3::new(0.5, 1.0, -4.0), Vec3::ONE, 3.0, f32::INFINITY));
        let mut isas: Vec<Option<Isa>> = Isa::available().into_iter().map(Some).collect();
        isas.push(None);
        for brdf in [Brdf::Lambert, Brdf::BlinnPhong, Brdf::Ggx] {
            for falloff in [Falloff::Gltf, Falloff::Linear] {
                let cfg = ResolveConfig { brdf, falloff, ..ResolveConfig::default() };
                let scalar = per_sample_f64_culled(&gb, &lights, &cfg, true, Shading::Scalar).unwrap();
                assert!(scalar.iter().any(|c| *c != DVec3::ZERO));
                let mut first: Option<Vec<DVec3>> = None;
                for &isa in &isas {
                    let lanes = per_sample_f64_culled(&gb, &lights, &cfg, true, Shading::Lanes(isa)).unwrap();
                    for (i, (a, b)) in lanes.iter().zip(&scalar).enumerate() {
                        let ok = if brdf == Brdf::BlinnPhong {
                            (*a - *b).abs().max_element() <= 1e-12 * b.abs().max_element()
                        } else {
                            a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits)
                        };
                        assert!(ok, "{brdf:?} {falloff:?} {isa:?} sample {i}: {a} vs {b}");
                    }
                    match &first {
                        None => first = Some(lanes),
                        Some(f) => assert!(
                            f.iter()
                                .zip(&lanes)
                                .all(|(a, b)| a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits)),
                            "{brdf:?} {falloff:?}: {isa:?} differs from {:?}",
                            isas[0]
                        ),
                    }
                }
            }
        }
    }
}
