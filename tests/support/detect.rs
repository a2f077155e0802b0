//! A tiny ray caster that builds per-sample G-buffers from analytic planes and spheres, for the detector tests.
//! Reached by the `detect_*` tests as `support::detect` (`mod support;`), and by `benches/detect.rs` with `#[path]`.
#![allow(dead_code)]

use gbuf::camera::Camera;
use gbuf::scene::raycast::{ray_plane, ray_sphere};
use gbuf::GBuffer;
use glam::Vec3;

/// Vertical field of view of the test camera.
pub const YFOV: f32 = 0.8;

/// The shape of a surface, in view space.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// An infinite plane through `point` with normal `normal`.
    Plane { normal: Vec3, point: Vec3 },
    /// A sphere.
    Sphere { center: Vec3, radius: f32 },
}

/// A surface of the test scene.
#[derive(Clone, Copy)]
pub struct Surface {
    pub shape: Shape,
    pub object: u32,
    pub material: u32,
    /// Keeps only the hits this returns true for (view-space position); `None` keeps all.
    pub keep: Option<fn(Vec3) -> bool>,
    /// Primitive ID of a hit (view-space position); `None` gives primitive 0.
    pub prim: Option<fn(Vec3) -> u32>,
}

impl Surface {
    /// A plain surface: no clipping, one primitive.
    pub fn new(shape: Shape, object: u32) -> Self {
        Surface { shape, object, material: object, keep: None, prim: None }
    }

    /// Ray (z = −1 scaled) → (depth, outward normal facing the camera).
    fn hit(&self, ray: Vec3) -> Option<(f32, Vec3)> {
        let (t, n) = match self.shape {
            Shape::Plane { normal, point } => {
                let t = ray_plane(ray, normal, point)?;
                (t, if normal.dot(ray) > 0.0 { -normal } else { normal })
            }
            Shape::Sphere { center, radius } => {
                let t = ray_sphere(ray, center, radius)?;
                (t, (ray * t - center).normalize())
            }
        };
        if self.keep.is_some_and(|k| !k(ray * t)) {
            return None;
        }
        Some((t, n.normalize()))
    }
}

/// The test camera for a `w × h` image.
pub fn camera(w: u32, h: u32) -> Camera {
    Camera::identity(YFOV, w as f32 / h as f32, 0.1, 1000.0)
}

/// Renders `surfaces` into a `w × h × samples` G-buffer with every attribute the detectors use.
pub fn render(w: u32, h: u32, samples: u32, surfaces: &[Surface]) -> GBuffer {
    let mut gb = GBuffer::new(w, h, samples).unwrap();
    let cam = camera(w, h);
    let n = gb.len();
    let (mut depth, mut pos, mut nrm, mut alb) =
        (vec![0.0; n], vec![Vec3::ZERO; n], vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    let (mut mat, mut obj, mut prim) = (vec![0u32; n], vec![0u32; n], vec![0u32; n]);
    for y in 0..h {
        for x in 0..w {
            for s in 0..samples {
                let i = gb.index(x, y, s);
                let ray = cam.view_ray(gb.sample_px(x, y, s), w, h);
                let best = surfaces
                    .iter()
                    .filter_map(|sf| sf.hit(ray).map(|(t, n)| (t, n, sf)))
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                if let Some((t, n, sf)) = best {
                    gb.coverage[i] = true;
                    depth[i] = t;
                    pos[i] = ray * t;
                    nrm[i] = n;
                    alb[i] = Vec3::new(0.2 + 0.1 * (sf.object % 8) as f32, 0.5, 0.7);
                    mat[i] = sf.material;
                    obj[i] = sf.object;
                    prim[i] = sf.prim.map_or(0, |p| p(ray * t));
                }
            }
        }
    }
    gb.camera = Some(cam);
    gb.depth = Some(depth);
    gb.position = Some(pos);
    gb.normal = Some(nrm);
    gb.albedo = Some(alb);
    gb.material_id = Some(mat);
    gb.object_id = Some(obj);
    gb.primitive_id = Some(prim);
    gb.validate().unwrap();
    gb
}

/// Columns (x) of the flagged pixels of row `y`.
pub fn flagged_columns(mask: &gbuf::detect::EdgeMask, y: u32) -> Vec<u32> {
    (0..mask.width).filter(|&x| mask.is_edge((y * mask.width + x) as usize)).collect()
}
