//! The GLSL that `gbuf layouts L --emit glsl` writes reproduces gbuf on a real GPU driver: on Mesa's llvmpipe
//! (moderngl, headless EGL), a compute shader feeds every covered sample's exact attributes to the emitted
//! `gbuf_pack_<target>` and compares nothing itself: it writes the words back, and this test checks them against
//! `Layout::pack`'s bytes bit for bit; it feeds `Layout::pack`'s words to `gbuf_unpack` and the attributes must
//! be `Layout::unpack`'s bits. Every built-in layout the emitter supports, the engine convention `oct-unorm`, and
//! each supported codec family at three bit widths, on the llvmpipe 4× fixture and a frame with every attribute.
//!
//! Required in CI (`.ci/run` installs Mesa, moderngl, glslang-tools and spirv-cross): there a missing driver or
//! compiler is a failure; elsewhere the tests say so on stderr and skip (`support::python_has`, `tool_has`).

mod support;

use gbuf::gbuffer::{Attribute, GBuffer, PlaneRef};
use gbuf::io::{load, LoadOptions};
use gbuf::layout::shader::{emit, Lang};
use gbuf::layout::{Layout, LayoutSpec};
use std::path::Path;
use std::process::Command;

/// The attributes of `GbufSurface` in ABI order.
const SURFACE_ORDER: [Attribute; 12] = [
    Attribute::Depth,
    Attribute::Position,
    Attribute::Normal,
    Attribute::Albedo,
    Attribute::Specular,
    Attribute::SpecularPower,
    Attribute::Roughness,
    Attribute::Metallic,
    Attribute::Motion,
    Attribute::MaterialId,
    Attribute::ObjectId,
    Attribute::PrimitiveId,
];

/// Words per sample of `GbufSurface` in the harness buffers, in ABI order.
const SURFACE_WORDS: usize = 19;

/// The attribute words of sample `i` (f32 bits, u32 IDs; 0 where the G-buffer has no plane).
fn surface_words(gb: &GBuffer, i: usize) -> [u32; SURFACE_WORDS] {
    let mut w = [0u32; SURFACE_WORDS];
    let mut at = 0;
    for a in SURFACE_ORDER {
        let n = a.components();
        match gb.plane(a) {
            Some(PlaneRef::F32(v)) => w[at] = v[i].to_bits(),
            Some(PlaneRef::U32(v)) => w[at] = v[i],
            Some(PlaneRef::Vec2(v)) => {
                w[at] = v[i].x.to_bits();
                w[at + 1] = v[i].y.to_bits();
            }
            Some(PlaneRef::Vec3(v)) => {
                w[at] = v[i].x.to_bits();
                w[at + 1] = v[i].y.to_bits();
                w[at + 2] = v[i].z.to_bits();
            }
            None => {}
        }
        at += n;
    }
    w
}

/// The spellings the harness body needs in each language.
struct Dialect {
    vec2: &'static str,
    vec3: &'static str,
    uvec4: &'static str,
    to_float: &'static str,
    to_bits: &'static str,
}

const GLSL: Dialect =
    Dialect { vec2: "vec2", vec3: "vec3", uvec4: "uvec4", to_float: "uintBitsToFloat", to_bits: "floatBitsToUint" };
const HLSL: Dialect =
    Dialect { vec2: "float2", vec3: "float3", uvec4: "uint4", to_float: "asfloat", to_bits: "asuint" };

/// The body of the harness's entry point after `uint i` (the sample) is known: read the sample's attributes, pack
/// them into `packed_out`, unpack gbuf's words from `words` into `unpacked_out`. One text for both languages.
fn harness_body(layout: &Layout, d: &Dialect) -> String {
    let t = layout.spec().targets.len();
    let f = |k: usize| format!("{}(inp[b + {k}u])", d.to_float);
    let mut body = format!(
        "  uint b = i * {SURFACE_WORDS}u;\n  GbufSurface s;\n  s.depth = {};\n  s.position = {v3}({}, {}, {});\n\
           s.normal = {v3}({}, {}, {});\n  s.albedo = {v3}({}, {}, {});\n  s.specular = {};\n  s.specular_power = {};\n\
           s.roughness = {};\n  s.metallic = {};\n  s.motion = {v2}({}, {});\n  s.material_id = inp[b + 16u];\n\
           s.object_id = inp[b + 17u];\n  s.primitive_id = inp[b + 18u];\n",
        f(0),
        f(1),
        f(2),
        f(3),
        f(4),
        f(5),
        f(6),
        f(7),
        f(8),
        f(9),
        f(10),
        f(11),
        f(12),
        f(13),
        f(14),
        f(15),
        v3 = d.vec3,
        v2 = d.vec2
    );
    let names: Vec<String> = layout
        .spec()
        .targets
        .iter()
        .map(|x| x.name.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '_' }).collect())
        .collect();
    for (k, name) in names.iter().enumerate() {
        body.push_str(&format!(
            "  {{ {} w = gbuf_pack_{name}(s); for (uint j = 0u; j < 4u; j++) packed_out[(i * {t}u + {k}u) * 4u + j] = w[j]; }}\n",
            d.uvec4
        ));
    }
    let args: Vec<String> = (0..t)
        .map(|k| {
            let w = |j: usize| format!("words[(i * {t}u + {k}u) * 4u + {j}u]");
            format!("{}({}, {}, {}, {})", d.uvec4, w(0), w(1), w(2), w(3))
        })
        .collect();
    let u = d.to_bits;
    body.push_str(&format!(
        "  GbufSurface u = gbuf_unpack({});\n  uint o = i * {SURFACE_WORDS}u;\n  unpacked_out[o] = {u}(u.depth);\n\
           for (uint j = 0u; j < 3u; j++) {{ unpacked_out[o + 1u + j] = {u}(u.position[j]); unpacked_out[o + 4u + j] = {u}(u.normal[j]); unpacked_out[o + 7u + j] = {u}(u.albedo[j]); }}\n\
           unpacked_out[o + 10u] = {u}(u.specular);\n  unpacked_out[o + 11u] = {u}(u.specular_power);\n\
           unpacked_out[o + 12u] = {u}(u.roughness);\n  unpacked_out[o + 13u] = {u}(u.metallic);\n\
           unpacked_out[o + 14u] = {u}(u.motion.x);\n  unpacked_out[o + 15u] = {u}(u.motion.y);\n\
           unpacked_out[o + 16u] = u.material_id;\n  unpacked_out[o + 17u] = u.object_id;\n  unpacked_out[o + 18u] = u.primitive_id;\n}}\n",
        args.join(", ")
    ));
    body
}

