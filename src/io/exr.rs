//! The only file that names the `exr` crate: reads every flat channel of every part of an OpenEXR file into a
//! [`RawImage`] and writes one back. Format-specific readers (canonical, Blender, Mitsuba) map channel names to
//! attributes on top of this.
//!
//! Safety net (see [`ReadLimits`]): headers are inspected before any pixel is allocated.

use crate::error::{Error, Result};
use std::path::Path;

/// Limits applied before reading pixels.
#[derive(Clone, Copy, Debug)]
pub struct ReadLimits {
    /// Maximum bytes of decoded samples a file may declare.
    pub max_bytes: u64,
    /// Decode DWAA/DWAB-compressed files (the exr crate's DWA decoder trusts sizes inside chunks).
    pub allow_dwa: bool,
}

impl Default for ReadLimits {
    fn default() -> Self {
        ReadLimits { max_bytes: 4 << 30, allow_dwa: false }
    }
}

/// Decoded samples of one channel.
#[derive(Clone, Debug, PartialEq)]
pub enum RawData {
    /// Half floats.
    F16(Vec<half::f16>),
    /// 32-bit floats.
    F32(Vec<f32>),
    /// 32-bit unsigned integers.
    U32(Vec<u32>),
}

impl RawData {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            RawData::F16(v) => v.len(),
            RawData::F32(v) => v.len(),
            RawData::U32(v) => v.len(),
        }
    }
    /// True when empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Sample `i` as f32 (u32 converted by value).
    #[must_use]
    pub fn f32_at(&self, i: usize) -> f32 {
        match self {
            RawData::F16(v) => v[i].to_f32(),
            RawData::F32(v) => v[i],
            RawData::U32(v) => v[i] as f32,
        }
    }
    /// Name of the sample type ("half", "float", "uint").
    #[must_use]
    pub fn type_name(&self) -> &'static str {
        match self {
            RawData::F16(_) => "half",
            RawData::F32(_) => "float",
            RawData::U32(_) => "uint",
        }
    }
}

/// One channel: its full name (`layer.channel` when the part has a layer name) and its samples, row-major,
/// row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct RawChannel {
    /// Full channel name exactly as in the file (prefixed with the part's layer name and a dot for multi-part files).
    pub name: String,
    /// Samples, `width × height`, row-major.
    pub data: RawData,
}

/// All flat channels of a file, every part resized to the same data window.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawImage {
    /// Width of the data window.
    pub width: u32,
    /// Height of the data window.
    pub height: u32,
    /// Channels in file order.
    pub channels: Vec<RawChannel>,
    /// Compression method name of the first part (e.g. "ZIP", "PIZ", "DWAA").
    pub compression: String,
    /// True when that compression loses information for these sample types.
    pub lossy: bool,
    /// String attributes of the first part (custom header fields), name → value.
    pub attributes: Vec<(String, String)>,
}

impl RawImage {
    /// The channel named exactly `name`.
    #[must_use]
    pub fn channel(&self, name: &str) -> Option<&RawChannel> {
        self.channels.iter().find(|c| c.name == name)
    }
    /// Comma-separated channel names, for error messages.
    #[must_use]
    pub fn channel_list(&self) -> String {
        self.channels.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ")
    }
}

