//! The G-buffer in memory: what every stage passes on.
//!
//! Structure of arrays: one plane per attribute. Every plane holds `width × height × samples` values in
//! **pixel-major** order: `index = (y * width + x) * samples + s`, row 0 at the top. The samples of one pixel are
//! adjacent because every consumer (edge detection, the resolve, the box filter) walks a pixel's samples together.
//!
//! View space is the glTF/OpenGL convention: +X right, +Y up, the camera looks along −Z. `depth` is the positive
//! distance along the view axis (`depth = −position.z`). Normals are unit vectors in view space; a surface facing the
//! camera has `normal.z > 0`.
//!
//! Background (no surface, sky) is recorded in `coverage` (`false` = background). Loaders write 0 into every other
//! plane at background samples so that planes stay finite; consumers skip background samples.
//! Absent attributes are `None`, never zero-filled.

use crate::camera::Camera;
use crate::error::{Error, Result};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// One G-buffer attribute. `ALL` lists them in canonical order; `name` is the one spelling used in CLI flags,
/// JSON output and our canonical EXR channel names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Attribute {
    /// View-space depth (positive distance along −Z), f32.
    Depth,
    /// View-space position, 3 × f32.
    Position,
    /// View-space unit normal, 3 × f32.
    Normal,
    /// Diffuse albedo, linear RGB.
    Albedo,
    /// Specular amount (or scalar F0), f32.
    Specular,
    /// Blinn-Phong specular power (exponent), f32.
    SpecularPower,
    /// Perceptual roughness in [0, 1], f32.
    Roughness,
    /// Metallic in [0, 1], f32.
    Metallic,
    /// Material ID, u32.
    MaterialId,
    /// Object ID, u32.
    ObjectId,
    /// Primitive (triangle) ID, u32.
    PrimitiveId,
    /// Screen-space motion in pixels, 2 × f32.
    Motion,
}

crate::named!(Attribute: "attribute" {
    Depth => "depth",
    Position => "position",
    Normal => "normal",
    Albedo => "albedo",
    Specular => "specular",
    SpecularPower => "specular_power",
    Roughness => "roughness",
    Metallic => "metallic",
    MaterialId => "material_id",
    ObjectId => "object_id",
    PrimitiveId => "primitive_id",
    Motion => "motion",
});

impl Attribute {
    /// Number of components (1, 2 or 3).
    #[must_use]
    pub fn components(self) -> usize {
        match self {
            Attribute::Position | Attribute::Normal | Attribute::Albedo => 3,
            Attribute::Motion => 2,
            _ => 1,
        }
    }

    /// True for the integer ID attributes.
    #[must_use]
    pub fn is_id(self) -> bool {
        matches!(self, Attribute::MaterialId | Attribute::ObjectId | Attribute::PrimitiveId)
    }
}

/// Standard D3D/Vulkan MSAA sample positions, in 1/16 pixel from the pixel centre (x right, y down as in D3D).
const D3D_2X: [(i8, i8); 2] = [(4, 4), (-4, -4)];
const D3D_4X: [(i8, i8); 4] = [(-2, -6), (6, -2), (-6, 2), (2, 6)];
const D3D_8X: [(i8, i8); 8] = [(1, -3), (-1, 3), (5, 1), (-3, -5), (-5, 5), (-7, -1), (3, 7), (7, -7)];
const D3D_16X: [(i8, i8); 16] = [
    (1, 1),
    (-1, -3),
    (-3, 2),
    (4, -1),
    (-5, -2),
    (2, 5),
    (5, 3),
    (3, -5),
    (-2, 6),
    (0, -7),
    (-4, -6),
    (-6, 4),
    (-8, 0),
    (7, -4),
    (6, 7),
    (-7, -8),
];

/// The standard sample positions for `samples` ∈ {1, 2, 4, 8, 16}, as offsets in pixels from the pixel centre with
/// +x right and +y **down** (image convention, same as D3D). `None` for other counts.
#[must_use]
pub fn standard_sample_positions(samples: u32) -> Option<Vec<Vec2>> {
    let table: &[(i8, i8)] = match samples {
        1 => &[(0, 0)],
        2 => &D3D_2X,
        4 => &D3D_4X,
        8 => &D3D_8X,
        16 => &D3D_16X,
        _ => return None,
    };
    Some(table.iter().map(|&(x, y)| Vec2::new(f32::from(x) / 16.0, f32::from(y) / 16.0)).collect())
}

/// The one range check of sample positions, whatever they were read from (an EXR header, a sidecar, a fold):
/// finite offsets within ±0.5 px of the pixel centre, or what is wrong with the first that is not.
pub fn check_sample_positions(positions: &[Vec2]) -> std::result::Result<(), String> {
    match positions.iter().position(|p| !(p.x.abs() <= 0.5 && p.y.abs() <= 0.5)) {
        None => Ok(()),
        Some(i) => Err(format!(
            "sample position {i} = ({}, {}) lies outside its pixel: positions are offsets from the pixel centre \
             within ±0.5 px",
            positions[i].x, positions[i].y
        )),
    }
}

/// The ordered-grid positions of a k×k supersampled block folded into one pixel, row-major within the block
/// (sample `j * k + i` comes from sub-pixel column `i`, row `j`).
#[must_use]
pub fn ordered_grid_positions(k: u32) -> Vec<Vec2> {
    let kf = k as f32;
    (0..k * k)
        .map(|s| {
            let (i, j) = ((s % k) as f32, (s / k) as f32);
            Vec2::new((i + 0.5) / kf - 0.5, (j + 0.5) / kf - 0.5)
        })
        .collect()
}

