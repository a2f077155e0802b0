//! Render-target formats with their real bit layouts.
//!
//! A render target's texel is a little-endian word of [`Format::bits`] bits: byte 0 holds bits 0–7, byte 1 bits
//! 8–15, and so on, which is how D3D and Vulkan lay out packed formats (`RGB10A2`'s red is bits 0–9, `RGBA8`'s red
//! is byte 0, `D24S8`'s depth is bits 0–23 and stencil bits 24–31). Fields of a layout are bit ranges of that word;
//! [`Format::components`] says what the hardware would see in each range (unorm, float, …), which is what
//! `gbuf layouts` shows and what a field's codec should match for the GPU to filter or blend it meaningfully.

use serde::Serialize;

/// How the hardware interprets one component of a texel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ComponentKind {
    /// Unsigned normalized integer: `code / (2^bits − 1)`.
    Unorm,
    /// Signed normalized integer (two's complement).
    Snorm,
    /// Unorm with the sRGB transfer curve applied on read.
    Srgb,
    /// IEEE-style float (32, 16, or the unsigned 11/10-bit small floats).
    Float,
    /// Unsigned integer, read as is.
    Uint,
    /// Stencil bits (unsigned integer).
    Stencil,
    /// One part of a shared-exponent float (`rgb9e5`: three 9-bit mantissas without an implicit leading one and
    /// their common 5-bit exponent, bias 15): the parts decode only together.
    SharedExponent,
}

/// One component of a texel: a named bit range and its interpretation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Component {
    /// Channel name (`r`, `g`, `b`, `a`, `depth`, `stencil`).
    pub name: &'static str,
    /// First bit within the texel word.
    pub offset: u32,
    /// Width in bits.
    pub bits: u32,
    /// Interpretation.
    pub kind: ComponentKind,
}

/// A component literal (a struct literal, so `&[...]` of them is promoted to `'static`).
macro_rules! c {
    ($name:literal, $offset:literal, $bits:literal, $kind:ident) => {
        Component { name: $name, offset: $offset, bits: $bits, kind: $kind }
    };
}

use ComponentKind::{Float, SharedExponent, Snorm, Srgb, Stencil, Uint, Unorm};

/// A render-target (or depth-stencil) format. `ALL` lists every format; [`Format::name`] is the one spelling used
/// in layout files and output (parsing also accepts upper case and `_`, e.g. `RGBA8_SRGB`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// 8-bit unorm red.
    R8,
    /// 2 × 8-bit unorm.
    Rg8,
    /// 3 × 8-bit unorm, 3 bytes per texel: not a GPU render-target format, but the memory layout of CPU
    /// G-buffers such as Intel's ISPC `deferred` example.
    Rgb8,
    /// 4 × 8-bit unorm.
    Rgba8,
    /// 4 × 8-bit, RGB sRGB-encoded, alpha unorm.
    Rgba8Srgb,
    /// 4 × 8-bit snorm.
    Rgba8Snorm,
    /// 3 × 10-bit unorm + 2-bit unorm alpha.
    Rgb10A2,
    /// Unsigned floats: 11-bit red and green, 10-bit blue (no sign bit).
    R11G11B10F,
    /// Three 9-bit mantissas sharing a 5-bit exponent (D3D `R9G9B9E5_SHAREDEXP`, Vulkan
    /// `E5B9G9R9_UFLOAT_PACK32`): unsigned HDR colour up to 65408, 32 bits. Sampled and filtered by every GPU;
    /// as a render target only on some (Vulkan lists it as an optional colour-attachment format), which is why
    /// engines write it from compute or keep it for emissive/lighting buffers they fill themselves.
    Rgb9e5,
    /// 16-bit float red.
    R16F,
    /// 2 × 16-bit float.
    Rg16F,
    /// 4 × 16-bit float.
    Rgba16F,
    /// 16-bit unorm red.
    R16Unorm,
    /// 2 × 16-bit unorm.
    Rg16Unorm,
    /// 2 × 16-bit snorm.
    Rg16Snorm,
    /// 4 × 16-bit unorm.
    Rgba16Unorm,
    /// 16-bit unsigned integer red.
    R16Ui,
    /// 32-bit float red.
    R32F,
    /// 2 × 32-bit float.
    Rg32F,
    /// 4 × 32-bit float.
    Rgba32F,
    /// 32-bit unsigned integer red.
    R32Ui,
    /// 2 × 32-bit unsigned integer.
    Rg32Ui,
    /// 4 × 32-bit unsigned integer.
    Rgba32Ui,
    /// 16-bit unorm depth.
    D16,
    /// 24-bit unorm depth (bits 0–23) + 8-bit stencil (bits 24–31).
    D24S8,
    /// 32-bit float depth.
    D32F,
}

