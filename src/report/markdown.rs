//! `report.md`: the tables a person reads, with the figures inline.

use crate::analysis::aggregate::{AggregateRow, DetectorAggregate, Stat};
use crate::analysis::needs::Needs;
use crate::analysis::record::{Frame, Report};
use crate::analysis::row::{ParetoFlags, Row};
use crate::base::table::{Align, Table};
use crate::measure::image::ErrorSet;
use crate::report::format::fmt_opt;
use std::fmt::Write as _;

fn pct(v: Option<f64>) -> String {
    v.map_or("—".into(), |x| format!("{:.1}%", 100.0 * x))
}

/// The "what the scene needs" section.
#[must_use]
fn needs_section(n: &Needs) -> String {
    let mut t = Table::new([("", Align::Left), ("", Align::Left)]);
    let list = |v: &[String]| if v.is_empty() { "none".to_string() } else { v.join(", ") };
    let constants: Vec<String> = n
        .constant
        .iter()
        .map(|a| {
            let vals: Vec<String> =
                n.constant_values.get(a).map_or(vec![], |v| v.iter().map(|x| format!("{x}")).collect());
            format!("{a} = {}", vals.join(" "))
        })
        .collect();
    t.row(["covered samples".to_string(), n.covered_samples.to_string()]);
    t.row(["constant attributes".to_string(), list(&constants)]);
    t.row(["absent attributes".to_string(), list(&n.absent)]);
    t.row(["derivable attributes".to_string(), list(&n.derivable)]);
    let mat = if n.material_count_capped {
        format!("more than {} (indirection not worthwhile)", n.material_count)
    } else {
        format!("{} → {} ID bits", n.material_count, n.material_id_bits.unwrap_or(0))
    };
    t.row(["distinct material tuples (specular, power, roughness, metallic)".to_string(), mat]);
    let faces = match n.normals_face_camera {
        Some(true) => "yes: hemisphere encodings are safe".to_string(),
        Some(false) => format!(
            "no: {} covered samples have normal z ≤ 0 (min z {})",
            n.back_facing_normals,
            fmt_opt(n.min_normal_z.map(f64::from), 3)
        ),
        None => "no normals".into(),
    };
    t.row(["normals face the camera".to_string(), faces]);
    if let Some([lo, hi]) = n.depth_range {
        let bits = n.depth_bits.map_or(String::new(), |b| {
            format!(
                "; at {} relative precision: {} bits linear, {} bits logarithmic",
                b.relative_precision, b.linear_bits, b.log_bits
            )
        });
        t.row(["depth range".to_string(), format!("{lo:.4} – {hi:.4}{bits}")]);
    }
    for (k, [lo, hi]) in &n.ranges {
        t.row([format!("range of {k}"), format!("{lo:.4} – {hi:.4}")]);
    }
    if let Some(p) = &n.pruned_layout {
        t.row([
            "pruned layout".to_string(),
            format!(
                "`{}`: {} B/sample instead of {} (`{}`), saves {} B; RMSE {} (base {}){}",
                p.name,
                p.bytes_per_sample,
                p.base_bytes_per_sample,
                p.base,
                p.bytes_saved,
                fmt_opt(p.rmse, 5),
                fmt_opt(p.base_rmse, 5),
                p.note.as_ref().map_or(String::new(), |n| format!(" — {n}"))
            ),
        ]);
        if !p.changes.is_empty() {
            t.row(["pruning".to_string(), p.changes.join("; ")]);
        }
    }
    t.finish()
}

fn flip_pair(e: Option<&ErrorSet>) -> String {
    match e {
        Some(e) if e.flip_ldr.is_some() || e.flip_hdr.is_some() => {
            format!("{} / {}", fmt_opt(e.flip_ldr, 4), fmt_opt(e.flip_hdr, 4))
        }
        _ => "—".into(),
    }
}

