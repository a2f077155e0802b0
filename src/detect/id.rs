//! The `id` detector: a pixel is per-sample when some sample's material or object ID differs from sample 0's.
//!
//! Exact for the surfaces the IDs separate, blind to silhouettes of an object against itself (a sphere in front of
//! its own base) and to creases inside one material. Material IDs are what a real G-buffer carries (often packed
//! into a few bits); object IDs are the ground truth of [`super::truth`], so `--ids object` scores perfectly there
//! by construction and is only useful as a check.

use super::{geometric_mask, missing, Detector, DetectorConfig, EdgeMask, IdSource};
use crate::error::Result;
use crate::gbuffer::GBuffer;

/// The ID planes a detector compares, resolved once.
#[derive(Clone, Copy, Debug)]
pub(crate) struct IdPlanes<'a> {
    material: Option<&'a [u32]>,
    object: Option<&'a [u32]>,
}

impl<'a> IdPlanes<'a> {
    /// The planes `source` asks for that `gb` has; `None` when it has none of them.
    pub(crate) fn resolve(gb: &'a GBuffer, source: IdSource) -> Option<Self> {
        let material = gb.material_id.as_deref().filter(|_| source != IdSource::Object);
        let object = gb.object_id.as_deref().filter(|_| source != IdSource::Material);
        (material.is_some() || object.is_some()).then_some(IdPlanes { material, object })
    }

    /// Do all `samples` samples starting at `base` carry sample 0's IDs?
    #[inline]
    pub(crate) fn same(&self, base: usize, samples: usize) -> bool {
        let same = |p: &[u32]| p[base + 1..base + samples].iter().all(|&v| v == p[base]);
        self.material.is_none_or(same) && self.object.is_none_or(same)
    }
}

/// Runs the `id` detector.
pub(crate) fn detect(gb: &GBuffer, cfg: &DetectorConfig) -> Result<EdgeMask> {
    let needs = match cfg.ids {
        IdSource::Material => "material_id",
        IdSource::Object => "object_id",
        IdSource::Either => "material_id or object_id",
    };
    let ids = IdPlanes::resolve(gb, cfg.ids).ok_or_else(|| missing(gb, Detector::Id, needs))?;
    let s = gb.samples as usize;
    Ok(geometric_mask(gb, |_, _, base| ids.same(base, s)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn material_and_object_ids_are_compared_as_asked() {
        let mut gb = GBuffer::new(2, 1, 2).unwrap();
        gb.coverage.fill(true);
        // Pixel 0: same material, different objects. Pixel 1: different materials, same object.
        gb.material_id = Some(vec![1, 1, 1, 2]);
        gb.object_id = Some(vec![7, 8, 9, 9]);
        let run = |ids| detect(&gb, &DetectorConfig { ids, ..Default::default() }).unwrap().edges();
        assert_eq!(run(IdSource::Material), vec![false, true]);
        assert_eq!(run(IdSource::Object), vec![true, false]);
        assert_eq!(run(IdSource::Either), vec![true, true]);
        gb.object_id = None;
        let e = detect(&gb, &DetectorConfig { ids: IdSource::Object, ..Default::default() }).unwrap_err();
        assert!(e.to_string().contains("object_id"), "{e}");
    }
}