/// The harness: reads the attributes and gbuf's packed words, runs pack and unpack per sample. In HLSL it is
/// compiled by glslang's HLSL front end and cross-compiled back to GLSL by spirv-cross.
fn harness(code: &str, layout: &Layout, lang: Lang) -> String {
    match lang {
        Lang::Wgsl => {
            // The GLSL body through gbuf's own GLSL → WGSL translation (the harness is GLSL-shaped like the
            // emitted code), with the buffers as WGSL's structs.
            let body = format!("void gbuf_harness(uint i) {{\n{}", harness_body(layout, &GLSL));
            let rename = [
                ("inp", "inp.d"),
                ("words", "words.d"),
                ("packed_out", "packed_out.d"),
                ("unpacked_out", "unpacked_out.d"),
            ];
            let body = gbuf::layout::wgsl::translate(&body, &rename).unwrap_or_else(|e| panic!("harness: {e}"));
            format!(
                "{code}\nstruct In {{ d: array<u32> }}\nstruct Words {{ d: array<u32> }}\nstruct Packed {{ d: array<u32> }}\n\
                 struct Unpacked {{ d: array<u32> }}\nstruct Harness {{ n_samples: u32, pad0: u32, pad1: u32, pad2: u32 }}\n\
                 @group(0) @binding(0) var<storage, read> inp: In;\n@group(0) @binding(1) var<storage, read> words: Words;\n\
                 @group(0) @binding(2) var<storage, read_write> packed_out: Packed;\n\
                 @group(0) @binding(3) var<storage, read_write> unpacked_out: Unpacked;\n\
                 @group(0) @binding(4) var<uniform> harness: Harness;\n{body}\n\
                 @compute @workgroup_size(64)\nfn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
                 if (id.x >= harness.n_samples) {{ return; }}\n  gbuf_harness(id.x);\n}}\n"
            )
        }
        Lang::Hlsl => format!(
            "{code}\nStructuredBuffer<uint> inp : register(t0);\nStructuredBuffer<uint> words : register(t1);\n\
             RWStructuredBuffer<uint> packed_out : register(u2);\nRWStructuredBuffer<uint> unpacked_out : register(u3);\n\
             cbuffer Harness : register(b1) {{ uint n_samples; }};\n\
             [numthreads(64, 1, 1)]\nvoid main(uint3 id : SV_DispatchThreadID) {{\n  uint i = id.x;\n  if (i >= n_samples) return;\n{}",
            harness_body(layout, &HLSL)
        ),
        _ => format!(
            "#version 450\nlayout(local_size_x = 64) in;\n\
             layout(std430, binding = 0) readonly buffer In {{ uint inp[]; }};\n\
             layout(std430, binding = 1) readonly buffer Words {{ uint words[]; }};\n\
             layout(std430, binding = 2) writeonly buffer Packed {{ uint packed_out[]; }};\n\
             layout(std430, binding = 3) writeonly buffer Unpacked {{ uint unpacked_out[]; }};\n\
             uniform uint n_samples;\n{code}\n\
             void main() {{\n  uint i = gl_GlobalInvocationID.x;\n  if (i >= n_samples) return;\n{}",
            harness_body(layout, &GLSL)
        ),
    }
}

/// Runs the shader on llvmpipe: argv = shader, inputs, words, n, targets, znear, zfar, packed out, unpacked out.
const RUN: &str = r#"
import sys, numpy as np, moderngl
shader, inp, words, n, t, znear, zfar, out_p, out_u, materials = sys.argv[1:]
n, t = int(n), int(t)
ctx = moderngl.create_standalone_context(backend="egl", require=450)
renderer = ctx.info["GL_RENDERER"]
assert "llvmpipe" in renderer, renderer
import re, struct
src = open(shader).read()
cs = ctx.compute_shader(src)
# Bindings by block name (spirv-cross output of the HLSL harness); the GLSL harness uses 0..3 and plain uniforms.
bind = {m.group(2): int(m.group(1)) for m in re.finditer(r"layout\(binding = (\d+), std\d+\) (?:readonly |writeonly |restrict )*(?:buffer|uniform) (\w+)", src)}
# spirv-cross names a block after its variable when naga's debug names are present (the WGSL harness).
for block, var in (("Harness", "harness"), ("GbufCamera", "gbuf_camera"), ("GbufMaterials", "gbuf_materials")):
    if var in bind and block not in bind:
        bind[block] = bind[var]
zn = struct.unpack("<f", struct.pack("<I", int(znear)))[0]
zf = struct.unpack("<f", struct.pack("<I", int(zfar)))[0]
keep = []
if "Harness" in bind:
    ub = ctx.buffer(struct.pack("<I12x", n)); ub.bind_to_uniform_block(bind["Harness"]); keep.append(ub)
else:
    cs["n_samples"].value = n
if "GbufCamera" in bind:
    cb = ctx.buffer(struct.pack("<ff8x", zn, zf)); cb.bind_to_uniform_block(bind["GbufCamera"]); keep.append(cb)
else:
    for name, v in (("gbuf_znear", zn), ("gbuf_zfar", zf)):
        if name in cs:
            cs[name].value = v
if materials != "-":
    mb = ctx.buffer(open(materials, "rb").read()); keep.append(mb)
    if "GbufMaterials" in bind:
        mb.bind_to_uniform_block(bind["GbufMaterials"])
    else:
        cs["GbufMaterials"].binding = 7
        mb.bind_to_uniform_block(7)
bi = ctx.buffer(open(inp, "rb").read())
bw = ctx.buffer(open(words, "rb").read())
bp = ctx.buffer(reserve=max(4, n * t * 16))
bu = ctx.buffer(reserve=max(4, n * 19 * 4))
for buf, name, default in ((bi, "inp", 0), (bw, "words", 1), (bp, "packed_out", 2), (bu, "unpacked_out", 3)):
    buf.bind_to_storage_buffer(bind.get(name, default))
