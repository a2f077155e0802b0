//! Structure-aware: a canonical G-buffer of any size (1–12 pixels a side), sample count (1–64, standard, square or
//! with explicit positions), attribute set, values (NaN, ±Inf, sentinels, any bits), camera (usable or not) and
//! material catalogue, converted with `canonical::to_raw`, then edited (channels dropped, retyped, renamed,
//! duplicated; header attributes set or removed, with values that matter to the reader), split into parts and
//! written with the exr crate in any compression, block layout and line order.
//!
//! Checked: an unedited, valid G-buffer written losslessly reads back bit-exactly through `read_raw_bytes` +
//! `canonical::from_raw`. Every file, edited or not, is then loaded with `load_bytes` under fuzzed options (fold,
//! sidecar, DWA, memory limit).
#![no_main]

use arbitrary::Arbitrary;
use gbuf::gbuffer::{Attribute, GBuffer, MaterialParams};
use gbuf::io::canonical;
use gbuf::io::exr::{RawChannel, RawData, RawImage};
use gbuf_fuzz::gen::{self, convert, EncodingIn, Fill, LoadIn, Name, Part, Ty, Val};
use libfuzzer_sys::fuzz_target;

const SAMPLES: [u32; 14] = [1, 2, 4, 8, 16, 9, 25, 36, 64, 3, 5, 6, 12, 32];

#[derive(Debug, Arbitrary)]
enum Edit {
    Drop(u16),
    Retype(u16, Ty),
    Rename(u16, Name),
    Duplicate(u16, Name),
    SetAttr(Name, Name),
    RemoveAttr(Name),
}

#[derive(Debug, Arbitrary)]
struct Input {
    width: u8,
    height: u8,
    samples: u8,
    positions: Option<Vec<(i8, i8)>>,
    attrs: u16,
    fills: Vec<Fill>,
    coverage: Fill,
    camera: Option<gen::CameraIn>,
    materials: Vec<(u8, Option<Val>, Option<Val>, Option<Val>, Option<Val>)>,
    encoding: EncodingIn,
    parts: Option<(u8, Name, Name)>,
    edits: Vec<Edit>,
    load: LoadIn,
}

fn build(input: &Input) -> GBuffer {
    let (w, h) = (gen::dim(input.width, 12), gen::dim(input.height, 12));
    let spp = SAMPLES[input.samples as usize % SAMPLES.len()];
    let mut gb = GBuffer::new(w, h, spp).unwrap_or_else(|_| GBuffer {
        width: w,
        height: h,
        samples: spp,
        sample_positions: vec![glam::Vec2::ZERO; spp as usize],
        coverage: vec![false; (w * h * spp) as usize],
        ..GBuffer::default()
    });
    if let Some(p) = input.positions.as_ref().filter(|p| p.len() >= spp as usize) {
        gb.sample_positions =
            p[..spp as usize].iter().map(|&(x, y)| glam::Vec2::new(f32::from(x), f32::from(y)) / 256.0).collect();
    }
    gb.coverage.iter_mut().enumerate().for_each(|(i, c)| *c = input.coverage.u32_at(i) & 1 == 1);
    let default = Fill::Const(Val::Special(2));
    for (k, attr) in Attribute::ALL.into_iter().enumerate() {
        if input.attrs & (1 << k) == 0 {
            continue;
        }
        let fill = |c: usize| input.fills.get((k * 3 + c) % input.fills.len().max(1)).unwrap_or(&default);
        if attr.is_id() {
            gen::set_plane(&mut gb, attr, |i, _| f32::from_bits(fill(0).u32_at(i)));
        } else {
            gen::set_plane(&mut gb, attr, |i, c| fill(c).f32_at(i));
        }
    }
    gb.camera = input.camera.as_ref().map(|c| c.build(w, h).to_camera());
    gb.materials = input
        .materials
        .iter()
        .take(4)
        .map(|m| MaterialParams {
            id: u32::from(m.0),
            name: None,
            specular: m.1.map(Val::f32),
            specular_power: m.2.map(Val::f32),
            roughness: m.3.map(Val::f32),
            metallic: m.4.map(Val::f32),
        })
        .collect();
    gb
}

