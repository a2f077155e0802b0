//! A layout as shader code: GLSL 4.50 (and HLSL and WGSL from the same text) that packs a surface into the
//! layout's render-target words and unpacks them, bit for bit what [`Layout::pack`] and [`Layout::unpack`] do
//! (docs/SHADERS.md has the ABI; the proof runs the code on Mesa's llvmpipe in `tests/shader_glsl.rs`).
//!
//! Every codec states its arithmetic as a [`Recipe`]; this module writes one function per field from it,
//! operation for operation as the CPU codec does (f64 where it uses f64, `precise` so no multiply-add is fused,
//! integer code for half floats and the rounding rule), so the GPU reproduces the CPU's bits rather than
//! approximating them. HLSL is the text through a token map; WGSL through [`super::wgsl`], with a software double
//! and fences for `precise`. Three codecs use the driver's transcendentals and are measured instead of exact
//! (`spherical`, `lambert-sphere`, `log2-unorm` over 12 bits: docs/SHADERS.md, "Not bit-exact"); material tables
//! over [`MAX_TABLE_BITS`] are refused with an error naming them.

use super::coder::Slot;
use super::{Field, Layout};
use crate::codec::depth::DepthStorage;
use crate::codec::normal::{PlaneMap, Quant};
use crate::codec::Recipe;
use crate::error::{Error, Result};
use crate::gbuffer::Attribute;
use std::fmt::Write as _;

/// The shading languages gbuf can emit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lang {
    /// GLSL 4.50 (core; needs `double`, core since 4.00).
    Glsl,
    /// HLSL, Shader Model 6 (`double` needs the device's double-precision support, as in D3D12's
    /// `DoublePrecisionFloatShaderOps`).
    Hlsl,
    /// WGSL (WebGPU). WGSL has no `f64`: the codecs gbuf computes in double run on a software double
    /// (`f64.wgsl`), bit for bit the same.
    Wgsl,
}

crate::named!(Lang: "shading language" {
    Glsl => "glsl",
    Hlsl => "hlsl",
    Wgsl => "wgsl",
});

/// The bind group of the uniforms the WGSL declares (`@group(3)`: camera at binding 0, material table at 1);
/// WebGPU guarantees four groups, and engines tend to fill them from 0.
pub const WGSL_GROUP: u32 = 3;

/// GLSL → HLSL for the code this module writes (a closed vocabulary, so a token map suffices): vector types,
/// bit casts, `lf` double literals as casts, constant arrays as initialiser lists.
fn to_hlsl(glsl: &str) -> String {
    const WORDS: [(&str, &str); 9] = [
        // GLSL's two-argument atan (the only one this code uses).
        ("atan", "atan2"),
        ("vec2", "float2"),
        ("vec3", "float3"),
        ("vec4", "float4"),
        ("uvec2", "uint2"),
        ("uvec3", "uint3"),
        ("uvec4", "uint4"),
        ("floatBitsToUint", "asuint"),
        ("uintBitsToFloat", "asfloat"),
    ];
    let mut out = String::with_capacity(glsl.len() + glsl.len() / 8);
    for line in glsl.lines() {
        // `const uint X[N] = uint[N](a, b);` → `static const uint X[N] = { a, b };`
        let line = match line.strip_prefix("const uint ") {
            Some(rest) if rest.contains("] = uint[") => {
                let (head, tail) = rest.split_once(" = ").unwrap_or((rest, ""));
                let body = tail.split_once('(').map_or("", |x| x.1).trim_end_matches(");");
                format!("static const uint {head} = {{ {body} }};")
            }
            _ => line.to_string(),
        };
        let b = line.as_bytes();
        let mut i = 0;
        while i < b.len() {
            if b[i].is_ascii_alphabetic() || b[i] == b'_' {
                let start = i;
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                    i += 1;
                }
                let w = &line[start..i];
                out.push_str(WORDS.iter().find(|(g, _)| *g == w).map_or(w, |(_, h)| h));
            } else if b[i].is_ascii_digit() {
                let start = i;
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'.') {
                    i += 1;
                }
                let n = &line[start..i];
                match n.strip_suffix("lf") {
                    Some(v) => {
                        let _ = write!(out, "((double){v})");
                    }
                    None => out.push_str(n),
                }
            } else {
                // Copy everything else (operators, spaces, UTF-8 in comments) up to the next token unchanged.
                let start = i;
                i += 1;
                while i < b.len() && !(b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                    i += 1;
                }
                out.push_str(&line[start..i]);
            }
        }
        out.push('\n');
    }
    out
}

/// Widest material index the emitted table block holds: 2^9 entries of 16 bytes plus their IDs fit the 16 KiB
/// every API guarantees for a uniform block.
pub const MAX_TABLE_BITS: u32 = 9;

/// The second entry point per target, for engines that write floats to UNORM/SNORM/sRGB/float render targets and
/// let the hardware convert: `vec4 gbuf_target_<target>(GbufSurface s)` returns, per component of the format, the
/// float that the D3D/GL conversion rules (round to nearest; sRGB encode; float → half round to nearest even) store
/// as exactly the bits `gbuf_pack_<target>` gives: `code / (2^k − 1)` for unorm, `code / (2^(k−1) − 1)` for snorm,
/// the sRGB-decoded value for sRGB, the value the bits encode for floats. Not emitted for integer, depth,
/// shared-exponent and `rgb8` targets (no float path a render target offers).
fn float_targets(layout: &Layout) -> String {
    use super::formats::ComponentKind;
    let mut o = String::new();
    let mut srgb_table = false;
    for (ti, t) in layout.spec().targets.iter().enumerate() {
        let format = layout.formats()[ti];
        let comps = format.components();
        let ok = !format.is_depth()
            && format != super::Format::Rgb8
            && comps.iter().all(|c| {
                matches!(
                    c.kind,
                    ComponentKind::Unorm | ComponentKind::Snorm | ComponentKind::Srgb | ComponentKind::Float
                )
            });
        if !ok {
            let _ = writeln!(
                o,
                "\n// (No gbuf_target_{}: a {format} target is written as bits, not floats.)",
                ident(&t.name)
            );
            continue;
        }
        let mut vals = Vec::new();
        for c in comps {
            let get = format!("gbuf_get(w, {}u, {}u)", c.offset, c.bits);
            vals.push(match (c.kind, c.bits) {
                (ComponentKind::Unorm, k) => format!("float({get}) / {}.0", (1u64 << k) - 1),
                (ComponentKind::Snorm, k) => {
                    format!("max(float(int({get} << {sh}u) >> {sh}) / {}.0, -1.0)", (1u64 << (k - 1)) - 1, sh = 32 - k)
                }
                (ComponentKind::Srgb, _) => {
                    srgb_table = true;
                    format!("uintBitsToFloat(gbuf_srgb8_D[{get}])")
                }
                (_, 32) => format!("uintBitsToFloat({get})"),
                (_, 16) => format!("gbuf_f16_value({get})"),
                (_, k) => format!("gbuf_ufloat_value({get}, {}u)", k - 5),
            });
        }
        while vals.len() < 4 {
            vals.push("0.0".into());
        }
        let _ = writeln!(
            o,
            "\n// Target {:?} as floats for the hardware's conversion to {format} (see docs/SHADERS.md).\n\
             vec4 gbuf_target_{}(GbufSurface s) {{\n    uvec4 w = gbuf_pack_{}(s);\n    precise vec4 v = vec4({});\n    return v;\n}}",
            t.name,
            ident(&t.name),
            ident(&t.name),
            vals.join(", ")
        );
    }
    let mut head = String::new();
    if srgb_table {
        if let Some(Recipe::ColorSrgb8 { decoded, .. }) = crate::codec::color_codec("srgb8").and_then(|c| c.recipe()) {
            let de: Vec<String> = decoded.iter().map(|v| format!("{:#010x}u", v.to_bits())).collect();
            let _ = writeln!(head, "\n// The linear value of each sRGB code (gbuf's srgb8 table).\nconst uint gbuf_srgb8_D[256] = uint[256]({});", de.join(", "));
        }
    }
    head + &o
}