cs.run(group_x=(n + 63) // 64)
ctx.finish()
open(out_p, "wb").write(bp.read())
open(out_u, "wb").write(bu.read())
print(renderer)
"#;

/// Packs and unpacks every covered sample of `gb` with `layout` on llvmpipe and compares with gbuf, bit for bit.
fn check(layout: &Layout, gb: &GBuffer, dir: &Path, tag: &str, lang: Lang) {
    let m = measure(layout, gb, dir, tag, lang, 0);
    assert_eq!(m.bad, 0, "{tag}-{}: {} mismatches over {} samples; first: {}", lang.name(), m.bad, m.samples, m.first);
}

/// What the driver gave against gbuf.
struct Mismatch {
    /// Texel words and attribute words that differ.
    bad: usize,
    /// Samples compared.
    samples: usize,
    /// The first difference.
    first: String,
    /// Packed texels that differ.
    bad_pack: usize,
    /// The largest difference between two codes of `step_bits` bits at the same place (0 when not asked).
    max_code_step: u64,
    /// The largest angle between a decoded normal and gbuf's, in degrees.
    max_normal_deg: f64,
    /// The largest relative difference of a decoded specular power from gbuf's.
    max_power_rel: f64,
}

fn measure(layout: &Layout, gb: &GBuffer, dir: &Path, tag: &str, lang: Lang, step_bits: u32) -> Mismatch {
    let code = emit(layout, lang).unwrap_or_else(|e| panic!("{tag}: {e}"));
    let tag = &format!("{tag}-{}", lang.name());
    let packed = layout.pack(gb).unwrap();
    let unpacked = layout.unpack(&packed, gb).unwrap();
    let covered: Vec<usize> = (0..gb.len()).filter(|&i| gb.coverage[i]).collect();
    let t = packed.targets.len();
    let mut inp = Vec::with_capacity(covered.len() * SURFACE_WORDS * 4);
    let mut words = Vec::with_capacity(covered.len() * t * 16);
    for &i in &covered {
        for w in surface_words(gb, i) {
            inp.extend_from_slice(&w.to_le_bytes());
        }
        for p in &packed.targets {
            let tb = p.format.bytes();
            let mut texel = [0u8; 16];
            texel[..tb].copy_from_slice(&p.bytes[i * tb..(i + 1) * tb]);
            words.extend_from_slice(&texel);
        }
    }
    let shader = dir.join(format!("{tag}.comp"));
    match lang {
        Lang::Glsl => std::fs::write(&shader, harness(&code, layout, lang)).unwrap(),
        Lang::Hlsl => hlsl_to_glsl(&harness(&code, layout, lang), dir, tag, &shader),
        Lang::Wgsl => wgsl_to_glsl(&harness(&code, layout, lang), dir, tag, &shader),
    }
    let (fi, fw, fp, fu) = (
        dir.join(format!("{tag}.in")),
        dir.join(format!("{tag}.words")),
        dir.join(format!("{tag}.p")),
        dir.join(format!("{tag}.u")),
    );
    std::fs::write(&fi, &inp).unwrap();
    std::fs::write(&fw, &words).unwrap();
    let run = dir.join("run.py");
    std::fs::write(&run, RUN).unwrap();
    let [zn, zf] = packed.depth_range;
    let o = Command::new("python3")
        .arg(&run)
        .args([&shader, &fi, &fw])
        .args([covered.len().to_string(), t.to_string(), zn.to_bits().to_string(), zf.to_bits().to_string()])
        .args([&fp, &fu])
        .arg(materials_block(layout, &packed, dir, tag))
        .output()
        .expect("python3");
    assert!(o.status.success(), "{tag}: the driver run failed:\n{}", String::from_utf8_lossy(&o.stderr));
    let got_p = std::fs::read(&fp).unwrap();
    let got_u = std::fs::read(&fu).unwrap();
    let word = |b: &[u8], k: usize| u32::from_le_bytes(b[k * 4..k * 4 + 4].try_into().unwrap());
    let mut bad = 0usize;
    let mut first = String::new();
    let (mut max_code_step, mut max_normal_deg, mut bad_pack, mut max_power_rel) = (0u64, 0f64, 0usize, 0f64);
    for (j, &i) in covered.iter().enumerate() {
        for (k, p) in packed.targets.iter().enumerate() {
            let tb = p.format.bytes();
            let mut want = [0u8; 16];
            want[..tb].copy_from_slice(&p.bytes[i * tb..(i + 1) * tb]);
            let got = &got_p[(j * t + k) * 16..(j * t + k + 1) * 16];
            if got != want {
                if step_bits > 0 {
                    let bits = |b: &[u8]| u128::from_le_bytes(b.try_into().unwrap());
                    let (g, w) = (bits(got), bits(&want));
                    let mask = (1u128 << step_bits) - 1;
                    for c in 0..(128 / step_bits) {
                        let (a, b) = ((g >> (c * step_bits)) & mask, (w >> (c * step_bits)) & mask);
                        max_code_step = max_code_step.max(a.abs_diff(b) as u64);
                    }
                }
                bad_pack += 1;
                bad += 1;
                if first.is_empty() {
                    first = format!("pack {}: sample {i}: GPU {got:02x?} gbuf {want:02x?}", p.name);
                }
            }
        }
        let want = surface_words(&unpacked, i);
        for a in layout.stored_attributes() {
            let (at, n) = offset_of(a);
            for (c, &w) in want.iter().enumerate().skip(at).take(n) {
                if word(&got_u, j * SURFACE_WORDS + c) != w {
                    bad += 1;
                    if first.is_empty() {
                        first = format!(
                            "unpack {}: sample {i} word {c}: GPU {:#010x} gbuf {:#010x}",
                            a.name(),
                            word(&got_u, j * SURFACE_WORDS + c),
                            w
                        );
                    }
                }
            }
        }
        if layout.stores(Attribute::SpecularPower) {
            let (at, _) = offset_of(Attribute::SpecularPower);
            let (g, e) =
                (f64::from(f32::from_bits(word(&got_u, j * SURFACE_WORDS + at))), f64::from(f32::from_bits(want[at])));
            max_power_rel = max_power_rel.max((g - e).abs() / e.abs().max(1e-30));
        }
        if layout.stores(Attribute::Normal) {
            let (at, _) = offset_of(Attribute::Normal);
            let v = |w: &dyn Fn(usize) -> u32| {
                glam::DVec3::new(
                    f64::from(f32::from_bits(w(at))),
                    f64::from(f32::from_bits(w(at + 1))),
                    f64::from(f32::from_bits(w(at + 2))),
                )
            };
            let g = v(&|c| word(&got_u, j * SURFACE_WORDS + c));
            let e = v(&|c| want[c]);
            if g != e {
                max_normal_deg = max_normal_deg.max(g.cross(e).length().atan2(g.dot(e)).to_degrees());
            }
        }
    }
    Mismatch { bad, samples: covered.len(), first, bad_pack, max_code_step, max_normal_deg, max_power_rel }
}

/// HLSL → SPIR-V (glslangValidator's HLSL front end) → GLSL 4.50 (spirv-cross), the way a Vulkan engine ships
/// HLSL; the GLSL then runs on llvmpipe.
fn hlsl_to_glsl(hlsl: &str, dir: &Path, tag: &str, out: &Path) {
    let src = dir.join(format!("{tag}.hlsl"));
    let spv = dir.join(format!("{tag}.spv"));
    std::fs::write(&src, hlsl).unwrap();
    let o = Command::new("glslangValidator")
        .args(["-D", "-e", "main", "-S", "comp", "-V", "--auto-map-bindings", "-o"])
        .arg(&spv)
        .arg(&src)
        .output()
        .expect("glslangValidator (Debian glslang-tools) is required");
    assert!(o.status.success(), "{tag}: glslang:\n{}", String::from_utf8_lossy(&o.stdout));
    spirv_to_glsl(&spv, tag, out);
}

/// SPIR-V → GLSL 4.50 (spirv-cross), for llvmpipe.
fn spirv_to_glsl(spv: &Path, tag: &str, out: &Path) {
    let o = Command::new("spirv-cross")
        .args(["--version", "450", "--output"])
        .arg(out)
        .arg(spv)
        .output()
        .expect("spirv-cross (Debian spirv-cross) is required");
    assert!(o.status.success(), "{tag}: spirv-cross:\n{}", String::from_utf8_lossy(&o.stderr));
}

/// WGSL → naga (parse and validate, every check on) → SPIR-V → GLSL 4.50 (spirv-cross), as a WebGPU
/// implementation on Vulkan compiles it; the GLSL then runs on llvmpipe.
pub fn wgsl_to_glsl(wgsl: &str, dir: &Path, tag: &str, out: &Path) {
    std::fs::write(dir.join(format!("{tag}.wgsl")), wgsl).unwrap();
    let module =
        naga::front::wgsl::parse_str(wgsl).unwrap_or_else(|e| panic!("{tag}: naga: {}", e.emit_to_string(wgsl)));
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{tag}: naga validation: {}", e.emit_to_string(wgsl)));
    let mut options = naga::back::spv::Options::default();
    options.flags |= naga::back::spv::WriterFlags::DEBUG;
    let words = naga::back::spv::write_vec(&module, &info, &options, None).unwrap();
    let spv = dir.join(format!("{tag}.spv"));
    std::fs::write(&spv, words.iter().flat_map(|w| w.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    spirv_to_glsl(&spv, tag, out);
}

/// The `GbufMaterials` uniform block (std140) for a layout with indirection, from `gbuf pack`'s table: entry k's
/// parameters in the layout's order (0 for a parameter the frame lacks), the IDs four per element, the count and
/// the key. `-` without indirection.
fn materials_block(layout: &Layout, packed: &gbuf::layout::Packed, dir: &Path, tag: &str) -> String {
    let (Some(ind), Some(table)) = (layout.indirection(), packed.material_table.as_ref()) else { return "-".into() };
    let n = 1usize << ind.bits;
    let mut b = vec![0u8; n * 16 + n.div_ceil(4) * 16 + 16];
    for (k, row) in table.entries.iter().enumerate() {
        for (i, a) in ind.parameters.iter().enumerate() {
            if let Some(col) = table.parameters.iter().position(|p| p == a.name()) {
                b[k * 16 + i * 4..k * 16 + i * 4 + 4].copy_from_slice(&row[col].to_le_bytes());
            }
        }
    }
    for (k, id) in table.ids.iter().enumerate() {
        let at = n * 16 + k * 4;
        b[at..at + 4].copy_from_slice(&id.to_le_bytes());
    }
    let at = n * 16 + n.div_ceil(4) * 16;
    b[at..at + 4].copy_from_slice(&(table.entries.len() as u32).to_le_bytes());
    b[at + 4..at + 8].copy_from_slice(&u32::from(table.key == "material-id").to_le_bytes());
    let f = dir.join(format!("{tag}.materials"));
    std::fs::write(&f, b).unwrap();
    f.display().to_string()
}

/// Word offset and count of an attribute in [`surface_words`].
fn offset_of(a: Attribute) -> (usize, usize) {
    let mut at = 0;
    for b in SURFACE_ORDER {
        if b == a {
            return (at, b.components());
        }
        at += b.components();
    }
    unreachable!()
}

fn fixture() -> GBuffer {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/raster_4x.exr");
    load(&p, &LoadOptions::default()).unwrap().gbuffer
}

/// A plausible frame with every attribute (values in and out of every codec's range).
fn every_attribute() -> GBuffer {
    let mut gb = support::io::plausible(29, 13, 4, 3);
    let n = gb.len();
    let mut r = gbuf::base::rng::SplitMix64::new(5);
    gb.specular = Some((0..n).map(|_| r.range_f32(-0.2, 1.2)).collect());
    gb.specular_power = Some((0..n).map(|_| r.range_f32(0.0, 300.0)).collect());
    gb.metallic = Some((0..n).map(|_| r.next_f32()).collect());
    gb.object_id = Some((0..n).map(|_| r.next_u64() as u32 >> 20).collect());
    gb.primitive_id = Some((0..n).map(|_| r.next_u64() as u32).collect());
    gb.motion = Some((0..n).map(|_| glam::Vec2::new(r.range_f32(-40.0, 40.0), r.range_f32(-1.0, 1.0))).collect());
    gb.albedo = Some(
        (0..n).map(|_| glam::Vec3::new(r.range_f32(-0.1, 1.1), r.next_f32(), r.range_f32(0.0, 70000.0))).collect(),
    );
    gb.normal = Some(
        (0..n)
            .map(|_| glam::Vec3::new(r.range_f32(-1.0, 1.0), r.range_f32(-1.0, 1.0), r.range_f32(-1.0, 1.0)))
            .collect(),
    );
    gb.zero_background();
    gb
}

/// Every built-in layout the emitter supports, on both frames.
#[test]
fn builtin_layouts_pack_and_unpack_on_llvmpipe_bit_for_bit() {
    if !drivers_ready() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let frames = [("raster", fixture()), ("every", every_attribute())];
    let mut done = Vec::new();
    for layout in Layout::builtins().into_iter().chain(Layout::visibility_builtins()) {
        if emit(&layout, Lang::Glsl).is_err() {
            continue;
        }
        for (tag, gb) in &frames {
            for lang in [Lang::Glsl, Lang::Hlsl, Lang::Wgsl] {
                check(&layout, gb, dir.path(), &format!("{}-{tag}", layout.name()), lang);
            }
        }
        done.push(layout.name().to_string());
    }
    for must in [
        "unreal-like",
        "bevy-deferred",
        "minimal-8",
        "reference-f32",
        "rgba16f-2x",
        "visibility-8",
        "fat-20",
        "lauritzen-15",
    ] {
        assert!(done.iter().any(|d| d == must), "{must} was not emitted: {done:?}");
    }
}

/// The driver and the compilers the shader tests run on: Mesa through moderngl, glslang (HLSL) and spirv-cross.
/// Required in CI; elsewhere a noted skip.
fn drivers_ready() -> bool {
    support::python_has("moderngl, numpy") && support::tool_has("glslangValidator") && support::tool_has("spirv-cross")
}

/// A layout of one field: `attr` with `codec` at bit `offset` of a `format` target named `t`.
fn one_field(attr: &str, codec: &str, format: &str, offset: u32) -> Layout {
    let bits = bits_of(attr.split('.').next().unwrap_or(attr), codec);
    let spec = format!(
        "name = \"one\"\n[[targets]]\nname = \"t\"\nformat = \"{format}\"\nfields = [ {{ attribute = \"{attr}\", codec = \"{codec}\", offset = {offset}, bits = {bits} }} ]\n"
    );
    Layout::from_spec(LayoutSpec::parse(Path::new("one.toml"), &spec).unwrap())
        .unwrap_or_else(|e| panic!("{codec}: {e}"))
}

/// The width of codec `c` for attribute `attr`.
fn bits_of(attr: &str, c: &str) -> u32 {
    use gbuf::codec::{color_codec, depth_codec, normal_codec, scalar_codec};
    match attr {
        "normal" => normal_codec(c).unwrap().bits(),
        "albedo" => color_codec(c).unwrap().bits(),
        "depth" => depth_codec(c, 0.1, 100.0).unwrap().bits(),
        _ => scalar_codec(c).unwrap().bits(),
    }
}

/// Each codec family the emitter has, at three widths, in one layout per family (fields spanning words
/// included).
#[test]
fn codec_families_at_three_widths_on_llvmpipe() {
    if !drivers_ready() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let gb = every_attribute();
    let families: [(&str, &str, [&str; 3]); 17] = [
        ("normal", "rgba32ui", ["spheremap-cry-16", "spheremap-cry-24", "spheremap-cry-f16-32"]),
        ("normal", "rgba32ui", ["xy-hemi-16", "xy-hemi-24", "xy-hemi-f16-32"]),
        ("specular_power", "rgba32ui", ["log2-unorm-4", "log2-unorm-8", "log2-unorm-12"]),
        ("normal", "rgba32ui", ["oct-16", "oct-24", "oct-32"]),
        ("normal", "rgba32ui", ["oct-unorm-16", "oct-unorm-20", "oct-unorm-32"]),
        ("normal", "rgba32ui", ["xyz-snorm-24", "xyz-unorm-30", "xyz-f16-48"]),
        ("albedo", "rgba32ui", ["unorm-5", "unorm8", "unorm-16"]),
        ("albedo", "rgba32ui", ["srgb8", "f16", "unorm-10"]),
        ("albedo", "rgba32ui", ["r11g11b10f", "rgb9e5", "unorm-1"]),
        ("normal", "rgba32ui", ["lambert-16", "lambert-unorm-24", "lambert-f16-32"]),
        ("normal", "rgba32ui", ["stereo-16", "stereo-unorm-20", "stereo-f16-32"]),
        ("normal", "rgba32ui", ["spheremap-ispc-16", "spheremap-ispc-20", "spheremap-ispc-32"]),
        ("normal", "rgba32ui", ["oct-precise-16", "oct-precise-24", "oct-precise-32"]),
        ("normal", "rgba32ui", ["stereo-sphere-16", "stereo-sphere-unorm-20", "stereo-sphere-24"]),
        ("roughness", "rgba32ui", ["unorm-4", "unorm-12", "unorm-24"]),
        ("motion.x", "rgba32ui", ["snorm-6:40", "snorm-12:40", "snorm-24:40"]),
        ("depth", "rgba32ui", ["unorm16", "unorm24-reversed", "f32-standard"]),
    ];
    for (attr, format, codecs) in families {
        let bits: Vec<u32> = codecs.iter().map(|c| bits_of(attr, c)).collect();
        for (c, b) in codecs.iter().zip(&bits) {
            let spec = format!(
                "name = \"family\"\n[[targets]]\nname = \"t\"\nformat = \"{format}\"\nfields = [\n  {{ attribute = \"{attr}\", codec = \"{c}\", offset = 3, bits = {b} }},\n]\n\
                 [[targets]]\nname = \"z\"\nformat = \"r32f\"\nfields = [ {{ attribute = \"{}\", codec = \"f32\", offset = 0, bits = 32 }} ]\n",
                if attr == "depth" { "roughness" } else { "depth" }
            );
            let layout = Layout::from_spec(LayoutSpec::parse(Path::new("family.toml"), &spec).unwrap())
                .unwrap_or_else(|e| panic!("{c}: {e}"));
            for lang in [Lang::Glsl, Lang::Hlsl, Lang::Wgsl] {
                check(&layout, &gb, dir.path(), &format!("family-{}", c.replace(':', "_")), lang);
            }
        }
    }
}

/// Material-ID indirection keyed by a palette of parameter tuples (the frame's six materials fit the table, so
/// the palette is lossless and a surface's entry is the one with its parameters), in GLSL, HLSL and WGSL.
#[test]
fn a_palette_keyed_material_table_on_llvmpipe() {
    if !drivers_ready() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let text = include_str!("../src/layout/builtin/destiny-96.toml")
        .replace("name = \"destiny-96\"", "name = \"destiny-palette\"")
        .replace("bits = 8\n", "bits = 8\nkey = \"palette\"\n");
    let layout = Layout::from_spec(LayoutSpec::parse(Path::new("palette.toml"), &text).unwrap()).unwrap();
    let gb = fixture();
    let table = layout.pack(&gb).unwrap().material_table.unwrap();
    assert_eq!(table.key, "palette");
    assert!(table.lossless, "six materials fit 256 entries");
    for lang in [Lang::Glsl, Lang::Hlsl, Lang::Wgsl] {
        check(&layout, &gb, dir.path(), "palette", lang);
    }
}

/// Renders `gbuf_target_<target>` into real render targets of each float-written format on llvmpipe (a fragment
/// per sample, MRT), reads the stored bits back (`glGetTexImage` with the packed type: no conversion) and prints
/// `name mismatches texels` per target.
const RENDER: &str = r##"
import sys, ctypes, struct, numpy as np, moderngl
shader, inp, n, znear, zfar, spec = sys.argv[1:7]
n = int(n)
targets = [t.split(":") for t in spec.split(",")]  # name:glformat:components:readformat:readtype:bytes
ctx = moderngl.create_standalone_context(backend="egl", require=450)
W = 256
H = (n + W - 1) // W
code = open(shader).read()
outs = "".join(f"layout(location = {i}) out vec4 o{i};\n" for i in range(len(targets)))
writes = "".join(f"  o{i} = gbuf_target_{t[0]}(s);\n" for i, t in enumerate(targets))
fs = ("#version 450\nlayout(std430, binding = 0) readonly buffer In { uint inp[]; };\nuniform uint n_samples;\n" + code + outs +
      "void main() {\n  uint i = uint(gl_FragCoord.y) * %du + uint(gl_FragCoord.x);\n  if (i >= n_samples) discard;\n  uint b = i * 19u;\n"
      "  GbufSurface s;\n  s.depth = uintBitsToFloat(inp[b]);\n"
      "  s.position = vec3(uintBitsToFloat(inp[b + 1u]), uintBitsToFloat(inp[b + 2u]), uintBitsToFloat(inp[b + 3u]));\n"
      "  s.normal = vec3(uintBitsToFloat(inp[b + 4u]), uintBitsToFloat(inp[b + 5u]), uintBitsToFloat(inp[b + 6u]));\n"
      "  s.albedo = vec3(uintBitsToFloat(inp[b + 7u]), uintBitsToFloat(inp[b + 8u]), uintBitsToFloat(inp[b + 9u]));\n"
      "  s.specular = uintBitsToFloat(inp[b + 10u]); s.specular_power = uintBitsToFloat(inp[b + 11u]);\n"
      "  s.roughness = uintBitsToFloat(inp[b + 12u]); s.metallic = uintBitsToFloat(inp[b + 13u]);\n"
      "  s.motion = vec2(uintBitsToFloat(inp[b + 14u]), uintBitsToFloat(inp[b + 15u]));\n"
      "  s.material_id = inp[b + 16u]; s.object_id = inp[b + 17u]; s.primitive_id = inp[b + 18u];\n" % W) + writes + "}\n"
vs = "#version 450\nvoid main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2); gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }\n"
prog = ctx.program(vertex_shader=vs, fragment_shader=fs)
prog["n_samples"].value = n
for name, v in (("gbuf_znear", znear), ("gbuf_zfar", zfar)):
    if name in prog:
        prog[name].value = struct.unpack("<f", struct.pack("<I", int(v)))[0]
texs = [ctx.texture((W, H), int(t[2]), dtype="f1", internal_format=int(t[1], 16)) for t in targets]
fbo = ctx.framebuffer(color_attachments=texs)
fbo.use()
ctx.enable_direct(0x8DB9)  # GL_FRAMEBUFFER_SRGB: sRGB targets encode
ctx.buffer(open(inp, "rb").read()).bind_to_storage_buffer(0)
vao = ctx.vertex_array(prog, [])
vao.render(moderngl.TRIANGLES, vertices=3)
ctx.finish()
gl = ctypes.CDLL("libGL.so.1")
gl.glGetTexImage.argtypes = [ctypes.c_uint, ctypes.c_int, ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p]
for t, tex in zip(targets, texs):
    nbytes = int(t[5])
    buf = ctypes.create_string_buffer(W * H * nbytes)
    tex.use(0)
    gl.glBindTexture(0x0DE1, tex.glo)
    gl.glPixelStorei(0x0D05, 1)  # GL_PACK_ALIGNMENT
    gl.glGetTexImage(0x0DE1, 0, int(t[3], 16), int(t[4], 16), buf)
    open(sys.argv[7] + "/" + t[0] + ".bits", "wb").write(buf.raw[: n * nbytes])
print(ctx.info["GL_RENDERER"])
"##;

/// The GL format, components, and the read format/type that returns a texel's stored bits, of a format written
/// as floats; `None` for formats GL cannot render to as floats (snorm: not colour-renderable in desktop GL).
fn gl_float_target(f: gbuf::layout::Format) -> Option<(&'static str, u32, &'static str, &'static str)> {
    use gbuf::layout::Format as F;
    // (internal format, components, read format, read type)
    Some(match f {
        F::R8 => ("8229", 1, "1903", "1401"),
        F::Rg8 => ("822b", 2, "8227", "1401"),
        F::Rgba8 => ("8058", 4, "1908", "1401"),
        F::Rgba8Srgb => ("8c43", 4, "1908", "1401"),
        F::Rgb10A2 => ("8059", 4, "1908", "8368"), // GL_UNSIGNED_INT_2_10_10_10_REV
        F::R11G11B10F => ("8c3a", 3, "1907", "8c3b"), // GL_UNSIGNED_INT_10F_11F_11F_REV
        F::R16F => ("822d", 1, "1903", "140b"),
        F::Rg16F => ("822f", 2, "8227", "140b"),
        F::Rgba16F => ("881a", 4, "1908", "140b"),
        F::R16Unorm => ("822a", 1, "1903", "1403"),
        F::Rg16Unorm => ("822c", 2, "8227", "1403"),
        F::Rgba16Unorm => ("805b", 4, "1908", "1403"),
        F::R32F => ("822e", 1, "1903", "1406"),
        F::Rg32F => ("8230", 2, "8227", "1406"),
        F::Rgba32F => ("8814", 4, "1908", "1406"),
        _ => return None,
    })
}

/// The float entry point `gbuf_target_<target>`, written to real render targets and converted by the driver,
/// stores exactly `gbuf_pack_<target>`'s bits on llvmpipe for every float-written target of every built-in layout
/// and of the engine capture's layout (RGB10A2 octahedral): unorm `code/(2^k − 1)` survives llvmpipe's
/// `rne(v·65535) >> 6` 10-bit conversion, sRGB the hardware encode, halves and singles their conversion.
#[test]
fn float_entry_points_store_the_packed_bits_through_the_hardware_conversion() {
    if !support::python_has("moderngl, numpy") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("render.py");
    std::fs::write(&run, RENDER).unwrap();
    let engine = Layout::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/engine_4x/engine.toml")).unwrap();
    let gb = fixture();
    let mut checked = Vec::new();
    // (destiny-96 is left out: its material table block is the compute harness's business; its formats are here.)
    for layout in Layout::builtins().into_iter().chain([engine]).filter(|l| l.indirection().is_none()) {
        let code = emit(&layout, Lang::Glsl).unwrap();
        let packed = layout.pack(&gb).unwrap();
        let covered: Vec<usize> = (0..gb.len()).filter(|&i| gb.coverage[i]).collect();
        let mut spec = Vec::new();
        let mut which = Vec::new();
        for (k, t) in layout.spec().targets.iter().enumerate() {
            let f = layout.formats()[k];
            if let (Some((fmt, comps, rf, rt)), true) =
                (gl_float_target(f), code.contains(&format!("gbuf_target_{}(", t.name)))
            {
                spec.push(format!("{}:{fmt}:{comps}:{rf}:{rt}:{}", t.name, f.bytes()));
                which.push(k);
            }
        }
        if spec.is_empty() {
            continue;
        }
        let mut inp = Vec::new();
        for &i in &covered {
            for w in surface_words(&gb, i) {
                inp.extend_from_slice(&w.to_le_bytes());
            }
        }
        let tag = layout.name().to_string();
        let (fs, fi) = (dir.path().join(format!("{tag}.glsl")), dir.path().join(format!("{tag}.in")));
        std::fs::write(&fs, &code).unwrap();
        std::fs::write(&fi, &inp).unwrap();
        let out = dir.path().join(&tag);
        std::fs::create_dir(&out).unwrap();
        let [zn, zf] = packed.depth_range;
        let o = Command::new("python3")
            .arg(&run)
            .args([&fs, &fi])
            .args([covered.len().to_string(), zn.to_bits().to_string(), zf.to_bits().to_string(), spec.join(",")])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{tag}: {}", String::from_utf8_lossy(&o.stderr));
        for k in which {
            let t = &packed.targets[k];
            let tb = t.format.bytes();
            let got = std::fs::read(out.join(format!("{}.bits", t.name))).unwrap();
            let bad = covered
                .iter()
                .enumerate()
                .filter(|(j, &i)| got[j * tb..(j + 1) * tb] != t.bytes[i * tb..(i + 1) * tb])
                .count();
            checked.push(format!("{tag}/{} ({}) {bad} of {}", t.name, t.format, covered.len()));
            assert_eq!(bad, 0, "{tag}/{} ({}): {bad} of {} texels differ", t.name, t.format, covered.len());
        }
    }
    assert!(
        checked.iter().any(|c| c.contains("rgb10a2")) && checked.iter().any(|c| c.contains("rgba8-srgb")),
        "{checked:?}"
    );
    eprintln!("float entry points, texels differing: {checked:?}");
}

/// From a dump to shader code in one command: `gbuf budget DUMP --max-bytes 12 --emit hlsl` chooses among the
/// layouts gbuf can emit and prints the winner as HLSL, which glslang's HLSL front end compiles.
#[test]
fn budget_emits_hlsl_and_wgsl_in_one_command() {
    if !support::tool_has("glslangValidator") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let dump = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/blender_gbuffer.exr");
    let o = support::gbuf(dir.path(), &["budget", dump.to_str().unwrap(), "--max-bytes", "12", "--emit", "hlsl"]);
    assert!(o.status.success(), "{}", support::stderr(&o));
    let code = String::from_utf8(o.stdout).unwrap();
    assert!(code.starts_with("// gbuf layout") && code.contains("GbufSurface gbuf_unpack("), "{code}");
    let hlsl = dir.path().join("budget.hlsl");
    std::fs::write(
        &hlsl,
        format!(
            "{code}\nRWStructuredBuffer<uint> o : register(u0);\n[numthreads(1, 1, 1)] void main() {{ o[0] = 1u; }}\n"
        ),
    )
    .unwrap();
    let c = Command::new("glslangValidator")
        .args(["-D", "-e", "main", "-S", "comp", "-V", "-o"])
        .arg(dir.path().join("b.spv"))
        .arg(&hlsl)
        .output()
        .unwrap();
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stdout));
    // With -o the layout goes to the TOML and the code beside it.
    let toml = dir.path().join("chosen.toml");
    let o = support::gbuf(
        dir.path(),
        &["budget", dump.to_str().unwrap(), "--max-bytes", "12", "-o", toml.to_str().unwrap(), "--emit", "glsl"],
    );
    assert!(o.status.success(), "{}", support::stderr(&o));
    assert!(toml.is_file() && dir.path().join("chosen.glsl").is_file());
    // WGSL from the same command validates in naga as it is (the layout is packed and unpacked bit for bit in the
    // tests above; here: the one command's output is a valid module).
    let o = support::gbuf(dir.path(), &["budget", dump.to_str().unwrap(), "--max-bytes", "12", "--emit", "wgsl"]);
    assert!(o.status.success(), "{}", support::stderr(&o));
    let wgsl = String::from_utf8(o.stdout).unwrap();
    let module = naga::front::wgsl::parse_str(&wgsl).unwrap_or_else(|e| panic!("{}", e.emit_to_string(&wgsl)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&wgsl)));
    assert!(module.functions.iter().any(|(_, f)| f.name.as_deref() == Some("gbuf_unpack")));
}