fn pareto_cell(p: ParetoFlags) -> &'static str {
    match (p.bytes, p.time) {
        (true, true) => "bytes, time",
        (true, false) => "bytes",
        (false, true) => "time",
        (false, false) => "",
    }
}

/// The columns of the results table: what decides between layouts (report.csv and report.json have every measure:
/// footprint, PSNR, AA and total RMSE, precision and recall, decode ops, traffic, every stage's time).
const DECIDING: [&str; 8] = [
    "normal max °",
    "layout RMSE",
    "layout FLIP LDR / HDR",
    "total FLIP LDR / HDR",
    "shaded",
    "decode ops",
    "resolve pass ms",
    "Pareto",
];

/// The results table of one frame: the columns that decide (`DECIDING`); the rest is in report.csv.
#[must_use]
fn rows_table(rows: &[Row]) -> String {
    let culling = rows.iter().any(|r| r.culling.is_some());
    let mut columns = vec![("layout", Align::Left), ("B/sample", Align::Right), ("detector", Align::Left)];
    if culling {
        columns.push(("culling", Align::Left));
    }
    let last = DECIDING.len() - 1;
    columns.extend(DECIDING.iter().enumerate().map(|(i, &c)| (c, if i == last { Align::Left } else { Align::Right })));
    let mut t = Table::new(columns);
    for r in rows {
        let mut cells = vec![r.layout.clone(), r.bytes_per_sample.to_string(), r.detector.clone()];
        if culling {
            cells.push(r.culling.clone().unwrap_or_else(|| "—".into()));
        }
        if let Some(e) = &r.error {
            cells.push(format!("error: {e}"));
            cells.extend(std::iter::repeat_n(String::new(), DECIDING.len() - 1));
        } else {
            let (l, e) = (r.layout_error.as_ref(), r.total_error.as_ref());
            cells.extend([
                fmt_opt(r.normal_max_deg, 3),
                fmt_opt(l.map(|e| e.rmse), 5),
                flip_pair(l),
                flip_pair(e),
                pct(r.shading_fraction),
                r.decode_ops_per_sample.map_or("—".into(), |n| n.to_string()),
                fmt_opt(r.resolve_pass_ms, 1),
                pareto_cell(r.pareto).to_string(),
            ]);
        }
        t.row(cells);
    }
    let mut s = t.finish();
    s.push_str(
        "\nEvery other measure of these rows — footprint, PSNR, AA and total RMSE, precision and recall, traffic, each \
         stage's time with its spread — is in report.csv (and report.json).\n",
    );
    // Each note once: the detectors of a layout that share it are listed together (`fat-20 (lauritzen, normal,
    // combined): …`), in the rows' order.
    let mut grouped: Vec<(&str, &str, Vec<&str>)> = Vec::new();
    for r in rows {
        let Some(n) = r.note.as_deref() else { continue };
        match grouped.iter_mut().find(|(l, m, _)| *l == r.layout && *m == n) {
            Some(g) => g.2.push(&r.detector),
            None => grouped.push((&r.layout, n, vec![&r.detector])),
        }
    }
    let layouts_with_rows = |l: &str| rows.iter().filter(|r| r.layout == l).count();
    let notes: Vec<String> = grouped
        .iter()
        .map(|(l, n, d)| {
            if d.len() == layouts_with_rows(l) && d.len() > 1 {
                format!("- {l} (every detector): {n}")
            } else {
                format!("- {l} × {}: {n}", d.join(", "))
            }
        })
        .collect();
    if !notes.is_empty() {
        s.push_str("\nNotes:\n");
        s.push_str(&notes.join("\n"));
        s.push('\n');
    }
    s
}

fn stat_cell(st: &Option<Stat>, prec: usize, frames: bool) -> String {
    match st {
        None => "—".into(),
        Some(st) if frames => {
            format!("{} / {} ({})", fmt_opt(Some(st.mean), prec), fmt_opt(Some(st.worst), prec), st.worst_frame)
        }
        Some(st) => format!("{} / {}", fmt_opt(Some(st.mean), prec), fmt_opt(Some(st.worst), prec)),
    }
}

