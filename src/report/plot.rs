//! Plots and pictures, drawn with `plotters` into PNG (`RgbImage`) and SVG (`String`): error-against-cost scatter
//! plots with the Pareto front (linear or log axes, labelled points, a legend), heatmap plots with a colour bar, and
//! raw heatmap pictures. Text uses an embedded TrueType font (Go Regular, BSD-3-Clause, `assets/fonts/`) through
//! plotters' `ab_glyph` feature, so no system font is needed.

use crate::error::Result;
use ab_glyph::{point, Font, FontRef, ScaleFont};
use image::RgbImage;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{self as pb, BackendColor, BackendCoord, DrawingErrorKind};
use std::sync::OnceLock;

/// The embedded font (Go Regular, 140 KB; licence in `assets/fonts/LICENSE-Go-Regular`).
static FONT: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/fonts/Go-Regular.ttf"));
/// The family name the font is registered under (plotters' `FontFamily::SansSerif`).
const FAMILY: &str = "sans-serif";

const FRONT: RGBColor = RGBColor(200, 40, 40);
const OTHER: RGBColor = RGBColor(60, 90, 180);
const INK: RGBColor = RGBColor(30, 30, 30);
const NO_DATA: RGBColor = RGBColor(128, 128, 128);

/// Smallest image the plots are drawn at (the axes and labels need room).
pub const MIN_SIZE: (u32, u32) = (160, 120);

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
#[derive(Clone, Debug, Default)]
pub struct ScatterPlot {
    /// Title above the plot.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Log scale on x: `Some(on)` forces it, `None` chooses it when the values are positive and span more than
    /// two decades. Values ≤ 0 on a log axis are drawn on its low edge.
    pub log_x: Option<bool>,
    /// Log scale on y, as `log_x`.
    pub log_y: Option<bool>,
    /// The points; non-finite ones are skipped.
    pub points: Vec<PlotPoint>,
}

/// A plot of a value grid (row-major `width × height`, `None` drawn grey) with a colour bar from 0 to `max`.
#[derive(Clone, Debug)]
pub struct Heatmap<'a> {
    /// Title above the plot.
    pub title: String,
    /// The values, row-major, row 0 on top.
    pub values: &'a [Option<f32>],
    /// Grid width (columns).
    pub width: u32,
    /// Grid height (rows).
    pub height: u32,
    /// The value drawn at the top of the colour map (larger values are clamped); 1 if not positive and finite.
    pub max: f32,
    /// Label of the colour bar (what the values are, with their unit).
    pub label: String,
}

fn draw_err(e: impl std::fmt::Display) -> crate::Error {
    crate::Error::Internal(format!("drawing the plot failed: {e}"))
}

/// Checks the image size and registers the font (once).
fn prepare(w: u32, h: u32) -> Result<()> {
    if w < MIN_SIZE.0 || h < MIN_SIZE.1 {
        return Err(crate::Error::Argument(format!("plot size {w}×{h} is below the minimum {MIN_SIZE:?}")));
    }
    static OK: OnceLock<bool> = OnceLock::new();
    let ok = *OK.get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_ok());
    ok.then_some(()).ok_or_else(|| crate::Error::Internal("the embedded font is not a readable TrueType font".into()))
}

fn font(size: f64) -> TextStyle<'static> {
    (FAMILY, size).into_font().color(&INK)
}

/// Something that draws itself on any plotters backend.
trait Draw {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>;
}

fn render_png(d: &impl Draw, w: u32, h: u32) -> Result<RgbImage> {
    prepare(w, h)?;
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    let root = GlyphFix(BitMapBackend::with_buffer(&mut buf, (w, h))).into_drawing_area();
    d.draw(&root).and_then(|()| root.present().map_err(draw_err))?;
    drop(root);
    RgbImage::from_raw(w, h, buf).ok_or_else(|| draw_err("the pixel buffer has the wrong size"))
}

/// A bitmap backend whose text keeps each glyph's side bearing and sits inside its layout box: plotters 0.3.7 lays
/// text out with the registered font but draws each glyph from its ink box (so "0.2" loses the space before the
/// dot) and about a fifth of its size above the box. Shapes are drawn as by `BitMapBackend`.
struct GlyphFix<'a>(BitMapBackend<'a>);