/// The material table block and the index lookup, for a layout with indirection.
fn material_block(layout: &Layout, lang: Lang) -> (String, String) {
    let Some(ind) = layout.indirection() else { return (String::new(), String::new()) };
    let n = 1u32 << ind.bits;
    let params: Vec<&str> = ind.parameters.iter().map(|a| a.name()).collect();
    let decl = match lang {
        Lang::Glsl => format!(
            "layout(std140) uniform GbufMaterials {{\n    vec4 gbuf_material_table[{n}];\n    uvec4 gbuf_material_ids[{}];\n    \
             uint gbuf_material_count;\n    uint gbuf_material_by_id;\n}};\n",
            n.div_ceil(4)
        ),
        Lang::Hlsl => format!(
            "cbuffer GbufMaterials {{\n    float4 gbuf_material_table[{n}];\n    uint4 gbuf_material_ids[{}];\n    \
             uint gbuf_material_count;\n    uint gbuf_material_by_id;\n}};\n",
            n.div_ceil(4)
        ),
        Lang::Wgsl => format!(
            "struct GbufMaterials {{\n    table: array<vec4<f32>, {n}>,\n    ids: array<vec4<u32>, {}>,\n    \
             count: u32,\n    by_id: u32,\n}}\n@group({WGSL_GROUP}) @binding(1) var<uniform> gbuf_materials: GbufMaterials;\n",
            n.div_ceil(4)
        ),
    };
    let cmp: Vec<String> = params.iter().enumerate().map(|(i, p)| format!("e[{i}] == s.{p}")).collect();
    let dist: Vec<String> =
        params.iter().enumerate().map(|(i, p)| format!("(e[{i}] - s.{p}) * (e[{i}] - s.{p})")).collect();
    let comment = format!(
        "\n// The material table (material-ID indirection, {bits} index bits): the engine fills it with `gbuf pack`'s\n\
         // material_table.json. gbuf_material_table[k] holds entry k's parameters in the layout's order ({plist}),\n\
         // gbuf_material_ids the engine material ID of each entry (four per element, key `material-id`),\n\
         // gbuf_material_count the entries, gbuf_material_by_id 1 when the table is keyed by material ID\n\
         // (WGSL: gbuf_materials.table, .ids, .count, .by_id).\n",
        bits = ind.bits,
        plist = params.join(", "),
    );
    let code = format!(
        "\n// The entry a surface packs: its material ID's entry (key `material-id`), else the entry whose parameters it\n\
         // has (key `palette`; the nearest when the palette was clustered, which need not be gbuf's assignment).\n\
         uint gbuf_material_index(GbufSurface s) {{\n    uint best = 0u;\n    float best_d = 3.0e38;\n    \
         for (uint k = 0u; k < gbuf_material_count; k++) {{\n        \
         if (gbuf_material_by_id != 0u) {{ if (gbuf_material_ids[k >> 2u][k & 3u] == s.material_id) return k; continue; }}\n        \
         vec4 e = gbuf_material_table[k];\n        if ({exact}) return k;\n        \
         precise float d = {d};\n        if (d < best_d) {{ best_d = d; best = k; }}\n    }}\n    return best;\n}}\n",
        exact = cmp.join(" && "),
        d = dist.join(" + ")
    );
    (comment + &decl, code)
}

/// The attributes of `GbufSurface`, in ABI order, with their GLSL types.
const SURFACE: [(&str, &str); 12] = [
    ("depth", "float"),
    ("position", "vec3"),
    ("normal", "vec3"),
    ("albedo", "vec3"),
    ("specular", "float"),
    ("specular_power", "float"),
    ("roughness", "float"),
    ("metallic", "float"),
    ("motion", "vec2"),
    ("material_id", "uint"),
    ("object_id", "uint"),
    ("primitive_id", "uint"),
];

/// The helpers every emitted file starts with (rounding, half floats, IEEE singles, bit fields).
const HELPERS: &str = r"
// ---- helpers (gbuf's rounding and conversions, integer-exact) ----

// Round half away from zero of a value clamped to ±2^24 (NaN → 0): truncate, then step by the fraction, which
// v − trunc(v) gives exactly. The rule of gbuf's codecs (and D3D's float → UNORM/SNORM conversion).
int gbuf_round(float v) {
    precise float c = isnan(v) ? 0.0 : clamp(v, -16777216.0, 16777216.0);
    int t = int(c);
    precise float f = c - float(t);
    return t + int(f >= 0.5) - int(f <= -0.5);
}

// IEEE single → half bits, round to nearest even; beyond the range → ±Inf, NaN → a quiet NaN.
uint gbuf_f16_bits(float v) {
    uint b = floatBitsToUint(v);
    uint sign = (b >> 16) & 0x8000u;
    uint a = b & 0x7fffffffu;
    if (a > 0x7f800000u) return sign | 0x7e00u;
    if (a >= 0x477ff000u) return sign | 0x7c00u;
    if (a >= 0x38800000u) {
        uint r = a - 0x38000000u;
        return sign | ((r + 0xfffu + ((r >> 13) & 1u)) >> 13);
    }
    uint e = a >> 23;
    if (e < 102u) return sign;
    uint m = (a & 0x7fffffu) | 0x800000u;
    uint s = 126u - e;
    uint q = m >> s;
    uint rest = m & ((1u << s) - 1u);
    uint half_ = 1u << (s - 1u);
    q += uint(rest > half_ || (rest == half_ && (q & 1u) == 1u));
    return sign | q;
}

// Half bits → a finite single, exactly: NaN → 0, ±Inf → ±65504.
float gbuf_f16_value(uint h) {
    uint sign = (h & 0x8000u) << 16;
    uint e = (h >> 10) & 0x1fu;
    uint m = h & 0x3ffu;
    if (e == 31u) return m != 0u ? 0.0 : uintBitsToFloat(sign | 0x477fe000u);
    if (e == 0u) {
        precise float v = float(m) * 5.9604644775390625e-8;
        return sign != 0u ? -v : v;
    }
    return uintBitsToFloat(sign | ((e + 112u) << 23) | (m << 13));
}

// A single's bits with NaN → 0 and ±Inf → ±f32::MAX (gbuf's f32 codecs), in the integer domain.
uint gbuf_f32_clean(uint b) {
    uint a = b & 0x7fffffffu;
    if (a > 0x7f800000u) return 0u;
    if (a == 0x7f800000u) return (b & 0x80000000u) | 0x7f7fffffu;
    return b;
}
uint gbuf_f32_bits(float v) {
    return gbuf_f32_clean(floatBitsToUint(v));
}
float gbuf_f32_value(uint b) {
    return uintBitsToFloat(gbuf_f32_clean(b));
}

// An unsigned small float (R11G11B10F: 5-bit exponent, bias 15, `m` mantissa bits, no sign) of a single: the
// exponent from the bits, the mantissa scaled by ldexp (exact) and rounded half away from zero, a carry into
// the next binade; NaN, zero and negatives → 0, beyond the range → the largest value.
uint gbuf_ufloat_bits(float v, uint m) {
    if (isnan(v) || v <= 0.0) return 0u;
    precise float c = min(v, uintBitsToFloat(((30u + 112u) << 23) | (((1u << m) - 1u) << (23u - m))));
    int e = max(int(floatBitsToUint(c) >> 23) - 127, -14);
    uint mant = uint(gbuf_round(ldexp(c, int(m) - e)));
    if (mant >= (2u << m)) {
        mant = mant >> 1;
        e = e + 1;
    }
    if (mant < (1u << m)) return mant;
    return (uint(e + 15) << m) | (mant - (1u << m));
}

// An unsigned small float's value, exactly; exponent 31 (Inf/NaN patterns) reads as the largest value.
float gbuf_ufloat_value(uint c, uint m) {
    uint e = c >> m;
    uint f = c & ((1u << m) - 1u);
    if (e == 0u) return ldexp(float(f), -14 - int(m));
    if (e >= 31u) return uintBitsToFloat(((30u + 112u) << 23) | (((1u << m) - 1u) << (23u - m)));
    return uintBitsToFloat(((e + 112u) << 23) | (f << (23u - m)));
}

// Clamp to [lo, hi] with NaN → clamp(0) (gbuf's `clean`).
float gbuf_clean(float v, float lo, float hi) {
    return isnan(v) ? clamp(0.0, lo, hi) : clamp(v, lo, hi);
}

// The field of `bits` bits at bit `offset` of a texel's little-endian 32-bit words (it may span two words).
uvec4 gbuf_put(uvec4 w, uint offset, uint bits, uint code) {
    uint i = offset >> 5u;
    uint s = offset & 31u;
    code &= bits >= 32u ? 0xffffffffu : ((1u << bits) - 1u);
    w[i] |= code << s;
    if (s + bits > 32u) w[i + 1u] |= code >> (32u - s);
    return w;
}
uint gbuf_get(uvec4 w, uint offset, uint bits) {
    uint i = offset >> 5u;
    uint s = offset & 31u;
    uint v = w[i] >> s;
    if (s + bits > 32u) v |= w[i + 1u] << (32u - s);
    return bits >= 32u ? v : v & ((1u << bits) - 1u);
}

// A unit vector as gbuf's normal codecs see it: NaN → +Z, infinite components carry the direction, divided by
// the largest magnitude first, then by the length.
vec3 gbuf_sanitize(vec3 n) {
    bool nan_ = isnan(n.x) || isnan(n.y) || isnan(n.z);
    bool finite = !(isinf(n.x) || isinf(n.y) || isinf(n.z)) && !nan_;
    precise vec3 d = vec3(isinf(n.x) ? (n.x > 0.0 ? 1.0 : -1.0) : 0.0, isinf(n.y) ? (n.y > 0.0 ? 1.0 : -1.0) : 0.0,
        isinf(n.z) ? (n.z > 0.0 ? 1.0 : -1.0) : 0.0);
    precise vec3 u = finite ? n : d;
    precise float m = max(max(abs(u.x), abs(u.y)), abs(u.z));
    precise vec3 v = vec3(u.x / m, u.y / m, u.z / m);
    precise float len = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    precise vec3 r = vec3(v.x / len, v.y / len, v.z / len);
    return (nan_ || m == 0.0) ? vec3(0.0, 0.0, 1.0) : r;
}