/// The table of the rows aggregated over frames: mean / worst (worst frame).
#[must_use]
fn aggregate_table(rows: &[AggregateRow]) -> String {
    use Align::{Left as L, Right as R};
    let mut t = Table::new([
        ("layout", L),
        ("B/sample", R),
        ("detector", L),
        ("culling", L),
        ("frames", R),
        ("layout RMSE mean / worst (frame)", R),
        ("layout FLIP LDR mean / worst", R),
        ("AA RMSE mean / worst", R),
        ("total RMSE mean / worst", R),
        ("resolve pass ms mean / worst", R),
        ("traffic tiled MB mean", R),
        ("traffic quad MB mean", R),
        ("Pareto", L),
    ]);
    for r in rows {
        let failed = if r.failed_frames > 0 { format!(" ({} failed)", r.failed_frames) } else { String::new() };
        t.row([
            r.layout.clone(),
            r.bytes_per_sample.to_string(),
            r.detector.clone(),
            r.culling.clone().unwrap_or_else(|| "—".into()),
            format!("{}{failed}", r.frames),
            stat_cell(&r.layout_rmse, 5, true),
            stat_cell(&r.layout_flip_ldr, 4, false),
            stat_cell(&r.aa_rmse, 5, false),
            stat_cell(&r.total_rmse, 5, false),
            stat_cell(&r.resolve_pass_ms, 1, false),
            fmt_opt(r.bandwidth_tiled_mb.as_ref().map(|s| s.mean), 1),
            fmt_opt(r.bandwidth_quad_mb.as_ref().map(|s| s.mean), 1),
            pareto_cell(r.pareto).to_string(),
        ]);
    }
    t.finish()
}

/// The detector table: anti-aliasing error against the shading each detector costs.
#[must_use]
fn detector_table(rows: &[DetectorAggregate]) -> String {
    use Align::{Left as L, Right as R};
    let mut t = Table::new([
        ("detector", L),
        ("shaded (mean)", R),
        ("AA RMSE mean / worst", R),
        ("AA FLIP LDR mean / worst", R),
        ("AA FLIP HDR mean / worst", R),
        ("on the front", L),
    ]);
    for d in rows {
        t.row([
            d.detector.clone(),
            pct(d.shading_fraction.as_ref().map(|s| s.mean)),
            stat_cell(&d.aa_rmse, 5, false),
            stat_cell(&d.aa_flip_ldr, 4, false),
            stat_cell(&d.aa_flip_hdr, 4, false),
            if d.on_front { "yes" } else { "" }.to_string(),
        ]);
    }
    t.finish()
}

fn frame_header(s: &mut String, f: &Frame, rows: usize, runs: usize) {
    for n in &f.notes {
        let _ = writeln!(s, "**Note:** {n}.\n");
    }
    let _ = writeln!(
        s,
        "{}×{} pixels, {} samples per pixel, {:.1}% of samples covered, {} lights ({}). Sweep of {rows} rows took \
         {:.1} s; times are medians of {runs} runs with (min–max).\n",
        f.width,
        f.height,
        f.samples,
        100.0 * f.coverage,
        f.lights,
        f.lights_source,
        f.sweep_seconds,
    );
    if let Some(t) = f.reference {
        let _ = writeln!(
            s,
            "The reference (every sample shaded, unquantized G-buffer) took {:.1} ms ({:.1}–{:.1}).\n",
            t.median_ms, t.min_ms, t.max_ms
        );
    }
    if !f.stage_seconds.is_empty() {
        let _ =
            writeln!(s, "Where the sweep's time went: {}.\n", crate::report::format::stage_summary(&f.stage_seconds));
    }
    if !f.other_seconds.is_empty() {
        let _ = writeln!(s, "Outside the sweep: {}.\n", crate::report::format::stage_summary(&f.other_seconds));
    }
}

