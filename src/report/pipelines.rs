//! The pipelines comparison for a person: the markdown table of [`Pipelines`] (what `gbuf pipelines` prints and
//! `report.md` holds), the side-by-side "shading computations per pixel" heatmap of forward MSAA and deferred, and
//! the anti-aliasing picture (one crop under every method).

use crate::analysis::forward::QuadShading;
use crate::analysis::pipelines::{Pipeline, Pipelines};
use crate::base::mask::EdgeMask;
use crate::base::table::{Align, Table};
use crate::error::{Error, Result};
use crate::image::HdrImage;
use crate::report::figures::image_picture;
use crate::report::format::fmt_opt;
use crate::report::plot::Panels;
use image::RgbImage;
use std::fmt::Write as _;

/// The pipelines table, the schedules' utilisation table and the traffic formulas, as markdown. `level` is the
/// heading level of the sub-headings (`###` in a report, `##` alone).
#[must_use]
pub fn pipelines_markdown(p: &Pipelines, level: usize) -> String {
    let h = "#".repeat(level);
    let mut s = String::new();
    let (w, ht, n) = p.size;
    let _ = writeln!(
        s,
        "{w}×{ht} × {n} samples, {} lights; deferred rows: detector `{}`, layout `{}` ({} B/sample).\n",
        p.lights, p.detector, p.layout, p.gbuffer_bytes
    );
    use Align::{Left as L, Right as R};
    let mut t = Table::new([
        ("pipeline", L),
        ("footprint MB", R),
        ("traffic MB/frame", R),
        ("shading", R),
        ("light pairs", R),
        ("SIMD util.", R),
        ("CPU ms", R),
        ("RMSE", R),
        ("LDR-FLIP", R),
        ("note", L),
    ]);
    for r in &p.rows {
        let e = r.error.as_ref();
        t.row([
            format!("{}{}", r.pipeline, if r.estimated { " (est.)" } else { "" }),
            format!("{:.2}", r.footprint_mb),
            format!("{:.1}", r.bandwidth_mb),
            format!("{} {}", r.shading, r.shading_unit),
            r.light_pairs.to_string(),
            format!("{:.0}%", 100.0 * r.utilisation),
            fmt_opt(r.cpu_ms, 1),
            fmt_opt(e.map(|e| e.rmse), 5),
            fmt_opt(e.and_then(|e| e.flip_ldr), 4),
            r.note.clone(),
        ]);
    }
    s.push_str(&t.finish());
    // One line per reason (the forward rows share theirs).
    let mut reasons: Vec<&str> = p.skipped.iter().map(|(_, why)| why.as_str()).collect();
    reasons.dedup();
    for why in reasons {
        let names: Vec<&str> = p.skipped.iter().filter(|(_, w)| w == why).map(|(p, _)| p.name()).collect();
        let _ = writeln!(s, "\nNot measured: {}: {why}", names.join(", "));
    }
    if let Some(v) = &p.visibility_packing {
        let ids_ok = v.primitive_id_mismatches == 0 && v.object_id_mismatches == 0 && v.missing.is_empty();
        let _ = writeln!(
            s,
            "\nVisibility buffer layout `{}` ({} B per sample), packed and unpacked on this frame: triangle IDs {}, \
             instance IDs {}, depth {}{}.",
            v.layout,
            v.bytes,
            if v.primitive_id_mismatches == 0 {
                "exact".to_string()
            } else {
                format!("{} samples changed", v.primitive_id_mismatches)
            },
            if v.object_id_mismatches == 0 {
                "exact".to_string()
            } else {
                format!("{} samples changed", v.object_id_mismatches)
            },
            if v.depth_max_rel_error == 0.0 {
                "exact".to_string()
            } else {
                format!("max relative error {:.1e}", v.depth_max_rel_error)
            },
            if v.missing.is_empty() { String::new() } else { format!("; not stored: {}", v.missing.join(", ")) },
        );
        if !ids_ok {
            let _ = writeln!(s, "**The layout loses IDs this frame needs: its visibility row's counts stand, but re-materialisation from it would shade the wrong triangles.**");
        }
    }
    match (&p.rematerialised, &p.rematerialise_error) {
        (Some(r), _) => {
            let worst = r.attributes.iter().map(|a| a.max_abs).fold(0.0f64, f64::max);
            let exact = r.attributes.iter().all(|a| a.bit_exact + r.failed == r.samples);
            let _ = writeln!(
                s,
                "\nVisibility buffer, re-materialised from the `{}` scene's triangles: {} covered samples, {} failed; \
                 {} attributes ({}), largest difference from the G-buffer {:e}{}; {} arithmetic operations and {} bytes \
                 of triangle and material fetched per sample, against {} B of G-buffer read.",
                r.scene,
                r.samples,
                r.failed,
                r.attributes.len(),
                r.attributes.iter().map(|a| a.attribute.as_str()).collect::<Vec<_>>().join(", "),
                worst,
                if exact { " (every value bit-identical)" } else { "" },
                r.ops_per_sample,
                r.bytes_fetched_per_sample,
                p.gbuffer_bytes
            );
        }
        (None, Some(e)) => {
            let _ = writeln!(s, "\nVisibility buffer re-materialisation failed: {e}");
        }
        (None, None) if p.rows.iter().any(|r| r.pipeline == Pipeline::VisibilityBuffer) => {
            let _ = writeln!(
                s,
                "\nVisibility buffer: re-materialising the attributes needs the frame's triangles (vertex positions \
                 and normals per (object, primitive) ID) and its material table; gbuf has them for its own scenes \
                 (`--geometry room|stress`), not for an engine's dump."
            );
        }
        _ => {}
    }
    if let Some(q) = &p.forward_msaa {
        let _ = writeln!(
            s,
            "\nForward MSAA launches {} quads for {} triangles: {} lanes, of which {} cover their pixel and {} ({:.1}%) \
             are helper lanes; the deferred rows shade {} samples.",
            q.quads,
            q.triangles,
            q.lanes,
            q.covered_lanes,
            q.helper_lanes,
            100.0 * q.helper_fraction,
            p.rows.iter().find(|r| r.pipeline == Pipeline::TiledDeferred).map_or(0, |r| r.shading)
        );
    }
    if !p.utilisation.is_empty() {
        let _ = writeln!(
            s,
            "\n{h} MSAA schedules: SIMD lane utilisation (useful / issued lane-steps, detector `{}`)\n",
            p.detector
        );
        let mut warps: Vec<u32> = p.utilisation.iter().map(|u| u.warp).collect();
        warps.dedup();
        let mut t = Table::new(
            std::iter::once(("schedule".to_string(), Align::Left))
                .chain(warps.iter().map(|w| (format!("W={w}"), Align::Right))),
        );
        for sched in crate::analysis::forward::MsaaSchedule::ALL {
            t.row(std::iter::once(sched.to_string()).chain(warps.iter().map(|w| {
                let u = p.utilisation.iter().find(|u| u.warp == *w && u.schedule == Some(sched));
                u.map_or("—".into(), |u| format!("{:.1}%", 100.0 * u.ratio))
            })));
        }
        s.push_str(&t.finish());
    }
    if !p.schedules.is_empty() {
        let _ = writeln!(
            s,
            "\nThe same three schedules run by gbuf's resolve on this CPU ({}-lane vectors, tiled culling):\n",
            crate::resolve::kernel_lanes()
        );
        let mut t = Table::new([
            ("schedule", L),
            ("CPU ms", R),
            ("evaluations", R),
            ("lane steps", R),
            ("utilisation", R),
            ("light pairs", R),
            ("G-buffer bytes read", R),
            ("same image", L),
        ]);
        for r in &p.schedules {
            t.row([
                r.schedule.to_string(),
                format!("{:.1}", r.ms),
                r.evaluations.to_string(),
                r.lane_steps.to_string(),
                format!("{:.1}%", 100.0 * r.evaluations as f64 / r.lane_steps.max(1) as f64),
                r.light_pairs.to_string(),
                r.bytes_read.to_string(),
                if r.same_image { "yes" } else { "**no**" }.to_string(),
            ]);
        }
        s.push_str(&t.finish());
    }
    if !p.aa.is_empty() {
        let _ = writeln!(
            s,
            "\n{h} Anti-aliasing: no AA, MLAA (Reshetov 2009, on the no-AA image), adaptive MSAA, SSAA\n\n\
             MLAA found {} horizontal and {} vertical edges, {} L, {} Z and {} U shapes, and blended {} pixels.\n",
            p.mlaa.edges_h, p.mlaa.edges_v, p.mlaa.shapes_l, p.mlaa.shapes_z, p.mlaa.shapes_u, p.mlaa.blended_pixels
        );
        if let Some(no_aa) = p.aa.first().filter(|r| !r.note.is_empty()) {
            let _ = writeln!(s, "The no-AA image is {}.\n", no_aa.note);
        }
        let mut t = Table::new([
            ("method", L),
            ("evaluations", R),
            ("G-buffer MB", R),
            ("CPU ms", R),
            ("RMSE", R),
            ("LDR-FLIP", R),
            ("HDR-FLIP", R),
        ]);
        for r in &p.aa {
            t.row([
                r.method.clone(),
                r.evaluations.to_string(),
                format!("{:.2}", r.footprint_mb),
                format!("{:.1}", r.ms),
                fmt_opt(Some(r.error.rmse), 5),
                fmt_opt(r.error.flip_ldr, 4),
                fmt_opt(r.error.flip_hdr, 4),
            ]);
        }
        s.push_str(&t.finish());
        for r in p.aa.iter().filter(|r| r.method.starts_with("vrs:")) {
            let _ = writeln!(s, "\n`{}`: {} (`gbuf vrs` compares generators and tile sizes).", r.method, r.note);
        }
        s.push_str(&aa_losers_note(&p.aa));
    }
    if let Some(first) = p.compressed.first() {
        let _ = writeln!(
            s,
            "\n{h} Compressed MSAA G-buffer (Kerzner & Salvi 2014's K surface slots per pixel; AGAA-style depth-layer \
             aggregates, Crassin et al. 2015; one evaluation each)\n\n\
             Fragments rebuilt from the dump's {}; each slot holds the {} fields ({} B) and a coverage word: {} B per \
             slot, plus 8 B per pixel. The full {}× G-buffer takes {} B per pixel.\n",
            match first.fragments_from {
                crate::analysis::compress::FragmentKey::ObjectPrimitive => "object and primitive IDs, in ID order",
                crate::analysis::compress::FragmentKey::ObjectMaterial => "object/material IDs, in ID order",
                crate::analysis::compress::FragmentKey::Geometry => "geometry (no IDs), in sample order",
            },
            p.layout,
            p.gbuffer_bytes,
            first.slot_bytes,
            p.size.2,
            first.full_bytes_per_pixel
        );
        let mut t = Table::new([
            ("method", L),
            ("slots", R),
            ("B/pixel", R),
            ("vs full", R),
            ("MB", R),
            ("evaluations", R),
            ("evicted samples", R),
            ("discarded pixels", R),
            ("CPU ms", R),
            ("RMSE", R),
            ("LDR-FLIP", R),
            ("HDR-FLIP", R),
        ]);
        for r in &p.compressed {
            t.row([
                match r.method {
                    crate::analysis::compress::Method::Streaming => "streaming",
                    crate::analysis::compress::Method::Aggregate => "aggregates",
                }
                .to_string(),
                r.slots.to_string(),
                r.bytes_per_pixel.to_string(),
                format!("{:.0}%", 100.0 * f64::from(r.bytes_per_pixel) / f64::from(r.full_bytes_per_pixel.max(1))),
                format!("{:.2}", r.footprint_mb),
                r.evaluations.to_string(),
                format!("{:.3}%", 100.0 * r.evicted_fraction),
                r.discarded_pixels.to_string(),
                format!("{:.1}", r.ms),
                fmt_opt(Some(r.error.rmse), 5),
                fmt_opt(r.error.flip_ldr, 4),
                fmt_opt(r.error.flip_hdr, 4),
            ]);
        }
        s.push_str(&t.finish());
    }
    let _ = writeln!(s, "\n{h} Traffic model ({})\n", crate::analysis::traffic::legend());
    for r in &p.rows {
        let _ = writeln!(s, "- {}: {}", r.pipeline, r.pipeline.bandwidth_formula());
    }
    s
}

