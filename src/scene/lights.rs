//! Lights for the analytic scenes, and lights scattered in the visible volume of any G-buffer.
//!
//! All lights are in view space (see [`crate::light`]). Point lights get `intensity = (range / 2)²`, so under
//! glTF's inverse-square falloff each one gives illuminance 1 at half its range, and `begin = range / 10` for the
//! linear falloff of the 2010 tiled-deferred demo.

use super::SceneName;
use crate::base::rng::SplitMix64;
use crate::camera::Camera;
use crate::gbuffer::GBuffer;
use crate::io::sidecar::{Sidecar, SidecarCamera, SidecarLight};
use crate::light::{Light, LightKind};
use glam::Vec3;

/// How many lights, on average, should reach a point of the visible volume when scattering: enough that tiles
/// see several lights and light culling matters, few enough that each light's range is local.
pub const SCATTER_OVERLAP: f32 = 4.0;
/// The most lights [`scatter_lights`] returns (a request for more is clamped: 16 M lights is already ~0.7 GB).
pub const MAX_SCATTERED_LIGHTS: usize = 1 << 24;
/// Seed of the scattered part of [`default_lights`] where a scene uses one.
const DEFAULT_SEED: u64 = 0x5CE9E;

/// A point light whose intensity and begin radius follow from its range (see the module doc).
fn point(position: Vec3, color: Vec3, range: f32) -> Light {
    Light { begin: 0.1 * range, ..Light::point(position, color, 0.25 * range * range, range) }
}

fn directional(direction: Vec3, color: Vec3, intensity: f32) -> Light {
    Light {
        kind: LightKind::Directional { direction },
        position: Vec3::ZERO,
        color,
        intensity,
        range: f32::INFINITY,
        begin: 0.0,
    }
}

/// A saturated colour from a hue in [0, 1).
fn hue(h: f32) -> Vec3 {
    let f = |o: f32| {
        let k = (h * 6.0 + o) % 6.0;
        1.0 - 0.6 * (k.min(4.0 - k).clamp(0.0, 1.0))
    };
    Vec3::new(f(5.0), f(3.0), f(1.0))
}

/// A deterministic light set for `name`, in view space, for the G-buffer `gb` that [`super::render`] made.
///
/// `room`: 24 point lights on a 4 × 6 grid through the room (range 4 m, alternating heights, a fixed palette of
/// warm and cool tints) plus a warm sun shining in through the window. `stress`: 16 lights scattered with a fixed
/// seed plus a directional light travelling exactly along −Z (head-on to the `facing-*` patches).
/// Without a camera in `gb`, the room's grid cannot be placed and scattered lights stand in for it.
#[must_use]
pub fn default_lights(name: SceneName, gb: &GBuffer) -> Vec<Light> {
    match (name, gb.camera.filter(Camera::is_valid)) {
        (SceneName::Room, Some(cam)) => {
            let mut out = Vec::with_capacity(25);
            for j in 0..6 {
                for i in 0..4 {
                    let world = Vec3::new(
                        -4.5 + 3.0 * i as f32,
                        if (i + j) % 2 == 0 { 0.8 } else { 2.6 },
                        -11.0 + 3.0 * j as f32,
                    );
                    let color = hue(((i * 6 + j) as f32 * 0.382).fract());
                    out.push(point(cam.to_view_point(world), color, 4.0));
                }
            }
            out.push(directional(cam.to_view_dir(Vec3::new(0.2, -0.6, 1.0)), Vec3::new(1.0, 0.95, 0.85), 2.0));
            out
        }
        (SceneName::Room, None) => {
            let mut out = scatter_lights(gb, 24, DEFAULT_SEED);
            out.push(directional(Vec3::new(0.3, -0.7, -0.6).normalize(), Vec3::new(1.0, 0.95, 0.85), 2.0));
            out
        }
        (SceneName::Stress, _) => {
            let mut out = scatter_lights(gb, 16, DEFAULT_SEED);
            out.push(directional(Vec3::NEG_Z, Vec3::ONE, 1.0));
            out
        }
    }
}

