//! A small analytic G-buffer built in code (ground plane + spheres under a pinhole camera, sky above the
//! horizon) and light scatterers, for the resolve's tests and benches. Deterministic for a given seed.
//!
//! Not a scene generator for users (that is [`crate::scene`]); it exists so the resolve can be tested and timed
//! without files. It builds on the data model (camera, G-buffer, lights), `scene::raycast`'s ray-plane and
//! ray-sphere tests and `base::rng::SplitMix64`, and [`lights_for_density`] runs `detect::baselines::none` and the
//! resolve itself; no reader, codec or layout is involved.

use crate::base::rng::SplitMix64;
use crate::camera::Camera;
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::light::Light;
use crate::scene::raycast::{ray_plane, ray_sphere};
use glam::Vec3;

/// One sphere of the fixture: centre (view space), radius, albedo, specular power, roughness, metallic.
type Ball = (Vec3, f32, Vec3, f32, f32, f32);

const BALLS: [Ball; 6] = [
    (Vec3::new(-2.5, 0.0, -8.0), 1.0, Vec3::new(0.9, 0.2, 0.2), 16.0, 0.4, 0.0),
    (Vec3::new(0.0, 0.5, -10.0), 1.5, Vec3::new(0.2, 0.8, 0.3), 64.0, 0.25, 1.0),
    (Vec3::new(2.8, -0.3, -7.0), 0.7, Vec3::new(0.3, 0.4, 0.9), 256.0, 0.1, 0.0),
    (Vec3::new(1.2, -0.6, -5.0), 0.4, Vec3::new(0.9, 0.9, 0.2), 4.0, 0.8, 0.0),
    (Vec3::new(-0.8, 2.2, -14.0), 2.0, Vec3::new(0.7, 0.7, 0.7), 1000.0, 0.05, 1.0),
    (Vec3::new(-4.0, 1.5, -18.0), 1.2, Vec3::new(0.5, 0.3, 0.8), 32.0, 0.5, 0.0),
];
const GROUND_Y: f32 = -1.0;
/// The ground plane ends at this distance (beyond it: sky).
const GROUND_EXTENT: f32 = 200.0;

/// Ground plane at `y = −1` and six spheres seen by a camera at the origin (60° vertical field of view), with
/// `samples` per pixel at the standard positions. Every attribute is filled (IDs: 0 = ground, 1.. = spheres).
pub fn spheres(width: u32, height: u32, samples: u32) -> Result<GBuffer> {
    build(width, height, samples, false)
}

/// [`spheres`] closed by a back wall at view depth [`WALL_DEPTH`] (object ID 7), so every sample is covered —
/// the benches' frame.
pub fn room(width: u32, height: u32, samples: u32) -> Result<GBuffer> {
    build(width, height, samples, true)
}

/// View depth of [`room`]'s back wall.
pub const WALL_DEPTH: f32 = 30.0;

fn build(width: u32, height: u32, samples: u32, wall: bool) -> Result<GBuffer> {
    let mut gb = GBuffer::new(width, height, samples)?;
    let aspect = width.max(1) as f32 / height.max(1) as f32;
    let cam = Camera::identity(60f32.to_radians(), aspect, 0.1, 1000.0);
    gb.camera = Some(cam);
    let n = gb.len();
    let mut depth = vec![0.0; n];
    let mut position = vec![Vec3::ZERO; n];
    let mut normal = vec![Vec3::ZERO; n];
    let mut albedo = vec![Vec3::ZERO; n];
    let mut specular = vec![0.0; n];
    let mut power = vec![0.0; n];
    let mut roughness = vec![0.0; n];
    let mut metallic = vec![0.0; n];
    let mut object = vec![0u32; n];
    for y in 0..height {
        for x in 0..width {
            for s in 0..samples {
                let i = gb.index(x, y, s);
                let ray = cam.view_ray(gb.sample_px(x, y, s), width, height);
                let hit = match intersect(ray) {
                    Some(h) if !wall || h.0 < WALL_DEPTH => Some(h),
                    _ if wall => Some((WALL_DEPTH, BALLS.len() as u32 + 1)),
                    _ => None,
                };
                let Some((t, id)) = hit else { continue };
                let p = ray * t;
                let (n_, a, pw, r, m) = if id as usize == BALLS.len() + 1 {
                    (Vec3::Z, Vec3::splat(0.6), 16.0, 0.6, 0.0)
                } else if id == 0 {
                    let check = ((p.x.floor() + p.z.floor()) as i32 & 1) as f32;
                    (Vec3::Y, Vec3::splat(0.35 + 0.4 * check), 8.0, 0.7, 0.0)
                } else {
                    let (c, _, a, pw, r, m) = BALLS[id as usize - 1];
                    ((p - c).normalize(), a, pw, r, m)
                };
                gb.coverage[i] = true;
                depth[i] = -p.z;
                position[i] = p;
                normal[i] = n_;
                albedo[i] = a;
                specular[i] = 0.5;
                power[i] = pw;
                roughness[i] = r;
                metallic[i] = m;
                object[i] = id;
            }
        }
    }
    gb.depth = Some(depth);
    gb.position = Some(position);
    gb.normal = Some(normal);
    gb.albedo = Some(albedo);
    gb.specular = Some(specular);
    gb.specular_power = Some(power);
    gb.roughness = Some(roughness);
    gb.metallic = Some(metallic);
    gb.material_id = Some(object.clone());
    gb.object_id = Some(object);
    Ok(gb)
}