/// Runs a compute shader over `n` items: argv = shader, input file (binding 0), output words per item, n, output
/// file (binding 2).
const RUN_ITEMS: &str = r#"
import sys, moderngl
shader, inp, per, n, out = sys.argv[1:]
per, n = int(per), int(n)
ctx = moderngl.create_standalone_context(backend="egl", require=450)
assert "llvmpipe" in ctx.info["GL_RENDERER"], ctx.info["GL_RENDERER"]
cs = ctx.compute_shader(open(shader).read())
bi = ctx.buffer(open(inp, "rb").read())
bo = ctx.buffer(reserve=n * per * 4)
bi.bind_to_storage_buffer(0)
bo.bind_to_storage_buffer(2)
cs.run(group_x=(n + 63) // 64)
ctx.finish()
open(out, "wb").write(bo.read())
"#;

/// A double with a random sign, a significand of 53 random bits and an exponent in ±`e`.
fn random_f64(r: &mut gbuf::base::rng::SplitMix64, e: i32) -> f64 {
    let m = 1.0 + (r.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    let x = (r.next_u64() % (2 * e as u64 + 1)) as i32 - e;
    let s = if r.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
    s * m * 2f64.powi(x)
}

/// WGSL's software double (`F64_WGSL`, what the f64 codecs run on in WGSL) against Rust's f64, bit for bit, on
/// llvmpipe: add, sub, mul, div, to f32, gbuf's code rounding and the conversions, over random doubles of wide and
/// narrow range, random singles, exact ties of every rounding, cancellation, overflow and the single's subnormals.
#[test]
fn wgsl_software_double_matches_rust_f64_on_llvmpipe() {
    if !(support::python_has("moderngl, numpy") && support::tool_has("spirv-cross")) {
        return;
    }
    let mut r = gbuf::base::rng::SplitMix64::new(64);
    let mut pairs: Vec<(f64, f64)> = Vec::new();
    for _ in 0..20_000 {
        pairs.push((random_f64(&mut r, 60), random_f64(&mut r, 60)));
        pairs.push((random_f64(&mut r, 3), random_f64(&mut r, 3)));
        let (a, b) = (f64::from(r.range_f32(-100.0, 100.0)), f64::from(r.range_f32(-1.0, 1.0)));
        pairs.push((a, b));
        // Cancellation: b within a few ulps of −a.
        pairs.push((a, -a * (1.0 + (r.next_u64() % 5) as f64 * f64::EPSILON)));
        // Ties of the f64 → f32 rounding and of the code rounding.
        let f = r.range_f32(-3.0e4, 3.0e4);
        let up = f32::from_bits(f.to_bits() + 1);
        pairs.push(((f64::from(f) + f64::from(up)) / 2.0, (r.next_u64() % 40_000) as f64 + 0.5));
        // Singles' subnormals and overflow on the way back.
        pairs.push((random_f64(&mut r, 4) * 2f64.powi(-135), random_f64(&mut r, 4) * 2f64.powi(127)));
        // Exact products and quotients of singles (the codecs' shape).
        pairs.push((f64::from(r.next_f32()), f64::from((r.next_u64() % (1 << 24)) as u32)));
    }
    for s in [0.0, -0.0, 1.0, -1.0, 16_777_216.0, 16_777_216.5, -16_777_217.0, 0.5, -0.5, 1.5, 2.5, f64::INFINITY] {
        pairs.push((s, 0.0));
        pairs.push((s, -0.0));
        pairs.push((s, 3.0));
        pairs.push((s, f64::NEG_INFINITY));
        pairs.push((0.0, s));
    }
    let n = pairs.len();
    let mut inp = Vec::with_capacity(n * 16);
    for (a, b) in &pairs {
        inp.extend_from_slice(&a.to_le_bytes());
        inp.extend_from_slice(&b.to_le_bytes());
    }
    // Per item: add, sub, mul, div (2 words each), to_f32(a), round(a), from_f32(f32(a)) (2), from_i32(round(a))
    // (2), clamp(a, −1, b) (2), lt(a, b).
    const PER: usize = 16;
    let shader = format!(
        "{}\nstruct In {{ d: array<u32> }}\nstruct Out {{ d: array<u32> }}\n\
         @group(0) @binding(0) var<storage, read> inp: In;\n@group(0) @binding(2) var<storage, read_write> outp: Out;\n\
         fn put(k: u32, v: vec2<u32>) {{ outp.d[k] = v.x; outp.d[k + 1u] = v.y; }}\n\
         @compute @workgroup_size(64)\nfn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
         let i = id.x;\n  if (i >= {n}u) {{ return; }}\n\
         let a = vec2<u32>(inp.d[4u * i], inp.d[4u * i + 1u]);\n  let b = vec2<u32>(inp.d[4u * i + 2u], inp.d[4u * i + 3u]);\n\
         let o = i * {PER}u;\n  put(o, gbuf_d_add(a, b));\n  put(o + 2u, gbuf_d_sub(a, b));\n  put(o + 4u, gbuf_d_mul(a, b));\n\
         put(o + 6u, gbuf_d_div(a, b));\n  outp.d[o + 8u] = bitcast<u32>(gbuf_d_to_f32(a));\n\
         outp.d[o + 9u] = bitcast<u32>(gbuf_d_round(a));\n  put(o + 10u, gbuf_d_from_f32(gbuf_d_to_f32(a)));\n\
         put(o + 12u, gbuf_d_from_i32(gbuf_d_round(a)));\n  put(o + 14u, gbuf_d_clamp(a, gbuf_d_from_i32(-1), b));\n}}\n",
        gbuf::layout::shader::F64_WGSL
    );
    let dir = tempfile::tempdir().unwrap();
    let comp = dir.path().join("f64.comp");
    wgsl_to_glsl(&shader, dir.path(), "f64", &comp);
    let (fi, fo, run) = (dir.path().join("f64.in"), dir.path().join("f64.out"), dir.path().join("run.py"));
    std::fs::write(&fi, &inp).unwrap();
    std::fs::write(&run, RUN_ITEMS).unwrap();
    let o = Command::new("python3")
        .arg(&run)
        .args([&comp, &fi])
        .args([PER.to_string(), n.to_string()])
        .arg(&fo)
        .output()
        .expect("python3");
    assert!(o.status.success(), "driver run: {}", String::from_utf8_lossy(&o.stderr));
    let got = std::fs::read(&fo).unwrap();
    let w = |k: usize| u32::from_le_bytes(got[k * 4..k * 4 + 4].try_into().unwrap());
    let d = |k: usize| u64::from(w(k)) | (u64::from(w(k + 1)) << 32);
    // NaN results compare as "a NaN", whatever its payload; a flushed f64 subnormal counts as the zero it is
    // documented to be (never reached from the codecs' inputs), so the pairs avoid producing them.
    let same = |got: u64, want: f64| (want.is_nan() && f64::from_bits(got).is_nan()) || got == want.to_bits();
    let mut bad = Vec::new();
    for (i, &(a, b)) in pairs.iter().enumerate() {
        let o = i * PER;
        let round = gbuf::codec::normal::round_in_range_f64(a);
        let checks: [(&str, bool); 8] = [
            ("add", same(d(o), a + b)),
            ("sub", same(d(o + 2), a - b)),
            ("mul", same(d(o + 4), a * b)),
            ("div", same(d(o + 6), a / b)),
            ("to_f32", w(o + 8) == (a as f32).to_bits() || ((a as f32).is_nan() && f32::from_bits(w(o + 8)).is_nan())),
            ("round", a.is_nan() || w(o + 9) as i32 == round),
            ("from_f32", a.is_nan() || same(d(o + 10), f64::from(a as f32))),
            (
                "clamp",
                a.is_nan()
                    || b < -1.0
                    || same(d(o + 14), a.clamp(-1.0, b))
                    || (a == 0.0 && f64::from_bits(d(o + 14)) == 0.0),
            ),
        ];
        for (name, ok) in checks {
            if !ok && bad.len() < 10 {
                bad.push(format!("{name}({a:e}, {b:e})"));
            }
        }
        if !a.is_nan() && f64::from_bits(d(o + 12)) != f64::from(round) {
            bad.push(format!("from_i32({round})"));
        }
    }
    assert!(bad.is_empty(), "{} items; first mismatches: {bad:?}", n);
}

