//! A serializable description of a layout with its footprint at a resolution: the rows of `gbuf layouts --json`,
//! and what reports print about a layout.

use super::{Layout, Slot};
use serde::Serialize;
use std::collections::BTreeMap;

/// One field, as listed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FieldSummary {
    /// What it stores (`normal`, `motion.x`, `material_index`, `reserved`).
    pub attribute: String,
    /// Codec name (empty for reserved bits and the material index).
    pub codec: String,
    /// First bit in the texel.
    pub offset: u32,
    /// Width in bits.
    pub bits: u32,
    /// The format's components the field occupies (`r`, `g`, …).
    pub components: Vec<&'static str>,
    /// Free text from the spec.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// One target, as listed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TargetSummary {
    /// Target name.
    pub name: String,
    /// Format name.
    pub format: &'static str,
    /// Bytes per texel.
    pub bytes: usize,
    /// Bits holding no G-buffer attribute: free bits plus `reserved` fields (all written as zero).
    pub unused_bits: u32,
    /// The fields.
    pub fields: Vec<FieldSummary>,
    /// Free text from the spec.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// A layout with its footprint.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LayoutSummary {
    /// Layout name.
    pub name: String,
    /// One-line description.
    pub description: String,
    /// Bytes per sample (sum of the targets).
    pub bytes_per_sample: usize,
    /// Bits spent on G-buffer attributes (excluding reserved bits).
    pub used_bits: u32,
    /// Width, height and samples the footprint is computed for.
    pub resolution: [u32; 2],
    /// Samples per pixel.
    pub msaa: u32,
    /// `width × height × msaa × bytes_per_sample`.
    pub footprint_bytes: u64,
    /// Footprint in MiB (2^20 bytes).
    pub footprint_mib: f64,
    /// Attributes stored (in fields or the material table).
    pub stored: Vec<&'static str>,
    /// Constants assumed for unstored attributes.
    pub constants: BTreeMap<&'static str, Vec<f32>>,
    /// Index bits and table parameters of material-ID indirection.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub material_indirection: Option<(u32, Vec<&'static str>)>,
    /// Sources.
    pub sources: Vec<String>,
    /// The targets.
    pub targets: Vec<TargetSummary>,
}

impl LayoutSummary {
    /// Describes `layout` at `width × height × msaa`.
    #[must_use]
    pub fn new(layout: &Layout, width: u32, height: u32, msaa: u32) -> Self {
        let spec = layout.spec();
        let targets = spec
            .targets
            .iter()
            .zip(layout.formats())
            .enumerate()
            .map(|(ti, (t, format))| {
                let fields: Vec<FieldSummary> = layout
                    .fields()
                    .iter()
                    .zip(spec.targets.iter().flat_map(|t| &t.fields))
                    .filter(|(f, _)| f.target == ti)
                    .map(|(f, fs)| FieldSummary {
                        attribute: f.slot.name(),
                        codec: f.codec.clone(),
                        offset: f.offset,
                        bits: f.bits,
                        components: format.components_in(f.offset, f.bits).iter().map(|c| c.name).collect(),
                        note: fs.note.clone(),
                    })
                    .collect();
                let used: u32 = fields.iter().filter(|f| f.attribute != Slot::Reserved.name()).map(|f| f.bits).sum();
                TargetSummary {
                    name: t.name.clone(),
                    format: format.name(),
                    bytes: format.bytes(),
                    unused_bits: format.bits() - used,
                    fields,
                    note: t.note.clone(),
                }
            })
            .collect();
        let footprint_bytes = layout.footprint_bytes(width, height, msaa);
        LayoutSummary {
            name: layout.name().to_string(),
            description: spec.description.clone(),
            bytes_per_sample: layout.bytes_per_sample(),
            used_bits: layout.used_bits(),
            resolution: [width, height],
            msaa,
            footprint_bytes,
            footprint_mib: footprint_bytes as f64 / f64::from(1u32 << 20),
            stored: layout.stored_attributes().iter().map(|a| a.name()).collect(),
            constants: layout.constants().iter().map(|(a, v)| (a.name(), v.clone())).collect(),
            material_indirection: layout
                .indirection()
                .map(|i| (i.bits, i.parameters.iter().map(|a| a.name()).collect())),
            sources: spec.sources.clone(),
            targets,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fat_layout_summary_matches_the_seed_numbers() {
        let s = LayoutSummary::new(&Layout::by_name("fat-20").unwrap(), 1900, 1200, 4);
        assert_eq!(s.footprint_bytes, 182_400_000);
        assert!((s.footprint_mib - 173.95).abs() < 0.01, "{}", s.footprint_mib);
        assert_eq!(s.targets.len(), 5);
        assert_eq!(s.targets[1].unused_bits, 32); // the lighting target holds no G-buffer attribute
        let normal = &s.targets[2].fields[0];
        assert_eq!(normal.components, ["r", "g", "b", "a"]);
        assert_eq!(s.targets.iter().map(|t| t.bytes).sum::<usize>(), s.bytes_per_sample);
    }
}