// Normalise a decoded vector; a zero or non-finite one reads as +Z.
vec3 gbuf_finish(vec3 v) {
    precise float l2 = v.x * v.x + v.y * v.y + v.z * v.z;
    precise float l = sqrt(l2);
    precise vec3 u = vec3(v.x / l, v.y / l, v.z / l);
    return (l2 > 0.0 && !isinf(l2) && !isnan(l2)) ? u : vec3(0.0, 0.0, 1.0);
}

float gbuf_sign_not_zero(float v) {
    return v >= 0.0 ? 1.0 : -1.0;
}

// Octahedral map (Meyer et al. 2010; Cigolle et al. 2014, `float32x3_to_oct` / `oct_to_float32x3`).
vec2 gbuf_oct_project(vec3 n) {
    precise float l1 = abs(n.x) + abs(n.y) + abs(n.z);
    precise vec2 p = vec2(n.x / l1, n.y / l1);
    precise vec2 f = vec2((1.0 - abs(p.y)) * gbuf_sign_not_zero(p.x), (1.0 - abs(p.x)) * gbuf_sign_not_zero(p.y));
    return n.z >= 0.0 ? p : f;
}
// The hemisphere map: x and y as they are, z = √max(1 − x² − y², 0) (z ≥ 0 only).
vec2 gbuf_hemi_project(vec3 n) {
    return vec2(n.x, n.y);
}
vec3 gbuf_hemi_unproject(vec2 q) {
    precise vec2 p = clamp(q, vec2(-1.0, -1.0), vec2(1.0, 1.0));
    precise float l2 = p.x * p.x + p.y * p.y;
    precise float z = sqrt(max(1.0 - l2, 0.0));
    return vec3(p, z);
}

// CryEngine 3's spheremap (Mittring 2009, Finding Next Gen): g = normalize(n.xy) · √(n.z·0.5 + 0.5).
// normalize() with +X where it is undefined, dividing by the larger magnitude first.
vec2 gbuf_normalize2_or_x(vec2 v) {
    precise float m = max(abs(v.x), abs(v.y));
    precise vec2 u = vec2(v.x / m, v.y / m);
    precise float len = sqrt(u.x * u.x + u.y * u.y);
    precise vec2 r = vec2(u.x / len, u.y / len);
    return (isnan(m) || m <= 0.0 || isinf(m)) ? vec2(1.0, 0.0) : r;
}
vec2 gbuf_spheremap_project(vec3 n) {
    precise float t = n.z * 0.5 + 0.5;
    precise float s = sqrt(max(t, 0.0));
    precise vec2 d = gbuf_normalize2_or_x(vec2(n.x, n.y));
    return vec2(d.x * s, d.y * s);
}
vec3 gbuf_spheremap_unproject(vec2 g) {
    precise float l2 = g.x * g.x + g.y * g.y;
    precise float z = clamp(l2 * 2.0 - 1.0, -1.0, 1.0);
    precise float r = sqrt(max(1.0 - z * z, 0.0));
    precise vec2 d = gbuf_normalize2_or_x(g);
    precise vec3 v = vec3(d.x * r, d.y * r, z);
    return (g.x == 0.0 && g.y == 0.0) ? vec3(0.0, 0.0, -1.0) : v;
}

// Lambert azimuthal equal-area centred on +Z (Snyder 1987, p. 182; Pranckevičius 2009, Compact Normal Storage,
// method #4), scaled to the unit disc: n.xy/√(2(1+z)) on z ≥ 0, normalize(n.xy)·√((1−z)/2) below.
vec2 gbuf_lambert_project(vec3 n) {
    precise float k = sqrt(2.0 * (1.0 + n.z));
    precise vec2 a = vec2(n.x / k, n.y / k);
    precise float r = sqrt(max((1.0 - n.z) * 0.5, 0.0));
    precise vec2 d = gbuf_normalize2_or_x(vec2(n.x, n.y));
    precise vec2 b = vec2(d.x * r, d.y * r);
    return n.z >= 0.0 ? a : b;
}
vec3 gbuf_lambert_unproject(vec2 q) {
    precise float s = min(q.x * q.x + q.y * q.y, 1.0);
    precise float k = 2.0 * sqrt(1.0 - s);
    precise float z = 1.0 - 2.0 * s;
    return vec3(q.x * k, q.y * k, z);
}

// The spheremap as ISPC's `deferred` example stores it (kernels.ispc, after Mittring): g·0.5 + 0.5, decoded by
// its own closed form.
vec2 gbuf_spheremap_ispc_project(vec3 n) {
    precise vec2 g = gbuf_spheremap_project(n);
    precise vec2 e = vec2(g.x * 0.5 + 0.5, g.y * 0.5 + 0.5);
    return e;
}
vec3 gbuf_spheremap_ispc_unproject(vec2 e) {
    precise float f = (e.x - e.x * e.x) + (e.y - e.y * e.y);
    precise float m = sqrt(max(4.0 * f - 1.0, 0.0));
    precise vec3 v = vec3(m * (4.0 * e.x - 2.0), m * (4.0 * e.y - 2.0), 3.0 - 8.0 * f);
    return v;
}

// Stereographic projection from −Z (Snyder 1987, p. 154; Pranckevičius 2009, method #7): n.xy/(1+z) divided by
// the scale; below the equator (1−z)/|xy| along normalize(xy), accurate near −Z; then moved radially onto the
// square |p| ≤ limit.
vec2 gbuf_stereo_project(vec3 n, float scale, float limit) {
    precise float r = sqrt(n.x * n.x + n.y * n.y);
    precise float k = (1.0 + n.z) * scale;
    precise vec2 front = vec2(n.x / k, n.y / k);
    precise vec2 d = gbuf_normalize2_or_x(vec2(n.x, n.y));
    precise float t = min((1.0 - n.z) / r / scale, 65504.0);
    precise vec2 back = vec2(d.x * t, d.y * t);
    vec2 p = n.z >= 0.0 ? front : (r > 0.0 ? back : vec2(65504.0, 0.0));
    precise float m = max(abs(p.x), abs(p.y));
    precise float c = limit / m;
    precise vec2 q = vec2(p.x * c, p.y * c);
    return m > limit ? q : p;
}
vec3 gbuf_stereo_unproject(vec2 q, float scale) {
    precise vec2 p = vec2(q.x * scale, q.y * scale);
    precise float r2 = p.x * p.x + p.y * p.y;
    precise float d = 1.0 + r2;
    precise vec3 v = vec3(2.0 * p.x / d, 2.0 * p.y / d, (1.0 - r2) / d);
    return (isinf(r2) || isnan(r2)) ? vec3(0.0, 0.0, -1.0) : v;
}

// The octahedral fold shared by the -sphere maps: a point (a, b) of the first quadrant's diamond, its signs and
// hemisphere, to the square (the lower hemisphere reflected across the diamond's edge), and back.
vec2 gbuf_diamond_to_square(float a, float b, float sx, float sy, bool lower) {
    precise vec2 l = vec2(sx * (1.0 - b), sy * (1.0 - a));
    precise vec2 u = vec2(sx * a, sy * b);
    return lower ? l : u;
}
// (a, b, sign x, sign y) of a square point; gbuf_square_lower tells the hemisphere.
vec4 gbuf_square_to_diamond(vec2 q) {
    vec2 p = clamp(q, vec2(-1.0, -1.0), vec2(1.0, 1.0));
    precise float ax = abs(p.x);
    precise float ay = abs(p.y);
    bool lower = ax + ay > 1.0;
    precise vec2 l = vec2(1.0 - ay, 1.0 - ax);
    vec2 ab = lower ? l : vec2(ax, ay);
    return vec4(ab.x, ab.y, gbuf_sign_not_zero(p.x), gbuf_sign_not_zero(p.y));
}
bool gbuf_square_lower(vec2 q) {
    vec2 p = clamp(q, vec2(-1.0, -1.0), vec2(1.0, 1.0));
    precise float s = abs(p.x) + abs(p.y);
    return s > 1.0;
}

// Lambert equal-area of each hemisphere on the diamond: radius |xy|/√(1+|z|), the azimuth as the split of the
// diamond's L1 radius (atan2; decoded with sin: the driver's, not bit-exact, see docs/SHADERS.md).
vec2 gbuf_lambert_sphere_project(vec3 n) {
    precise float t = sqrt(n.x * n.x + n.y * n.y) / sqrt(1.0 + abs(n.z));
    float w = atan(abs(n.y), abs(n.x));
    precise float s = min(w * 0.636619746685028076, 1.0);
    precise float a = t * (1.0 - s);
    precise float b = t * s;
    return gbuf_diamond_to_square(a, b, gbuf_sign_not_zero(n.x), gbuf_sign_not_zero(n.y), n.z < 0.0);
}
vec3 gbuf_lambert_sphere_unproject(vec2 q) {
    vec4 d = gbuf_square_to_diamond(q);
    bool lower = gbuf_square_lower(q);
    precise float t = min(d.x + d.y, 1.0);
    precise float fa = d.x / t;
    precise float fb = d.y / t;
    float ca = t > 0.0 ? fa : 0.0;
    float cb = t > 0.0 ? fb : 0.0;
    precise float ea = ca * 1.57079637050628662;
    precise float eb = cb * 1.57079637050628662;
    float c = sin(ea);
    float sn = sin(eb);
    precise float t2 = t * t;
    precise float r = t * sqrt(2.0 - t2);
    precise float z = 1.0 - t2;
    precise vec3 v = vec3(d.z * r * c, d.w * r * sn, lower ? -z : z);
    return v;
}

