//! What a scene needs from its G-buffer: attributes that are constant or absent, the number of distinct material
//! tuples (→ the ID bits material-ID indirection would need), whether every normal faces the camera (→ hemisphere
//! encodings are safe), the depth range in use (→ depth bits) and the range of each scalar.
//!
//! Input: a G-buffer. Output: [`Needs`], a plain serializable summary. Only covered (non-background) samples are
//! looked at, since background samples hold zeros by convention. The pruned layout built from this analysis lives
//! in `analysis::prune`; it is attached to [`Needs::pruned_layout`] by the callers that can measure its error.

use crate::gbuffer::{Attribute, GBuffer, PlaneRef};
use serde::Serialize;
use std::collections::{BTreeMap, HashSet};

/// Two values of an attribute closer than this (relative to `max(1, |value|)`) count as equal when deciding that
/// an attribute is constant: 1e-4 is below half a step of a 12-bit unorm, so a "constant" attribute dropped from a
/// layout costs less than the coarsest encoding that would have stored it.
pub const CONSTANT_TOLERANCE: f32 = 1e-4;

/// The relative depth precision the depth-bit estimate aims for: 1e-4 of the distance (1 mm at 10 m), the order
/// of what a 24-bit unorm gives over a 1:100 depth range.
pub const DEPTH_RELATIVE_PRECISION: f64 = 1e-4;

/// Counting distinct material tuples stops here: beyond 16 bits of IDs, indirection no longer saves anything.
pub const MAX_MATERIAL_TUPLES: usize = 1 << 16;

/// The material parameters that a material-ID indirection table would hold (everything but albedo).
pub const MATERIAL_PARAMETERS: [Attribute; 4] =
    [Attribute::Specular, Attribute::SpecularPower, Attribute::Roughness, Attribute::Metallic];

/// Bits a depth encoding needs over the depth range in use.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct DepthBits {
    /// The relative precision aimed for.
    pub relative_precision: f64,
    /// Bits for a linear (unorm) encoding of view depth over [min, max].
    pub linear_bits: u32,
    /// Bits for a logarithmic encoding over [min, max].
    pub log_bits: u32,
}

/// The layout that leaves out what the scene does not need (filled in by `analysis::prune`).
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct PrunedLayout {
    /// Name of the pruned layout.
    pub name: String,
    /// The layout it was derived from.
    pub base: String,
    /// Bytes per sample of the pruned layout.
    pub bytes_per_sample: u32,
    /// Bytes per sample of the base layout.
    pub base_bytes_per_sample: u32,
    /// Bytes saved per sample.
    pub bytes_saved: u32,
    /// What was dropped or changed, one line each.
    pub changes: Vec<String>,
    /// Layout error (image RMSE against the exact G-buffer lit with the same detector) of the base layout, when
    /// measured.
    pub base_rmse: Option<f64>,
    /// Layout error (RMSE) of the pruned layout, when measured.
    pub rmse: Option<f64>,
    /// Layout error as PSNR in dB (peak: the exact image's largest channel value), when measured.
    pub psnr_db: Option<f64>,
    /// Why a measurement is missing, if one is.
    pub note: Option<String>,
}

/// The scene-needs analysis.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct Needs {
    /// Covered (surface) samples looked at.
    pub covered_samples: usize,
    /// Attributes present but constant over every covered sample (within [`CONSTANT_TOLERANCE`]).
    pub constant: Vec<String>,
    /// The value of each constant attribute (components).
    pub constant_values: BTreeMap<String, Vec<f64>>,
    /// Attributes not in the dump.
    pub absent: Vec<String>,
    /// Attributes a renderer can rebuild from others (position from depth + camera).
    pub derivable: Vec<String>,
    /// Distinct tuples of the non-albedo material parameters (specular, specular power, roughness, metallic).
    pub material_count: usize,
    /// True when counting stopped at [`MAX_MATERIAL_TUPLES`].
    pub material_count_capped: bool,
    /// Bits of material ID an indirection table needs (`None` when the count was capped).
    pub material_id_bits: Option<u32>,
    /// Distinct material IDs in the dump's `material_id` plane (when present, up to the cap).
    pub material_ids: Option<usize>,
    /// Every covered view-space normal has z > 0: hemisphere encodings are safe. `None` without normals.
    pub normals_face_camera: Option<bool>,
    /// Covered samples whose normal has z ≤ 0.
    pub back_facing_normals: usize,
    /// The smallest normal z over covered samples.
    pub min_normal_z: Option<f32>,
    /// [min, max] view depth over covered samples.
    pub depth_range: Option<[f32; 2]>,
    /// Depth bits that range needs at [`DEPTH_RELATIVE_PRECISION`].
    pub depth_bits: Option<DepthBits>,
    /// [min, max] of each scalar attribute (and each albedo channel as `albedo.r/g/b`) over covered samples.
    pub ranges: BTreeMap<String, [f32; 2]>,
    /// The pruned layout, when a caller computed it.
    pub pruned_layout: Option<PrunedLayout>,
}

