//! A layout as views for RenderDoc's texture viewer: one custom display shader per decoded attribute (GLSL, for
//! OpenGL and Vulkan captures), and the buffer viewer's format string of each target, so a packed target is seen as
//! what it holds (normals as RGB, linear depth, albedo, roughness, metallic, IDs as colours) at the MSAA sample the
//! viewer selects.
//!
//! The shader's interface is RenderDoc's documented one for custom display shaders (1.19 and later,
//! `how_custom_visualisation`): RenderDoc inserts its prefix after `#version` (the `RD_*_BINDING` macros and the
//! helpers `RD_TextureType()`, `RD_SelectedSample()` — the sample, or −N for "average value" — `RD_SelectedMip()`,
//! `RD_SelectedSliceFace()`), binds the viewed texture by type (float slots for unorm, sRGB, float and depth
//! formats; uint slots for integer formats) and renders the output into an RGBA16F texture. The shader fetches
//! the texel (no filtering), rebuilds the texel's bits from what the sampler returns — unorm: the nearest code;
//! sRGB: the nearest of gbuf's 256 decoded values (a driver's own sRGB decode can be off by a third of a code);
//! float: the bits; integer: the value — and decodes them with the layout's own emitted code ([`super::shader`]),
//! so the view shows gbuf's decode bit for bit up to the RGBA16F store. "Average value" is the mean of the decoded
//! samples (for IDs: sample 0, so that no blended colour suggests an ID that is not there).
//!
//! Not emitted, with the reason: formats whose bits the sampler does not give back unambiguously (snorm: −1 has
//! two codes; shared-exponent; 24-bit depth in an f32; stencil), attributes split over several targets, and
//! layouts with a material table (its uniform block is not RenderDoc's to set). The proof runs the views in
//! RenderDoc's own replay of `fixtures/engine_4x.rdc` (`tests/packed_input.rs`).

use super::formats::{ComponentKind, Format};
use super::shader::{self, Lang};
use super::Layout;
use crate::error::{Error, Result};
use crate::gbuffer::Attribute;
use std::fmt::Write as _;

/// One display shader.
#[derive(Clone, Debug)]
pub struct View {
    /// The file name to write it under (`gbuf_<layout>_<target>_<attribute>.glsl`).
    pub file: String,
    /// The target it views.
    pub target: String,
    /// The attribute it shows.
    pub attribute: Attribute,
    /// The GLSL source.
    pub code: String,
}

/// What `gbuf layouts L --emit renderdoc` writes.
#[derive(Clone, Debug)]
pub struct Views {
    /// One shader per attribute that can be viewed.
    pub views: Vec<View>,
    /// Attributes without a view, and why.
    pub skipped: Vec<String>,
    /// Per target, the buffer viewer's format string showing its fields (`uint normal_0 : 10; …`).
    pub buffer_formats: Vec<(String, String)>,
}