/// The largest sample count per pixel we accept (a folded 8×8 block).
pub const MAX_SAMPLES: u32 = 64;

/// A multisampled G-buffer: per-sample surface attributes in view space, plus the camera when known.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GBuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub samples: u32,
    /// Sub-pixel sample positions, offsets from the pixel centre in pixels (+x right, +y down); `samples` entries.
    pub sample_positions: Vec<Vec2>,
    /// The camera, when the dump or its sidecar gives one (or it was recovered from positions).
    pub camera: Option<Camera>,
    /// `true` where a surface was hit; `false` for background (sky). Always present.
    pub coverage: Vec<bool>,
    /// View-space depth, positive along −Z.
    pub depth: Option<Vec<f32>>,
    /// View-space position.
    pub position: Option<Vec<Vec3>>,
    /// View-space unit normal.
    pub normal: Option<Vec<Vec3>>,
    /// Linear RGB albedo.
    pub albedo: Option<Vec<Vec3>>,
    /// Specular amount / scalar F0.
    pub specular: Option<Vec<f32>>,
    /// Blinn-Phong specular power.
    pub specular_power: Option<Vec<f32>>,
    /// Perceptual roughness.
    pub roughness: Option<Vec<f32>>,
    /// Metallic.
    pub metallic: Option<Vec<f32>>,
    /// Material ID.
    pub material_id: Option<Vec<u32>>,
    /// Object ID.
    pub object_id: Option<Vec<u32>>,
    /// Primitive ID.
    pub primitive_id: Option<Vec<u32>>,
    /// Screen-space motion in pixels.
    pub motion: Option<Vec<Vec2>>,
    /// The engine's material catalogue, when a sidecar gives one (`materials`): parameters per material ID, which
    /// material-ID indirection uses as its table instead of per-ID means. Empty when unknown.
    pub materials: Vec<MaterialParams>,
}

/// One engine material as a sidecar declares it: its material ID and whichever scalar parameters it states
/// (absent ones are taken from the dump, as the per-ID mean).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialParams {
    /// The material ID the engine writes into the G-buffer.
    pub id: u32,
    /// The engine's name for it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Specular amount / scalar F0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specular: Option<f32>,
    /// Blinn-Phong specular power.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specular_power: Option<f32>,
    /// Perceptual roughness.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roughness: Option<f32>,
    /// Metallic.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub metallic: Option<f32>,
}

impl MaterialParams {
    /// The declared value of scalar attribute `attr`, if this material states it.
    #[must_use]
    pub fn get(&self, attr: Attribute) -> Option<f32> {
        match attr {
            Attribute::Specular => self.specular,
            Attribute::SpecularPower => self.specular_power,
            Attribute::Roughness => self.roughness,
            Attribute::Metallic => self.metallic,
            _ => None,
        }
    }

    /// Checks a catalogue: IDs unique, every stated value finite (and roughness, metallic in [0, 1], specular
    /// power ≥ 0). The message names the offending entry.
    pub fn validate_all(materials: &[MaterialParams]) -> std::result::Result<(), String> {
        let mut seen = std::collections::HashSet::new();
        for (i, m) in materials.iter().enumerate() {
            if !seen.insert(m.id) {
                return Err(format!("materials[{i}]: material ID {} is listed twice", m.id));
            }
            for (attr, v) in [Attribute::Specular, Attribute::SpecularPower, Attribute::Roughness, Attribute::Metallic]
                .into_iter()
                .filter_map(|a| m.get(a).map(|v| (a, v)))
            {
                let ok = v.is_finite()
                    && match attr {
                        Attribute::Roughness | Attribute::Metallic => (0.0..=1.0).contains(&v),
                        _ => v >= 0.0,
                    };
                if !ok {
                    return Err(format!("materials[{i}] (ID {}): {} = {v} is out of range", m.id, attr.name()));
                }
            }
        }
        Ok(())
    }
}

/// A borrowed view of one attribute plane, for code that walks attributes generically.
#[derive(Clone, Copy, Debug)]
pub enum PlaneRef<'a> {
    /// A scalar f32 plane.
    F32(&'a [f32]),
    /// A 2-component plane.
    Vec2(&'a [Vec2]),
    /// A 3-component plane.
    Vec3(&'a [Vec3]),
    /// An integer ID plane.
    U32(&'a [u32]),
}

impl PlaneRef<'_> {
    /// Values in the plane (one per sample).
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            PlaneRef::F32(v) => v.len(),
            PlaneRef::Vec2(v) => v.len(),
            PlaneRef::Vec3(v) => v.len(),
            PlaneRef::U32(v) => v.len(),
        }
    }

    /// Is the plane empty?
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bytes it holds (4 per f32 or ID component).
    #[must_use]
    pub fn bytes(&self) -> usize {
        match self {
            PlaneRef::F32(v) => std::mem::size_of_val(*v),
            PlaneRef::Vec2(v) => std::mem::size_of_val(*v),
            PlaneRef::Vec3(v) => std::mem::size_of_val(*v),
            PlaneRef::U32(v) => std::mem::size_of_val(*v),
        }
    }
}

