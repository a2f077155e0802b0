//! Ground truth for the edge detectors, from the IDs the dump carries.
//!
//! A pixel is a *true edge* when its samples do not all come from one surface: some are background and some are
//! not, or their object IDs differ ([`TruthSource::Object`], the ground truth of `gbuf edges`), or their
//! (object, primitive) IDs differ ([`TruthSource::Primitive`], the finer truth a forward renderer's MSAA rate
//! follows). The shading truth (does the reference shading actually vary inside the pixel?) is computed from the
//! resolve's reference in `measure::edges::shading_truth`.

use super::{pixel_coverage, PixelCoverage};
use crate::gbuffer::GBuffer;
use rayon::prelude::*;

/// Which IDs define "one surface".
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TruthSource {
    /// Object IDs: one object is one surface.
    Object,
    /// Primitive IDs (paired with object IDs when present): one triangle is one surface.
    Primitive,
}

crate::named!(TruthSource: "truth" { Object => "object", Primitive => "primitive" });

/// Per-pixel true-edge flags (row-major) from `source`'s IDs; `None` when the G-buffer lacks them.
/// Empty pixels are never edges; a pixel mixing background and surface always is.
#[must_use]
pub fn id_truth(gb: &GBuffer, source: TruthSource) -> Option<Vec<bool>> {
    let (primary, secondary) = match source {
        TruthSource::Object => (gb.object_id.as_deref()?, None),
        TruthSource::Primitive => (gb.primitive_id.as_deref()?, gb.object_id.as_deref()),
    };
    let s = gb.samples as usize;
    if gb.coverage.len() != gb.len() || primary.len() != gb.len() || secondary.is_some_and(|o| o.len() != gb.len()) {
        debug_assert!(false, "inconsistent G-buffer reached id_truth");
        return None;
    }
    let mut out = vec![false; gb.pixel_count()];
    out.par_iter_mut().enumerate().for_each(|(p, edge)| {
        let base = p * s;
        *edge = match pixel_coverage(&gb.coverage, base, s) {
            PixelCoverage::Empty => false,
            PixelCoverage::Mixed => true,
            PixelCoverage::Full => {
                let differs = |plane: &[u32]| plane[base + 1..base + s].iter().any(|&v| v != plane[base]);
                differs(primary) || secondary.is_some_and(differs)
            }
        };
    });
    Some(out)
}

/// The ground truth of `gbuf edges`: [`id_truth`] with object IDs.
#[must_use]
pub fn object_truth(gb: &GBuffer) -> Option<Vec<bool>> {
    id_truth(gb, TruthSource::Object)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_from_objects_and_primitives() {
        let mut gb = GBuffer::new(4, 1, 2).unwrap();
        // Pixel 0: one object, two triangles. 1: two objects. 2: half background. 3: empty.
        gb.coverage = vec![true, true, true, true, true, false, false, false];
        gb.object_id = Some(vec![1, 1, 1, 2, 1, 0, 0, 0]);
        assert_eq!(object_truth(&gb), Some(vec![false, true, true, false]));
        assert_eq!(id_truth(&gb, TruthSource::Primitive), None);
        gb.primitive_id = Some(vec![3, 4, 3, 3, 3, 0, 0, 0]);
        assert_eq!(id_truth(&gb, TruthSource::Primitive), Some(vec![true, true, true, false]));
        gb.object_id = None;
        assert_eq!(object_truth(&gb), None);
        // Without object IDs, pixel 1's equal primitive indices count as one primitive.
        assert_eq!(id_truth(&gb, TruthSource::Primitive), Some(vec![true, false, true, false]));
    }
}
