//! Generators for the structure-aware targets: values, channel names, header attributes, EXR encodings, sidecars
//! and load options, all built from `arbitrary` data, and the in-memory EXR writer.

use arbitrary::{Arbitrary, Result, Unstructured};
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, IntegerBounds, Layer, LayerAttributes, SmallVec,
    WritableImage,
};
use gbuf::io::conventions::{Background, DepthKind, IdEncoding, NormalEncoding, Overrides, Space};
use gbuf::io::exr::{RawData, RawImage};
use gbuf::io::sidecar::{Sidecar, SidecarCamera, SidecarLight};
use gbuf::io::LoadOptions;
use half::f16;
use std::path::PathBuf;

/// Floats a reader treats specially (background markers, unit components, sentinels, non-finite values).
pub const SPECIAL_F32: [f32; 24] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    0.25,
    2.0,
    3.0,
    10.0,
    0.577_350_26,
    -0.577_350_26,
    0.707_106_77,
    1e9,
    1e10,
    -1e10,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    f32::MIN_POSITIVE,
    f32::MAX,
    65504.0,
    1e-7,
    100.0,
    0.1,
];

/// One value: from [`SPECIAL_F32`], any bit pattern, or a small integer (IDs).
#[derive(Clone, Copy, Debug, Arbitrary)]
pub enum Val {
    /// An index into [`SPECIAL_F32`].
    Special(u8),
    /// Any f32.
    Bits(u32),
    /// A small non-negative integer.
    Small(u8),
}

impl Val {
    /// As a float.
    #[must_use]
    pub fn f32(self) -> f32 {
        match self {
            Val::Special(i) => SPECIAL_F32[i as usize % SPECIAL_F32.len()],
            Val::Bits(b) => f32::from_bits(b),
            Val::Small(v) => f32::from(v),
        }
    }
    /// As an unsigned integer.
    #[must_use]
    pub fn u32(self) -> u32 {
        match self {
            Val::Bits(b) => b,
            Val::Small(v) => u32::from(v),
            Val::Special(i) => i as u32 % 4,
        }
    }
}

/// How a channel's samples are filled: one value, a ramp, or cycling through a short list.
#[derive(Clone, Debug, Arbitrary)]
pub enum Fill {
    /// Every sample the same.
    Const(Val),
    /// `start + i · step`.
    Ramp(Val, Val),
    /// `list[(i · stride) mod len]`.
    Cycle(Vec<Val>, u8),
}

impl Fill {
    /// Sample `i` as f32.
    #[must_use]
    pub fn f32_at(&self, i: usize) -> f32 {
        match self {
            Fill::Const(v) => v.f32(),
            Fill::Ramp(a, b) => a.f32() + i as f32 * b.f32(),
            Fill::Cycle(list, stride) => match list.len() {
                0 => 0.0,
                n => list[(i * (*stride as usize + 1)) % n].f32(),
            },
        }
    }
    /// Sample `i` as u32.
    #[must_use]
    pub fn u32_at(&self, i: usize) -> u32 {
        match self {
            Fill::Const(v) => v.u32(),
            Fill::Ramp(a, b) => a.u32().wrapping_add((i as u32).wrapping_mul(b.u32())),
            Fill::Cycle(list, stride) => match list.len() {
                0 => 0,
                n => list[(i * (*stride as usize + 1)) % n].u32(),
            },
        }
    }
    /// `n` samples of type `ty`.
    #[must_use]
    pub fn data(&self, ty: Ty, n: usize) -> RawData {
        match ty {
            Ty::F16 => RawData::F16((0..n).map(|i| f16::from_f32(self.f32_at(i))).collect()),
            Ty::F32 => RawData::F32((0..n).map(|i| self.f32_at(i)).collect()),
            Ty::U32 => RawData::U32((0..n).map(|i| self.u32_at(i)).collect()),
        }
    }
}

/// A sample type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Arbitrary)]
pub enum Ty {
    /// half.
    F16,
    /// float.
    F32,
    /// uint.
    U32,
}

