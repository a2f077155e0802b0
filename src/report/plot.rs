//! Plots and pictures, drawn by hand with the `image` crate (PNG) and as SVG text: error-against-cost scatter plots
//! with the Pareto front, and heatmaps (per-attribute error, light count, edge mask).
//!
//! The plots are meant to be read next to the tables of `report.md`, so they stay simple: linear or log axes with
//! "nice" ticks, one labelled point per row, the front as a polyline.

use crate::base::picture::colormap;
pub use crate::base::picture::{png_bytes, write_png};
use crate::report::font;
use image::{Rgb, RgbImage};
use std::fmt::Write as _;

/// One point of a scatter plot.
#[derive(Clone, Debug)]
pub struct PlotPoint {
    /// Cost (x).
    pub x: f64,
    /// Error (y).
    pub y: f64,
    /// Short label drawn next to the point.
    pub label: String,
    /// On the Pareto front (drawn filled and joined by the front line).
    pub on_front: bool,
}

/// An error-against-cost scatter plot.
#[derive(Clone, Debug)]
pub struct ScatterPlot {
    /// Title above the plot.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Log scale on y (values ≤ 0 are drawn on the bottom edge).
    pub log_y: bool,
    /// The points; non-finite ones are skipped.
    pub points: Vec<PlotPoint>,
}

const BG: Rgb<u8> = Rgb([255, 255, 255]);
const INK: Rgb<u8> = Rgb([30, 30, 30]);
const GRID: Rgb<u8> = Rgb([225, 225, 225]);
const FRONT: Rgb<u8> = Rgb([200, 40, 40]);
const OTHER: Rgb<u8> = Rgb([60, 90, 180]);

/// Plot area margins in pixels (left, right, top, bottom).
const MARGIN: (f64, f64, f64, f64) = (70.0, 30.0, 36.0, 50.0);

/// Axis mapping shared by the PNG and SVG renderers.
struct Frame {
    w: f64,
    h: f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    log_y: bool,
}

impl Frame {
    fn new(plot: &ScatterPlot, w: u32, h: u32) -> Frame {
        let pts: Vec<&PlotPoint> = plot.points.iter().filter(|p| p.x.is_finite() && p.y.is_finite()).collect();
        let (mut x0, mut x1) = min_max(pts.iter().map(|p| p.x)).unwrap_or((0.0, 1.0));
        let ys = pts.iter().map(|p| p.y).filter(|&y| !plot.log_y || y > 0.0);
        let (mut y0, mut y1) = min_max(ys).unwrap_or((1e-3, 1.0));
        if plot.log_y {
            y0 = y0.log10().floor();
            y1 = y1.log10().ceil();
            if y1 <= y0 {
                y1 = y0 + 1.0;
            }
        } else {
            pad(&mut y0, &mut y1);
        }
        pad(&mut x0, &mut x1);
        Frame { w: f64::from(w), h: f64::from(h), x0, x1, y0, y1, log_y: plot.log_y }
    }
    fn px(&self, x: f64) -> f64 {
        MARGIN.0 + (x - self.x0) / (self.x1 - self.x0) * (self.w - MARGIN.0 - MARGIN.1)
    }
    fn py(&self, y: f64) -> f64 {
        let v = if self.log_y {
            if y > 0.0 {
                y.log10()
            } else {
                self.y0
            }
        } else {
            y
        };
        let t = ((v - self.y0) / (self.y1 - self.y0)).clamp(0.0, 1.0);
        self.h - MARGIN.3 - t * (self.h - MARGIN.2 - MARGIN.3)
    }
    fn x_ticks(&self) -> Vec<(f64, String)> {
        nice_ticks(self.x0, self.x1, 6).into_iter().map(|t| (t, fmt_tick(t))).collect()
    }
    fn y_ticks(&self) -> Vec<(f64, String)> {
        if self.log_y {
            let (a, b) = (self.y0 as i32, self.y1 as i32);
            (a..=b).map(|e| (10f64.powi(e), format!("1E{e}"))).collect()
        } else {
            nice_ticks(self.y0, self.y1, 6).into_iter().map(|t| (t, fmt_tick(t))).collect()
        }
    }
}

fn min_max(it: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    it.fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((a, b)) => Some((a.min(v), b.max(v))),
    })
}

fn pad(lo: &mut f64, hi: &mut f64) {
    let span = *hi - *lo;
    let p = if span > 0.0 { span * 0.08 } else { lo.abs().max(1.0) * 0.1 };
    *lo -= p;
    *hi += p;
}

/// Round tick values (1, 2, 5 × 10^k steps) covering [lo, hi].
#[must_use]
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return vec![lo];
    }
    let raw = (hi - lo) / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|i| i as f64 * step).collect()
}

fn fmt_tick(t: f64) -> String {
    if t == 0.0 {
        "0".into()
    } else if t.abs() >= 1e4 || t.abs() < 1e-2 {
        format!("{t:.0E}")
    } else if t.fract().abs() < 1e-9 {
        format!("{t:.0}")
    } else {
        let s = format!("{t:.3}");
        s.trim_end_matches('0').to_string()
    }
}