/// The views of `layout`. `camera` (near, far) is baked into the code when the layout's depth codec needs the
/// projection (RenderDoc sets no uniforms of ours); the error says so when it is missing.
pub fn views(layout: &Layout, camera: Option<(f32, f32)>) -> Result<Views> {
    if layout.indirection().is_some() {
        return Err(Error::Argument(format!(
            "layout {:?} decodes through a material table, a uniform block RenderDoc's texture viewer cannot fill: \
             no display shaders are emitted for it",
            layout.name()
        )));
    }
    let mut base = shader::emit(layout, Lang::Glsl)?;
    const CAMERA: &str = "uniform float gbuf_znear;\nuniform float gbuf_zfar;\n";
    if base.contains(CAMERA) {
        if let Some((n, f)) = camera.filter(|&(n, f)| !(n.is_finite() && f.is_finite() && 0.0 < n && n < f)) {
            return Err(Error::Argument(format!(
                "--znear {n} --zfar {f}: the planes must be finite with 0 < near < far"
            )));
        }
        let Some((n, f)) = camera else {
            return Err(Error::Argument(format!(
                "layout {:?}'s depth codec needs the camera's near and far planes, which RenderDoc cannot pass to a \
                 display shader: give them (--znear N --zfar F) to be written into the code",
                layout.name()
            )));
        };
        let consts = format!(
            "const float gbuf_znear = {}; // baked in by --emit renderdoc\nconst float gbuf_zfar = {};\n",
            literal(n),
            literal(f)
        );
        base = base.replace(CAMERA, &consts);
    }
    if base.lines().any(|l| l.trim_start().starts_with("uniform ") || l.contains(") uniform ")) {
        return Err(Error::Internal(format!("layout {:?}: the emitted code declares uniforms", layout.name())));
    }
    let mut views = Vec::new();
    let mut skipped = Vec::new();
    let mut attributes: Vec<Attribute> = Vec::new();
    for f in layout.fields() {
        if let Some(a) = f.slot.attribute() {
            if !attributes.contains(&a) {
                attributes.push(a);
            }
        }
    }
    for a in attributes {
        let mut targets: Vec<usize> =
            layout.fields().iter().filter(|f| f.slot.attribute() == Some(a)).map(|f| f.target).collect();
        targets.sort_unstable();
        targets.dedup();
        if targets.len() != 1 {
            skipped.push(format!("{}: stored in {} targets; a view sees one", a.name(), targets.len()));
            continue;
        }
        let ti = targets[0];
        let target = &layout.spec().targets[ti].name;
        let format = layout.formats()[ti];
        let words = match words_fn(format) {
            Ok(w) => w,
            Err(why) => {
                skipped.push(format!("{} (target {target}, {format}): {why}", a.name()));
                continue;
            }
        };
        let args: Vec<&str> =
            (0..layout.spec().targets.len()).map(|i| if i == ti { "w" } else { "uvec4(0u)" }).collect();
        let code = view_code(layout, &base, target, format, a, &words, &args.join(", "));
        let file = format!("gbuf_{}_{}_{}.glsl", ident(layout.name()), ident(target), a.name());
        views.push(View { file, target: target.clone(), attribute: a, code });
    }
    let buffer_formats = (0..layout.spec().targets.len())
        .map(|ti| (layout.spec().targets[ti].name.clone(), buffer_format(layout, ti)))
        .collect();
    Ok(Views { views, skipped, buffer_formats })
}

/// An f32 as a decimal literal every GLSL compiler rounds back to it (17 significant digits of its double).
fn literal(v: f32) -> String {
    format!("{:.16e}", f64::from(v))
}

fn ident(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '_' }).collect()
}

/// Is `format` read through RenderDoc's integer (uint) slots?
fn is_uint(format: Format) -> bool {
    format.components().iter().all(|c| c.kind == ComponentKind::Uint)
}

/// `uvec4 gbuf_rd_words(<sampled texel>)`: the texel's bits (gbuf's ABI: little-endian 32-bit words) from what the
/// sampler returns; the reason when they cannot be rebuilt exactly.
fn words_fn(format: Format) -> std::result::Result<String, String> {
    let uint = is_uint(format);
    let channel = |name: &str| match name {
        "r" | "depth" => "x",
        "g" => "y",
        "b" => "z",
        _ => "w",
    };
    let mut parts: Vec<Vec<String>> = vec![Vec::new(); format.bits().div_ceil(32) as usize];
    for c in format.components() {
        let v = format!("v.{}", channel(c.name));
        let code = match (c.kind, c.bits) {
            (ComponentKind::Uint, 32) => v,
            (ComponentKind::Uint, k) => format!("({v} & {:#x}u)", (1u64 << k) - 1),
            (ComponentKind::Unorm, k) if k <= 16 => format!("gbuf_rd_unorm_code({v}, {}.0)", (1u64 << k) - 1),
            (ComponentKind::Srgb, 8) => format!("gbuf_rd_srgb8_code({v})"),
            (ComponentKind::Float, 32) => format!("floatBitsToUint({v})"),
            (ComponentKind::Float, 16) => format!("(packHalf2x16(vec2({v}, 0.0)) & 0xffffu)"),
            (ComponentKind::Float, k) => format!("gbuf_ufloat_bits({v}, {}u)", k - 5),
            (ComponentKind::Unorm, k) => {
                return Err(format!("a {k}-bit unorm does not round-trip through the sampler's f32"))
            }
            (ComponentKind::Snorm, _) => return Err("snorm −1.0 has two codes".into()),
            (ComponentKind::SharedExponent, _) => return Err("a shared exponent has several codes per value".into()),
            (ComponentKind::Stencil, _) => return Err("the viewer does not sample stencil with depth".into()),
            (ComponentKind::Srgb, k) => return Err(format!("{k}-bit sRGB")),
        };
        let shift = c.offset % 32;
        parts[(c.offset / 32) as usize].push(if shift == 0 { code } else { format!("({code} << {shift}u)") });
    }
    let words: Vec<String> =
        (0..4).map(|i| parts.get(i).filter(|p| !p.is_empty()).map_or("0u".to_string(), |p| p.join(" | "))).collect();
    let input = if uint { "uvec4 v" } else { "vec4 v" };
    Ok(format!(
        "// The texel's bits ({format}) from what the sampler returns: gbuf's words (docs/SHADERS.md).\n\
         uvec4 gbuf_rd_words({input}) {{\n    return uvec4({});\n}}\n",
        words.join(", ")
    ))
}