fn glyph_font() -> &'static FontRef<'static> {
    static F: OnceLock<FontRef<'static>> = OnceLock::new();
    // register_font has already parsed the same bytes, so this cannot fail.
    F.get_or_init(|| FontRef::try_from_slice(FONT).expect("the embedded font parses"))
}

type Coord = BackendCoord;
type BErr<'a> = DrawingErrorKind<<BitMapBackend<'a> as DrawingBackend>::ErrorType>;

impl<'a> DrawingBackend for GlyphFix<'a> {
    type ErrorType = <BitMapBackend<'a> as DrawingBackend>::ErrorType;
    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }
    fn ensure_prepared(&mut self) -> Result<(), BErr<'a>> {
        self.0.ensure_prepared()
    }
    fn present(&mut self) -> Result<(), BErr<'a>> {
        self.0.present()
    }
    fn draw_pixel(&mut self, p: BackendCoord, c: BackendColor) -> Result<(), BErr<'a>> {
        self.0.draw_pixel(p, c)
    }
    fn draw_line<S: pb::BackendStyle>(&mut self, a: BackendCoord, b: BackendCoord, s: &S) -> Result<(), BErr<'a>> {
        self.0.draw_line(a, b, s)
    }
    fn draw_rect<S: pb::BackendStyle>(&mut self, a: Coord, b: Coord, s: &S, f: bool) -> Result<(), BErr<'a>> {
        self.0.draw_rect(a, b, s, f)
    }
    fn draw_text<T: pb::BackendTextStyle>(&mut self, text: &str, style: &T, pos: BackendCoord) -> Result<(), BErr<'a>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        // The box plotters laid out (and anchored) the text in; the glyphs are centred in it vertically.
        let ((x0, y0), (x1, y1)) = style.layout_box(text).map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (bw, bh) = (x1 - x0, y1 - y0);
        let a = style.anchor();
        let shift =
            |size: i32, start: bool, centre: bool| [-size, -size / 2, 0][usize::from(centre) + 2 * usize::from(start)];
        let dx = shift(bw, matches!(a.h_pos, HPos::Left), matches!(a.h_pos, HPos::Center));
        let dy = shift(bh, matches!(a.v_pos, VPos::Top), matches!(a.v_pos, VPos::Center));
        let font = glyph_font().as_scaled(style.size() as f32);
        let baseline = bh as f32 / 2.0 + (font.ascent() + font.descent()) / 2.0;
        let (trans, (w, h)) = (style.transform(), self.get_size());
        let (mut caret, mut prev) = (0.0f32, None);
        let mut res = Ok(());
        for c in text.chars() {
            let id = font.glyph_id(c);
            if let Some(p) = prev {
                caret += font.kern(p, id);
            }
            prev = Some(id);
            if let Some(g) = font.outline_glyph(id.with_scale_and_position(font.scale(), point(caret, baseline))) {
                let b = g.px_bounds();
                g.draw(|gx, gy, cov| {
                    let (x, y) = trans.transform(b.min.x as i32 + gx as i32 + dx, b.min.y as i32 + gy as i32 + dy);
                    let (x, y) = (pos.0 + x, pos.1 + y);
                    if res.is_ok() && x >= 0 && y >= 0 && x < w as i32 && y < h as i32 && cov > 0.0 {
                        let alpha = color.alpha * f64::from(cov.min(1.0));
                        res = self.0.draw_pixel((x, y), BackendColor { alpha, rgb: color.rgb });
                    }
                });
            }
            caret += font.h_advance(id);
        }
        res
    }
}

fn render_svg(d: &impl Draw, w: u32, h: u32) -> Result<String> {
    prepare(w, h)?;
    let mut s = String::new();
    let root = SVGBackend::with_string(&mut s, (w, h)).into_drawing_area();
    d.draw(&root).and_then(|()| root.present().map_err(draw_err))?;
    drop(root);
    Ok(s)
}

fn min_max(it: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    it.fold(None, |acc, v| Some(acc.map_or((v, v), |(a, b): (f64, f64)| (a.min(v), b.max(v)))))
}

