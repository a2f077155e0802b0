//! How many surfaces a pixel really holds: the question behind MSAA G-buffer compression (Kerzner & Salvi 2014's
//! streaming compression keeps 3 surfaces per pixel at 8×; AGAA 2 aggregates). Per pixel, the covered samples are
//! grouped two ways:
//!
//! - **by identity**: distinct (object ID, primitive ID) pairs where the dump has primitive IDs, else distinct
//!   (object ID, material ID) — what a rasterizer wrote;
//! - **by geometry**: greedy merging in sample order, a sample joining the first group whose first sample has a
//!   normal within [`MERGE_DOT`] (|dot| ≥ 0.785, Kerzner & Salvi's normal test) and a view depth within
//!   [`MERGE_DEPTH_RELATIVE`] of its own — surfaces a compressor could store once.
//!
//! The histograms count pixels by their number of groups (index 0: pixels with no covered sample).

use crate::gbuffer::GBuffer;
use serde::{Deserialize, Serialize};

/// Normals agree when |n₁·n₂| ≥ this (Kerzner & Salvi 2014's merge test, about 38°).
pub const MERGE_DOT: f32 = 0.785;
/// Depths agree within this fraction of the nearer one.
pub const MERGE_DEPTH_RELATIVE: f32 = 0.02;

/// Surfaces per pixel of one frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfacesPerPixel {
    /// Samples per pixel (the histograms run 0..=samples).
    pub samples: u32,
    /// Which IDs the identity count uses: `object+primitive`, `object+material`, `object`, `material`; `None`
    /// without IDs.
    pub identity_key: Option<String>,
    /// Pixels with k distinct identities among their covered samples, k = 0..=samples.
    pub by_identity: Option<Vec<u64>>,
    /// Pixels with k geometric groups, k = 0..=samples; `None` without normals or depth.
    pub by_geometry: Option<Vec<u64>>,
}

/// The surfaces of every pixel (row-major; 0 where no sample is covered), by identity and by geometry.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceMaps {
    /// Which IDs the identity count uses (see [`SurfacesPerPixel::identity_key`]).
    pub identity_key: Option<&'static str>,
    /// Distinct identities per pixel; `None` without IDs.
    pub by_identity: Option<Vec<u8>>,
    /// Geometric groups per pixel; `None` without normals or depth.
    pub by_geometry: Option<Vec<u8>>,
}

/// Counts the surfaces of every pixel of `gb`.
#[must_use]
pub fn surfaces_per_pixel(gb: &GBuffer) -> SurfacesPerPixel {
    SurfacesPerPixel::of(gb.samples, &surface_maps(gb))
}

/// The surfaces of every pixel of `gb` (the heatmap behind [`surfaces_per_pixel`]'s histograms).
#[must_use]
pub fn surface_maps(gb: &GBuffer) -> SurfaceMaps {
    let s = gb.samples as usize;
    let pixels = gb.width as usize * gb.height as usize;
    let (obj, prim, mat) = (gb.object_id.as_deref(), gb.primitive_id.as_deref(), gb.material_id.as_deref());
    let identity_key = match (obj, prim, mat) {
        (Some(_), Some(_), _) => Some("object+primitive"),
        (Some(_), None, Some(_)) => Some("object+material"),
        (Some(_), None, None) => Some("object"),
        (None, Some(_), _) => Some("primitive"),
        (None, None, Some(_)) => Some("material"),
        (None, None, None) => None,
    };
    let key = |i: usize| -> (u32, u32) {
        let o = obj.map_or(0, |v| v[i]);
        let second = prim.or(mat).map_or(0, |v| v[i]);
        (o, second)
    };
    let geometry = gb.normal.as_deref().zip(gb.depth.as_deref());
    let mut by_identity = identity_key.map(|_| vec![0u8; pixels]);
    let mut by_geometry = geometry.map(|_| vec![0u8; pixels]);
    let mut keys: Vec<(u32, u32)> = Vec::with_capacity(s);
    let mut firsts: Vec<usize> = Vec::with_capacity(s);
    for p in 0..pixels {
        keys.clear();
        firsts.clear();
        for i in p * s..(p + 1) * s {
            if !gb.coverage[i] {
                continue;
            }
            if identity_key.is_some() {
                let k = key(i);
                if !keys.contains(&k) {
                    keys.push(k);
                }
            }
            if let Some((n, z)) = geometry {
                let joins = firsts.iter().any(|&f| {
                    let near = z[i].min(z[f]).abs();
                    n[i].dot(n[f]).abs() >= MERGE_DOT && (z[i] - z[f]).abs() <= MERGE_DEPTH_RELATIVE * near
                });
                if !joins {
                    firsts.push(i);
                }
            }
        }
        // At most `samples` ≤ MAX_SAMPLES (64) groups: a byte holds it.
        if let Some(m) = by_identity.as_mut() {
            m[p] = keys.len() as u8;
        }
        if let Some(m) = by_geometry.as_mut() {
            m[p] = firsts.len() as u8;
        }
    }
    SurfaceMaps { identity_key, by_identity, by_geometry }
}

