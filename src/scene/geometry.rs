//! Scene geometry: objects made of triangles, and builders for the shapes the scenes use (quads, boxes,
//! tessellated spheres and cylinders).
//!
//! Everything is a triangle so the ray caster has one intersection routine and every surface has a primitive ID
//! (`SV_PrimitiveID`-style: the triangle's index within its object). Flat triangles store their exact normal, so
//! a quad built with normal `(0, 0, 1)` reports exactly that; smooth triangles (spheres, cylinder sides) store
//! vertex normals that the ray caster interpolates, so their triangle edges are not surface edges.

use super::material::Material;
use glam::{Mat3, Mat4, Vec3};

/// One object: a material and the IDs every sample that hits it carries.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Human-readable name ("sphere-large", "bar-0.01", ...).
    pub name: String,
    /// Object ID written into the `object_id` plane.
    pub object_id: u32,
    /// Material ID written into the `material_id` plane.
    pub material_id: u32,
    /// The material's values.
    pub material: Material,
}

/// One triangle with its shading normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertices.
    pub v: [Vec3; 3],
    /// Vertex normals (unit). For flat triangles all three are the face normal.
    pub n: [Vec3; 3],
    /// Interpolate `n` (true) or report `n[0]` exactly (false).
    pub smooth: bool,
    /// Index of the owning object in [`Mesh::objects`].
    pub object: u32,
    /// Primitive ID: index of the triangle within its object.
    pub prim: u32,
}

/// A triangle soup grouped into objects.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// The objects.
    pub objects: Vec<Object>,
    /// Every triangle of every object.
    pub triangles: Vec<Triangle>,
    /// Triangles per object so far (next primitive ID).
    prim_counts: Vec<u32>,
}

impl Mesh {
    /// Adds an object and returns its index (for the `add_*` builders).
    pub fn add_object(&mut self, name: impl Into<String>, object_id: u32, material_id: u32, material: Material) -> u32 {
        self.objects.push(Object { name: name.into(), object_id, material_id, material });
        self.prim_counts.push(0);
        (self.objects.len() - 1) as u32
    }

    /// Adds one triangle to object `obj`.
    fn add_triangle(&mut self, obj: u32, v: [Vec3; 3], n: [Vec3; 3], smooth: bool) {
        let prim = self.prim_counts[obj as usize];
        self.prim_counts[obj as usize] += 1;
        self.triangles.push(Triangle { v, n, smooth, object: obj, prim });
    }

    /// Adds a planar quad `a b c d` (in order around the edge) as two flat triangles with the given exact normal.
    fn add_quad(&mut self, obj: u32, [a, b, c, d]: [Vec3; 4], normal: Vec3) {
        self.add_triangle(obj, [a, b, c], [normal; 3], false);
        self.add_triangle(obj, [a, c, d], [normal; 3], false);
    }

    /// Adds a rectangle centred at `centre` with half-edge vectors `du` and `dv` (perpendicular), as two flat
    /// triangles with the exact normal `normal`.
    pub fn add_rect(&mut self, obj: u32, centre: Vec3, du: Vec3, dv: Vec3, normal: Vec3) {
        self.add_quad(obj, [centre - du - dv, centre + du - dv, centre + du + dv, centre - du + dv], normal);
    }

