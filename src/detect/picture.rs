//! A picture of an edge mask over the scene, for `gbuf edges --mask OUT.png`.
//!
//! The scene is drawn from the G-buffer alone (no lights needed): albedo × (0.25 + 0.75 · max(N·(0,0,1), 0)),
//! averaged over the covered samples, sRGB-encoded; greyscale depth (near bright) where albedo is missing; black
//! background. Over it, solid colours: [`FLAGGED`] for pixels shaded per sample (correctly, when there is a
//! truth), and with a truth [`MISSED`] for true edges not flagged and [`FALSE_ALARM`] for flagged pixels that
//! are not true edges.

use super::EdgeMask;
use crate::base::picture::{srgb8, write_png as write_png_image};
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use glam::Vec3;
use std::path::Path;

/// Per-sample pixels (true positives when a truth is given): red.
pub const FLAGGED: [u8; 3] = [255, 0, 0];
/// True edges the detector missed: yellow.
pub const MISSED: [u8; 3] = [255, 230, 0];
/// Flagged pixels that are not true edges: cyan.
pub const FALSE_ALARM: [u8; 3] = [0, 220, 255];

/// The scene as linear RGB per pixel, drawn from albedo and normals, else depth, else coverage.
fn scene_rgb(gb: &GBuffer) -> Vec<Vec3> {
    let s = gb.samples as usize;
    let (mut zmin, mut zmax) = (f32::INFINITY, f32::NEG_INFINITY);
    let depth = gb.depth.as_deref();
    if let (None, Some(d)) = (gb.albedo.as_deref(), depth) {
        for (&z, &c) in d.iter().zip(&gb.coverage) {
            if c && z.is_finite() {
                zmin = zmin.min(z);
                zmax = zmax.max(z);
            }
        }
    }
    let range = (zmax - zmin).max(f32::MIN_POSITIVE);
    (0..gb.pixel_count())
        .map(|p| {
            let (mut sum, mut n) = (Vec3::ZERO, 0u32);
            for i in p * s..p * s + s {
                if !gb.coverage[i] {
                    continue;
                }
                let light = gb.normal.as_deref().map_or(1.0, |nrm| 0.25 + 0.75 * nrm[i].z.max(0.0));
                let c = match (gb.albedo.as_deref(), depth) {
                    (Some(a), _) => a[i] * light,
                    (None, Some(d)) => Vec3::splat(1.0 - 0.8 * (d[i] - zmin) / range),
                    (None, None) => Vec3::splat(light),
                };
                if c.is_finite() {
                    sum += c;
                    n += 1;
                }
            }
            if n == 0 {
                Vec3::ZERO
            } else {
                sum / n as f32
            }
        })
        .collect()
}

/// Draws `mask` over the scene of `gb`; `truth` (row-major true-edge flags) adds misses and false alarms.
/// Errors when the mask or truth does not match the G-buffer's size.
pub fn render(gb: &GBuffer, mask: &EdgeMask, truth: Option<&[bool]>) -> Result<image::RgbImage> {
    gb.validate()?;
    let n = gb.pixel_count();
    if mask.width != gb.width || mask.height != gb.height || mask.shade_count.len() != n {
        return Err(Error::Mismatch(format!(
            "edge mask is {}×{}, the G-buffer {}×{}",
            mask.width, mask.height, gb.width, gb.height
        )));
    }
    if truth.is_some_and(|t| t.len() != n) {
        return Err(Error::Mismatch(format!("truth has {} pixels, the G-buffer {n}", truth.map_or(0, <[bool]>::len))));
    }
    let scene = scene_rgb(gb);
    let mut img = image::RgbImage::new(gb.width, gb.height);
    for (p, px) in img.pixels_mut().enumerate() {
        let flagged = mask.is_edge(p);
        let colour = match (flagged, truth.map(|t| t[p])) {
            (true, None | Some(true)) => FLAGGED,
            (true, Some(false)) => FALSE_ALARM,
            (false, Some(true)) => MISSED,
            (false, _) => scene[p].to_array().map(srgb8),
        };
        px.0 = colour;
    }
    Ok(img)
}

/// Renders (see [`render`]) and writes a PNG atomically to `path`.
pub fn write_png(path: &Path, gb: &GBuffer, mask: &EdgeMask, truth: Option<&[bool]>) -> Result<()> {
    write_png_image(path, &render(gb, mask, truth)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_follow_the_confusion_matrix() {
        let mut gb = GBuffer::new(4, 1, 2).unwrap();
        gb.coverage.fill(true);
        gb.albedo = Some(vec![Vec3::new(1.0, 0.0, 0.5); 8]);
        gb.normal = Some(vec![Vec3::Z; 8]);
        let mask = EdgeMask { width: 4, height: 1, samples: 2, shade_count: vec![2, 2, 1, 1] };
        let truth = [true, false, true, false];
        let img = render(&gb, &mask, Some(&truth)).unwrap();
        let px: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
        assert_eq!(px[..3], [FLAGGED, FALSE_ALARM, MISSED]);
        assert_eq!(px[3], [255, 0, 188]); // sRGB(0.5) = 188
        let img = render(&gb, &mask, None).unwrap();
        assert_eq!(img.get_pixel(1, 0).0, FLAGGED);
        assert!(render(&gb, &EdgeMask::filled(3, 1, 2, 1), None).is_err());
        assert!(render(&gb, &mask, Some(&truth[..2])).is_err());
    }

    #[test]
    fn depth_only_buffers_draw_near_bright() {
        let mut gb = GBuffer::new(2, 1, 1).unwrap();
        gb.coverage.fill(true);
        gb.depth = Some(vec![1.0, 5.0]);
        let img = render(&gb, &EdgeMask::filled(2, 1, 1, 1), None).unwrap();
        assert!(img.get_pixel(0, 0).0[0] > img.get_pixel(1, 0).0[0]);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.png");
        write_png(&p, &gb, &EdgeMask::filled(2, 1, 1, 1), None).unwrap();
        assert_eq!(image::open(&p).unwrap().width(), 2);
    }
}
