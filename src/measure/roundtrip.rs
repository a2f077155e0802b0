//! A layout's roundtrip measured on a G-buffer: pack, unpack, and every attribute's error against the input, with
//! the headline numbers flat (what `gbuf roundtrip --json` prints) and the material table summarised.

use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::layout::{Layout, MaterialTable};
use crate::measure::gbuffer::{compare, AttributeErrors};
use serde::Serialize;

/// A layout's roundtrip on one G-buffer: headline numbers flat, the full breakdown under `errors`.
#[derive(Debug, Serialize)]
pub struct Roundtrip {
    /// Layout name.
    pub layout: String,
    /// Bytes per sample.
    pub bytes_per_sample: usize,
    /// Width, height, samples.
    pub size: [u32; 3],
    /// Mean normal error, degrees.
    pub normal_mean_deg: Option<f64>,
    /// 95th percentile normal error, degrees.
    pub normal_p95_deg: Option<f64>,
    /// Largest normal error, degrees.
    pub normal_max_deg: Option<f64>,
    /// Largest relative depth error.
    pub depth_rel_max: Option<f64>,
    /// Mean relative depth error.
    pub depth_rel_mean: Option<f64>,
    /// Largest absolute albedo error.
    pub albedo_max_abs: Option<f64>,
    /// Albedo RMSE.
    pub albedo_rmse: Option<f64>,
    /// Attributes of the dump the layout neither stores nor assumes a constant for.
    pub dropped: Vec<String>,
    /// The material table, when the layout uses indirection.
    pub material_table: Option<MaterialTableSummary>,
    /// Every measured error with where the worst sample sits.
    pub errors: AttributeErrors,
}

/// Material table summary (the entries themselves are left out).
#[derive(Debug, Serialize)]
pub struct MaterialTableSummary {
    /// Parameters in the table.
    pub parameters: Vec<String>,
    /// Distinct tuples in the dump.
    pub distinct_tuples: usize,
    /// Table entries used.
    pub entries: usize,
    /// Index bits.
    pub bits: u32,
    /// Every tuple has its own entry.
    pub lossless: bool,
    /// Per parameter, the largest error the table introduces.
    pub max_abs_error: Vec<f32>,
    /// Per parameter, the mean error over covered samples.
    pub mean_abs_error: Vec<f32>,
    /// What indexes the table: `material-id` (the engine's IDs) or `palette` (clustered tuples).
    pub key: String,
    /// Table values taken from the sidecar's `materials` (the rest are per-ID means).
    pub from_sidecar: usize,
    /// Why the table is not what the layout asked for, if so.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl From<&MaterialTable> for MaterialTableSummary {
    fn from(t: &MaterialTable) -> Self {
        MaterialTableSummary {
            parameters: t.parameters.clone(),
            distinct_tuples: t.distinct_tuples,
            entries: t.entries.len(),
            bits: t.bits,
            lossless: t.lossless,
            max_abs_error: t.max_abs_error.clone(),
            mean_abs_error: t.mean_abs_error.clone(),
            key: t.key.clone(),
            from_sidecar: t.from_sidecar,
            note: t.note.clone(),
        }
    }
}

/// Packs `gb` with `layout`, unpacks it and measures every attribute against `gb`.
pub fn roundtrip(gb: &GBuffer, layout: &Layout) -> Result<Roundtrip> {
    let packed = layout.pack(gb)?;
    let back = layout.unpack(&packed, gb)?;
    let e = compare(gb, &back)?;
    let dropped = gb.attributes().into_iter().filter(|a| !back.has(*a)).map(|a| a.name().to_string()).collect();
    Ok(Roundtrip {
        layout: layout.name().to_string(),
        bytes_per_sample: layout.bytes_per_sample(),
        size: [gb.width, gb.height, gb.samples],
        normal_mean_deg: e.normal.as_ref().map(|n| n.mean_deg),
        normal_p95_deg: e.normal.as_ref().map(|n| n.p95_deg),
        normal_max_deg: e.normal.as_ref().map(|n| n.max_deg),
        depth_rel_max: e.depth.as_ref().map(|d| d.rel_max),
        depth_rel_mean: e.depth.as_ref().map(|d| d.rel_mean),
        albedo_max_abs: e.albedo.as_ref().map(|a| a.max_abs),
        albedo_rmse: e.albedo.as_ref().map(|a| a.rmse),
        dropped,
        material_table: packed.material_table.as_ref().map(MaterialTableSummary::from),
        errors: e,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lossless layout measures no error and drops nothing; a material-table layout reports its table; the
    /// headline numbers are the breakdown's.
    #[test]
    fn headline_numbers_are_the_breakdowns() {
        let gb = crate::scene::render(crate::scene::SceneName::Room, 32, 18, 4).unwrap();
        let exact = roundtrip(&gb, &Layout::by_name("reference-f32").unwrap()).unwrap();
        assert_eq!(exact.normal_max_deg, Some(0.0));
        assert_eq!(exact.depth_rel_max, Some(0.0));
        assert!(exact.dropped.is_empty() && exact.material_table.is_none());
        let lossy = roundtrip(&gb, &Layout::by_name("destiny-96").unwrap()).unwrap();
        let n = lossy.errors.normal.as_ref().unwrap();
        assert!(n.max_deg > 0.0 && lossy.normal_max_deg == Some(n.max_deg));
        assert_eq!(lossy.bytes_per_sample, 12);
        assert!(lossy.material_table.is_some(), "destiny-96 indexes a material table");
    }
}