impl SurfacesPerPixel {
    /// The histograms of `maps` (pixels by their count, 0..=samples).
    #[must_use]
    pub fn of(samples: u32, maps: &SurfaceMaps) -> Self {
        let hist = |m: &Vec<u8>| {
            let mut h = vec![0u64; samples as usize + 1];
            for &k in m {
                h[usize::from(k)] += 1;
            }
            h
        };
        SurfacesPerPixel {
            samples,
            identity_key: maps.identity_key.map(str::to_string),
            by_identity: maps.by_identity.as_ref().map(hist),
            by_geometry: maps.by_geometry.as_ref().map(hist),
        }
    }

    /// One line per histogram: the share of covered pixels holding 1, 2, … surfaces.
    #[must_use]
    pub fn to_text(&self) -> String {
        let line = |name: &str, h: &[u64]| {
            let covered: u64 = h[1..].iter().sum();
            let parts: Vec<String> = h
                .iter()
                .enumerate()
                .skip(1)
                .filter(|(_, &c)| c > 0)
                .map(|(k, &c)| format!("{k}: {:.2}%", 100.0 * c as f64 / covered.max(1) as f64))
                .collect();
            format!("{name:<36}{} ({covered} covered pixels)\n", parts.join(", "))
        };
        let mut t = String::new();
        if let (Some(k), Some(h)) = (&self.identity_key, &self.by_identity) {
            t.push_str(&line(&format!("surfaces/pixel ({k})"), h));
        }
        if let Some(h) = &self.by_geometry {
            t.push_str(&line("surfaces/pixel (geometry)", h));
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn two_objects_in_a_pixel_are_two_surfaces_and_one_plane_is_one() {
        let mut gb = GBuffer::new(2, 1, 4).unwrap();
        gb.coverage = vec![true, true, true, false, true, true, true, true];
        gb.object_id = Some(vec![1, 1, 2, 0, 3, 3, 3, 3]);
        gb.depth = Some(vec![1.0, 1.001, 5.0, 0.0, 2.0, 2.0, 2.01, 2.0]);
        gb.normal = Some(vec![Vec3::Z, Vec3::Z, Vec3::X, Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Z, -Vec3::Z]);
        let h = surfaces_per_pixel(&gb);
        assert_eq!(h.identity_key.as_deref(), Some("object"));
        let maps = surface_maps(&gb);
        assert_eq!((maps.by_identity.unwrap(), maps.by_geometry.unwrap()), (vec![2, 1], vec![2, 1]));
        assert_eq!(h.by_identity.unwrap(), [0, 1, 1, 0, 0]);
        // Pixel 0: two groups (the far X-facing sample apart); pixel 1: one (−Z counts by |dot|, 0.5% deeper).
        assert_eq!(h.by_geometry.unwrap(), [0, 1, 1, 0, 0]);
    }
}