/// `spherical` and `lambert-sphere` go through the driver's `atan`, `sin` and `cos`, and `log2-unorm` over 12 bits
/// through its `log2` and `exp2`, which the shading languages let differ from libm by several ulps: their code is
/// emitted, and the difference is measured and bounded instead of zero (docs/SHADERS.md, "Not bit-exact").
#[test]
fn spherical_through_the_drivers_transcendentals_is_within_its_measured_bound() {
    if !drivers_ready() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let frames = [("raster", fixture()), ("every", every_attribute())];
    for c in ["spherical-16", "spherical-24", "lambert-sphere-16", "lambert-sphere-24"] {
        let b = bits_of("normal", c);
        let layout = one_field("normal", c, "rgba32ui", 0);
        for (tag, gb) in &frames {
            for lang in [Lang::Glsl, Lang::Hlsl, Lang::Wgsl] {
                let m = measure(&layout, gb, dir.path(), &format!("{c}-{tag}"), lang, b / 2);
                println!(
                    "{c} {tag} {}: packed codes differ in {} of {} samples (largest step {}); decoded normal words in \
                     {}; largest normal difference {:.2e}°",
                    lang.name(),
                    m.bad_pack,
                    m.samples,
                    m.max_code_step,
                    m.bad - m.bad_pack,
                    m.max_normal_deg
                );
                // Measured on llvmpipe: at most 38 of 138 745 samples one code off, decodes within 7.8e-6°.
                assert!(m.max_code_step <= 1, "{c} {tag}: a code more than one step from gbuf's: {}", m.first);
                assert!(m.bad_pack * 1000 <= m.samples, "{c} {tag}: {} of {} codes differ", m.bad_pack, m.samples);
                assert!(m.max_normal_deg < 1e-4, "{c} {tag}: decoded normals {}° from gbuf's", m.max_normal_deg);
            }
        }
    }
    // log2-unorm wider than its exact tables: the driver's log2 and exp2.
    for c in ["log2-unorm-13", "log2-unorm-16", "log2-unorm-24"] {
        let b = bits_of("specular_power", c);
        let layout = one_field("specular_power", c, "r32ui", 0);
        let gb = every_attribute();
        for lang in [Lang::Glsl, Lang::Hlsl, Lang::Wgsl] {
            let m = measure(&layout, &gb, dir.path(), c, lang, b);
            println!(
                "{c} {}: codes differ in {} of {} samples (largest step {}); largest relative power difference {:.2e}",
                lang.name(),
                m.bad_pack,
                m.samples,
                m.max_code_step,
                m.max_power_rel
            );
            // Measured on llvmpipe: 13 and 16 bits 0 codes off; 24 bits (finer than an f32 log2 resolves near 1)
            // 45 of 1370 codes off by up to 2 steps.
            let (step, percent) = if b <= 16 { (1, 1) } else { (2, 5) };
            assert!(m.max_code_step <= step, "{c}: {}", m.first);
            assert!(m.bad_pack * 100 <= percent * m.samples, "{c}: {} of {} codes differ", m.bad_pack, m.samples);
            assert!(m.max_power_rel < 1e-5, "{c}: decoded powers {} apart (relative)", m.max_power_rel);
        }
    }
}