/// Forward MSAA's lanes per pixel (left) beside the deferred mask's evaluations per pixel (right), on one colour
/// scale with a numbered colour bar, axes and a title, as a PNG in memory (a 2-pixel grey gap between), and the
/// scale's maximum.
pub fn shading_heatmaps_png(forward: &QuadShading, deferred: &EdgeMask) -> Result<(Vec<u8>, u32)> {
    let (w, h) = (deferred.width as usize, deferred.height as usize);
    if forward.lanes_per_pixel.len() != w * h {
        return Err(Error::Mismatch(format!(
            "forward counts for {} pixels, mask of {w}×{h}",
            forward.lanes_per_pixel.len()
        )));
    }
    const GAP: usize = 2;
    let width = 2 * w + GAP;
    let mut values = vec![None; width * h];
    for y in 0..h {
        for x in 0..w {
            values[y * width + x] = Some(forward.lanes_per_pixel[y * w + x] as f32);
            values[y * width + w + GAP + x] = Some(f32::from(deferred.shade_count[y * w + x]));
        }
    }
    let max = values.iter().flatten().fold(1.0f32, |a, &b| a.max(b));
    // As the report's heatmaps: at most twice its picture width of grid, room for the title, axes and colour bar.
    let grid_w = (width as u32).clamp(1, 2 * crate::report::figures::MAX_PICTURE_WIDTH);
    let grid_h = (u64::from(h as u32) * u64::from(grid_w) / width as u64).max(1) as u32;
    let (pw, ph) = ((grid_w + 190).max(crate::report::plot::MIN_SIZE.0), (grid_h + 90).max(300));
    let img = crate::report::plot::Heatmap {
        title: "Forward MSAA fragment-shader lanes (left) and deferred shading evaluations (right) per pixel".into(),
        values: &values,
        width: width as u32,
        height: h as u32,
        max,
        label: "per pixel".into(),
    }
    .to_png_image(pw, ph)?;
    Ok((crate::base::picture::png_bytes(&img)?, max as u32))
}