/// The depth range covered by `gb`'s surfaces (finite, positive depths only; from the position plane when the
/// depth plane is absent), if any.
fn covered_depth_range(gb: &GBuffer) -> Option<(f32, f32)> {
    let depths: Box<dyn Iterator<Item = f32> + '_> = match (&gb.depth, &gb.position) {
        (Some(d), _) => Box::new(d.iter().copied()),
        (None, Some(p)) => Box::new(p.iter().map(|p| -p.z)),
        (None, None) => return None,
    };
    let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
    for (d, &c) in depths.zip(&gb.coverage) {
        if c && d.is_finite() && d > 0.0 {
            lo = lo.min(d);
            hi = hi.max(d);
        }
    }
    (hi > 0.0).then_some((lo, hi))
}

/// The bounding box of `gb`'s covered view-space positions, if any.
fn covered_box(gb: &GBuffer) -> Option<(Vec3, Vec3)> {
    let pos = gb.position.as_ref()?;
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for (&p, &c) in pos.iter().zip(&gb.coverage) {
        if c && p.is_finite() {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (lo.x <= hi.x).then_some((lo, hi))
}

/// Where a frame's lights came from ([`choose_lights`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightsSource {
    /// The dump's own lights or its sidecar's.
    Dump,
    /// `n` point lights scattered with `seed` ([`scatter_lights`]).
    Scattered {
        /// How many.
        n: usize,
        /// The seed.
        seed: u64,
    },
}

impl std::fmt::Display for LightsSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LightsSource::Dump => f.write_str("from the dump/sidecar"),
            LightsSource::Scattered { n, seed } => write!(f, "{n} scattered, seed {seed}"),
        }
    }
}

/// The lights of a frame, by the one rule every command follows: lights asked for explicitly (`scatter`: `--lights
/// N`) are scattered with `seed` and replace the dump's; otherwise the dump's or sidecar's lights (`from_dump`, when
/// not empty); otherwise `fallback` lights scattered (the commands that always light something), or `None` when
/// there is no fallback (the caller says how to get lights).
#[must_use]
pub fn choose_lights(
    gb: &GBuffer,
    from_dump: Option<&[Light]>,
    scatter: Option<usize>,
    fallback: Option<usize>,
    seed: u64,
) -> Option<(Vec<Light>, LightsSource)> {
    let scattered = |n: usize| (scatter_lights(gb, n, seed), LightsSource::Scattered { n, seed });
    match (scatter, from_dump.filter(|l| !l.is_empty())) {
        (Some(n), _) => Some(scattered(n)),
        (None, Some(l)) => Some((l.to_vec(), LightsSource::Dump)),
        (None, None) => fallback.map(scattered),
    }
}