/// A stand-in for the prefix RenderDoc inserts after `#version` in a custom display shader, declaring what its
/// documentation promises (the `RD_*_BINDING` slots, `RD_TextureType_*` and the `RD_*()` helpers over a uniform
/// block at binding 0), so that glslang can compile the views outside RenderDoc. (RenderDoc's own compile of them
/// runs in `tests/packed_input.rs`, in its replay.)
const RD_STAND_IN: &str = "
#define RD_FLOAT_2D_BINDING 2
#define RD_FLOAT_2D_ARRAY_BINDING 6
#define RD_FLOAT_2DMS_BINDING 10
#define RD_FLOAT_2DMS_ARRAY_BINDING 11
#define RD_UINT_2D_BINDING 22
#define RD_UINT_2D_ARRAY_BINDING 26
#define RD_UINT_2DMS_BINDING 30
#define RD_UINT_2DMS_ARRAY_BINDING 31
const uint RD_TextureType_2D = 2u;
const uint RD_TextureType_2D_Array = 6u;
const uint RD_TextureType_2DMS = 10u;
const uint RD_TextureType_2DMS_Array = 11u;
layout(binding = 0, std140) uniform RdStandIn { uvec4 dim; uint mip; uint type; uint slice; int sample_; } rd_stand_in;
uint RD_TextureType() { return rd_stand_in.type; }
int RD_SelectedSample() { return rd_stand_in.sample_; }
uint RD_SelectedMip() { return rd_stand_in.mip; }
uint RD_SelectedSliceFace() { return rd_stand_in.slice; }
";

