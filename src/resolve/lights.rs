//! Light preparation: sanitise the caller's lights once, then lay them out as one cache-line record of constants
//! per light for the batched kernel (one uniform representation for point, spot and directional lights, so the inner loop has
//! no branch on the light kind).
//!
//! Uniform representation: the unnormalised light vector is `L = pos − w · p` (`w = 1` for positional lights;
//! `w = 0` and `pos = −direction` for directional ones, so `|L| = 1` and every falloff evaluates to 1); the cone
//! factor is `clamp(dot(axis, −L̂) · scale + offset, 0, 1)²` with `scale = 0, offset = 1` for non-spot lights.

use super::config::Falloff;
use super::culling::light_sphere;
use super::falloff::{cone_constants, MIN_RAMP_FRACTION};
use crate::light::{Light, LightKind};
use glam::Vec3;

/// A sanitised hemisphere environment ([`LightKind::Hemisphere`]): unit `up`, sky and ground radiance with the
/// intensity folded in. Shaded per sample after the light loop (`kernel::add_environment` in f32,
/// `reference::environment` in f64), never culled: it reaches every sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hemisphere {
    /// Unit up direction, view space.
    pub up: Vec3,
    /// Sky radiance (colour × intensity).
    pub sky: Vec3,
    /// Ground radiance (ground colour × intensity).
    pub ground: Vec3,
}

/// Lights made safe for shading, plus how many were dropped.
#[derive(Clone, Debug, Default)]
pub struct CleanLights {
    /// The usable punctual lights (directions normalised, cones and begin radius clamped): the light loop's.
    pub lights: Vec<Light>,
    /// The usable hemisphere environments, in input order.
    pub environment: Vec<Hemisphere>,
    /// Lights dropped because a field was NaN/Inf/negative, a range was ≤ 0, or a direction was zero.
    pub dropped: u64,
}

/// Sanitises `lights`: drops lights that cannot contribute or hold non-finite values, normalises directions,
/// clamps `begin` into `[0, range]` and spot cones into `0 ≤ inner ≤ outer ≤ π/2`.
#[must_use]
pub fn sanitize(lights: &[Light]) -> CleanLights {
    let mut out = CleanLights { lights: Vec::with_capacity(lights.len()), ..Default::default() };
    for l in lights {
        match sanitize_one(l) {
            Some(Light { kind: LightKind::Hemisphere { up, ground }, color, intensity, .. }) => {
                out.environment.push(Hemisphere { up, sky: color * intensity, ground: ground * intensity });
            }
            Some(l) => out.lights.push(l),
            None => out.dropped += 1,
        }
    }
    out
}

fn sanitize_one(l: &Light) -> Option<Light> {
    let mut l = *l;
    let colour_ok = l.color.is_finite() && l.color.min_element() >= 0.0;
    if !colour_ok || !l.intensity.is_finite() || l.intensity < 0.0 || l.range.is_nan() || l.range <= 0.0 {
        return None;
    }
    if !l.is_directional() && !l.is_environment() && !l.position.is_finite() {
        return None;
    }
    l.begin = if l.begin.is_finite() { l.begin.clamp(0.0, l.range) } else { 0.0 };
    match &mut l.kind {
        LightKind::Point => {}
        LightKind::Spot { direction, inner_cone_angle, outer_cone_angle } => {
            *direction = direction.try_normalize()?;
            let half_pi = std::f32::consts::FRAC_PI_2;
            let outer = if outer_cone_angle.is_finite() { outer_cone_angle.clamp(0.0, half_pi) } else { half_pi };
            let inner = if inner_cone_angle.is_finite() { inner_cone_angle.clamp(0.0, outer) } else { 0.0 };
            (*inner_cone_angle, *outer_cone_angle) = (inner, outer);
        }
        LightKind::Directional { direction } => {
            *direction = direction.try_normalize()?;
            l.range = f32::INFINITY;
            l.position = Vec3::ZERO;
        }
        LightKind::Hemisphere { up, ground } => {
            *up = up.try_normalize()?;
            if !ground.is_finite() || ground.min_element() < 0.0 {
                return None;
            }
            l.range = f32::INFINITY;
            l.position = Vec3::ZERO;
        }
    }
    Some(l)
}