/// `data` converted to type `ty` (by value).
#[must_use]
pub fn convert(data: &RawData, ty: Ty) -> RawData {
    let n = data.len();
    match ty {
        Ty::F16 => RawData::F16((0..n).map(|i| f16::from_f32(data.f32_at(i))).collect()),
        Ty::F32 => RawData::F32((0..n).map(|i| data.f32_at(i)).collect()),
        Ty::U32 => RawData::U32(match data {
            RawData::U32(v) => v.clone(),
            _ => (0..n).map(|i| data.f32_at(i) as u32).collect(),
        }),
    }
}

/// Channel names seen in fixtures/ and named in the readers (canonical, Blender short and long pass names, Mitsuba
/// AOVs, LuxCore file sets, generic RGBA/XYZ).
pub const CHANNEL_NAMES: &[&str] = &[
    "s0.coverage.V",
    "s0.depth.Z",
    "s0.position.X",
    "s0.position.Y",
    "s0.position.Z",
    "s0.normal.X",
    "s0.normal.Y",
    "s0.normal.Z",
    "s0.albedo.R",
    "s0.albedo.G",
    "s0.albedo.B",
    "s0.specular.V",
    "s0.specular_power.V",
    "s0.roughness.V",
    "s0.metallic.V",
    "s0.material_id.ID",
    "s0.object_id.ID",
    "s0.primitive_id.ID",
    "s0.motion.X",
    "s0.motion.Y",
    "s1.coverage.V",
    "s1.depth.Z",
    "s1.normal.X",
    "s1.normal.Y",
    "s1.normal.Z",
    "ViewLayer.Depth.Z",
    "ViewLayer.Normal.X",
    "ViewLayer.Normal.Y",
    "ViewLayer.Normal.Z",
    "ViewLayer.Position.X",
    "ViewLayer.Position.Y",
    "ViewLayer.Position.Z",
    "ViewLayer.DiffCol.R",
    "ViewLayer.DiffCol.G",
    "ViewLayer.DiffCol.B",
    "ViewLayer.Diffuse Color.R",
    "ViewLayer.Diffuse Color.G",
    "ViewLayer.Diffuse Color.B",
    "ViewLayer.GlossCol.R",
    "ViewLayer.GlossCol.G",
    "ViewLayer.GlossCol.B",
    "ViewLayer.Glossy Color.R",
    "ViewLayer.IndexMA.X",
    "ViewLayer.Material Index.X",
    "ViewLayer.IndexOB.X",
    "ViewLayer.Object Index.X",
    "ViewLayer.Vector.X",
    "ViewLayer.Vector.Y",
    "ViewLayer.Vector.Z",
    "ViewLayer.Vector.W",
    "ViewLayer.Combined.R",
    "ViewLayer.Combined.G",
    "ViewLayer.Combined.B",
    "ViewLayer.Combined.A",
    "ViewLayer.Roughness.X",
    "ViewLayer.Metallic.X",
    "ViewLayer.Specular.X",
    "ViewLayer.Specular Power.X",
    "depth.T",
    "position.X",
    "position.Y",
    "position.Z",
    "sh_normal.X",
    "sh_normal.Y",
    "sh_normal.Z",
    "geo_normal.X",
    "geo_normal.Y",
    "geo_normal.Z",
    "nn.X",
    "nn.Y",
    "nn.Z",
    "albedo.R",
    "albedo.G",
    "albedo.B",
    "shape_index.I",
    "prim_index.I",
    "uv.U",
    "uv.V",
    "R",
    "G",
    "B",
    "A",
    "Y",
    "Z",
    "X",
    "N.X",
    "N.Y",
    "N.Z",
    "P.X",
    "P.Y",
    "P.Z",
];

/// Header attribute names: the canonical format's and ones real files carry.
pub const ATTRIBUTE_NAMES: &[&str] = &[
    "gbuf.format",
    "gbuf.version",
    "gbuf.samples",
    "gbuf.sample_positions",
    "gbuf.camera",
    "gbuf.materials",
    "BlenderMultiChannel",
    "Camera",
    "cycles.ViewLayer.samples",
    "generatedBy",
    "type",
];

