//! Re-materialisation, the visibility buffer's other half: from a sample's triangle (object ID + primitive ID) and
//! its sample position, rebuild every attribute a fat G-buffer stores — intersect the sample's view ray with that
//! one triangle (the barycentrics), interpolate, and look the material up — and compare with the G-buffer.
//!
//! For the analytic scenes the geometry is known, so this is exact: the renderer's own triangle test
//! (`super::bvh::intersect_triangle`) and shading normal give the same bits (the error should be 0; a non-zero
//! one means the dump is not that scene at that size). The work per sample is counted from the code
//! ([`OPS_PER_SAMPLE`]): what a visibility-buffer renderer pays per shaded sample instead of reading a fat G-buffer.

use super::geometry::{Mesh, Triangle};
use super::raycast::{shading_normal, NEAR_SLACK};
use super::{build, SceneName};
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Arithmetic operations per re-materialised sample, counted from the code (adds, multiplies, one division,
/// compares not counted): the view ray through the sample position (6), Möller–Trumbore (two cross products, three
/// dot products, the reciprocal and three scalings: 34), the position (3), the smooth normal (interpolation 15,
/// normalisation 6, the facing test 8; flat triangles: 3), the material (a table lookup, 0).
pub const OPS_PER_SAMPLE: u32 = 6 + 34 + 3 + 29;

/// Bytes fetched per re-materialised sample beyond the visibility buffer's own 8: the triangle's three vertices
/// and three normals (72) and the material record (albedo, specular, power, roughness, metallic, ID: 32).
pub const BYTES_FETCHED_PER_SAMPLE: u32 = 72 + 32;

/// Covered samples that may fail to re-materialise (a triangle test at an edge, within the renderer's slack)
/// before the dump is taken for another scene.
pub const MAX_FAILED_FRACTION: f64 = 0.001;

/// One attribute's agreement between the re-materialised samples and the G-buffer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AttributeAgreement {
    /// The attribute.
    pub attribute: String,
    /// Largest absolute difference over the re-materialised samples (per component for vectors).
    pub max_abs: f64,
    /// Samples whose value is bit-identical.
    pub bit_exact: u64,
}

/// What re-materialising a dump of an analytic scene gave.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rematerialised {
    /// The scene the geometry came from.
    pub scene: String,
    /// Covered samples.
    pub samples: u64,
    /// Covered samples whose (object, primitive) is not a triangle of the scene, or whose ray misses it.
    pub failed: u64,
    /// Per attribute: depth, position, normal, albedo, specular, specular_power, roughness, metallic, material_id.
    pub attributes: Vec<AttributeAgreement>,
    /// [`OPS_PER_SAMPLE`].
    pub ops_per_sample: u32,
    /// [`BYTES_FETCHED_PER_SAMPLE`].
    pub bytes_fetched_per_sample: u32,
}

/// One sample rebuilt from its triangle.
#[derive(Clone, Copy, Default)]
struct Rebuilt {
    depth: f32,
    position: Vec3,
    normal: Vec3,
    albedo: Vec3,
    scalars: [f32; 4],
    material_id: u32,
}

