//! Platform limits on render targets: do a layout's targets bind as one pass on WebGPU, Vulkan, D3D12 and Metal?
//!
//! Input: the target formats in binding order and an MSAA sample count; output: per platform, the formats it does
//! not guarantee as attachments, the features they need, and the colour bytes per pixel against the platform's
//! budget. Tile-based GPUs keep every colour target of a pass on chip, so WebGPU caps the bytes of one sample of all
//! colour attachments and Apple GPUs cap them per pixel; Vulkan and D3D12 only cap the target count. Depth never
//! counts toward a colour budget. Support means what every conforming device *guarantees*, not what a driver reports:
//! a layout that passes runs everywhere, one that fails may still run on the device at hand.

use super::formats::Format;

/// What a platform guarantees for one format as an attachment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Support {
    /// Usable as an attachment: a colour attachment for colour formats, a depth-stencil one for depth formats.
    pub render: bool,
    /// Blendable (colour formats only).
    pub blend: bool,
    /// Usable with 4× MSAA, the one count every API below guarantees whenever it guarantees any.
    pub msaa: bool,
    /// A feature (WebGPU) or device query (Vulkan, Metal) without which none of the above holds; `None`: guaranteed.
    pub needs_feature: Option<&'static str>,
    /// A feature needed for blending only (WebGPU's `float32-blendable`).
    pub blend_needs_feature: Option<&'static str>,
}

const NONE: Support =
    Support { render: false, blend: false, msaa: false, needs_feature: None, blend_needs_feature: None };
const ALL: Support = Support { render: true, blend: true, msaa: true, ..NONE };
/// A colour format that renders and multisamples but does not blend (integer formats).
const NO_BLEND: Support = Support { blend: false, ..ALL };
/// Renders without MSAA or blending.
const PLAIN: Support = Support { render: true, ..NONE };
/// A depth(-stencil) attachment with 4× MSAA.
const DEPTH: Support = Support { render: true, msaa: true, ..NONE };

/// An Apple GPU tier, as Metal groups devices into GPU families (`MTLGPUFamily`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AppleGpu {
    /// `Apple1`: A7.
    Apple1,
    /// `Apple2` and `Apple3`: A8 to A10.
    Apple2,
    /// `Apple4` to `Apple6`: A11 to A13.
    Apple4,
    /// `Apple7` and later: A14 and later, M1 and later.
    Apple7,
    /// AMD and Intel GPUs in Macs (`Mac2` without an Apple family): no tile memory, so no colour budget.
    Mac2,
}

/// The API whose rules a [`Platform`] follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Api {
    /// WebGPU.
    WebGpu {
        /// The device has `core-features-and-limits` (false in compatibility mode).
        core: bool,
    },
    /// Vulkan, required format support only.
    Vulkan,
    /// Direct3D 12 at feature level 11_0, required format support only.
    D3d12,
    /// Metal on one GPU tier.
    Metal(AppleGpu),
}

/// A target platform of `gbuf layouts --check`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Platform {
    /// Kebab-case name (`webgpu`, `vulkan`, `metal-apple4`, …).
    pub name: &'static str,
    /// One line saying which devices or limits it stands for.
    pub describe: &'static str,
    /// Whose rules apply.
    pub api: Api,
    /// Colour attachments one pass may bind.
    pub max_color_attachments: u32,
    /// Colour storage budget in bytes: per sample on WebGPU ([`webgpu_bytes_per_sample`]), per pixel on Apple GPUs
    /// ([`metal_bytes_per_pixel`]); `None`: no budget.
    pub color_bytes_limit: Option<u32>,
}