crate::named!(Format: "format" {
    R8 => "r8",
    Rg8 => "rg8",
    Rgb8 => "rgb8",
    Rgba8 => "rgba8",
    Rgba8Srgb => "rgba8-srgb",
    Rgba8Snorm => "rgba8-snorm",
    Rgb10A2 => "rgb10a2",
    R11G11B10F => "r11g11b10f",
    Rgb9e5 => "rgb9e5",
    R16F => "r16f",
    Rg16F => "rg16f",
    Rgba16F => "rgba16f",
    R16Unorm => "r16-unorm",
    Rg16Unorm => "rg16-unorm",
    Rg16Snorm => "rg16-snorm",
    Rgba16Unorm => "rgba16-unorm",
    R16Ui => "r16ui",
    R32F => "r32f",
    Rg32F => "rg32f",
    Rgba32F => "rgba32f",
    R32Ui => "r32ui",
    Rg32Ui => "rg32ui",
    Rgba32Ui => "rgba32ui",
    D16 => "d16",
    D24S8 => "d24s8",
    D32F => "d32f",
});

impl Format {
    /// All known names, comma-separated (for error messages).
    #[must_use]
    pub fn known_names() -> String {
        Format::ALL.map(Format::name).join(", ")
    }

    /// Components in bit order.
    #[must_use]
    pub fn components(self) -> &'static [Component] {
        match self {
            Format::R8 => &[c!("r", 0, 8, Unorm)],
            Format::Rg8 => &[c!("r", 0, 8, Unorm), c!("g", 8, 8, Unorm)],
            Format::Rgb8 => &[c!("r", 0, 8, Unorm), c!("g", 8, 8, Unorm), c!("b", 16, 8, Unorm)],
            Format::Rgba8 => {
                &[c!("r", 0, 8, Unorm), c!("g", 8, 8, Unorm), c!("b", 16, 8, Unorm), c!("a", 24, 8, Unorm)]
            }
            Format::Rgba8Srgb => {
                &[c!("r", 0, 8, Srgb), c!("g", 8, 8, Srgb), c!("b", 16, 8, Srgb), c!("a", 24, 8, Unorm)]
            }
            Format::Rgba8Snorm => {
                &[c!("r", 0, 8, Snorm), c!("g", 8, 8, Snorm), c!("b", 16, 8, Snorm), c!("a", 24, 8, Snorm)]
            }
            Format::Rgb10A2 => {
                &[c!("r", 0, 10, Unorm), c!("g", 10, 10, Unorm), c!("b", 20, 10, Unorm), c!("a", 30, 2, Unorm)]
            }
            Format::R11G11B10F => &[c!("r", 0, 11, Float), c!("g", 11, 11, Float), c!("b", 22, 10, Float)],
            Format::Rgb9e5 => &[
                c!("r", 0, 9, SharedExponent),
                c!("g", 9, 9, SharedExponent),
                c!("b", 18, 9, SharedExponent),
                c!("e", 27, 5, SharedExponent),
            ],
            Format::R16F => &[c!("r", 0, 16, Float)],
            Format::Rg16F => &[c!("r", 0, 16, Float), c!("g", 16, 16, Float)],
            Format::Rgba16F => {
                &[c!("r", 0, 16, Float), c!("g", 16, 16, Float), c!("b", 32, 16, Float), c!("a", 48, 16, Float)]
            }
            Format::R16Unorm => &[c!("r", 0, 16, Unorm)],
            Format::Rg16Unorm => &[c!("r", 0, 16, Unorm), c!("g", 16, 16, Unorm)],
            Format::Rg16Snorm => &[c!("r", 0, 16, Snorm), c!("g", 16, 16, Snorm)],
            Format::Rgba16Unorm => {
                &[c!("r", 0, 16, Unorm), c!("g", 16, 16, Unorm), c!("b", 32, 16, Unorm), c!("a", 48, 16, Unorm)]
            }
            Format::R16Ui => &[c!("r", 0, 16, Uint)],
            Format::R32F => &[c!("r", 0, 32, Float)],
            Format::Rg32F => &[c!("r", 0, 32, Float), c!("g", 32, 32, Float)],
            Format::Rgba32F => {
                &[c!("r", 0, 32, Float), c!("g", 32, 32, Float), c!("b", 64, 32, Float), c!("a", 96, 32, Float)]
            }
            Format::R32Ui => &[c!("r", 0, 32, Uint)],
            Format::Rg32Ui => &[c!("r", 0, 32, Uint), c!("g", 32, 32, Uint)],
            Format::Rgba32Ui => {
                &[c!("r", 0, 32, Uint), c!("g", 32, 32, Uint), c!("b", 64, 32, Uint), c!("a", 96, 32, Uint)]
            }
            Format::D16 => &[c!("depth", 0, 16, Unorm)],
            Format::D24S8 => &[c!("depth", 0, 24, Unorm), c!("stencil", 24, 8, Stencil)],
            Format::D32F => &[c!("depth", 0, 32, Float)],
        }
    }

    /// Bits per texel (the sum of the components).
    #[must_use]
    pub fn bits(self) -> u32 {
        self.components().iter().map(|c| c.bits).sum()
    }

    /// Bytes per texel.
    #[must_use]
    pub fn bytes(self) -> usize {
        (self.bits() / 8) as usize
    }

    /// Is this a depth(-stencil) format?
    #[must_use]
    pub fn is_depth(self) -> bool {
        matches!(self, Format::D16 | Format::D24S8 | Format::D32F)
    }

    /// The components that bit range `[offset, offset + bits)` touches.
    #[must_use]
    pub fn components_in(self, offset: u32, bits: u32) -> Vec<Component> {
        let end = offset + bits;
        self.components().iter().copied().filter(|c| c.offset < end && offset < c.offset + c.bits).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn components_tile_the_texel_without_gaps() {
        for f in Format::ALL {
            let mut next = 0;
            for comp in f.components() {
                assert_eq!(comp.offset, next, "{f}: component {} starts at {}", comp.name, comp.offset);
                next += comp.bits;
            }
            assert_eq!(next, f.bits());
            assert_eq!(f.bits() % 8, 0, "{f}");
            assert!(f.bits() <= 128, "{f}");
        }
    }

    #[test]
    fn sizes_match_the_apis() {
        let expect = [
            (Format::Rgba8, 4),
            (Format::Rgb10A2, 4),
            (Format::R11G11B10F, 4),
            (Format::Rgb9e5, 4),
            (Format::Rg16F, 4),
            (Format::Rgba16F, 8),
            (Format::R32F, 4),
            (Format::Rgba32Ui, 16),
            (Format::D24S8, 4),
            (Format::D32F, 4),
            (Format::D16, 2),
            (Format::R8, 1),
        ];
        for (f, b) in expect {
            assert_eq!(f.bytes(), b, "{f}");
        }
    }

    #[test]
    fn names_parse_in_any_spelling() {
        for f in Format::ALL {
            assert_eq!(Format::from_name(f.name()), Some(f));
            assert_eq!(Format::from_name(&f.name().to_uppercase().replace('-', "_")), Some(f));
        }
        assert_eq!(Format::from_name("R11G11B10_FLOAT"), None);
        assert_eq!(Format::from_name("Rgba8Srgb"), Some(Format::Rgba8Srgb));
        assert_eq!(Format::from_name("RGBA8_SRGB"), Some(Format::Rgba8Srgb));
        assert_eq!(Format::from_name("nope"), None);
    }

    #[test]
    fn components_in_finds_straddled_channels() {
        let touched: Vec<_> = Format::Rgba8.components_in(4, 8).iter().map(|c| c.name).collect();
        assert_eq!(touched, ["r", "g"]);
        assert_eq!(Format::D24S8.components_in(0, 24).len(), 1);
    }
}
