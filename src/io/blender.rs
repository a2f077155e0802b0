//! Blender Cycles multilayer EXR reader (channels `<ViewLayer>.<Pass>.<Chan>`).
//!
//! Passes are recognised by name whatever the view layer is called, under the short names Blender 2.8–3.x
//! writes (`Depth`, `Normal`, `Position`, `DiffCol`, `GlossCol`, `IndexMA`, `IndexOB`, `Vector`, `Combined`) and
//! the long names of newer releases (`Diffuse Color`, `Glossy Color`, `Material Index`, `Object Index`, …), plus
//! AOVs named like `Roughness`, `Metallic` or `Specular`.
//!
//! Conversions: `Depth.Z` is camera-space Z (background 1e10 → no surface); `Normal` and `Position` are in Blender's
//! Z-up world space and are brought into our view space with the camera — from the sidecar, else recovered from the
//! `Position` pass by `super::camera_fit`. Without either, depth is still view depth, normals stay in world space
//! (flagged in their source note) and positions are dropped. `IndexMA`/`IndexOB` are float-coded integers;
//! `GlossCol` becomes the scalar specular (mean of RGB); `Vector.XY` becomes the motion since the previous frame
//! in pixels (+y down).

use super::exr::{RawData, RawImage};
use super::sidecar::Sidecar;
use super::{AttributeSource, LoadOptions, Loaded, SourceFormat};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer, PlaneSlot};
use glam::{Vec2, Vec3};
use std::path::Path;

/// Depth at or beyond this is Cycles' background value (it writes 1e10 where no surface was hit).
pub const BACKGROUND_DEPTH: f32 = 1e9;
/// A camera recovered from the position pass is used only when it reprojects the positions within this many
/// pixels (RMS): beyond that, edges would land in the wrong pixels.
pub const FIT_MAX_RMS_PX: f32 = 1.0;

/// The passes we read: (our role, Blender's short name, long name, channel suffixes).
const PASSES: [(Role, &str, &str, &[&str]); 9] = [
    (Role::Depth, "Depth", "Depth", &["Z"]),
    (Role::Normal, "Normal", "Normal", &["X", "Y", "Z"]),
    (Role::Position, "Position", "Position", &["X", "Y", "Z"]),
    (Role::Albedo, "DiffCol", "Diffuse Color", &["R", "G", "B"]),
    (Role::Gloss, "GlossCol", "Glossy Color", &["R", "G", "B"]),
    (Role::MaterialId, "IndexMA", "Material Index", &["X"]),
    (Role::ObjectId, "IndexOB", "Object Index", &["X"]),
    (Role::Motion, "Vector", "Vector", &["X", "Y", "Z", "W"]),
    (Role::Combined, "Combined", "Combined", &["R", "G", "B", "A"]),
];

/// AOV pass names (lower-case) for the scalar attributes.
const AOVS: [(Attribute, &[&str]); 4] = [
    (Attribute::Roughness, &["roughness"]),
    (Attribute::Metallic, &["metallic", "metalness"]),
    (Attribute::Specular, &["specular"]),
    (Attribute::SpecularPower, &["specular_power", "specularpower", "specular power"]),
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Depth,
    Normal,
    Position,
    Albedo,
    Gloss,
    MaterialId,
    ObjectId,
    Motion,
    Combined,
}

/// Splits `<ViewLayer>.<Pass>.<Chan>` into (view layer, pass, channel); the view layer may itself contain dots.
fn split(name: &str) -> Option<(&str, &str, &str)> {
    let (rest, chan) = name.rsplit_once('.')?;
    let (layer, pass) = rest.rsplit_once('.')?;
    Some((layer, pass, chan))
}

fn role_of(pass: &str) -> Option<Role> {
    PASSES.iter().find(|(_, short, long, _)| pass == *short || pass == *long).map(|p| p.0)
}

/// Does `raw` look like a Blender multilayer EXR (some `<layer>.<Pass>.<Chan>` channel with a Cycles pass name)?
#[must_use]
pub fn matches(raw: &RawImage) -> bool {
    raw.channels.iter().any(|c| {
        split(&c.name).is_some_and(|(layer, pass, _)| {
            !layer.is_empty() && matches!(role_of(pass), Some(Role::Depth | Role::Normal | Role::Position))
        })
    }) && !super::canonical::matches(raw)
}