/// Every platform, in the order reports list them.
///
/// WebGPU: the "Limits" table of the WebGPU Editor's Draft (2026-08): `maxColorAttachments` 8 (4 in compatibility
/// mode), `maxColorAttachmentBytesPerSample` 32 in both; adapters may grant more (wgpu grants 64 on D3D12 and on
/// Metal `Apple4`+). Vulkan: "Limit Requirements" of the Vulkan 1.4.360 specification: `maxColorAttachments` at least
/// 4, 8 for Vulkan 1.4 and Roadmap 2024. D3D12: `D3D12_SIMULTANEOUS_RENDER_TARGET_COUNT` (8) in `d3d12.h`. Metal:
/// "Maximum number of color render targets per render pass" and "Maximum total render target size, per pixel, when
/// using multiple color render targets" of Apple's *Metal Feature Set Tables* before June 2025: 4 and 128 bits on
/// `Apple1`, 8 and 256 bits on `Apple2`–`Apple3`, 8 and 512 bits from `Apple4`, no size limit on `Mac2`.
pub const PLATFORMS: &[Platform] = &[
    platform("webgpu", Api::WebGpu { core: true }, 8, Some(32), "WebGPU default limits"),
    platform("webgpu-64", Api::WebGpu { core: true }, 8, Some(64), "WebGPU, adapter granting 64 bytes per sample"),
    platform("webgpu-128", Api::WebGpu { core: true }, 8, Some(128), "WebGPU, adapter granting 128 bytes per sample"),
    platform("webgpu-compat", Api::WebGpu { core: false }, 4, Some(32), "WebGPU compatibility mode"),
    platform("vulkan", Api::Vulkan, 4, None, "Vulkan 1.0-1.3, required formats only"),
    platform("vulkan-2024", Api::Vulkan, 8, None, "Vulkan 1.4 or Roadmap 2024, required formats only"),
    platform("d3d12", Api::D3d12, 8, None, "Direct3D 12 at feature level 11_0, required formats only"),
    platform("metal-apple1", Api::Metal(AppleGpu::Apple1), 4, Some(16), "Metal on A7 (Apple1)"),
    platform("metal-apple2", Api::Metal(AppleGpu::Apple2), 8, Some(32), "Metal on A8-A10 (Apple2, Apple3)"),
    platform("metal-apple4", Api::Metal(AppleGpu::Apple4), 8, Some(64), "Metal on A11-A13 (Apple4 to Apple6)"),
    platform("metal-apple7", Api::Metal(AppleGpu::Apple7), 8, Some(64), "Metal on A14+ and M1+ (Apple7 and later)"),
    platform("metal-mac2", Api::Metal(AppleGpu::Mac2), 8, None, "Metal on AMD and Intel Mac GPUs (Mac2)"),
];

/// A [`PLATFORMS`] entry.
const fn platform(name: &'static str, api: Api, targets: u32, bytes: Option<u32>, describe: &'static str) -> Platform {
    Platform { name, describe, api, max_color_attachments: targets, color_bytes_limit: bytes }
}

impl Platform {
    /// The platform called `name`.
    #[must_use]
    pub fn by_name(name: &str) -> Option<&'static Platform> {
        PLATFORMS.iter().find(|p| p.name == name)
    }
}

/// WebGPU's "render target pixel byte cost" and "render target component alignment" of a colour format, in bytes;
/// `None` for formats that are not colour-renderable in WebGPU (`rgb9e5ufloat`, depth, and our CPU-only `rgb8`).
///
/// Source: the table in "Texture Format Capabilities" › "Plain color formats" of the WebGPU Editor's Draft
/// (gpuweb/gpuweb `spec/index.bs`, 2026-08-19). It equals `TextureFormat::target_pixel_byte_cost` and
/// `target_component_alignment` in wgpu-types 22.0 and later. The 8 bytes of the 4-byte `rgba8*`, `rgb10a2unorm` and
/// `rg11b10ufloat` match Apple A7–A10 tile memory, where those formats take 8 bytes (always, or with MSAA).
#[must_use]
pub fn webgpu_byte_cost(format: Format) -> Option<(u32, u32)> {
    use Format::*;
    match format {
        R8 => Some((1, 1)),
        Rg8 => Some((2, 1)),
        Rgba8 | Rgba8Srgb | Rgba8Snorm => Some((8, 1)),
        R16F | R16Unorm | R16Ui => Some((2, 2)),
        Rg16F | Rg16Unorm | Rg16Snorm => Some((4, 2)),
        Rgba16F | Rgba16Unorm => Some((8, 2)),
        R32F | R32Ui => Some((4, 4)),
        Rg32F | Rg32Ui => Some((8, 4)),
        Rgba32F | Rgba32Ui => Some((16, 4)),
        Rgb10A2 | R11G11B10F => Some((8, 4)),
        Rgb8 | Rgb9e5 | D16 | D24S8 | D32F => None,
    }
}

