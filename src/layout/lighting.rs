//! How a frame packed with a layout is made ready for lighting — the one policy the report's sweep, the budget's
//! layout error and `gbuf resolve` follow ([`Layout::prepare_lighting`]): the packed targets themselves when they
//! are smaller than the decoded planes (the edge pass and the resolve decode them band by band, as a GPU reads
//! its G-buffer), the input itself when the roundtrip leaves it unchanged (a lossless layout), else a decoded copy.
//! The image is the same bit for bit whichever is used (tests/resolve_packed.rs); the choice is about memory.

use super::{Layout, Packed, PackedFrame};
use crate::error::Result;
use crate::gbuffer::GBuffer;

/// What a layout's frame is lit from.
#[allow(clippy::large_enum_variant)] // one per layout at a time: its size does not matter
pub enum LightingSource {
    /// The packed targets, decoded band by band where they are read (a layout smaller packed than decoded).
    Packed(Packed),
    /// The input itself: a layout no smaller packed than decoded whose roundtrip leaves the G-buffer bit for bit
    /// as it is (a lossless layout on finite input).
    Input,
    /// A decoded copy ([`Layout::roundtrip_for_lighting`]): a layout no smaller packed than decoded whose
    /// roundtrip changes the G-buffer.
    Copy(GBuffer),
}

/// A frame made ready for lighting through a layout, with what making it cost.
pub struct PreparedLighting {
    /// What is lit.
    pub source: LightingSource,
    /// Encode times, ms, one per timing run.
    pub encode_ms: Vec<f64>,
    /// Decode times, ms (none for packed targets: their bands are decoded, and timed, where they are read).
    pub decode_ms: Vec<f64>,
    /// Time to build the material table, ms, when the layout has one.
    pub table_ms: Option<f64>,
}

/// What the edge pass and the resolve read of a [`PreparedLighting`]: the packed frame, or planes.
pub enum LitFrame<'a> {
    /// The packed targets, band by band.
    Packed(PackedFrame<'a>),
    /// Whole planes (the input or the decoded copy).
    Planes(&'a GBuffer),
}

impl Layout {
    /// Packs `gb` for lighting by the one policy ([`crate::layout::lighting`]): packed targets when the layout
    /// packs smaller than its decoded planes (`runs` timed encodes, the runs after the first timing every
    /// `stride`-th band), else the input when the roundtrip leaves it unchanged, else a decoded copy.
    pub fn prepare_lighting(&self, gb: &GBuffer, runs: usize, stride: u32) -> Result<PreparedLighting> {
        if self.packs_smaller(gb) {
            let (packed, encode_ms, table_ms) = self.pack_timed(gb, runs, stride)?;
            return Ok(PreparedLighting {
                source: LightingSource::Packed(packed),
                encode_ms,
                decode_ms: Vec::new(),
                table_ms,
            });
        }
        let (same, enc, dec) = self.roundtrip_matches(gb)?;
        if same {
            let (mut encode_ms, mut decode_ms) = (vec![enc], vec![dec]);
            for _ in 1..runs.max(1) {
                let (enc, dec) = self.roundtrip_time_sampled(gb, stride)?;
                encode_ms.push(enc);
                decode_ms.push(dec);
            }
            return Ok(PreparedLighting { source: LightingSource::Input, encode_ms, decode_ms, table_ms: None });
        }
        let r = self.roundtrip_for_lighting(gb, runs)?;
        Ok(PreparedLighting {
            source: LightingSource::Copy(r.decoded),
            encode_ms: r.encode_ms,
            decode_ms: r.decode_ms,
            table_ms: r.table_ms,
        })
    }
}

impl PreparedLighting {
    /// What is read when lighting `gb` prepared with `layout`: its packed frame, the input, or the copy.
    pub fn frame<'a>(&'a self, layout: &'a Layout, gb: &'a GBuffer) -> Result<LitFrame<'a>> {
        Ok(match &self.source {
            LightingSource::Packed(p) => LitFrame::Packed(layout.frame(p, gb)?),
            LightingSource::Input => LitFrame::Planes(gb),
            LightingSource::Copy(d) => LitFrame::Planes(d),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smaller_layouts_light_from_their_targets_and_lossless_ones_from_the_input() {
        let gb = crate::scene::render(crate::scene::SceneName::Room, 32, 18, 4).unwrap();
        let small = Layout::by_name("lauritzen-15").unwrap();
        let p = small.prepare_lighting(&gb, 2, 4).unwrap();
        assert!(matches!(p.source, LightingSource::Packed(_)) && p.encode_ms.len() == 2 && p.decode_ms.is_empty());
        assert!(matches!(p.frame(&small, &gb).unwrap(), LitFrame::Packed(_)));
        let lossless = Layout::by_name("reference-f32").unwrap();
        assert!(!lossless.packs_smaller(&gb));
        let p = lossless.prepare_lighting(&gb, 1, 4).unwrap();
        assert!(matches!(p.source, LightingSource::Input), "a lossless roundtrip lights the input itself");
        assert!(matches!(p.frame(&lossless, &gb).unwrap(), LitFrame::Planes(d) if std::ptr::eq(d, &gb)));
    }
}