/// Whether an axis over `vals` is drawn log: forced by `opt`, else when all are positive and span > 2 decades.
fn use_log(opt: Option<bool>, vals: &[f64]) -> bool {
    let span = || min_max(vals.iter().copied()).is_some_and(|(lo, hi)| lo > 0.0 && hi / lo > 100.0);
    opt.unwrap_or_else(span)
}

/// The axis range over `vals`: padded linear, or whole decades (with a little room) for log.
fn axis_range(vals: &[f64], log: bool) -> (f64, f64) {
    if log {
        let (lo, hi) = min_max(vals.iter().copied().filter(|&v| v > 0.0)).unwrap_or((0.1, 10.0));
        let a = (lo.log10() - 0.05).floor();
        (10f64.powf(a), 10f64.powf((hi.log10() + 0.05).ceil().max(a + 1.0)))
    } else {
        let (lo, hi) = min_max(vals.iter().copied()).unwrap_or((0.0, 1.0));
        let span = hi - lo;
        let p = if span > 0.0 { span * 0.06 } else { lo.abs().max(1.0) * 0.1 };
        (lo - p, hi + p)
    }
}

/// A tick label: plain decimals from 0.001 to 99999, else `2.5e-6` style; float noise rounded away.
fn fmt_tick(t: f64) -> String {
    let a = t.abs();
    if t == 0.0 || !t.is_finite() {
        return if t == 0.0 { "0".into() } else { format!("{t}") };
    }
    let trim = |s: &str| s.trim_end_matches('0').trim_end_matches('.').to_string();
    if (1e-3..1e5).contains(&a) {
        trim(&format!("{t:.6}"))
    } else {
        let s = format!("{t:.2e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        format!("{}e{e}", trim(m))
    }
}

impl ScatterPlot {
    /// The finite points.
    fn finite(&self) -> Vec<&PlotPoint> {
        self.points.iter().filter(|p| p.x.is_finite() && p.y.is_finite()).collect()
    }

    /// Whether (x, y) are drawn on log axes, after the automatic choice.
    #[must_use]
    fn log_axes(&self) -> (bool, bool) {
        let pts = self.finite();
        let xs: Vec<f64> = pts.iter().map(|p| p.x).collect();
        let ys: Vec<f64> = pts.iter().map(|p| p.y).collect();
        (use_log(self.log_x, &xs), use_log(self.log_y, &ys))
    }

    /// Renders the plot as a `w × h` RGB image.
    pub fn to_png_image(&self, w: u32, h: u32) -> Result<RgbImage> {
        render_png(self, w, h)
    }

    /// Renders the plot as an SVG document (text as `<text>` in a sans-serif font). Each point's circle carries a
    /// `<title>` (its label and values): a browser shows it as a tooltip.
    pub fn to_svg(&self, w: u32, h: u32) -> Result<String> {
        let svg = render_svg(self, w, h)?;
        // The points' circles come first in the document, in drawing order: the front's, then the others'.
        let pts = self.finite();
        let order = pts.iter().filter(|p| p.on_front).chain(pts.iter().filter(|p| !p.on_front));
        let mut out = String::with_capacity(svg.len() + 64 * pts.len());
        let mut rest = svg.as_str();
        for p in order {
            let Some(at) = rest.find("<circle") else { break };
            let Some(end) = rest[at..].find("/>").map(|e| at + e) else { break };
            out.push_str(&rest[..end]);
            let tip = format!(
                "{}: {} = {}, {} = {}{}",
                p.label,
                self.x_label,
                fmt_tick(p.x),
                self.y_label,
                fmt_tick(p.y),
                if p.on_front { " (Pareto front)" } else { "" }
            );
            let tip = tip.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
            out.push_str(&format!("><title>{tip}</title></circle>"));
            rest = &rest[end + 2..];
        }
        out.push_str(rest);
        Ok(out)
    }

    fn draw_on<DB, X, Y>(&self, root: &DrawingArea<DB, Shift>, xc: X, yc: Y) -> Result<()>
    where
        DB: DrawingBackend,
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let (xr, yr) = (xc.range(), yc.range());
        let clamp = |p: &PlotPoint| (p.x.clamp(xr.start, xr.end), p.y.clamp(yr.start, yr.end));
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, font(20.0))
            .margin(10)
            .margin_right(24)
            .x_label_area_size(46)
            .y_label_area_size(70)
            .build_cartesian_2d(xc, yc)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .label_style(font(14.0))
            .axis_desc_style(font(15.0))
            .x_label_formatter(&|v| fmt_tick(*v))
            .y_label_formatter(&|v| fmt_tick(*v))
            .x_labels(8)
            .y_labels(8)
            .bold_line_style(RGBColor(214, 214, 214))
            .light_line_style(RGBColor(240, 240, 240))
            .max_light_lines(4)
            .axis_style(INK)
            .draw()
            .map_err(draw_err)?;
        let (px, py) = chart.plotting_area().get_pixel_range();
        let pts = self.finite();
        if pts.is_empty() {
            let style = font(18.0).color(&NO_DATA).pos(Pos::new(HPos::Center, VPos::Center));
            let at = ((px.start + px.end) / 2, (py.start + py.end) / 2);
            root.draw(&Text::new("no data", at, style)).map_err(draw_err)?;
            return Ok(());
        }
        let mut front: Vec<(f64, f64)> = pts.iter().filter(|p| p.on_front).map(|p| clamp(p)).collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        chart.draw_series(LineSeries::new(front.iter().copied(), FRONT.stroke_width(2))).map_err(draw_err)?;
        // Front points filled (their legend with the line), the others hollow.
        for (on, name, dot, line) in [
            (true, "Pareto front", FRONT.filled(), FRONT.stroke_width(2)),
            (false, "other", OTHER.stroke_width(2), TRANSPARENT.into()),
        ] {
            let these: Vec<(f64, f64)> = pts.iter().filter(|p| p.on_front == on).map(|p| clamp(p)).collect();
            if !these.is_empty() {
                let series = chart.draw_series(these.iter().map(|&c| Circle::new(c, 4, dot))).map_err(draw_err)?;
                let mark = move |c| {
                    EmptyElement::at(c) + PathElement::new([(-9, 0), (9, 0)], line) + Circle::new((0, 0), 4, dot)
                };
                series.label(name).legend(mark);
            }
        }
        // Labels: beside the point, moved down a line while they would overlap a label already drawn.
        let coords: Vec<(i32, i32)> = pts.iter().map(|p| chart.backend_coord(&clamp(p))).collect();
        let mut boxes: Vec<(i32, i32, i32, i32)> = Vec::new();
        for (p, &(x, y)) in pts.iter().zip(&coords) {
            let col = if p.on_front { RGBColor(160, 25, 25) } else { RGBColor(40, 60, 140) };
            let style = font(14.0).color(&col);
            let (tw, th) = root.estimate_text_size(&p.label, &style).map_err(draw_err)?;
            let (tw, th) = (tw as i32, th as i32 + 2);
            let lx = if x + 7 + tw > px.end { x - 7 - tw } else { x + 7 };
            let hit = |ly: i32| {
                boxes.iter().any(|&(bx, by, bw, bh)| lx < bx + bw && bx < lx + tw && ly < by + bh && by < ly + th)
            };
            let ly = (0..8).map(|k| y - th - 3 + k * th).find(|&ly| !hit(ly)).unwrap_or(y - th - 3);
            boxes.push((lx, ly, tw, th));
            root.draw(&Text::new(p.label.clone(), (lx, ly), style)).map_err(draw_err)?;
        }
        // The legend goes in the corner of the plot area with the fewest points and labels.
        use SeriesLabelPosition::{LowerLeft, LowerRight, UpperLeft, UpperRight};
        let (lw, lh, right, bottom) = (130, 56, px.end - 130, py.end - 56);
        let corners = [(UpperRight, right, py.start), (UpperLeft, px.start, py.start), (LowerRight, right, bottom)];
        let inside = |cx: i32, cy: i32, x: i32, y: i32| x >= cx && x <= cx + lw && y >= cy && y <= cy + lh;
        let crowd = |&(_, cx, cy): &(SeriesLabelPosition, i32, i32)| {
            let l = boxes.iter().filter(|&&(x, y, w, h)| inside(cx, cy, x, y) || inside(cx, cy, x + w, y + h));
            coords.iter().filter(|&&(x, y)| inside(cx, cy, x, y)).count() * 2 + l.count()
        };
        let best =
            corners.into_iter().chain([(LowerLeft, px.start, bottom)]).min_by_key(crowd).map_or(UpperRight, |c| c.0);
        chart
            .configure_series_labels()
            .position(best)
            .label_font(font(14.0))
            .background_style(WHITE.mix(0.9))
            .border_style(RGBColor(170, 170, 170))
            .draw()
            .map_err(draw_err)
    }
}