/// Header attribute values worth trying.
pub const ATTRIBUTE_VALUES: &[&str] = &[
    "gbuf-canonical",
    "1",
    "0",
    "2",
    "4",
    "9",
    "64",
    "65",
    "-1",
    " 4 ",
    "4294967297",
    "[[0,0]]",
    "[[-0.25,-0.25],[0.25,0.25]]",
    "[[-0.125,0.375],[0.375,0.125],[-0.375,-0.125],[0.125,-0.375]]",
    "[[0.6,0]]",
    "[]",
    "{}",
    "null",
    r#"{"world_to_view":[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],"yfov":0.8,"aspect":1.3333,"znear":0.1,"zfar":100}"#,
    r#"{"world_to_view":[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],"yfov":0.8,"aspect":1,"znear":0.1,"zfar":100,"principal_point":[0.1,-0.1]}"#,
    r#"{"world_to_view":[[0,0,0,0],[0,0,0,0],[0,0,0,0],[0,0,0,0]],"yfov":0.8,"aspect":1,"znear":0.1,"zfar":100}"#,
    r#"[{"id":1,"specular":0.5,"roughness":0.3}]"#,
    r#"[{"id":1},{"id":1}]"#,
    r#"[{"id":2,"name":"m","specular_power":-1}]"#,
    "Blender V2.55.1 and newer",
    "Mitsuba version 3.9.1",
    "scanlineimage",
    "",
];

/// A name: from a list, or any text.
#[derive(Clone, Debug, Arbitrary)]
pub enum Name {
    /// An index into the list.
    Known(u8),
    /// Text of its own.
    Own(String),
    /// A canonical channel name at another sample index (`s<i>.<layer>.<comp>` of a listed canonical name).
    Sample(u8, u8),
}

impl Name {
    /// The name, taking listed names from `list`.
    #[must_use]
    pub fn resolve(&self, list: &[&str]) -> String {
        match self {
            Name::Known(i) => list[*i as usize % list.len()].to_string(),
            Name::Own(s) => s.clone(),
            Name::Sample(k, s) => {
                let base = CHANNEL_NAMES[*k as usize % 20];
                format!("s{s}{}", &base[2..])
            }
        }
    }
}

/// Compressions the exr crate writes, indexed by their OpenEXR id (0 NONE, 1 RLE, 2 ZIPS, 3 ZIP, 4 PIZ, 5 PXR24,
/// 6 B44, 7 B44A) and then again without PIZ: its encoder builds 64 K-entry Huffman tables for every block, which
/// made PIZ files cost the structure-aware targets more than half of their time when picked one time in eight.
/// DWA and the rest are reached by patching the header, see [`EncodingIn::compression_patch`].
const WRITABLE: [exr::compression::Compression; 16] = {
    use exr::compression::Compression as C;
    [
        C::Uncompressed,
        C::RLE,
        C::ZIP1,
        C::ZIP16,
        C::PIZ,
        C::PXR24,
        C::B44,
        C::B44A,
        C::Uncompressed,
        C::RLE,
        C::ZIP1,
        C::ZIP16,
        C::PXR24,
        C::B44,
        C::B44A,
        C::Uncompressed,
    ]
};

/// How to encode: compression, scan lines or tiles, line order, and optionally a different compression byte
/// patched into the header afterwards (so DWAA/DWAB/HTJ2K decoders see data written for another method; the
/// offset table stays consistent when both methods put as many lines in a block, e.g. PIZ → DWAA, 32 lines, or any
/// image of at most 16 lines).
#[derive(Clone, Debug, Arbitrary)]
pub struct EncodingIn {
    /// Index into the writable compressions (0–7: the OpenEXR ids NONE … B44A).
    pub compression: u8,
    /// Tile size − 1 (else scan lines).
    pub tiles: Option<(u8, u8)>,
    /// 0 increasing, 1 decreasing, 2 unspecified.
    pub line_order: u8,
    /// Compression byte to patch into the header after writing.
    pub compression_patch: Option<u8>,
}