/// Reads a Blender multilayer EXR into a single-sample G-buffer (folding is the caller's job).
pub fn read(raw: &RawImage, path: &Path, sidecar: Option<&Sidecar>, opts: &LoadOptions) -> Result<Loaded> {
    let layer = pick_view_layer(raw).ok_or_else(|| Error::MissingChannel {
        path: path.into(),
        name: "<ViewLayer>.Depth.Z, .Normal.XYZ or .Position.XYZ (a Blender view layer)".into(),
        found: raw.channel_list(),
    })?;
    // Channel names of a pass in the chosen layer (short or long spelling), unless `--map` names them.
    let find = |role: Role| -> Option<Vec<String>> {
        let (_, short, long, chans) = PASSES.iter().find(|p| p.0 == role)?;
        [short, long].iter().find_map(|pass| {
            let names: Vec<String> = chans.iter().map(|c| format!("{layer}.{pass}.{c}")).collect();
            names.iter().all(|n| raw.channel(n).is_some()).then_some(names)
        })
    };
    let ch = Channels::new(raw, path, opts);
    let depth_ch = ch.pick(Attribute::Depth, find(Role::Depth), 1)?;
    let normal_ch = ch.pick(Attribute::Normal, find(Role::Normal), 3)?;
    let pos_ch = ch.pick(Attribute::Position, find(Role::Position), 3)?;
    let albedo_ch = ch.pick(Attribute::Albedo, find(Role::Albedo), 3)?;
    let mat_ch = ch.pick(Attribute::MaterialId, find(Role::MaterialId), 1)?;
    let obj_ch = ch.pick(Attribute::ObjectId, find(Role::ObjectId), 1)?;
    let motion_ch = ch.pick(Attribute::Motion, find(Role::Motion).map(|v| v[0..2].to_vec()), 2)?;
    // A value AOV has one channel (`X`); a colour AOV three (`R`, `G`, `B`), reduced to their mean below.
    let aov = |names: &[&str]| -> Option<Vec<String>> {
        let pass = raw.channels.iter().find_map(|c| {
            let (l, pass, _) = split(&c.name)?;
            (l == layer && names.contains(&pass.to_ascii_lowercase().as_str())).then_some(pass)
        })?;
        let rgb: Vec<String> = ["R", "G", "B"].iter().map(|c| format!("{layer}.{pass}.{c}")).collect();
        if rgb.iter().all(|n| raw.channel(n).is_some()) {
            return Some(rgb);
        }
        raw.channels
            .iter()
            .find(|c| split(&c.name).is_some_and(|(l, p, _)| l == layer && p == pass))
            .map(|c| vec![c.name.clone()])
    };
    let mut scalar_ch = Vec::new();
    for (attr, names) in AOVS {
        let found = aov(names);
        let found = if attr == Attribute::Specular && found.is_none() { find(Role::Gloss) } else { found };
        if let Some(c) = ch.pick(attr, found, 1)? {
            scalar_ch.push((attr, c));
        }
    }

    let (w, h) = (raw.width, raw.height);
    let mut gb = GBuffer::new(w, h, 1)?;
    let n = gb.len();
    let mut sources = Vec::new();
    let depth_raw = depth_ch.as_ref().map(|c| ch.floats(&c[0])).transpose()?;
    let pos_world = pos_ch.as_ref().map(|c| ch.vec3(c)).transpose()?;
    let normal_world = normal_ch.as_ref().map(|c| ch.vec3(c)).transpose()?;
    if depth_raw.is_none() && pos_world.is_none() && normal_world.is_none() {
        return Err(Error::MissingChannel {
            path: path.into(),
            name: format!("{layer}.Depth.Z, {layer}.Position.XYZ or {layer}.Normal.XYZ"),
            found: raw.channel_list(),
        });
    }
    // Coverage: Cycles writes depth 1e10 and zero position/normal where no surface was hit.
    for i in 0..n {
        gb.coverage[i] = match (&depth_raw, &pos_world, &normal_world) {
            (Some(d), _, _) => d[i].is_finite() && d[i] > 0.0 && d[i] < BACKGROUND_DEPTH,
            (None, _, Some(nw)) => nw[i] != Vec3::ZERO,
            (None, Some(p), None) => p[i] != Vec3::ZERO,
            (None, None, None) => unreachable!("checked above"),
        };
    }
    let cam = resolve_camera(sidecar, pos_world.as_deref(), &gb.coverage, w, h, path)?;
    gb.camera = cam.camera;

    if let (Some(d), Some(c)) = (depth_raw, &depth_ch) {
        gb.depth = Some(mask(&gb.coverage, d, 0.0));
        sources.push(src(
            "depth",
            c,
            ch.type_of(&c[0]),
            Some("camera-space Z; ≥ 1e9 (Cycles writes 1e10) = background"),
        ));
    }
    if let (Some(p), Some(c)) = (pos_world, &pos_ch) {
        match &gb.camera {
            Some(camera) => {
                let m = camera.world_to_view;
                gb.position = Some(map_covered(&gb.coverage, &p, |v| m.transform_point3(v)));
                sources.push(src("position", c, ch.type_of(&c[0]), Some(&format!("world→view ({})", cam.detail))));
            }
            None => sources.push(src(
                "position",
                c,
                ch.type_of(&c[0]),
                Some(&format!("DROPPED: world-space positions and no camera ({})", cam.detail)),
            )),
        }
    }
    if gb.depth.is_none() && gb.position.is_some() {
        gb.derive_depth_or_position();
        sources.push(derived("depth", "−z of the view-space position"));
    }
    if let (Some(nw), Some(c)) = (normal_world, &normal_ch) {
        let (plane, note) = normals_to_view(&gb.coverage, &nw, gb.camera.as_ref(), &cam.detail);
        gb.normal = Some(plane);
        sources.push(src("normal", c, ch.type_of(&c[0]), Some(&note)));
    }
    if let Some(c) = &albedo_ch {
        gb.albedo = Some(mask(&gb.coverage, ch.vec3(c)?, Vec3::ZERO));
        sources.push(src("albedo", c, ch.type_of(&c[0]), None));
    }
    for (attr, c) in &scalar_ch {
        // Cycles' glossy colour pass is the tint of the specular lobe (1 for an untinted one), not a specular
        // level: said beside the source, since it reads as specular = 1 on every untinted surface.
        let gloss = c.first().is_some_and(|n| n.contains("GlossCol") || n.contains("Glossy Color"));
        let (plane, note) = if c.len() == 3 {
            let rgb = ch.vec3(c)?;
            let note = if gloss {
                "scalar = mean of the RGB channels of Cycles' glossy colour, the specular lobe's tint (1 when \
                 untinted), not the material's specular level: a `Specular` AOV gives that"
            } else {
                "scalar = mean of the RGB channels"
            };
            (rgb.iter().map(|v| (v.x + v.y + v.z) / 3.0).collect(), Some(note))
        } else {
            (ch.floats(&c[0])?, None)
        };
        let plane = mask(&gb.coverage, plane, 0.0);
        if let PlaneSlot::F32(slot) = gb.slot(*attr) {
            *slot = Some(plane);
        }
        sources.push(src(attr.name(), c, ch.type_of(&c[0]), note));
    }
    for (attr, c) in [(Attribute::MaterialId, &mat_ch), (Attribute::ObjectId, &obj_ch)] {
        if let Some(c) = c {
            let (ids, odd) = ch.ids(&c[0])?;
            let ids = mask(&gb.coverage, ids, 0);
            let note = (odd > 0).then(|| format!("{odd} non-integral or negative values rounded/clamped"));
            if attr == Attribute::MaterialId {
                gb.material_id = Some(ids);
            } else {
                gb.object_id = Some(ids);
            }
            sources.push(src(
                attr.name(),
                c,
                ch.type_of(&c[0]),
                Some(note.as_deref().unwrap_or("float-coded integer")),
            ));
        }
    }
    if let Some(c) = &motion_ch {
        // Measured with Blender 3.4 (a cube moving right and up across frames): Vector.XY is the offset to the
        // previous frame's position in pixels with +y up, i.e. −(motion since the previous frame). Ours is the
        // motion since the previous frame with +y down: (−X, +Y).
        let (x, y) = (ch.floats(&c[0])?, ch.floats(&c[1])?);
        let mv: Vec<Vec2> = x.iter().zip(&y).map(|(x, y)| Vec2::new(-*x, *y)).collect();
        gb.motion = Some(mask(&gb.coverage, mv, Vec2::ZERO));
        let note =
            "Vector.X/Y (offset to the previous frame, +y up) → motion since the previous frame (−X, +Y), +y down";
        sources.push(src("motion", c, ch.type_of(&c[0]), Some(note)));
    }
    gb.validate()?;
    let lights = sidecar_lights(sidecar, gb.camera.as_ref(), path)?;
    Ok(Loaded {
        gbuffer: gb,
        format: SourceFormat::Blender,
        sources,
        lights,
        camera_source: cam.source,
        compression: Some((raw.compression.clone(), raw.lossy)),
        sanitized: Vec::new(),
        warnings: Vec::new(),
        reading: None,
        positions_assumed: false,
    })
}