/// The storage slot of one attribute plane, typed: what generic code over the planes writes through. With
/// [`GBuffer::plane`] it is one of the two places that list the planes by field (shared and mutable borrows); every
/// other walk over the planes goes through them ([`GBuffer::visit_planes_mut`], [`GBuffer::map_planes`]).
#[derive(Debug)]
pub enum PlaneSlot<'a> {
    /// A scalar f32 plane.
    F32(&'a mut Option<Vec<f32>>),
    /// A 2-component plane.
    Vec2(&'a mut Option<Vec<Vec2>>),
    /// A 3-component plane.
    Vec3(&'a mut Option<Vec<Vec3>>),
    /// An integer ID plane.
    U32(&'a mut Option<Vec<u32>>),
}

/// Copies `from` into the slot `to`, reusing its allocation; true.
fn copy_into<T: Copy>(to: &mut Option<Vec<T>>, from: &[T]) -> bool {
    let v = to.get_or_insert_with(Vec::new);
    v.clear();
    v.extend_from_slice(from);
    true
}

/// What a walk over every present plane does to one, whatever its element type ([`GBuffer::visit_planes_mut`]).
pub trait PlaneVisitor {
    /// Called once per present plane, in canonical attribute order.
    fn visit<T: Copy + Default + Send + Sync>(&mut self, attr: Attribute, plane: &mut [T]);
}

/// Builds a new plane from an existing one, whatever its element type ([`GBuffer::map_planes`]).
pub trait PlaneMapper {
    /// The new plane of `attr` from its old one; `None` drops the attribute.
    fn map<T: Copy + Default + Send + Sync>(&mut self, attr: Attribute, plane: &[T]) -> Option<Vec<T>>;
}

/// One sample's attributes as values: the record beside [`GBuffer::plane`] and [`GBuffer::slot`] for code that
/// reads, combines and writes whole samples (MSAA compression's slots). Read with [`GBuffer::sample`] (an absent
/// plane reads as zero) and written with [`SamplesMut::set`] (only into the planes present).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// View-space depth.
    pub depth: f32,
    /// View-space position.
    pub position: Vec3,
    /// View-space unit normal.
    pub normal: Vec3,
    /// Linear RGB albedo.
    pub albedo: Vec3,
    /// Specular amount / scalar F0.
    pub specular: f32,
    /// Blinn-Phong specular power.
    pub specular_power: f32,
    /// Perceptual roughness.
    pub roughness: f32,
    /// Metallic.
    pub metallic: f32,
    /// Material ID.
    pub material_id: u32,
    /// Object ID.
    pub object_id: u32,
    /// Primitive ID.
    pub primitive_id: u32,
    /// Screen-space motion in pixels.
    pub motion: Vec2,
}

impl Sample {
    /// `self · a + other · b` for every float attribute (per component); the IDs are `self`'s.
    #[must_use]
    pub fn blend(&self, a: f32, other: &Sample, b: f32) -> Sample {
        Sample {
            depth: self.depth * a + other.depth * b,
            position: self.position * a + other.position * b,
            normal: self.normal * a + other.normal * b,
            albedo: self.albedo * a + other.albedo * b,
            specular: self.specular * a + other.specular * b,
            specular_power: self.specular_power * a + other.specular_power * b,
            roughness: self.roughness * a + other.roughness * b,
            metallic: self.metallic * a + other.metallic * b,
            motion: self.motion * a + other.motion * b,
            ..*self
        }
    }

    /// Every float attribute times `k`; the IDs kept.
    #[must_use]
    pub fn scaled(&self, k: f32) -> Sample {
        Sample {
            depth: self.depth * k,
            position: self.position * k,
            normal: self.normal * k,
            albedo: self.albedo * k,
            specular: self.specular * k,
            specular_power: self.specular_power * k,
            roughness: self.roughness * k,
            metallic: self.metallic * k,
            motion: self.motion * k,
            ..*self
        }
    }
}

/// A run of consecutive samples of a G-buffer (a row of pixels, say), coverage and every plane borrowed mutably:
/// what [`GBuffer::sample_runs_mut`] splits a buffer into, so that runs are written in parallel.
#[derive(Debug)]
pub struct SamplesMut<'a> {
    /// The run's coverage.
    pub coverage: &'a mut [bool],
    depth: Option<&'a mut [f32]>,
    position: Option<&'a mut [Vec3]>,
    normal: Option<&'a mut [Vec3]>,
    albedo: Option<&'a mut [Vec3]>,
    specular: Option<&'a mut [f32]>,
    specular_power: Option<&'a mut [f32]>,
    roughness: Option<&'a mut [f32]>,
    metallic: Option<&'a mut [f32]>,
    material_id: Option<&'a mut [u32]>,
    object_id: Option<&'a mut [u32]>,
    primitive_id: Option<&'a mut [u32]>,
    motion: Option<&'a mut [Vec2]>,
}

impl SamplesMut<'_> {
    /// Writes `v` into sample `i` of the run, in every plane present (coverage is not touched).
    #[inline]
    pub fn set(&mut self, i: usize, v: &Sample) {
        fn put<T: Copy>(p: &mut Option<&mut [T]>, i: usize, x: T) {
            if let Some(p) = p {
                p[i] = x;
            }
        }
        put(&mut self.depth, i, v.depth);
        put(&mut self.position, i, v.position);
        put(&mut self.normal, i, v.normal);
        put(&mut self.albedo, i, v.albedo);
        put(&mut self.specular, i, v.specular);
        put(&mut self.specular_power, i, v.specular_power);
        put(&mut self.roughness, i, v.roughness);
        put(&mut self.metallic, i, v.metallic);
        put(&mut self.material_id, i, v.material_id);
        put(&mut self.object_id, i, v.object_id);
        put(&mut self.primitive_id, i, v.primitive_id);
        put(&mut self.motion, i, v.motion);
    }
}