// Stereographic of each hemisphere on the diamond: radius |xy|/(1+|z|) along the L1 direction of (|x|, |y|).
vec2 gbuf_stereo_sphere_project(vec3 n) {
    precise float ax = abs(n.x);
    precise float ay = abs(n.y);
    precise float l1 = ax + ay;
    precise float t = sqrt(n.x * n.x + n.y * n.y) / (1.0 + abs(n.z));
    precise float kk = t / l1;
    float k = l1 > 0.0 ? kk : 0.0;
    precise float a = ax * k;
    precise float b = ay * k;
    return gbuf_diamond_to_square(a, b, gbuf_sign_not_zero(n.x), gbuf_sign_not_zero(n.y), n.z < 0.0);
}
vec3 gbuf_stereo_sphere_unproject(vec2 q) {
    vec4 d = gbuf_square_to_diamond(q);
    bool lower = gbuf_square_lower(q);
    precise float t = min(d.x + d.y, 1.0);
    precise float rr = sqrt(d.x * d.x + d.y * d.y);
    precise float kk = 2.0 * t / rr;
    float k = rr > 0.0 ? kk : 0.0;
    precise float z = 1.0 - t * t;
    precise vec3 v = vec3(d.z * d.x * k, d.w * d.y * k, lower ? -z : z);
    return v;
}

// Spherical coordinates: θ/π and (φ + π)/2π; decoded with sin and cos, the south pole snapped to −Z and v = 1
// read as v = 0. atan, sin and cos are the driver's: not bit-exact (docs/SHADERS.md, Not bit-exact).
vec2 gbuf_spherical_project(vec3 n) {
    precise float r = sqrt(n.x * n.x + n.y * n.y);
    float theta = atan(r, n.z);
    float phi = atan(n.y, n.x);
    precise vec2 p = vec2(theta / 3.14159274101257324, (phi + 3.14159274101257324) / 6.28318548202514648);
    return p;
}
vec3 gbuf_spherical_unproject(vec2 p) {
    precise float theta = max(p.x, 0.0) * 3.14159274101257324;
    float v = p.y >= 1.0 ? 0.0 : max(p.y, 0.0);
    precise float phi = v * 6.28318548202514648 - 3.14159274101257324;
    float st = sin(theta);
    float ct = cos(theta);
    precise vec3 d = vec3(st * cos(phi), st * sin(phi), ct);
    return p.x >= 1.0 ? vec3(0.0, 0.0, -1.0) : d;
}

vec3 gbuf_oct_unproject(vec2 q) {
    precise vec2 p = clamp(q, vec2(-1.0, -1.0), vec2(1.0, 1.0));
    precise float z = 1.0 - abs(p.x) - abs(p.y);
    precise vec3 f = vec3((1.0 - abs(p.y)) * gbuf_sign_not_zero(p.x), (1.0 - abs(p.x)) * gbuf_sign_not_zero(p.y), z);
    return z >= 0.0 ? vec3(p, z) : f;
}
";

/// The f64 operations of the codecs that compute in double, one function each, so that WGSL's software double
/// (`f64.wgsl`) stands in for them with the same names. Emitted only when a field needs them: a layout without
/// such a field needs no `double` support from the device.
const F64_HELPERS: &str = r"
// ---- f64 arithmetic (the codecs gbuf computes in double), one function per operation ----
double gbuf_d_from_f32(float v) { return double(v); }
double gbuf_d_from_i32(int v) { return double(v); }
double gbuf_d_from_u32(uint v) { return double(v); }
float gbuf_d_to_f32(double v) { return float(v); }
double gbuf_d_add(double a, double b) { precise double r = a + b; return r; }
double gbuf_d_sub(double a, double b) { precise double r = a - b; return r; }
double gbuf_d_mul(double a, double b) { precise double r = a * b; return r; }
double gbuf_d_div(double a, double b) { precise double r = a / b; return r; }
// clamp() and max() written out: HLSL compilers may resolve those intrinsics to float.
double gbuf_d_clamp(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }
double gbuf_d_max(double a, double b) { return a < b ? b : a; }

// Round half away from zero of a value clamped to ±2^24: truncate, then step by the exact fraction.
int gbuf_d_round(double v) {
    precise double c = gbuf_d_clamp(v, -16777216.0lf, 16777216.0lf);
    int t = int(c);
    precise double f = c - double(t);
    return t + int(f >= 0.5lf) - int(f <= -0.5lf);
}
";

/// IEEE binary64 in software for WGSL (`vec2<u32>` bits; add, sub, mul, div rounding to nearest even,
/// conversions, clamp, gbuf's code rounding): what the f64 codecs use in WGSL, under the names of
/// the GLSL `gbuf_d_*` helpers. Checked against Rust's f64 on llvmpipe (tests/shader_glsl.rs).
pub const F64_WGSL: &str = include_str!("f64.wgsl");

/// What WGSL lacks, as WGSL: NaN and infinity tests on the bits (an implementation may assume neither exists, so
/// `x != x` can fold away).
const WGSL_PRELUDE: &str = r"
fn gbuf_isnan(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7fffffffu) > 0x7f800000u;
}
fn gbuf_isinf(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7fffffffu) == 0x7f800000u;
}
";

/// GLSL float literal with the exact bits of `v` (`uintBitsToFloat(0x…u)` keeps every bit).
fn lit(v: f32) -> String {
    format!("uintBitsToFloat({:#010x}u)", v.to_bits())
}

/// Encode/decode expressions of one quantized coordinate (`Quant`), as GLSL functions named by storage.
fn quant_fns(q: Quant, name: &str, out: &mut String) {
    match q {
        Quant::Snorm(k) => {
            let m = (1u32 << (k - 1)) - 1;
            let _ = write!(
                out,
                "uint {name}_enc(float v) {{ return uint(gbuf_round(clamp(isnan(v) ? 0.0 : v, -1.0, 1.0) * {m}.0)) & {mask}u; }}\n\
                 float {name}_dec(uint c) {{ int s = int((c & {mask}u) << {sh}) >> {sh}; precise float v = float(s) / {m}.0; return max(v, -1.0); }}\n",
                mask = (1u64 << k) - 1,
                sh = 32 - k
            );
        }
        Quant::Unorm(k) => {
            let m = (1u64 << k) - 1;
            let _ = write!(
                out,
                "uint {name}_enc(float v) {{ return uint(gbuf_round(clamp(isnan(v) ? 0.0 : v, 0.0, 1.0) * {m}.0)); }}\n\
                 float {name}_dec(uint c) {{ precise float v = float(c & {m}u) / {m}.0; return v; }}\n"
            );
        }
        Quant::UnormSigned(k) => {
            let m = (1u64 << k) - 1;
            let _ = write!(
                out,
                "// unorm p·0.5 + 0.5 (Cigolle et al. 2014's GLSL; the engines' RGB10A2 normals)\n\
                 uint {name}_enc(float v) {{ precise float t = clamp(isnan(v) ? 0.0 : v, -1.0, 1.0) * 0.5 + 0.5; precise float s = t * {m}.0; return uint(gbuf_round(s)); }}\n\
                 float {name}_dec(uint c) {{ precise float t = float(c & {m}u) / {m}.0; precise float v = t * 2.0 - 1.0; return v; }}\n"
            );
        }
        Quant::F16 => {
            let _ = write!(
                out,
                "uint {name}_enc(float v) {{ return gbuf_f16_bits(clamp(isnan(v) ? 0.0 : v, -65504.0, 65504.0)); }}\n\
                 float {name}_dec(uint c) {{ return gbuf_f16_value(c & 0xffffu); }}\n"
            );
        }
    }
}

/// The GLSL expression of an attribute (or component) of the surface `s`.
fn member(slot: Slot) -> Option<String> {
    Some(match slot {
        Slot::Whole(a) => format!("s.{}", a.name()),
        Slot::Component(a, k) => format!("s.{}.{}", a.name(), ["x", "y", "z"][k]),
        _ => return None,
    })
}

/// A field's codec functions: `uint[] enc(value)` written as `uvec3 <f>_enc(...)` returning component codes, and
/// `<type> <f>_dec(uvec3 codes)`; `k` is each component's width.
struct FieldCode {
    /// Component width in bits and component count.
    k: u32,
    n: u32,
    /// The functions.
    text: String,
    /// Needs `gbuf_znear`/`gbuf_zfar`.
    camera: bool,
    /// Computes in f64 (the `gbuf_d_*` helpers).
    f64: bool,
}