/// The view layer to read: the first (in file order) that has a Depth, Normal or Position pass.
fn pick_view_layer(raw: &RawImage) -> Option<String> {
    raw.channels.iter().find_map(|c| {
        let (layer, pass, _) = split(&c.name)?;
        matches!(role_of(pass), Some(Role::Depth | Role::Normal | Role::Position)).then(|| layer.to_string())
    })
}

// ---- Shared with the Mitsuba reader: channel access, camera resolution, world → view. ----

/// Channel access for one file: `--map` overrides, type checks and conversions, all naming the file in errors.
pub(super) struct Channels<'a> {
    raw: &'a RawImage,
    path: &'a Path,
    opts: &'a LoadOptions,
}

impl<'a> Channels<'a> {
    pub(super) fn new(raw: &'a RawImage, path: &'a Path, opts: &'a LoadOptions) -> Self {
        Channels { raw, path, opts }
    }

    /// The channels for `attr`: the `--map` override if given (it must name `count` existing channels), else
    /// `found`.
    pub(super) fn pick(
        &self,
        attr: Attribute,
        found: Option<Vec<String>>,
        count: usize,
    ) -> Result<Option<Vec<String>>> {
        let Some((_, names)) = self.opts.map.iter().find(|(a, _)| *a == attr) else { return Ok(found) };
        if names.len() != count {
            return Err(Error::invalid(
                self.path,
                format!("--map {}: {} channel(s) given, {count} needed", attr.name(), names.len()),
            ));
        }
        for n in names {
            if self.raw.channel(n).is_none() {
                return Err(Error::MissingChannel {
                    path: self.path.into(),
                    name: n.clone(),
                    found: self.raw.channel_list(),
                });
            }
        }
        Ok(Some(names.clone()))
    }

