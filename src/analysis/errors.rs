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

/// Albedos above 1 in the data, and what clamping them costs: every unorm or sRGB albedo codec stores [0, 1], so
/// part of such a layout's error is the data's, not the packing's. Returns the covered samples with a channel
/// above 1, the largest channel, and the image error of `gb` with only those albedos clamped to [0, 1], lit with
/// `detector` and `rc` against `gb` lit the same way (`exact`, when the caller has it already; else lit here);
/// `None` when no covered albedo exceeds 1.
pub fn albedo_clamp_error(
    gb: &GBuffer,
    lights: &[Light],
    exact: Option<&HdrImage>,
    detector: Detector,
    detector_config: &DetectorConfig,
    rc: &ResolveConfig,
) -> Result<Option<(u64, f32, ImageError)>> {
    let Some(albedo) = &gb.albedo else { return Ok(None) };
    let bright = |i: usize| gb.coverage[i] && albedo[i].max_element() > 1.0;
    let count = (0..gb.len()).filter(|&i| bright(i)).count() as u64;
    if count == 0 {
        return Ok(None);
    }
    let max = (0..gb.len()).filter(|&i| bright(i)).map(|i| albedo[i].max_element()).fold(1.0f32, f32::max);
    let mut clamped = gb.clone();
    if let Some(a) = clamped.albedo.as_mut() {
        for v in a.iter_mut() {
            *v = v.clamp(glam::Vec3::ZERO, glam::Vec3::ONE);
        }
    }
    let clamp = lit(&clamped, lights, detector, detector_config, rc)?.image;
    let error = match exact {
        Some(e) => compare(e, &clamp),
        None => compare(&lit(gb, lights, detector, detector_config, rc)?.image, &clamp),
    };
    Ok(Some((count, max, error)))
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