/// The shader code of field `f` from its codec's recipe: one function per family of recipes (IDs, scalars,
/// colours, normals, depth).
fn field_code(f: &Field, recipe: Option<Recipe>, name: &str, layout: &Layout) -> Result<FieldCode> {
    let unsupported = |why: &str| {
        Error::Argument(format!(
            "layout {:?}: field {} ({}): {why}; gbuf emits shader code for every codec of docs/LAYOUTS.md",
            layout.name(),
            f.slot.name(),
            f.codec
        ))
    };
    let code = match (&f.slot, recipe) {
        (Slot::Whole(a), _) if a.is_id() => id_code(f, *a, name),
        (_, Some(r)) => match r {
            Recipe::ScalarUnorm { .. }
            | Recipe::ScalarSnorm { .. }
            | Recipe::ScalarLog2 { .. }
            | Recipe::ScalarF16
            | Recipe::ScalarF32
            | Recipe::ScalarTable { .. } => scalar_code(r, f, name),
            Recipe::ColorUnorm { .. }
            | Recipe::ColorSrgb8 { .. }
            | Recipe::ColorF16
            | Recipe::ColorF32
            | Recipe::ColorR11G11B10F
            | Recipe::ColorRgb9e5 => color_code(r, f, name),
            Recipe::NormalPlanar { .. } | Recipe::NormalOctPrecise { .. } | Recipe::NormalXyz { .. } => {
                normal_code(r, f, name)
            }
            Recipe::DepthLinearF32 | Recipe::DepthLinearF16 | Recipe::DepthPost { .. } => depth_code(r, f, name),
        },
        (_, None) => return Err(unsupported("no shader recipe for this codec yet")),
    };
    Ok(code)
}

/// The shader code of an ID field: its low bits, saturating.
fn id_code(f: &Field, a: Attribute, name: &str) -> FieldCode {
    let mut t = String::new();
    let (k, n) = {
        let m = if f.bits >= 32 { u32::MAX } else { (1u32 << f.bits) - 1 };
        let _ = write!(
            t,
            "// {a}: the low {b} bits, saturating at 2^{b} − 1\n\
                 uvec3 {name}_enc(uint v) {{ return uvec3(min(v, {m}u), 0u, 0u); }}\n\
                 uint {name}_dec(uvec3 c) {{ return c.x; }}\n",
            a = a.name(),
            b = f.bits
        );
        (f.bits, 1)
    };
    FieldCode { k, n, text: t, camera: false, f64: false }
}

/// The shader code of a scalar field from its codec's recipe (one of the `Scalar…` recipes).
fn scalar_code(r: Recipe, f: &Field, name: &str) -> FieldCode {
    let mut t = String::new();
    let camera = false;
    let mut f64 = false;
    let (k, n) = match r {
        Recipe::ScalarUnorm { bits, lo, hi } => {
            f64 = true;
            let m = (1u64 << bits) - 1;
            let _ = write!(
                t,
                "// unorm over [{lo}, {hi}], {bits} bits (f64 so that wide codes round exactly)\n\
                 uvec3 {name}_enc(float v) {{ precise float u = (v - {l}) / ({h} - {l}); precise float c = isnan(v) ? 0.0 : clamp(u, 0.0, 1.0); \
                 return uvec3(uint(gbuf_d_round(gbuf_d_mul(gbuf_d_from_f32(c), gbuf_d_from_u32({m}u)))), 0u, 0u); }}\n\
                 float {name}_dec(uvec3 c) {{ double t = gbuf_d_div(gbuf_d_from_u32(c.x & {m}u), gbuf_d_from_u32({m}u)); precise float w = {h} - {l}; \
                 return gbuf_d_to_f32(gbuf_d_add(gbuf_d_from_f32({l}), gbuf_d_mul(t, gbuf_d_from_f32(w)))); }}\n",
                l = lit(lo),
                h = lit(hi),
            );
            (bits, 1)
        }
        Recipe::ScalarSnorm { bits, range } => {
            f64 = true;
            let m = (1u64 << (bits - 1)) - 1;
            let mask = (1u64 << bits) - 1;
            let _ = write!(
                t,
                "// snorm over [−{range}, {range}], {bits} bits (f64)\n\
                 uvec3 {name}_enc(float v) {{ precise float u = v / {r}; precise float c = isnan(v) ? 0.0 : clamp(u, -1.0, 1.0); \
                 return uvec3(uint(gbuf_d_round(gbuf_d_mul(gbuf_d_from_f32(c), gbuf_d_from_u32({m}u)))) & {mask}u, 0u, 0u); }}\n\
                 float {name}_dec(uvec3 c) {{ int s = int((c.x & {mask}u) << {sh}) >> {sh}; \
                 double q = gbuf_d_max(gbuf_d_div(gbuf_d_from_i32(s), gbuf_d_from_u32({m}u)), gbuf_d_from_i32(-1)); \
                 return gbuf_d_to_f32(gbuf_d_mul(q, gbuf_d_from_f32({r}))); }}\n",
                r = lit(range),
                sh = 32 - bits
            );
            (bits, 1)
        }
        Recipe::ScalarLog2 { bits } => {
            f64 = true;
            let m = (1u64 << bits) - 1;
            let _ = write!(
                t,
                "// specular power as log2(p)/12 in a {bits}-bit unorm (f64 rounding); the driver's log2 and exp2, so\n\
                 // not bit-exact (docs/SHADERS.md, Not bit-exact; up to 12 bits gbuf emits exact tables instead)\n\
                 uvec3 {name}_enc(float v) {{ float p = isnan(v) ? 1.0 : clamp(v, 1.0, 4096.0); float l = log2(p); precise float u = l / 12.0; \
                 float c = isnan(u) ? 0.0 : clamp(u, 0.0, 1.0); \
                 return uvec3(uint(gbuf_d_round(gbuf_d_mul(gbuf_d_from_f32(c), gbuf_d_from_u32({m}u)))), 0u, 0u); }}\n\
                 float {name}_dec(uvec3 c) {{ float t = gbuf_d_to_f32(gbuf_d_div(gbuf_d_from_u32(c.x & {m}u), gbuf_d_from_u32({m}u))); \
                 precise float x = t * 12.0; float p = exp2(x); return clamp(p, 1.0, 4096.0); }}\n"
            );
            (bits, 1)
        }
        Recipe::ScalarF16 => {
            let _ = write!(
                t,
                "uvec3 {name}_enc(float v) {{ return uvec3(gbuf_f16_bits(clamp(isnan(v) ? 0.0 : v, -65504.0, 65504.0)), 0u, 0u); }}\n\
                 float {name}_dec(uvec3 c) {{ return gbuf_f16_value(c.x & 0xffffu); }}\n"
            );
            (16, 1)
        }
        Recipe::ScalarF32 => {
            let _ = write!(
                t,
                "uvec3 {name}_enc(float v) {{ return uvec3(gbuf_f32_bits(v), 0u, 0u); }}\n\
                 float {name}_dec(uvec3 c) {{ return gbuf_f32_value(c.x); }}\n"
            );
            (32, 1)
        }
        Recipe::ScalarTable { bits, lo, hi, nan, thresholds, decoded } => {
            let th: Vec<String> = thresholds.iter().map(|v| format!("{:#010x}u", v.to_bits())).collect();
            let de: Vec<String> = decoded.iter().map(|v| format!("{:#010x}u", v.to_bits())).collect();
            let (n_th, n_de) = (th.len(), de.len());
            let _ = write!(
                t,
                "// {codec}: monotonic, so encode counts the thresholds at or below the value and decode looks the\n\
                 // value up (gbuf's own tables: the bits match without the driver's exp2/log2)\n\
                 const uint {name}_T[{n_th}] = uint[{n_th}]({th});\n\
                 const uint {name}_D[{n_de}] = uint[{n_de}]({de});\n\
                 uvec3 {name}_enc(float v) {{ float c = isnan(v) ? {nan} : clamp(v, {lo}, {hi}); uint k = 0u; \
                 for (uint stride = {top}u; stride > 0u; stride >>= 1) {{ if (k + stride <= {n_th}u && c >= uintBitsToFloat({name}_T[k + stride - 1u])) k += stride; }} \
                 return uvec3(k, 0u, 0u); }}\n\
                 float {name}_dec(uvec3 c) {{ return uintBitsToFloat({name}_D[c.x & {m}u]); }}\n",
                codec = f.codec,
                th = th.join(", "),
                de = de.join(", "),
                nan = lit(nan),
                lo = lit(lo),
                hi = lit(hi),
                top = 1u64 << (bits - 1),
                m = (1u64 << bits) - 1
            );
            (bits, 1)
        }
        other => unreachable!("scalar_code takes the Scalar recipes, not {other:?}"),
    };
    FieldCode { k, n, text: t, camera, f64 }
}