/// What RenderDoc binds and the fetch of sample `s` of the texel under the fragment (float or uint slots).
fn inputs(uint: bool) -> String {
    let (p, t, k) = if uint { ("u", "uvec4", "UINT") } else { ("", "vec4", "FLOAT") };
    format!(
        r"
// ---- RenderDoc's inputs (custom display shaders, RenderDoc 1.19 and later): its prefix, inserted after #version,
// defines the RD_* binding macros, RD_TextureType_* and the helpers used here; the viewed texture is bound by type.
#ifdef VULKAN
layout (binding = RD_{k}_2D_ARRAY_BINDING) uniform {p}sampler2DArray tex2DArray;
layout (binding = RD_{k}_2DMS_ARRAY_BINDING) uniform {p}sampler2DMSArray tex2DMSArray;
#else
layout (binding = RD_{k}_2D_BINDING) uniform {p}sampler2D tex2D;
layout (binding = RD_{k}_2D_ARRAY_BINDING) uniform {p}sampler2DArray tex2DArray;
layout (binding = RD_{k}_2DMS_BINDING) uniform {p}sampler2DMS tex2DMS;
layout (binding = RD_{k}_2DMS_ARRAY_BINDING) uniform {p}sampler2DMSArray tex2DMSArray;
#endif

// What the viewer shows (RenderDoc stores it as RGBA16F).
layout (location = 0) out vec4 gbuf_rd_out;

// The samples of the viewed texel (1 when single-sampled).
int gbuf_rd_samples() {{
    uint type = RD_TextureType();
#ifdef VULKAN
    if (type == RD_TextureType_2DMS) return textureSamples(tex2DMSArray);
#else
    if (type == RD_TextureType_2DMS) return textureSamples(tex2DMS);
    if (type == RD_TextureType_2DMS_Array) return textureSamples(tex2DMSArray);
#endif
    return 1;
}}

// Sample s of the texel under this fragment (gl_FragCoord is a texel of the selected mip): the selected slice and
// mip, fetched, never filtered.
{t} gbuf_rd_fetch(int s) {{
    ivec2 p = ivec2(gl_FragCoord.xy);
    int mip = int(RD_SelectedMip());
    int slice = int(RD_SelectedSliceFace());
    uint type = RD_TextureType();
#ifdef VULKAN
    if (type == RD_TextureType_2DMS) return texelFetch(tex2DMSArray, ivec3(p, slice), s);
    return texelFetch(tex2DArray, ivec3(p, slice), mip);
#else
    if (type == RD_TextureType_2DMS) return texelFetch(tex2DMS, p, s);
    if (type == RD_TextureType_2DMS_Array) return texelFetch(tex2DMSArray, ivec3(p, slice), s);
    if (type == RD_TextureType_2D_Array) return texelFetch(tex2DArray, ivec3(p, slice), mip);
    return texelFetch(tex2D, p, mip);
#endif
}}
"
    )
}

/// The code rebuilding unorm and sRGB codes from sampled values.
const CODES: &str = r"
// A k-bit unorm's code from the sampled code / (2^k − 1): the nearest code.
uint gbuf_rd_unorm_code(float v, float maxcode) {
    precise float s = clamp(v, 0.0, 1.0) * maxcode + 0.5;
    return uint(floor(s));
}
";

