//! Packing a G-buffer into render-target bytes and reading it back.
//!
//! [`Layout::pack`] encodes every covered sample field by field, ORs the codes into the target's texel word and
//! writes it little-endian (background samples are a cleared texel: all zero bits). [`Layout::unpack`] reads the
//! words back, extracts each field's bits and decodes them; it is bit-exact with calling each codec's
//! `decode(encode(x))` by hand. Both run in parallel (rayon) over chunks of samples.

use super::bits::{extract, insert, load_le, mask, store_le};
use super::coder::{encode_id, Coder, Slot};
use super::material::MaterialTable;
use super::{Field, Format, Layout, DEFAULT_DEPTH_RANGE};
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Samples per parallel work item: big enough to amortize scheduling, small enough for several per thread.
const CHUNK: usize = 4096;

/// One render target's bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetPlane {
    /// Target name from the layout.
    pub name: String,
    /// Its format.
    pub format: Format,
    /// `samples × format.bytes()` bytes, pixel-major like the G-buffer planes, each texel little-endian.
    pub bytes: Vec<u8>,
}

/// A packed G-buffer: what the renderer's render targets would hold.
#[derive(Clone, Debug, PartialEq)]
pub struct Packed {
    /// The layout's name.
    pub layout: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub samples: u32,
    /// One byte plane per render target.
    pub targets: Vec<TargetPlane>,
    /// The material table, when the layout uses indirection.
    pub material_table: Option<MaterialTable>,
    /// Near/far planes the depth codecs were built with.
    pub depth_range: [f32; 2],
    /// Attributes that the input had and the layout stores (the others are not decoded).
    pub present: Vec<Attribute>,
}

impl Packed {
    /// Total bytes over all targets.
    #[must_use]
    pub fn total_bytes(&self) -> usize {
        self.targets.iter().map(|t| t.bytes.len()).sum()
    }
}

