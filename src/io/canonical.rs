//! Our canonical G-buffer EXR (docs/FORMAT.md): lossless, every attribute, any sample count.
//!
//! [`GBuffer`] → [`RawImage`] → single-part ZIP EXR, and back, bit-exact. One EXR layer per sample and attribute:
//! channel `s<i>.<attribute>.<component>` holds sample `i` of every pixel, so sample 0 of a canonical file is an
//! ordinary image any EXR viewer shows. Floats are stored as 32-bit floats, IDs and the coverage mask as 32-bit
//! unsigned integers. The header carries the format name and version, the sample count, the sample positions and
//! (when known) the camera as JSON text attributes.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::gbuffer::{
    checked_len, ordered_grid_positions, standard_sample_positions, Attribute, GBuffer, MaterialParams, MAX_SAMPLES,
};
use crate::io::exr::{RawChannel, RawData, RawImage};
use crate::io::sidecar::SidecarCamera;
use crate::io::LoadOptions;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::path::Path;

/// Value of the `gbuf.format` header attribute.
pub const FORMAT_NAME: &str = "gbuf-canonical";
/// The format version this build writes (and the highest it reads).
pub const VERSION: u32 = 1;
/// Header attribute: format name ([`FORMAT_NAME`]).
pub const ATTR_FORMAT: &str = "gbuf.format";
/// Header attribute: format version (decimal integer).
pub const ATTR_VERSION: &str = "gbuf.version";
/// Header attribute: samples per pixel (decimal integer, 1..=64).
pub const ATTR_SAMPLES: &str = "gbuf.samples";
/// Header attribute: sample positions, JSON `[[x, y], …]` in pixels from the pixel centre, +y down.
pub const ATTR_SAMPLE_POSITIONS: &str = "gbuf.sample_positions";
/// Header attribute: the camera, JSON in the sidecar's camera form (row-major `world_to_view`, `yfov`, `aspect`,
/// `znear`, `zfar`).
pub const ATTR_CAMERA: &str = "gbuf.camera";
/// Header attribute: the engine's material catalogue, JSON in the sidecar's `materials` form (written when known).
pub const ATTR_MATERIALS: &str = "gbuf.materials";
/// Layer name of the coverage mask (component `V`, uint: 1 = surface, 0 = background).
pub const COVERAGE: &str = "coverage";

/// Component (channel suffix) names of `attr` in the canonical file.
#[must_use]
pub fn components(attr: Attribute) -> &'static [&'static str] {
    match attr {
        Attribute::Depth => &["Z"],
        Attribute::Position | Attribute::Normal => &["X", "Y", "Z"],
        Attribute::Albedo => &["R", "G", "B"],
        Attribute::Motion => &["X", "Y"],
        Attribute::MaterialId | Attribute::ObjectId | Attribute::PrimitiveId => &["ID"],
        Attribute::Specular | Attribute::SpecularPower | Attribute::Roughness | Attribute::Metallic => &["V"],
    }
}

/// The canonical channel name of component `comp` of layer `layer` (an attribute name or [`COVERAGE`]) at
/// sample `sample`.
#[must_use]
fn channel_name(sample: u32, layer: &str, comp: &str) -> String {
    format!("s{sample}.{layer}.{comp}")
}

/// Is `raw` a canonical file? (It has the `gbuf.format` header attribute or the `s0.coverage.V` channel.)
#[must_use]
pub fn matches(raw: &RawImage) -> bool {
    header(raw, ATTR_FORMAT) == Some(FORMAT_NAME) || raw.channel(&channel_name(0, COVERAGE, "V")).is_some()
}

/// A text header attribute of `raw`, if present.
pub fn header<'a>(raw: &'a RawImage, key: &str) -> Option<&'a str> {
    raw.attributes.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