fn bits_equal(a: &GBuffer, b: &GBuffer) -> bool {
    let f = |x: &Option<Vec<f32>>| x.as_ref().map(|v| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>());
    let v2 = |x: &Option<Vec<glam::Vec2>>| {
        x.as_ref().map(|v| v.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect::<Vec<_>>())
    };
    let v3 = |x: &Option<Vec<glam::Vec3>>| {
        x.as_ref().map(|v| v.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect::<Vec<_>>())
    };
    (a.width, a.height, a.samples) == (b.width, b.height, b.samples)
        && a.sample_positions == b.sample_positions
        && a.coverage == b.coverage
        && a.camera == b.camera
        && serde_json::to_string(&a.materials).ok() == serde_json::to_string(&b.materials).ok()
        && f(&a.depth) == f(&b.depth)
        && v3(&a.position) == v3(&b.position)
        && v3(&a.normal) == v3(&b.normal)
        && v3(&a.albedo) == v3(&b.albedo)
        && f(&a.specular) == f(&b.specular)
        && f(&a.specular_power) == f(&b.specular_power)
        && f(&a.roughness) == f(&b.roughness)
        && f(&a.metallic) == f(&b.metallic)
        && a.material_id == b.material_id
        && a.object_id == b.object_id
        && a.primitive_id == b.primitive_id
        && v2(&a.motion) == v2(&b.motion)
}

fn apply(raw: &mut RawImage, e: &Edit) {
    let n = raw.channels.len();
    let at = |i: u16| (n > 0).then(|| i as usize % n);
    match e {
        Edit::Drop(i) => {
            if let Some(i) = at(*i) {
                raw.channels.remove(i);
            }
        }
        Edit::Retype(i, ty) => {
            if let Some(i) = at(*i) {
                raw.channels[i].data = convert(&raw.channels[i].data, *ty);
            }
        }
        Edit::Rename(i, name) => {
            if let Some(i) = at(*i) {
                raw.channels[i].name = name.resolve(gen::CHANNEL_NAMES);
            }
        }
        Edit::Duplicate(i, name) => {
            if let Some(i) = at(*i) {
                let data = raw.channels[i].data.clone();
                raw.channels.push(RawChannel { name: name.resolve(gen::CHANNEL_NAMES), data });
            }
        }
        Edit::SetAttr(k, v) => {
            let k = k.resolve(gen::ATTRIBUTE_NAMES);
            let v = v.resolve(gen::ATTRIBUTE_VALUES);
            raw.attributes.retain(|(a, _)| *a != k);
            raw.attributes.push((k, v));
        }
        Edit::RemoveAttr(k) => {
            let k = k.resolve(gen::ATTRIBUTE_NAMES);
            raw.attributes.retain(|(a, _)| *a != k);
        }
    }
}

fn types(raw: &RawImage) -> impl Iterator<Item = Ty> + '_ {
    raw.channels.iter().map(|c| match c.data {
        RawData::F16(_) => Ty::F16,
        RawData::F32(_) => Ty::F32,
        RawData::U32(_) => Ty::U32,
    })
}

fuzz_target!(init: gbuf_fuzz::init(), |input: Input| {
    gbuf_fuzz::run(|| {
        let gb = build(&input);
        let path = gen::path();
        let mut raw = canonical::to_raw(&gb);
        let usable_camera = gb.camera.as_ref().is_none_or(|c| c.is_valid());
        let valid = gb.validate().is_ok() && usable_camera && MaterialParams::validate_all(&gb.materials).is_ok();
        if valid && input.encoding.lossless_for(types(&raw)) {
            if let Some(bytes) = gen::encode(&[Part::from_raw(&raw)], &input.encoding) {
                let back = gbuf::io::exr::read_raw_bytes(&bytes, &path, &gbuf_fuzz::limits(false))
                    .expect("a canonical file the exr crate wrote reads");
                let read = canonical::from_raw(&back, &path).expect("a valid canonical G-buffer reads back");
                assert!(bits_equal(&gb, &read), "canonical round trip differs:\nwrote {gb:?}\nread {read:?}");
            }
        }
        for e in input.edits.iter().take(8) {
            apply(&mut raw, e);
        }
        let mut parts = vec![Part::from_raw(&raw)];
        if let Some((k, a, b)) = &input.parts {
            let m = 2 + *k as usize % 3;
            let (first, second): (Vec<_>, Vec<_>) =
                parts[0].channels.drain(..).enumerate().partition(|(i, _)| i % m != 0);
            parts[0].channels = first.into_iter().map(|(_, c)| c).collect();
            parts[0].layer = Some(a.resolve(&["main", "s0", "ViewLayer", "rgba"]));
            let second = Part {
                layer: Some(b.resolve(&["aux", "s1", "depth", "coverage"])),
                channels: second.into_iter().map(|(_, c)| c).collect(),
                attributes: Vec::new(),
                ..parts[0].clone()
            };
            parts.push(second);
        }
        let Some(bytes) = gen::encode(&parts, &input.encoding) else { return };
        let opts = input.load.options(raw.width, raw.height);
        gbuf_fuzz::loaded(&gbuf::io::load_bytes(&bytes, &path, &opts), &path);
    });
});