/// The sRGB code from the driver's decode of it: the nearest of gbuf's 256 linear values (binary search, then the
/// nearer neighbour; adjacent values are at least 3e-4 apart, a driver's decode within a third of that).
const SRGB_CODE: &str = r"
uint gbuf_rd_srgb8_code(float v) {
    uint lo = 0u;
    for (uint stride = 128u; stride > 0u; stride >>= 1) {
        if (lo + stride <= 255u && v >= uintBitsToFloat(gbuf_srgb8_D[lo + stride])) lo += stride;
    }
    if (lo < 255u) {
        precise float below = v - uintBitsToFloat(gbuf_srgb8_D[lo]);
        precise float above = uintBitsToFloat(gbuf_srgb8_D[lo + 1u]) - v;
        if (above < below) lo += 1u;
    }
    return lo;
}
";

/// An ID as a colour: 24 bits of a 32-bit integer hash (Wellons' lowbias32).
const ID_COLOUR: &str = r"
vec4 gbuf_rd_id_colour(uint id) {
    uint h = id;
    h ^= h >> 16; h *= 0x7feb352du; h ^= h >> 15; h *= 0x846ca68bu; h ^= h >> 16;
    return vec4(float(h & 255u) / 255.0, float((h >> 8) & 255u) / 255.0, float((h >> 16) & 255u) / 255.0, 1.0);
}
";

/// The whole display shader of attribute `a` of `target`.
fn view_code(
    layout: &Layout,
    base: &str,
    target: &str,
    format: Format,
    a: Attribute,
    words: &str,
    args: &str,
) -> String {
    let m = format!("s.{}", a.name());
    let (show, what) = match a {
        Attribute::Normal => (format!("vec4({m} * 0.5 + 0.5, 1.0)"), "the unit view-space normal as n·0.5 + 0.5"),
        Attribute::Depth => (
            format!("vec4({m}, {m}, {m}, 1.0)"),
            "linear view depth in scene units (set the viewer's range, or Auto-fit, to see it as grey)",
        ),
        Attribute::Position => (format!("vec4({m}, 1.0)"), "the view-space position (set the viewer's range)"),
        Attribute::Albedo => (format!("vec4({m}, 1.0)"), "linear albedo"),
        Attribute::Motion => (format!("vec4({m}, 0.0, 1.0)"), "motion in R and G"),
        a if a.is_id() => (format!("gbuf_rd_id_colour({m})"), "the ID hashed to a colour"),
        _ => (format!("vec4({m}, {m}, {m}, 1.0)"), "the value as grey"),
    };
    let id = a.is_id();
    let srgb = format.components().iter().any(|c| c.kind == ComponentKind::Srgb);
    let mut o = String::new();
    o.push_str("#version 450 core\n");
    let _ = writeln!(
        o,
        "// RenderDoc custom display shader: {} of target {target:?} ({format}) of gbuf layout {:?}, shown as {what}.\n\
         // Generated by gbuf {} (`gbuf layouts {} --emit renderdoc`). Put it in a folder listed in RenderDoc's\n\
         // Settings > Texture Viewer > Custom shader directories (or ~/.local/share/qrenderdoc/), open the target in\n\
         // the texture viewer and pick it in the Custom Shader box. The sample selector picks the MSAA sample;\n\
         // \"average value\" shows the mean of the decoded samples{}.\n",
        a.name(),
        layout.name(),
        env!("CARGO_PKG_VERSION"),
        layout.name(),
        if id { " (for IDs: sample 0)" } else { "" }
    );
    o.push_str(base);
    o.push_str(&inputs(is_uint(format)));
    o.push_str(CODES);
    if srgb {
        o.push_str(SRGB_CODE);
    }
    if id {
        o.push_str(ID_COLOUR);
    }
    o.push('\n');
    o.push_str(words);
    let _ = write!(
        o,
        "\n// The attribute as shown: gbuf's decode of the target's words (the other targets' words are not read).\n\
         vec4 gbuf_rd_show(uvec4 w) {{\n    GbufSurface s = gbuf_unpack({args});\n    return {show};\n}}\n\
         \nvoid main() {{\n    int selected = RD_SelectedSample(); // the sample, or −N for \"average value\"\n    \
         int n = gbuf_rd_samples();\n    if (selected >= 0 || {id}) {{\n        \
         gbuf_rd_out = gbuf_rd_show(gbuf_rd_words(gbuf_rd_fetch(clamp(selected, 0, n - 1))));\n        return;\n    }}\n    \
         vec4 sum = vec4(0.0);\n    for (int k = 0; k < n; ++k) sum += gbuf_rd_show(gbuf_rd_words(gbuf_rd_fetch(k)));\n    \
         gbuf_rd_out = sum / float(n);\n}}\n"
    );
    o
}