/// A borrowed source plane for one field.
enum Src<'a> {
    F32(&'a [f32]),
    V3(&'a [Vec3]),
    V3c(&'a [Vec3], usize),
    V2c(&'a [Vec2], usize),
    U32(&'a [u32]),
    Absent,
}

fn source<'a>(gb: &'a GBuffer, slot: Slot, index: &'a [u32]) -> Src<'a> {
    use crate::gbuffer::PlaneRef as P;
    match slot {
        Slot::MaterialIndex => Src::U32(index),
        Slot::Reserved => Src::Absent,
        Slot::Whole(a) => match gb.plane(a) {
            Some(P::F32(p)) => Src::F32(p),
            Some(P::Vec3(p)) => Src::V3(p),
            Some(P::U32(p)) => Src::U32(p),
            Some(P::Vec2(_)) | None => Src::Absent,
        },
        Slot::Component(a, k) => match gb.plane(a) {
            Some(P::Vec3(p)) => Src::V3c(p, k),
            Some(P::Vec2(p)) => Src::V2c(p, k),
            _ => Src::Absent,
        },
    }
}

#[inline]
fn encode(coder: &Coder, src: &Src<'_>, i: usize) -> u64 {
    match (coder, src) {
        (Coder::Normal(c), Src::V3(p)) => c.encode(p[i]),
        (Coder::Color(c), Src::V3(p)) => c.encode(p[i]),
        (Coder::Depth(c), Src::F32(p)) => c.encode(p[i]),
        (Coder::Scalar(c), Src::F32(p)) => c.encode(p[i]),
        (Coder::Scalar(c), Src::V3c(p, k)) => c.encode(p[i][*k]),
        (Coder::Scalar(c), Src::V2c(p, k)) => c.encode(p[i][*k]),
        (Coder::Id(bits), Src::U32(p)) => encode_id(p[i], *bits),
        (Coder::None, Src::U32(p)) => u64::from(p[i]),
        _ => 0,
    }
}

impl Layout {
    /// Near/far planes for depth codecs: the G-buffer camera's, else the layout's `depth_range`, else the default.
    #[must_use]
    pub fn depth_range_for(&self, gb: &GBuffer) -> [f32; 2] {
        match gb.camera {
            Some(c) if c.znear > 0.0 && c.zfar > c.znear && c.zfar.is_finite() => [c.znear, c.zfar],
            _ => self.spec().depth_range.unwrap_or(DEFAULT_DEPTH_RANGE),
        }
    }

    fn coders(&self, [znear, zfar]: [f32; 2]) -> Result<Vec<Coder>> {
        self.fields()
            .iter()
            .map(|f| {
                Coder::build(f.slot, &f.codec, znear, zfar)
                    .map_err(|e| Error::Argument(format!("layout {:?}: {e}", self.name())))
            })
            .collect()
    }

    /// Packs `gb` into render-target bytes.
    pub fn pack(&self, gb: &GBuffer) -> Result<Packed> {
        gb.validate()?;
        let depth_range = self.depth_range_for(gb);
        let coders = self.coders(depth_range)?;
        let (material_table, index) = match self.indirection() {
            Some(ind) => {
                let (t, i) = MaterialTable::build(gb, &ind.parameters, ind.bits);
                (Some(t), i)
            }
            None => (None, Vec::new()),
        };
        let n = gb.len();
        let mut targets = Vec::with_capacity(self.formats().len());
        for (ti, (format, tspec)) in self.formats().iter().zip(&self.spec().targets).enumerate() {
            let size = format.bytes();
            let fields: Vec<(&Field, &Coder, Src<'_>)> = self
                .fields()
                .iter()
                .zip(&coders)
                .filter(|(f, _)| f.target == ti)
                .map(|(f, c)| (f, c, source(gb, f.slot, &index)))
                .filter(|(_, _, s)| !matches!(s, Src::Absent))
                .collect();
            let mut bytes = vec![0u8; n * size];
            bytes.par_chunks_mut(CHUNK * size).enumerate().for_each(|(chunk, out)| {
                let base = chunk * CHUNK;
                for (j, texel) in out.chunks_exact_mut(size).enumerate() {
                    let i = base + j;
                    if !gb.coverage[i] {
                        continue;
                    }
                    let mut word = 0u128;
                    for (f, coder, src) in &fields {
                        insert(&mut word, f.offset, f.bits, encode(coder, src, i));
                    }
                    store_le(word, texel);
                }
            });
            targets.push(TargetPlane { name: tspec.name.clone(), format: *format, bytes });
        }
        let present = self.stored_attributes().into_iter().filter(|a| gb.has(*a)).collect();
        Ok(Packed {
            layout: self.name().to_string(),
            width: gb.width,
            height: gb.height,
            samples: gb.samples,
            targets,
            material_table,
            depth_range,
            present,
        })
    }

    /// Reads `packed` back into a G-buffer. Size, sample positions, camera and coverage come from `like` (the
    /// buffer that was packed, or one with the same geometry). Stored attributes are decoded; unstored ones get
    /// the layout's constants or stay absent; position (or depth) is re-derived from the other and the camera
    /// when the layout stores only one. Background samples are 0 in every plane.
    pub fn unpack(&self, packed: &Packed, like: &GBuffer) -> Result<GBuffer> {
        self.check(packed, like)?;
        let coders = self.coders(packed.depth_range)?;
        let n = like.len();
        let cov = &like.coverage[..];
        let mut out = GBuffer {
            width: like.width,
            height: like.height,
            samples: like.samples,
            sample_positions: like.sample_positions.clone(),
            camera: like.camera,
            coverage: like.coverage.clone(),
            ..GBuffer::default()
        };
        let mut index: Vec<u32> = Vec::new();
        for (f, coder) in self.fields().iter().zip(&coders) {
            let t = &packed.targets[f.target];
            let (bytes, size) = (&t.bytes[..], t.format.bytes());
            let (off, bits) = (f.offset, f.bits);
            let code = move |w: u128| extract(w, off, bits);
            match (f.slot, coder) {
                (Slot::Reserved, _) => {}
                (Slot::MaterialIndex, _) => {
                    index = vec![0; n];
                    fill(&mut index, bytes, size, cov, |d, w| *d = code(w) as u32);
                }
                (Slot::Whole(a), _) if !packed.present.contains(&a) => {}
                (Slot::Component(a, _), _) if !packed.present.contains(&a) => {}
                (Slot::Whole(Attribute::Normal), Coder::Normal(c)) => {
                    fill(out.normal.get_or_insert_with(|| vec![Vec3::ZERO; n]), bytes, size, cov, |d, w| {
                        *d = c.decode(code(w));
                    });
                }
                (Slot::Whole(Attribute::Albedo), Coder::Color(c)) => {
                    fill(out.albedo.get_or_insert_with(|| vec![Vec3::ZERO; n]), bytes, size, cov, |d, w| {
                        *d = c.decode(code(w));
                    });
                }
                (Slot::Whole(Attribute::Depth), Coder::Depth(c)) => {
                    fill(out.depth.get_or_insert_with(|| vec![0.0; n]), bytes, size, cov, |d, w| {
                        *d = c.decode(code(w));
                    });
                }
                (Slot::Whole(a), Coder::Scalar(c)) => {
                    fill(scalar_plane(&mut out, a, n)?, bytes, size, cov, |d, w| *d = c.decode(code(w)));
                }
                (Slot::Whole(a), Coder::Id(_)) => {
                    fill(id_plane(&mut out, a, n)?, bytes, size, cov, |d, w| *d = code(w) as u32);
                }
                (Slot::Component(a, k), Coder::Scalar(c)) => match a {
                    Attribute::Motion => {
                        fill(out.motion.get_or_insert_with(|| vec![Vec2::ZERO; n]), bytes, size, cov, |d, w| {
                            d[k] = c.decode(code(w));
                        });
                    }
                    _ => {
                        let plane = match a {
                            Attribute::Normal => &mut out.normal,
                            Attribute::Albedo => &mut out.albedo,
                            _ => &mut out.position,
                        };
                        fill(plane.get_or_insert_with(|| vec![Vec3::ZERO; n]), bytes, size, cov, |d, w| {
                            d[k] = c.decode(code(w));
                        });
                    }
                },
                (slot, _) => {
                    return Err(Error::Argument(format!("layout {:?}: cannot decode {}", self.name(), slot.name())))
                }
            }
        }
        if let Some(table) = &packed.material_table {
            for (p, a) in table.attributes().into_iter().enumerate() {
                let mut plane = vec![0f32; n];
                for i in (0..n).filter(|&i| cov[i]) {
                    let row = table.entries.get(index.get(i).copied().unwrap_or(0) as usize).ok_or_else(|| {
                        Error::Argument(format!(
                            "material index {} outside the table of {} entries",
                            index[i],
                            table.entries.len()
                        ))
                    })?;
                    plane[i] = row[p];
                }
                *scalar_plane(&mut out, a, n)? = plane;
            }
        }
        for (a, vals) in self.constants() {
            set_constant(&mut out, *a, vals, n);
        }
        if !self.stores(Attribute::Position) || !self.stores(Attribute::Depth) {
            out.derive_depth_or_position();
        }
        Ok(out)
    }

    /// Packs and unpacks: the G-buffer the lighting pass of a renderer using this layout would see.
    pub fn roundtrip(&self, gb: &GBuffer) -> Result<GBuffer> {
        self.unpack(&self.pack(gb)?, gb)
    }

    fn check(&self, packed: &Packed, like: &GBuffer) -> Result<()> {
        let bad = |what: String| Err(Error::Argument(format!("unpack with layout {:?}: {what}", self.name())));
        if packed.layout != self.name() {
            return bad(format!("the data was packed with layout {:?}", packed.layout));
        }
        if (packed.width, packed.height, packed.samples) != (like.width, like.height, like.samples) {
            return bad(format!(
                "packed {}×{}×{} but the reference is {}×{}×{}",
                packed.width, packed.height, packed.samples, like.width, like.height, like.samples
            ));
        }
        like.validate()?;
        if packed.targets.len() != self.formats().len() {
            return bad(format!("{} targets, the layout has {}", packed.targets.len(), self.formats().len()));
        }
        for (t, f) in packed.targets.iter().zip(self.formats()) {
            if t.format != *f || t.bytes.len() != like.len() * f.bytes() {
                return bad(format!("target {} has {} bytes of {}, expected {f}", t.name, t.bytes.len(), t.format));
            }
        }
        if self.indirection().is_some() != packed.material_table.is_some() {
            return bad("material table missing or unexpected".into());
        }
        Ok(())
    }
}

/// Decodes into `dst` in parallel: `f(dst[i], texel word)` for covered samples; others keep their value.
fn fill<T: Send>(dst: &mut [T], bytes: &[u8], size: usize, cov: &[bool], f: impl Fn(&mut T, u128) + Sync) {
    dst.par_chunks_mut(CHUNK).zip(bytes.par_chunks(CHUNK * size)).zip(cov.par_chunks(CHUNK)).for_each(|((d, b), c)| {
        for ((d, texel), &covered) in d.iter_mut().zip(b.chunks_exact(size)).zip(c) {
            if covered {
                f(d, load_le(texel));
            }
        }
    });
}

fn scalar_plane(gb: &mut GBuffer, a: Attribute, n: usize) -> Result<&mut Vec<f32>> {
    let p = match a {
        Attribute::Depth => &mut gb.depth,
        Attribute::Specular => &mut gb.specular,
        Attribute::SpecularPower => &mut gb.specular_power,
        Attribute::Roughness => &mut gb.roughness,
        Attribute::Metallic => &mut gb.metallic,
        _ => return Err(Error::Argument(format!("{} is not a scalar attribute", a.name()))),
    };
    Ok(p.get_or_insert_with(|| vec![0.0; n]))
}

fn id_plane(gb: &mut GBuffer, a: Attribute, n: usize) -> Result<&mut Vec<u32>> {
    let p = match a {
        Attribute::MaterialId => &mut gb.material_id,
        Attribute::ObjectId => &mut gb.object_id,
        Attribute::PrimitiveId => &mut gb.primitive_id,
        _ => return Err(Error::Argument(format!("{} is not an ID attribute", a.name()))),
    };
    Ok(p.get_or_insert_with(|| vec![0; n]))
}

fn set_constant(gb: &mut GBuffer, a: Attribute, v: &[f32], n: usize) {
    let cov = gb.coverage.clone();
    let pick = |i: usize| cov[i];
    match a {
        Attribute::Normal | Attribute::Albedo | Attribute::Position => {
            let val = Vec3::new(v[0], v[1], v[2]);
            let plane = (0..n).map(|i| if pick(i) { val } else { Vec3::ZERO }).collect();
            match a {
                Attribute::Normal => gb.normal = Some(plane),
                Attribute::Albedo => gb.albedo = Some(plane),
                _ => gb.position = Some(plane),
            }
        }
        Attribute::Motion => {
            let val = Vec2::new(v[0], v[1]);
            gb.motion = Some((0..n).map(|i| if pick(i) { val } else { Vec2::ZERO }).collect());
        }
        a if a.is_id() => {
            let val = v[0] as u32;
            if let Ok(p) = id_plane(gb, a, n) {
                *p = (0..n).map(|i| if pick(i) { val } else { 0 }).collect();
            }
        }
        a => {
            if let Ok(p) = scalar_plane(gb, a, n) {
                *p = (0..n).map(|i| if pick(i) { v[0] } else { 0.0 }).collect();
            }
        }
    }
}

/// The code a field holds for sample `i` of a packed target (for tests and tools that inspect raw bytes).
#[must_use]
pub fn field_code(packed: &Packed, field: &Field, i: usize) -> u64 {
    let t = &packed.targets[field.target];
    let size = t.format.bytes();
    extract(load_le(&t.bytes[i * size..(i + 1) * size]), field.offset, field.bits) & mask(field.bits)
}