/// The shader code of a colour field from its codec's recipe (one of the `Color…` recipes).
fn color_code(r: Recipe, _f: &Field, name: &str) -> FieldCode {
    let mut t = String::new();
    let camera = false;
    let f64 = false;
    let (k, n) = match r {
        Recipe::ColorUnorm { bits } => {
            let m = (1u64 << bits) - 1;
            let _ = write!(
                t,
                "// linear unorm, {bits} bits per channel\n\
                 uint {name}_q(float v) {{ precise float s = gbuf_clean(v, 0.0, 1.0) * {m}.0; return uint(gbuf_round(s)); }}\n\
                 uvec3 {name}_enc(vec3 v) {{ return uvec3({name}_q(v.x), {name}_q(v.y), {name}_q(v.z)); }}\n\
                 vec3 {name}_dec(uvec3 c) {{ precise vec3 v = vec3(float(c.x & {m}u) / {m}.0, float(c.y & {m}u) / {m}.0, float(c.z & {m}u) / {m}.0); return v; }}\n"
            );
            (bits, 3)
        }
        Recipe::ColorSrgb8 { thresholds, decoded } => {
            let th: Vec<String> = thresholds.iter().map(|v| format!("{:#010x}u", v.to_bits())).collect();
            let de: Vec<String> = decoded.iter().map(|v| format!("{:#010x}u", v.to_bits())).collect();
            let _ = write!(
                t,
                "// srgb8 (IEC 61966-2-1): encode by the smallest value of each code 1..255, decode by the value of each\n\
                 // code; both tables are gbuf's own, so the bits match without a pow().\n\
                 const uint {name}_T[255] = uint[255]({th});\n\
                 const uint {name}_D[256] = uint[256]({de});\n\
                 uint {name}_q(float v) {{ float c = gbuf_clean(v, 0.0, 1.0); uint lo = 0u; \
                 for (uint stride = 128u; stride > 0u; stride >>= 1) {{ if (lo + stride <= 255u && c >= uintBitsToFloat({name}_T[lo + stride - 1u])) lo += stride; }} return lo; }}\n\
                 uvec3 {name}_enc(vec3 v) {{ return uvec3({name}_q(v.x), {name}_q(v.y), {name}_q(v.z)); }}\n\
                 vec3 {name}_dec(uvec3 c) {{ return vec3(uintBitsToFloat({name}_D[c.x & 255u]), uintBitsToFloat({name}_D[c.y & 255u]), uintBitsToFloat({name}_D[c.z & 255u])); }}\n",
                th = th.join(", "),
                de = de.join(", ")
            );
            (8, 3)
        }
        Recipe::ColorF16 => {
            let _ = write!(
                t,
                "uint {name}_q(float v) {{ return gbuf_f16_bits(gbuf_clean(v, -65504.0, 65504.0)); }}\n\
                 uvec3 {name}_enc(vec3 v) {{ return uvec3({name}_q(v.x), {name}_q(v.y), {name}_q(v.z)); }}\n\
                 vec3 {name}_dec(uvec3 c) {{ return vec3(gbuf_f16_value(c.x & 0xffffu), gbuf_f16_value(c.y & 0xffffu), gbuf_f16_value(c.z & 0xffffu)); }}\n"
            );
            (16, 3)
        }
        Recipe::ColorF32 => {
            let _ = write!(
                t,
                "uvec3 {name}_enc(vec3 v) {{ return uvec3(gbuf_f32_bits(v.x), gbuf_f32_bits(v.y), gbuf_f32_bits(v.z)); }}\n\
                 vec3 {name}_dec(uvec3 c) {{ return vec3(gbuf_f32_value(c.x), gbuf_f32_value(c.y), gbuf_f32_value(c.z)); }}\n"
            );
            (32, 3)
        }
        Recipe::ColorR11G11B10F => {
            let _ = write!(
                t,
                "// R11G11B10F: unsigned small floats, 6/6/5 mantissa bits\n\
                 uvec3 {name}_enc(vec3 v) {{ return uvec3(gbuf_ufloat_bits(v.x, 6u) | (gbuf_ufloat_bits(v.y, 6u) << 11) | (gbuf_ufloat_bits(v.z, 5u) << 22), 0u, 0u); }}\n\
                 vec3 {name}_dec(uvec3 c) {{ return vec3(gbuf_ufloat_value(c.x & 0x7ffu, 6u), gbuf_ufloat_value((c.x >> 11) & 0x7ffu, 6u), gbuf_ufloat_value(c.x >> 22, 5u)); }}\n"
            );
            // One 32-bit code (the channels are 11, 11 and 10 bits wide).
            (32, 1)
        }
        Recipe::ColorRgb9e5 => {
            let _ = write!(
                t,
                "// RGB9E5 (EXT_texture_shared_exponent, mantissas rounded to nearest): the shared exponent from the\n\
                 // largest channel's bits, one carry check, the mantissas scaled by ldexp (exact)\n\
                 uvec3 {name}_enc(vec3 v) {{ vec3 c = vec3(gbuf_clean(v.x, 0.0, 65408.0), gbuf_clean(v.y, 0.0, 65408.0), gbuf_clean(v.z, 0.0, 65408.0)); \
                 float maxc = max(max(c.x, c.y), c.z); if (maxc < 2.98023223876953125e-8) return uvec3(0u, 0u, 0u); \
                 int e = max(int(floatBitsToUint(maxc) >> 23) - 127, -16) + 1 + 15; \
                 if (gbuf_round(ldexp(maxc, 24 - e)) == 512) e = e + 1; \
                 uint r = min(uint(gbuf_round(ldexp(c.x, 24 - e))), 511u); uint g = min(uint(gbuf_round(ldexp(c.y, 24 - e))), 511u); \
                 uint b = min(uint(gbuf_round(ldexp(c.z, 24 - e))), 511u); \
                 return uvec3(r | (g << 9) | (b << 18) | (uint(e) << 27), 0u, 0u); }}\n\
                 vec3 {name}_dec(uvec3 c) {{ int e = int(c.x >> 27) - 24; \
                 return vec3(ldexp(float(c.x & 511u), e), ldexp(float((c.x >> 9) & 511u), e), ldexp(float((c.x >> 18) & 511u), e)); }}\n"
            );
            (32, 1)
        }
        other => unreachable!("color_code takes the Color recipes, not {other:?}"),
    };
    FieldCode { k, n, text: t, camera, f64 }
}

/// The shader code of a normal field from its codec's recipe (one of the `Normal…` recipes).
fn normal_code(r: Recipe, f: &Field, name: &str) -> FieldCode {
    let mut t = String::new();
    let camera = false;
    let f64 = false;
    let (k, n) = match r {
        Recipe::NormalPlanar { map, quant } => {
            quant_fns(quant, &format!("{name}_c"), &mut t);
            let (project, unproject) = match map {
                PlaneMap::Oct => ("gbuf_oct_project(u)".to_string(), "gbuf_oct_unproject(p)".to_string()),
                PlaneMap::XyHemi => ("gbuf_hemi_project(u)".into(), "gbuf_hemi_unproject(p)".into()),
                PlaneMap::SpheremapCry => ("gbuf_spheremap_project(u)".into(), "gbuf_spheremap_unproject(p)".into()),
                PlaneMap::Lambert => ("gbuf_lambert_project(u)".into(), "gbuf_lambert_unproject(p)".into()),
                PlaneMap::Spherical => ("gbuf_spherical_project(u)".into(), "gbuf_spherical_unproject(p)".into()),
                PlaneMap::LambertSphere => {
                    ("gbuf_lambert_sphere_project(u)".into(), "gbuf_lambert_sphere_unproject(p)".into())
                }
                PlaneMap::StereoSphere => {
                    ("gbuf_stereo_sphere_project(u)".into(), "gbuf_stereo_sphere_unproject(p)".into())
                }
                PlaneMap::SpheremapIspc => {
                    ("gbuf_spheremap_ispc_project(u)".into(), "gbuf_spheremap_ispc_unproject(p)".into())
                }
                PlaneMap::Stereo { scaled } => {
                    let (scale, limit) = if scaled { (1.7777f32, 1.0f32) } else { (1.0, 65504.0) };
                    (
                        format!("gbuf_stereo_project(u, {}, {})", lit(scale), lit(limit)),
                        format!("gbuf_stereo_unproject(p, {})", lit(scale)),
                    )
                }
            };
            let _ = write!(
                t,
                "// two-component normal ({})\n\
                 uvec3 {name}_enc(vec3 n) {{ vec3 u = gbuf_sanitize(n); vec2 q = {project}; return uvec3({name}_c_enc(q.x), {name}_c_enc(q.y), 0u); }}\n\
                 vec3 {name}_dec(uvec3 c) {{ vec2 p = vec2({name}_c_dec(c.x), {name}_c_dec(c.y)); return gbuf_finish({unproject}); }}\n",
                f.codec
            );
            (quant.bits(), 2)
        }
        Recipe::NormalOctPrecise { k } => {
            let q = Quant::Snorm(k);
            quant_fns(q, &format!("{name}_c"), &mut t);
            let m = (1u32 << (k - 1)) - 1;
            let _ = write!(
                t,
                "// precise octahedral (Cigolle et al. 2014, octP): of the four codes around the projected point, the one\n\
                 // whose decoded normal is nearest (squared chord; the first of equals)\n\
                 vec3 {name}_d2(uint cx, uint cy) {{ return gbuf_finish(gbuf_oct_unproject(vec2({name}_c_dec(cx), {name}_c_dec(cy)))); }}\n\
                 uvec3 {name}_enc(vec3 n) {{ vec3 u = gbuf_sanitize(n); vec2 q = gbuf_oct_project(u); \
                 precise vec2 p = vec2(q.x * {m}.0, q.y * {m}.0); vec2 b = floor(p); float best = 3.0e38; uvec2 bc = uvec2(0u, 0u); \
                 for (uint dy = 0u; dy < 2u; dy++) {{ for (uint dx = 0u; dx < 2u; dx++) {{ \
                 vec2 s = clamp(b + vec2(float(dx), float(dy)), vec2(-{m}.0, -{m}.0), vec2({m}.0, {m}.0)); \
                 uint cx = uint(int(s.x)) & {mask}u; uint cy = uint(int(s.y)) & {mask}u; \
                 vec3 e = {name}_d2(cx, cy) - u; precise float d = e.x * e.x + e.y * e.y + e.z * e.z; \
                 if (d < best) {{ best = d; bc = uvec2(cx, cy); }} }} }} \
                 return uvec3(bc.x, bc.y, 0u); }}\n\
                 vec3 {name}_dec(uvec3 c) {{ return {name}_d2(c.x, c.y); }}\n",
                mask = (1u64 << k) - 1
            );
            (k, 2)
        }
        Recipe::NormalXyz { quant, unorm } => {
            quant_fns(quant, &format!("{name}_c"), &mut t);
            let (to, from) = if unorm { (" * 0.5 + 0.5", " * 2.0 - 1.0") } else { ("", "") };
            let _ = write!(
                t,
                "// xyz normal ({})\n\
                 uint {name}_e(float v) {{ precise float t = v{to}; return {name}_c_enc(t); }}\n\
                 float {name}_d(uint c) {{ precise float v = {name}_c_dec(c){from}; return v; }}\n\
                 uvec3 {name}_enc(vec3 n) {{ vec3 u = gbuf_sanitize(n); return uvec3({name}_e(u.x), {name}_e(u.y), {name}_e(u.z)); }}\n\
                 vec3 {name}_dec(uvec3 c) {{ return gbuf_finish(vec3({name}_d(c.x), {name}_d(c.y), {name}_d(c.z))); }}\n",
                f.codec
            );
            (quant.bits(), 3)
        }
        other => unreachable!("normal_code takes the Normal recipes, not {other:?}"),
    };
    FieldCode { k, n, text: t, camera, f64 }
}

