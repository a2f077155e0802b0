//! `gbuf roundtrip`: pack a dump with a layout, unpack it, and report the error per attribute.

use super::common::InputArgs;
use anyhow::Context;
use gbuf::layout::Layout;
use gbuf::measure::gbuffer::SampleAt;
use gbuf::measure::roundtrip::{roundtrip, Roundtrip};
use serde::Serialize;

/// Flags of `gbuf roundtrip`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// Layout: a built-in name (see `gbuf layouts`) or a TOML/JSON layout file.
    #[arg(long, value_name = "NAME|PATH", required_unless_present = "normal_targets")]
    pub layout: Option<String>,
    /// Instead of a layout: the normal target alone under each normal codec in the format engines store it in, its
    /// angular error on the dump and its bytes after the framebuffer-compression models.
    #[arg(long, conflicts_with = "layout")]
    pub normal_targets: bool,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The JSON of `gbuf roundtrip`: the input file, then the roundtrip's numbers.
#[derive(Serialize)]
struct Row {
    file: String,
    #[serde(flatten)]
    roundtrip: Roundtrip,
    /// How much of each field's code space the packed frame uses (covered samples).
    code_space: Vec<gbuf::layout::codespace::FieldCodes>,
    /// Each target's bytes under framebuffer-compression models (`gbuf::layout::compression`).
    compression: Vec<gbuf::layout::compression::TargetBytes>,
}

/// Runs `gbuf roundtrip`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let Some(name) = args.layout.as_deref() else {
        return normal_targets(&args);
    };
    let layout = Layout::by_name_or_path(name)?;
    let loaded = args.input.load().with_context(|| format!("loading {}", args.input.file.display()))?;
    let file = args.input.file.display().to_string();
    let roundtrip = roundtrip(&loaded.gbuffer, &layout).with_context(|| format!("{file}: layout {}", layout.name()))?;
    let packed = layout.pack(&loaded.gbuffer).with_context(|| format!("{file}: layout {}", layout.name()))?;
    let code_space = gbuf::layout::codespace::code_space(&layout, &packed, &loaded.gbuffer.coverage);
    let mut compression = gbuf::layout::compression::compressed(&packed);
    gbuf::layout::compression::fixed_rate(&mut compression, &layout);
    drop(packed);
    let row = Row { file, roundtrip, code_space, compression };
    if args.json {
        return super::common::print_json(&row);
    }
    print_text(&row)
}