/// Each crop pixel is drawn as a square of this many picture pixels (nearest neighbour, so aliasing stays visible).
pub const AA_CROP_ZOOM: u32 = 4;

/// Why an adaptive MSAA row can err more than no AA at all, said under the table when one does: its pixels
/// without an edge are shaded once, at sample 0, which sits off the pixel centre; where the shading changes fast
/// across a pixel (a sharp highlight, a light close to the surface) one off-centre sample misses or catches what
/// the every-sample reference averages, while the no-AA image is shaded at the centre (or is that same sample 0,
/// when no 1-sample render was given).
fn aa_losers_note(rows: &[crate::analysis::pipelines::AaRow]) -> String {
    let Some(no_aa) = rows.iter().find(|r| r.method == "no-aa") else { return String::new() };
    let losers: Vec<String> = rows
        .iter()
        .filter(|r| r.method.starts_with("msaa:") && r.error.rmse > no_aa.error.rmse)
        .map(|r| {
            format!(
                "{} (RMSE {} against {})",
                r.method,
                fmt_opt(Some(r.error.rmse), 4),
                fmt_opt(Some(no_aa.error.rmse), 4)
            )
        })
        .collect();
    if losers.is_empty() {
        return String::new();
    }
    format!(
        "\n**Why adaptive MSAA can lose to no AA here:** {} errs more than no AA. Adaptive MSAA shades each pixel \
         without a detected edge once, at sample 0, which sits off the pixel centre; where the shading varies \
         sharply inside a pixel (narrow specular highlights from low roughness or high specular powers, lights close \
         to a surface) that one off-centre sample misses or catches what the every-sample reference averages over \
         the pixel. The no-AA image is {}. The error is the schedule's, not the detector's edges: compare the \
         detectors' shading against the SSAA row.\n",
        losers.join(", "),
        if no_aa.note.is_empty() { "shaded at the pixel centre".to_string() } else { no_aa.note.clone() }
    )
}