impl GBuffer {
    /// An empty G-buffer (all background, no attributes) of the given size with standard (or, for non-standard
    /// counts that are perfect squares, ordered-grid) sample positions.
    pub fn new(width: u32, height: u32, samples: u32) -> Result<Self> {
        let sample_positions = match standard_sample_positions(samples) {
            Some(p) => p,
            None => {
                let k = (samples as f64).sqrt().round() as u32;
                if k * k != samples || samples == 0 || samples > MAX_SAMPLES {
                    return Err(Error::Argument(format!(
                        "unsupported sample count {samples} (use 1, 2, 4, 8, 16 or a square up to {MAX_SAMPLES})"
                    )));
                }
                ordered_grid_positions(k)
            }
        };
        let len = checked_len(width, height, samples)?;
        Ok(GBuffer {
            width,
            height,
            samples,
            sample_positions,
            coverage: crate::base::memory::zeroed_on_huge_pages(len),
            ..Default::default()
        })
    }

    /// Number of pixels.
    #[must_use]
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Number of samples in every plane (`pixels × samples`).
    #[must_use]
    pub fn len(&self) -> usize {
        self.pixel_count() * self.samples as usize
    }

    /// True when the buffer has no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Plane index of sample `s` of pixel (`x`, `y`).
    #[inline]
    #[must_use]
    pub fn index(&self, x: u32, y: u32, s: u32) -> usize {
        debug_assert!(x < self.width && y < self.height && s < self.samples);
        (y as usize * self.width as usize + x as usize) * self.samples as usize + s as usize
    }

    /// Continuous pixel coordinate of sample `s` of pixel (`x`, `y`): the pixel centre plus the sample's offset
    /// (the point a primary ray goes through, see [`crate::camera::Camera::view_ray`]).
    #[inline]
    #[must_use]
    pub fn sample_px(&self, x: u32, y: u32, s: u32) -> Vec2 {
        let o = self.sample_positions[s as usize];
        Vec2::new(x as f32 + 0.5 + o.x, y as f32 + 0.5 + o.y)
    }

    /// [`Self::sample_px`] of plane index `i`.
    #[inline]
    #[must_use]
    pub fn sample_px_of(&self, i: usize) -> Vec2 {
        let s = self.samples as usize;
        let pixel = i / s;
        let (x, y) = (pixel % self.width as usize, pixel / self.width as usize);
        self.sample_px(x as u32, y as u32, (i % s) as u32)
    }

    /// Bytes of the sample data held: every attribute plane (4 bytes per f32 or ID component) plus one byte of
    /// coverage per sample (what loading a dump must hold at the end, the yardstick of its peak memory).
    #[must_use]
    pub fn plane_bytes(&self) -> usize {
        let planes: usize = Attribute::ALL.into_iter().filter_map(|a| self.plane(a)).map(|p| p.bytes()).sum();
        planes + self.coverage.len()
    }

    /// Number of background (uncovered) samples.
    #[must_use]
    pub fn background_samples(&self) -> usize {
        self.coverage.iter().filter(|c| !**c).count()
    }

    /// Is `attr` present?
    #[must_use]
    pub fn has(&self, attr: Attribute) -> bool {
        self.plane(attr).is_some()
    }

    /// The attributes present, in canonical order.
    #[must_use]
    pub fn attributes(&self) -> Vec<Attribute> {
        Attribute::ALL.into_iter().filter(|a| self.has(*a)).collect()
    }