/// `--normal-targets`: the table of `gbuf::analysis::normal_targets`.
fn normal_targets(args: &Args) -> anyhow::Result<()> {
    let loaded = args.input.load().with_context(|| format!("loading {}", args.input.file.display()))?;
    let file = args.input.file.display();
    let rows = gbuf::analysis::normal_targets::normal_targets(&loaded.gbuffer).with_context(|| format!("{file}"))?;
    if args.json {
        return super::common::print_json(&rows);
    }
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    let g = &loaded.gbuffer;
    writeln!(
        out,
        "{file}: the normal target alone, {}×{}×{}; bytes per sample after framebuffer compression (models of published \
         constraints, not a vendor's compressor)",
        g.width, g.height, g.samples
    )?;
    writeln!(
        out,
        "  {:<22} {:<10} {:>8} {:>10} {:>10} {:>8} {:>8} {:>8}",
        "codec", "format", "B/sample", "mean °", "max °", "dcc", "ccs", "afbc"
    )?;
    for r in &rows {
        writeln!(
            out,
            "  {:<22} {:<10} {:>8} {:>10.4} {:>10.4} {:>8.3} {:>8.3} {:>8.3}",
            r.codec,
            r.format,
            r.bytes_per_sample,
            r.mean_deg,
            r.max_deg,
            r.compressed[0],
            r.compressed[1],
            r.compressed[2]
        )?;
    }
    Ok(())
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

/// The per-attribute lines of an [`AttributeErrors`] (`gbuf roundtrip`, and `gbuf compare` of two frames).
pub fn attribute_lines(e: &gbuf::measure::gbuffer::AttributeErrors) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    if let Some(n) = &e.normal {
        let _ = writeln!(
            out,
            "  normal         mean {:.4}°  p95 {:.4}°  max {:.4}°{}",
            n.mean_deg,
            n.p95_deg,
            n.max_deg,
            worst(n.max_deg, &n.worst)
        );
        if n.skipped_invalid > 0 {
            let _ = writeln!(
                out,
                "                 ({} samples with a zero or non-unit normal in the dump left out)",
                n.skipped_invalid
            );
        }
    }
    if let Some(d) = &e.depth {
        let _ = writeln!(
            out,
            "  depth          rel max {:.3e}  rel mean {:.3e}  abs max {:.3e}{}",
            d.rel_max,
            d.rel_mean,
            d.abs_max,
            worst(d.rel_max, &d.worst)
        );
    }
    for v in e.albedo.iter().chain(&e.position).chain(&e.motion).chain(&e.scalars) {
        let _ = writeln!(
            out,
            "  {:<14} max abs {:.3e}  mean abs {:.3e}  rmse {:.3e}{}",
            v.attribute,
            v.max_abs,
            v.mean_abs,
            v.rmse,
            worst(v.max_abs, &v.worst)
        );
    }
    for id in &e.ids {
        let first = id.first.as_ref().map(|s| format!("  first at {}", at(s))).unwrap_or_default();
        let _ = writeln!(out, "  {:<14} {} mismatches{first}", id.attribute, id.mismatches);
    }
    out
}

fn print_text(row: &Row) -> anyhow::Result<()> {
    let r = &row.roundtrip;
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    let e = &r.errors;
    writeln!(
        out,
        "{}: {}×{}×{} through layout {} ({} B/sample), {} covered samples",
        row.file, r.size[0], r.size[1], r.size[2], r.layout, r.bytes_per_sample, e.covered_samples
    )?;
    out.write_all(attribute_lines(e).as_bytes())?;
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
    writeln!(out, "  code space used per field (covered samples):")?;
    out.write_all(gbuf::layout::codespace::text(&row.code_space).as_bytes())?;
    writeln!(
        out,
        "  bytes after framebuffer compression (models of published constraints, not a vendor's compressor; zstd on each \
         256-byte block for scale):"
    )?;
    writeln!(
        out,
        "    {:<18} {:<12} {:>10} {:>16} {:>16} {:>16} {:>16}",
        "target", "format", "nominal", "dcc", "ccs", "afbc", "zstd"
    )?;
    let cell = |b: Option<u64>, nominal: u64| match b {
        Some(b) => format!("{b} ({:.0}%)", 100.0 * b as f64 / nominal.max(1) as f64),
        None => "n/a".to_string(),
    };
    let (mut nominal, mut sums) = (0u64, [Some(0u64); 4]);
    for t in &row.compression {
        let by: Vec<Option<u64>> = t.schemes.iter().map(|s| s.bytes).chain([t.zstd]).collect();
        writeln!(
            out,
            "    {:<18} {:<12} {:>10} {:>16} {:>16} {:>16} {:>16}",
            t.target,
            t.format,
            t.nominal,
            cell(by[0], t.nominal),
            cell(by[1], t.nominal),
            cell(by[2], t.nominal),
            cell(by[3], t.nominal)
        )?;
        nominal += t.nominal;
        for (sum, b) in sums.iter_mut().zip(&by) {
            // AFBC holds a layout only when it holds every target.
            *sum = sum.zip(*b).map(|(a, b)| a + b);
        }
    }
    writeln!(
        out,
        "    {:<18} {:<12} {:>10} {:>16} {:>16} {:>16} {:>16}",
        "all targets",
        "",
        nominal,
        cell(sums[0], nominal),
        cell(sums[1], nominal),
        cell(sums[2], nominal),
        cell(sums[3], nominal)
    )?;
    Ok(())
}
