//! What a dump's numbers mean: the conventions a reader must know to turn a renderer's images into our view-space
//! G-buffer (space, depth convention, ID encoding, background marker, normal encoding).
//!
//! Format-specific readers (canonical, Blender, Mitsuba, ISPC) know their conventions. Data read by naming — a
//! file set of single-purpose images, or `--map` — gets them from a preset ([`crate::io::fileset::Preset`]) or the
//! user's flags (`--space`, `--depth`, `--id-encoding`, `--background`, …), which override the preset field by field
//! ([`Overrides`]). [`Conventions::apply`] does the conversion once, on the file's own one-sample grid (before any
//! folding), with the camera.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use glam::{Vec2, Vec3};
use std::path::Path;

crate::named_enum! {
    /// The space positions and normals are stored in.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Space: "space" {
        /// Our view space (+X right, +Y up, looking along −Z).
        View => "view",
        /// World space: converted with the camera's `world_to_view`.
        World => "world",
    }
}

crate::named_enum! {
    /// What a depth value measures.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum DepthKind: "depth convention" {
        /// Positive distance along the view axis (`−z_view`); a channel holding mostly negative values is `z_view`
        /// itself and is negated.
        ViewZ => "view-z",
        /// Distance from the eye along the pixel's ray: `z = d · cos θ`.
        Ray => "ray",
        /// Distance along the ray from its origin on the near plane (LuxCoreRender): `z = near + d · cos θ`.
        RayFromNear => "ray-from-near",
        /// D3D post-projection depth in [0, 1] (0 at near), or reversed (`--reversed-z`, 1 at near).
        Ndc => "ndc",
    }
}

crate::named_enum! {
    /// How integer IDs are stored.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum IdEncoding: "ID encoding" {
        /// A float channel holding the ID (rounded; negative or non-finite → 0).
        Float => "float",
        /// A 32-bit unsigned channel, or a 16-bit grey PNG.
        U32 => "u32",
        /// Packed into 8-bit RGB: `id = R + 256·G + 65536·B` (LuxCoreRender's ID outputs).
        Rgb8 => "rgb8",
    }
}

crate::named_enum! {
    /// How normals are encoded in their channels.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum NormalEncoding: "normal encoding" {
        /// Signed components in [−1, 1].
        Signed => "signed",
        /// `n · 0.5 + 0.5` (the usual 8-bit and visualisation encoding).
        Unorm => "unorm",
    }
}

/// Which samples are background (no surface).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Background {
    /// Depth 0, non-finite, or at least [`BACKGROUND_DEPTH`]; without depth, a zero or non-finite position.
    Auto,
    /// Depth (else position) is +Inf.
    Inf,
    /// Depth (else position) is NaN.
    Nan,
    /// The depth file's alpha channel is 0.
    Alpha,
    /// Depth equals this value (after conversion to view depth: give it in the file's units).
    Value(f32),
}

impl Background {
    /// Parses `auto`, `inf`, `nan`, `alpha` or a number.
    pub fn parse(s: &str) -> std::result::Result<Background, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(Background::Auto),
            "inf" | "+inf" => Ok(Background::Inf),
            "nan" => Ok(Background::Nan),
            "alpha" => Ok(Background::Alpha),
            t => t
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Background::Value)
                .ok_or_else(|| format!("background {s:?}: expected auto, inf, nan, alpha or a finite number")),
        }
    }

    /// The spelling `parse` reads.
    #[must_use]
    pub fn name(&self) -> String {
        match self {
            Background::Auto => "auto".into(),
            Background::Inf => "inf".into(),
            Background::Nan => "nan".into(),
            Background::Alpha => "alpha".into(),
            Background::Value(v) => v.to_string(),
        }
    }
}

/// Depths at or beyond this are background under [`Background::Auto`] (Blender writes 1e10 for sky).
pub const BACKGROUND_DEPTH: f32 = 1e9;

/// The full set of conventions for data read by naming.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Conventions {
    /// Space of positions and normals.
    pub space: Space,
    /// What depth measures.
    pub depth: DepthKind,
    /// With [`DepthKind::Ndc`]: 1 at the near plane.
    pub reversed_z: bool,
    /// Near plane for `ray-from-near` and `ndc` (default: the camera's).
    pub znear: Option<f32>,
    /// Far plane for `ndc` (default: the camera's).
    pub zfar: Option<f32>,
    /// How IDs are stored (`None`: by the channel's type — uint as is, float rounded, 8-bit RGB packed).
    pub ids: Option<IdEncoding>,
    /// Background marker.
    pub background: Background,
    /// Normal encoding.
    pub normals: NormalEncoding,
}