/// Which rows a front holds.
type RowPick = fn(&Row) -> bool;
/// Which aggregate rows a front holds.
type AggregatePick = fn(&AggregateRow) -> bool;

fn fronts(s: &mut String, rows: &[Row]) {
    let fronts: [(&str, RowPick); 3] = [
        ("layout error against bytes per sample", |r| r.pareto.bytes),
        ("layout error against the resolve pass time", |r| r.pareto.time),
        ("layout error against the tiled traffic after the `dcc` compression model", |r| r.pareto.compressed),
    ];
    for (what, pick) in fronts {
        let mut names: Vec<String> =
            rows.iter().filter(|r| pick(r)).map(|r| format!("{} × {}", r.layout, r.detector)).collect();
        names.dedup();
        let _ = writeln!(s, "- {what}: {}", if names.is_empty() { "none".into() } else { names.join(", ") });
    }
}

/// Each layout's bytes after the framebuffer-compression models, the tiled traffic with them, and where the ranking
/// by compressed bytes differs from the nominal one.
fn compression(s: &mut String, rows: &[Row], multi: bool, samples: u64) {
    // One row per layout (the models see the packed targets, whatever the detector).
    let mut layouts: Vec<&Row> = Vec::new();
    for r in rows.iter().filter(|r| r.compressed.is_some()) {
        if !layouts.iter().any(|l| l.layout == r.layout) {
            layouts.push(r);
        }
    }
    if layouts.is_empty() {
        return;
    }
    s.push_str(if multi {
        "\n### Bytes after framebuffer compression (models)\n\n"
    } else {
        "\n## Bytes after framebuffer compression (models)\n\n"
    });
    s.push_str(
        "Models of the vendors' published constraints (`dcc`: AMD-like 256-byte blocks stored as 64–256 bytes; `ccs`: \
         Intel-like 128-byte pairs; `afbc`: Arm-like 4 × 4 sub-blocks, single-sampled targets of at most 32 bits \
         only, the others counted uncompressed), not any vendor's compressor: the point is the ranking. Traffic is \
         the tiled resolve's model with the compressed bytes. B/sample is what the targets occupy in memory (an \
         AFRC target at its fixed rate, which no lossless model shrinks further).\n\n",
    );
    let stored = |r: &Row| r.footprint_bytes as f64 / samples.max(1) as f64;
    let rank = |key: &dyn Fn(&Row) -> f64| -> Vec<usize> {
        layouts.iter().map(|r| layouts.iter().filter(|q| key(q) < key(r)).count() + 1).collect()
    };
    let nominal = rank(&stored);
    let dcc = rank(&|r| r.compressed.map_or(f64::NAN, |c| c.bytes_per_sample[0]));
    use Align::{Left as L, Right as R};
    let mut t = Table::new([
        ("layout", L),
        ("B/sample", R),
        ("dcc", R),
        ("ccs", R),
        ("afbc", R),
        ("tiled MB", R),
        ("tiled MB after dcc", R),
        ("rank nominal → dcc", L),
    ]);
    for (i, r) in layouts.iter().enumerate() {
        let c = r.compressed.expect("filtered above");
        t.row([
            r.layout.clone(),
            format!("{:.2}", stored(r)).trim_end_matches('0').trim_end_matches('.').to_string(),
            format!("{:.2}", c.bytes_per_sample[0]),
            format!("{:.2}", c.bytes_per_sample[1]),
            format!("{:.2}", c.bytes_per_sample[2]),
            format!("{:.2}", r.bandwidth_mb.tiled),
            format!("{:.2}", c.tiled_mb[0]),
            format!("{} → {}", nominal[i], dcc[i]),
        ]);
    }
    s.push_str(&t.finish());
    // The one published aggregate to set the models against: Arm's AFBC sample.
    let afbc: Vec<f64> =
        layouts.iter().map(|r| r.compressed.expect("filtered above").bytes_per_sample[2] / stored(r)).collect();
    let (lo, hi) = afbc.iter().fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
    let _ = writeln!(
        s,
        "\nFor scale, a published aggregate: Arm's Vulkan best-practice sample `afbc` measured 33% less write bandwidth \
         with AFBC on Sponza (about 0.67 of nominal). {}",
        if hi >= 1.0 && lo >= 1.0 {
            "AFBC holds none of these targets here (multisampled or wider than 32 bits), so it does not apply.".to_string()
        } else {
            format!(
                "Here the `afbc` model stores {:.2}–{:.2} of the nominal bytes: {}",
                lo,
                hi,
                if hi < 0.67 {
                    "below Arm's figure. Either this frame is smoother than textured Sponza or the model is optimistic; \
                     no vendor publishes per-target ratios that would decide it"
                } else {
                    "within or above Arm's figure"
                }
            )
        }
    );
    let moved: Vec<&str> = layouts
        .iter()
        .zip(nominal.iter().zip(&dcc))
        .filter(|(_, (a, b))| a != b)
        .map(|(r, _)| r.layout.as_str())
        .collect();
    let _ = writeln!(
        s,
        "\n{}",
        if moved.is_empty() {
            "The ranking by `dcc` bytes is the nominal one.".to_string()
        } else {
            format!("The ranking by `dcc` bytes differs from the nominal one for {}.", moved.join(", "))
        }
    );
}