impl Needs {
    /// Is `attr` constant in this scene?
    #[must_use]
    pub fn is_constant(&self, attr: Attribute) -> bool {
        self.constant.iter().any(|n| n == attr.name())
    }

    /// Position counted as derivable rather than absent: for a frame whose position plane was left out because
    /// depth and the camera give it bit for bit (`ReportInput::position_derived`).
    pub fn count_position_as_derivable(&mut self) {
        let name = Attribute::Position.name();
        self.absent.retain(|a| a != name);
        if !self.derivable.iter().any(|a| a == name) {
            self.derivable.push(name.to_string());
        }
    }

    /// Is `attr` absent from this scene?
    #[must_use]
    pub fn is_absent(&self, attr: Attribute) -> bool {
        self.absent.iter().any(|n| n == attr.name())
    }

    /// One line for people (what `gbuf report`, `gbuf demo` and `gbuf budget` print before their tables).
    #[must_use]
    pub fn summary_line(&self) -> String {
        format!(
            "needs: constant [{}], absent [{}], {} material tuples ({} ID bits), normals face camera: {}",
            self.constant.join(", "),
            self.absent.join(", "),
            self.material_count,
            self.material_id_bits.map_or("n/a".into(), |b| b.to_string()),
            self.normals_face_camera.map_or("n/a".into(), |b| b.to_string())
        )
    }

    /// A few lines for people (what `gbuf info` prints under "needs").
    #[must_use]
    pub fn to_text(&self) -> String {
        let list = |v: &[String]| if v.is_empty() { "none".to_string() } else { v.join(", ") };
        let constants: Vec<String> = self
            .constant
            .iter()
            .map(|a| {
                let v = self
                    .constant_values
                    .get(a)
                    .map_or(String::new(), |v| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" "));
                format!("{a} = {v}")
            })
            .collect();
        let mut t = String::new();
        t.push_str(&format!("needs       constant: {}\n", list(&constants)));
        t.push_str(&format!("            absent: {}; derivable: {}\n", list(&self.absent), list(&self.derivable)));
        let bits = self.material_id_bits.map_or("too many for an ID table".into(), |b| format!("{b} ID bits"));
        let capped = if self.material_count_capped { "more than " } else { "" };
        t.push_str(&format!("            material tuples: {capped}{} ({bits})\n", self.material_count));
        let faces = match self.normals_face_camera {
            Some(true) => "all normals face the camera (hemisphere encodings are safe)".to_string(),
            Some(false) => {
                format!("{} covered samples have normal z ≤ 0 (use a full-sphere encoding)", self.back_facing_normals)
            }
            None => "no normals".into(),
        };
        t.push_str(&format!("            {faces}\n"));
        if let (Some([lo, hi]), Some(b)) = (self.depth_range, self.depth_bits) {
            t.push_str(&format!(
                "            depth {lo} – {hi}: {} bits linear / {} bits log for {} relative precision\n",
                b.linear_bits, b.log_bits, b.relative_precision
            ));
        }
        if let Some(p) = &self.pruned_layout {
            t.push_str(&format!(
                "            pruned layout: {} = {} B/sample ({} B less than {}){}\n",
                p.name,
                p.bytes_per_sample,
                p.bytes_saved,
                p.base,
                p.rmse.map_or(String::new(), |r| format!(", image RMSE {r:.6}"))
            ));
            for c in &p.changes {
                t.push_str(&format!("              - {c}\n"));
            }
        }
        t
    }

    /// Attributes a layout does not need to store: absent, constant, or derivable ones.
    #[must_use]
    pub fn unneeded(&self) -> Vec<Attribute> {
        Attribute::ALL
            .into_iter()
            .filter(|a| {
                let n = a.name();
                self.absent.iter().chain(&self.constant).chain(&self.derivable).any(|x| x == n)
            })
            .collect()
    }
}

