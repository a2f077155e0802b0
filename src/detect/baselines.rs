//! The baselines every detector is measured between: `none` (shade each covered pixel once: cheapest, aliased
//! lighting), `ssaa` (shade every sample: the cost ceiling), and `forward-msaa` (what hardware MSAA shades in a
//! forward renderer: the pixel shader runs once per primitive covering the pixel, so the count is the number of
//! distinct primitives among the covered samples).

use super::{missing, per_pixel, pixel_coverage, Detector, EdgeMask, PixelCoverage};
use crate::error::Result;
use crate::gbuffer::GBuffer;

/// `none`: 1 evaluation per pixel with any covered sample, 0 for empty pixels.
#[must_use]
pub fn none(gb: &GBuffer) -> EdgeMask {
    let s = gb.samples as usize;
    if s == 1 {
        // One sample a pixel: the mask is the coverage (a copy, where the per-pixel driver cost 2 ms at 720p).
        let mut shade_count: Vec<u8> = crate::base::memory::zeroed_on_huge_pages(gb.coverage.len());
        for (m, &c) in shade_count.iter_mut().zip(&gb.coverage) {
            *m = u8::from(c);
        }
        return EdgeMask { width: gb.width, height: gb.height, samples: 1, shade_count };
    }
    per_pixel(gb, |_, _, base| u8::from(pixel_coverage(&gb.coverage, base, s) != PixelCoverage::Empty))
}

/// `ssaa`: every pixel with any covered sample shaded per sample (count `samples`), 0 for empty pixels. The mask
/// asks for `samples` per such pixel, but the resolve shades only covered samples, so what it costs is the covered
/// samples ([`EdgeMask::evaluations`], which the reported shading fractions use). The count stays `samples` even
/// for a pixel with a single covered sample: a count of 1 would mean "sample 0 stands for the pixel" (full weight
/// instead of the box filter's 1/samples).
#[must_use]
pub fn ssaa(gb: &GBuffer) -> EdgeMask {
    let s = gb.samples as usize;
    let all = gb.samples.min(u32::from(u8::MAX)) as u8;
    per_pixel(gb, |_, _, base| if pixel_coverage(&gb.coverage, base, s) == PixelCoverage::Empty { 0 } else { all })
}

/// `forward-msaa`: the number of distinct primitives among a pixel's covered samples. A primitive is its primitive
/// ID, paired with its object ID when the G-buffer has object IDs (renderers number primitives per draw call).
/// Needs primitive IDs.
pub fn forward_msaa(gb: &GBuffer) -> Result<EdgeMask> {
    let prim = gb.primitive_id.as_deref().ok_or_else(|| missing(gb, Detector::ForwardMsaa, "primitive_id"))?;
    let obj = gb.object_id.as_deref();
    let s = gb.samples as usize;
    Ok(per_pixel(gb, |_, _, base| {
        // At most 64 samples: a quadratic scan over a small stack array beats hashing.
        let mut seen = [(0u32, 0u32); crate::gbuffer::MAX_SAMPLES as usize];
        let mut n = 0usize;
        for i in base..base + s {
            if !gb.coverage[i] {
                continue;
            }
            let key = (obj.map_or(0, |o| o[i]), prim[i]);
            if !seen[..n].contains(&key) {
                seen[n] = key;
                n += 1;
            }
        }
        n as u8
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forward_counts_distinct_covered_primitives() {
        let mut gb = GBuffer::new(3, 1, 4).unwrap();
        gb.coverage = vec![true, true, true, true, true, false, true, true, false, false, false, false];
        gb.primitive_id = Some(vec![5, 5, 5, 5, 1, 9, 2, 2, 0, 0, 0, 0]);
        assert_eq!(forward_msaa(&gb).unwrap().shade_count, vec![1, 2, 0]);
        // The same primitive index in two objects is two primitives.
        gb.object_id = Some(vec![0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(forward_msaa(&gb).unwrap().shade_count, vec![2, 2, 0]);
        assert_eq!(none(&gb).shade_count, vec![1, 1, 0]);
        assert_eq!(ssaa(&gb).shade_count, vec![4, 4, 0]);
    }
}