impl EncodingIn {
    /// Scan lines in increasing order with compression `c` (an OpenEXR id 0..=7).
    #[must_use]
    pub fn scan_lines(c: u8) -> Self {
        EncodingIn { compression: c, tiles: None, line_order: 0, compression_patch: None }
    }
    /// The exr crate's encoding.
    #[must_use]
    pub fn encoding(&self) -> Encoding {
        use exr::meta::attribute::LineOrder;
        Encoding {
            compression: WRITABLE[self.compression as usize % WRITABLE.len()],
            blocks: match self.tiles {
                None => exr::image::Blocks::ScanLines,
                Some((w, h)) => exr::image::Blocks::Tiles(exr::math::Vec2(1 + w as usize % 32, 1 + h as usize % 32)),
            },
            line_order: match self.line_order % 3 {
                0 => LineOrder::Increasing,
                1 => LineOrder::Decreasing,
                _ => LineOrder::Unspecified,
            },
        }
    }
    /// Does the written file keep every sample of these types exactly (no lossy compression, no patch)?
    #[must_use]
    pub fn lossless_for(&self, types: impl IntoIterator<Item = Ty>) -> bool {
        use exr::meta::attribute::SampleType as S;
        let c = self.encoding().compression;
        self.compression_patch.is_none()
            && types.into_iter().all(|t| {
                c.is_lossless_for(match t {
                    Ty::F16 => S::F16,
                    Ty::F32 => S::F32,
                    Ty::U32 => S::U32,
                })
            })
    }
}

/// One part of a file to write.
#[derive(Clone, Debug, Default)]
pub struct Part {
    /// Layer (part) name; needed by the exr crate when there are several parts.
    pub layer: Option<String>,
    /// Size.
    pub width: usize,
    /// Size.
    pub height: usize,
    /// Channels; each has `width × height` samples.
    pub channels: Vec<(String, RawData)>,
    /// Text header attributes.
    pub attributes: Vec<(String, String)>,
}

impl Part {
    /// A single part holding all of `raw`.
    #[must_use]
    pub fn from_raw(raw: &RawImage) -> Part {
        Part {
            layer: None,
            width: raw.width as usize,
            height: raw.height as usize,
            channels: raw.channels.iter().map(|c| (c.name.clone(), c.data.clone())).collect(),
            attributes: raw.attributes.clone(),
        }
    }
}

/// Writes `parts` as an EXR in memory; `None` when the exr crate refuses (names outside Latin-1, duplicate or
/// missing names, sizes it cannot encode, …): generators may build files no writer would.
#[must_use]
pub fn encode(parts: &[Part], enc: &EncodingIn) -> Option<Vec<u8>> {
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| encode_inner(parts, enc)));
    match r {
        Ok(v) => v,
        Err(_) => {
            crate::forget_panic();
            None
        }
    }
}

fn encode_inner(parts: &[Part], enc: &EncodingIn) -> Option<Vec<u8>> {
    use exr::meta::attribute::{AttributeValue, Text};
    let first = parts.first()?;
    let mut layers: SmallVec<[Layer<AnyChannels<FlatSamples>>; 2]> = SmallVec::new();
    for p in parts {
        let n = p.width * p.height;
        let mut list = SmallVec::new();
        for (name, data) in &p.channels {
            if data.len() != n {
                return None;
            }
            let samples = match data {
                RawData::F16(v) => FlatSamples::F16(v.clone()),
                RawData::F32(v) => FlatSamples::F32(v.clone()),
                RawData::U32(v) => FlatSamples::U32(v.clone()),
            };
            list.push(AnyChannel::new(Text::new_or_none(name.as_str())?, samples));
        }
        let mut attributes = LayerAttributes::default();
        if let Some(l) = &p.layer {
            attributes.layer_name = Some(Text::new_or_none(l.as_str())?);
        }
        for (k, v) in &p.attributes {
            attributes
                .other
                .insert(Text::new_or_none(k.as_str())?, AttributeValue::Text(Text::new_or_none(v.as_str())?));
        }
        layers.push(Layer::new((p.width, p.height), attributes, enc.encoding(), AnyChannels::sort(list)));
    }
    let image = Image::new(
        exr::meta::header::ImageAttributes::new(IntegerBounds::from_dimensions((first.width, first.height))),
        layers,
    );
    let mut out = std::io::Cursor::new(Vec::new());
    image.write().non_parallel().to_buffered(&mut out).ok()?;
    let mut bytes = out.into_inner();
    if let Some(c) = enc.compression_patch {
        patch_compression(&mut bytes, c);
    }
    Some(bytes)
}

