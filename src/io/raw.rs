//! The decoded channels of an image file, whatever read them: what the EXR reader returns and its writers take,
//! and what the naming-based readers map to G-buffer attributes. Plain data, below both `io::exr` (reading) and
//! `io::exr_write` (writing).

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
    /// Every sample as f32 (u32 converted by value), in parallel blocks; half through the slice conversion (F16C or
    /// NEON where the CPU has it) rather than one sample at a time.
    #[must_use]
    pub fn to_f32_vec(&self) -> Vec<f32> {
        use half::slice::HalfFloatSliceExt;
        use rayon::prelude::*;
        const BLOCK: usize = 1 << 16;
        match self {
            RawData::F32(v) => v.clone(),
            RawData::F16(v) => {
                let mut out = vec![0.0f32; v.len()];
                out.par_chunks_mut(BLOCK).zip(v.par_chunks(BLOCK)).for_each(|(o, h)| h.convert_to_f32_slice(o));
                out
            }
            RawData::U32(v) => v.par_iter().map(|&u| u as f32).collect(),
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
