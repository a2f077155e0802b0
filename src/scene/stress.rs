//! The `stress` scene: the extreme cases a G-buffer codec, layout or edge detector must survive, on an almost
//! empty image (about 3 % of the samples are covered; the rest is background).
//!
//! The camera is the identity (`world_to_view = I`), so world space is view space and normals are stored
//! exactly as written here. Regions are laid out on a grid of screen positions (normalised device coordinates,
//! NDC, +y up), each a patch about 0.12 × image height across (sub-pixel features are sized in pixels):
//!
//! | region | where (NDC) | exercises |
//! |---|---|---|
//! | `facing-exact` | (−0.8, 0.8) | normal exactly (0, 0, 1); albedo 1, specular 1, power 1e4, roughness 0, metallic 1 |
//! | `facing-1e-7` | (−0.4, 0.8) | normal 1e-7 rad from +Z: (1e-7, 0, 1), `z == 1.0` in f32 but x ≠ 0 |
//! | `facing-z-ulp` | (0.0, 0.8) | normal z = 1 − 2⁻²⁴ (the f32 just below 1), x = √(1 − z²) ≈ 3.5e-4 |
//! | `facing-denormal` | (0.4, 0.8) | normal (1e-40, −1e-40, 1): subnormal components |
//! | `far-plane` | (0.8, 0.8) | depth 0.995 · zfar (995 m); albedo 0, specular 0, power 0, roughness 1, metallic 0 |
//! | `axis-+x` / `axis--x` | (∓0.49, 0) | normals exactly (±1, 0, 0): walls left and right of the view axis |
//! | `axis-+y` / `axis--y` | (0, ∓0.52) | normals exactly (0, ±1, 0): floor and ceiling patches |
//! | `near-plane` | (−0.8, −0.8) | depth exactly znear (0.1) |
//! | `edge-on` | (−0.4, −0.8) | a plane 3° from edge-on (normal almost ⊥ to the view ray): a thin sliver |
//! | `subpixel-bar` | (0.0, −0.8) | a vertical bar 0.3 px wide on a pixel-centre column: hit by 1× centres and by some 4× samples, missed by others |
//! | `subpixel-hbar` | (0.2, −0.8) | a horizontal bar 0.3 px tall on a pixel-centre row |
//! | `subpixel-dot` | (0.4, −0.8) | a 0.3 × 0.3 px square on a pixel centre: covered at 1×, missed by every 4× sample |
//! | `huge-ids` | (0.8, −0.8) | object ID 1 000 000 (> 16 bits) and material ID 300 (> 8 bits) |
//!
//! A normal near −Z cannot face a perspective camera (a visible surface has `n · (eye − p) > 0`, and for
//! n ≈ −Z that is ≈ −depth < 0), so the scene has none: the ray caster reports normals facing the eye.

use super::geometry::Mesh;
use super::material::Material;
use super::raycast::ViewScene;
use crate::camera::Camera;
use glam::{Vec2, Vec3};

/// Vertical field of view of the stress camera.
pub const YFOV: f32 = 0.8;
/// Near plane.
pub const ZNEAR: f32 = 0.1;
/// Far plane.
pub const ZFAR: f32 = 1000.0;
/// Depth of most patches.
const DEPTH: f32 = 5.0;
/// Half size of a patch, as a fraction of the image height in NDC units (so a patch is 0.12 H pixels across).
const HALF: f32 = 0.06;

/// The extreme material: every value at its upper bound.
const MAX_MATERIAL: Material =
    Material { name: "max", albedo: Vec3::ONE, specular: 1.0, specular_power: 1.0e4, roughness: 0.0, metallic: 1.0 };
/// Every value at its lower bound.
const MIN_MATERIAL: Material =
    Material { name: "min", albedo: Vec3::ZERO, specular: 0.0, specular_power: 0.0, roughness: 1.0, metallic: 0.0 };
/// A mid-range material for the geometric cases.
const MID_MATERIAL: Material = Material {
    name: "mid",
    albedo: Vec3::new(0.5, 0.25, 0.125),
    specular: 0.5,
    specular_power: 32.0,
    roughness: 0.5,
    metallic: 0.5,
};
/// The material of the `huge-ids` patch.
const ODD_MATERIAL: Material = Material {
    name: "odd",
    albedo: Vec3::new(1.0, 0.0, 1.0),
    specular: 0.25,
    specular_power: 1.0,
    roughness: 0.75,
    metallic: 0.0,
};

/// The stress camera: identity transform looking along −Z.
#[must_use]
pub fn camera(width: u32, height: u32) -> Camera {
    Camera::identity(YFOV, width as f32 / height.max(1) as f32, ZNEAR, ZFAR)
}

struct Builder {
    mesh: Mesh,
    cam: Camera,
    width: u32,
    height: u32,
}