/// Converts a G-buffer into canonical channels and header attributes (no file involved).
#[must_use]
pub fn to_raw(gb: &GBuffer) -> RawImage {
    let n = gb.pixel_count();
    let spp = gb.samples as usize;
    // Every channel: coverage per sample, then per attribute, sample and component (`None`: coverage). They are
    // de-interleaved from the pixel-major planes in parallel, in this order.
    /// A channel to make: `None` (coverage) or (attribute, component), the sample, the name.
    type Job = (Option<(Attribute, usize)>, usize, String);
    let mut jobs: Vec<Job> = (0..spp).map(|s| (None, s, channel_name(s as u32, COVERAGE, "V"))).collect();
    for attr in gb.attributes() {
        for s in 0..spp {
            for (ci, comp) in components(attr).iter().enumerate() {
                jobs.push((Some((attr, ci)), s, channel_name(s as u32, attr.name(), comp)));
            }
        }
    }
    let channels: Vec<RawChannel> = jobs
        .into_par_iter()
        .map(|(what, s, name)| {
            let data = match what {
                None => RawData::U32((0..n).map(|p| u32::from(gb.coverage[p * spp + s])).collect()),
                Some((attr, ci)) => plane_channel(gb, attr, ci, s, n, spp),
            };
            RawChannel { name, data }
        })
        .collect();
    let positions: Vec<[f32; 2]> = gb.sample_positions.iter().map(|p| [p.x, p.y]).collect();
    let mut attributes = vec![
        (ATTR_FORMAT.to_string(), FORMAT_NAME.to_string()),
        (ATTR_VERSION.to_string(), VERSION.to_string()),
        (ATTR_SAMPLES.to_string(), gb.samples.to_string()),
        (ATTR_SAMPLE_POSITIONS.to_string(), serde_json::to_string(&positions).expect("plain floats")),
    ];
    if let Some(cam) = &gb.camera {
        let json = serde_json::to_string(&SidecarCamera::from_camera(cam)).expect("plain floats");
        attributes.push((ATTR_CAMERA.to_string(), json));
    }
    if !gb.materials.is_empty() {
        let json = serde_json::to_string(&gb.materials).expect("plain values");
        attributes.push((ATTR_MATERIALS.to_string(), json));
    }
    attributes.sort();
    RawImage { width: gb.width, height: gb.height, channels, compression: "ZIP16".into(), lossy: false, attributes }
}

/// Component `ci` of sample `s` of every pixel of `attr`'s plane.
fn plane_channel(gb: &GBuffer, attr: Attribute, ci: usize, s: usize, n: usize, spp: usize) -> RawData {
    use crate::gbuffer::PlaneRef;
    let idx = |p: usize| p * spp + s;
    match gb.plane(attr).expect("attribute present") {
        PlaneRef::F32(v) => RawData::F32((0..n).map(|p| v[idx(p)]).collect()),
        PlaneRef::Vec2(v) => RawData::F32((0..n).map(|p| v[idx(p)][ci]).collect()),
        PlaneRef::Vec3(v) => RawData::F32((0..n).map(|p| v[idx(p)][ci]).collect()),
        PlaneRef::U32(v) => RawData::U32((0..n).map(|p| v[idx(p)]).collect()),
    }
}

/// Builds a G-buffer from a canonical file's channels and header (`path` names the file in errors).
pub fn from_raw(raw: &RawImage, path: &Path) -> Result<GBuffer> {
    build(Source::Keep(raw), path)
}

/// [`from_raw`], releasing each attribute's samples once they are in the G-buffer (the channels stay, empty, with
/// their names and types, for [`sources`]): loading then holds the file's samples and the G-buffer together one
/// attribute at a time instead of whole, so its peak stays near the G-buffer's own size.
pub fn from_raw_releasing(raw: &mut RawImage, path: &Path) -> Result<GBuffer> {
    build(Source::Release(raw), path)
}

/// The channels a G-buffer is built from: borrowed, or owned and emptied attribute by attribute.
enum Source<'a> {
    Keep(&'a RawImage),
    Release(&'a mut RawImage),
}

impl Source<'_> {
    fn raw(&self) -> &RawImage {
        match self {
            Source::Keep(r) => r,
            Source::Release(r) => r,
        }
    }
    /// Empties (and frees) every channel of `layer`, whatever its sample.
    fn release(&mut self, layer: &str) {
        if let Source::Release(r) = self {
            for ch in r.channels.iter_mut().filter(|c| c.name.split('.').nth(1) == Some(layer)) {
                ch.data = match ch.data {
                    RawData::F16(_) => RawData::F16(Vec::new()),
                    RawData::F32(_) => RawData::F32(Vec::new()),
                    RawData::U32(_) => RawData::U32(Vec::new()),
                };
            }
        }
    }
}

