//! Folding supersampled dumps: each k×k pixel block becomes k² ordered-grid samples of one pixel.
//!
//! A dump rendered at k× resolution with one sample per pixel holds exactly what a k²-sample ordered-grid MSAA
//! buffer holds: sample `j·k + i` of output pixel (x, y) is input pixel (k·x + i, k·y + j), at offset
//! ((i + ½)/k − ½, (j + ½)/k − ½) from the output pixel centre ([`ordered_grid_positions`]). The camera is
//! unchanged: the field of view and the aspect ratio are the same at either resolution.

use crate::error::{Error, Result};
use crate::gbuffer::{ordered_grid_positions, Attribute, GBuffer, PlaneMapper, MAX_SAMPLES};

/// Folds every k×k block of a one-sample G-buffer into k² samples of one pixel.
///
/// Errors (as [`Error::Argument`]) when `gb` has more than one sample per pixel, when `k` is 0 or k² exceeds
/// [`MAX_SAMPLES`], or when the width or height is not a multiple of `k`. `k = 1` returns a copy.
pub fn fold(gb: &GBuffer, k: u32) -> Result<GBuffer> {
    if k == 0 || k * k > MAX_SAMPLES {
        return Err(Error::Argument(format!(
            "fold factor {k} outside 1..=8 (k² samples must be at most {MAX_SAMPLES})"
        )));
    }
    if gb.samples != 1 {
        return Err(Error::Argument(format!(
            "fold needs one sample per pixel; this G-buffer already has {} (fold a supersampled dump, not an MSAA one)",
            gb.samples
        )));
    }
    if !gb.width.is_multiple_of(k) || !gb.height.is_multiple_of(k) {
        return Err(Error::Argument(format!(
            "fold {k}: the image size {}×{} is not a multiple of {k}",
            gb.width, gb.height
        )));
    }
    gb.validate()?;
    let (w, h) = (gb.width / k, gb.height / k);
    let mut map = FoldMap { src_width: gb.width as usize, w: w as usize, h: h as usize, k: k as usize };
    let coverage = map.gather(&gb.coverage);
    Ok(gb.map_planes((w, h, k * k), ordered_grid_positions(k), coverage, &mut map))
}

/// Unfolds a mosaic of sample images, as RenderDoc saves a multisampled texture with "slices as grid": a
/// one-sample image of `cols × rows` tiles, tile `s` (column `s % cols`, row `s / cols`, top left first) holding
/// sample `s` of every pixel. The result has `cols · rows` samples per pixel at the standard positions for that
/// count (D3D/Vulkan patterns; an ordered grid for other squares). A camera stored in the file described the
/// mosaic, not the frame, and is dropped (the sidecar's applies).
pub fn ungrid(gb: &GBuffer, cols: u32, rows: u32) -> Result<GBuffer> {
    let s = cols.saturating_mul(rows);
    if cols == 0 || rows == 0 || s > MAX_SAMPLES {
        return Err(Error::Argument(format!("--grid {cols}x{rows}: 1 to {MAX_SAMPLES} tiles")));
    }
    if gb.samples != 1 {
        return Err(Error::Argument(format!("--grid needs a one-sample mosaic; this one has {} samples", gb.samples)));
    }
    if !gb.width.is_multiple_of(cols) || !gb.height.is_multiple_of(rows) {
        return Err(Error::Argument(format!(
            "--grid {cols}x{rows}: the image size {}×{} is not a multiple of the tiles",
            gb.width, gb.height
        )));
    }
    gb.validate()?;
    let (w, h) = (gb.width / cols, gb.height / rows);
    let positions = GBuffer::new(1, 1, s)?.sample_positions;
    let mut map =
        GridMap { src_width: gb.width as usize, w: w as usize, h: h as usize, cols: cols as usize, s: s as usize };
    let coverage = map.gather(&gb.coverage);
    let mut out = gb.map_planes((w, h, s), positions, coverage, &mut map);
    out.camera = None;
    Ok(out)
}

/// Index mapping from the unfolded (pixel-major) order back to the mosaic.
struct GridMap {
    src_width: usize,
    w: usize,
    h: usize,
    cols: usize,
    s: usize,
}

impl GridMap {
    fn gather<T: Copy>(&self, src: &[T]) -> Vec<T> {
        let mut out = Vec::with_capacity(src.len());
        for y in 0..self.h {
            for x in 0..self.w {
                for s in 0..self.s {
                    let (tx, ty) = (s % self.cols, s / self.cols);
                    out.push(src[(ty * self.h + y) * self.src_width + tx * self.w + x]);
                }
            }
        }
        out
    }
}