/// RenderDoc's buffer-viewer format of target `ti`: its fields as bitfields of the 32-bit words (a field across
/// two words as a 64-bit `ulong` bitfield), gaps as unnamed bitfields, so one struct is one texel.
fn buffer_format(layout: &Layout, ti: usize) -> String {
    let format = layout.formats()[ti];
    // A field split at the format's components (an oct normal in RGB10A2 is `normal_r : 10; normal_g : 10`).
    let mut fields: Vec<(u32, u32, String)> = Vec::new();
    for f in layout.fields().iter().filter(|f| f.target == ti) {
        let name = ident(&f.slot.name());
        let parts = format.components_in(f.offset, f.bits);
        if parts.len() <= 1 {
            fields.push((f.offset, f.bits, name));
            continue;
        }
        for c in parts {
            let (lo, hi) = (c.offset.max(f.offset), (c.offset + c.bits).min(f.offset + f.bits));
            fields.push((lo, hi - lo, format!("{name}_{}", c.name)));
        }
    }
    fields.sort_by_key(|f| f.0);
    let total = format.bits();
    let wide = fields.iter().any(|&(o, b, _)| o / 32 != (o + b - 1) / 32);
    let unit = if wide { 64 } else { 32 };
    let ty = if wide { "ulong" } else { "uint" };
    // Unnamed bitfields for the bits [from, to), one per unit so that none crosses a word.
    let pad = |from: u32, to: u32, s: &mut String| {
        let mut x = from;
        while x < to {
            let end = to.min((x / unit + 1) * unit);
            let _ = write!(s, "{ty} : {}; ", end - x);
            x = end;
        }
    };
    let mut s = String::new();
    let mut at = 0;
    let mut names: Vec<String> = Vec::new();
    for (o, b, n) in fields {
        pad(at, o, &mut s);
        let mut name = n.clone();
        let mut k = 2;
        while names.contains(&name) {
            name = format!("{n}_{k}");
            k += 1;
        }
        names.push(name.clone());
        let whole_float =
            format.components().iter().any(|c| c.offset == o && c.bits == 32 && c.kind == ComponentKind::Float);
        if whole_float && b == 32 && !wide {
            let _ = write!(s, "float {name}; ");
        } else {
            let _ = write!(s, "{ty} {name} : {b}; ");
        }
        at = o + b;
    }
    pad(at, total, &mut s);
    s.trim_end().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_layout_gives_views_or_says_why_not() {
        for layout in Layout::builtins() {
            match views(&layout, Some((0.1, 100.0))) {
                Ok(v) => {
                    assert!(!v.views.is_empty() || !v.skipped.is_empty(), "{}", layout.name());
                    for view in &v.views {
                        assert!(view.code.starts_with("#version 450 core\n"), "{}", view.file);
                        assert!(view.code.contains("RD_SelectedSample()") && view.code.contains("gbuf_unpack("));
                        assert!(!view.code.contains("uniform float gbuf_znear"), "{}", view.file);
                    }
                    // One format string per target, its bit widths summing to the texel.
                    for ((name, f), ti) in v.buffer_formats.iter().zip(0..) {
                        let bits: u32 = f
                            .split(';')
                            .filter(|d| !d.trim().is_empty())
                            .map(|d| match d.rsplit_once(':') {
                                Some((_, b)) => b.trim().parse::<u32>().unwrap(),
                                None => 32, // `float name`
                            })
                            .sum();
                        assert_eq!(bits, layout.formats()[ti].bits(), "{}: {name}: {f}", layout.name());
                    }
                }
                Err(e) => assert!(layout.indirection().is_some(), "{}: {e}", layout.name()),
            }
        }
    }

    #[test]
    fn a_depth_codec_that_needs_the_camera_asks_for_it() {
        let l = Layout::by_name("fat-20").unwrap();
        if shader::emit(&l, Lang::Glsl).unwrap().contains("uniform float gbuf_znear") {
            let e = views(&l, None).unwrap_err().to_string();
            assert!(e.contains("--znear") && e.contains("--zfar"), "{e}");
        }
    }
}