fn build(mut src: Source<'_>, path: &Path) -> Result<GBuffer> {
    let raw = src.raw();
    let version: u32 = header(raw, ATTR_VERSION)
        .ok_or_else(|| Error::invalid(path, format!("canonical file without the {ATTR_VERSION} header attribute")))?
        .trim()
        .parse()
        .map_err(|_| Error::invalid(path, format!("{ATTR_VERSION} is not an integer")))?;
    if version == 0 || version > VERSION {
        return Err(Error::Unsupported {
            path: path.into(),
            what: format!("canonical format version {version} (this build reads 1..={VERSION})"),
        });
    }
    let samples: u32 = header(raw, ATTR_SAMPLES)
        .ok_or_else(|| Error::invalid(path, format!("canonical file without the {ATTR_SAMPLES} header attribute")))?
        .trim()
        .parse()
        .map_err(|_| Error::invalid(path, format!("{ATTR_SAMPLES} is not an integer")))?;
    if samples == 0 || samples > MAX_SAMPLES {
        return Err(Error::invalid(path, format!("{ATTR_SAMPLES} = {samples}, outside 1..={MAX_SAMPLES}")));
    }
    let sample_positions = read_positions(raw, path, samples)?;
    let camera = match header(raw, ATTR_CAMERA) {
        None => None,
        Some(text) => {
            let c: SidecarCamera = serde_json::from_str(text)
                .map_err(|e| Error::invalid(path, format!("{ATTR_CAMERA} header attribute: {e}")))?;
            let cam: Camera = c.to_camera();
            if !cam.is_valid() {
                return Err(Error::invalid(path, format!("{ATTR_CAMERA} header attribute: camera is not usable")));
            }
            Some(cam)
        }
    };
    let materials: Vec<MaterialParams> = match header(raw, ATTR_MATERIALS) {
        None => Vec::new(),
        Some(text) => {
            let m: Vec<MaterialParams> = serde_json::from_str(text)
                .map_err(|e| Error::invalid(path, format!("{ATTR_MATERIALS} header attribute: {e}")))?;
            MaterialParams::validate_all(&m)
                .map_err(|e| Error::invalid(path, format!("{ATTR_MATERIALS} header attribute: {e}")))?;
            m
        }
    };
    let len = checked_len(raw.width, raw.height, samples).map_err(|e| Error::invalid(path, e.to_string()))?;
    let spp = samples as usize;
    let n = raw.width as usize * raw.height as usize;
    let mut gb = GBuffer {
        width: raw.width,
        height: raw.height,
        samples,
        sample_positions,
        camera,
        coverage: vec![false; len],
        materials,
        ..Default::default()
    };
    let reader = Reader { raw, path, samples, n };
    let coverage: Vec<[&RawChannel; 1]> =
        (0..spp).map(|s| reader.channel(s as u32, COVERAGE, "V").map(|c| [c])).collect::<Result<_>>()?;
    interleave(&mut gb.coverage, &coverage, |[v]| v != 0.0);
    src.release(COVERAGE);
    for attr in Attribute::ALL {
        let raw = src.raw();
        let reader = Reader { raw, path, samples, n };
        let comps = components(attr);
        let present = comps.iter().any(|c| raw.channel(&channel_name(0, attr.name(), c)).is_some());
        if !present {
            continue;
        }
        if attr.is_id() {
            let mut v = vec![0u32; len];
            for s in 0..spp {
                let ch = reader.channel(s as u32, attr.name(), comps[0])?;
                let RawData::U32(d) = &ch.data else {
                    return Err(Error::UnsupportedSampleType {
                        path: path.into(),
                        channel: ch.name.clone(),
                        found: format!("{} (IDs must be uint)", ch.data.type_name()),
                    });
                };
                for p in 0..n {
                    v[p * spp + s] = d[p];
                }
            }
            set_u32(&mut gb, attr, v);
            src.release(attr.name());
            continue;
        }
        // Float attributes: each component of each sample straight into its place in the plane.
        let channels: Vec<Vec<&RawChannel>> = (0..spp)
            .map(|s| comps.iter().map(|comp| reader.float_channel(s as u32, attr.name(), comp)).collect())
            .collect::<Result<_>>()?;
        match comps.len() {
            1 => {
                let one: Vec<[&RawChannel; 1]> = channels.iter().map(|c| [c[0]]).collect();
                let mut v = vec![0.0f32; len];
                interleave(&mut v, &one, |[x]| x);
                set_f32(&mut gb, attr, v);
            }
            2 => {
                let two: Vec<[&RawChannel; 2]> = channels.iter().map(|c| [c[0], c[1]]).collect();
                let mut v = vec![Vec2::ZERO; len];
                interleave(&mut v, &two, Vec2::from_array);
                gb.motion = Some(v);
            }
            _ => {
                let three: Vec<[&RawChannel; 3]> = channels.iter().map(|c| [c[0], c[1], c[2]]).collect();
                let mut v = vec![Vec3::ZERO; len];
                interleave(&mut v, &three, Vec3::from_array);
                match attr {
                    Attribute::Position => gb.position = Some(v),
                    Attribute::Normal => gb.normal = Some(v),
                    _ => gb.albedo = Some(v),
                }
            }
        }
        drop(channels);
        src.release(attr.name());
    }
    gb.validate().map_err(|e| Error::invalid(path, e.to_string()))?;
    Ok(gb)
}