/// Replaces the value of every `compression` attribute in the headers of `bytes` by `value` (OpenEXR ids: 0 NONE,
/// 1 RLE, 2 ZIPS, 3 ZIP, 4 PIZ, 5 PXR24, 6 B44, 7 B44A, 8 DWAA, 9 DWAB, 10–11 HTJ2K).
pub fn patch_compression(bytes: &mut [u8], value: u8) {
    const KEY: &[u8] = b"compression\0compression\0\x01\0\0\0";
    let mut i = 0;
    while let Some(at) = bytes[i..].windows(KEY.len()).position(|w| w == KEY) {
        let v = i + at + KEY.len();
        if v < bytes.len() {
            bytes[v] = value % 12;
        }
        i = v;
    }
}

/// A sidecar camera: near a usable one, with any field replaced.
#[derive(Clone, Debug, Arbitrary)]
pub struct CameraIn {
    rotation: u8,
    translation: [i8; 3],
    yfov: Option<Val>,
    /// `None`: the image's aspect (so the loader's aspect check passes).
    aspect: Option<Val>,
    znear: Option<Val>,
    zfar: Option<Val>,
    principal: Option<(Val, Val)>,
    intrinsics: Option<[Val; 4]>,
    matrix_edit: Option<(u8, Val)>,
}

impl CameraIn {
    /// The camera for an image of `width × height` pixels.
    #[must_use]
    pub fn build(&self, width: u32, height: u32) -> SidecarCamera {
        let (s, c) = (f32::from(self.rotation) * 0.05).sin_cos();
        let t = self.translation.map(|v| f32::from(v) * 0.25);
        let mut m = [[c, 0.0, -s, t[0]], [0.0, 1.0, 0.0, t[1]], [s, 0.0, c, t[2] - 5.0], [0.0, 0.0, 0.0, 1.0]];
        if let Some((k, v)) = self.matrix_edit {
            m[(k as usize / 4) % 4][k as usize % 4] = v.f32();
        }
        SidecarCamera {
            world_to_view: m,
            yfov: self.yfov.map_or(0.8, Val::f32),
            aspect: self.aspect.map_or(width as f32 / height.max(1) as f32, Val::f32),
            znear: self.znear.map_or(0.1, Val::f32),
            zfar: self.zfar.map_or(100.0, Val::f32),
            principal_point: self.principal.map(|(x, y)| [x.f32(), y.f32()]),
            intrinsics: self.intrinsics.map(|v| v.map(Val::f32)),
        }
    }
}

/// A sidecar light.
#[derive(Clone, Debug, Arbitrary)]
pub struct LightIn {
    kind: u8,
    position: Option<[Val; 3]>,
    direction: Option<[Val; 3]>,
    color: [Val; 3],
    intensity: Val,
    range: Option<Val>,
    begin: Option<Val>,
    cones: Option<(Val, Val)>,
    /// A hemisphere light's ground colour.
    ground: Option<[Val; 3]>,
}

/// A sidecar: camera, supersampling, lights, their space, materials.
#[derive(Clone, Debug, Arbitrary)]
pub struct SidecarIn {
    camera: Option<CameraIn>,
    supersample: Option<u8>,
    lights: Vec<LightIn>,
    lights_space: Option<u8>,
    materials: Vec<(u8, Option<Val>, Option<Val>, Option<Val>, Option<Val>)>,
    /// Replace the JSON by text of its own (parse errors are a path too).
    raw: Option<String>,
}

