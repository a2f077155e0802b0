//! The analytic scene generator: a ray caster over triangle scenes that renders per-sample G-buffers at the
//! standard MSAA sample positions (`gbuf scene`).
//!
//! Input: a scene name, an image size and a sample count. Output: a [`GBuffer`] with every attribute but motion,
//! the camera set, and (through [`default_lights`] / [`scatter_lights`]) view-space lights. The scenes are
//! ground truth for the rest of the crate: exact IDs, exact normals where the scene says so, depth and position
//! consistent with the camera ray through each sample position.
//!
//! - `room`: a furnished interior with sky, thin bars, smooth spheres and a dozen materials.
//! - [`stress`]: the extreme values and geometric corner cases, on an almost empty image.
//!
//! Rendering is parallel over image rows with rayon; see [`raycast`] for the conventions and `bvh` for the
//! acceleration structure.

pub(crate) mod bvh;
pub(crate) mod geometry;
pub mod lights;
pub(crate) mod material;
pub mod raycast;
pub mod rematerialise;
pub(crate) mod room;
pub mod stress;

pub use self::lights::{choose_lights, default_lights, scatter_lights, scene_sidecar, sidecar_light, LightsSource};
pub use self::material::Material;

use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use raycast::ViewScene;

/// The most samples (width × height × samples per pixel) [`render`] accepts: 2^25 (e.g. 1920×1080 at 16×, or
/// 4096×2048 at 4×). A full G-buffer costs about 70 bytes per sample, so this caps memory near 2.5 GB.
pub const MAX_RENDER_SAMPLES: u64 = 1 << 25;

/// The built-in analytic scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SceneName {
    /// A furnished room open to the sky (see `room`).
    Room,
    /// Extreme values and corner cases on an almost empty image (see [`stress`]).
    Stress,
}

crate::named!(SceneName: "scene" { Room => "room", Stress => "stress" });

/// One object of a scene, as the G-buffer's ID planes name it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ObjectInfo {
    /// Object name ("sphere-chrome", "subpixel-bar", ...); several objects may share one (floor tiles).
    pub name: String,
    /// Value in the `object_id` plane.
    pub object_id: u32,
    /// Value in the `material_id` plane.
    pub material_id: u32,
    /// Material name.
    pub material: &'static str,
    /// Number of triangles (primitive IDs run from 0 to this − 1).
    pub triangles: u32,
}

/// Scene `name` in view space for an image of `width × height` (camera and triangles).
#[must_use]
pub fn build(name: SceneName, width: u32, height: u32) -> ViewScene {
    match name {
        SceneName::Room => room::build(width, height),
        SceneName::Stress => stress::build(width, height),
    }
}

/// The objects of scene `name` as rendered at `width × height` (the stress scene sizes sub-pixel features in
/// pixels, so its geometry, not its IDs, depends on the size).
#[must_use]
pub fn objects(name: SceneName, width: u32, height: u32) -> Vec<ObjectInfo> {
    let scene = build(name, width.max(1), height.max(1));
    let mut counts = vec![0u32; scene.mesh.objects.len()];
    for t in &scene.mesh.triangles {
        counts[t.object as usize] += 1;
    }
    scene
        .mesh
        .objects
        .iter()
        .zip(counts)
        .map(|(o, triangles)| ObjectInfo {
            name: o.name.clone(),
            object_id: o.object_id,
            material_id: o.material_id,
            material: o.material.name,
            triangles,
        })
        .collect()
}

/// Renders scene `name` at `width × height` with `samples` per pixel (1, 2, 4, 8 or 16, at the standard D3D
/// positions) into a G-buffer whose `camera` is set. Every sample gets depth, position, normal, albedo, specular,
/// specular power, roughness, metallic and the three IDs; background samples have `coverage == false` and zeros.
///
/// Errors: a zero dimension, an unsupported sample count, or more than [`MAX_RENDER_SAMPLES`] samples.
pub fn render(name: SceneName, width: u32, height: u32, samples: u32) -> Result<GBuffer> {
    if width == 0 || height == 0 {
        return Err(Error::Argument(format!("scene size {width}×{height}: both dimensions must be at least 1")));
    }
    if crate::gbuffer::standard_sample_positions(samples).is_none() {
        return Err(Error::Argument(format!("{samples} samples per pixel: scenes render 1, 2, 4, 8 or 16")));
    }
    let total = u64::from(width) * u64::from(height) * u64::from(samples);
    if total > MAX_RENDER_SAMPLES {
        return Err(Error::Argument(format!(
            "{width}×{height} at {samples}× is {total} samples; the limit is {MAX_RENDER_SAMPLES}"
        )));
    }
    let mut gb = GBuffer::new(width, height, samples)?;
    raycast::render_into(&build(name, width, height), &mut gb);
    debug_assert!(gb.validate().is_ok());
    Ok(gb)
}
