//! The figures of a report: error against bytes and against run time (PNG + SVG), per-attribute error heatmaps
//! of the worst layouts, the edge masks of each detector and the light-count heatmap.

use crate::analysis::aggregate::{AggregateRow, Over};
use crate::analysis::pareto;
use crate::analysis::record::Figure;
use crate::analysis::row::Row;
use crate::analysis::sweep::SweepOutput;
use crate::base::mask::EdgeMask;
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::io::raw::{RawChannel, RawData, RawImage};
use crate::report::format::Attachment;
use crate::report::plot::{self, PlotPoint, ScatterPlot};
use image::{Rgb, RgbImage};

/// Size of the scatter plots in pixels.
pub const PLOT_SIZE: (u32, u32) = (720, 440);

/// How many of the worst layouts get error heatmaps (the sweep keeps the maps of that many).
pub const WORST_LAYOUTS: usize = crate::analysis::sweep::HEATMAP_LAYOUTS;

/// Heatmaps wider than this are downscaled (nearest pixel) to keep the report folder small.
pub const MAX_PICTURE_WIDTH: u32 = 960;

/// One point per layout: its row with the least layout error (over detectors and culling modes), with the Pareto
/// front of those points. The y axis is logarithmic when the errors span more than a factor of 20; layouts with
/// layout error 0 (lossless) sit on the axis of a linear plot and are left out of a logarithmic one.
fn scatter<'a>(
    rows: impl IntoIterator<Item = (&'a str, Option<f64>, Option<f64>)>,
    title: &str,
    x_label: &str,
    y_what: &str,
) -> ScatterPlot {
    let mut best: Vec<(&str, f64, f64)> = Vec::new();
    for (layout, xv, y) in rows {
        let (Some(xv), Some(y)) = (xv, y) else { continue };
        if !(xv.is_finite() && y.is_finite()) {
            continue;
        }
        match best.iter_mut().find(|b| b.0 == layout) {
            Some(b) if y < b.2 => *b = (layout, xv, y),
            Some(_) => {}
            None => best.push((layout, xv, y)),
        }
    }
    let front = pareto::front(&best.iter().map(|b| (b.1, b.2)).collect::<Vec<_>>());
    let (lo, hi) =
        best.iter().filter(|p| p.2 > 0.0).fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.2), b.max(p.2)));
    let log_y = lo > 0.0 && hi / lo > 20.0;
    if log_y {
        best.retain(|p| p.2 > 0.0);
    }
    let points = best
        .iter()
        .zip(front)
        .map(|(b, f)| PlotPoint { x: b.1, y: b.2, label: b.0.to_string(), on_front: f })
        .collect();
    let y_label = if log_y { format!("{y_what} (log)") } else { y_what.to_string() };
    ScatterPlot { title: title.into(), x_label: x_label.into(), y_label, log_x: None, log_y: Some(log_y), points }
}

/// A heatmap plot of per-pixel `values` with axes and a colour bar, at most [`MAX_PICTURE_WIDTH`] pixels of grid.
fn heat_plot(title: String, values: &[Option<f32>], gb: &GBuffer, max: f32, label: String) -> Result<RgbImage> {
    let grid_w = gb.width.clamp(1, MAX_PICTURE_WIDTH);
    let grid_h = (u64::from(gb.height) * u64::from(grid_w) / u64::from(gb.width.max(1))).max(1) as u32;
    // At least 300 pixels tall: the colour bar and its label need the room on a small frame.
    let (w, h) = (grid_w + 190, (grid_h + 90).max(300));
    let (w, h) = (w.max(plot::MIN_SIZE.0), h.max(plot::MIN_SIZE.1));
    plot::Heatmap { title, values, width: gb.width, height: gb.height, max, label }.to_png_image(w, h)
}

/// Downscales (nearest) so the width is at most [`MAX_PICTURE_WIDTH`].
fn fit(img: RgbImage) -> RgbImage {
    if img.width() <= MAX_PICTURE_WIDTH {
        return img;
    }
    let k = img.width().div_ceil(MAX_PICTURE_WIDTH);
    let (w, h) = (img.width() / k, (img.height() / k).max(1));
    RgbImage::from_fn(w, h, |x, y| *img.get_pixel(x * k, y * k))
}