impl SidecarIn {
    /// The sidecar's JSON text for an image of `width × height` pixels (as stored, before folding).
    #[must_use]
    pub fn json(&self, width: u32, height: u32) -> String {
        if let Some(r) = &self.raw {
            return r.clone();
        }
        let kinds = ["point", "spot", "directional", "hemisphere", "area"];
        let s = Sidecar {
            camera: self.camera.as_ref().map(|c| c.build(width, height)),
            supersample: self.supersample.map(|k| u32::from(k % 10)),
            lights: self
                .lights
                .iter()
                .take(8)
                .map(|l| SidecarLight {
                    kind: kinds[l.kind as usize % kinds.len()].to_string(),
                    position: l.position.map(|p| p.map(Val::f32)),
                    direction: l.direction.map(|p| p.map(Val::f32)),
                    color: l.color.map(Val::f32),
                    intensity: l.intensity.f32(),
                    range: l.range.map(Val::f32),
                    begin: l.begin.map(Val::f32),
                    inner_cone_angle: l.cones.map(|c| c.0.f32()),
                    outer_cone_angle: l.cones.map(|c| c.1.f32()),
                    ground: l.ground.map(|g| g.map(Val::f32)),
                })
                .collect(),
            lights_space: self.lights_space.map(|k| ["world", "view", "screen"][k as usize % 3].to_string()),
            materials: self
                .materials
                .iter()
                .take(8)
                .map(|m| gbuf::gbuffer::MaterialParams {
                    id: u32::from(m.0),
                    name: None,
                    specular: m.1.map(Val::f32),
                    specular_power: m.2.map(Val::f32),
                    roughness: m.3.map(Val::f32),
                    metallic: m.4.map(Val::f32),
                })
                .collect(),
            sample_positions: None,
        };
        serde_json::to_string(&s).unwrap_or_default()
    }
}

/// Declared conventions (`--space`, `--depth`, …).
#[derive(Clone, Debug, Arbitrary)]
pub struct ConventionsIn {
    space: Option<u8>,
    depth: Option<u8>,
    reversed_z: bool,
    znear: Option<Val>,
    zfar: Option<Val>,
    ids: Option<u8>,
    background: Option<(u8, Val)>,
    normals: Option<u8>,
}

impl ConventionsIn {
    /// As overrides.
    #[must_use]
    pub fn overrides(&self) -> Overrides {
        let pick = |i: u8, n: usize| i as usize % n;
        Overrides {
            space: self.space.map(|i| Space::ALL[pick(i, Space::ALL.len())]),
            depth: self.depth.map(|i| DepthKind::ALL[pick(i, DepthKind::ALL.len())]),
            reversed_z: self.reversed_z,
            znear: self.znear.map(Val::f32),
            zfar: self.zfar.map(Val::f32),
            ids: self.ids.map(|i| IdEncoding::ALL[pick(i, IdEncoding::ALL.len())]),
            background: self.background.map(|(k, v)| match k % 5 {
                0 => Background::Auto,
                1 => Background::Inf,
                2 => Background::Nan,
                3 => Background::Alpha,
                _ => Background::Value(v.f32()),
            }),
            normals: self.normals.map(|i| NormalEncoding::ALL[pick(i, NormalEncoding::ALL.len())]),
        }
    }
}

/// Options for a load: fold, sidecar, DWA, a lower memory limit.
#[derive(Clone, Debug, Arbitrary)]
pub struct LoadIn {
    fold: Option<u8>,
    sidecar: Option<SidecarIn>,
    allow_dwa: bool,
    max_mib: Option<u8>,
}

