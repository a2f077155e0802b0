//! An image file as an image to compare: an OpenEXR file's linear RGB, or a PNG's display values.
//!
//! What the values are is part of the result: an EXR holds linear radiance (HDR), a PNG holds display-encoded
//! values in [0, 1] (sRGB, 8 or 16 bits). `gbuf compare` measures each kind as NVIDIA's FLIP tool does (HDR-FLIP
//! of the linear values, LDR-FLIP of the sRGB-encoded ones) and refuses to mix them.

use super::HdrImage;
use crate::error::{Error, Result};
use crate::io::exr::ReadLimits;
use glam::Vec3;
use std::path::Path;

/// What the values of an image file are.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ImageKind {
    /// Linear radiance (OpenEXR).
    Hdr,
    /// Display values in [0, 1], sRGB-encoded (PNG, 8 or 16 bits per channel).
    Ldr,
}

/// An image file read for comparison.
#[derive(Clone, Debug)]
pub struct ImageFile {
    /// The values: linear RGB (HDR) or display values in [0, 1] (LDR), row 0 at the top.
    pub image: HdrImage,
    /// What the values are.
    pub kind: ImageKind,
    /// How the file stores them, for the report (`EXR R,G,B half`, `PNG 8-bit RGB`, …).
    pub storage: String,
    /// Samples that were NaN or infinite (read as 0: FLIP and the errors need finite values).
    pub non_finite: u64,
}

/// Reads `path`: a `.png` (8 or 16 bits, grey, grey + alpha, RGB or RGBA; alpha ignored) or an OpenEXR file
/// (channels `R`, `G`, `B`, or `Y` for grey; also the first layer with `.R`/`.G`/`.B`).
pub fn read(path: &Path, limits: &ReadLimits) -> Result<ImageFile> {
    crate::base::files::protect_input(path);
    let png = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if png {
        return read_png(path, limits);
    }
    let raw = crate::io::exr::read_raw(path, limits)?;
    let find = |suffix: &str| {
        raw.channel(suffix).or_else(|| raw.channels.iter().find(|c| c.name.ends_with(&format!(".{suffix}"))))
    };
    let (channels, names) = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => ([r, g, b], format!("{},{},{}", r.name, g.name, b.name)),
        (_, _, _, Some(y)) => ([y, y, y], y.name.clone()),
        _ => {
            return Err(Error::invalid(
                path,
                format!("no R, G, B (or Y) channels to compare; channels found: {}", raw.channel_list()),
            ))
        }
    };
    let n = raw.width as usize * raw.height as usize;
    let mut non_finite = 0u64;
    let mut rgb = vec![Vec3::ZERO; n];
    for (i, px) in rgb.iter_mut().enumerate() {
        for (k, c) in channels.iter().enumerate() {
            let v = c.data.f32_at(i);
            if v.is_finite() {
                px[k] = v;
            } else {
                non_finite += 1;
            }
        }
    }
    Ok(ImageFile {
        image: HdrImage { width: raw.width, height: raw.height, rgb },
        kind: ImageKind::Hdr,
        storage: format!("EXR {names} {}", channels[0].data.type_name()),
        non_finite,
    })
}

fn read_png(path: &Path, limits: &ReadLimits) -> Result<ImageFile> {
    let reader = image::ImageReader::open(path).map_err(|e| Error::io(path, e))?;
    let mut reader = reader.with_guessed_format().map_err(|e| Error::io(path, e))?;
    let mut l = image::Limits::default();
    l.max_alloc = Some(limits.max_bytes);
    reader.limits(l);
    let img = reader.decode().map_err(|e| Error::invalid(path, format!("PNG: {e}")))?;
    let sixteen = matches!(
        img.color(),
        image::ColorType::L16 | image::ColorType::La16 | image::ColorType::Rgb16 | image::ColorType::Rgba16
    );
    let (w, h) = (img.width(), img.height());
    let rgb: Vec<Vec3> = if sixteen {
        img.to_rgb16().pixels().map(|p| Vec3::new(p[0].into(), p[1].into(), p[2].into()) / 65535.0).collect()
    } else {
        img.to_rgb8().pixels().map(|p| Vec3::new(p[0].into(), p[1].into(), p[2].into()) / 255.0).collect()
    };
    Ok(ImageFile {
        image: HdrImage { width: w, height: h, rgb },
        kind: ImageKind::Ldr,
        storage: format!("PNG {}-bit {:?}", if sixteen { 16 } else { 8 }, img.color()),
        non_finite: 0,
    })
}