    fn data(&self, name: &str) -> Result<&'a RawData> {
        let c = self.raw.channel(name).ok_or_else(|| Error::MissingChannel {
            path: self.path.into(),
            name: name.into(),
            found: self.raw.channel_list(),
        })?;
        let n = self.raw.width as usize * self.raw.height as usize;
        if c.data.len() != n {
            return Err(Error::SizeMismatch {
                path: self.path.into(),
                what: format!("channel {name} has {} samples, expected {n}", c.data.len()),
            });
        }
        Ok(&c.data)
    }

    /// The file's sample type of channel `name`.
    pub(super) fn type_of(&self, name: &str) -> &'static str {
        self.raw.channel(name).map_or("?", |c| c.data.type_name())
    }

    /// A half or float channel as f32 (uint is refused: it is not a measurement).
    pub(super) fn floats(&self, name: &str) -> Result<Vec<f32>> {
        match self.data(name)? {
            d @ (RawData::F16(_) | RawData::F32(_)) => Ok(d.to_f32_vec()),
            RawData::U32(_) => Err(Error::UnsupportedSampleType {
                path: self.path.into(),
                channel: name.into(),
                found: "uint (expected half or float)".into(),
            }),
        }
    }

    /// Three channels as one Vec3 plane.
    pub(super) fn vec3(&self, names: &[String]) -> Result<Vec<Vec3>> {
        let (x, y, z) = (self.floats(&names[0])?, self.floats(&names[1])?, self.floats(&names[2])?);
        Ok(x.iter().zip(&y).zip(&z).map(|((x, y), z)| Vec3::new(*x, *y, *z)).collect())
    }

    /// An integer ID channel (uint, or float-coded integers). Returns the IDs and how many values were not
    /// non-negative integers (rounded, negatives and NaN → 0).
    pub(super) fn ids(&self, name: &str) -> Result<(Vec<u32>, u64)> {
        if let RawData::U32(v) = self.data(name)? {
            return Ok((v.clone(), 0));
        }
        let f = self.floats(name)?;
        let mut odd = 0;
        let ids = f
            .iter()
            .map(|&v| {
                if !(v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f32) {
                    odd += 1;
                }
                if v.is_finite() && v > 0.0 {
                    v.round().min(u32::MAX as f32) as u32
                } else {
                    0
                }
            })
            .collect();
        Ok((ids, odd))
    }
}