#[test]
fn renderdoc_views_of_every_layout_compile_with_glslang() {
    if !support::tool_has("glslangValidator") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut compiled = 0;
    for layout in Layout::builtins().into_iter().chain(Layout::visibility_builtins()) {
        let Ok(views) = gbuf::layout::renderdoc::views(&layout, Some((0.1, 100.0))) else {
            assert!(layout.indirection().is_some(), "{}: no views", layout.name());
            continue;
        };
        for v in &views.views {
            let (version, body) = v.code.split_once('\n').unwrap();
            // The OpenGL and the Vulkan spelling (glslang's -V defines VULKAN, as RenderDoc's Vulkan prefix does).
            let spv = dir.path().join("out.spv");
            let spv = spv.to_str().unwrap();
            for (vulkan, flags) in [(false, vec!["-S", "frag"]), (true, vec!["-V", "-S", "frag", "-o", spv])] {
                let src = format!("{version}\n{RD_STAND_IN}\n{body}");
                let path = dir.path().join(format!("{}{}.frag", v.file, if vulkan { ".vk" } else { "" }));
                std::fs::write(&path, src).unwrap();
                let o = Command::new("glslangValidator").args(&flags).arg(&path).output().unwrap();
                assert!(
                    o.status.success(),
                    "{} ({}) does not compile:\n{}{}",
                    v.file,
                    if vulkan { "Vulkan" } else { "OpenGL" },
                    String::from_utf8_lossy(&o.stdout),
                    String::from_utf8_lossy(&o.stderr)
                );
                compiled += 1;
            }
        }
    }
    assert!(compiled >= 40, "only {compiled} views compiled");
}