fn percentile_max(v: &[Option<f32>]) -> f32 {
    let mut vals: Vec<f32> = v.iter().flatten().copied().filter(|x| x.is_finite()).collect();
    if vals.is_empty() {
        return 0.0;
    }
    // Scale to the 99.5th percentile so a few outliers do not wash out the map.
    let k = ((vals.len() as f64 * 0.995) as usize).min(vals.len() - 1);
    let (_, m, _) = vals.select_nth_unstable_by(k, f32::total_cmp);
    *m
}

/// An edge-mask picture: per-sample pixels white, once-shaded pixels dim grey, background black.
#[must_use]
fn mask_picture(mask: &EdgeMask) -> RgbImage {
    RgbImage::from_fn(mask.width, mask.height, |x, y| match mask.shade_count[(y * mask.width + x) as usize] {
        0 => Rgb([0, 0, 0]),
        1 => Rgb([70, 70, 70]),
        _ => Rgb([255, 255, 255]),
    })
}

/// The picture of the reference image, tone-mapped (Reinhard) and sRGB-encoded.
#[must_use]
pub fn image_picture(img: &crate::image::HdrImage) -> RgbImage {
    RgbImage::from_raw(img.width, img.height, img.to_srgb8(crate::image::ToneMap::default()))
        .expect("an HdrImage holds width × height pixels")
}

/// Writes the two scatter plots (PNG + SVG) of a report: layout error against bytes and against time.
fn plot_pair(
    files: &mut Vec<Attachment>,
    figs: &mut Vec<Figure>,
    by_bytes: &ScatterPlot,
    by_time: &ScatterPlot,
    over: &str,
) -> Result<()> {
    let (w, h) = PLOT_SIZE;
    for (stem, p, what) in
        [("error_vs_bytes", by_bytes, "bytes per sample"), ("error_vs_time", by_time, "resolve pass time")]
    {
        let name = format!("{stem}.png");
        files.push(Attachment { name: name.clone(), bytes: crate::base::picture::png_bytes(&p.to_png_image(w, h)?)? });
        figs.push(Figure {
            file: name,
            caption: format!(
                "Layout error{over} against {what}, one point per layout (its best detector); the Pareto front in red \
                 (SVG: {stem}.svg)"
            ),
            against: None,
        });
        files.push(Attachment { name: format!("{stem}.svg"), bytes: p.to_svg(w, h)?.into_bytes() });
    }
    Ok(())
}

/// The plots of a report over several frames: each layout's aggregated layout error (mean or worst frame).
pub fn aggregate_figures(rows: &[AggregateRow], over: Over) -> Result<(Vec<Attachment>, Vec<Figure>)> {
    let (mut files, mut figs) = (Vec::new(), Vec::new());
    let ok = || rows.iter().filter(|r| r.failed_frames == 0);
    let err = |r: &AggregateRow| r.layout_rmse.as_ref().map(|s| s.over(over));
    let y = format!("layout error, {} frame (RMSE)", over.name());
    let by_bytes = scatter(
        ok().map(|r| (r.layout.as_str(), Some(f64::from(r.bytes_per_sample)), err(r))),
        "Layout error over all frames vs bytes per sample",
        "bytes per sample",
        &y,
    );
    let by_time = scatter(
        ok().map(|r| (r.layout.as_str(), r.resolve_pass_ms.as_ref().map(|s| s.mean), err(r))),
        "Layout error over all frames vs resolve pass time",
        "mean decode + resolve (ms)",
        &y,
    );
    plot_pair(&mut files, &mut figs, &by_bytes, &by_time, &format!(" ({} frame)", over.name()))?;
    Ok((files, figs))
}