/// One light's kernel constants, in one 64-byte cache line (the kernel broadcasts them into vectors).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct LightRec {
    /// `pos.x` (position, or −direction for directional lights).
    pub px: f32,
    /// `pos.y`.
    pub py: f32,
    /// `pos.z`.
    pub pz: f32,
    /// 1 for positional lights, 0 for directional.
    pub w: f32,
    /// colour.r × intensity.
    pub cr: f32,
    /// colour.g × intensity.
    pub cg: f32,
    /// colour.b × intensity.
    pub cb: f32,
    /// Luminance of the scaled colour (light pre-pass specular).
    pub lum: f32,
    /// Falloff constant a: linear `end / width` (1 when unbounded); gltf `1 / range⁴` (0 when unbounded).
    pub fa: f32,
    /// Falloff constant b: linear `1 / width` (0 when unbounded); unused by gltf.
    pub fb: f32,
    /// Spot axis x.
    pub sx: f32,
    /// Spot axis y.
    pub sy: f32,
    /// Spot axis z.
    pub sz: f32,
    /// Cone scale (0 for non-spot lights: the kernel then skips the cone).
    pub cs: f32,
    /// Cone offset (1 for non-spot lights).
    pub co: f32,
    /// Squared radius of the culling sphere around `pos` (∞ for directional and unbounded lights): beyond it
    /// the light adds exactly 0.
    pub r2: f32,
}

/// The one light list of a resolve: one [`LightRec`] per light, same order as the input, and the culling
/// spheres as structure of arrays — read by the tile culling (centre and radius, 16 lights at a time against a
/// tile's bounds) and by the kernel (centre and squared radius against a vector of samples' bounding box).
///
/// The centre is the uniform light vector's `pos` (−direction for directional lights, whose radius is ∞: any
/// finite centre passes every test, so the culling result is the same as with the light's position).
#[derive(Clone, Debug, Default)]
pub struct LightTable {
    /// The records.
    pub rec: Vec<LightRec>,
    /// `rec[i].px`.
    pub x: Vec<f32>,
    /// `rec[i].py`.
    pub y: Vec<f32>,
    /// `rec[i].pz`.
    pub z: Vec<f32>,
    /// Radius of the culling sphere ([`light_sphere`]; `rec[i].r2` is its square).
    pub r: Vec<f32>,
    /// `rec[i].r2`.
    pub r2: Vec<f32>,
    /// Some light is a spot light (the kernel then evaluates the cone factor for every light of the list: exactly 1
    /// for the others; without spot lights it never does, and the light loop has no branch on the light kind).
    pub any_spot: bool,
}

/// Rec. 709 luminance weights, used to make the light pre-pass specular monochromatic.
pub const LUMA: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

impl LightTable {
    /// Lays out already-sanitised lights for `falloff`.
    #[must_use]
    pub fn new(lights: &[Light], falloff: Falloff) -> Self {
        let mut t = LightTable::default();
        for l in lights {
            t.push(LightRec::new(l, falloff), light_sphere(l).1);
        }
        t
    }

    /// Number of lights.
    #[must_use]
    pub fn len(&self) -> usize {
        self.rec.len()
    }