impl PlaneMapper for GridMap {
    fn map<T: Copy + Default + Send + Sync>(&mut self, _: Attribute, plane: &[T]) -> Option<Vec<T>> {
        Some(self.gather(plane))
    }
}

/// Index mapping from the folded (pixel-major) order back to the source image.
struct FoldMap {
    src_width: usize,
    w: usize,
    h: usize,
    k: usize,
}

impl FoldMap {
    fn gather<T: Copy>(&self, src: &[T]) -> Vec<T> {
        let k = self.k;
        let mut out = Vec::with_capacity(src.len());
        for y in 0..self.h {
            for x in 0..self.w {
                for j in 0..k {
                    let row = (y * k + j) * self.src_width + x * k;
                    out.extend_from_slice(&src[row..row + k]);
                }
            }
        }
        out
    }
}

/// Every plane folded the way the coverage is.
impl PlaneMapper for FoldMap {
    fn map<T: Copy + Default + Send + Sync>(&mut self, _: Attribute, plane: &[T]) -> Option<Vec<T>> {
        Some(self.gather(plane))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;

    fn indexed(w: u32, h: u32) -> GBuffer {
        let mut gb = GBuffer::new(w, h, 1).unwrap();
        gb.coverage = (0..w * h).map(|i| i % 3 != 0).collect();
        gb.depth = Some((0..w * h).map(|i| i as f32).collect());
        gb.object_id = Some((0..w * h).collect());
        gb.camera = Some(Camera::identity(0.7, w as f32 / h as f32, 0.1, 10.0));
        gb
    }

    #[test]
    fn sample_j_k_plus_i_comes_from_sub_pixel_column_i_row_j() {
        let gb = indexed(6, 4);
        let f = fold(&gb, 2).unwrap();
        assert_eq!((f.width, f.height, f.samples), (3, 2, 4));
        f.validate().unwrap();
        let ids = f.object_id.as_ref().unwrap();
        for y in 0..2 {
            for x in 0..3 {
                for s in 0..4 {
                    let (i, j) = (s % 2, s / 2);
                    let src = (2 * y + j) * 6 + 2 * x + i;
                    assert_eq!(ids[f.index(x, y, s)], src);
                    assert_eq!(f.depth.as_ref().unwrap()[f.index(x, y, s)], src as f32);
                    assert_eq!(f.coverage[f.index(x, y, s)], gb.coverage[src as usize]);
                }
            }
        }
        // The sample position of sample s sits at the centre of its source pixel.
        let p = f.sample_positions[3];
        assert_eq!((p.x, p.y), (0.25, 0.25));
        let cam = f.camera.unwrap();
        assert!((cam.aspect - f.width as f32 / f.height as f32).abs() < 1e-6);
    }

    /// Tile s of a 2×2 mosaic is sample s: pixel (x, y) sample s comes from (x + (s % 2)·w, y + (s / 2)·h).
    #[test]
    fn a_grid_mosaic_unfolds_tile_by_tile() {
        let gb = indexed(6, 4);
        let g = ungrid(&gb, 2, 2).unwrap();
        assert_eq!((g.width, g.height, g.samples), (3, 2, 4));
        let ids = g.object_id.as_ref().unwrap();
        for y in 0..2 {
            for x in 0..3 {
                for s in 0..4 {
                    let src = (y + (s / 2) * 2) * 6 + x + (s % 2) * 3;
                    assert_eq!(ids[g.index(x, y, s)], src);
                    assert_eq!(g.coverage[g.index(x, y, s)], gb.coverage[src as usize]);
                }
            }
        }
        assert_eq!(g.sample_positions, crate::gbuffer::standard_sample_positions(4).unwrap());
        assert!(g.camera.is_none());
        assert!(ungrid(&gb, 4, 1).unwrap_err().to_string().contains("multiple"));
        assert!(ungrid(&g, 1, 1).is_err(), "a multisampled input");
    }

    #[test]
    fn refuses_bad_sizes_and_multisampled_input() {
        let gb = indexed(6, 4);
        let e = fold(&gb, 4).unwrap_err().to_string();
        assert!(e.contains("6×4") && e.contains("multiple of 4"), "{e}");
        assert!(fold(&gb, 0).is_err());
        assert!(fold(&gb, 9).is_err());
        let twice = fold(&gb, 2).unwrap();
        assert!(fold(&twice, 1).unwrap_err().to_string().contains("already has 4"));
        assert_eq!(fold(&gb, 1).unwrap(), gb);
    }
}