    /// A borrowed view of `attr`'s plane, if present.
    #[must_use]
    pub fn plane(&self, attr: Attribute) -> Option<PlaneRef<'_>> {
        Some(match attr {
            Attribute::Depth => PlaneRef::F32(self.depth.as_deref()?),
            Attribute::Position => PlaneRef::Vec3(self.position.as_deref()?),
            Attribute::Normal => PlaneRef::Vec3(self.normal.as_deref()?),
            Attribute::Albedo => PlaneRef::Vec3(self.albedo.as_deref()?),
            Attribute::Specular => PlaneRef::F32(self.specular.as_deref()?),
            Attribute::SpecularPower => PlaneRef::F32(self.specular_power.as_deref()?),
            Attribute::Roughness => PlaneRef::F32(self.roughness.as_deref()?),
            Attribute::Metallic => PlaneRef::F32(self.metallic.as_deref()?),
            Attribute::MaterialId => PlaneRef::U32(self.material_id.as_deref()?),
            Attribute::ObjectId => PlaneRef::U32(self.object_id.as_deref()?),
            Attribute::PrimitiveId => PlaneRef::U32(self.primitive_id.as_deref()?),
            Attribute::Motion => PlaneRef::Vec2(self.motion.as_deref()?),
        })
    }

    /// Sample `i`'s attributes ([`Sample`]); an absent plane reads as zero.
    #[must_use]
    pub fn sample(&self, i: usize) -> Sample {
        fn at<T: Copy + Default>(p: &Option<Vec<T>>, i: usize) -> T {
            p.as_ref().map_or(T::default(), |v| v[i])
        }
        Sample {
            depth: at(&self.depth, i),
            position: at(&self.position, i),
            normal: at(&self.normal, i),
            albedo: at(&self.albedo, i),
            specular: at(&self.specular, i),
            specular_power: at(&self.specular_power, i),
            roughness: at(&self.roughness, i),
            metallic: at(&self.metallic, i),
            material_id: at(&self.material_id, i),
            object_id: at(&self.object_id, i),
            primitive_id: at(&self.primitive_id, i),
            motion: at(&self.motion, i),
        }
    }

    /// Coverage and every plane split into runs of `len` samples (the last may be shorter), in order: for writing
    /// whole samples run by run in parallel ([`SamplesMut::set`]).
    pub fn sample_runs_mut(&mut self, len: usize) -> Vec<SamplesMut<'_>> {
        fn runs<T>(p: &mut Option<Vec<T>>, len: usize) -> Box<dyn Iterator<Item = Option<&mut [T]>> + '_> {
            match p {
                Some(v) => Box::new(v.chunks_mut(len).map(Some)),
                None => Box::new(std::iter::repeat_with(|| None)),
            }
        }
        let len = len.max(1);
        let (mut depth, mut position, mut normal, mut albedo) = (
            runs(&mut self.depth, len),
            runs(&mut self.position, len),
            runs(&mut self.normal, len),
            runs(&mut self.albedo, len),
        );
        let (mut specular, mut specular_power, mut roughness, mut metallic) = (
            runs(&mut self.specular, len),
            runs(&mut self.specular_power, len),
            runs(&mut self.roughness, len),
            runs(&mut self.metallic, len),
        );
        let (mut material_id, mut object_id, mut primitive_id, mut motion) = (
            runs(&mut self.material_id, len),
            runs(&mut self.object_id, len),
            runs(&mut self.primitive_id, len),
            runs(&mut self.motion, len),
        );
        // A present plane shorter than coverage (an invalid buffer) leaves the runs past its end without it.
        self.coverage
            .chunks_mut(len)
            .map(|coverage| SamplesMut {
                coverage,
                depth: depth.next().flatten(),
                position: position.next().flatten(),
                normal: normal.next().flatten(),
                albedo: albedo.next().flatten(),
                specular: specular.next().flatten(),
                specular_power: specular_power.next().flatten(),
                roughness: roughness.next().flatten(),
                metallic: metallic.next().flatten(),
                material_id: material_id.next().flatten(),
                object_id: object_id.next().flatten(),
                primitive_id: primitive_id.next().flatten(),
                motion: motion.next().flatten(),
            })
            .collect()
    }

    /// The storage slot of `attr`'s plane (present or not).
    pub fn slot(&mut self, attr: Attribute) -> PlaneSlot<'_> {
        match attr {
            Attribute::Depth => PlaneSlot::F32(&mut self.depth),
            Attribute::Position => PlaneSlot::Vec3(&mut self.position),
            Attribute::Normal => PlaneSlot::Vec3(&mut self.normal),
            Attribute::Albedo => PlaneSlot::Vec3(&mut self.albedo),
            Attribute::Specular => PlaneSlot::F32(&mut self.specular),
            Attribute::SpecularPower => PlaneSlot::F32(&mut self.specular_power),
            Attribute::Roughness => PlaneSlot::F32(&mut self.roughness),
            Attribute::Metallic => PlaneSlot::F32(&mut self.metallic),
            Attribute::MaterialId => PlaneSlot::U32(&mut self.material_id),
            Attribute::ObjectId => PlaneSlot::U32(&mut self.object_id),
            Attribute::PrimitiveId => PlaneSlot::U32(&mut self.primitive_id),
            Attribute::Motion => PlaneSlot::Vec2(&mut self.motion),
        }
    }

    /// Resizes every present plane to `n` entries (new ones zero), keeping its storage: for a buffer reused band
    /// after band.
    pub fn resize_planes(&mut self, n: usize) {
        for attr in Attribute::ALL {
            match self.slot(attr) {
                PlaneSlot::F32(Some(p)) => p.resize(n, 0.0),
                PlaneSlot::Vec2(Some(p)) => p.resize(n, Vec2::ZERO),
                PlaneSlot::Vec3(Some(p)) => p.resize(n, Vec3::ZERO),
                PlaneSlot::U32(Some(p)) => p.resize(n, 0),
                _ => {}
            }
        }
    }

    /// Calls `v` on every present plane, in canonical attribute order.
    pub fn visit_planes_mut(&mut self, v: &mut impl PlaneVisitor) {
        for attr in Attribute::ALL {
            match self.slot(attr) {
                PlaneSlot::F32(Some(p)) => v.visit(attr, p),
                PlaneSlot::Vec2(Some(p)) => v.visit(attr, p),
                PlaneSlot::Vec3(Some(p)) => v.visit(attr, p),
                PlaneSlot::U32(Some(p)) => v.visit(attr, p),
                _ => {}
            }
        }
    }

    /// A G-buffer of `width` × `height` × `samples` with `sample_positions` and `coverage`, this one's camera and
    /// materials, and every present plane mapped by `m` (which must return planes of the new size).
    pub fn map_planes(
        &self,
        (width, height, samples): (u32, u32, u32),
        sample_positions: Vec<Vec2>,
        coverage: Vec<bool>,
        m: &mut impl PlaneMapper,
    ) -> GBuffer {
        let mut out = GBuffer {
            width,
            height,
            samples,
            sample_positions,
            camera: self.camera,
            coverage,
            materials: self.materials.clone(),
            ..GBuffer::default()
        };
        for attr in Attribute::ALL {
            match (self.plane(attr), out.slot(attr)) {
                (Some(PlaneRef::F32(p)), PlaneSlot::F32(o)) => *o = m.map(attr, p),
                (Some(PlaneRef::Vec2(p)), PlaneSlot::Vec2(o)) => *o = m.map(attr, p),
                (Some(PlaneRef::Vec3(p)), PlaneSlot::Vec3(o)) => *o = m.map(attr, p),
                (Some(PlaneRef::U32(p)), PlaneSlot::U32(o)) => *o = m.map(attr, p),
                _ => {}
            }
        }
        out
    }

    /// This G-buffer's size, sample positions, camera, coverage and materials with no attribute planes: what an
    /// unpacked or rebuilt G-buffer starts from.
    #[must_use]
    pub fn shell(&self) -> GBuffer {
        GBuffer {
            width: self.width,
            height: self.height,
            samples: self.samples,
            sample_positions: self.sample_positions.clone(),
            camera: self.camera,
            coverage: self.coverage.clone(),
            materials: self.materials.clone(),
            ..GBuffer::default()
        }
    }

    /// Sets every attribute of the background (uncovered) samples to zero (0 for IDs).
    pub fn zero_background(&mut self) {
        struct Zero<'a>(&'a [bool]);
        impl PlaneVisitor for Zero<'_> {
            fn visit<T: Copy + Default + Send + Sync>(&mut self, _: Attribute, plane: &mut [T]) {
                plane.iter_mut().zip(self.0).filter(|(_, c)| !**c).for_each(|(v, _)| *v = T::default());
            }
        }
        let coverage = std::mem::take(&mut self.coverage);
        self.visit_planes_mut(&mut Zero(&coverage));
        self.coverage = coverage;
    }

    /// Replaces the plane of `attr` by `other`'s (absent there: absent here). False, and nothing changed, when
    /// the two G-buffers differ in size.
    pub fn copy_plane_from(&mut self, other: &GBuffer, attr: Attribute) -> bool {
        if (self.width, self.height, self.samples) != (other.width, other.height, other.samples) {
            return false;
        }
        let copied = match (self.slot(attr), other.plane(attr)) {
            (PlaneSlot::F32(o), Some(PlaneRef::F32(p))) => copy_into(o, p),
            (PlaneSlot::Vec2(o), Some(PlaneRef::Vec2(p))) => copy_into(o, p),
            (PlaneSlot::Vec3(o), Some(PlaneRef::Vec3(p))) => copy_into(o, p),
            (PlaneSlot::U32(o), Some(PlaneRef::U32(p))) => copy_into(o, p),
            _ => false,
        };
        if !copied {
            self.remove(attr);
        }
        true
    }

    /// Removes `attr` (makes it absent).
    pub fn remove(&mut self, attr: Attribute) {
        match self.slot(attr) {
            PlaneSlot::F32(o) => *o = None,
            PlaneSlot::Vec2(o) => *o = None,
            PlaneSlot::Vec3(o) => *o = None,
            PlaneSlot::U32(o) => *o = None,
        }
    }

    /// Checks the invariants every stage relies on: plane lengths, sample count and positions (each inside its pixel,
    /// [`check_sample_positions`]). Loaders call this
    /// once; after that the invariants are `debug_assert!`ed.
    pub fn validate(&self) -> Result<()> {
        if self.samples == 0 || self.samples > MAX_SAMPLES {
            return Err(Error::Argument(format!("sample count {} outside 1..={MAX_SAMPLES}", self.samples)));
        }
        if self.sample_positions.len() != self.samples as usize {
            return Err(Error::Mismatch(format!(
                "{} sample positions for {} samples",
                self.sample_positions.len(),
                self.samples
            )));
        }
        check_sample_positions(&self.sample_positions).map_err(Error::Argument)?;
        let n = checked_len(self.width, self.height, self.samples)?;
        if self.coverage.len() != n {
            return Err(Error::Mismatch(format!("coverage has {} entries, expected {n}", self.coverage.len())));
        }
        for attr in self.attributes() {
            let len = self.plane(attr).expect("present").len();
            if len != n {
                return Err(Error::Mismatch(format!("{} plane has {len} entries, expected {n}", attr.name())));
            }
        }
        Ok(())
    }

    /// Fills `depth` from `position` (depth = −z) or `position` from `depth` and the camera, whichever is missing
    /// and derivable. Returns the attribute it filled, if any.
    pub fn derive_depth_or_position(&mut self) -> Option<Attribute> {
        if self.depth.is_none() {
            self.position.as_ref()?;
            self.fill_depth_from_position();
            return Some(Attribute::Depth);
        }
        if self.position.is_none() {
            self.camera.as_ref()?;
            self.fill_position_from_depth();
            return Some(Attribute::Position);
        }
        None
    }

    /// (Re)computes `depth` from `position` (depth = −z on covered samples, 0 elsewhere), in place when the plane
    /// exists. Does nothing without positions.
    pub fn fill_depth_from_position(&mut self) {
        let Some(pos) = self.position.as_ref() else { return };
        let n = pos.len();
        let depth = self.depth.get_or_insert_with(|| vec![0.0; n]);
        depth
            .par_chunks_mut(DERIVE_CHUNK)
            .zip(pos.par_chunks(DERIVE_CHUNK))
            .zip(self.coverage.par_chunks(DERIVE_CHUNK))
            .for_each(|((d, p), c)| {
                for ((d, p), &c) in d.iter_mut().zip(p).zip(c) {
                    *d = if c { -p.z } else { 0.0 };
                }
            });
    }

    /// (Re)computes `position` from `depth` and the camera's ray through each sample (0 on background samples), in
    /// place when the plane exists. Does nothing without depth or camera.
    pub fn fill_position_from_depth(&mut self) {
        if self.camera.is_none() || self.depth.is_none() {
            return;
        }
        let n = self.len();
        let mut pos = self.position.take().unwrap_or_else(|| crate::base::memory::zeroed_vec3(n));
        self.derive_positions_into(0, &mut pos);
        self.position = Some(pos);
    }

    /// The positions [`GBuffer::fill_position_from_depth`] writes, as a plane of their own (the G-buffer is left as
    /// it is); `None` without depth or camera.
    #[must_use]
    pub fn derived_positions(&self) -> Option<Vec<Vec3>> {
        self.camera.as_ref().and(self.depth.as_ref())?;
        let mut pos = crate::base::memory::zeroed_vec3(self.len());
        self.derive_positions_into(0, &mut pos);
        Some(pos)
    }

    /// [`GBuffer::derived_positions`] of rows `rows` alone; `None` without depth or camera.
    #[must_use]
    pub fn derived_positions_of_rows(&self, rows: std::ops::Range<usize>) -> Option<Vec<Vec3>> {
        self.camera.as_ref().and(self.depth.as_ref())?;
        let row = self.width as usize * self.samples as usize;
        let mut pos = crate::base::memory::zeroed_vec3(rows.len() * row);
        self.derive_positions_into(rows.start, &mut pos);
        Some(pos)
    }

    /// Writes the derived positions of the rows from `first_row` on into `pos` (whole rows); nothing without depth or
    /// camera.
    fn derive_positions_into(&self, first_row: usize, pos: &mut [Vec3]) {
        let (Some(cam), Some(depth)) = (self.camera.as_ref(), self.depth.as_ref()) else { return };
        let chunk = (self.width as usize * self.samples as usize).max(1);
        let depth = &depth[first_row * chunk..first_row * chunk + pos.len()];
        let coverage = &self.coverage[first_row * chunk..first_row * chunk + pos.len()];
        let rays = cam.ray_caster(self.width, self.height);
        let offsets = &self.sample_positions;
        pos.par_chunks_mut(chunk).zip(depth.par_chunks(chunk)).zip(coverage.par_chunks(chunk)).enumerate().for_each(
            |(y, ((p, d), c))| {
                for (i, p) in p.iter_mut().enumerate() {
                    *p = derived_position(&rays, offsets, first_row + y, i, d[i], c[i]);
                }
            },
        );
    }

    /// The view-space position of sample `i`: the position plane's, else the one depth and the camera give
    /// ([`GBuffer::fill_position_from_depth`]'s bits; `rays` is the camera's [`Camera::ray_caster`] for this frame's
    /// size); `None` with neither.
    #[must_use]
    pub fn position_or_derived(&self, rays: Option<&crate::camera::RayCaster>, i: usize) -> Option<Vec3> {
        if let Some(p) = &self.position {
            return Some(p[i]);
        }
        let (rays, depth) = (rays?, self.depth.as_ref()?);
        let row = (self.width as usize * self.samples as usize).max(1);
        Some(derived_position(rays, &self.sample_positions, i / row, i % row, depth[i], self.coverage[i]))
    }

    /// Whether this G-buffer leaves its positions to depth and the camera: no position plane, but both of those (every
    /// reader then derives [`GBuffer::fill_position_from_depth`]'s bits).
    #[must_use]
    pub fn derives_position(&self) -> bool {
        self.position.is_none() && self.depth.is_some() && self.camera.is_some()
    }

    /// Whether the position plane holds exactly what [`GBuffer::fill_position_from_depth`] would write, bit for bit
    /// (0 on background samples): then it says nothing depth and the camera do not, and a reader that derives
    /// positions from depth reads the same bits. False without a position plane, depth or camera.
    #[must_use]
    pub fn position_is_derived(&self) -> bool {
        let (Some(cam), Some(depth), Some(pos)) = (self.camera.as_ref(), self.depth.as_ref(), self.position.as_ref())
        else {
            return false;
        };
        let rays = cam.ray_caster(self.width, self.height);
        let offsets = &self.sample_positions;
        let chunk = (self.width as usize * self.samples as usize).max(1);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        pos.par_chunks(chunk).zip(depth.par_chunks(chunk)).zip(self.coverage.par_chunks(chunk)).enumerate().all(
            |(y, ((p, d), c))| {
                p.iter().enumerate().all(|(i, &p)| bits(p) == bits(derived_position(&rays, offsets, y, i, d[i], c[i])))
            },
        )
    }
}