/// The running total of "Calculating color attachment bytes per sample" in the WebGPU Editor's Draft: for each colour
/// format in binding order, round the total up to the format's component alignment, then add its byte cost. Depth
/// formats are skipped (they are not colour attachments); `None` if a colour format has no cost (not renderable).
///
/// Agrees with `validate_color_attachment_bytes_per_sample` in wgpu-core (`wgpu-core/src/validation.rs`, 22.0
/// through the 28 rewrite), which rejects a total greater than the limit. Binding order matters: `[r8, r32f]` takes 8
/// bytes, `[r32f, r8]` 5.
#[must_use]
pub fn webgpu_bytes_per_sample(formats: &[Format]) -> Option<u32> {
    running_total(formats, webgpu_byte_cost)
}

/// Round up to each alignment, then add each cost; depth skipped, `None` on a colour format without a cost.
fn running_total(formats: &[Format], cost: impl Fn(Format) -> Option<(u32, u32)>) -> Option<u32> {
    let mut total = 0u32;
    for &f in formats.iter().filter(|f| !f.is_depth()) {
        let (bytes, align) = cost(f)?;
        total = total.next_multiple_of(align) + bytes;
    }
    Some(total)
}

/// Bytes and alignment a colour format takes in Apple tile memory; `None` if it is not renderable there or the GPU
/// has no tile memory (`Mac2`). `msaa` selects the multisampled size, which differs only on `Apple1`–`Apple3`.
///
/// Apple's *Understanding Color-Renderable Pixel Format Sizes* says A7–A10 expand some formats in tile memory and sends
/// the numbers to the *Metal Feature Set Tables*; the per-format values here are the ones ANGLE's Metal back end
/// validates with (`FormatTable::adjustFormatCapsForDevice` in `mtl_format_utils.mm`): on A7–A10 every target takes at
/// least 4 bytes at 4-byte alignment, `rgb10a2`/`rg11b10f`/`rgb9e5` take 8, sRGB and snorm `rgba8` take 8 with MSAA
/// (plain `rgba8` too from A8); from A11 each format takes its own size, aligned to its component size.
#[must_use]
pub fn metal_tile_cost(format: Format, gpu: AppleGpu, msaa: bool) -> Option<(u32, u32)> {
    use Format::*;
    if format.is_depth() || gpu == AppleGpu::Mac2 || !metal_support(format, gpu).render {
        return None;
    }
    let natural = format.bits() / 8;
    let packed = matches!(format, Rgb10A2 | R11G11B10F | Rgb9e5);
    Some(match gpu {
        AppleGpu::Apple1 | AppleGpu::Apple2 => {
            let cost = match format {
                _ if packed => 8,
                Rgba8Srgb | Rgba8Snorm if msaa => 8,
                Rgba8 if msaa && gpu == AppleGpu::Apple2 => 8,
                _ => natural.max(4),
            };
            (cost, 4)
        }
        _ if packed => (4, 4),
        _ => (natural, natural / format.components().len() as u32),
    })
}

/// Tile memory one pixel of these colour targets takes on an Apple GPU, with the padding rule of
/// [`webgpu_bytes_per_sample`] (Apple's engineers describe the on-chip pixel as a struct whose members keep their
/// natural alignment); `None` as for [`metal_tile_cost`].
#[must_use]
pub fn metal_bytes_per_pixel(formats: &[Format], gpu: AppleGpu, samples: u32) -> Option<u32> {
    running_total(formats, |f| metal_tile_cost(f, gpu, samples > 1))
}