/// A drawing surface over an `RgbImage` with clipping.
struct Canvas(RgbImage);

impl Canvas {
    fn put(&mut self, x: i32, y: i32, c: Rgb<u8>) {
        if x >= 0 && y >= 0 && (x as u32) < self.0.width() && (y as u32) < self.0.height() {
            self.0.put_pixel(x as u32, y as u32, c);
        }
    }
    fn line(&mut self, a: (f64, f64), b: (f64, f64), c: Rgb<u8>, thick: i32) {
        let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as i32).max(1);
        for i in 0..=n {
            let t = f64::from(i) / f64::from(n);
            let (x, y) = ((a.0 + (b.0 - a.0) * t).round() as i32, (a.1 + (b.1 - a.1) * t).round() as i32);
            for d in 0..thick {
                self.put(x + d - thick / 2, y, c);
                self.put(x, y + d - thick / 2, c);
            }
        }
    }
    fn disc(&mut self, cx: f64, cy: f64, r: f64, c: Rgb<u8>, filled: bool) {
        let ri = r.ceil() as i32 + 1;
        for dy in -ri..=ri {
            for dx in -ri..=ri {
                let d = f64::from(dx * dx + dy * dy).sqrt();
                if (filled && d <= r) || (!filled && (d - r).abs() <= 0.7) {
                    self.put(cx.round() as i32 + dx, cy.round() as i32 + dy, c);
                }
            }
        }
    }
    fn text(&mut self, s: &str, x: i32, y: i32, c: Rgb<u8>) {
        font::draw_text(s, x, y, 1, |px, py| self.put(px, py, c));
    }
}

impl ScatterPlot {
    /// Renders the plot as a `w × h` RGB image.
    #[must_use]
    pub fn to_png_image(&self, w: u32, h: u32) -> RgbImage {
        let f = Frame::new(self, w, h);
        let mut c = Canvas(RgbImage::from_pixel(w, h, BG));
        let (l, r, t, b) = (MARGIN.0, f.w - MARGIN.1, MARGIN.2, f.h - MARGIN.3);
        for (v, s) in f.x_ticks() {
            let x = f.px(v);
            c.line((x, t), (x, b), GRID, 1);
            c.line((x, b), (x, b + 4.0), INK, 1);
            c.text(&s, x as i32 - font::text_width(&s, 1) as i32 / 2, b as i32 + 8, INK);
        }
        for (v, s) in f.y_ticks() {
            let y = f.py(v);
            c.line((l, y), (r, y), GRID, 1);
            c.line((l - 4.0, y), (l, y), INK, 1);
            c.text(&s, l as i32 - 8 - font::text_width(&s, 1) as i32, y as i32 - 3, INK);
        }
        c.line((l, b), (r, b), INK, 1);
        c.line((l, t), (l, b), INK, 1);
        c.text(&self.title, l as i32, 12, INK);
        let xl = &self.x_label;
        c.text(xl, ((l + r) / 2.0) as i32 - font::text_width(xl, 1) as i32 / 2, b as i32 + 26, INK);
        c.text(&self.y_label, 4, t as i32 - 14, INK);
        let front = self.front_points(&f);
        for w2 in front.windows(2) {
            c.line(w2[0], w2[1], FRONT, 2);
        }
        // Labels move down a line while they would overlap one already drawn (identical points stay readable).
        let mut boxes: Vec<(f64, f64, f64)> = Vec::new();
        for p in self.points.iter().filter(|p| p.x.is_finite() && p.y.is_finite()) {
            let (x, y) = (f.px(p.x), f.py(p.y));
            let col = if p.on_front { FRONT } else { OTHER };
            c.disc(x, y, 3.5, col, p.on_front);
            let lw = font::text_width(&p.label, 1) as f64;
            let lx = if x + 6.0 + lw > f.w - 2.0 { x - 6.0 - lw } else { x + 6.0 };
            let mut ly = y - 9.0;
            for _ in 0..8 {
                if !boxes.iter().any(|&(bx, by, bw)| lx < bx + bw && bx < lx + lw && (ly - by).abs() < 9.0) {
                    break;
                }
                ly += 9.0;
            }
            boxes.push((lx, ly, lw));
            c.text(&p.label, lx as i32, ly as i32, col);
        }
        c.0
    }

    fn front_points(&self, f: &Frame) -> Vec<(f64, f64)> {
        let mut pts: Vec<(f64, f64)> = self
            .points
            .iter()
            .filter(|p| p.on_front && p.x.is_finite() && p.y.is_finite())
            .map(|p| (p.x, p.y))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        pts.into_iter().map(|(x, y)| (f.px(x), f.py(y))).collect()
    }