impl Draw for ScatterPlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(draw_err)?;
        let pts = self.finite();
        let (lx, ly) = self.log_axes();
        let (x0, x1) = axis_range(&pts.iter().map(|p| p.x).collect::<Vec<_>>(), lx);
        let (y0, y1) = axis_range(&pts.iter().map(|p| p.y).collect::<Vec<_>>(), ly);
        let lin = |a: f64, b: f64| RangedCoordf64::from(a..b);
        let log = |a: f64, b: f64| LogCoord::from((a..b).log_scale());
        match (lx, ly) {
            (false, false) => self.draw_on(root, lin(x0, x1), lin(y0, y1)),
            (true, false) => self.draw_on(root, log(x0, x1), lin(y0, y1)),
            (false, true) => self.draw_on(root, lin(x0, x1), log(y0, y1)),
            (true, true) => self.draw_on(root, log(x0, x1), log(y0, y1)),
        }
    }
}

impl Heatmap<'_> {
    /// Renders the plot as a `w × h` RGB image (grid cells averaged down to at most one per pixel).
    pub fn to_png_image(&self, w: u32, h: u32) -> Result<RgbImage> {
        render_png(self, w, h)
    }

    /// The mean of the finite values in the block of grid cells `[x0, x1) × [y0, y1)`.
    fn block(&self, (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> Option<f32> {
        let cells = (y0..y1).flat_map(|y| (x0..x1).map(move |x| (y * self.width + x) as usize));
        let vals = cells.filter_map(|i| self.values[i]).filter(|v| v.is_finite());
        let (sum, n) = vals.fold((0.0, 0u32), |(s, n), v| (s + f64::from(v), n + 1));
        (n > 0).then(|| (sum / f64::from(n)) as f32)
    }
}

impl Draw for Heatmap<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        if self.values.len() != self.width as usize * self.height as usize {
            let (w, h, n) = (self.width, self.height, self.values.len());
            return Err(crate::Error::Internal(format!("heatmap of {w}×{h} cells given {n} values")));
        }
        root.fill(&WHITE).map_err(draw_err)?;
        let area = root.margin(8, 0, 0, 0).titled(&self.title, font(20.0)).map_err(draw_err)?;
        let (aw, ah) = area.dim_in_pixel();
        let bar_w = 120u32.min(aw / 3);
        let (left, right) = area.split_horizontally(aw - bar_w);
        let max = if self.max > 0.0 && self.max.is_finite() { f64::from(self.max) } else { 1.0 };
        let (gw, gh) = (f64::from(self.width.max(1)), f64::from(self.height.max(1)));
        // Keep the cells square: shrink the plot area along one axis and centre it.
        let (label_l, label_b, pad) = (56.0, 30.0, 10.0);
        let (pw, ph) = (f64::from(aw - bar_w) - label_l - 2.0 * pad, f64::from(ah) - label_b - 2.0 * pad);
        let s = (pw / gw).min(ph / gh).max(0.0);
        let (ex, ey) = (((pw - s * gw) / 2.0) as i32, ((ph - s * gh) / 2.0) as i32);
        let (mx, my) = (pad as i32 + ex, pad as i32 + ey);
        let mut chart = ChartBuilder::on(&left.margin(my, my, mx, mx))
            .x_label_area_size(label_b as i32)
            .y_label_area_size(label_l as i32)
            .build_cartesian_2d(0.0..gw, gh..0.0)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .label_style(font(12.0))
            .x_label_formatter(&|v| fmt_tick(*v))
            .y_label_formatter(&|v| fmt_tick(*v))
            .x_labels(6)
            .y_labels(6)
            .draw()
            .map_err(draw_err)?;
        let (ppx, ppy) = chart.plotting_area().dim_in_pixel();
        let (cols, rows) = (self.width.min(ppx.max(1)), self.height.min(ppy.max(1)));
        let edge = |i: u32, n: u32, total: u32| (u64::from(i) * u64::from(total) / u64::from(n)) as u32;
        let cells = (0..rows).flat_map(|r| (0..cols).map(move |c| (c, r))).map(|(c, r)| {
            let (x0, x1) = (edge(c, cols, self.width), edge(c + 1, cols, self.width));
            let (y0, y1) = (edge(r, rows, self.height), edge(r + 1, rows, self.height));
            let v = self.block((x0, x1), (y0, y1));
            let col = v.map_or(NO_DATA, |v| to_rgb(colormap((f64::from(v) / max) as f32)));
            Rectangle::new([(f64::from(x0), f64::from(y0)), (f64::from(x1), f64::from(y1))], col.filled())
        });
        chart.draw_series(cells).map_err(draw_err)?;
        // The colour bar, aligned with the plot area, its scale on the right.
        let mut bar = ChartBuilder::on(&right.margin(my, my + label_b as i32, 4, 6))
            .set_label_area_size(LabelAreaPosition::Right, 46)
            .build_cartesian_2d(0.0..1.0, 0.0..max)
            .map_err(draw_err)?;
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .label_style(font(12.0))
            .y_label_formatter(&|v| fmt_tick(*v))
            .y_labels(6)
            .y_desc(&self.label)
            .axis_desc_style(font(13.0))
            .draw()
            .map_err(draw_err)?;
        bar.draw_series((0..64).map(|i| {
            let (a, b) = (f64::from(i) / 64.0, f64::from(i + 1) / 64.0);
            Rectangle::new([(0.0, a * max), (1.0, b * max)], to_rgb(colormap(((a + b) / 2.0) as f32)).filled())
        }))
        .map_err(draw_err)?;
        bar.plotting_area().draw(&Rectangle::new([(0.0, 0.0), (1.0, max)], INK)).map_err(draw_err)?;
        Ok(())
    }
}

