//! 8-bit pictures: the sRGB transfer function, the colour map every heatmap uses, and PNG encoding. The one place
//! the crate turns numbers into pixels and pixels into a PNG file; plots (`report::plot`) draw on top of it.

use crate::base::files::write_bytes_atomic;
use crate::error::{Error, Result};
use image::RgbImage;
use std::path::Path;

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1]: the crate's one sRGB (the image
/// writers, the `srgb8` codec and its decode table; FLIP's vectorised approximation is its own, tested against it).
#[must_use]
#[inline]
pub fn srgb_encode(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`srgb_encode`]: an sRGB-encoded value in [0, 1] back to linear.
#[must_use]
#[inline]
pub fn srgb_decode(e: f32) -> f32 {
    if e <= 0.040_45 {
        e / 12.92
    } else {
        ((e + 0.055) / 1.055).powf(2.4)
    }
}

/// A linear value as an 8-bit sRGB code: clamped to [0, 1] (non-finite → 0), encoded, rounded to nearest.
#[must_use]
pub fn srgb8(x: f32) -> u8 {
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
    (srgb_encode(x) * 255.0 + 0.5) as u8
}

/// The colour map of every heatmap: `t` ∈ [0, 1] to a perceptually ordered colour (dark violet → blue → teal →
/// green → yellow, after viridis). Non-finite `t` is 0.
#[must_use]
pub fn colormap(t: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 5] =
        [[68.0, 1.0, 84.0], [59.0, 82.0, 139.0], [33.0, 145.0, 140.0], [94.0, 201.0, 98.0], [253.0, 231.0, 37.0]];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 } * (STOPS.len() - 1) as f32;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let u = t - i as f32;
    [0, 1, 2].map(|k| (STOPS[i][k] + (STOPS[i + 1][k] - STOPS[i][k]) * u).round() as u8)
}

/// Encodes an RGB image as PNG bytes ([`crate::base::png`]: bands of rows deflated in parallel).
pub fn png_bytes(img: &RgbImage) -> Result<Vec<u8>> {
    crate::base::png::encode_rgb8(img.width(), img.height(), img.as_raw())
}

/// Writes an RGB image as a PNG file, atomically (temporary file, then rename). Errors name `path`.
pub fn write_png(path: &Path, img: &RgbImage) -> Result<()> {
    if img.width() == 0 || img.height() == 0 {
        return Err(Error::Argument(format!("{}: cannot write an empty image", path.display())));
    }
    let bytes = png_bytes(img).map_err(|e| Error::invalid(path, e.to_string()))?;
    write_bytes_atomic(path, &bytes)
}

/// Writes 8-bit RGB bytes (row-major, `width × height × 3`) as a PNG file, atomically.
pub fn write_rgb8_png(path: &Path, width: u32, height: u32, bytes: Vec<u8>) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::Argument(format!("{}: cannot write an empty image", path.display())));
    }
    let img = RgbImage::from_raw(width, height, bytes)
        .ok_or_else(|| Error::Mismatch(format!("{}: pixel buffer does not match {width}×{height}", path.display())))?;
    write_png(path, &img)
}

/// Height in pixels of the legend strip under a heatmap.
pub const HEATMAP_LEGEND_ROWS: u32 = 8;

/// `counts` (row-major, `width × height`) as a heatmap PNG in memory through [`colormap`], scaled so that
/// `max(counts)` is the top of the map, with a legend strip of [`HEATMAP_LEGEND_ROWS`] rows underneath running
/// from 0 (left) to the maximum (right): the PNG's bytes and the maximum, which the caller should print (the PNG
/// carries no text; the report's heatmaps, `report::plot::Heatmap`, have a numbered colour bar).
pub fn heatmap_png(width: u32, height: u32, counts: &[u32]) -> Result<(Vec<u8>, u32)> {
    if counts.len() != width as usize * height as usize {
        return Err(Error::Mismatch(format!("{} counts for a {width}×{height} heatmap", counts.len())));
    }
    let max = counts.iter().copied().max().unwrap_or(0);
    let scale = if max > 0 { 1.0 / max as f32 } else { 0.0 };
    let mut bytes: Vec<u8> = counts.iter().flat_map(|&c| colormap(c as f32 * scale)).collect();
    for _ in 0..HEATMAP_LEGEND_ROWS {
        for x in 0..width {
            bytes.extend(colormap(x as f32 / (width.max(2) - 1) as f32));
        }
    }
    Ok((crate::base::png::encode_rgb8(width, height + HEATMAP_LEGEND_ROWS, &bytes)?, max))
}

