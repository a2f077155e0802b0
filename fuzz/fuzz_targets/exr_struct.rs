//! Structure-aware: an EXR of 1–16 pixels a side whose channels come in groups named as real renderers name them
//! (Blender view-layer passes short and long, Mitsuba AOVs, LuxCore outputs, canonical layers, generic RGBA/XYZ) or
//! anyhow, of any sample type and values, optionally split into two parts, with header attributes, written with the
//! exr crate in any compression and block layout; loaded with `load_bytes` under a fuzzed `--map` whose channels are
//! picked among the file's, declared conventions (`--space`, `--depth`, `--ids`, `--background`, …), fold, a
//! generated sidecar (camera, lights, materials), DWA and a memory limit. Reaches the Blender, Mitsuba and `--map`
//! readers, conventions, camera fitting and the scalar overrides deeply.
#![no_main]

use arbitrary::Arbitrary;
use gbuf::gbuffer::Attribute;
use gbuf_fuzz::gen::{self, ConventionsIn, EncodingIn, Fill, LoadIn, Name, Part, Ty};
use libfuzzer_sys::fuzz_target;

/// Channel groups: prefix and natural suffixes.
const GROUPS: &[(&str, &[&str])] = &[
    ("ViewLayer.Depth", &["Z"]),
    ("ViewLayer.Normal", &["X", "Y", "Z"]),
    ("ViewLayer.Position", &["X", "Y", "Z"]),
    ("ViewLayer.DiffCol", &["R", "G", "B"]),
    ("ViewLayer.GlossCol", &["R", "G", "B"]),
    ("ViewLayer.IndexMA", &["X"]),
    ("ViewLayer.IndexOB", &["X"]),
    ("ViewLayer.Vector", &["X", "Y", "Z", "W"]),
    ("ViewLayer.Combined", &["R", "G", "B", "A"]),
    ("ViewLayer.Roughness", &["X"]),
    ("ViewLayer.Metallic", &["X"]),
    ("ViewLayer.Specular", &["X"]),
    ("ViewLayer.Diffuse Color", &["R", "G", "B"]),
    ("ViewLayer.Glossy Color", &["R", "G", "B"]),
    ("ViewLayer.Material Index", &["X"]),
    ("ViewLayer.Object Index", &["X"]),
    ("depth", &["T"]),
    ("position", &["X", "Y", "Z"]),
    ("sh_normal", &["X", "Y", "Z"]),
    ("geo_normal", &["X", "Y", "Z"]),
    ("nn", &["X", "Y", "Z"]),
    ("dd.y", &["T"]),
    ("albedo", &["R", "G", "B"]),
    ("shape_index", &["I"]),
    ("prim_index", &["I"]),
    ("uv", &["U", "V"]),
    ("", &["R", "G", "B", "A"]),
    ("", &["Z"]),
    ("N", &["X", "Y", "Z"]),
    ("P", &["X", "Y", "Z"]),
    ("DEPTH", &["R", "G", "B"]),
    ("POSITION", &["R", "G", "B"]),
    ("s0.coverage", &["V"]),
    ("s0.depth", &["Z"]),
];
const SUFFIXES: &[&[&str]] =
    &[&["Z"], &["X", "Y", "Z"], &["R", "G", "B"], &["T"], &["I"], &["U", "V"], &["R", "G", "B", "A"], &["V"], &["ID"]];

#[derive(Debug, Arbitrary)]
struct Group {
    prefix: Name,
    suffixes: Option<u8>,
    ty: Ty,
    fills: Vec<Fill>,
}

#[derive(Debug, Arbitrary)]
struct Input {
    width: u8,
    height: u8,
    groups: Vec<Group>,
    second_part: Option<(u8, Name, Name)>,
    attributes: Vec<(Name, Name)>,
    encoding: EncodingIn,
    map: Vec<(u8, [u16; 3])>,
    conventions: ConventionsIn,
    load: LoadIn,
}

fuzz_target!(init: gbuf_fuzz::init(), |input: Input| {
    gbuf_fuzz::run(|| {
        let (w, h) = (gen::dim(input.width, 16), gen::dim(input.height, 16));
        let n = (w * h) as usize;
        let prefixes: Vec<&str> = GROUPS.iter().map(|g| g.0).collect();
        let mut part = Part { width: w as usize, height: h as usize, ..Part::default() };
        let default = Fill::Const(gen::Val::Special(2));
        for g in input.groups.iter().take(12) {
            let prefix = g.prefix.resolve(&prefixes);
            let natural = GROUPS.iter().find(|x| x.0 == prefix).map_or(&["X", "Y", "Z"][..], |x| x.1);
            let suffixes = g.suffixes.map_or(natural, |k| SUFFIXES[k as usize % SUFFIXES.len()]);
            for (c, s) in suffixes.iter().enumerate() {
                let name = if prefix.is_empty() { s.to_string() } else { format!("{prefix}.{s}") };
                if part.channels.iter().any(|(x, _)| *x == name) {
                    continue;
                }
                let fill = g.fills.get(c % g.fills.len().max(1)).unwrap_or(&default);
                part.channels.push((name, fill.data(g.ty, n)));
            }
        }
        for (k, v) in input.attributes.iter().take(6) {
            part.attributes.push((k.resolve(gen::ATTRIBUTE_NAMES), v.resolve(gen::ATTRIBUTE_VALUES)));
        }
        let names: Vec<String> = part.channels.iter().map(|c| c.0.clone()).collect();
        let mut parts = vec![part];
        if let Some((k, a, b)) = &input.second_part {
            let m = 2 + *k as usize % 3;
            let all = std::mem::take(&mut parts[0].channels);
            let (first, second): (Vec<_>, Vec<_>) = all.into_iter().enumerate().partition(|(i, _)| i % m != 0);
            parts[0].channels = first.into_iter().map(|(_, c)| c).collect();
            parts[0].layer = Some(a.resolve(&["ViewLayer", "main", "rgba"]));
            let mut p2 = Part { layer: Some(b.resolve(&["aux", "depth", "normal"])), ..Part::default() };
            (p2.width, p2.height) = (parts[0].width, parts[0].height);
            p2.channels = second.into_iter().map(|(_, c)| c).collect();
            parts.push(p2);
        }
        let Some(bytes) = gen::encode(&parts, &input.encoding) else { return };
        let mut opts = input.load.options(w, h);
        opts.conventions = input.conventions.overrides();
        if !names.is_empty() {
            for (a, idx) in input.map.iter().take(6) {
                let attr = Attribute::ALL[*a as usize % Attribute::ALL.len()];
                let chans = idx[..attr.components()].iter().map(|&i| names[i as usize % names.len()].clone()).collect();
                opts.map.push((attr, chans));
            }
        }
        let path = gen::path();
        gbuf_fuzz::loaded(&gbuf::io::load_bytes(&bytes, &path, &opts), &path);
    });
});
