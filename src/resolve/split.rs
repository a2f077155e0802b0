//! A G-buffer in split order for the resolve: sample 0 of every pixel in planes of their own (laid out exactly
//! like a one-sample G-buffer), followed by the other samples of every pixel, side by side.
//!
//! Why: the adaptive schedule shades a non-edge pixel once, from its sample 0. In [`GBuffer`]'s interleaved order
//! (`(y·width + x)·samples + s`) those samples sit one in every `samples`, so building the work list of a 4×
//! frame streams the whole 4× G-buffer through the cache to use a quarter of it. In split order the non-edge
//! pixels read exactly what a one-sample frame reads, and only edge pixels touch the other samples, which share
//! cache lines (a fully sample-major order — every pixel's sample 1, then every pixel's sample 2 — puts each of
//! them on a line of its own: measured 1.2× the work-list CPU time and 1.05–1.17× the frame when 5–10% of pixels
//! are edges, docs/RESOLVE.md). A renderer chooses its G-buffer's memory order when it writes it; this is the one
//! to choose for an adaptive MSAA resolve.
//! The image, the heatmap and every count are the same in both orders (the work list is the same, item for item:
//! `tests/resolve_props.rs` checks it).

use super::surface::SampleOrder;
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::layout::PackedFrame;
use rayon::prelude::*;

/// A G-buffer's resolve attributes (coverage, depth, position, normal, albedo, specular, specular power,
/// roughness, metallic) in split order, ready to be resolved any number of times (see the module docs).
/// ID and motion planes are not kept: the resolve does not read them (detect edges on the original G-buffer).
///
/// ```
/// use gbuf::detect::{detect, Detector, DetectorConfig};
/// use gbuf::resolve::{fixture, resolve, ResolveConfig, SplitSamples};
/// let gb = fixture::spheres(48, 32, 4)?;
/// let lights = fixture::lights_on_surfaces(&gb, 20, 3.0, 1);
/// let mask = detect(&gb, Detector::Lauritzen, &DetectorConfig::default())?;
/// let split = SplitSamples::new(&gb)?; // once per G-buffer
/// let cfg = ResolveConfig::default();
/// let (a, b) = (resolve(&gb, &lights, &mask, &cfg)?, resolve(&split, &lights, &mask, &cfg)?);
/// assert_eq!(a.image, b.image);
/// assert!(b.stats.edge_fraction > 0.0 && b.stats.shading_fraction < 1.0);
/// # Ok::<(), gbuf::Error>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplitSamples {
    /// The planes, reordered ([`GBuffer::index`] does not apply to them: only the resolve reads this).
    gb: GBuffer,
}

impl SplitSamples {
    /// Reorders `gb` (one pass over the planes the resolve reads, in parallel on rayon's current pool; for one
    /// sample per pixel a plain copy). Fails
    /// when `gb` is inconsistent (see [`GBuffer::validate`]).
    pub fn new(gb: &GBuffer) -> Result<Self> {
        gb.validate()?;
        let (p, s) = (gb.pixel_count(), gb.samples as usize);
        fn reorder<T: Copy + Default + Send + Sync>(v: &[T], p: usize, s: usize) -> Vec<T> {
            if s == 1 {
                return v.to_vec();
            }
            // Pieces of pixels in parallel, each one pass over its pixels' samples: sample 0 to the first part,
            // the others to the second.
            const PIECE: usize = 1 << 12;
            let mut out = vec![T::default(); v.len()];
            let (first, rest) = out.split_at_mut(p);
            first.par_chunks_mut(PIECE).zip(rest.par_chunks_mut(PIECE * (s - 1))).enumerate().for_each(
                |(c, (first, rest))| {
                    let from = v[c * PIECE * s..].chunks_exact(s);
                    for ((f, r), px) in first.iter_mut().zip(rest.chunks_exact_mut(s - 1)).zip(from) {
                        *f = px[0];
                        r.copy_from_slice(&px[1..]);
                    }
                },
            );
            out
        }
        fn plane<T: Copy + Default + Send + Sync>(v: &Option<Vec<T>>, p: usize, s: usize) -> Option<Vec<T>> {
            v.as_deref().map(|v| reorder(v, p, s))
        }
        Ok(SplitSamples {
            gb: GBuffer {
                width: gb.width,
                height: gb.height,
                samples: gb.samples,
                sample_positions: gb.sample_positions.clone(),
                camera: gb.camera,
                coverage: reorder(&gb.coverage, p, s),
                depth: plane(&gb.depth, p, s),
                position: plane(&gb.position, p, s),
                normal: plane(&gb.normal, p, s),
                albedo: plane(&gb.albedo, p, s),
                specular: plane(&gb.specular, p, s),
                specular_power: plane(&gb.specular_power, p, s),
                roughness: plane(&gb.roughness, p, s),
                metallic: plane(&gb.metallic, p, s),
                materials: gb.materials.clone(),
                ..Default::default()
            },
        })
    }