/// What `--map` on one EXR has always assumed: view space, view-z depth, automatic background, signed normals.
/// Presets state only where they differ (`Conventions { space: Space::World, ..MAP_DEFAULT }`).
pub const MAP_DEFAULT: Conventions = Conventions {
    space: Space::View,
    depth: DepthKind::ViewZ,
    reversed_z: false,
    znear: None,
    zfar: None,
    ids: None,
    background: Background::Auto,
    normals: NormalEncoding::Signed,
};

impl Default for Conventions {
    /// [`MAP_DEFAULT`].
    fn default() -> Self {
        MAP_DEFAULT
    }
}

/// The user's explicit conventions (flags); each one given overrides the preset's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Overrides {
    /// `--space`.
    pub space: Option<Space>,
    /// `--depth`.
    pub depth: Option<DepthKind>,
    /// `--reversed-z`.
    pub reversed_z: bool,
    /// `--znear`.
    pub znear: Option<f32>,
    /// `--zfar`.
    pub zfar: Option<f32>,
    /// `--ids`.
    pub ids: Option<IdEncoding>,
    /// `--background`.
    pub background: Option<Background>,
    /// `--normals`.
    pub normals: Option<NormalEncoding>,
}

impl Overrides {
    /// True when no flag was given.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        *self == Overrides::default()
    }
}

impl Conventions {
    /// These conventions with the user's flags applied over them.
    #[must_use]
    pub fn with(mut self, o: &Overrides) -> Conventions {
        if let Some(v) = o.space {
            self.space = v;
        }
        if let Some(v) = o.depth {
            self.depth = v;
        }
        self.reversed_z |= o.reversed_z;
        if o.znear.is_some() {
            self.znear = o.znear;
        }
        if o.zfar.is_some() {
            self.zfar = o.zfar;
        }
        if o.ids.is_some() {
            self.ids = o.ids;
        }
        if let Some(v) = o.background {
            self.background = v;
        }
        if let Some(v) = o.normals {
            self.normals = v;
        }
        self
    }

    /// One line for `gbuf info`: `world space, depth ray-from-near, IDs rgb8, background inf, normals signed`.
    #[must_use]
    pub fn describe(&self) -> String {
        let depth = match (self.depth, self.reversed_z) {
            (DepthKind::Ndc, true) => "ndc (reversed-z)".to_string(),
            (d, _) => d.name().to_string(),
        };
        format!(
            "{} space, depth {depth}, IDs {}, background {}, normals {}",
            self.space.name(),
            self.ids.map_or("by channel type", IdEncoding::name),
            self.background.name(),
            self.normals.name()
        )
    }