/// Builds every figure of one frame's sweep (with the two scatter plots when `with_plots`; a report over several
/// frames draws them from the aggregate instead). `prefix` starts every file name. Returns the files and their
/// captions.
pub fn figures(
    gb: &GBuffer,
    preview: Option<&dyn crate::detect::rate::Preview>,
    out: &SweepOutput,
    with_plots: bool,
    prefix: &str,
) -> Result<(Vec<Attachment>, Vec<Figure>)> {
    let mut files = Vec::new();
    let mut figs = Vec::new();
    let png = |name: &str,
               img: RgbImage,
               caption: String,
               files: &mut Vec<Attachment>,
               figs: &mut Vec<Figure>|
     -> Result<()> {
        let name = format!("{prefix}{name}");
        files.push(Attachment { name: name.clone(), bytes: crate::base::picture::png_bytes(&fit(img))? });
        figs.push(Figure { file: name, caption, against: None });
        Ok(())
    };
    if with_plots {
        let rows = || out.rows.iter().filter(|r| r.error.is_none());
        let by_bytes = scatter(
            rows().map(|r| (r.layout.as_str(), Some(f64::from(r.bytes_per_sample)), r.layout_rmse())),
            "Layout error vs bytes per sample",
            "bytes per sample",
            "layout error (image RMSE)",
        );
        let by_time = scatter(
            rows().map(|r| (r.layout.as_str(), r.resolve_pass_ms, r.layout_rmse())),
            "Layout error vs resolve pass time",
            "decode + resolve (ms)",
            "layout error (image RMSE)",
        );
        plot_pair(&mut files, &mut figs, &by_bytes, &by_time, "")?;
    }
    png(
        "reference.png",
        image_picture(&out.reference),
        "The reference image (every sample shaded, unquantized G-buffer), tone-mapped".into(),
        &mut files,
        &mut figs,
    )?;
    // A/B views: each layout's displayed image against the reference's, on the crop where the worst layout's FLIP
    // is largest (the report page flickers between them on a click and wipes with a slider).
    if let Some(reference) = out.reference_shown.as_ref().filter(|_| !out.shown.is_empty()) {
        let (w, h) = (out.reference.width, out.reference.height);
        let (cw, ch) = (w.min(AB_CROP[0]), h.min(AB_CROP[1]));
        let (x0, y0) = match &out.worst_flip {
            Some((_, map)) if map.values.len() == (w * h) as usize => {
                crate::base::picture::busiest_window(&map.values, w, h, cw, ch)
            }
            _ => ((w - cw) / 2, (h - ch) / 2),
        };
        let zoom = 2;
        let crop = |rgb: &[u8]| -> RgbImage {
            let mut img = RgbImage::new(cw * zoom, ch * zoom);
            for (x, y, px) in img.enumerate_pixels_mut() {
                let i = 3 * (((y0 + y / zoom) * w + x0 + x / zoom) as usize);
                *px = image::Rgb([rgb[i], rgb[i + 1], rgb[i + 2]]);
            }
            img
        };
        let ab_reference = format!("{prefix}ab_reference.png");
        png(
            "ab_reference.png",
            crop(reference),
            format!(
                "The reference, {cw}×{ch} pixels at ({x0}, {y0}) magnified {zoom}×: where the A/B views below look"
            ),
            &mut files,
            &mut figs,
        )?;
        for (layout, rgb) in &out.shown {
            if rgb.len() != reference.len() {
                continue;
            }
            let slug: String = layout.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
            let file = format!("{prefix}ab_{slug}.png");
            files.push(Attachment { name: file.clone(), bytes: crate::base::picture::png_bytes(&crop(rgb))? });
            figs.push(Figure {
                file,
                caption: format!(
                    "A/B: {layout} (lit with the first detector) against the reference, same crop (the page: click to \
                     flicker, drag the slider to wipe)"
                ),
                against: Some(ab_reference.clone()),
            });
        }
        // Beside them, where shading less than once per pixel is safe: gbuf's shading-rate image over the reference.
        // (Only where the frame gives the detector what it reads: the figure is an illustration, not a measurement.)
        let tile = crate::analysis::pipelines::VRS_TILE;
        let sri = crate::detect::detect(gb, crate::detect::Detector::Lauritzen, &Default::default())
            .and_then(|mask| crate::detect::rate::gbuffer_sri(gb, preview, &mask, tile, false, &Default::default()));
        if let Ok(sri) = sri {
            let rates = sri.picture(w, h);
            let over: Vec<u8> =
                reference.iter().zip(&rates).map(|(&a, &b)| ((u16::from(a) + u16::from(b)) / 2) as u8).collect();
            let coarse = 1.0 - sri.histogram()[0] as f64 / sri.rates.len().max(1) as f64;
            let file = format!("{prefix}ab_shading_rate.png");
            files.push(Attachment { name: file.clone(), bytes: crate::base::picture::png_bytes(&crop(&over))? });
            figs.push(Figure {
                file,
                caption: format!(
                    "A/B: gbuf's shading-rate image (tile {tile}, from the G-buffer{} and the lauritzen mask, before \
                     the lighting) over the reference, same crop: green 1×1, blue 2×1, cyan 1×2, yellow 2×2; {:.0}% \
                     of the frame's tiles shade coarser than once per pixel (`gbuf vrs` measures what that costs)",
                    if preview.is_some() { ", a preview of its lights" } else { "" },
                    100.0 * coarse
                ),
                against: Some(ab_reference.clone()),
            });
        }
    }
    if let Some((name, map)) = &out.worst_flip {
        let img =
            RgbImage::from_raw(map.width as u32, map.height as u32, crate::measure::flip::flip_map_to_magma_rgb8(map))
                .expect("a FLIP map holds width × height values");
        png(
            "flip_worst_layout.png",
            img,
            format!(
                "LDR-FLIP error map of {name}, the layout with the largest layout FLIP (mean {:.4}; magma: black = no \
                 visible difference, yellow = the largest)",
                map.mean
            ),
            &mut files,
            &mut figs,
        )?;
    }

    // The worst layouts by their best layout error.
    let mut worst: Vec<(&str, f64)> = Vec::new();
    for m in &out.maps {
        let best =
            out.rows.iter().filter(|r| r.layout == m.layout).filter_map(Row::layout_rmse).fold(f64::NAN, f64::min);
        if best.is_finite() {
            worst.push((&m.layout, best));
        }
    }
    worst.sort_by(|a, b| b.1.total_cmp(&a.1));
    for (name, _) in worst.iter().take(WORST_LAYOUTS) {
        let Some(m) = out.maps.iter().find(|m| m.layout == *name) else { continue };
        let slug: String = name.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
        // The same maps as floats, one channel each, for tev or any EXR viewer (NaN = background).
        let channels: Vec<RawChannel> = [
            ("normal_deg", &m.normal_deg),
            ("depth_rel", &m.depth_rel),
            ("albedo_abs", &m.albedo_abs),
            ("image_abs", &m.image_abs),
        ]
        .into_iter()
        .filter_map(|(c, v)| v.as_ref().map(|v| RawChannel { name: c.into(), data: RawData::F32(v.clone()) }))
        .collect();
        if !channels.is_empty() {
            let file = format!("{prefix}error_maps_{slug}.exr");
            let names: Vec<String> = channels.iter().map(|c| c.name.clone()).collect();
            let raw = RawImage { width: gb.width, height: gb.height, channels, ..Default::default() };
            files.push(Attachment {
                name: file.clone(),
                bytes: crate::io::exr::raw_to_bytes(std::path::Path::new(&file), &raw)?,
            });
            figs.push(Figure {
                file,
                caption: format!(
                    "{name}: the per-pixel error maps as floats (channels {}; NaN = background), for tev",
                    names.join(", ")
                ),
                against: None,
            });
        }
        // The colour bar's label stays short (it runs along the bar, as tall as a small frame); the caption says it
        // in full.
        for (what, short, unit, map) in [
            ("normal", "°", "degrees", &m.normal_deg),
            ("depth", "relative", "relative", &m.depth_rel),
            ("albedo", "absolute", "absolute", &m.albedo_abs),
            ("image", "radiance", "absolute radiance against the exact G-buffer's image", &m.image_abs),
        ] {
            let Some(v) = map else { continue };
            let v: Vec<Option<f32>> = v.iter().map(|&e| (!e.is_nan()).then_some(e)).collect();
            let max = percentile_max(&v);
            png(
                &format!("heatmap_{slug}_{what}.png"),
                heat_plot(format!("{name}: {what} error"), &v, gb, max, format!("{what} error ({short})"))?,
                format!("{name}: per-pixel {what} error ({unit}; the colour bar's top = {max:.3e} or more, grey = background)"),
                &mut files,
                &mut figs,
            )?;
        }
    }
    for (det, mask) in &out.masks {
        png(
            &format!("edges_{det}.png"),
            mask_picture(mask),
            format!("Edge mask of {det}: white = shaded per sample ({:.1}% of pixels)", 100.0 * mask.edge_fraction()),
            &mut files,
            &mut figs,
        )?;
    }
    if let Some(lpp) = &out.lights_per_pixel {
        let v: Vec<Option<f32>> = lpp.iter().map(|&n| Some(n as f32)).collect();
        let max = lpp.iter().copied().max().unwrap_or(0) as f32;
        png(
            "lights_per_pixel.png",
            heat_plot("Lights per pixel after culling".into(), &v, gb, max, "lights evaluated".into())?,
            format!("Lights reaching each pixel after culling (colour bar: 0 to {max})"),
            &mut files,
            &mut figs,
        )?;
    }
    Ok((files, figs))
}
/// The largest crop of the A/B views (before magnification).
const AB_CROP: [u32; 2] = [320, 180];