/// Fills the pixel-major plane `out` (`n × spp` values, a pixel's samples side by side) from the per-sample
/// channels `channels[s]` (`C` components each, `n` values, float, half or uint): `out[p·spp + s] =
/// make(channels[s][..][p])`. In parallel over blocks of pixels; each channel's block converted to f32 at once
/// (half with the F16C / NEON conversion where the CPU has it).
fn interleave<T: Send, const C: usize>(
    out: &mut [T],
    channels: &[[&RawChannel; C]],
    make: impl Fn([f32; C]) -> T + Sync,
) {
    use half::slice::HalfFloatSliceExt;
    const BLOCK: usize = 4096;
    let spp = channels.len();
    if spp == 0 || out.is_empty() {
        return;
    }
    out.par_chunks_mut(BLOCK * spp).enumerate().for_each(|(b, o)| {
        let (p0, np) = (b * BLOCK, o.len() / spp);
        let mut tmp = vec![[0.0f32; BLOCK]; C];
        for (s, chs) in channels.iter().enumerate() {
            for (t, ch) in tmp.iter_mut().zip(chs) {
                let t = &mut t[..np];
                match &ch.data {
                    RawData::F32(v) => t.copy_from_slice(&v[p0..p0 + np]),
                    RawData::F16(v) => v[p0..p0 + np].convert_to_f32_slice(t),
                    RawData::U32(v) => t.iter_mut().zip(&v[p0..p0 + np]).for_each(|(t, &u)| *t = u as f32),
                }
            }
            for (i, o) in o.iter_mut().skip(s).step_by(spp).enumerate() {
                *o = make(std::array::from_fn(|c| tmp[c][i]));
            }
        }
    });
}

struct Reader<'a> {
    raw: &'a RawImage,
    path: &'a Path,
    samples: u32,
    n: usize,
}

impl Reader<'_> {
    fn channel(&self, s: u32, layer: &str, comp: &str) -> Result<&RawChannel> {
        let name = channel_name(s, layer, comp);
        let ch = self.raw.channel(&name).ok_or_else(|| Error::MissingChannel {
            path: self.path.into(),
            name: format!("{name} (canonical file with {} samples per pixel)", self.samples),
            found: self.raw.channel_list(),
        })?;
        if ch.data.len() != self.n {
            return Err(Error::SizeMismatch {
                path: self.path.into(),
                what: format!("channel {name} has {} samples, expected {}", ch.data.len(), self.n),
            });
        }
        Ok(ch)
    }
    fn float_channel(&self, s: u32, layer: &str, comp: &str) -> Result<&RawChannel> {
        let ch = self.channel(s, layer, comp)?;
        if let RawData::U32(_) = ch.data {
            return Err(Error::UnsupportedSampleType {
                path: self.path.into(),
                channel: ch.name.clone(),
                found: "uint (expected float or half)".into(),
            });
        }
        Ok(ch)
    }
}