/// Bits needed to encode `[min, max]` linearly and logarithmically with relative precision `rel`.
#[must_use]
pub fn depth_bits(min: f32, max: f32, rel: f64) -> Option<DepthBits> {
    let (lo, hi) = (f64::from(min), f64::from(max));
    if !(lo > 0.0 && hi >= lo && hi.is_finite() && rel > 0.0) {
        return None;
    }
    let bits = |steps: f64| (steps + 1.0).log2().ceil().max(1.0) as u32;
    Some(DepthBits {
        relative_precision: rel,
        linear_bits: bits((hi - lo) / (lo * rel)),
        log_bits: bits((hi / lo).ln() / rel.ln_1p()),
    })
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= CONSTANT_TOLERANCE * a.abs().max(b.abs()).max(1.0)
}

/// Components of sample `i` of a plane, as f32 (IDs converted exactly up to 2^24, compared exactly below).
fn components(p: PlaneRef<'_>, i: usize) -> ([f32; 3], usize) {
    match p {
        PlaneRef::F32(v) => ([v[i], 0.0, 0.0], 1),
        PlaneRef::Vec2(v) => ([v[i].x, v[i].y, 0.0], 2),
        PlaneRef::Vec3(v) => ([v[i].x, v[i].y, v[i].z], 3),
        PlaneRef::U32(v) => ([v[i] as f32, 0.0, 0.0], 1),
    }
}

/// The constant value of `attr` over the covered samples, if it is constant.
fn constant_value(gb: &GBuffer, attr: Attribute, covered: &[usize]) -> Option<Vec<f64>> {
    let plane = gb.plane(attr)?;
    let &first = covered.first()?;
    if let PlaneRef::U32(v) = plane {
        let c = v[first];
        return covered.iter().all(|&i| v[i] == c).then(|| vec![f64::from(c)]);
    }
    let (c, n) = components(plane, first);
    covered
        .iter()
        .all(|&i| {
            let (v, _) = components(plane, i);
            (0..n).all(|k| close(v[k], c[k]))
        })
        .then(|| c[..n].iter().map(|&x| f64::from(x)).collect())
}

fn range(v: &[f32], covered: &[usize]) -> Option<[f32; 2]> {
    covered.iter().map(|&i| v[i]).fold(None, |acc, x| match acc {
        None => Some([x, x]),
        Some([a, b]) => Some([a.min(x), b.max(x)]),
    })
}

/// Counts distinct (bit-exact) tuples of the present material parameters, stopping after `cap`.
fn count_material_tuples(gb: &GBuffer, covered: &[usize], cap: usize) -> (usize, bool) {
    let planes: Vec<&[f32]> = MATERIAL_PARAMETERS
        .iter()
        .filter_map(|&a| match gb.plane(a) {
            Some(PlaneRef::F32(v)) => Some(v),
            _ => None,
        })
        .collect();
    if covered.is_empty() {
        return (0, false);
    }
    let mut seen: HashSet<[u32; 4]> = HashSet::new();
    for &i in covered {
        let mut key = [0u32; 4];
        for (k, p) in planes.iter().enumerate() {
            key[k] = p[i].to_bits();
        }
        seen.insert(key);
        if seen.len() > cap {
            return (cap, true);
        }
    }
    (seen.len(), false)
}

fn count_ids(v: &[u32], covered: &[usize], cap: usize) -> usize {
    let mut seen = HashSet::new();
    for &i in covered {
        seen.insert(v[i]);
        if seen.len() > cap {
            break;
        }
    }
    seen.len()
}