/// The top-left corner of the `cw × ch` window of `values` (a row-major `w × h` map) with the largest sum
/// (non-finite values count 0; the first such window in row order on ties): where a crop shows the most of
/// something — an error map's worst region. A summed-area table, every position tried.
#[must_use]
pub fn busiest_window(values: &[f32], w: u32, h: u32, cw: u32, ch: u32) -> (u32, u32) {
    let (wu, hu, cw, ch) = (w as usize, h as usize, cw.min(w) as usize, ch.min(h) as usize);
    if values.len() != wu * hu {
        return (0, 0);
    }
    let w1 = wu + 1;
    let mut sat = vec![0.0f64; w1 * (hu + 1)];
    for y in 0..hu {
        let mut row = 0.0f64;
        for x in 0..wu {
            let v = values[y * wu + x];
            row += if v.is_finite() { f64::from(v) } else { 0.0 };
            sat[(y + 1) * w1 + x + 1] = sat[y * w1 + x + 1] + row;
        }
    }
    let mut best = (0, 0, f64::NEG_INFINITY);
    for y in 0..=hu - ch {
        for x in 0..=wu - cw {
            let v = sat[(y + ch) * w1 + x + cw] - sat[y * w1 + x + cw] - sat[(y + ch) * w1 + x] + sat[y * w1 + x];
            if v > best.2 {
                best = (x as u32, y as u32, v);
            }
        }
    }
    (best.0, best.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_busiest_window_is_where_the_values_are() {
        let (w, h) = (12u32, 9u32);
        let mut v = vec![0.0f32; (w * h) as usize];
        for (x, y) in [(7, 5), (8, 5), (8, 6)] {
            v[(y * w + x) as usize] = 1.0;
        }
        v[0] = f32::NAN; // counts 0
        v[1] = f32::INFINITY;
        assert_eq!(busiest_window(&v, w, h, 3, 2), (6, 5));
        assert_eq!(busiest_window(&vec![0.0; (w * h) as usize], w, h, 3, 2), (0, 0), "ties: the first window");
        assert_eq!(busiest_window(&v, w, h, 40, 40), (0, 0), "a window larger than the map is the map");
        assert_eq!(busiest_window(&v[1..], w, h, 3, 2), (0, 0), "a map of the wrong size");
    }

    #[test]
    fn srgb_round_trips_and_has_the_standard_ends() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        for i in 0..=100 {
            let x = i as f32 / 100.0;
            assert!((srgb_decode(srgb_encode(x)) - x).abs() < 1e-6, "{x}");
        }
        assert_eq!(srgb8(0.5), 188);
        assert_eq!((srgb8(f32::NAN), srgb8(f32::INFINITY), srgb8(-1.0), srgb8(7.0)), (0, 0, 0, 255));
    }

    #[test]
    fn colormap_ends_and_png_round_trip() {
        assert_eq!(colormap(0.0), [68, 1, 84]);
        assert_eq!(colormap(1.0), [253, 231, 37]);
        assert_eq!(colormap(f32::NAN), colormap(0.0));
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.png");
        write_rgb8_png(&p, 2, 1, vec![1, 2, 3, 4, 5, 6]).unwrap();
        assert_eq!(image::open(&p).unwrap().to_rgb8().as_raw(), &vec![1, 2, 3, 4, 5, 6]);
        assert!(write_rgb8_png(&p, 3, 1, vec![0; 6]).is_err());
        assert!(write_rgb8_png(&p, 0, 1, vec![]).is_err());
    }

    #[test]
    fn heatmap_scales_to_the_maximum_with_a_legend() {
        let (png, max) = heatmap_png(3, 2, &[0, 1, 2, 3, 4, 8]).unwrap();
        assert_eq!(max, 8);
        let h = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!(h.dimensions(), (3, 2 + HEATMAP_LEGEND_ROWS));
        assert_eq!(h.get_pixel(2, 1).0, colormap(1.0));
        assert_eq!(h.get_pixel(0, 0).0, colormap(0.0));
        assert_eq!(h.get_pixel(2, 2 + HEATMAP_LEGEND_ROWS - 1).0, colormap(1.0), "legend ends at the maximum");
        assert!(heatmap_png(3, 3, &[0; 6]).is_err());
    }
}
