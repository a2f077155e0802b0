//! The layout error, in one place: a layout's roundtrip lit exactly as the unquantized G-buffer is ([`lit`]), the
//! two images compared ([`layout_image_error`]). The budget search, the pruned layout's check and `gbuf resolve
//! --layout` measure it here; the sweep times the same steps per row and compares the same images.

use crate::detect::{self, Detector, DetectorConfig};
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::image::HdrImage;
use crate::layout::Layout;
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
    let decoded = layout.roundtrip(gb)?;
    Ok(compare(exact, &lit(&decoded, lights, detector, detector_config, rc)?.image))
}