/// Bits needed to tell `n` things apart (0 for one or none).
#[must_use]
pub fn bits_for_count(n: usize) -> u32 {
    if n <= 1 {
        0
    } else {
        usize::BITS - (n - 1).leading_zeros()
    }
}

/// Analyses what `gb` needs. The pruned layout is left `None` (see `analysis::prune`).
#[must_use]
pub fn analyze(gb: &GBuffer) -> Needs {
    let covered: Vec<usize> = gb.coverage.iter().enumerate().filter(|(_, c)| **c).map(|(i, _)| i).collect();
    let mut constant = Vec::new();
    let mut constant_values = BTreeMap::new();
    let mut absent = Vec::new();
    for attr in Attribute::ALL {
        if !gb.has(attr) {
            absent.push(attr.name().to_string());
        } else if let Some(v) = constant_value(gb, attr, &covered) {
            constant.push(attr.name().to_string());
            constant_values.insert(attr.name().to_string(), v);
        }
    }
    let mut derivable = Vec::new();
    if gb.has(Attribute::Position) && gb.has(Attribute::Depth) && gb.camera.is_some() {
        derivable.push(Attribute::Position.name().to_string());
    }

    let (material_count, capped) = count_material_tuples(gb, &covered, MAX_MATERIAL_TUPLES);
    let material_ids = gb.material_id.as_deref().map(|v| count_ids(v, &covered, MAX_MATERIAL_TUPLES));

    let (mut normals_face_camera, mut back, mut min_z) = (None, 0, None);
    if let Some(n) = gb.normal.as_deref() {
        back = covered.iter().filter(|&&i| n[i].z.is_nan() || n[i].z <= 0.0).count();
        normals_face_camera = Some(back == 0);
        min_z = covered.iter().map(|&i| n[i].z).reduce(f32::min);
    }

    let depth_range = gb.depth.as_deref().and_then(|d| range(d, &covered));
    let mut ranges = BTreeMap::new();
    for attr in Attribute::ALL {
        if let Some(PlaneRef::F32(v)) = gb.plane(attr) {
            if let Some(r) = range(v, &covered) {
                ranges.insert(attr.name().to_string(), r);
            }
        }
    }
    if let Some(a) = gb.albedo.as_deref() {
        for (k, ch) in ["r", "g", "b"].iter().enumerate() {
            let c: Vec<f32> = covered.iter().map(|&i| a[i][k]).collect();
            let all: Vec<usize> = (0..c.len()).collect();
            if let Some(r) = range(&c, &all) {
                ranges.insert(format!("albedo.{ch}"), r);
            }
        }
    }

    Needs {
        covered_samples: covered.len(),
        constant,
        constant_values,
        absent,
        derivable,
        material_count,
        material_count_capped: capped,
        material_id_bits: (!capped).then(|| bits_for_count(material_count)),
        material_ids,
        normals_face_camera,
        back_facing_normals: back,
        min_normal_z: min_z,
        depth_range,
        depth_bits: depth_range.and_then(|[lo, hi]| depth_bits(lo, hi, DEPTH_RELATIVE_PRECISION)),
        ranges,
        pruned_layout: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A 4×2, 2-sample G-buffer: the right column is background; 3 material tuples on covered samples.
    fn gb() -> GBuffer {
        let mut g = GBuffer::new(4, 2, 2).unwrap();
        let n = g.len();
        g.coverage = (0..n).map(|i| (i / 2) % 4 != 3).collect();
        g.depth = Some((0..n).map(|i| 1.0 + i as f32).collect());
        g.normal = Some((0..n).map(|i| Vec3::new(0.1 * (i % 3) as f32, 0.0, 1.0).normalize()).collect());
        g.albedo = Some((0..n).map(|i| Vec3::new(0.5, 0.1 * (i % 5) as f32, 0.2)).collect());
        g.metallic = Some(vec![0.0; n]);
        g.specular = Some(vec![1.0; n]);
        g.roughness = Some((0..n).map(|i| [0.2, 0.5, 0.9][i % 3]).collect());
        g.material_id = Some((0..n).map(|i| (i % 3) as u32).collect());
        g
    }

    #[test]
    fn constant_and_absent_attributes() {
        let mut g = gb();
        // Background samples hold junk that must not break constancy.
        let m = g.metallic.as_mut().unwrap();
        m[6] = 0.7;
        m[7] = 0.7;
        m[0] = 0.5 * CONSTANT_TOLERANCE; // inside the tolerance
        let needs = analyze(&g);
        assert_eq!(needs.constant, vec!["specular", "metallic"]);
        assert_eq!(needs.constant_values["specular"], vec![1.0]);
        assert!(needs.absent.contains(&"motion".to_string()) && needs.absent.contains(&"position".to_string()));
        assert!(!needs.absent.contains(&"depth".to_string()));
        assert!(needs.is_constant(Attribute::Metallic) && needs.is_absent(Attribute::Motion));
        // Just outside the tolerance on a covered sample: no longer constant.
        g.metallic.as_mut().unwrap()[0] = 3.0 * CONSTANT_TOLERANCE;
        assert!(!analyze(&g).is_constant(Attribute::Metallic));
    }

    #[test]
    fn material_tuples_and_bits() {
        let g = gb();
        let needs = analyze(&g);
        assert_eq!(needs.material_count, 3, "three roughness values × constant specular and metallic");
        assert_eq!(needs.material_id_bits, Some(2));
        assert_eq!(needs.material_ids, Some(3));
        assert_eq!([0, 1, 2, 3, 4, 5, 256, 257].map(bits_for_count), [0, 0, 1, 2, 2, 3, 8, 9]);
    }

    #[test]
    fn material_count_is_capped() {
        let mut g = GBuffer::new(300, 300, 1).unwrap();
        let n = g.len();
        g.coverage = vec![true; n];
        g.roughness = Some((0..n).map(|i| i as f32).collect());
        let needs = analyze(&g);
        assert!(needs.material_count_capped);
        assert_eq!(needs.material_id_bits, None);
    }

    #[test]
    fn hemisphere_true_and_false() {
        let mut g = gb();
        let needs = analyze(&g);
        assert_eq!(needs.normals_face_camera, Some(true));
        assert_eq!(needs.back_facing_normals, 0);
        // A back-facing normal on a background sample does not count; on a covered one it does.
        g.normal.as_mut().unwrap()[7] = Vec3::new(0.0, 0.0, -1.0);
        assert_eq!(analyze(&g).normals_face_camera, Some(true));
        g.normal.as_mut().unwrap()[2] = Vec3::new(1.0, 0.0, 0.0);
        let needs = analyze(&g);
        assert_eq!(needs.normals_face_camera, Some(false));
        assert_eq!(needs.back_facing_normals, 1);
        assert_eq!(needs.min_normal_z, Some(0.0));
        g.normal = None;
        assert_eq!(analyze(&g).normals_face_camera, None);
    }

    #[test]
    fn depth_range_and_bits() {
        let needs = analyze(&gb());
        // Covered samples are 0..6 and 8..14 → depth 1..=6 and 9..=14; background 6, 7, 14, 15 excluded.
        assert_eq!(needs.depth_range, Some([1.0, 14.0]));
        let b = needs.depth_bits.unwrap();
        // linear: 13 / 1e-4 = 130000 steps → 17 bits; log: ln 14 / ln(1.0001) ≈ 26391 steps → 15 bits.
        assert_eq!((b.linear_bits, b.log_bits), (17, 15));
        assert_eq!(depth_bits(0.0, 1.0, 1e-3), None);
        assert_eq!(needs.ranges["roughness"], [0.2, 0.9]);
        assert_eq!(needs.ranges["albedo.r"], [0.5, 0.5]);
    }

    #[test]
    fn all_background_has_no_ranges_and_no_constants() {
        let mut g = gb();
        g.coverage.iter_mut().for_each(|c| *c = false);
        let needs = analyze(&g);
        assert_eq!(needs.covered_samples, 0);
        assert!(needs.constant.is_empty());
        assert_eq!(needs.depth_range, None);
        assert_eq!(needs.material_count, 0);
    }
}