/// `img` as the report shows images ([`image_picture`]: Reinhard, sRGB), magnified `zoom` times (nearest
/// neighbour).
fn zoomed_picture(img: &HdrImage, zoom: u32) -> RgbImage {
    image::imageops::resize(
        &image_picture(img),
        img.width * zoom,
        img.height * zoom,
        image::imageops::FilterType::Nearest,
    )
}

/// The anti-aliasing picture: the same crop (`aa_crop` of the no-AA image) of the every-sample reference and of
/// each method's image in [`Pipelines::aa`], magnified [`AA_CROP_ZOOM`]×, each captioned with its method and error
/// (LDR-FLIP when measured, else RMSE). Returns the picture and the crop.
pub fn aa_crop_picture(p: &Pipelines, reference: &HdrImage) -> Result<(RgbImage, (u32, u32, u32, u32))> {
    let crop = p.aa_crop;
    let (x, y, cw, ch) = crop;
    if p.aa_images.is_empty() {
        return Err(Error::Argument("no anti-aliasing images to show".into()));
    }
    if p.aa_images.len() != p.aa.len()
        || p.aa_images.iter().any(|i| (i.width, i.height) != (cw, ch))
        || x + cw > reference.width
        || y + ch > reference.height
    {
        return Err(Error::Mismatch(format!(
            "anti-aliasing crops ({}) do not match the rows ({}), their {cw}×{ch} rectangle at ({x}, {y}), or the \
             reference's size {}×{}",
            p.aa_images.len(),
            p.aa.len(),
            reference.width,
            reference.height
        )));
    }
    let zoom = AA_CROP_ZOOM;
    let mut panels = vec![("reference (every sample)".to_string(), zoomed_picture(&reference.crop(crop), zoom))];
    for (row, img) in p.aa.iter().zip(&p.aa_images) {
        let err = match row.error.flip_ldr {
            Some(f) => format!("LDR-FLIP {f:.4}"),
            None => format!("RMSE {:.4}", row.error.rmse),
        };
        panels.push((format!("{} · {err}", row.method), zoomed_picture(img, zoom)));
    }
    let title = format!(
        "The same {}×{} crop at ({}, {}) under each method, {}× (crop of largest no-AA error)",
        crop.2, crop.3, crop.0, crop.1, AA_CROP_ZOOM
    );
    let pic = Panels { title, panels, columns: 4 }.to_png_image()?;
    Ok((pic, crop))
}
