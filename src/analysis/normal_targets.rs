//! The normal target alone, under each normal codec in a format engines store it in: its angular error on a frame and
//! its bytes after the framebuffer-compression models (`layout::compression`). It answers whether octahedral normals
//! in RGB10A2 cost more or less traffic than spheremap normals in RG16F once compressed, on the user's own frame.

use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use crate::layout::{compression, FieldSpec, Layout, LayoutSpec, TargetSpec};
use serde::Serialize;

/// (codec, format, bits): the normal encodings engines ship, each in the format it is stored in (docs/CODECS.md).
pub const CANDIDATES: [(&str, &str, u32); 11] = [
    ("oct-16", "rg8", 16),
    ("spheremap-cry-16", "rg8", 16),
    ("oct-20", "rgb10a2", 20),
    ("oct-24", "rgba8", 24),
    ("xyz-unorm-24", "rgba8", 24),
    ("xyz-unorm-30", "rgb10a2", 30),
    ("oct-32", "rg16unorm", 32),
    ("oct-f16-32", "rg16f", 32),
    ("spheremap-cry-f16-32", "rg16f", 32),
    ("xy-hemi-f16-32", "rg16f", 32),
    ("xyz-f16-48", "rgba16f", 48),
];

/// One codec's normal target on a frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NormalTarget {
    /// The normal codec.
    pub codec: String,
    /// The target's format.
    pub format: String,
    /// Bytes per sample, nominal.
    pub bytes_per_sample: u32,
    /// Mean angle between the frame's normals and the decoded ones, degrees, over covered samples.
    pub mean_deg: f64,
    /// The largest such angle.
    pub max_deg: f64,
    /// Bytes per sample under each compression model (`compression::SCHEMES` order; a model that cannot hold the
    /// target counts it uncompressed).
    pub compressed: [f64; 3],
}

/// The one-target layout storing the normal with `codec` in `format`.
fn layout(codec: &str, format: &str, bits: u32) -> Result<Layout> {
    Layout::from_spec(LayoutSpec {
        name: format!("normal-{codec}-{format}"),
        description: format!("the normal alone, {codec} in {format}"),
        sources: Vec::new(),
        depth_range: None,
        constants: Default::default(),
        material_indirection: None,
        targets: vec![TargetSpec {
            name: "normal".into(),
            format: format.into(),
            note: String::new(),
            afrc: None,
            fields: vec![FieldSpec {
                attribute: "normal".into(),
                codec: codec.into(),
                offset: 0,
                bits,
                note: String::new(),
            }],
        }],
    })
}

/// Every [`CANDIDATES`] entry on `gb`: packed, decoded and compressed. An error when the frame has no normals or no
/// covered sample (no angle to measure).
pub fn normal_targets(gb: &GBuffer) -> Result<Vec<NormalTarget>> {
    let Some(normals) = gb.normal.as_deref() else {
        return Err(Error::Argument("the frame has no normals: no normal target to compare".into()));
    };
    let covered = gb.coverage.iter().filter(|&&c| c).count();
    if covered == 0 {
        return Err(Error::Argument("the frame has no covered sample: no normal to compare".into()));
    }
    CANDIDATES
        .iter()
        .map(|&(codec, format, bits)| {
            let l = layout(codec, format, bits)?;
            let packed = l.pack(gb)?;
            let decoded = l.unpack(&packed, gb)?;
            let back = decoded.normal.as_deref().expect("a layout storing the normal decodes it");
            let (mut sum, mut max) = (0.0f64, 0.0f64);
            for ((a, b), _) in normals.iter().zip(back).zip(&gb.coverage).filter(|(_, &c)| c) {
                let d = crate::measure::gbuffer::angle_deg(*a, *b);
                sum += d;
                max = max.max(d);
            }
            let sizes = compression::compressed_models(&packed);
            Ok(NormalTarget {
                codec: codec.into(),
                format: format.into(),
                bytes_per_sample: l.bytes_per_sample() as u32,
                mean_deg: sum / covered as f64,
                max_deg: max,
                compressed: compression::bytes_per_sample(&sizes, gb.len() as u64),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_candidate_is_a_valid_layout_and_the_room_ranks_them() {
        let gb = crate::scene::render(crate::scene::SceneName::Room, 48, 32, 1).unwrap();
        let rows = normal_targets(&gb).unwrap();
        assert_eq!(rows.len(), CANDIDATES.len());
        let row = |c: &str| rows.iter().find(|r| r.codec == c).unwrap();
        // More bits, less error, in one family; the nominal bytes are the format's.
        assert!(row("oct-16").mean_deg > row("oct-24").mean_deg && row("oct-24").mean_deg > row("oct-32").mean_deg);
        assert_eq!((row("oct-16").bytes_per_sample, row("xyz-f16-48").bytes_per_sample), (2, 8));
        assert!(row("oct-24").max_deg < 0.1 && row("oct-32").max_deg < row("oct-24").max_deg);
        for r in &rows {
            assert!(r.max_deg >= r.mean_deg && r.max_deg <= 180.0, "{r:?}");
            // A model never stores more than the texels plus its metadata.
            assert!(r.compressed.iter().all(|&b| b > 0.0 && b <= 1.05 * f64::from(r.bytes_per_sample)), "{r:?}");
        }
        let mut bare = gb.clone();
        bare.normal = None;
        assert!(normal_targets(&bare).unwrap_err().to_string().contains("no normals"));
    }
}
