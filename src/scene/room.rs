//! The `room` scene: a furnished interior open to the sky, built in a Y-up world and viewed from inside.
//!
//! What it holds, and what each part exercises:
//! - **floor**: 2 m tiles alternating two materials: coplanar neighbours with different object and material IDs
//!   but the same normal and depth (a material edge without a geometric one); far tiles at grazing angles.
//! - **walls**: a brick back wall with a window (sky through it, three thin window bars), a plaster left wall seen
//!   almost edge-on, a partial right wall; no ceiling, so sky fills the top of the image and the open right side.
//! - **boxes**: a rotated crate, a stack of two boxes, a tall dark pillar: hard edges, depth discontinuities.
//! - **thin bars**: a fence of vertical bars from 10 cm down to 1.5 mm wide (sub-pixel at 1080p beyond the first
//!   few) under a 1 cm rail: sub-pixel geometry that some samples of a pixel hit and others miss.
//! - **spheres**: four UV spheres from coarse (12×6) to fine (48×24) with interpolated vertex normals: triangle
//!   edges that are not surface edges (different primitive IDs, same object, continuous normal).
//! - **grazing**: a thin panel almost parallel to the view direction and a plank tilted 3° off the floor.
//! - **materials**: the fourteen tuples of [`room_palette`], from rough dielectrics to mirror-like metals.

use super::geometry::Mesh;
use super::material::{room_palette, Material};
use super::raycast::ViewScene;
use crate::camera::Camera;
use glam::{Mat4, Quat, Vec3};

/// Vertical field of view of the room camera (radians; ≈ 52°).
pub const YFOV: f32 = 0.9;
/// Near plane of the room camera.
pub const ZNEAR: f32 = 0.1;
/// Far plane of the room camera.
pub const ZFAR: f32 = 100.0;

// Palette indices (material ID = index + 1).
const TILE_LIGHT: usize = 0;
const TILE_DARK: usize = 1;
const PLASTER: usize = 2;
const BRICK: usize = 3;
const WOOD: usize = 4;
const GOLD: usize = 5;
const CHROME: usize = 6;
const BLUE: usize = 7;
const GREEN: usize = 8;
const SOOT: usize = 9;
const WHITE: usize = 10;
const COPPER: usize = 11;
const STEEL: usize = 12;
const RED: usize = 13;

/// The room camera for an image of `width × height` (aspect = width / height).
#[must_use]
pub fn camera(width: u32, height: u32) -> Camera {
    Camera::look_at(
        Vec3::new(0.3, 1.7, 5.0),
        Vec3::new(0.0, 1.2, -6.0),
        Vec3::Y,
        YFOV,
        width as f32 / height.max(1) as f32,
        ZNEAR,
        ZFAR,
    )
}

struct Builder {
    mesh: Mesh,
    palette: Vec<Material>,
}

impl Builder {
    fn object(&mut self, name: &str, material: usize) -> u32 {
        let id = self.mesh.objects.len() as u32 + 1;
        self.mesh.add_object(name, id, material as u32 + 1, self.palette[material])
    }
    fn cuboid(&mut self, name: &str, material: usize, centre: Vec3, half: Vec3, yaw: f32) {
        let o = self.object(name, material);
        self.mesh.add_box(o, Mat4::from_scale_rotation_translation(half, Quat::from_rotation_y(yaw), centre));
    }
    /// A wall rectangle between two corners in a plane of constant x or z.
    fn wall_rect(&mut self, o: u32, a: Vec3, b: Vec3, normal: Vec3) {
        let c = (a + b) * 0.5;
        let d = (b - a).abs() * 0.5;
        let (u, hu) = if d.x > 0.0 { (Vec3::X, d.x) } else { (Vec3::Z, d.z) };
        self.mesh.add_rect(o, c, u * hu, Vec3::Y * d.y, normal);
    }
}