/// The whole `report.md`.
#[must_use]
pub fn to_markdown(rep: &Report) -> String {
    let mut s = String::new();
    let multi = rep.frames.len() > 1;
    if multi {
        let _ = writeln!(s, "# gbuf report: {} frames\n", rep.frames.len());
    } else {
        let _ = writeln!(s, "# gbuf report: {}\n", rep.frames.first().map_or("(no frame)", |f| f.input.as_str()));
    }
    match &rep.lighting {
        Some(l) => {
            let _ = writeln!(
                s,
                "**Lighting:** every image is lit with the **{}** BRDF and the {} falloff: {}. A layout's ranking \
                 depends on what the BRDF reads (GGX reads roughness and metallic; Blinn-Phong a specular amount and \
                 power).\n",
                l.brdf, l.falloff, l.why
            );
        }
        None => s.push_str("**Lighting:** not recorded in this report.\n\n"),
    }
    let v = &rep.viewing;
    let _ = writeln!(
        s,
        "Errors are kept apart: the **layout error** (image lit from the unpacked G-buffer against the exact \
         G-buffer lit with the same detector and schedule), the **anti-aliasing (AA) error** (the exact G-buffer lit \
         with the detector against the every-sample reference) and the **total** (unpacked G-buffer against the \
         reference). Fronts rank layouts by layout error. FLIP ({} rows): LDR-FLIP of the displayed image \
         ({} tone map, exposure {}, 8-bit sRGB, as `gbuf resolve --png`) and HDR-FLIP of the linear image, at {:.2} \
         pixels per degree. PSNR's peak is the largest channel value of the image compared against.\n",
        rep.flip.name(),
        v.tone_map.name(),
        v.exposure,
        v.pixels_per_degree
    );
    if multi {
        let over = rep.over.name();
        s.push_str(&format!("\n## Over all frames (fronts by the {over} frame)\n\n"));
        s.push_str(&aggregate_table(&rep.aggregate));
        s.push('\n');
        let fronts: [(&str, AggregatePick); 3] = [
            ("bytes per sample", |r| r.pareto.bytes),
            ("mean resolve pass time", |r| r.pareto.time),
            ("mean tiled traffic after the `dcc` compression model", |r| r.pareto.compressed),
        ];
        for (what, pick) in fronts {
            let names: Vec<String> =
                rep.aggregate.iter().filter(|r| pick(r)).map(|r| format!("{} × {}", r.layout, r.detector)).collect();
            let _ = writeln!(
                s,
                "- layout error ({over}) against {what}: {}",
                if names.is_empty() { "none".into() } else { names.join(", ") }
            );
        }
    }
    s.push_str("\n## Detectors: anti-aliasing error against the shading it costs\n\n");
    s.push_str(&detector_table(&rep.detectors));
    for f in &rep.frames {
        let rows: Vec<Row> = rep.rows.iter().filter(|r| r.frame == f.input).cloned().collect();
        if multi {
            let _ = writeln!(s, "\n## Frame {}\n", f.input);
        } else {
            s.push('\n');
        }
        frame_header(&mut s, f, rows.len(), rep.runs);
        s.push_str(if multi { "### What the scene needs\n\n" } else { "## What the scene needs\n\n" });
        s.push_str(&needs_section(&f.needs));
        if let Some(sp) = f.surfaces_per_pixel.as_ref().filter(|sp| sp.samples > 1) {
            let text = sp.to_text();
            if !text.is_empty() {
                let _ = writeln!(
                    s,
                    "\nSurfaces per pixel (covered pixels by how many distinct surfaces their samples hold):\n"
                );
                for line in text.lines() {
                    let _ = writeln!(s, "- {}", line.split_whitespace().collect::<Vec<_>>().join(" "));
                }
                s.push('\n');
            }
        }
        s.push_str(if multi { "\n### Layouts × detectors\n\n" } else { "\n## Layouts × detectors\n\n" });
        s.push_str(&rows_table(&rows));
        if !f.fits.is_empty() {
            let _ = writeln!(
                s,
                "\nWhere each layout's targets bind as one {}× pass, as every conforming device guarantees (`gbuf layouts \
                 --check` says why; `+feature`: with an optional feature):\n",
                f.samples
            );
            for fit in &f.fits {
                let mut on = fit.fits.clone();
                on.extend(fit.with_feature.iter().map(|p| format!("{p} +feature")));
                let _ = writeln!(s, "- {}: {}", fit.layout, if on.is_empty() { "none".into() } else { on.join(", ") });
            }
        }
        compression(&mut s, &rows, multi, u64::from(f.width) * u64::from(f.height) * u64::from(f.samples));
        s.push_str(if multi { "\n### Pareto fronts\n\n" } else { "\n## Pareto fronts\n\n" });
        fronts(&mut s, &rows);
        s.push_str(if multi {
            "\n### Forward or deferred: the pipelines on this frame\n\n"
        } else {
            "\n## Forward or deferred: the pipelines on this frame\n\n"
        });
        match (&f.pipelines, &f.pipelines_error) {
            (Some(p), _) => s.push_str(&crate::report::pipelines::pipelines_markdown(p, if multi { 4 } else { 3 })),
            (None, Some(e)) => {
                let _ = writeln!(s, "Not measured: {e}");
            }
            (None, None) => s.push_str("Not measured.\n"),
        }
    }
    if !rep.figures.is_empty() {
        s.push_str("\n## Figures\n\n");
        for f in rep.figures.iter().filter(|f| !f.file.ends_with(".exr")) {
            // An A/B pair names its other image as the link title (report.html shows the two as one view).
            let against = f.against.as_ref().map_or(String::new(), |b| format!(" \"{b}\""));
            let _ = writeln!(s, "![{}]({}{against})\n\n*{}*\n", f.caption, f.file, f.caption);
        }
        let data: Vec<_> = rep.figures.iter().filter(|f| f.file.ends_with(".exr")).collect();
        if !data.is_empty() {
            s.push_str("\n### Float error maps (EXR, beside this file)\n\n");
            for f in data {
                let _ = writeln!(s, "- [{}]({}): {}", f.file, f.file, f.caption);
            }
        }
    }
    s.push_str(
        "\n## Reading the numbers\n\n\
         docs/GUIDE.md gives every column with its formula. In short:\n\n\
         - **B/sample**: bytes one MSAA sample takes in the layout's render targets; footprint = B/sample × pixels × \
         samples.\n\
         - **layout error**: what the layout's quantization alone costs; 0 for a lossless layout.\n\
         - **AA error**: what shading edge pixels once (per the detector) costs; the same for every layout.\n\
         - **total**: both, against the reference lit from the unquantized G-buffer with every sample shaded.\n\
         - **FLIP**: NVIDIA's perceptual difference (0 = indistinguishable, 1 = most different), mean over pixels.\n\
         - **shaded**: shading evaluations / (pixels × samples): 100% is supersampling, 1/samples is one per pixel.\n\
         - **decode ops**: arithmetic operations per sample the lighting pass spends unpacking the layout.\n\
         - **traffic**: modelled G-buffer bytes per frame; tiled = write + one read per covered sample + output; \
         quad = write + per light-fragment pair one G-buffer read and an RGBA16F read-modify-write.\n\
         - **resolve pass**: decode + resolve medians, the time axis of the fronts; encode is the tool's own cost.\n\
         - **Pareto**: no other row has both less layout error and fewer bytes (or a shorter resolve pass).\n",
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_note_shared_by_a_layouts_detectors_is_said_once() {
        let row = |layout: &str, detector: &str, note: Option<&str>| Row {
            layout: layout.into(),
            detector: detector.into(),
            note: note.map(str::to_string),
            ..Default::default()
        };
        let rows = vec![
            row("a", "depth", Some("not stored")),
            row("a", "normal", Some("not stored")),
            row("b", "depth", Some("x")),
            row("b", "normal", Some("y")),
            row("b", "combined", Some("x")),
            row("c", "depth", None),
        ];
        let t = rows_table(&rows);
        let notes: Vec<&str> = t.lines().filter(|l| l.starts_with("- ")).collect();
        assert_eq!(notes, ["- a (every detector): not stored", "- b × depth, combined: x", "- b × normal: y"], "{t}");
    }

    #[test]
    fn markdown_has_every_row_and_figure() {
        let rows = vec![
            Row {
                layout: "fat-20".into(),
                bytes_per_sample: 20,
                frame: "room".into(),
                detector: "depth".into(),
                layout_error: Some(ErrorSet { rmse: 0.1, ..Default::default() }),
                ..Default::default()
            },
            Row {
                layout: "bad".into(),
                frame: "room".into(),
                detector: "depth".into(),
                error: Some("no | way".into()),
                ..Default::default()
            },
        ];
        let figures =
            vec![crate::analysis::record::Figure { file: "a.png".into(), caption: "A plot".into(), against: None }];
        let rep = crate::analysis::record::test_report("room", 4, 2, rows, figures);
        let md = to_markdown(&rep);
        assert!(md.contains("| fat-20 | 20 |"));
        assert!(md.contains("error: no / way"), "pipes in errors are escaped");
        assert!(md.contains("![A plot](a.png)"));
        assert!(md.contains("absent attributes | depth, position"));
        // Every table line of the results has the same number of cells.
        let table: Vec<&str> = md.lines().skip_while(|l| !l.starts_with("| layout")).take(4).collect();
        let cells: Vec<usize> = table.iter().map(|l| l.matches('|').count()).collect();
        assert!(cells.iter().all(|&c| c == cells[0]), "{table:?}");
    }

    #[test]
    fn number_formatting() {
        assert_eq!(fmt_opt(None, 2), "—");
        assert_eq!(fmt_opt(Some(f64::INFINITY), 2), "∞");
        assert_eq!(fmt_opt(Some(1.23456), 2), "1.23");
        assert_eq!(fmt_opt(Some(0.0001), 2), "1.0e-4");
        assert_eq!(fmt_opt(Some(0.0), 2), "0.00");
    }
}