/// What `platform` guarantees for `format`.
#[must_use]
pub fn support(platform: &Platform, format: Format) -> Support {
    match platform.api {
        Api::WebGpu { core } => webgpu_support(format, core),
        Api::Vulkan => vulkan_support(format),
        Api::D3d12 => d3d12_support(format),
        Api::Metal(gpu) => metal_support(format, gpu),
    }
}

/// WebGPU, from the "Plain color formats" and "Depth-stencil formats" tables of the WebGPU Editor's Draft. `core`
/// stands for `core-features-and-limits`, which every non-compatibility device has and which `rgba16float`, `r16uint`
/// and `r32float` need for MSAA.
#[must_use]
pub fn webgpu_support(format: Format, core: bool) -> Support {
    use Format::*;
    const TIER1: Option<&str> = Some("texture-formats-tier1");
    const FLOAT32_BLENDABLE: Option<&str> = Some("float32-blendable");
    match format {
        R8 | Rg8 | Rgba8 | Rgba8Srgb | Rgb10A2 | R16F | Rg16F => ALL,
        Rgba16F => Support { msaa: core, ..ALL },
        Rgba8Snorm | R16Unorm | Rg16Unorm | Rg16Snorm | Rgba16Unorm => Support { needs_feature: TIER1, ..ALL },
        R11G11B10F => Support { needs_feature: Some("rg11b10ufloat-renderable"), ..ALL },
        R16Ui => Support { msaa: core, ..NO_BLEND },
        R32F => Support { msaa: core, blend_needs_feature: FLOAT32_BLENDABLE, ..ALL },
        Rg32F | Rgba32F => Support { msaa: false, blend_needs_feature: FLOAT32_BLENDABLE, ..ALL },
        R32Ui | Rg32Ui | Rgba32Ui => PLAIN,
        D16 | D24S8 | D32F => DEPTH,
        Rgb8 | Rgb9e5 => NONE,
    }
}

/// Vulkan, from "Required Format Support" of the Vulkan 1.4.360 specification (`COLOR_ATTACHMENT`,
/// `COLOR_ATTACHMENT_BLEND` and `DEPTH_STENCIL_ATTACHMENT` in `optimalTilingFeatures`). MSAA: a colour-attachment
/// format's `sampleCounts` include `framebufferColorSampleCounts` (at least 1 and 4) for float and fixed-point formats,
/// but only `framebufferIntegerColorSampleCounts` (at least 1) for integer ones; depth gets
/// `framebufferDepthSampleCounts` (at least 1 and 4). `rgb10a2` is `A2B10G10R10_UNORM_PACK32` (red in the low bits).
#[must_use]
pub fn vulkan_support(format: Format) -> Support {
    use Format::*;
    match format {
        R8 | Rg8 | Rgba8 | Rgba8Srgb | Rgb10A2 | R16F | Rg16F | Rgba16F => ALL,
        R32F | Rg32F | Rgba32F => Support { blend: false, ..ALL },
        R16Ui | R32Ui | Rg32Ui | Rgba32Ui => PLAIN,
        D16 => DEPTH,
        // The tables require depth attachments on "at least one of" a pair, not on either member.
        D32F => Support { needs_feature: Some("D32_SFLOAT support (it or X8_D24_UNORM_PACK32 is required)"), ..DEPTH },
        D24S8 => {
            Support { needs_feature: Some("D24_UNORM_S8_UINT support (it or D32_SFLOAT_S8_UINT is required)"), ..DEPTH }
        }
        Rgb8 | Rgba8Snorm | R11G11B10F | Rgb9e5 | R16Unorm | Rg16Unorm | Rg16Snorm | Rgba16Unorm => NONE,
    }
}

