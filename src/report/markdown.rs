//! `report.md`: the tables a person reads, with the figures inline.

use crate::analysis::needs::Needs;
use crate::analysis::row::{Report, Row};
use std::fmt::Write as _;

/// Formats an optional number with `prec` decimals; `—` when missing, `∞` when infinite.
#[must_use]
pub fn fmt_opt(v: Option<f64>, prec: usize) -> String {
    match v {
        None => "—".into(),
        Some(x) if x.is_nan() => "—".into(),
        Some(x) if x == f64::INFINITY => "∞".into(),
        Some(x) if x == f64::NEG_INFINITY => "−∞".into(),
        Some(x) if x != 0.0 && x.abs() < 10f64.powi(-(prec as i32)) => format!("{x:.1e}"),
        Some(x) => format!("{x:.prec$}"),
    }
}

fn timing_cell(r: &Row, stage: &str) -> String {
    match r.timings.get(stage) {
        Some(t) if t.runs > 1 => format!("{:.1} ({:.1}–{:.1})", t.median_ms, t.min_ms, t.max_ms),
        Some(t) => format!("{:.1}", t.median_ms),
        None => "—".into(),
    }
}

fn pct(v: Option<f64>) -> String {
    v.map_or("—".into(), |x| format!("{:.1}%", 100.0 * x))
}

/// The "what the scene needs" section.
#[must_use]
pub fn needs_section(n: &Needs) -> String {
    let mut s = String::from("| | |\n|---|---|\n");
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
    let _ = writeln!(s, "| covered samples | {} |", n.covered_samples);
    let _ = writeln!(s, "| constant attributes | {} |", list(&constants));
    let _ = writeln!(s, "| absent attributes | {} |", list(&n.absent));
    let _ = writeln!(s, "| derivable attributes | {} |", list(&n.derivable));
    let mat = if n.material_count_capped {
        format!("more than {} (indirection not worthwhile)", n.material_count)
    } else {
        format!("{} → {} ID bits", n.material_count, n.material_id_bits.unwrap_or(0))
    };
    let _ = writeln!(s, "| distinct material tuples (specular, power, roughness, metallic) | {mat} |");
    let faces = match n.normals_face_camera {
        Some(true) => "yes: hemisphere encodings are safe".to_string(),
        Some(false) => format!(
            "no: {} covered samples have normal z ≤ 0 (min z {})",
            n.back_facing_normals,
            fmt_opt(n.min_normal_z.map(f64::from), 3)
        ),
        None => "no normals".into(),
    };
    let _ = writeln!(s, "| normals face the camera | {faces} |");
    if let Some([lo, hi]) = n.depth_range {
        let bits = n.depth_bits.map_or(String::new(), |b| {
            format!(
                "; at {} relative precision: {} bits linear, {} bits logarithmic",
                b.relative_precision, b.linear_bits, b.log_bits
            )
        });
        let _ = writeln!(s, "| depth range | {lo:.4} – {hi:.4}{bits} |");
    }
    for (k, [lo, hi]) in &n.ranges {
        let _ = writeln!(s, "| range of {k} | {lo:.4} – {hi:.4} |");
    }
    if let Some(p) = &n.pruned_layout {
        let _ = writeln!(
            s,
            "| pruned layout | `{}`: {} B/sample instead of {} (`{}`), saves {} B; RMSE {} (base {}){} |",
            p.name,
            p.bytes_per_sample,
            p.base_bytes_per_sample,
            p.base,
            p.bytes_saved,
            fmt_opt(p.rmse, 5),
            fmt_opt(p.base_rmse, 5),
            p.note.as_ref().map_or(String::new(), |n| format!(" — {n}"))
        );
        if !p.changes.is_empty() {
            let _ = writeln!(s, "| pruning | {} |", p.changes.join("; "));
        }
    }
    s
}

/// The results table.
#[must_use]
pub fn rows_table(rows: &[Row]) -> String {
    let culling = rows.iter().any(|r| r.culling.is_some());
    let mut s = String::from("| layout | B/sample | footprint MiB | detector |");
    if culling {
        s.push_str(" culling |");
    }
    s.push_str(
        " normal mean / p95 / max ° | depth rel max | PSNR dB | RMSE | layout RMSE | shaded | precision / recall | \
         encode ms | decode ms | detect ms | resolve ms | Pareto |\n|---|--:|--:|---|",
    );
    if culling {
        s.push_str("---|");
    }
    s.push_str("--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|---|\n");
    for r in rows {
        let pareto = match (r.pareto.bytes, r.pareto.time) {
            (true, true) => "bytes, time",
            (true, false) => "bytes",
            (false, true) => "time",
            (false, false) => "",
        };
        let _ = write!(
            s,
            "| {} | {} | {:.1} | {} |",
            r.layout,
            r.bytes_per_sample,
            r.footprint_bytes as f64 / (1024.0 * 1024.0),
            r.detector
        );
        if culling {
            let _ = write!(s, " {} |", r.culling.as_deref().unwrap_or("—"));
        }
        if let Some(e) = &r.error {
            let _ = writeln!(s, " error: {} | | | | | | | | | | | |", e.replace('|', "/"));
            continue;
        }
        let _ = writeln!(
            s,
            " {} / {} / {} | {} | {} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {pareto} |",
            fmt_opt(r.normal_mean_deg, 3),
            fmt_opt(r.normal_p95_deg, 3),
            fmt_opt(r.normal_max_deg, 3),
            fmt_opt(r.depth_rel_max, 6),
            fmt_opt(r.psnr_db, 2),
            fmt_opt(r.rmse, 5),
            fmt_opt(r.layout_rmse, 5),
            pct(r.shading_fraction),
            fmt_opt(r.precision, 3),
            fmt_opt(r.recall, 3),
            timing_cell(r, "encode"),
            timing_cell(r, "decode"),
            timing_cell(r, "detect"),
            timing_cell(r, "resolve"),
        );
    }
    let notes: Vec<String> =
        rows.iter().filter_map(|r| r.note.as_ref().map(|n| format!("- {} × {}: {n}", r.layout, r.detector))).collect();
    if !notes.is_empty() {
        s.push_str("\nNotes:\n");
        s.push_str(&notes.join("\n"));
        s.push('\n');
    }
    s
}