/// The shader code of a depth field from its codec's recipe (one of the `Depth…` recipes).
fn depth_code(r: Recipe, _f: &Field, name: &str) -> FieldCode {
    let mut t = String::new();
    let camera = true;
    let mut f64 = false;
    let (k, n) = match r {
        Recipe::DepthLinearF32 => {
            let _ = write!(
                t,
                "// linear view depth, IEEE single (NaN → the far plane)\n\
                 uvec3 {name}_enc(float z) {{ float c = isnan(z) ? gbuf_zfar : clamp(z, {lo}, {hi}); return uvec3(floatBitsToUint(c), 0u, 0u); }}\n\
                 float {name}_dec(uvec3 c) {{ uint a = c.x & 0x7fffffffu; float z = uintBitsToFloat(c.x); \
                 return a > 0x7f800000u ? gbuf_zfar : clamp(z, {lo}, {hi}); }}\n",
                lo = lit(f32::MIN_POSITIVE),
                hi = lit(f32::MAX)
            );
            (32, 1)
        }
        Recipe::DepthLinearF16 => {
            let _ = write!(
                t,
                "// linear view depth, half float\n\
                 uvec3 {name}_enc(float z) {{ float c = isnan(z) ? gbuf_zfar : z; return uvec3(gbuf_f16_bits(clamp(c, {lo}, 65504.0)), 0u, 0u); }}\n\
                 float {name}_dec(uvec3 c) {{ return clamp(gbuf_f16_value(c.x & 0xffffu), {lo}, 65504.0); }}\n",
                lo = lit(2f32.powi(-24))
            );
            (16, 1)
        }
        Recipe::DepthPost { storage, reversed } => {
            f64 = true;
            let (d_of, z_of) = if reversed {
                (
                    "gbuf_d_mul(gbuf_d_div(n, gbuf_d_sub(f, n)), gbuf_d_sub(gbuf_d_div(f, z), gbuf_d_from_u32(1u)))",
                    "gbuf_d_div(gbuf_d_mul(n, f), gbuf_d_add(n, gbuf_d_mul(d, gbuf_d_sub(f, n))))",
                )
            } else {
                (
                    "gbuf_d_mul(gbuf_d_div(f, gbuf_d_sub(f, n)), gbuf_d_sub(gbuf_d_from_u32(1u), gbuf_d_div(n, z)))",
                    "gbuf_d_div(gbuf_d_mul(n, f), gbuf_d_sub(f, gbuf_d_mul(d, gbuf_d_sub(f, n))))",
                )
            };
            let (bits, store, load) = match storage {
                DepthStorage::Unorm(k) => {
                    let m = (1u64 << k) - 1;
                    (
                        k,
                        format!("uint(gbuf_d_round(gbuf_d_mul(d, gbuf_d_from_u32({m}u))))"),
                        format!("gbuf_d_div(gbuf_d_from_u32(c.x & {m}u), gbuf_d_from_u32({m}u))"),
                    )
                }
                DepthStorage::F32 => (
                    32,
                    "floatBitsToUint(gbuf_d_to_f32(d))".to_string(),
                    format!(
                        "(c.x & 0x7fffffffu) > 0x7f800000u ? {name}_d(f, n, f) : gbuf_d_from_f32(uintBitsToFloat(c.x))"
                    ),
                ),
            };
            let _ = write!(
                t,
                "// post-projection depth d ∈ [0, 1] of the camera's near/far ({}), f64 arithmetic\n\
                 double {name}_d(double z, double n, double f) {{ double d = {d_of}; return gbuf_d_clamp(d, gbuf_d_from_u32(0u), gbuf_d_from_u32(1u)); }}\n\
                 uvec3 {name}_enc(float depth) {{ double n = gbuf_d_from_f32(gbuf_znear); double f = gbuf_d_from_f32(gbuf_zfar); \
                 double z = isnan(depth) ? f : gbuf_d_clamp(gbuf_d_from_f32(depth), n, f); double d = {name}_d(z, n, f); \
                 return uvec3({store}, 0u, 0u); }}\n\
                 float {name}_dec(uvec3 c) {{ double n = gbuf_d_from_f32(gbuf_znear); double f = gbuf_d_from_f32(gbuf_zfar); \
                 double d = gbuf_d_clamp({load}, gbuf_d_from_u32(0u), gbuf_d_from_u32(1u)); double z = {z_of}; \
                 return gbuf_d_to_f32(gbuf_d_clamp(z, n, f)); }}\n",
                if reversed { "reversed Z" } else { "standard Z" },
            );
            (bits, 1)
        }
        other => unreachable!("depth_code takes the Depth recipes, not {other:?}"),
    };
    FieldCode { k, n, text: t, camera, f64 }
}

/// Can gbuf emit codec `codec` for `slot` as shader code that gives its bits exactly (it has a recipe that is
/// exact on any conforming driver, or it is an ID)? What `gbuf budget --emit` chooses among: the codecs that go
/// through the driver's transcendentals are emitted too, but measured rather than exact (docs/SHADERS.md).
#[must_use]
pub fn codec_emittable(slot: Slot, codec: &str) -> bool {
    use super::coder::Coder;
    let [n, f] = super::DEFAULT_DEPTH_RANGE;
    let exact = |r: Option<Recipe>| r.is_some_and(|r| r.is_exact());
    match Coder::build(slot, codec, n, f) {
        Ok(Coder::Normal(c)) => exact(c.recipe()),
        Ok(Coder::Depth(c)) => exact(c.recipe()),
        Ok(Coder::Color(c)) => exact(c.recipe()),
        Ok(Coder::Scalar(c)) => exact(c.recipe()),
        Ok(Coder::Id(_) | Coder::None) => true,
        Err(_) => false,
    }
}

/// The recipe of field `f`'s codec (IDs and reserved bits have none).
fn recipe_of(f: &Field, layout: &Layout) -> Result<Option<Recipe>> {
    use super::coder::Coder;
    let [n, far] = layout.spec().depth_range.unwrap_or(super::DEFAULT_DEPTH_RANGE);
    let coder = Coder::build(f.slot, &f.codec, n, far).map_err(Error::Argument)?;
    Ok(match coder {
        Coder::Normal(c) => c.recipe(),
        Coder::Depth(c) => c.recipe(),
        Coder::Color(c) => c.recipe(),
        Coder::Scalar(c) => c.recipe(),
        Coder::Id(_) | Coder::None => None,
    })
}

fn ident(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '_' }).collect()
}