/// Where the camera of a world-space dump came from.
pub(super) struct CameraChoice {
    pub(super) camera: Option<Camera>,
    /// Sidecar, fit or unknown (for [`Loaded::camera_source`]).
    pub(super) source: super::CameraSource,
    /// The same with detail, for source notes (e.g. the fit's reprojection error).
    pub(super) detail: String,
}

/// The sidecar's camera, else one fitted to the world positions of the covered samples (pixel centres of this
/// unfolded image), else none.
/// A sidecar camera is checked against the position pass (when there is one): it must reproject the covered
/// samples' world positions to their pixel centres within this median error, else the sidecar belongs to another
/// render (or another frame) and the load fails instead of silently producing wrong view-space data.
pub const SIDECAR_MAX_MEDIAN_REPROJECTION_PX: f32 = 2.0;
/// Samples used for that check (a fixed stride over the covered samples).
const CHECK_SAMPLES: usize = 2048;

pub(super) fn resolve_camera(
    sidecar: Option<&Sidecar>,
    world_pos: Option<&[Vec3]>,
    coverage: &[bool],
    w: u32,
    h: u32,
    path: &Path,
) -> Result<CameraChoice> {
    if let Some(c) = sidecar.and_then(|s| s.camera.as_ref()) {
        let camera = c.to_camera_for(w, h);
        let mut detail = "sidecar camera".to_string();
        if let Some(err) = world_pos.and_then(|p| median_reprojection_px(&camera, p, coverage, w, h)) {
            if err.is_nan() || err > SIDECAR_MAX_MEDIAN_REPROJECTION_PX {
                return Err(Error::invalid(
                    path,
                    format!(
                        "the sidecar camera does not match this image: it reprojects the position pass {err:.1} px \
                         (median) away from the pixels (limit {SIDECAR_MAX_MEDIAN_REPROJECTION_PX} px)"
                    ),
                ));
            }
            // The check only: the one reprojection figure a run prints is `info`'s, per sample after folding.
            detail.push_str(&format!(
                ", checked against the position pass (within {SIDECAR_MAX_MEDIAN_REPROJECTION_PX} px)"
            ));
        }
        return Ok(CameraChoice { camera: Some(camera), source: super::CameraSource::Sidecar, detail });
    }
    if let Some(p) = world_pos {
        let (mut ps, mut qs) = (Vec::new(), Vec::new());
        for (i, (pos, covered)) in p.iter().zip(coverage).enumerate() {
            if *covered {
                ps.push(*pos);
                qs.push(Vec2::new((i % w as usize) as f32 + 0.5, (i / w as usize) as f32 + 0.5));
            }
        }
        match super::camera_fit::fit_camera(&ps, &qs, w, h) {
            Some((camera, rms)) if rms <= FIT_MAX_RMS_PX => {
                let detail = format!("camera fitted to {} positions, RMS reprojection error {rms:.3} px", ps.len());
                return Ok(CameraChoice { camera: Some(camera), source: super::CameraSource::Fit, detail });
            }
            Some((_, rms)) => {
                let detail = format!("camera fit rejected: RMS reprojection error {rms:.2} px > {FIT_MAX_RMS_PX} px");
                return Ok(CameraChoice { camera: None, source: super::CameraSource::Unknown, detail });
            }
            None => {
                let detail = "camera fit failed: positions too few or degenerate (coplanar or collinear)".into();
                return Ok(CameraChoice { camera: None, source: super::CameraSource::Unknown, detail });
            }
        }
    }
    Ok(CameraChoice {
        camera: None,
        source: super::CameraSource::Unknown,
        detail: "no sidecar camera and no position pass".into(),
    })
}

