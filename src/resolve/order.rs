//! A G-buffer in sample-major order for the resolve: every pixel's sample 0 in planes of their own (laid out
//! exactly like a one-sample G-buffer), then every pixel's sample 1, and so on.
//!
//! Why: the adaptive schedule shades a non-edge pixel once, from its sample 0. In [`GBuffer`]'s interleaved order
//! (`(y·width + x)·samples + s`) those samples sit one in every `samples`, so building the work list of a 4×
//! frame streams the whole 4× G-buffer through the cache to use a quarter of it. In sample-major order the
//! non-edge pixels read exactly what a one-sample frame reads, and only edge pixels touch the other samples'
//! planes. A renderer chooses its G-buffer's memory order when it writes it; this is the order to choose for an
//! adaptive MSAA resolve. The image, the heatmap and every count are the same in both orders (the work list is
//! the same, item for item: `tests/resolve_props.rs` checks it).

use super::surface::SampleOrder;
use crate::error::Result;
use crate::gbuffer::GBuffer;
use rayon::prelude::*;

/// A G-buffer's resolve attributes (coverage, depth, position, normal, albedo, specular, specular power,
/// roughness, metallic) reordered sample-major, ready to be resolved any number of times (see the module docs).
/// ID and motion planes are not kept: the resolve does not read them (detect edges on the original G-buffer).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SampleMajor {
    /// The planes, reordered (so [`GBuffer::index`] does not apply to them: only the resolve reads this).
    gb: GBuffer,
}

impl SampleMajor {
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
            // Pieces of pixels in parallel; each reads its pixels' samples in order (one pass over `v`) and writes
            // sample k into plane k.
            const PIECE: usize = 1 << 12;
            let mut out = vec![T::default(); v.len()];
            let mut pieces: Vec<Vec<&mut [T]>> = (0..p.div_ceil(PIECE)).map(|_| Vec::with_capacity(s)).collect();
            for plane in out.chunks_mut(p) {
                for (piece, part) in pieces.iter_mut().zip(plane.chunks_mut(PIECE)) {
                    piece.push(part);
                }
            }
            pieces.into_par_iter().enumerate().for_each(|(c, mut parts)| {
                let n = parts[0].len();
                for (j, px) in v[c * PIECE * s..].chunks_exact(s).take(n).enumerate() {
                    for (part, &x) in parts.iter_mut().zip(px) {
                        part[j] = x;
                    }
                }
            });
            out
        }
        fn plane<T: Copy + Default + Send + Sync>(v: &Option<Vec<T>>, p: usize, s: usize) -> Option<Vec<T>> {
            v.as_deref().map(|v| reorder(v, p, s))
        }
        Ok(SampleMajor {
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

/// What the resolve lights: a [`GBuffer`] as it is (interleaved samples) or a [`SampleMajor`] copy of one. Both
/// give the same image; `&GBuffer` and `&SampleMajor` convert into it, so either can be passed to
/// [`super::resolve`].
#[derive(Clone, Copy, Debug)]
pub enum ResolveInput<'a> {
    /// [`GBuffer`]'s own order.
    Interleaved(&'a GBuffer),
    /// Sample-major order.
    SampleMajor(&'a SampleMajor),
}

impl<'a> From<&'a GBuffer> for ResolveInput<'a> {
    fn from(gb: &'a GBuffer) -> Self {
        ResolveInput::Interleaved(gb)
    }
}

impl<'a> From<&'a SampleMajor> for ResolveInput<'a> {
    fn from(sm: &'a SampleMajor) -> Self {
        ResolveInput::SampleMajor(sm)
    }
}

impl<'a> ResolveInput<'a> {
    /// The planes and their order.
    #[must_use]
    pub(crate) fn planes(self) -> (&'a GBuffer, SampleOrder) {
        match self {
            ResolveInput::Interleaved(gb) => (gb, SampleOrder::Interleaved),
            ResolveInput::SampleMajor(sm) => (&sm.gb, SampleOrder::SampleMajor),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn every_sample_lands_at_its_sample_major_index() {
        let mut gb = GBuffer::new(3, 2, 4).unwrap();
        let n = gb.len();
        gb.coverage = (0..n).map(|i| i % 3 != 0).collect();
        gb.position = Some((0..n).map(|i| Vec3::new(i as f32, 0.0, -1.0)).collect());
        gb.specular = Some((0..n).map(|i| i as f32).collect());
        gb.object_id = Some(vec![7; n]);
        let sm = SampleMajor::new(&gb).unwrap();
        let (p, s) = (gb.pixel_count(), 4);
        for y in 0..2 {
            for x in 0..3 {
                for k in 0..4 {
                    let (from, to) = (gb.index(x, y, k), k as usize * p + (y * 3 + x) as usize);
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
        assert!(SampleMajor::new(&gb).is_err());
    }
}