/// The layout as GLSL 4.50: `struct GbufSurface`, per target `uvec4 gbuf_pack_<target>(GbufSurface s)` and
/// `GbufSurface gbuf_unpack(uvec4 <target>, …)` (docs/SHADERS.md). Errors name a codec or feature gbuf does not
/// emit yet.
pub fn emit(layout: &Layout, lang: Lang) -> Result<String> {
    if let Some(ind) = layout.indirection() {
        if ind.bits > MAX_TABLE_BITS || ind.parameters.len() > 4 {
            return Err(Error::Argument(format!(
                "layout {:?}: a material table of {} index bits and {} parameters does not fit the emitted uniform \
                 block (at most {MAX_TABLE_BITS} bits and 4 parameters)",
                layout.name(),
                ind.bits,
                ind.parameters.len()
            )));
        }
    }
    let mut fields = Vec::new();
    let mut camera = false;
    for (i, f) in layout.fields().iter().enumerate() {
        if matches!(f.slot, Slot::Reserved | Slot::MaterialIndex) {
            continue;
        }
        let target = &layout.spec().targets[f.target].name;
        let name = format!("gbuf_{}_{}", ident(target), ident(&f.slot.name()));
        let code = field_code(f, recipe_of(f, layout)?, &name, layout)?;
        camera |= code.camera;
        fields.push((i, f, name, code));
    }
    let f64 = fields.iter().any(|x| x.3.f64);
    let mut head = String::new();
    let _ = writeln!(head, "// gbuf layout {:?}: {}", layout.name(), layout.spec().description);
    let _ = writeln!(
        head,
        "// {}, generated by gbuf {} (`gbuf layouts {} --emit {}`). ABI: docs/SHADERS.md. Everything here is\n\
         // named gbuf_*/Gbuf*; paste it into any shader. Packing and unpacking give gbuf's bits exactly (tested on\n\
         // Mesa llvmpipe{}).",
        match lang {
            Lang::Glsl => "GLSL 4.50",
            Lang::Hlsl => "HLSL (Shader Model 6)",
            Lang::Wgsl => "WGSL",
        },
        env!("CARGO_PKG_VERSION"),
        layout.name(),
        lang.name(),
        match lang {
            Lang::Glsl => "",
            Lang::Hlsl => ", compiled by glslang's HLSL front end to SPIR-V",
            Lang::Wgsl => ", validated and compiled to SPIR-V by naga",
        }
    );
    if lang == Lang::Wgsl && f64 {
        head.push_str(
            "// WGSL has no f64: the fields gbuf computes in double use the software double below (gbuf_d_*).\n",
        );
    }
    if camera {
        head.push_str("\n// The camera's near and far planes (the depth codec's projection).\n");
        head.push_str(&match lang {
            Lang::Glsl => "uniform float gbuf_znear;\nuniform float gbuf_zfar;\n".to_string(),
            Lang::Hlsl => "cbuffer GbufCamera {\n    float gbuf_znear;\n    float gbuf_zfar;\n};\n".to_string(),
            Lang::Wgsl => format!(
                "// (@group({WGSL_GROUP}): change the two bind attributes to fit your pipeline layout.)\n\
                 struct GbufCamera {{\n    znear: f32,\n    zfar: f32,\n}}\n\
                 @group({WGSL_GROUP}) @binding(0) var<uniform> gbuf_camera: GbufCamera;\n"
            ),
        });
    }
    let (material_decl, material_code) = material_block(layout, lang);
    head.push_str(&material_decl);
    let mut o = String::new();
    o.push_str("\nstruct GbufSurface {\n");
    for (n, t) in SURFACE {
        let _ = writeln!(o, "    {t} {n};");
    }
    o.push_str("};\n");
    o.push_str(HELPERS);
    if f64 && lang != Lang::Wgsl {
        o.push_str(F64_HELPERS);
    }
    o.push_str(&material_code);
    o.push_str("\n// ---- one encode/decode pair per field ----\n");
    for (_, f, _, code) in &fields {
        let _ = writeln!(
            o,
            "\n// {} bits {}..{}: {} ({})",
            layout.spec().targets[f.target].name,
            f.offset,
            f.offset + f.bits,
            f.slot.name(),
            if f.codec.is_empty() { "id" } else { &f.codec }
        );
        o.push_str(&code.text);
    }
    // Packing: one function per target.
    for (ti, t) in layout.spec().targets.iter().enumerate() {
        let _ = writeln!(
            o,
            "\n// Target {:?} ({}): the texel's bits as little-endian 32-bit words, unused words 0.\nuvec4 gbuf_pack_{}(GbufSurface s) {{\n    uvec4 w = uvec4(0u, 0u, 0u, 0u);",
            t.name,
            layout.formats()[ti],
            ident(&t.name)
        );
        for f in layout.fields().iter().filter(|f| f.target == ti && f.slot == Slot::MaterialIndex) {
            let _ = writeln!(o, "    w = gbuf_put(w, {}u, {}u, gbuf_material_index(s));", f.offset, f.bits);
        }
        for (_, f, name, code) in fields.iter().filter(|x| x.1.target == ti) {
            let m = member(f.slot).unwrap_or_default();
            let _ = writeln!(o, "    uvec3 c_{name} = {name}_enc({m});");
            for j in 0..code.n {
                let _ = writeln!(o, "    w = gbuf_put(w, {}u, {}u, c_{name}[{j}]);", f.offset + j * code.k, code.k);
            }
        }
        o.push_str("    return w;\n}\n");
    }
    o.push_str(&float_targets(layout));
    // Unpacking.
    let params: Vec<String> = layout.spec().targets.iter().map(|t| format!("uvec4 {}", ident(&t.name))).collect();
    let _ = writeln!(
        o,
        "\n// The surface a lighting pass reads: what Layout::unpack gives. Attributes the layout does not store hold\n\
         // its constants or 0 (a position the layout does not store is left to the lighting, which rebuilds it\n\
         // from depth and its camera).\nGbufSurface gbuf_unpack({}) {{",
        params.join(", ")
    );
    o.push_str("    GbufSurface s;\n");
    for (n, t) in SURFACE {
        let zero = match t {
            "float" => "0.0",
            "uint" => "0u",
            "vec2" => "vec2(0.0, 0.0)",
            _ => "vec3(0.0, 0.0, 0.0)",
        };
        let _ = writeln!(o, "    s.{n} = {zero};");
    }
    for (a, vals) in layout.constants() {
        let v: Vec<String> = vals.iter().map(|v| lit(*v)).collect();
        let value = match vals.len() {
            1 if a.is_id() => format!("{}u", vals[0] as u32),
            1 => v[0].clone(),
            n => format!("vec{n}({})", v.join(", ")),
        };
        let _ = writeln!(o, "    s.{} = {value}; // the layout's constant", a.name());
    }
    for (_, f, name, code) in &fields {
        let src = ident(&layout.spec().targets[f.target].name);
        let comps: Vec<String> = (0..3)
            .map(|j| {
                if j < code.n {
                    format!("gbuf_get({src}, {}u, {}u)", f.offset + j * code.k, code.k)
                } else {
                    "0u".into()
                }
            })
            .collect();
        let m = member(f.slot).unwrap_or_default();
        let _ = writeln!(o, "    {m} = {name}_dec(uvec3({}));", comps.join(", "));
    }
    if let (Some(ind), Some(f)) = (layout.indirection(), layout.fields().iter().find(|f| f.slot == Slot::MaterialIndex))
    {
        let src = ident(&layout.spec().targets[f.target].name);
        let _ = writeln!(o, "    vec4 e = gbuf_material_table[gbuf_get({src}, {}u, {}u)];", f.offset, f.bits);
        for (i, a) in ind.parameters.iter().enumerate() {
            let _ = writeln!(o, "    s.{} = e[{i}]; // from the material table", a.name());
        }
    }
    if layout.stores(Attribute::Position) && !layout.stores(Attribute::Depth) {
        o.push_str("    s.depth = -s.position.z; // depth derived from position\n");
    }
    o.push_str("    return s;\n}\n");
    Ok(match lang {
        Lang::Glsl => head + &o,
        Lang::Hlsl => head + &to_hlsl(&o),
        Lang::Wgsl => {
            const RENAME: [(&str, &str); 6] = [
                ("gbuf_znear", "gbuf_camera.znear"),
                ("gbuf_zfar", "gbuf_camera.zfar"),
                ("gbuf_material_table", "gbuf_materials.table"),
                ("gbuf_material_ids", "gbuf_materials.ids"),
                ("gbuf_material_count", "gbuf_materials.count"),
                ("gbuf_material_by_id", "gbuf_materials.by_id"),
            ];
            let body = super::wgsl::translate(&o, &RENAME)
                .map_err(|e| Error::Internal(format!("layout {:?}: {e}", layout.name())))?;
            // The software double before the layout's code, so that the file ends with `gbuf_unpack` as in the
            // other languages (WGSL does not mind the order).
            let mut w = head + WGSL_PRELUDE;
            if f64 {
                w.push('\n');
                w.push_str(F64_WGSL);
            }
            if body.contains("gbuf_fence") || body.contains("gbuf_mul(") {
                w.push_str(super::wgsl::FENCE);
            }
            w.push_str(&body);
            w
        }
    })
}