/// The position [`GBuffer::fill_position_from_depth`] gives sample `i` of row `y` (an index within the row) at
/// view depth `depth`: the camera ray through the sample times the depth, 0 at a background sample.
#[inline]
fn derived_position(
    rays: &crate::camera::RayCaster,
    offsets: &[Vec2],
    y: usize,
    i: usize,
    depth: f32,
    covered: bool,
) -> Vec3 {
    if !covered {
        return Vec3::ZERO;
    }
    let s = offsets.len();
    let o = offsets[i % s];
    rays.ray(Vec2::new((i / s) as f32 + 0.5 + o.x, y as f32 + 0.5 + o.y)) * depth
}

/// Samples per parallel block when deriving depth from position.
const DERIVE_CHUNK: usize = 1 << 14;

/// `width × height × samples` as a usize, refusing overflow and absurd sizes (over 2^32 samples).
pub fn checked_len(width: u32, height: u32, samples: u32) -> Result<usize> {
    let n = u64::from(width) * u64::from(height) * u64::from(samples);
    if n > 1 << 32 {
        return Err(Error::Argument(format!("{width}×{height}×{samples} samples is too large")));
    }
    Ok(n as usize)
}

/// Storage other than a layout's render targets that a frame's samples are decoded from a band of rows at a time:
/// a dump's own arrays (the ISPC `.bin`'s, `io::ispc::Arrays`). `layout::PackedFrame::of_source` makes it a frame
/// the resolve and the edge pass read band by band, as they read a layout's packed targets.
pub trait BandSource: Sync {
    /// What the samples are stored as, for messages ("the ISPC .bin's arrays").
    fn describe(&self) -> String;