    /// Width in pixels.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.gb.width
    }

    /// Height in pixels.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.gb.height
    }

    /// Samples per pixel.
    #[must_use]
    pub fn samples(&self) -> u32 {
        self.gb.samples
    }
}

/// What the resolve lights: a [`GBuffer`] as it is (interleaved samples) or a [`SplitSamples`] copy of one. Both
/// give the same image; `&GBuffer` and `&SplitSamples` convert into it, so either can be passed to
/// [`super::resolve`].
#[derive(Clone, Copy, Debug)]
pub enum ResolveInput<'a> {
    /// [`GBuffer`]'s own order.
    Interleaved(&'a GBuffer),
    /// Split order.
    Split(&'a SplitSamples),
    /// Packed render targets, decoded band by band inside the resolve ([`crate::layout::Layout::frame`]): the
    /// image is the unpacked G-buffer's bit for bit, and no decoded copy of the frame exists.
    Packed(&'a PackedFrame<'a>),
}

impl<'a> From<&'a PackedFrame<'a>> for ResolveInput<'a> {
    fn from(frame: &'a PackedFrame<'a>) -> Self {
        ResolveInput::Packed(frame)
    }
}

impl<'a> From<&'a GBuffer> for ResolveInput<'a> {
    fn from(gb: &'a GBuffer) -> Self {
        ResolveInput::Interleaved(gb)
    }
}

impl<'a> From<&'a SplitSamples> for ResolveInput<'a> {
    fn from(split: &'a SplitSamples) -> Self {
        ResolveInput::Split(split)
    }
}

impl<'a> ResolveInput<'a> {
    /// The planes and their order.
    #[must_use]
    pub(crate) fn planes(self) -> (&'a GBuffer, SampleOrder) {
        match self {
            ResolveInput::Interleaved(gb) => (gb, SampleOrder::Interleaved),
            ResolveInput::Split(split) => (&split.gb, SampleOrder::Split),
            ResolveInput::Packed(frame) => (frame.like(), SampleOrder::Interleaved),
        }
    }

    /// The packed targets, when the input is packed.
    #[must_use]
    pub(crate) fn packed(self) -> Option<&'a PackedFrame<'a>> {
        match self {
            ResolveInput::Packed(frame) => Some(frame),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn every_sample_lands_at_its_split_index() {
        let mut gb = GBuffer::new(3, 2, 4).unwrap();
        let n = gb.len();
        gb.coverage = (0..n).map(|i| i % 3 != 0).collect();
        gb.position = Some((0..n).map(|i| Vec3::new(i as f32, 0.0, -1.0)).collect());
        gb.specular = Some((0..n).map(|i| i as f32).collect());
        gb.object_id = Some(vec![7; n]);
        let sm = SplitSamples::new(&gb).unwrap();
        let (p, s) = (gb.pixel_count(), 4);
        let at = super::super::surface::SampleIndex::new(SampleOrder::Split, p, s);
        for y in 0..2 {
            for x in 0..3 {
                for k in 0..4 {
                    let px = (y * 3 + x) as usize;
                    let to = if k == 0 { px } else { p + px * 3 + k as usize - 1 };
                    let from = gb.index(x, y, k);
                    assert_eq!(at.of(px, k), to);
                    assert_eq!(sm.gb.position.as_ref().unwrap()[to].x, from as f32);
                    assert_eq!(sm.gb.specular.as_ref().unwrap()[to], from as f32);
                    assert_eq!(sm.gb.coverage[to], gb.coverage[from]);
                }
            }
        }
        assert_eq!(sm.gb.len(), p * s);
        assert!(sm.gb.object_id.is_none() && sm.gb.normal.is_none());
        assert!(sm.gb.validate().is_ok());
    }

    #[test]
    fn an_inconsistent_gbuffer_is_refused() {
        let mut gb = GBuffer::new(2, 2, 4).unwrap();
        gb.normal = Some(vec![Vec3::Z; 3]);
        assert!(SplitSamples::new(&gb).is_err());
    }
}