fn read_positions(raw: &RawImage, path: &Path, samples: u32) -> Result<Vec<Vec2>> {
    let Some(text) = header(raw, ATTR_SAMPLE_POSITIONS) else {
        // Without positions: the standard pattern, or an ordered grid for square counts.
        if let Some(p) = standard_sample_positions(samples) {
            return Ok(p);
        }
        let k = (samples as f64).sqrt().round() as u32;
        if k * k == samples {
            return Ok(ordered_grid_positions(k));
        }
        return Err(Error::invalid(
            path,
            format!("{samples} samples per pixel need the {ATTR_SAMPLE_POSITIONS} header attribute"),
        ));
    };
    let pos: Vec<[f32; 2]> = serde_json::from_str(text)
        .map_err(|e| Error::invalid(path, format!("{ATTR_SAMPLE_POSITIONS} header attribute: {e}")))?;
    if pos.len() != samples as usize {
        return Err(Error::invalid(
            path,
            format!("{ATTR_SAMPLE_POSITIONS} lists {} positions for {samples} samples", pos.len()),
        ));
    }
    let pos: Vec<Vec2> = pos.into_iter().map(Vec2::from).collect();
    crate::gbuffer::check_sample_positions(&pos)
        .map_err(|e| Error::invalid(path, format!("{ATTR_SAMPLE_POSITIONS} header attribute: {e}")))?;
    Ok(pos)
}

fn set_f32(gb: &mut GBuffer, attr: Attribute, v: Vec<f32>) {
    match attr {
        Attribute::Depth => gb.depth = Some(v),
        Attribute::Specular => gb.specular = Some(v),
        Attribute::SpecularPower => gb.specular_power = Some(v),
        Attribute::Roughness => gb.roughness = Some(v),
        Attribute::Metallic => gb.metallic = Some(v),
        _ => unreachable!("scalar float attributes only"),
    }
}

fn set_u32(gb: &mut GBuffer, attr: Attribute, v: Vec<u32>) {
    match attr {
        Attribute::MaterialId => gb.material_id = Some(v),
        Attribute::ObjectId => gb.object_id = Some(v),
        Attribute::PrimitiveId => gb.primitive_id = Some(v),
        _ => unreachable!("ID attributes only"),
    }
}

/// Writes `gb` as a canonical EXR at `path` with ZIP compression, atomically (temporary file + rename).
pub fn write(path: &Path, gb: &GBuffer) -> Result<()> {
    write_with(path, gb, crate::io::exr::WriteCompression::Zip)
}

/// [`write()`] with the compression given (all lossless).
pub fn write_with(path: &Path, gb: &GBuffer, compression: crate::io::exr::WriteCompression) -> Result<()> {
    gb.validate()?;
    crate::io::exr::write_raw_owned(path, to_raw(gb), compression)
}

/// Reads a canonical EXR (only the G-buffer; use [`crate::io::load`] for sidecars, folding and sanitizing).
pub fn read(path: &Path, opts: &LoadOptions) -> Result<GBuffer> {
    let raw = crate::io::exr::read_raw(path, &opts.limits)?;
    if !matches(&raw) {
        return Err(Error::MissingChannel {
            path: path.into(),
            name: format!("{} (not a gbuf canonical file)", channel_name(0, COVERAGE, "V")),
            found: raw.channel_list(),
        });
    }
    from_raw(&raw, path)
}

/// Where each attribute of a canonical G-buffer came from: its sample-0 channel names with `s*` standing for
/// every sample when there are several.
#[must_use]
pub fn sources(raw: &RawImage, gb: &GBuffer) -> Vec<crate::io::AttributeSource> {
    gb.attributes()
        .into_iter()
        .map(|attr| {
            let names: Vec<String> =
                components(attr)
                    .iter()
                    .map(|c| {
                        if gb.samples == 1 {
                            channel_name(0, attr.name(), c)
                        } else {
                            format!("s*.{}.{c}", attr.name())
                        }
                    })
                    .collect();
            let file_type = raw
                .channel(&channel_name(0, attr.name(), components(attr)[0]))
                .map_or("unknown", |c| c.data.type_name())
                .to_string();
            crate::io::AttributeSource { attribute: attr.name(), channels: names, file_type, note: None }
        })
        .collect()
}