    /// Decodes rows `rows` of the frame `like` into `out`, as `layout::PackedFrame::decode_rows` documents (`only`: the
    /// planes to decode, as in `PackedFrame::decode_rows_only`; `None`: every plane). Each plane must be what
    /// the storage's whole-frame reader gives for those samples, bit for bit.
    fn decode_rows(
        &self,
        like: &GBuffer,
        rows: std::ops::Range<u32>,
        out: &mut GBuffer,
        only: Option<&[Attribute]>,
    ) -> Result<()>;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A G-buffer with every plane, each sample's values distinct per plane and per sample.
    fn full(w: u32, h: u32, s: u32) -> GBuffer {
        let mut gb = GBuffer::new(w, h, s).unwrap();
        let n = gb.len();
        gb.coverage = (0..n).map(|i| i % 3 != 0).collect();
        let f = |k: f32| Some((0..n).map(|i| i as f32 + k).collect::<Vec<f32>>());
        let v3 = |k: f32| Some((0..n).map(|i| Vec3::new(i as f32, k, -(i as f32))).collect::<Vec<Vec3>>());
        (gb.depth, gb.specular, gb.specular_power, gb.roughness, gb.metallic) =
            (f(0.5), f(1.5), f(2.5), f(3.5), f(4.5));
        (gb.position, gb.normal, gb.albedo) = (v3(1.0), v3(2.0), v3(3.0));
        let ids = |k: u32| Some((0..n as u32).map(|i| i * 7 + k).collect::<Vec<u32>>());
        (gb.material_id, gb.object_id, gb.primitive_id) = (ids(1), ids(2), ids(3));
        gb.motion = Some((0..n).map(|i| Vec2::new(i as f32, 9.0)).collect());
        gb
    }

