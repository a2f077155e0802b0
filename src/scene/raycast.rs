//! The ray caster: one primary ray per MSAA sample, through the G-buffer's own sample positions, into a
//! view-space scene; then every attribute plane is filled from the hits.
//!
//! Rays start at the view-space origin with direction [`Camera::view_ray`] (z = −1), so the hit parameter `t` is
//! the view depth itself: `depth = t` and `position = dir · t` hold exactly (`position.z = −t` bit for bit).
//! Hits are clipped to the camera's [znear, zfar] range, like a rasterizer's clip planes.

use super::bvh::{Bvh, Hit};
use super::geometry::{Mesh, Triangle};
use crate::camera::Camera;
use crate::gbuffer::GBuffer;
use glam::Vec3;
use rayon::prelude::*;

/// Relative slack on the near clip: geometry placed exactly on the near plane must not be lost to the rounding
/// of `t` (it comes back within a few ulps of `znear`).
pub(crate) const NEAR_SLACK: f32 = 1e-4;
/// Smallest cosine between an interpolated normal and the direction to the eye. At silhouettes of tessellated
/// surfaces the interpolated normal can face slightly away; it is bent just enough to face the camera, since a
/// visible sample with a back-facing normal is not something a G-buffer holds.
const MIN_FACING: f32 = 1e-3;
/// Marks a sample whose ray hit nothing.
const MISS: u32 = u32::MAX;

/// A view-space scene ready to render: camera plus triangles.
#[derive(Clone, Debug)]
pub struct ViewScene {
    /// The camera (its `world_to_view` is informational: the mesh is already in view space).
    pub camera: Camera,
    /// Objects and triangles in view space.
    pub mesh: Mesh,
}

/// Nearest hit `t > 0` of the view ray `dir · t` (from the eye at the origin; `t` is the view depth when
/// `dir.z = −1`) with the sphere of `centre` and `radius`; `None` for a miss or a non-finite `t`. The analytic
/// scenes of the tests and of the resolve's fixture use it beside the triangle `Bvh`.
#[inline]
#[must_use]
pub fn ray_sphere(dir: Vec3, centre: Vec3, radius: f32) -> Option<f32> {
    // |dir·t − c|² = r²  →  a t² − 2 b t + (|c|² − r²) = 0.
    let a = dir.length_squared();
    let b = dir.dot(centre);
    let disc = b * b - a * (centre.length_squared() - radius * radius);
    if disc < 0.0 {
        return None;
    }
    let t = (b - disc.sqrt()) / a;
    (t > 0.0 && t.is_finite()).then_some(t)
}

/// Hit `t > 0` of the view ray `dir · t` with the plane through `point` with normal `normal`; `None` when the ray
/// is parallel to it (|n·dir| < 1e-12), points away from it, or `t` is not finite.
#[inline]
#[must_use]
pub fn ray_plane(dir: Vec3, normal: Vec3, point: Vec3) -> Option<f32> {
    let denom = normal.dot(dir);
    if denom.abs() < 1e-12 {
        return None;
    }
    let t = normal.dot(point) / denom;
    (t > 0.0 && t.is_finite()).then_some(t)
}