impl Builder {
    fn object(&mut self, name: &str, material_id: u32, material: Material) -> u32 {
        let id = self.mesh.objects.len() as u32 + 1;
        self.mesh.add_object(name, id, material_id, material)
    }
    /// View-space point at NDC (x, y) and depth d.
    fn at(&self, ndc: Vec2, d: f32) -> Vec3 {
        let t = self.cam.tan_half_fov();
        Vec3::new(ndc.x * t * self.cam.aspect * d, ndc.y * t * d, -d)
    }
    /// World size of one pixel at depth d.
    fn pixel(&self, d: f32) -> f32 {
        2.0 * self.cam.tan_half_fov() * d / self.height as f32
    }
    /// A square patch (in pixels) centred at NDC `ndc`, depth `d`, lying in the plane with exact normal `n`.
    fn patch(&mut self, o: u32, ndc: Vec2, d: f32, n: Vec3) {
        let centre = self.at(ndc, d);
        let h = HALF * self.cam.tan_half_fov() * d;
        let a1 = Vec3::Y.cross(n).normalize();
        let a2 = n.cross(a1);
        self.mesh.add_rect(o, centre, a1 * h, a2 * h, n);
    }
    /// A pixel-aligned rectangle facing the camera: centre at pixel centre (px, py), size in pixels.
    fn pixel_rect(&mut self, o: u32, px: f32, py: f32, w_px: f32, h_px: f32, d: f32) {
        let c = self.cam.view_position(Vec2::new(px, py), d, self.width, self.height);
        let p = self.pixel(d);
        self.mesh.add_rect(o, c, Vec3::X * (0.5 * w_px * p), Vec3::Y * (0.5 * h_px * p), Vec3::Z);
    }
    /// The pixel centre nearest to NDC `ndc`.
    fn pixel_centre(&self, ndc: Vec2) -> (f32, f32) {
        let x = ((ndc.x + 1.0) * 0.5 * self.width as f32).floor() + 0.5;
        let y = ((1.0 - ndc.y) * 0.5 * self.height as f32).floor() + 0.5;
        (x.min(self.width as f32 - 0.5), y.min(self.height as f32 - 0.5))
    }
}

/// The stress scene for an image of `width × height` (sub-pixel features are sized in pixels of this image).
#[must_use]
pub fn build(width: u32, height: u32) -> ViewScene {
    let cam = camera(width, height);
    let mut b = Builder { mesh: Mesh::default(), cam, width: width.max(1), height: height.max(1) };
    let top = 0.8;

    let o = b.object("facing-exact", 1, MAX_MATERIAL);
    b.patch(o, Vec2::new(-0.8, top), DEPTH, Vec3::Z);
    let o = b.object("facing-1e-7", 2, MID_MATERIAL);
    b.patch(o, Vec2::new(-0.4, top), DEPTH, Vec3::new(1e-7, 0.0, 1.0));
    let z = 1.0 - f32::EPSILON / 2.0;
    let x = (1.0 - f64::from(z) * f64::from(z)).sqrt() as f32;
    let o = b.object("facing-z-ulp", 2, MID_MATERIAL);
    b.patch(o, Vec2::new(0.0, top), DEPTH, Vec3::new(x, 0.0, z));
    let o = b.object("facing-denormal", 2, MID_MATERIAL);
    b.patch(o, Vec2::new(0.4, top), DEPTH, Vec3::new(1e-40, -1e-40, 1.0));
    let o = b.object("far-plane", 3, MIN_MATERIAL);
    b.patch(o, Vec2::new(0.8, top), 0.995 * ZFAR, Vec3::Z);

    // Axis normals: patches on the planes x = ±2 and y = ±1.2, between depths 5 and 6.
    for (name, centre, n, u, v) in [
        ("axis-+x", Vec3::new(-2.0, 0.0, -5.5), Vec3::X, Vec3::Z, Vec3::Y),
        ("axis--x", Vec3::new(2.0, 0.0, -5.5), Vec3::NEG_X, Vec3::Z, Vec3::Y),
        ("axis-+y", Vec3::new(0.0, -1.2, -5.5), Vec3::Y, Vec3::Z, Vec3::X),
        ("axis--y", Vec3::new(0.0, 1.2, -5.5), Vec3::NEG_Y, Vec3::Z, Vec3::X),
    ] {
        let o = b.object(name, 2, MID_MATERIAL);
        b.mesh.add_rect(o, centre, u * 0.5, v * 0.1, n);
    }

    let bottom = -0.8;
    let o = b.object("near-plane", 1, MAX_MATERIAL);
    b.patch(o, Vec2::new(-0.8, bottom), ZNEAR, Vec3::Z);

    // Edge-on: normal 3° from perpendicular to the ray through the patch centre.
    let o = b.object("edge-on", 3, MIN_MATERIAL);
    let c = b.at(Vec2::new(-0.4, bottom), 8.0);
    let view = -c.normalize();
    let side = view.cross(Vec3::Y).normalize();
    let n = (side + view * 0.05).normalize();
    let along = n.cross(Vec3::Y).normalize();
    b.mesh.add_rect(o, c, along, Vec3::Y * (HALF * b.cam.tan_half_fov() * 8.0), n);

    let (px, py) = b.pixel_centre(Vec2::new(0.0, bottom));
    let o = b.object("subpixel-bar", 2, MID_MATERIAL);
    b.pixel_rect(o, px, py, 0.3, 0.12 * height as f32, DEPTH);
    let (px, py) = b.pixel_centre(Vec2::new(0.2, bottom));
    let o = b.object("subpixel-hbar", 2, MID_MATERIAL);
    b.pixel_rect(o, px, py, 0.12 * height as f32, 0.3, DEPTH);
    let (px, py) = b.pixel_centre(Vec2::new(0.4, bottom));
    let o = b.object("subpixel-dot", 2, MID_MATERIAL);
    b.pixel_rect(o, px, py, 0.3, 0.3, DEPTH);

    let o = b.mesh.add_object("huge-ids", 1_000_000, 300, ODD_MATERIAL);
    b.patch(o, Vec2::new(0.8, bottom), DEPTH, Vec3::Z);

    ViewScene { camera: cam, mesh: b.mesh }
}