    /// Every sample read as a record and written back through runs of any length rebuilds the buffer bit for bit;
    /// an absent plane reads as zero and is not created by a write.
    #[test]
    fn sample_records_round_trip_through_runs() {
        let src = full(5, 3, 4);
        for every_plane in [true, false] {
            let mut src = src.clone();
            if !every_plane {
                src.remove(Attribute::Albedo);
                src.remove(Attribute::ObjectId);
            }
            for len in [1, 4, 7, 20, 60, 1000] {
                let mut out = src.clone();
                out.visit_planes_mut(&mut {
                    struct Garbage;
                    impl PlaneVisitor for Garbage {
                        fn visit<T: Copy + Default + Send + Sync>(&mut self, _: Attribute, p: &mut [T]) {
                            p.fill(T::default());
                        }
                    }
                    Garbage
                });
                out.coverage.fill(false);
                let mut at = 0;
                for mut run in out.sample_runs_mut(len) {
                    for j in 0..run.coverage.len() {
                        run.set(j, &src.sample(at + j));
                        run.coverage[j] = src.coverage[at + j];
                    }
                    at += run.coverage.len();
                }
                assert_eq!(at, src.len());
                assert_eq!(out, src, "runs of {len}, every plane: {every_plane}");
            }
            if !every_plane {
                assert_eq!(src.sample(6).albedo, Vec3::ZERO);
                assert_eq!(src.sample(6).object_id, 0);
            }
        }
    }

    /// `blend` and `scaled` act on every float attribute and keep the IDs of `self`.
    #[test]
    fn sample_blend_is_per_attribute() {
        let gb = full(2, 1, 1);
        let (a, b) = (gb.sample(0), gb.sample(1));
        let m = a.blend(0.25, &b, 0.75);
        assert_eq!(m.depth, 0.5 * 0.25 + 1.5 * 0.75);
        assert_eq!(m.metallic, 4.5 * 0.25 + 5.5 * 0.75);
        assert_eq!(m.normal, a.normal * 0.25 + b.normal * 0.75);
        assert_eq!(m.motion, Vec2::new(0.75, 9.0));
        assert_eq!((m.material_id, m.object_id, m.primitive_id), (1, 2, 3));
        let s = b.scaled(2.0);
        assert_eq!((s.roughness, s.albedo, s.primitive_id), (9.0, Vec3::new(2.0, 6.0, -2.0), 10));
    }

    #[test]
    fn standard_positions_are_inside_the_pixel_and_distinct() {
        for n in [1, 2, 4, 8, 16] {
            let p = standard_sample_positions(n).unwrap();
            assert_eq!(p.len(), n as usize);
            for (i, a) in p.iter().enumerate() {
                assert!(a.x.abs() <= 0.5 && a.y.abs() <= 0.5, "{n}x sample {i} at {a}");
                for b in &p[i + 1..] {
                    assert_ne!(a, b, "{n}x has a repeated position");
                }
            }
        }
        assert!(standard_sample_positions(3).is_none());
        assert_eq!(standard_sample_positions(4).unwrap()[0], Vec2::new(-2.0 / 16.0, -6.0 / 16.0));
    }

    #[test]
    fn ordered_grid_is_centred() {
        let p = ordered_grid_positions(2);
        assert_eq!(
            p,
            vec![Vec2::new(-0.25, -0.25), Vec2::new(0.25, -0.25), Vec2::new(-0.25, 0.25), Vec2::new(0.25, 0.25)]
        );
        let sum: Vec2 = ordered_grid_positions(3).iter().sum();
        assert!(sum.length() < 1e-6);
    }

    #[test]
    fn new_and_validate() {
        let mut g = GBuffer::new(3, 2, 4).unwrap();
        assert_eq!(g.len(), 24);
        assert_eq!(g.index(2, 1, 3), 23);
        g.validate().unwrap();
        g.depth = Some(vec![1.0; 5]);
        assert!(g.validate().is_err());
        assert!(GBuffer::new(3, 2, 3).is_err());
        assert_eq!(GBuffer::new(1, 1, 9).unwrap().sample_positions.len(), 9);
    }

    #[test]
    fn attribute_names_round_trip() {
        for a in Attribute::ALL {
            assert_eq!(Attribute::from_name(a.name()), Some(a));
        }
        assert_eq!(Attribute::from_name("material-id"), Some(Attribute::MaterialId));
        assert_eq!(Attribute::from_name("nope"), None);
    }
}
