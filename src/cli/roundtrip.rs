//! `gbuf roundtrip`: pack a dump with a layout, unpack it, and report the error per attribute.

use super::common::InputArgs;
use anyhow::Context;
use gbuf::layout::{Layout, MaterialTable};
use gbuf::measure::gbuffer::{compare, AttributeErrors, SampleAt};
use serde::Serialize;

/// Flags of `gbuf roundtrip`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// Layout: a built-in name (see `gbuf layouts`) or a TOML/JSON layout file.
    #[arg(long, value_name = "NAME|PATH")]
    pub layout: String,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The JSON row of `gbuf roundtrip`: headline numbers flat, the full breakdown under `errors`.
#[derive(Debug, Serialize)]
pub struct Row {
    /// Input file.
    pub file: String,
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
    pub material_table: Option<MaterialTableRow>,
    /// Every measured error with where the worst sample sits.
    pub errors: AttributeErrors,
}

/// Material table summary (the entries themselves are left out).
#[derive(Debug, Serialize)]
pub struct MaterialTableRow {
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

impl From<&MaterialTable> for MaterialTableRow {
    fn from(t: &MaterialTable) -> Self {
        MaterialTableRow {
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

/// Packs, unpacks and measures; the library part of the command.
pub fn measure(gb: &gbuf::GBuffer, layout: &Layout, file: &str) -> anyhow::Result<Row> {
    let packed = layout.pack(gb).with_context(|| format!("packing with layout {}", layout.name()))?;
    let back = layout.unpack(&packed, gb).with_context(|| format!("unpacking with layout {}", layout.name()))?;
    let e = compare(gb, &back)?;
    let dropped = gb.attributes().into_iter().filter(|a| !back.has(*a)).map(|a| a.name().to_string()).collect();
    Ok(Row {
        file: file.to_string(),
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
        material_table: packed.material_table.as_ref().map(MaterialTableRow::from),
        errors: e,
    })
}

/// Runs `gbuf roundtrip`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let layout = Layout::by_name_or_path(&args.layout)?;
    let loaded = args.input.load().with_context(|| format!("loading {}", args.input.file.display()))?;
    let row = measure(&loaded.gbuffer, &layout, &args.input.file.display().to_string())?;
    if args.json {
        return super::common::print_json(&row);
    }
    print_text(&row)
}

fn at(s: &SampleAt) -> String {
    format!("pixel ({}, {}) sample {}", s.x, s.y, s.sample)
}

/// "  worst at …" unless the error is zero (then there is no worst sample to point at).
fn worst(err: f64, s: &SampleAt) -> String {
    if err > 0.0 {
        format!("  worst at {}", at(s))
    } else {
        String::new()
    }
}

fn print_text(r: &Row) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    let e = &r.errors;
    writeln!(
        out,
        "{}: {}×{}×{} through layout {} ({} B/sample), {} covered samples",
        r.file, r.size[0], r.size[1], r.size[2], r.layout, r.bytes_per_sample, e.covered_samples
    )?;
    if let Some(n) = &e.normal {
        writeln!(
            out,
            "  normal         mean {:.4}°  p95 {:.4}°  max {:.4}°{}",
            n.mean_deg,
            n.p95_deg,
            n.max_deg,
            worst(n.max_deg, &n.worst)
        )?;
        if n.skipped_invalid > 0 {
            writeln!(
                out,
                "                 ({} samples with a zero or non-unit normal in the dump left out)",
                n.skipped_invalid
            )?;
        }
    }
    if let Some(d) = &e.depth {
        writeln!(
            out,
            "  depth          rel max {:.3e}  rel mean {:.3e}  abs max {:.3e}{}",
            d.rel_max,
            d.rel_mean,
            d.abs_max,
            worst(d.rel_max, &d.worst)
        )?;
    }
    for v in e.albedo.iter().chain(&e.position).chain(&e.motion).chain(&e.scalars) {
        writeln!(
            out,
            "  {:<14} max abs {:.3e}  mean abs {:.3e}  rmse {:.3e}{}",
            v.attribute,
            v.max_abs,
            v.mean_abs,
            v.rmse,
            worst(v.max_abs, &v.worst)
        )?;
    }
    for id in &e.ids {
        let first = id.first.as_ref().map(|s| format!("  first at {}", at(s))).unwrap_or_default();
        writeln!(out, "  {:<14} {} mismatches{first}", id.attribute, id.mismatches)?;
    }
    if let Some(t) = &r.material_table {
        let how = match (t.key.as_str(), t.lossless) {
            ("material-id", _) if t.from_sidecar > 0 => {
                format!("keyed by material ID, {} values from the sidecar's materials", t.from_sidecar)
            }
            ("material-id", _) => "keyed by material ID (per-ID means)".to_string(),
            (_, true) => "palette, lossless".to_string(),
            (_, false) => "palette, clustered".to_string(),
        };
        writeln!(
            out,
            "  material table: {} distinct tuples → {} entries ({}-bit), {how}; max error {:?}",
            t.distinct_tuples,
            t.entries,
            t.bits,
            t.parameters.iter().zip(&t.max_abs_error).map(|(p, e)| format!("{p} {e:.3e}")).collect::<Vec<_>>()
        )?;
        if let Some(n) = &t.note {
            writeln!(out, "  material table note: {n}")?;
        }
    }
    if !r.dropped.is_empty() {
        writeln!(out, "  not stored by the layout: {}", r.dropped.join(", "))?;
    }
    if e.nonfinite > 0 {
        writeln!(out, "  {} non-finite values skipped", e.nonfinite)?;
    }
    Ok(())
}
