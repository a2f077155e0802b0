//! Light preparation: sanitise the caller's lights once, then lay them out as structure-of-arrays constants the
//! batched kernel reads (one uniform representation for point, spot and directional lights, so the inner loop has
//! no branch on the light kind).
//!
//! Uniform representation: the unnormalised light vector is `L = pos − w · p` (`w = 1` for positional lights;
//! `w = 0` and `pos = −direction` for directional ones, so `|L| = 1` and every falloff evaluates to 1); the cone
//! factor is `clamp(dot(axis, −L̂) · scale + offset, 0, 1)²` with `scale = 0, offset = 1` for non-spot lights.

use super::config::Falloff;
use super::falloff::{cone_constants, MIN_RAMP_FRACTION};
use crate::light::{Light, LightKind};
use glam::Vec3;

/// Lights made safe for shading, plus how many were dropped.
#[derive(Clone, Debug, Default)]
pub struct CleanLights {
    /// The usable lights (directions normalised, cones and begin radius clamped).
    pub lights: Vec<Light>,
    /// Lights dropped because a field was NaN/Inf/negative, a range was ≤ 0, or a direction was zero.
    pub dropped: u64,
}

/// Sanitises `lights`: drops lights that cannot contribute or hold non-finite values, normalises directions,
/// clamps `begin` into `[0, range]` and spot cones into `0 ≤ inner ≤ outer ≤ π/2`.
#[must_use]
pub fn sanitize(lights: &[Light]) -> CleanLights {
    let mut out = CleanLights { lights: Vec::with_capacity(lights.len()), dropped: 0 };
    for l in lights {
        match sanitize_one(l) {
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
    if !l.is_directional() && !l.position.is_finite() {
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
    }
    Some(l)
}

/// Structure-of-arrays light constants for the kernel (one entry per light, same order as the input).
#[derive(Clone, Debug, Default)]
pub struct LightSoa {
    /// `pos.x` (position, or −direction for directional lights).
    pub px: Vec<f32>,
    /// `pos.y`.
    pub py: Vec<f32>,
    /// `pos.z`.
    pub pz: Vec<f32>,
    /// 1 for positional lights, 0 for directional.
    pub w: Vec<f32>,
    /// colour.r × intensity.
    pub cr: Vec<f32>,
    /// colour.g × intensity.
    pub cg: Vec<f32>,
    /// colour.b × intensity.
    pub cb: Vec<f32>,
    /// Luminance of the scaled colour (light pre-pass specular).
    pub lum: Vec<f32>,
    /// Falloff constant a: linear `end / width` (1 when unbounded); gltf `1 / range⁴` (0 when unbounded).
    pub fa: Vec<f32>,
    /// Falloff constant b: linear `1 / width` (0 when unbounded); unused by gltf.
    pub fb: Vec<f32>,
    /// Spot axis x.
    pub sx: Vec<f32>,
    /// Spot axis y.
    pub sy: Vec<f32>,
    /// Spot axis z.
    pub sz: Vec<f32>,
    /// Cone scale (0 for non-spot lights).
    pub cs: Vec<f32>,
    /// Cone offset (1 for non-spot lights).
    pub co: Vec<f32>,
}

/// Rec. 709 luminance weights, used to make the light pre-pass specular monochromatic.
pub const LUMA: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

impl LightSoa {
    /// Lays out already-sanitised lights for `falloff`.
    #[must_use]
    pub fn new(lights: &[Light], falloff: Falloff) -> Self {
        let mut s = LightSoa::default();
        for l in lights {
            s.push(l, falloff);
        }
        s
    }

    /// Number of lights.
    #[must_use]
    pub fn len(&self) -> usize {
        self.px.len()
    }

    /// True when there are no lights.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.px.is_empty()
    }

    /// Appends light `i` of `other` (used to gather a tile's light list contiguously).
    pub fn push_from(&mut self, other: &LightSoa, i: usize) {
        self.px.push(other.px[i]);
        self.py.push(other.py[i]);
        self.pz.push(other.pz[i]);
        self.w.push(other.w[i]);
        self.cr.push(other.cr[i]);
        self.cg.push(other.cg[i]);
        self.cb.push(other.cb[i]);
        self.lum.push(other.lum[i]);
        self.fa.push(other.fa[i]);
        self.fb.push(other.fb[i]);
        self.sx.push(other.sx[i]);
        self.sy.push(other.sy[i]);
        self.sz.push(other.sz[i]);
        self.cs.push(other.cs[i]);
        self.co.push(other.co[i]);
    }

    /// Empties the arrays, keeping their capacity.
    pub fn clear(&mut self) {
        for v in [
            &mut self.px,
            &mut self.py,
            &mut self.pz,
            &mut self.w,
            &mut self.cr,
            &mut self.cg,
            &mut self.cb,
            &mut self.lum,
            &mut self.fa,
            &mut self.fb,
            &mut self.sx,
            &mut self.sy,
            &mut self.sz,
            &mut self.cs,
            &mut self.co,
        ] {
            v.clear();
        }
    }

    fn push(&mut self, l: &Light, falloff: Falloff) {
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
        self.px.push(pos.x);
        self.py.push(pos.y);
        self.pz.push(pos.z);
        self.w.push(w);
        self.cr.push(c.x);
        self.cg.push(c.y);
        self.cb.push(c.z);
        self.lum.push(c.dot(LUMA));
        self.fa.push(fa);
        self.fb.push(fb);
        self.sx.push(axis.x);
        self.sy.push(axis.y);
        self.sz.push(axis.z);
        self.cs.push(cs);
        self.co.push(co);
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
        let s = LightSoa::new(&c.lights, Falloff::Linear);
        assert_eq!((s.px[0], s.py[0], s.pz[0], s.w[0]), (0.0, 1.0, 0.0, 0.0));
        assert_eq!((s.fa[0], s.fb[0]), (1.0, 0.0));
        assert_eq!((s.cs[0], s.co[0]), (0.0, 1.0));
        assert_eq!(s.cr[0], 3.0);
    }
}
