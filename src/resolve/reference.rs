//! The reference image: the unpacked, unquantized G-buffer, every covered sample shaded against every light in
//! f64 (the formulas of `brdf.rs`, exact `powf`), box-filtered into pixels with background samples contributing 0.
//! No culling and no schedule: the configuration's BRDF and falloff are used, its culling, tile size and schedule
//! are ignored. (A light whose distance is at or beyond its range is skipped; both falloffs are exactly 0 there.)

use super::brdf;
use super::brdf::DIELECTRIC_F0;
use super::config::Brdf;
use super::config::ResolveConfig;
use super::lights::{sanitize, Hemisphere};
use super::surface::{SanitizedCounts, SurfaceReader};
use super::worklist::Surface;
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
pub fn environment_factor(albedo: DVec3, metallic: f64, brdf: Brdf) -> DVec3 {
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

/// Radiance of every sample in f64, plane-indexed like the G-buffer (`(y·width + x)·samples + s`); background
/// samples are 0.
fn per_sample_f64(gb: &GBuffer, lights: &[Light], cfg: &ResolveConfig) -> Result<Vec<DVec3>> {
    cfg.validate()?;
    let reader = SurfaceReader::new(gb)?;
    let clean = sanitize(lights);
    let (w, s) = (gb.width as usize, gb.samples as usize);
    let mut out = vec![DVec3::ZERO; gb.len()];
    if w == 0 || s == 0 {
        return Ok(out);
    }
    out.par_chunks_mut(w * s).enumerate().for_each(|(y, row)| {
        let mut counts = SanitizedCounts::default();
        for x in 0..w {
            for k in 0..s {
                if let Some(surf) = reader.read(x as u32, y as u32, k as u32, &mut counts) {
                    let mut sum = DVec3::ZERO;
                    for l in &clean.lights {
                        sum += brdf::shade(&surf, l, cfg.brdf, cfg.falloff);
                    }
                    for e in &clean.environment {
                        sum += environment(&surf, e, cfg.brdf);
                    }
                    row[x * s + k] = if sum.is_finite() { sum } else { DVec3::ZERO };
                }
            }
        }
    });
    Ok(out)
}

/// The radiance of every sample (f32 from f64 accumulation), plane-indexed like the G-buffer; background samples
/// are 0. What the edge detectors' shading ground truth compares against.
pub fn reference_per_sample(gb: &GBuffer, lights: &[Light], cfg: &ResolveConfig) -> Result<Vec<Vec3>> {
    Ok(per_sample_f64(gb, lights, cfg)?.into_iter().map(|c| c.as_vec3()).collect())
}

/// The reference image: every sample shaded in f64 and box-filtered (background = 0).
pub fn reference(gb: &GBuffer, lights: &[Light], cfg: &ResolveConfig) -> Result<HdrImage> {
    let samples = per_sample_f64(gb, lights, cfg)?;
    let mut img = HdrImage::new(gb.width, gb.height);
    let s = gb.samples as usize;
    if s == 0 {
        return Ok(img);
    }
    for (p, px) in img.rgb.iter_mut().enumerate() {
        let sum: DVec3 = samples[p * s..(p + 1) * s].iter().sum();
        *px = (sum / s as f64).as_vec3();
    }
    Ok(img)
}

/// Refuses a lighting result that cannot be right: no covered sample to shade, no light, or a reference that is
/// black everywhere although samples are covered (no light reaches any surface: lights in the wrong space, out of
/// range, or behind every surface). A report on such a frame would rank layouts by an error of 0.
pub fn check_meaningful(gb: &GBuffer, lights: &[Light], reference: &HdrImage) -> Result<()> {
    let covered = gb.coverage.iter().filter(|c| **c).count();
    if covered == 0 {
        return Err(Error::Argument(format!(
            "no covered sample: all {} samples are background, nothing to shade (is the background marker right?)",
            gb.len()
        )));
    }
    if lights.is_empty() {
        return Err(Error::Argument("no lights: every image would be black".into()));
    }
    if reference.rgb.iter().all(|c| *c == Vec3::ZERO) {
        return Err(Error::Argument(format!(
            "the reference image is black: none of the {} lights reaches any of the {covered} covered samples \
             (lights in another space than the G-buffer, out of range, or behind every surface?)",
            lights.len()
        )));
    }
    Ok(())
}