/// Direct3D 12 at feature level 11_0, from Microsoft's *Format support for Direct3D Feature Level 11.0 hardware*
/// (the 12.0 page agrees for these formats): "RenderTarget", "Blendable RenderTarget", "4x Multisample RenderTarget"
/// and "Depth/Stencil Target" marked required. 8× is required too, except for the 128-bit formats.
#[must_use]
pub fn d3d12_support(format: Format) -> Support {
    use Format::*;
    match format {
        R8 | Rg8 | Rgba8 | Rgba8Srgb | Rgba8Snorm | Rgb10A2 | R11G11B10F | R16F | Rg16F | Rgba16F | R16Unorm
        | Rg16Unorm | Rg16Snorm | Rgba16Unorm | R32F | Rg32F | Rgba32F => ALL,
        R16Ui | R32Ui | Rg32Ui | Rgba32Ui => NO_BLEND,
        D16 | D24S8 | D32F => DEPTH,
        Rgb8 | Rgb9e5 => NONE,
    }
}

/// Metal, from the pixel-format capability tables of Apple's *Metal Feature Set Tables* as ANGLE transcribes them
/// (`caps` in `mtl_format_map.json` of ANGLE's Metal back end). Apple GPUs render, blend and multisample `rgb9e5`;
/// they multisample 32-bit-per-channel formats only from `Apple7` (`rg32ui`, `rgba32f`) or never (`r32ui`,
/// `rgba32ui`, `rg32f`), blend `rgba32f` never, and have no `Depth24Unorm_Stencil8`.
#[must_use]
pub fn metal_support(format: Format, gpu: AppleGpu) -> Support {
    use Format::*;
    let mac = gpu == AppleGpu::Mac2;
    let msaa_from_apple7 = mac || gpu == AppleGpu::Apple7;
    match format {
        R8 | Rg8 | Rgba8 | Rgba8Srgb | Rgba8Snorm | Rgb10A2 | R11G11B10F | R16F | Rg16F | Rgba16F | R16Unorm
        | Rg16Unorm | Rg16Snorm | Rgba16Unorm | R32F => ALL,
        Rgb9e5 if !mac => ALL,
        Rg32F => Support { msaa: mac, ..ALL },
        Rgba32F => Support { blend: mac, msaa: msaa_from_apple7, ..ALL },
        R16Ui => NO_BLEND,
        Rg32Ui => Support { msaa: msaa_from_apple7, ..PLAIN },
        R32Ui | Rgba32Ui => Support { msaa: mac, ..PLAIN },
        D16 | D32F => DEPTH,
        D24S8 if mac => Support { needs_feature: Some("MTLDevice.depth24Stencil8PixelFormatSupported"), ..DEPTH },
        Rgb8 | Rgb9e5 | D24S8 => NONE,
    }
}

/// Whether Arm Mali GPUs can keep a target AFBC-compressed (Arm Frame Buffer Compression).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Afbc {
    /// On every Mali GPU with AFBC for Vulkan (Mali-G51 and later, driver r16p0 and later).
    AllMali,
    /// From Mali-G77: every format up to 32 bits per pixel.
    FromMaliG77,
    /// Never: multisampled, wider than 32 bits, or not a render-target format.
    Never,
}

/// AFBC eligibility of a `samples`× target, from Arm's *Enabling AFBC in your Vulkan Application* (Khronos
/// Vulkan-Samples, `samples/performance/afbc`): only single-sampled 2D optimal-tiling images (MSAA images are
/// resolved on chip; the resolve target can be compressed), formats up to 32 bits per pixel from Mali-G77 and a
/// listed subset before it. The image must also not be a storage image, transient, aliased or mutable-format,
/// which a layout does not say.
#[must_use]
pub fn afbc(format: Format, samples: u32) -> Afbc {
    use Format::*;
    match format {
        _ if samples > 1 => Afbc::Never,
        R8 | Rg8 | Rgba8 | Rgba8Srgb | Rgb10A2 | D16 | D24S8 | D32F => Afbc::AllMali,
        Rgb8 => Afbc::Never,
        _ if format.bits() <= 32 => Afbc::FromMaliG77,
        _ => Afbc::Never,
    }
}