/// The room in world space (Y up), before the camera transform.
#[must_use]
fn world_mesh() -> Mesh {
    let mut b = Builder { mesh: Mesh::default(), palette: room_palette() };

    // Floor: 6 × 9 tiles of 2 m, checkered.
    for (j, z) in (-12..6).step_by(2).enumerate() {
        for (i, x) in (-6..6).step_by(2).enumerate() {
            let o = b.object("floor-tile", if (i + j) % 2 == 0 { TILE_LIGHT } else { TILE_DARK });
            let c = Vec3::new(x as f32 + 1.0, 0.0, z as f32 + 1.0);
            b.mesh.add_rect(o, c, Vec3::X, Vec3::Z, Vec3::Y);
        }
    }

    // Back wall with a window (x ∈ [−1, 3], y ∈ [1.2, 3.2]) at z = −12.
    let wall = b.object("back-wall", BRICK);
    let z = -12.0;
    for (a, c) in [
        (Vec3::new(-6.0, 0.0, z), Vec3::new(-1.0, 4.0, z)),
        (Vec3::new(3.0, 0.0, z), Vec3::new(6.0, 4.0, z)),
        (Vec3::new(-1.0, 0.0, z), Vec3::new(3.0, 1.2, z)),
        (Vec3::new(-1.0, 3.2, z), Vec3::new(3.0, 4.0, z)),
    ] {
        b.wall_rect(wall, a, c, Vec3::Z);
    }
    for (k, w) in [0.06, 0.02, 0.008].into_iter().enumerate() {
        let x = k as f32;
        b.cuboid("window-bar", STEEL, Vec3::new(x, 2.2, z + 0.05), Vec3::new(w * 0.5, 1.0, 0.02), 0.0);
    }
    let left = b.object("left-wall", PLASTER);
    b.wall_rect(left, Vec3::new(-6.0, 0.0, -12.0), Vec3::new(-6.0, 4.0, 6.0), Vec3::X);
    let right = b.object("right-wall", WHITE);
    b.wall_rect(right, Vec3::new(6.0, 0.0, -12.0), Vec3::new(6.0, 4.0, -5.0), Vec3::NEG_X);

    // Boxes.
    b.cuboid("crate", WOOD, Vec3::new(-3.0, 0.5, -4.0), Vec3::splat(0.5), 0.4);
    b.cuboid("stack-low", BLUE, Vec3::new(2.5, 0.4, -7.0), Vec3::new(0.8, 0.4, 0.6), -0.3);
    b.cuboid("stack-high", RED, Vec3::new(2.5, 1.05, -7.0), Vec3::splat(0.25), 0.7);
    b.cuboid("pillar", SOOT, Vec3::new(-4.5, 1.25, -9.0), Vec3::new(0.3, 1.25, 0.3), 0.0);

    // Fence: bars from 10 cm to 1.5 mm wide, under a 1 cm rail.
    for (k, w) in [0.1, 0.05, 0.025, 0.012, 0.006, 0.003, 0.0015].into_iter().enumerate() {
        let x = -1.5 + 0.5 * k as f32;
        b.cuboid("fence-bar", STEEL, Vec3::new(x, 1.1, -6.0), Vec3::new(w * 0.5, 1.1, w * 0.5), 0.0);
    }
    b.cuboid("fence-rail", COPPER, Vec3::new(0.0, 2.2, -6.0), Vec3::new(1.6, 0.005, 0.005), 0.0);

    // Spheres, coarse to fine.
    for (name, mat, c, r, seg) in [
        ("sphere-chrome", CHROME, Vec3::new(-2.8, 1.0, -7.5), 1.0, 48),
        ("sphere-gold", GOLD, Vec3::new(-3.0, 1.5, -4.0), 0.5, 32),
        ("sphere-rubber", GREEN, Vec3::new(1.0, 0.3, -2.0), 0.3, 12),
        ("sphere-copper", COPPER, Vec3::new(4.0, 0.6, -3.0), 0.6, 40),
    ] {
        let o = b.object(name, mat);
        b.mesh.add_sphere(o, c, r, seg, seg / 2);
    }
    let column = b.object("column", WHITE);
    b.mesh.add_cylinder(column, Vec3::new(4.0, 0.0, -10.0), 0.4, 4.0, 24);

    // Grazing: a thin panel nearly along the view direction, and a plank tilted 3° off the floor.
    b.cuboid("grazing-panel", WOOD, Vec3::new(1.5, 0.6, -2.5), Vec3::new(0.01, 0.6, 1.5), 0.0);
    let plank = b.object("tilted-plank", RED);
    b.mesh.add_box(
        plank,
        Mat4::from_scale_rotation_translation(
            Vec3::new(0.4, 0.02, 1.5),
            Quat::from_rotation_x(0.05),
            Vec3::new(-1.5, 0.1, -3.0),
        ),
    );
    b.mesh
}

/// The room in view space for an image of `width × height`.
#[must_use]
pub fn build(width: u32, height: u32) -> ViewScene {
    let camera = camera(width, height);
    let mut mesh = world_mesh();
    mesh.transform(camera.world_to_view);
    ViewScene { camera, mesh }
}