/// Median distance in pixels between the projection of covered world positions and their pixel centres (over a
/// fixed-stride subsample); `None` without covered finite positions. Points behind the camera count as infinitely
/// far off.
fn median_reprojection_px(camera: &Camera, world_pos: &[Vec3], coverage: &[bool], w: u32, h: u32) -> Option<f32> {
    let covered: Vec<usize> = (0..world_pos.len()).filter(|&i| coverage[i] && world_pos[i].is_finite()).collect();
    let stride = covered.len().div_ceil(CHECK_SAMPLES).max(1);
    let mut errs: Vec<f32> = covered
        .iter()
        .step_by(stride)
        .map(|&i| {
            let centre = Vec2::new((i % w as usize) as f32 + 0.5, (i / w as usize) as f32 + 0.5);
            camera.project(camera.to_view_point(world_pos[i]), w, h).map_or(f32::INFINITY, |q| (q - centre).length())
        })
        .collect();
    if errs.is_empty() {
        return None;
    }
    let mid = errs.len() / 2;
    Some(*errs.select_nth_unstable_by(mid, f32::total_cmp).1)
}

/// World-space normals → view space ([`Camera::normal_to_view`]: the normal matrix, lengths kept, the rule of every
/// reader). Without a camera they are left in world space and the note says so loudly.
pub(super) fn normals_to_view(
    coverage: &[bool],
    n: &[Vec3],
    camera: Option<&Camera>,
    detail: &str,
) -> (Vec<Vec3>, String) {
    match camera {
        Some(c) => {
            let m = c.normal_matrix();
            (map_covered(coverage, n, |v| Camera::normal_to_view(&m, v)), format!("world→view ({detail})"))
        }
        None => (map_covered(coverage, n, |v| v), format!("LEFT IN WORLD SPACE (not view space): {detail}")),
    }
}

/// The sidecar's lights in view space (`None` without any).
pub(super) fn sidecar_lights(
    sidecar: Option<&Sidecar>,
    camera: Option<&Camera>,
    path: &Path,
) -> Result<Option<Vec<crate::light::Light>>> {
    match sidecar.filter(|s| !s.lights.is_empty()) {
        Some(s) => Ok(Some(s.view_lights(camera, path)?)),
        None => Ok(None),
    }
}

/// `plane` with background samples set to `zero`.
pub(super) fn mask<T: Copy>(coverage: &[bool], mut plane: Vec<T>, zero: T) -> Vec<T> {
    for (v, c) in plane.iter_mut().zip(coverage) {
        if !c {
            *v = zero;
        }
    }
    plane
}

/// `f` applied to covered samples, zero elsewhere.
pub(super) fn map_covered(coverage: &[bool], v: &[Vec3], f: impl Fn(Vec3) -> Vec3) -> Vec<Vec3> {
    v.iter().zip(coverage).map(|(v, c)| if *c { f(*v) } else { Vec3::ZERO }).collect()
}

/// A source entry read from channels.
pub(super) fn src(
    attribute: &'static str,
    channels: &[String],
    file_type: &str,
    note: Option<&str>,
) -> AttributeSource {
    AttributeSource {
        attribute,
        channels: channels.to_vec(),
        file_type: file_type.into(),
        note: note.map(str::to_string),
    }
}

/// A source entry for a derived attribute.
pub(super) fn derived(attribute: &'static str, how: &str) -> AttributeSource {
    AttributeSource {
        attribute,
        channels: Vec::new(),
        file_type: "float".into(),
        note: Some(format!("derived: {how}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_layer_pass_and_channel() {
        assert_eq!(split("ViewLayer.Depth.Z"), Some(("ViewLayer", "Depth", "Z")));
        assert_eq!(split("My.Layer.Diffuse Color.R"), Some(("My.Layer", "Diffuse Color", "R")));
        assert_eq!(split("depth.T"), None);
        assert_eq!(role_of("Material Index"), Some(Role::MaterialId));
        assert_eq!(role_of("IndexMA"), Some(Role::MaterialId));
        assert_eq!(role_of("depth"), None);
    }
}