/// Pictures in a grid, each under its caption, with a title above (a crop of several images at one place, say).
/// The pictures are copied pixel for pixel (no scaling); cells are as large as the largest picture.
#[derive(Clone, Debug)]
pub struct Panels {
    /// Title above the grid.
    pub title: String,
    /// Captions and pictures, in reading order.
    pub panels: Vec<(String, RgbImage)>,
    /// Pictures per row (at least 1).
    pub columns: usize,
}

/// Space between and around [`Panels`] cells, and the heights of the title and caption lines, in pixels.
const PANEL_GAP: u32 = 10;
const PANEL_TITLE: u32 = 30;
const PANEL_CAPTION: u32 = 20;

impl Panels {
    /// The cell size and the grid's columns and rows.
    fn grid(&self) -> ((u32, u32), u32, u32) {
        let cell = self.panels.iter().fold((1, 1), |(w, h), (_, p)| (p.width().max(w), p.height().max(h)));
        let cols = self.columns.clamp(1, self.panels.len().max(1)) as u32;
        let rows = (self.panels.len() as u32).div_ceil(cols).max(1);
        (cell, cols, rows)
    }

    /// Where cell `i`'s caption starts (its picture sits [`PANEL_CAPTION`] below).
    fn origin(&self, i: usize) -> (u32, u32) {
        let ((cw, ch), cols, _) = self.grid();
        let (c, r) = (i as u32 % cols, i as u32 / cols);
        (PANEL_GAP + c * (cw + PANEL_GAP), PANEL_TITLE + r * (ch + PANEL_CAPTION + PANEL_GAP))
    }