/// Re-materialises every covered sample of `gb` (which needs object and primitive IDs) from scene `name` at
/// `gb`'s size and compares each attribute `gb` holds with the rebuilt one.
pub fn rematerialise(name: SceneName, gb: &GBuffer) -> Result<Rematerialised> {
    let (Some(obj), Some(prim)) = (&gb.object_id, &gb.primitive_id) else {
        return Err(Error::Mismatch("re-materialisation needs object and primitive IDs in the G-buffer".into()));
    };
    let scene = build(name, gb.width, gb.height);
    let mesh: &Mesh = &scene.mesh;
    let index: HashMap<(u32, u32), usize> = mesh
        .triangles
        .iter()
        .enumerate()
        .map(|(i, t)| ((mesh.objects[t.object as usize].object_id, t.prim), i))
        .collect();
    let cam = scene.camera;
    let (t_min, t_max) = (cam.znear * (1.0 - NEAR_SLACK), cam.zfar);
    let rebuilt: Vec<Option<Rebuilt>> = (0..gb.len())
        .into_par_iter()
        .map(|i| {
            if !gb.coverage[i] {
                return None;
            }
            let tri: &Triangle = &mesh.triangles[*index.get(&(obj[i], prim[i]))?];
            let dir = cam.view_ray(gb.sample_px_of(i), gb.width, gb.height);
            let (t, u, v) = super::bvh::intersect_triangle(tri, Vec3::ZERO, dir, t_min, t_max)?;
            let hit = super::bvh::Hit { t, tri: 0, u, v };
            let object = &mesh.objects[tri.object as usize];
            let m = &object.material;
            Some(Rebuilt {
                depth: t,
                position: dir * t,
                normal: shading_normal(tri, &hit, dir),
                albedo: m.albedo,
                scalars: [m.specular, m.specular_power, m.roughness, m.metallic],
                material_id: object.material_id,
            })
        })
        .collect();
    let covered = gb.coverage.iter().filter(|c| **c).count() as u64;
    let ok: Vec<usize> = (0..gb.len()).filter(|&i| rebuilt[i].is_some()).collect();
    let failed = covered - ok.len() as u64;
    if failed as f64 > MAX_FAILED_FRACTION * covered as f64 {
        return Err(Error::Implausible(format!(
            "the dump does not look like the {} scene at {}×{}: {failed} of {covered} covered samples name no \
             triangle of it or miss the one they name",
            name.name(),
            gb.width,
            gb.height
        )));
    }
    let mut attributes = Vec::new();
    let mut agree = |name: &str, diff: &(dyn Fn(usize, &Rebuilt) -> (f64, bool) + Sync)| {
        let (max_abs, bit_exact) = ok
            .par_iter()
            .map(|&i| {
                let (d, same) = diff(i, rebuilt[i].as_ref().expect("filtered"));
                (d, u64::from(same))
            })
            .reduce(|| (0.0, 0), |a, b| (a.0.max(b.0), a.1 + b.1));
        attributes.push(AttributeAgreement { attribute: name.into(), max_abs, bit_exact });
    };
    let f = |a: f32, b: f32| (f64::from((a - b).abs()), a.to_bits() == b.to_bits());
    let v = |a: Vec3, b: Vec3| {
        (f64::from((a - b).abs().max_element()), a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
    };
    if let Some(p) = &gb.depth {
        agree("depth", &|i, r| f(p[i], r.depth));
    }
    // The input's positions, or those its depth and camera give (what a renderer reading it derives).
    let rays = gb.camera.map(|c| c.ray_caster(gb.width, gb.height));
    if gb.position.is_some() || (gb.depth.is_some() && rays.is_some()) {
        let p = |i: usize| gb.position_or_derived(rays.as_ref(), i).unwrap_or(Vec3::NAN);
        agree("position", &|i, r| v(p(i), r.position));
    }
    if let Some(p) = &gb.normal {
        agree("normal", &|i, r| v(p[i], r.normal));
    }
    if let Some(p) = &gb.albedo {
        agree("albedo", &|i, r| v(p[i], r.albedo));
    }
    for (k, (name, plane)) in [
        ("specular", &gb.specular),
        ("specular_power", &gb.specular_power),
        ("roughness", &gb.roughness),
        ("metallic", &gb.metallic),
    ]
    .into_iter()
    .enumerate()
    {
        if let Some(p) = plane {
            agree(name, &|i, r| f(p[i], r.scalars[k]));
        }
    }
    if let Some(p) = &gb.material_id {
        agree("material_id", &|i, r| (f64::from(p[i].abs_diff(r.material_id)), p[i] == r.material_id));
    }
    Ok(Rematerialised {
        scene: name.name().into(),
        samples: covered,
        failed,
        attributes,
        ops_per_sample: OPS_PER_SAMPLE,
        bytes_fetched_per_sample: BYTES_FETCHED_PER_SAMPLE,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rendered_room_is_rebuilt_bit_for_bit_and_another_frame_is_not() {
        let gb = super::super::render(SceneName::Room, 64, 36, 4).unwrap();
        let r = rematerialise(SceneName::Room, &gb).unwrap();
        assert!(r.samples > 0 && r.failed == 0, "{r:?}");
        assert_eq!(r.attributes.len(), 9);
        for a in &r.attributes {
            assert_eq!((a.max_abs, a.bit_exact), (0.0, r.samples), "{a:?}");
        }
        // The stress scene's dump is not the room: refused, with the counts.
        let other = super::super::render(SceneName::Stress, 64, 36, 4).unwrap();
        let e = rematerialise(SceneName::Room, &other).unwrap_err().to_string();
        assert!(e.contains("does not look like the room scene at 64×36"), "{e}");
        // A changed value is seen, and only in its attribute.
        let mut changed = gb.clone();
        let i = changed.coverage.iter().position(|c| *c).unwrap();
        changed.albedo.as_mut().unwrap()[i].y += 0.25;
        let r = rematerialise(SceneName::Room, &changed).unwrap();
        for a in &r.attributes {
            let want = if a.attribute == "albedo" { (0.25, r.samples - 1) } else { (0.0, r.samples) };
            assert!((a.max_abs - want.0).abs() < 1e-6 && a.bit_exact == want.1, "{a:?}");
        }
        // Without IDs there is nothing to re-materialise from.
        let mut no_ids = gb.clone();
        no_ids.primitive_id = None;
        assert!(rematerialise(SceneName::Room, &no_ids).unwrap_err().to_string().contains("primitive IDs"));
    }
}