impl LoadIn {
    /// The options (writing the sidecar file, if any, for an image of `width × height` as stored).
    #[must_use]
    pub fn options(&self, width: u32, height: u32) -> LoadOptions {
        let mut o = crate::default_options();
        o.fold = self.fold.map(|k| u32::from(k % 10));
        o.limits.allow_dwa = self.allow_dwa && crate::dwa_enabled();
        if let Some(m) = self.max_mib {
            o.limits.max_bytes = (u64::from(m) << 14).min(crate::max_declared_bytes());
        }
        o.sidecar = self.sidecar.as_ref().map(|s| crate::sidecar_file(s.json(width, height).as_bytes()));
        o
    }
}

/// The path a structure-aware target names its dump by.
#[must_use]
pub fn path() -> PathBuf {
    crate::dump_path()
}

/// A small dimension in `1..=max` from a byte.
#[must_use]
pub fn dim(b: u8, max: u8) -> u32 {
    1 + u32::from(b % max)
}

/// Consumes an `Unstructured` for one `T` (helper for targets that take raw bytes first).
pub fn take<'a, T: Arbitrary<'a>>(u: &mut Unstructured<'a>) -> Result<T> {
    T::arbitrary(u)
}

/// Sets `attr`'s plane of `gb` from a flat list of `len × components` values (IDs as integers).
pub fn set_plane(gb: &mut gbuf::gbuffer::GBuffer, attr: gbuf::gbuffer::Attribute, f: impl Fn(usize, usize) -> f32) {
    use gbuf::gbuffer::Attribute as A;
    use glam::{Vec2, Vec3};
    let n = gb.len();
    let s = |c: usize| -> Vec<f32> { (0..n).map(|i| f(i, c)).collect() };
    let v2 = || -> Vec<Vec2> { (0..n).map(|i| Vec2::new(f(i, 0), f(i, 1))).collect() };
    let v3 = || -> Vec<Vec3> { (0..n).map(|i| Vec3::new(f(i, 0), f(i, 1), f(i, 2))).collect() };
    let id = || -> Vec<u32> { (0..n).map(|i| f(i, 0).to_bits()).collect() };
    match attr {
        A::Depth => gb.depth = Some(s(0)),
        A::Position => gb.position = Some(v3()),
        A::Normal => gb.normal = Some(v3()),
        A::Albedo => gb.albedo = Some(v3()),
        A::Specular => gb.specular = Some(s(0)),
        A::SpecularPower => gb.specular_power = Some(s(0)),
        A::Roughness => gb.roughness = Some(s(0)),
        A::Metallic => gb.metallic = Some(s(0)),
        A::MaterialId => gb.material_id = Some(id()),
        A::ObjectId => gb.object_id = Some(id()),
        A::PrimitiveId => gb.primitive_id = Some(id()),
        A::Motion => gb.motion = Some(v2()),
    }
}

/// A 4×3, 4-sample G-buffer with every attribute, plausible values and a camera (for packing through layouts).
#[must_use]
pub fn sample_gbuffer() -> gbuf::gbuffer::GBuffer {
    use gbuf::gbuffer::Attribute;
    let mut gb = gbuf::gbuffer::GBuffer::new(4, 3, 4).expect("4 samples");
    gb.camera = Some(gbuf::camera::Camera::identity(0.8, 4.0 / 3.0, 0.1, 100.0));
    gb.coverage.iter_mut().enumerate().for_each(|(i, c)| *c = i % 5 != 0);
    for attr in Attribute::ALL {
        set_plane(&mut gb, attr, |i, c| match attr {
            Attribute::Depth => 1.0 + i as f32 * 0.25,
            Attribute::Position => [0.1 * i as f32, -0.2, -1.0 - i as f32 * 0.25][c],
            Attribute::Normal => [0.0, 0.6, 0.8][c],
            Attribute::MaterialId | Attribute::ObjectId | Attribute::PrimitiveId => f32::from_bits(i as u32 % 7),
            Attribute::SpecularPower => 16.0 + i as f32,
            _ => (i as f32 * 0.07 + c as f32 * 0.1).fract(),
        });
    }
    gb.zero_background();
    gb
}