/// The verdict of [`check`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Check {
    /// Colour bytes per sample (WebGPU) or per pixel (Metal), where the platform has a budget and every colour
    /// format has a cost.
    pub color_bytes: Option<u32>,
    /// Why the targets do not bind as one pass; empty when they do.
    pub problems: Vec<String>,
    /// Features or device queries the targets need beyond the guarantees (each once).
    pub needs: Vec<&'static str>,
}

impl Check {
    /// Do the targets bind as one pass without any feature?
    #[must_use]
    pub fn fits(&self) -> bool {
        self.problems.is_empty() && self.needs.is_empty()
    }
}

/// Do targets of these formats, in binding order, bind as one `samples`× pass on `platform`? Checks the colour
/// target count, one depth target at most, per-format attachment and MSAA support, the sample count (1 and 4
/// everywhere, 8 on D3D12 below 128 bits per pixel) and the colour byte budget.
#[must_use]
pub fn check(platform: &Platform, formats: &[Format], samples: u32) -> Check {
    let name = platform.name;
    let mut problems = Vec::new();
    let mut needs: Vec<&'static str> = Vec::new();
    let colors = formats.iter().filter(|f| !f.is_depth()).count();
    if colors > platform.max_color_attachments as usize {
        problems.push(format!("{colors} colour targets; {name} binds {}", platform.max_color_attachments));
    }
    if formats.iter().filter(|f| f.is_depth()).count() > 1 {
        problems.push("more than one depth target in one pass".to_string());
    }
    for &f in formats {
        let s = support(platform, f);
        if !s.render {
            problems.push(format!("{f} is not a guaranteed attachment format on {name}"));
            continue;
        }
        if let Some(n) = s.needs_feature.filter(|n| !needs.contains(n)) {
            needs.push(n);
        }
        let eight_ok = platform.api == Api::D3d12 && f.bits() < 128;
        let guaranteed = samples == 1 || (s.msaa && (samples == 4 || (samples == 8 && eight_ok)));
        if !guaranteed {
            problems.push(format!("{f} has no guaranteed {samples}x MSAA on {name}"));
        }
    }
    let color_bytes = match platform.api {
        Api::WebGpu { .. } => webgpu_bytes_per_sample(formats),
        Api::Metal(gpu) if platform.color_bytes_limit.is_some() => metal_bytes_per_pixel(formats, gpu, samples),
        _ => None,
    };
    if let (Some(bytes), Some(limit)) = (color_bytes, platform.color_bytes_limit) {
        if bytes > limit {
            problems.push(format!("colour targets take {bytes} bytes; {name} allows {limit}"));
        }
    }
    Check { color_bytes, problems, needs }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Format::*;

    fn named(name: &str) -> &'static Platform {
        Platform::by_name(name).unwrap_or_else(|| panic!("no platform {name}"))
    }

    #[test]
    fn webgpu_samples_deferred_renderer_went_over_32_bytes_and_back() {
        // webgpu/webgpu-samples `sample/deferredRendering`: position rgba32float + normal rgba32float + albedo
        // bgra8unorm (same cost as rgba8unorm) drew Dawn's "Total color attachment bytes per sample (40) exceeds
        // maximum (32)"; an rgba16float normal made it 32, and reconstructing position from depth 16.
        let original = [Rgba32F, Rgba32F, Rgba8];
        assert_eq!(webgpu_bytes_per_sample(&original), Some(40));
        assert!(!check(named("webgpu"), &original, 1).fits());
        assert!(check(named("webgpu-64"), &original, 1).fits());
        assert_eq!(webgpu_bytes_per_sample(&[Rgba32F, Rgba16F, Rgba8]), Some(32));
        let today = [D24S8, Rgba16F, Rgba8];
        assert_eq!(webgpu_bytes_per_sample(&today), Some(16));
        assert!(check(named("webgpu"), &today, 1).fits());
    }

    #[test]
    fn padding_follows_each_formats_component_alignment() {
        // wgpu's worked example: 8 (sRGB) + 16 + 1 + 1 + 1, pad 27 -> 28, + 16 + 4.
        assert_eq!(webgpu_bytes_per_sample(&[Rgba8Srgb, Rgba32F, R8, R8, R8, Rgba32F, R32F]), Some(48));
        assert_eq!(webgpu_bytes_per_sample(&[R8, R32F]), Some(8));
        assert_eq!(webgpu_bytes_per_sample(&[R32F, R8]), Some(5));
        assert_eq!(webgpu_bytes_per_sample(&[R8, Rgba16F]), Some(10));
        assert_eq!(webgpu_bytes_per_sample(&[R8, R8, Rgb10A2]), Some(12));
    }

    #[test]
    fn depth_is_free_and_unrenderable_colour_has_no_total() {
        assert_eq!(webgpu_bytes_per_sample(&[D32F]), Some(0));
        assert_eq!(webgpu_bytes_per_sample(&[Rgba8, Rgb9e5]), None);
        assert_eq!(webgpu_bytes_per_sample(&[Rgb8]), None);
        for f in Format::ALL {
            let renderable = webgpu_support(f, true).render && !f.is_depth();
            assert_eq!(webgpu_byte_cost(f).is_some(), renderable, "{f}");
        }
    }

    #[test]
    fn apple_tile_memory_grows_small_and_packed_formats_before_a11() {
        assert_eq!(metal_bytes_per_pixel(&[Rgba16F, Rgba8], AppleGpu::Apple4, 1), Some(12));
        assert_eq!(metal_bytes_per_pixel(&[R8, R8], AppleGpu::Apple2, 1), Some(8));
        assert_eq!(metal_tile_cost(Rgba8, AppleGpu::Apple2, true), Some((8, 4)));
        assert_eq!(metal_tile_cost(Rgba8, AppleGpu::Apple1, true), Some((4, 4)));
        assert_eq!(metal_tile_cost(Rgb10A2, AppleGpu::Apple7, false), Some((4, 4)));
        assert_eq!(metal_tile_cost(Rgba8, AppleGpu::Mac2, false), None);
        // Four rgba16f targets: 32 bytes, over A7's 16, at A8-A10's limit.
        let four = [Rgba16F; 4];
        assert!(!check(named("metal-apple1"), &four, 1).fits());
        assert!(check(named("metal-apple2"), &four, 1).fits());
    }

    #[test]
    fn support_tables_keep_their_conditions() {
        assert_eq!(webgpu_support(R11G11B10F, true).needs_feature, Some("rg11b10ufloat-renderable"));
        assert_eq!(webgpu_support(R32F, true).blend_needs_feature, Some("float32-blendable"));
        assert!(!webgpu_support(Rgba16F, false).msaa && webgpu_support(Rgba16F, true).msaa);
        assert!(!vulkan_support(R11G11B10F).render && d3d12_support(R11G11B10F).render);
        assert!(vulkan_support(D16).needs_feature.is_none() && vulkan_support(D24S8).needs_feature.is_some());
        assert!(!d3d12_support(Rgb9e5).render && metal_support(Rgb9e5, AppleGpu::Apple4).render);
        // Bevy's deferred texel is Rgba32Uint: fine single-sampled, never 4x on WebGPU.
        let bevy = [D32F, Rgba32Ui];
        assert!(check(named("webgpu"), &bevy, 1).fits());
        assert!(!check(named("webgpu"), &bevy, 4).fits());
        assert_eq!(check(named("vulkan"), &bevy, 1).needs.len(), 1);
    }

    #[test]
    fn afbc_needs_single_samples_and_32_bits_at_most() {
        assert_eq!(afbc(Rgba8, 1), Afbc::AllMali);
        assert_eq!(afbc(Rgba8, 4), Afbc::Never);
        assert_eq!(afbc(Rg16F, 1), Afbc::FromMaliG77);
        assert_eq!(afbc(Rgba16F, 1), Afbc::Never);
    }

    #[test]
    fn platform_names_are_unique_kebab_case() {
        for (i, p) in PLATFORMS.iter().enumerate() {
            assert!(p.name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-'));
            assert!(PLATFORMS[..i].iter().all(|q| q.name != p.name), "{}", p.name);
        }
    }
}
