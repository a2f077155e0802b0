//! The layout error, in one place: a layout's roundtrip lit exactly as the unquantized G-buffer is ([`lit`]), the
//! two images compared ([`layout_image_error`]). The budget search, the pruned layout's check and `gbuf resolve
//! --layout` measure it here; the sweep times the same steps per row and compares the same images.

use crate::detect::{self, Detector, DetectorConfig};
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::image::HdrImage;
use crate::layout::{Layout, LitFrame};
use crate::light::Light;
use crate::measure::image::{compare, ImageError};
use crate::resolve::{self, ResolveConfig, Resolved};

/// `gb` lit with `lights`: `detector`'s mask, then the resolve. On the unquantized G-buffer this is the *exact*
/// image a layout's roundtrip is compared against (what the layout alone costs, the detector's error left out).
pub fn lit(
    gb: &GBuffer,
    lights: &[Light],
    detector: Detector,
    detector_config: &DetectorConfig,
    rc: &ResolveConfig,
) -> Result<Resolved> {
    let mask = detect::detect(gb, detector, detector_config)?;
    resolve::resolve(gb, lights, &mask, rc)
}

/// The layout error of `layout` on `gb`: its roundtrip [`lit`] the same way as `exact` (the unquantized `gb` lit
/// with the same detector and resolve), compared with it.
pub fn layout_image_error(
    gb: &GBuffer,
    lights: &[Light],
    layout: &Layout,
    exact: &HdrImage,
    detector: Detector,
    detector_config: &DetectorConfig,
    rc: &ResolveConfig,
) -> Result<ImageError> {
    Ok(compare(exact, &lit_layout(gb, lights, layout, detector, detector_config, rc)?.image))
}

/// `gb` through `layout` [`lit`], prepared by the one policy ([`Layout::prepare_lighting`]): the packed targets
/// band by band, the input itself or a decoded copy — the same image either way (tests/resolve_packed.rs), in the
/// least memory.
fn lit_layout(
    gb: &GBuffer,
    lights: &[Light],
    layout: &Layout,
    detector: Detector,
    detector_config: &DetectorConfig,
    rc: &ResolveConfig,
) -> Result<Resolved> {
    let prepared = layout.prepare_lighting(gb, 1, resolve::TIMING_STRIDE)?;
    match prepared.frame(layout, gb)? {
        LitFrame::Packed(frame) => {
            let mask = detect::detect_packed(&frame, detector, detector_config)?;
            resolve::resolve(&frame, lights, &mask, rc)
        }
        LitFrame::Planes(planes) => lit(planes, lights, detector, detector_config, rc),
    }
}