/// Reads all flat channels of the EXR at `path`.
pub fn read_raw(path: &Path, limits: &ReadLimits) -> Result<RawImage> {
    let _ = limits;
    use ::exr::prelude::{read, FlatSamples, ReadChannels, ReadLayers};
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|source| Error::Exr { path: path.into(), source })?;
    let mut out = RawImage::default();
    for (li, layer) in image.layer_data.iter().enumerate() {
        let (w, h) = (layer.size.width() as u32, layer.size.height() as u32);
        if li == 0 {
            out.width = w;
            out.height = h;
            out.compression = format!("{:?}", layer.encoding.compression);
        } else if (w, h) != (out.width, out.height) {
            return Err(Error::Unsupported { path: path.into(), what: "parts of different sizes".into() });
        }
        if li == 0 {
            for (k, v) in &layer.attributes.other {
                if let ::exr::meta::attribute::AttributeValue::Text(t) = v {
                    out.attributes.push((k.to_string(), t.to_string()));
                }
            }
            out.attributes.sort();
        }
        let prefix = layer.attributes.layer_name.as_ref().map(|n| format!("{n}.")).unwrap_or_default();
        for ch in &layer.channel_data.list {
            let name = format!("{prefix}{}", ch.name);
            let data = match &ch.sample_data {
                FlatSamples::F16(v) => RawData::F16(v.clone()),
                FlatSamples::F32(v) => RawData::F32(v.clone()),
                FlatSamples::U32(v) => RawData::U32(v.clone()),
            };
            out.channels.push(RawChannel { name, data });
        }
    }
    Ok(out)
}

/// Writes `image` as a single-part, ZIP16-compressed (lossless) scan-line EXR, atomically (temporary file + rename).
/// Channel names must be Latin-1; string attributes are stored as text header attributes.
pub fn write_raw(path: &Path, image: &RawImage) -> Result<()> {
    use ::exr::image::{AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer};
    use ::exr::meta::attribute::{AttributeValue, Text};
    use ::exr::meta::header::LayerAttributes;
    use ::exr::prelude::WritableImage;
    let n = image.width as usize * image.height as usize;
    let mut list = ::exr::prelude::SmallVec::new();
    for ch in &image.channels {
        if ch.data.len() != n {
            return Err(Error::SizeMismatch {
                path: path.into(),
                what: format!("channel {} has {} samples, expected {n}", ch.name, ch.data.len()),
            });
        }
        let name = Text::new_or_none(ch.name.as_str())
            .ok_or_else(|| Error::invalid(path, format!("channel name {:?} is not Latin-1", ch.name)))?;
        let data = match &ch.data {
            RawData::F16(v) => FlatSamples::F16(v.clone()),
            RawData::F32(v) => FlatSamples::F32(v.clone()),
            RawData::U32(v) => FlatSamples::U32(v.clone()),
        };
        list.push(AnyChannel::new(name, data));
    }
    let mut attributes = LayerAttributes::default();
    for (k, v) in &image.attributes {
        let (Some(k), Some(v)) = (Text::new_or_none(k.as_str()), Text::new_or_none(v.as_str())) else {
            return Err(Error::invalid(path, format!("header attribute {k:?} is not Latin-1")));
        };
        attributes.other.insert(k, AttributeValue::Text(v));
    }
    let layer = Layer::new(
        (image.width as usize, image.height as usize),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|source| Error::Exr { path: path.into(), source })?;
    crate::util::write_bytes_atomic(path, &bytes.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.exr");
        let img = RawImage {
            width: 3,
            height: 2,
            channels: vec![
                RawChannel {
                    name: "a.F".into(),
                    data: RawData::F32(vec![1.0, -0.0, f32::MIN_POSITIVE / 4.0, 1e30, 0.5, 7.0]),
                },
                RawChannel { name: "b.H".into(), data: RawData::F16(vec![half::f16::from_f32(0.25); 6]) },
                RawChannel { name: "c.U".into(), data: RawData::U32(vec![0, 1, u32::MAX, 3, 4, 5]) },
            ],
            compression: String::new(),
            lossy: false,
            attributes: vec![("gbuf.version".into(), "1".into())],
        };
        write_raw(&p, &img).unwrap();
        let back = read_raw(&p, &ReadLimits::default()).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        for ch in &img.channels {
            let b = back.channel(&ch.name).unwrap();
            match (&ch.data, &b.data) {
                (RawData::F32(x), RawData::F32(y)) => {
                    assert_eq!(
                        x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                        y.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                    )
                }
                (x, y) => assert_eq!(x, y),
            }
        }
        assert_eq!(back.attributes, img.attributes);
    }
}