    /// Renders the grid as an RGB image.
    pub fn to_png_image(&self) -> Result<RgbImage> {
        let ((cw, ch), cols, rows) = self.grid();
        let w = (PANEL_GAP + cols * (cw + PANEL_GAP)).max(MIN_SIZE.0);
        let h = (PANEL_TITLE + rows * (ch + PANEL_CAPTION + PANEL_GAP)).max(MIN_SIZE.1);
        let mut img = render_png(self, w, h)?;
        for (i, (_, p)) in self.panels.iter().enumerate() {
            let (x, y) = self.origin(i);
            image::imageops::replace(&mut img, p, i64::from(x), i64::from(y + PANEL_CAPTION));
        }
        Ok(img)
    }
}

impl Draw for Panels {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(draw_err)?;
        root.draw(&Text::new(self.title.as_str(), (PANEL_GAP as i32, 6), font(17.0))).map_err(draw_err)?;
        for (i, (caption, _)) in self.panels.iter().enumerate() {
            let (x, y) = self.origin(i);
            root.draw(&Text::new(caption.as_str(), (x as i32, y as i32 + 2), font(13.0))).map_err(draw_err)?;
        }
        Ok(())
    }
}

fn to_rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

use crate::base::picture::colormap;

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(x: f64, y: f64, label: &str, on_front: bool) -> PlotPoint {
        PlotPoint { x, y, label: label.into(), on_front }
    }

    fn plot() -> ScatterPlot {
        let pts = [(8.0, 0.5, true), (12.0, 0.9, false), (16.0, 0.001, true), (20.0, f64::NAN, false)];
        let points = pts.iter().enumerate().map(|(i, &(x, y, f))| pt(x, y, &format!("L{i}"), f)).collect();
        let (title, x_label, y_label) = ("error vs bytes".into(), "bytes per sample".into(), "rmse".into());
        ScatterPlot { title, x_label, y_label, points, ..ScatterPlot::default() }
    }

    fn has_text(svg: &str, text: &str) -> bool {
        svg.contains(&format!(">\n{text}\n</text>"))
    }

    /// Pixels of colour `c` with x in `xs` and y in `ys`.
    fn count(img: &RgbImage, c: RGBColor, xs: std::ops::Range<u32>, ys: std::ops::Range<u32>) -> usize {
        img.enumerate_pixels().filter(|(x, y, p)| xs.contains(x) && ys.contains(y) && p.0 == [c.0, c.1, c.2]).count()
    }

    #[test]
    fn panels_copy_each_picture_under_its_caption() {
        let pic = |c: u8| RgbImage::from_pixel(40, 30, image::Rgb([c, 0, 255 - c]));
        let p = Panels {
            title: "crops".into(),
            panels: (0..5).map(|i| (format!("panel {i}"), pic(40 * i as u8))).collect(),
            columns: 3,
        };
        let img = p.to_png_image().unwrap();
        let ((cw, ch), cols, rows) = p.grid();
        assert_eq!((cw, ch, cols, rows), (40, 30, 3, 2));
        assert_eq!(img.width(), (PANEL_GAP + 3 * (40 + PANEL_GAP)).max(MIN_SIZE.0));
        for i in 0..5 {
            let (x, y) = p.origin(i);
            let want = image::Rgb([40 * i as u8, 0, 255 - 40 * i as u8]);
            // Every pixel of the picture is where it belongs, and the caption line above it has ink.
            assert!((0..40).all(|dx| (0..30).all(|dy| *img.get_pixel(x + dx, y + PANEL_CAPTION + dy) == want)), "{i}");
            let ink = (x..x + 40).flat_map(|xx| (y..y + PANEL_CAPTION).map(move |yy| (xx, yy)));
            assert!(ink.filter(|&(xx, yy)| img.get_pixel(xx, yy).0 != [255, 255, 255]).count() > 10, "caption {i}");
        }
    }

    #[test]
    fn png_has_the_size_points_front_and_text() {
        let img = plot().to_png_image(480, 320).unwrap();
        assert_eq!(img.dimensions(), (480, 320));
        assert!(count(&img, FRONT, 70..470, 30..280) > 60, "front line and points inside the plot area");
        assert!(count(&img, OTHER, 70..470, 30..280) > 10, "off-front point drawn");
        // Anti-aliased glyphs leave grey levels that no shape has; the title sits inside the image, below its top.
        let grey = img.pixels().filter(|p| p.0[0] == p.0[1] && p.0[1] == p.0[2] && (60..200).contains(&p.0[0]));
        assert!(grey.count() > 200, "text drawn");
        let dark =
            |ys: std::ops::Range<u32>| img.enumerate_pixels().filter(move |(_, y, p)| ys.contains(y) && p.0[0] < 100);
        assert!(dark(0..2).count() == 0 && dark(6..34).count() > 50, "title placed");
        assert_eq!(image::load_from_memory(&crate::base::picture::png_bytes(&img).unwrap()).unwrap().height(), 320);
        assert!(plot().to_png_image(100, 50).is_err(), "too small");
    }

    #[test]
    fn svg_has_the_texts_and_one_circle_per_finite_point() {
        let svg = plot().to_svg(480, 320).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        let texts = ["error vs bytes", "bytes per sample", "rmse", "L0", "L1", "L2", "Pareto front", "other"];
        assert!(texts.iter().all(|t| has_text(&svg, t)), "title, axis labels, point labels and legend");
        assert!(!has_text(&svg, "L3"), "the NaN point is skipped");
        assert_eq!(svg.matches("<circle").count(), 3 + 2, "three finite points and two legend markers");
        // Each point's circle has its tooltip (label and values), the legend markers none.
        assert_eq!(svg.matches("<title>").count(), 3, "{svg}");
        for l in ["L0", "L1", "L2"] {
            assert!(svg.contains(&format!("<title>{l}: bytes per sample = ")), "tooltip of {l}");
        }
        assert_eq!(svg.matches(r##"stroke="#C82828" stroke-width="2""##).count(), 2, "front line and its legend");
    }

    #[test]
    fn log_axes_are_chosen_when_data_spans_decades() {
        assert_eq!(plot().log_axes(), (false, true), "y spans 0.001..0.9, x only 8..16");
        let lin = ScatterPlot { points: vec![pt(1.0, 1.0, "a", true), pt(2.0, 50.0, "b", false)], ..plot() };
        assert_eq!(lin.log_axes(), (false, false));
        assert_eq!(ScatterPlot { log_x: Some(true), log_y: Some(false), ..plot() }.log_axes(), (true, false));
        let neg = ScatterPlot { points: vec![pt(-1.0, 1e-6, "a", true), pt(1e3, 1.0, "b", true)], ..plot() };
        assert_eq!(neg.log_axes(), (false, true), "no automatic log axis over values ≤ 0");
        let svg = plot().to_svg(480, 320).unwrap();
        assert!(["0.001", "0.01", "0.1", "1"].iter().all(|t| has_text(&svg, t)), "decade ticks on y");
    }

    #[test]
    fn empty_plot_draws_axes_and_says_no_data() {
        let empty = ScatterPlot { points: vec![pt(f64::NAN, 1.0, "x", true)], ..plot() };
        let svg = empty.to_svg(400, 300).unwrap();
        assert!(has_text(&svg, "no data") && has_text(&svg, "error vs bytes") && !svg.contains("<circle"));
        assert!(count(&empty.to_png_image(400, 300).unwrap(), INK, 0..400, 0..300) > 400, "axis lines drawn");
    }

    #[test]
    fn heatmap_plot_has_cells_colour_bar_and_scale() {
        let (w, h) = (40u32, 24u32);
        let v: Vec<_> = (0..w * h).map(|i| (i % w >= 4).then(|| (i % w) as f32 / 4.0)).collect();
        let hm =
            Heatmap { title: "normal error".into(), values: &v, width: w, height: h, max: 8.0, label: "deg".into() };
        let (img, bar, plot) = (hm.to_png_image(520, 300).unwrap(), 400..520, 0..400);
        assert_eq!(img.dimensions(), (520, 300));
        let c = |t: f32| to_rgb(colormap(t));
        assert!(count(&img, c(63.5 / 64.0), bar.clone(), 0..300) > 20, "top of the colour bar");
        assert!(count(&img, c(0.5 / 64.0), bar, 0..300) > 20, "bottom of the colour bar");
        assert!(count(&img, c(1.0), plot.clone(), 0..300) > 500, "cells over max at the top colour");
        assert!(count(&img, NO_DATA, plot.clone(), 0..300) > 200 && count(&img, c(0.0), plot, 0..300) == 0);
        assert!(Heatmap { values: &v[1..], ..hm }.to_png_image(520, 300).is_err());
    }

    #[test]
    fn tick_labels() {
        let labels = [0.0, 0.30000000000000004, 12.5, 0.001, 2.5e-6, 1e6, -3.0].map(fmt_tick);
        assert_eq!(labels, ["0", "0.3", "12.5", "0.001", "2.5e-6", "1e6", "-3"]);
    }
}