    /// True when there are no lights.
    #[allow(dead_code)] // the pair of `len` (clippy: len_without_is_empty)
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.rec.is_empty()
    }

    /// Appends light `i` of `other` (used to gather a tile's light list contiguously).
    pub fn push_from(&mut self, other: &LightTable, i: usize) {
        self.push(other.rec[i], other.r[i]);
    }

    /// Appends a record and its culling radius (`radius² == rec.r2`).
    pub fn push(&mut self, rec: LightRec, radius: f32) {
        debug_assert_eq!((radius * radius).to_bits(), rec.r2.to_bits());
        self.rec.push(rec);
        self.x.push(rec.px);
        self.y.push(rec.py);
        self.z.push(rec.pz);
        self.r.push(radius);
        self.r2.push(rec.r2);
        self.any_spot |= rec.cs != 0.0;
    }

    /// Empties the list, keeping its capacity.
    pub fn clear(&mut self) {
        self.rec.clear();
        for v in [&mut self.x, &mut self.y, &mut self.z, &mut self.r, &mut self.r2] {
            v.clear();
        }
        self.any_spot = false;
    }
}

impl LightRec {
    /// The constants of an already-sanitised light for `falloff`.
    #[must_use]
    pub fn new(l: &Light, falloff: Falloff) -> Self {
        let (pos, w) = match l.kind {
            LightKind::Directional { direction } => (-direction, 0.0),
            _ => (l.position, 1.0),
        };
        let c = l.color * l.intensity;
        let (fa, fb) = match falloff {
            Falloff::Gltf if l.range.is_finite() => (1.0 / l.range.powi(4), 0.0),
            Falloff::Gltf => (0.0, 0.0),
            Falloff::Linear if l.range.is_finite() => {
                let width = (l.range - l.begin).max(l.range * MIN_RAMP_FRACTION);
                (l.range / width, 1.0 / width)
            }
            Falloff::Linear => (1.0, 0.0),
        };
        let (axis, cs, co) = match l.kind {
            LightKind::Spot { direction, inner_cone_angle, outer_cone_angle } => {
                let (cs, co) = cone_constants(inner_cone_angle, outer_cone_angle);
                (direction, cs, co)
            }
            _ => (Vec3::ZERO, 0.0, 1.0),
        };
        LightRec {
            px: pos.x,
            py: pos.y,
            pz: pos.z,
            w,
            cr: c.x,
            cg: c.y,
            cb: c.z,
            lum: c.dot(LUMA),
            fa,
            fb,
            sx: axis.x,
            sy: axis.y,
            sz: axis.z,
            cs,
            co,
            r2: {
                let r = light_sphere(l).1;
                r * r
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sanitize_drops_broken_lights_and_clamps_the_rest() {
        let good = Light::point(Vec3::new(0.0, 0.0, -3.0), Vec3::ONE, 2.0, 5.0);
        let mut nan = good;
        nan.position.x = f32::NAN;
        let mut zero_range = good;
        zero_range.range = 0.0;
        let mut neg = good;
        neg.intensity = -1.0;
        let dir0 = Light { kind: LightKind::Directional { direction: Vec3::ZERO }, ..good };
        let mut begin_big = good;
        begin_big.begin = 99.0;
        let c = sanitize(&[good, nan, zero_range, neg, dir0, begin_big]);
        assert_eq!(c.dropped, 4);
        assert_eq!(c.lights.len(), 2);
        assert_eq!(c.lights[1].begin, 5.0);
    }

    #[test]
    fn soa_uses_the_uniform_representation() {
        let d = Light {
            kind: LightKind::Directional { direction: Vec3::new(0.0, -2.0, 0.0) },
            ..Light::point(Vec3::ZERO, Vec3::ONE, 3.0, 1.0)
        };
        let c = sanitize(&[d]);
        let s = &LightTable::new(&c.lights, Falloff::Linear).rec[0];
        assert_eq!((s.px, s.py, s.pz, s.w), (0.0, 1.0, 0.0, 0.0));
        assert_eq!((s.fa, s.fb), (1.0, 0.0));
        assert_eq!((s.cs, s.co), (0.0, 1.0));
        assert_eq!(s.cr, 3.0);
        assert_eq!(std::mem::size_of::<LightRec>(), 64);
    }
}