    /// Adds a box: the cube [−1, 1]³ mapped by `to_world` (any affine map; faces stay flat with exact normals
    /// from the inverse transpose).
    pub fn add_box(&mut self, obj: u32, to_world: Mat4) {
        let normal_m = Mat3::from_mat4(to_world).inverse().transpose();
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let mut n = Vec3::ZERO;
                n[axis] = sign;
                let (mut u, mut v) = (Vec3::ZERO, Vec3::ZERO);
                u[(axis + 1) % 3] = 1.0;
                v[(axis + 2) % 3] = 1.0;
                let corners = [n - u - v, n + u - v, n + u + v, n - u + v].map(|p| to_world.transform_point3(p));
                self.add_quad(obj, corners, (normal_m * n).normalize());
            }
        }
    }

    /// Adds a UV sphere of `segments` longitudes × `rings` latitudes with interpolated (exact radial) vertex
    /// normals.
    pub fn add_sphere(&mut self, obj: u32, centre: Vec3, radius: f32, segments: u32, rings: u32) {
        let (segments, rings) = (segments.max(3), rings.max(2));
        let dir = |i: u32, j: u32| {
            let phi = std::f32::consts::TAU * i as f32 / segments as f32;
            let theta = std::f32::consts::PI * j as f32 / rings as f32;
            Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
        };
        for j in 0..rings {
            for i in 0..segments {
                let (a, b, c, d) = (dir(i, j), dir(i + 1, j), dir(i + 1, j + 1), dir(i, j + 1));
                let p = |n: Vec3| centre + n * radius;
                if j != 0 {
                    self.add_triangle(obj, [p(a), p(b), p(c)], [a, b, c], true);
                }
                if j != rings - 1 {
                    self.add_triangle(obj, [p(a), p(c), p(d)], [a, c, d], true);
                }
            }
        }
    }

    /// Adds a vertical cylinder (axis +Y from `base`) with smooth sides and flat caps.
    pub fn add_cylinder(&mut self, obj: u32, base: Vec3, radius: f32, height: f32, segments: u32) {
        let segments = segments.max(3);
        let ring = |i: u32| {
            let phi = std::f32::consts::TAU * i as f32 / segments as f32;
            Vec3::new(phi.cos(), 0.0, phi.sin())
        };
        let up = Vec3::Y * height;
        for i in 0..segments {
            let (na, nb) = (ring(i), ring(i + 1));
            let (a, b) = (base + na * radius, base + nb * radius);
            self.add_triangle(obj, [a, b, b + up], [na, nb, nb], true);
            self.add_triangle(obj, [a, b + up, a + up], [na, nb, na], true);
            self.add_triangle(obj, [base + up, a + up, b + up], [Vec3::Y; 3], false);
            self.add_triangle(obj, [base, b, a], [Vec3::NEG_Y; 3], false);
        }
    }

    /// Applies a rigid transform (rotation + translation) to every vertex and normal. Normals are renormalised;
    /// flat normals that are exact before stay exact only if the rotation is the identity.
    pub fn transform(&mut self, m: Mat4) {
        let r = Mat3::from_mat4(m);
        for t in &mut self.triangles {
            t.v = t.v.map(|p| m.transform_point3(p));
            t.n = t.n.map(|n| (r * n).normalize());
        }
    }

    /// The geometric (face) normal of triangle `t`, unit, oriented like its stored normals.
    #[must_use]
    pub fn face_normal(t: &Triangle) -> Vec3 {
        let g = (t.v[1] - t.v[0]).cross(t.v[2] - t.v[0]).normalize_or_zero();
        if g.dot(t.n[0] + t.n[1] + t.n[2]) < 0.0 {
            -g
        } else {
            g
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::material::room_palette;

    #[test]
    fn box_has_twelve_outward_triangles() {
        let mut m = Mesh::default();
        let o = m.add_object("box", 1, 1, room_palette()[0]);
        m.add_box(o, Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Mat4::from_scale(Vec3::splat(0.5)));
        assert_eq!(m.triangles.len(), 12);
        for t in &m.triangles {
            let centre = (t.v[0] + t.v[1] + t.v[2]) / 3.0 - Vec3::new(1.0, 2.0, 3.0);
            assert!(t.n[0].dot(centre) > 0.0, "inward normal {:?}", t.n[0]);
            assert!(Mesh::face_normal(t).dot(t.n[0]) > 0.999);
        }
        assert_eq!(m.triangles.last().unwrap().prim, 11);
    }

    #[test]
    fn sphere_vertices_lie_on_the_sphere_with_radial_normals() {
        let mut m = Mesh::default();
        let o = m.add_object("s", 1, 1, room_palette()[0]);
        m.add_sphere(o, Vec3::new(0.0, 1.0, 0.0), 2.0, 8, 4);
        assert_eq!(m.triangles.len(), 8 * 4 * 2 - 2 * 8);
        for t in &m.triangles {
            for k in 0..3 {
                let r = t.v[k] - Vec3::new(0.0, 1.0, 0.0);
                assert!((r.length() - 2.0).abs() < 1e-5);
                assert!((r.normalize() - t.n[k]).length() < 1e-5);
            }
            assert!(Mesh::face_normal(t).dot(t.v[0] - Vec3::Y) > 0.0, "inward-wound triangle");
        }
    }
}