    /// Renders the plot as an SVG document.
    #[must_use]
    pub fn to_svg(&self, w: u32, h: u32) -> String {
        let f = Frame::new(self, w, h);
        let (l, r, t, b) = (MARGIN.0, f.w - MARGIN.1, MARGIN.2, f.h - MARGIN.3);
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="11">"#
        );
        let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = writeln!(s, r#"<text x="{l}" y="20" font-size="13">{}</text>"#, esc(&self.title));
        for (v, lab) in f.x_ticks() {
            let x = f.px(v);
            let _ = writeln!(s, r##"<line x1="{x:.1}" y1="{t}" x2="{x:.1}" y2="{b}" stroke="#e1e1e1"/>"##);
            let _ = writeln!(s, r#"<text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"#, b + 16.0, esc(&lab));
        }
        for (v, lab) in f.y_ticks() {
            let y = f.py(v);
            let _ = writeln!(s, r##"<line x1="{l}" y1="{y:.1}" x2="{r}" y2="{y:.1}" stroke="#e1e1e1"/>"##);
            let _ =
                writeln!(s, r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#, l - 6.0, y + 4.0, esc(&lab));
        }
        let _ = writeln!(s, r#"<polyline points="{l},{t} {l},{b} {r},{b}" fill="none" stroke="black"/>"#);
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            (l + r) / 2.0,
            b + 34.0,
            esc(&self.x_label)
        );
        let _ = writeln!(s, r#"<text x="4" y="{:.1}">{}</text>"#, t - 8.0, esc(&self.y_label));
        let line: Vec<String> = self.front_points(&f).iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
        if line.len() > 1 {
            let _ = writeln!(
                s,
                r##"<polyline points="{}" fill="none" stroke="#c82828" stroke-width="2"/>"##,
                line.join(" ")
            );
        }
        for p in self.points.iter().filter(|p| p.x.is_finite() && p.y.is_finite()) {
            let (x, y) = (f.px(p.x), f.py(p.y));
            let col = if p.on_front { "#c82828" } else { "#3c5ab4" };
            let fill = if p.on_front { col } else { "white" };
            let _ = writeln!(
                s,
                r#"<circle cx="{x:.1}" cy="{y:.1}" r="3.5" fill="{fill}" stroke="{col}"><title>{} ({}, {})</title></circle>"#,
                esc(&p.label),
                p.x,
                p.y
            );
            let _ = writeln!(s, r#"<text x="{:.1}" y="{:.1}" fill="{col}">{}</text>"#, x + 6.0, y - 4.0, esc(&p.label));
        }
        s.push_str("</svg>\n");
        s
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// A heatmap of `values` (row-major `width × height`), scaled so that `max` maps to the top of the colour map.
/// `None` entries (e.g. background pixels) are drawn grey.
#[must_use]
pub fn heatmap(values: &[Option<f32>], width: u32, height: u32, max: f32) -> RgbImage {
    debug_assert_eq!(values.len(), width as usize * height as usize);
    let inv = if max > 0.0 && max.is_finite() { 1.0 / max } else { 0.0 };
    RgbImage::from_fn(width, height, |x, y| match values[(y * width + x) as usize] {
        Some(v) => Rgb(colormap(v * inv)),
        None => Rgb([128, 128, 128]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plot() -> ScatterPlot {
        let pts = [(8.0, 0.5, true), (12.0, 0.9, false), (16.0, 0.01, true), (20.0, f64::NAN, false)];
        ScatterPlot {
            title: "error vs bytes".into(),
            x_label: "bytes per sample".into(),
            y_label: "rmse".into(),
            log_y: true,
            points: pts
                .iter()
                .enumerate()
                .map(|(i, &(x, y, f))| PlotPoint { x, y, label: format!("L{i}"), on_front: f })
                .collect(),
        }
    }

    #[test]
    fn png_has_the_size_and_draws_front_and_points() {
        let img = plot().to_png_image(480, 320);
        assert_eq!(img.dimensions(), (480, 320));
        let red = img.pixels().filter(|p| **p == FRONT).count();
        let blue = img.pixels().filter(|p| **p == OTHER).count();
        assert!(red > 50, "front line and points drawn: {red}");
        assert!(blue > 5, "off-front point drawn: {blue}");
        let bytes = png_bytes(&img).unwrap();
        let back = image::load_from_memory(&bytes).unwrap();
        assert_eq!((back.width(), back.height()), (480, 320));
    }

    #[test]
    fn svg_lists_every_finite_point_once() {
        let svg = plot().to_svg(480, 320);
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<circle").count(), 3);
        assert_eq!(svg.matches("<polyline").count(), 2, "axes + front");
    }

    #[test]
    fn nice_ticks_are_round_and_cover_the_range() {
        assert_eq!(nice_ticks(0.0, 10.0, 5), vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        let t = nice_ticks(7.3, 41.0, 6);
        assert!(t.first().unwrap() >= &7.3 && t.last().unwrap() <= &41.0 && t.len() >= 3);
        assert_eq!(nice_ticks(1.0, 1.0, 5), vec![1.0]);
    }

    #[test]
    fn colormap_ends_and_heatmap_background() {
        let img = heatmap(&[Some(0.0), Some(2.0), None, Some(1.0)], 2, 2, 2.0);
        assert_eq!(*img.get_pixel(1, 0), Rgb([253, 231, 37]));
        assert_eq!(*img.get_pixel(0, 1), Rgb([128, 128, 128]));
    }
}