/// The whole `report.md`.
#[must_use]
pub fn to_markdown(rep: &Report) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# gbuf report: {}\n", rep.input);
    let _ = writeln!(
        s,
        "{}×{} pixels, {} samples per pixel, {:.1}% of samples covered, {} lights ({}). Sweep of {} rows took \
         {:.1} s; times are medians of {} runs with (min–max).\n",
        rep.width,
        rep.height,
        rep.samples,
        100.0 * rep.coverage,
        rep.lights,
        rep.lights_source,
        rep.rows.len(),
        rep.sweep_seconds,
        rep.runs
    );
    if let Some(t) = rep.reference {
        let _ = writeln!(
            s,
            "The reference (every sample shaded, unquantized G-buffer) took {:.1} ms ({:.1}–{:.1}).\n",
            t.median_ms, t.min_ms, t.max_ms
        );
    }
    s.push_str("## What the scene needs\n\n");
    s.push_str(&needs_section(&rep.needs));
    s.push_str("\n## Layouts × detectors\n\n");
    s.push_str(&rows_table(&rep.rows));
    s.push_str("\n## Pareto fronts\n\n");
    for (what, pick) in [("image RMSE against bytes per sample", true), ("image RMSE against run time", false)] {
        let mut names: Vec<String> = rep
            .rows
            .iter()
            .filter(|r| if pick { r.pareto.bytes } else { r.pareto.time })
            .map(|r| format!("{} × {}", r.layout, r.detector))
            .collect();
        names.dedup();
        let _ = writeln!(s, "- {what}: {}", if names.is_empty() { "none".into() } else { names.join(", ") });
    }
    if !rep.figures.is_empty() {
        s.push_str("\n## Figures\n\n");
        for f in &rep.figures {
            let _ = writeln!(s, "![{}]({})\n\n*{}*\n", f.caption, f.file, f.caption);
        }
    }
    s.push_str(
        "\n## Reading the numbers\n\n\
         - **B/sample**: bytes one MSAA sample takes in the layout's render targets; footprint = B/sample × pixels × \
         samples.\n\
         - **normal °**: angle between the stored and the decoded normal over covered samples.\n\
         - **PSNR / RMSE**: the lit image from the decoded G-buffer (shaded per pixel or per sample as the detector \
         decides) against the reference lit from the unquantized G-buffer with every sample shaded. PSNR is \
         infinite when the images are identical. It counts both the layout's quantization and the detector's \
         aliasing (edge samples shaded once).\n\
         - **layout RMSE**: the same lit image against the exact G-buffer lit with the same detector: what the \
         layout's quantization alone costs.\n\
         - **shaded**: shading evaluations / (pixels × samples): 100% is supersampling, 1/samples is one per pixel.\n\
         - **precision / recall**: of the detector's edge pixels against ground-truth edges (pixels whose samples \
         shade differently).\n\
         - **Pareto**: no other row has both less error and fewer bytes (or less run time).\n",
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::needs::analyze;
    use crate::GBuffer;

    #[test]
    fn markdown_has_every_row_and_figure() {
        let rows = vec![
            Row {
                layout: "fat-20".into(),
                bytes_per_sample: 20,
                detector: "depth".into(),
                rmse: Some(0.1),
                ..Default::default()
            },
            Row {
                layout: "bad".into(),
                detector: "depth".into(),
                error: Some("no | way".into()),
                ..Default::default()
            },
        ];
        let rep = Report {
            input: "room".into(),
            width: 4,
            height: 2,
            samples: 1,
            coverage: 0.0,
            lights: 0,
            lights_source: "none".into(),
            runs: 3,
            reference: None,
            sweep_seconds: 0.5,
            needs: analyze(&GBuffer::new(4, 2, 1).unwrap()),
            rows,
            figures: vec![crate::analysis::row::Figure { file: "a.png".into(), caption: "A plot".into() }],
        };
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