/// The heatmap of how many surfaces each pixel holds (by identity when the frame has IDs, else by geometry; grey
/// where no sample is covered): where MSAA G-buffer compression would keep more than one surface. `None` for a
/// 1-sample frame or one without IDs and geometry.
pub fn surfaces_figure(
    gb: &GBuffer,
    maps: &crate::analysis::surfaces::SurfaceMaps,
    prefix: &str,
) -> Result<Option<(Attachment, Figure)>> {
    let (how, counts) = match (&maps.by_identity, &maps.by_geometry) {
        _ if gb.samples < 2 => return Ok(None),
        (Some(m), _) => (format!("by {} IDs", maps.identity_key.unwrap_or("")), m),
        (None, Some(m)) => ("by geometry (depth plane and normal)".to_string(), m),
        (None, None) => return Ok(None),
    };
    let values: Vec<Option<f32>> = counts.iter().map(|&k| (k > 0).then_some(f32::from(k))).collect();
    let max = gb.samples as f32;
    let img = heat_plot(format!("Surfaces per pixel, {how}"), &values, gb, max, "surfaces".into())?;
    let name = format!("{prefix}surfaces_per_pixel.png");
    let caption = format!(
        "Surfaces per pixel, {how} (colour bar to {max}; grey = no covered sample): pixels above 1 are where a \
         compressed MSAA G-buffer needs more than one surface slot"
    );
    Ok(Some((
        Attachment { name: name.clone(), bytes: crate::base::picture::png_bytes(&img)? },
        Figure { file: name, caption, against: None },
    )))
}