/// Nearest hit along `ray` (ray = direction with z = −1, point = ray · t, t = view depth): (t, object id).
fn intersect(ray: Vec3) -> Option<(f32, u32)> {
    let mut best =
        ray_plane(ray, Vec3::Y, Vec3::new(0.0, GROUND_Y, 0.0)).filter(|&t| t < GROUND_EXTENT).map(|t| (t, 0));
    for (k, &(c, r, ..)) in BALLS.iter().enumerate() {
        if let Some(t) = ray_sphere(ray, c, r) {
            if best.is_none_or(|(bt, _)| t < bt) {
                best = Some((t, k as u32 + 1));
            }
        }
    }
    best
}

/// `n` point lights hovering just above random covered samples of `gb` (offset along the normal), with the
/// given `range`, `begin = range / 4` and random colours. Deterministic for `seed`; empty when nothing is covered.
#[must_use]
pub fn lights_on_surfaces(gb: &GBuffer, n: usize, range: f32, seed: u64) -> Vec<Light> {
    let covered: Vec<usize> = (0..gb.len()).filter(|&i| gb.coverage[i]).collect();
    let (Some(pos), false) = (&gb.position, covered.is_empty()) else { return Vec::new() };
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            let i = covered[(rng.next_u64() % covered.len() as u64) as usize];
            let nrm = gb.normal.as_ref().map_or(Vec3::Z, |v| v[i]);
            let p = pos[i] + nrm * rng.range_f32(0.05, 0.3) * range;
            let color = Vec3::new(rng.range_f32(0.2, 1.0), rng.range_f32(0.2, 1.0), rng.range_f32(0.2, 1.0));
            let mut l = Light::point(p, color, 1.0, range);
            l.begin = 0.25 * range;
            l
        })
        .collect()
}

/// [`lights_on_surfaces`] with the range chosen so that tile culling leaves about `per_sample` lights per
/// shaded sample of `gb` (one sample per pixel): a bisection on the range, measured with the resolve itself on a
/// quarter-size copy of the frame (4-pixel tiles, so the tile frusta match the full frame's 16-pixel ones).
///
/// # Errors
/// When the quarter-size frame cannot be built or resolved.
pub fn lights_for_density(width: u32, height: u32, n: usize, per_sample: f64, seed: u64) -> Result<Vec<Light>> {
    use super::{resolve, ResolveConfig};
    let small = room((width / 4).max(1), (height / 4).max(1), 1)?;
    let mask = crate::detect::baselines::none(&small);
    let cfg = ResolveConfig { tile_size: 4, ..Default::default() };
    let (mut lo, mut hi) = (0.05f32, 8.0f32);
    for _ in 0..18 {
        let mid = (lo * hi).sqrt();
        let lights = lights_on_surfaces(&small, n, mid, seed);
        if resolve(&small, &lights, &mask, &cfg)?.stats.lights_per_sample < per_sample {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(lights_on_surfaces(&room(width, height, 1)?, n, (lo * hi).sqrt(), seed))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixture_has_sky_ground_and_spheres() {
        let gb = spheres(64, 36, 4).unwrap();
        gb.validate().unwrap();
        let ids = gb.object_id.as_ref().unwrap();
        let covered = gb.coverage.iter().filter(|&&c| c).count();
        assert!(covered > gb.len() / 3 && covered < gb.len(), "{covered} of {}", gb.len());
        for id in 0..=BALLS.len() as u32 {
            assert!(ids.iter().zip(&gb.coverage).any(|(&i, &c)| c && i == id), "object {id} not visible");
        }
        let room = room(64, 36, 4).unwrap();
        assert!(room.coverage.iter().all(|&c| c));
        let lights = lights_on_surfaces(&gb, 10, 2.0, 1);
        assert_eq!(lights.len(), 10);
        assert!(lights.iter().all(|l| l.position.is_finite() && l.position.z < 0.0));
    }
}
