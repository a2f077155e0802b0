//! The data the resolve's stages pass each other, apart from the math that fills and reads it: a [`Surface`] (one
//! sample ready to shade), the packed work list [`Items`] (structure of arrays, padded to whole vectors) and the
//! lights' screen rectangles [`QuadSoa`]. `surface` fills work lists, `culling` bounds them, `kernel` shades them;
//! keeping the types here lets those files import this one instead of each other.

use super::simd::BLOCK;
use glam::Vec3;

/// One sample, ready to shade: every field finite, normal unit length, depth > `surface::MIN_VIEW_DEPTH`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// View-space position.
    pub p: Vec3,
    /// Unit view-space normal.
    pub n: Vec3,
    /// Linear albedo, components ≥ 0.
    pub albedo: Vec3,
    /// Specular amount ≥ 0.
    pub specular: f32,
    /// Specular power in [0, `surface::MAX_SPECULAR_POWER`].
    pub power: f32,
    /// Perceptual roughness in [0, 1].
    pub roughness: f32,
    /// Metallic in [0, 1].
    pub metallic: f32,
}

/// `pixel` of padding items.
pub const PAD_PIXEL: u32 = u32::MAX;

/// Per-light screen rectangle (tangent units x/d, y/d) and depth bounds for quad culling.
#[derive(Clone, Debug, Default)]
pub struct QuadSoa {
    /// Rectangle left.
    pub x0: Vec<f32>,
    /// Rectangle right.
    pub x1: Vec<f32>,
    /// Rectangle bottom.
    pub y0: Vec<f32>,
    /// Rectangle top.
    pub y1: Vec<f32>,
    /// Nearest depth.
    pub z0: Vec<f32>,
    /// Farthest depth.
    pub z1: Vec<f32>,
}

impl QuadSoa {
    /// Appends light `i` of `o`.
    pub fn push_from(&mut self, o: &QuadSoa, i: usize) {
        self.x0.push(o.x0[i]);
        self.x1.push(o.x1[i]);
        self.y0.push(o.y0[i]);
        self.y1.push(o.y1[i]);
        self.z0.push(o.z0[i]);
        self.z1.push(o.z1[i]);
    }
    /// Empties the arrays.
    pub fn clear(&mut self) {
        for v in [&mut self.x0, &mut self.x1, &mut self.y0, &mut self.y1, &mut self.z0, &mut self.z1] {
            v.clear();
        }
    }
}

macro_rules! soa {
    ($(#[$doc:meta])* $name:ident { f32: [$($f:ident),* $(,)?], u32: [$($u:ident),* $(,)?] }) => {
        $(#[$doc])*
        #[derive(Clone, Debug, Default)]
        pub struct $name {
            $(#[doc = concat!("Per-item `", stringify!($f), "`.")] pub $f: Vec<f32>,)*
            $(#[doc = concat!("Per-item `", stringify!($u), "`.")] pub $u: Vec<u32>,)*
        }
        impl $name {
            /// Empties every array, keeping capacity.
            pub fn clear(&mut self) {
                $(self.$f.clear();)*
                $(self.$u.clear();)*
            }
            /// Appends a copy of its own item `i`.
            fn push_copy(&mut self, i: usize) {
                $(let v = self.$f[i]; self.$f.push(v);)*
                $(let v = self.$u[i]; self.$u.push(v);)*
            }
            /// Appends item `i` of `o` (used to reorder a work list).
            pub fn push_from(&mut self, o: &$name, i: usize) {
                $(self.$f.push(o.$f[i]);)*
                $(self.$u.push(o.$u[i]);)*
            }
            /// Sets every array's length to `n` (new entries 0).
            pub fn resize(&mut self, n: usize) {
                $(self.$f.resize(n, 0.0);)*
                $(self.$u.resize(n, 0);)*
            }
        }
    };
}

soa! {
    /// A packed work list: one entry per sample to shade. The schedule fills the surface (`px..metal`), `pixel`
    /// and `weight` (where the result goes: the box filter; `pixel` indexes the rows of the tile's band); [`shade`] writes `or..ls` (colour, or the light
    /// pre-pass buffers), `tested` and `lit` (light counts, exact in f32 below 2²⁴ lights).
    Items {
        f32: [px, py, pz, nx, ny, nz, ar, ag, ab, spec, pw, rough, metal, or, og, ob, ls, tested, lit, weight],
        u32: [pixel]
    }
}

impl Items {
    /// Number of items.
    #[must_use]
    pub fn len(&self) -> usize {
        self.px.len()
    }

    /// True when empty.
    #[allow(dead_code)] // the pair of `len` (clippy: len_without_is_empty)
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.px.is_empty()
    }

    /// Pads the list to a multiple of [`BLOCK`] with copies of item `template` that go nowhere (`pixel` =
    /// [`PAD_PIXEL`], weight 0): the kernel then runs whole vectors only, with no scalar remainder loop.
    pub fn pad_to_lanes(&mut self, template: usize) {
        while !self.len().is_multiple_of(BLOCK) {
            self.push_copy(template);
            let last = self.len() - 1;
            self.pixel[last] = PAD_PIXEL;
            self.weight[last] = 0.0;
        }
    }

    /// Appends a sample with its destination pixel and box-filter weight.
    #[cfg_attr(not(test), allow(dead_code))] // used by the tests
    pub fn push(&mut self, s: &Surface, pixel: u32, weight: f32) {
        let n = self.len();
        self.resize(n + 1);
        self.set(n, s);
        self.pixel[n] = pixel;
        self.weight[n] = weight;
    }

    /// Writes surface `s` into item `j`.
    #[cfg_attr(not(test), allow(dead_code))] // used by the tests
    pub fn set(&mut self, j: usize, s: &Surface) {
        (self.px[j], self.py[j], self.pz[j]) = (s.p.x, s.p.y, s.p.z);
        (self.nx[j], self.ny[j], self.nz[j]) = (s.n.x, s.n.y, s.n.z);
        (self.ar[j], self.ag[j], self.ab[j]) = (s.albedo.x, s.albedo.y, s.albedo.z);
        (self.spec[j], self.pw[j], self.rough[j], self.metal[j]) = (s.specular, s.power, s.roughness, s.metallic);
    }

    /// View depth `−z` of item `j`.
    #[must_use]
    pub fn depth(&self, j: usize) -> f32 {
        -self.pz[j]
    }
}