    /// Converts a one-sample G-buffer read in these conventions to ours, in place, and sets its coverage.
    ///
    /// `raw_depth` is the depth channel as stored (before conversion), `alpha` the depth file's alpha when it has
    /// one. Positions and normals are converted to view space; depth to view depth, from the position when both
    /// are present (exact) and otherwise along each pixel's ray through `camera`. Returns notes per attribute
    /// saying what was done.
    pub fn apply(
        &self,
        gb: &mut GBuffer,
        camera: Option<&Camera>,
        alpha: Option<&[f32]>,
        path: &Path,
    ) -> Result<Vec<(&'static str, String)>> {
        let mut notes = Vec::new();
        let n = gb.len();
        // Coverage first, on the values as stored.
        let marker = |v: f32| -> bool {
            match self.background {
                Background::Auto => v == 0.0 || !v.is_finite() || v.abs() >= BACKGROUND_DEPTH,
                Background::Inf => v == f32::INFINITY,
                Background::Nan => v.is_nan(),
                Background::Alpha => false,
                Background::Value(b) => v == b,
            }
        };
        let mut coverage = vec![true; n];
        match (&gb.depth, &gb.position) {
            (Some(d), _) => coverage.iter_mut().zip(d).for_each(|(c, &v)| *c = !marker(v)),
            (None, Some(p)) => coverage.iter_mut().zip(p).for_each(|(c, v)| {
                *c = match self.background {
                    Background::Auto => *v != Vec3::ZERO && v.is_finite(),
                    _ => !(marker(v.x) || marker(v.y) || marker(v.z)),
                }
            }),
            (None, None) => {
                return Err(Error::invalid(path, "neither depth nor position: cannot tell surface from background"))
            }
        }
        if self.background == Background::Alpha {
            let a = alpha.ok_or_else(|| {
                Error::invalid(path, "--background alpha, but the depth (or position) image has no alpha channel")
            })?;
            coverage.iter_mut().zip(a).for_each(|(c, &a)| *c = a > 0.0);
        }
        // Non-finite values on covered samples also mean "no surface" only under auto; otherwise they stay and
        // the sanitize pass counts them.
        gb.coverage = coverage;

        if self.normals == NormalEncoding::Unorm {
            if let Some(nm) = &mut gb.normal {
                nm.iter_mut().for_each(|v| *v = *v * 2.0 - Vec3::ONE);
                notes.push(("normal", "decoded from n·0.5 + 0.5".to_string()));
            }
        }
        if self.space == Space::World {
            let cam = camera.ok_or_else(|| {
                Error::invalid(
                    path,
                    "world-space data needs the camera to convert it to view space: give a sidecar with a camera \
                     (--scene FILE, docs/FORMAT.md)",
                )
            })?;
            let cov = &gb.coverage;
            if let Some(p) = &mut gb.position {
                p.iter_mut().zip(cov).filter(|(_, c)| **c).for_each(|(v, _)| *v = cam.to_view_point(*v));
                notes.push(("position", "world → view with the camera".to_string()));
            }
            if let Some(nm) = &mut gb.normal {
                let m = cam.normal_matrix();
                nm.iter_mut().zip(cov).filter(|(_, c)| **c).for_each(|(v, _)| *v = Camera::normal_to_view(&m, *v));
                notes.push(("normal", "world → view with the camera".to_string()));
            }
        }
        // Depth.
        let (w, h, spp) = (gb.width, gb.height, gb.samples as usize);
        let positions = gb.sample_positions.clone();
        let ray_len = |i: usize, cam: &Camera| -> f32 {
            let pix = i / spp;
            let px = Vec2::new((pix as u32 % w) as f32 + 0.5, (pix as u32 / w) as f32 + 0.5) + positions[i % spp];
            cam.view_ray(px, w, h).length()
        };
        if let (Some(d), Some(p)) = (&mut gb.depth, &gb.position) {
            if self.depth != DepthKind::ViewZ || self.space == Space::World {
                for ((d, p), &c) in d.iter_mut().zip(p).zip(&gb.coverage) {
                    if c {
                        *d = -p.z;
                    }
                }
                notes.push(("depth", format!("view depth from the position (the file's depth is {})", self.depth)));
            } else {
                negate_if_z(d, &gb.coverage, &mut notes);
            }
        } else if let Some(d) = &mut gb.depth {
            match self.depth {
                DepthKind::ViewZ => negate_if_z(d, &gb.coverage, &mut notes),
                kind => {
                    let cam = camera.ok_or_else(|| {
                        Error::invalid(
                            path,
                            format!("depth convention {kind} needs the camera: give a sidecar with a camera (--scene)"),
                        )
                    })?;
                    let near = self.znear.unwrap_or(cam.znear);
                    let far = self.zfar.unwrap_or(cam.zfar);
                    if kind == DepthKind::Ndc && !(near > 0.0 && far > near) {
                        return Err(Error::Argument(format!("--depth ndc needs 0 < znear < zfar (got {near}, {far})")));
                    }
                    let ndc_cam = Camera { znear: near, zfar: far, ..*cam };
                    for (i, (v, &c)) in d.iter_mut().zip(&gb.coverage).enumerate() {
                        if !c {
                            continue;
                        }
                        *v = match kind {
                            DepthKind::Ray => *v / ray_len(i, cam),
                            DepthKind::RayFromNear => near + *v / ray_len(i, cam),
                            DepthKind::Ndc => {
                                let z = if self.reversed_z { 1.0 - *v } else { *v };
                                ndc_cam.view_depth_from_post_projection(z)
                            }
                            DepthKind::ViewZ => unreachable!(),
                        };
                    }
                    notes.push(("depth", format!("converted from {kind} to view depth")));
                }
            }
        }
        gb.zero_background();
        Ok(notes)
    }
}

/// A depth channel holding mostly negative values is view-space z: negate it.
fn negate_if_z(d: &mut [f32], cov: &[bool], notes: &mut Vec<(&'static str, String)>) {
    let negative = d.iter().zip(cov).filter(|(v, c)| **c && **v < 0.0).count();
    let positive = d.iter().zip(cov).filter(|(v, c)| **c && **v > 0.0).count();
    if negative > positive {
        d.iter_mut().for_each(|v| *v = -*v);
        notes.push(("depth", "negated (the channel holds view-space z)".to_string()));
    }
}