/// The "shading computations per pixel" pair of a frame: forward MSAA's fragment-shader lanes (helpers included)
/// and the deferred mask's shading evaluations, on one colour scale so the two compare.
pub fn shading_figures(
    gb: &GBuffer,
    forward: &crate::analysis::forward::QuadShading,
    (detector, mask): (&str, &EdgeMask),
    prefix: &str,
) -> Result<(Vec<Attachment>, Vec<Figure>)> {
    let fwd: Vec<Option<f32>> = forward.lanes_per_pixel.iter().map(|&n| Some(n as f32)).collect();
    let def: Vec<Option<f32>> = mask.shade_count.iter().map(|&n| Some(f32::from(n))).collect();
    let max = fwd.iter().chain(&def).flatten().fold(1.0f32, |a, &b| a.max(b));
    let mut files = Vec::new();
    let mut figs = Vec::new();
    for (stem, what, values) in [
        ("forward_msaa", "forward MSAA: fragment-shader lanes", &fwd),
        ("deferred", "deferred: shading evaluations", &def),
    ] {
        let name = format!("{prefix}shading_per_pixel_{stem}.png");
        let img = heat_plot(format!("{what} per pixel"), values, gb, max, "per pixel".into())?;
        files.push(Attachment { name: name.clone(), bytes: crate::base::picture::png_bytes(&img)? });
        figs.push(Figure {
            file: name,
            caption: format!(
                "Shading computations per pixel, {what}{} (same scale, top = {max})",
                if stem == "deferred" { format!(" with `{detector}`") } else { String::new() }
            ),
            against: None,
        });
    }
    Ok((files, figs))
}