/// `n` point lights scattered deterministically (per `seed`) in the visible volume of `gb`, in view space.
///
/// With a usable camera the volume is the view frustum between the nearest and farthest covered depth (or
/// between znear and min(zfar, 100 · znear) when nothing is covered), sampled uniformly by volume. Without a camera
/// it is the bounding box of the covered positions, or the unit box centred at (0, 0, −1). Ranges are chosen so
/// that on average [`SCATTER_OVERLAP`] lights reach each point; colours are saturated hues. `n` is clamped to
/// [`MAX_SCATTERED_LIGHTS`]. Never panics, whatever `gb` holds.
#[must_use]
pub fn scatter_lights(gb: &GBuffer, n: usize, seed: u64) -> Vec<Light> {
    let n = n.min(MAX_SCATTERED_LIGHTS);
    if n == 0 {
        return Vec::new();
    }
    let mut rng = SplitMix64::new(seed);
    let sample: Box<dyn FnMut(&mut SplitMix64) -> Vec3>;
    let (volume, extent);
    if let Some(cam) = gb.camera.filter(Camera::is_valid) {
        let (lo, hi) = match covered_depth_range(gb) {
            Some((lo, hi)) => (lo.max(cam.znear), hi.min(cam.zfar)),
            None => (cam.znear, cam.zfar.min(100.0 * cam.znear)),
        };
        let (lo, hi) = if hi > lo { (lo, hi) } else { (lo, lo * 1.01 + 1e-6) };
        let (tx, ty) = (cam.tan_half_fov() * cam.aspect, cam.tan_half_fov());
        volume = 4.0 * tx * ty * (hi.powi(3) - lo.powi(3)) / 3.0;
        extent = hi;
        let (lo3, hi3) = (lo.powi(3), hi.powi(3));
        sample = Box::new(move |r: &mut SplitMix64| {
            let d = (lo3 + r.next_f32() * (hi3 - lo3)).cbrt().clamp(lo, hi);
            Vec3::new(r.range_f32(-1.0, 1.0) * tx * d, r.range_f32(-1.0, 1.0) * ty * d, -d)
        });
    } else {
        let (lo, hi) = covered_box(gb).unwrap_or((Vec3::new(-0.5, -0.5, -1.5), Vec3::new(0.5, 0.5, -0.5)));
        let size = (hi - lo).max(Vec3::splat(1e-3 * (hi - lo).max_element().max(1e-3)));
        volume = size.x * size.y * size.z;
        extent = size.length();
        sample = Box::new(move |r: &mut SplitMix64| lo + Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * size);
    }
    let range = (3.0 * SCATTER_OVERLAP * volume / (4.0 * std::f32::consts::PI * n as f32)).cbrt();
    let range = if range.is_finite() && range > 0.0 { range.clamp(1e-6 * extent, extent) } else { 1.0 };
    let mut sample = sample;
    (0..n)
        .map(|_| {
            let p = sample(&mut rng);
            let color = hue(rng.next_f32());
            point(p, color, range * rng.range_f32(0.75, 1.25))
        })
        .collect()
}

/// One light as a sidecar entry (KHR_lights_punctual fields; an unbounded range and a zero begin are omitted).
#[must_use]
pub fn sidecar_light(l: &Light) -> SidecarLight {
    let (kind, position, direction, cones) = match l.kind {
        LightKind::Point => ("point", Some(l.position), None, None),
        LightKind::Spot { direction, inner_cone_angle, outer_cone_angle } => {
            ("spot", Some(l.position), Some(direction), Some((inner_cone_angle, outer_cone_angle)))
        }
        LightKind::Directional { direction } => ("directional", None, Some(direction), None),
        LightKind::Hemisphere { up, .. } => ("hemisphere", None, Some(up), None),
    };
    let ground = match l.kind {
        LightKind::Hemisphere { ground, .. } => Some(ground.to_array()),
        _ => None,
    };
    SidecarLight {
        kind: kind.into(),
        position: position.map(|v: Vec3| v.to_array()),
        direction: direction.map(|v: Vec3| v.to_array()),
        color: l.color.to_array(),
        intensity: l.intensity,
        range: l.range.is_finite().then_some(l.range),
        begin: (l.begin > 0.0).then_some(l.begin),
        inner_cone_angle: cones.map(|c| c.0),
        outer_cone_angle: cones.map(|c| c.1),
        ground,
    }
}

/// The sidecar for a rendered scene: `gb`'s camera and `lights` (view space, so `lights_space` is "view").
#[must_use]
pub fn scene_sidecar(gb: &GBuffer, lights: &[Light]) -> Sidecar {
    Sidecar {
        camera: gb.camera.as_ref().map(SidecarCamera::from_camera),
        supersample: None,
        lights: lights.iter().map(sidecar_light).collect(),
        lights_space: Some("view".into()),
        materials: gb.materials.clone(),
        sample_positions: None,
    }
}