/// Renders `scene` into `gb` (whose size, samples and sample positions are already set): fills `coverage` and
/// every attribute plane except motion, and sets `gb.camera`.
pub fn render_into(scene: &ViewScene, gb: &mut GBuffer) {
    let bvh = Bvh::build(&scene.mesh.triangles);
    let cam = scene.camera;
    let (w, ht) = (gb.width, gb.height);
    let (t_min, t_max) = (cam.znear * (1.0 - NEAR_SLACK), cam.zfar);
    let row_len = (gb.width * gb.samples) as usize;
    let mut hits = vec![Hit { t: 0.0, tri: MISS, u: 0.0, v: 0.0 }; gb.len()];
    {
        let gbr: &GBuffer = gb;
        hits.par_chunks_mut(row_len.max(1)).enumerate().for_each(|(y, row)| {
            for (k, hit) in row.iter_mut().enumerate() {
                let dir = cam.view_ray(gbr.sample_px_of(y * row_len + k), w, ht);
                if let Some(found) = bvh.intersect(Vec3::ZERO, dir, t_min, t_max) {
                    *hit = found;
                }
            }
        });
    }
    let tris = &scene.mesh.triangles;
    let objects = &scene.mesh.objects;
    let object_of = |h: &Hit| &objects[tris[h.tri as usize].object as usize];
    let g: &GBuffer = gb;
    let fill_f32 = |f: &(dyn Fn(&Hit) -> f32 + Sync)| -> Vec<f32> {
        hits.par_iter().map(|h| if h.tri == MISS { 0.0 } else { f(h) }).collect()
    };
    let fill_u32 = |f: &(dyn Fn(&Hit) -> u32 + Sync)| -> Vec<u32> {
        hits.par_iter().map(|h| if h.tri == MISS { 0 } else { f(h) }).collect()
    };
    let coverage: Vec<bool> = hits.par_iter().map(|h| h.tri != MISS).collect();
    let depth = fill_f32(&|h| h.t);
    let position: Vec<Vec3> = hits
        .par_iter()
        .enumerate()
        .map(|(i, h)| if h.tri == MISS { Vec3::ZERO } else { cam.view_ray(g.sample_px_of(i), w, ht) * h.t })
        .collect();
    let normal: Vec<Vec3> = hits
        .par_iter()
        .enumerate()
        .map(|(i, h)| {
            if h.tri == MISS {
                Vec3::ZERO
            } else {
                shading_normal(&tris[h.tri as usize], h, cam.view_ray(g.sample_px_of(i), w, ht))
            }
        })
        .collect();
    let albedo: Vec<Vec3> =
        hits.par_iter().map(|h| if h.tri == MISS { Vec3::ZERO } else { object_of(h).material.albedo }).collect();
    let specular = fill_f32(&|h| object_of(h).material.specular);
    let specular_power = fill_f32(&|h| object_of(h).material.specular_power);
    let roughness = fill_f32(&|h| object_of(h).material.roughness);
    let metallic = fill_f32(&|h| object_of(h).material.metallic);
    let material_id = fill_u32(&|h| object_of(h).material_id);
    let object_id = fill_u32(&|h| object_of(h).object_id);
    let primitive_id = fill_u32(&|h| tris[h.tri as usize].prim);
    gb.coverage = coverage;
    gb.depth = Some(depth);
    gb.position = Some(position);
    gb.normal = Some(normal);
    gb.albedo = Some(albedo);
    gb.specular = Some(specular);
    gb.specular_power = Some(specular_power);
    gb.roughness = Some(roughness);
    gb.metallic = Some(metallic);
    gb.material_id = Some(material_id);
    gb.object_id = Some(object_id);
    gb.primitive_id = Some(primitive_id);
    gb.camera = Some(cam);
}

/// The view-space shading normal at a hit: the stored normal of a flat triangle (exactly, or negated when the
/// ray sees its back), or the renormalised interpolated vertex normal of a smooth one, bent to face the eye if
/// needed (see [`MIN_FACING`]).
pub(crate) fn shading_normal(t: &Triangle, h: &Hit, dir: Vec3) -> Vec3 {
    if !t.smooth {
        return if t.n[0].dot(dir) > 0.0 { -t.n[0] } else { t.n[0] };
    }
    let back = Mesh::face_normal(t).dot(dir) > 0.0;
    let n = (t.n[0] * (1.0 - h.u - h.v) + t.n[1] * h.u + t.n[2] * h.v).normalize_or_zero();
    let n = if back { -n } else { n };
    let to_eye = -dir.normalize();
    let c = n.dot(to_eye);
    if c >= MIN_FACING {
        n
    } else {
        (n + to_eye * (MIN_FACING - c)).normalize_or(to_eye)
    }
}
