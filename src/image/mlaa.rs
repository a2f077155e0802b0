//! Morphological antialiasing (MLAA): an edge-smoothing post-process for a 1-sample linear RGB image.
//!
//! Source: A. Reshetov, "Morphological Antialiasing", HPG 2009. The per-pixel combination of the two directions
//! follows Jimenez et al., "Practical Morphological Antialiasing", GPU Pro 2 (2011).
//!
//! Steps ([`mlaa`]):
//! 1. **Sanitise**: every non-finite channel (NaN, ±Inf) is replaced by 0; only finite values are read after this, so
//!    the output is always finite.
//! 2. **Edge detection** on a display encoding: `e = sqrt(luma709(x / (1 + x)))` of the linear value clamped at 0
//!    (Reinhard per channel, then a gamma-2 curve), which lies in [0, 1). Two 4-neighbours are separated by an edge
//!    when their `e` differ by more than [`MlaaConfig::threshold`]. Linear HDR differences are not used: a step of
//!    0.5 matters at 0.1 and is invisible at 50.
//! 3. **Runs**: along each separation line between two rows (horizontal pass) or two columns (vertical pass), maximal
//!    runs of consecutive edges are found by one linear scan.
//! 4. **Shapes**: at each end of a run the crossing (orthogonal) edge is looked up on the two sides of the line. An end
//!    has a shape end when exactly one side has it; none, both, or the image border give an open end. Two shape ends
//!    on the same side make a U, on opposite sides a Z, a single one an L, none a straight edge (left alone).
//! 5. **Areas**: as in Reshetov's decomposition of Z and U into two L's, each shape end is joined by a straight line
//!    from the midpoint of its crossing edge (half a pixel off the separation line) to the separation line at the
//!    run's middle, capped at [`MlaaConfig::max_search`] pixels from the end. For each pixel under that line the area
//!    of the trapezoid between the line and the separation line is its blend weight toward the neighbour across the
//!    line; only pixels on the crossing edge's side are blended. Each weight is below 1/2. A shape end whose crossing
//!    edge goes on past the pixel beside the separation line is an object's corner, not the step of an aliased line
//!    (whose crossing edges are one pixel long); its areas are scaled by [`MlaaConfig::corner_rounding`], as SMAA
//!    does (Jimenez et al., "SMAA: Enhanced Subpixel Morphological Antialiasing", 2012), so a box's silhouette is not
//!    rounded off along half its edge.
//! 6. **Blend**, in linear RGB: both passes compute weights from the original image; every pixel then gets
//!    `Σ_k (a_k / Σa) · ((1 − a_k)·c + a_k·n_k)` over its four neighbours `n_k` with weights `a_k` (Jimenez et al.'s
//!    weighted average of the per-edge blends). Unlike a plain sum this does not count twice the corner where a
//!    horizontal and a vertical run meet, and it is always a convex combination of the pixel and its 4-neighbours
//!    (the result is also clamped to their per-channel range against rounding).
//!
//! Cost: O(width·height) time — one encode per pixel, one edge test per neighbour pair and direction, four crossing
//! tests per run, at most `2·min(run/2, max_search)` weight updates per run, one blend per touched pixel. On one core
//! (release): about 10 ms for 1280×720 with ordinary content, about 40 ms on white noise (half of all
//! neighbour pairs are edges).
//! Memory: the output plus 20 bytes per pixel (encoded luma and four weights).

use glam::Vec3;

/// Settings of [`mlaa`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MlaaConfig {
    /// Luma difference (of the display-encoded value, 0..1) above which two neighbouring pixels are separated by an edge.
    ///
    /// Default 0.1, the usual MLAA/SMAA value on gamma-encoded luma: about a tenth of the display range, so smooth
    /// shading (a few hundredths per pixel) is not taken for geometry while visible silhouettes are.
    pub threshold: f32,
    /// Longest edge run searched, in pixels (each side).
    ///
    /// Each shape end's line reaches the separation line at most this many pixels from that end, so runs longer than
    /// twice this are smoothed only near their ends. Default 32: lines as shallow as 1/64 get their full reconstruction,
    /// and a long run with one stray step is not smeared over hundreds of pixels. 0 disables blending.
    pub max_search: u32,
    /// Blend the display-encoded values (per channel Reinhard `x / (1 + x)`, decoded back after the blend) instead of
    /// linear ones, as MLAA on a GPU does on the final tone-mapped frame. Default false: on the room scene rendered
    /// at pixel centres (320×180, against its 16-sample reference) linear blending lowers mean LDR-FLIP from 0.0348
    /// to 0.0313, display blending raises it to 0.0359.
    pub display_blend: bool,
    /// Share of the blend kept at a shape end whose crossing edge goes on beyond the pixel next to the separation
    /// line (SMAA's corner rounding, Jimenez et al. 2012).
    ///
    /// On an aliased line every step's crossing edge is one pixel long; one that continues is the corner of an
    /// object (a box's silhouette meeting the floor), which MLAA would otherwise round off with a ramp reaching up
    /// to `max_search` pixels along the edge. 1 is Reshetov's MLAA, 0 keeps corners sharp. Default 0.25, SMAA's.
    pub corner_rounding: f32,
}

impl Default for MlaaConfig {
    fn default() -> Self {
        Self { threshold: 0.1, max_search: 32, display_blend: false, corner_rounding: 0.25 }
    }
}

/// What `mlaa` found and did (counts are summable).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MlaaStats {
    /// Edges on horizontal separation lines: pairs of vertically adjacent pixels found different.
    pub edges_h: u64,
    /// Edges on vertical separation lines: pairs of horizontally adjacent pixels found different.
    pub edges_v: u64,
    /// Runs (both directions) with a shape end at exactly one end.
    pub shapes_l: u64,
    /// Runs whose two shape ends' crossing edges lie on opposite sides of the line (a step).
    pub shapes_z: u64,
    /// Runs whose two shape ends' crossing edges lie on the same side of the line (a bump or notch).
    pub shapes_u: u64,
    /// Pixels that received a non-zero blend weight.
    pub blended_pixels: u64,
}

/// Anti-aliases `rgb` (linear, row-major, row 0 at the top, width × height) by MLAA; see the [module docs](self).
///
/// The caller guarantees `rgb.len() == width × height` (checked by `debug_assert`; in release builds a mismatch
/// returns the sanitised input with zero stats). Non-finite channels are read and returned as 0. Returns the new
/// image and what was found.
#[must_use]
pub fn mlaa(rgb: &[Vec3], width: u32, height: u32, cfg: &MlaaConfig) -> (Vec<Vec3>, MlaaStats) {
    let (w, h) = (width as usize, height as usize);
    let n = w.checked_mul(h);
    debug_assert_eq!(n, Some(rgb.len()), "mlaa: rgb.len() must be width × height");
    let mut out: Vec<Vec3> = rgb.iter().map(|&c| sanitize(c)).collect();
    let mut stats = MlaaStats::default();
    if n != Some(rgb.len()) || out.is_empty() {
        return (out, stats);
    }
    let luma: Vec<f32> = out.iter().map(|&c| display_luma(c)).collect();
    // Per pixel: blend weight toward the neighbour [up, down, left, right].
    let mut weights = vec![[0.0_f32; 4]; out.len()];
    let horizontal = Axis { lines: h, len: w, line_stride: w, pos_stride: 1, slots: [1, 0] };
    let vertical = Axis { lines: w, len: h, line_stride: 1, pos_stride: w, slots: [3, 2] };
    let ch = scan(&luma, &mut weights, &horizontal, cfg);
    let cv = scan(&luma, &mut weights, &vertical, cfg);
    stats.edges_h = ch.edges;
    stats.edges_v = cv.edges;
    stats.shapes_l = ch.l + cv.l;
    stats.shapes_z = ch.z + cv.z;
    stats.shapes_u = ch.u + cv.u;

    // Blend from the (sanitised) input, so the order of updates does not matter.
    for (p, a) in weights.iter().enumerate() {
        let sum: f32 = a.iter().sum();
        if sum <= 0.0 {
            continue;
        }
        stats.blended_pixels += 1;
        let (enc, dec): (Map, Map) = if cfg.display_blend {
            (
                |x| {
                    let x = x.max(Vec3::ZERO);
                    x / (Vec3::ONE + x)
                },
                |y| y / (Vec3::ONE - y).max(Vec3::splat(f32::MIN_POSITIVE)),
            )
        } else {
            (|x| x, |x| x)
        };
        let c = enc(sanitize(rgb[p]));
        let neighbours = [p.wrapping_sub(w), p + w, p.wrapping_sub(1), p + 1];
        let (mut lo, mut hi) = (c, c);
        let mut moved = 0.0; // Σ a_k² / Σa: the total weight taken from the neighbours.
        let mut acc = Vec3::ZERO;
        for (&ak, &q) in a.iter().zip(&neighbours) {
            if ak > 0.0 {
                let nb = enc(sanitize(rgb[q]));
                let wk = ak * ak / sum;
                moved += wk;
                acc += wk * nb;
                lo = lo.min(nb);
                hi = hi.max(nb);
            }
        }
        let v = (1.0 - moved) * c + acc;
        let v = dec(if v.is_finite() { v.clamp(lo, hi) } else { c });
        out[p] = if v.is_finite() { v } else { sanitize(rgb[p]) };
    }
    (out, stats)
}

/// A per-pixel colour map (the blend's encode and decode).
type Map = fn(Vec3) -> Vec3;

/// Non-finite channels become 0.
fn sanitize(c: Vec3) -> Vec3 {
    let f = |v: f32| if v.is_finite() { v } else { 0.0 };
    Vec3::new(f(c.x), f(c.y), f(c.z))
}

/// Display-encoded luma in [0, 1): Rec. 709 luma of the per-channel Reinhard `x / (1 + x)`, then `sqrt` (what
/// MLAA's edge test compares; also where the report's anti-aliasing crop looks for the largest error).
#[must_use]
pub fn display_luma(c: Vec3) -> f32 {
    let x = c.max(Vec3::ZERO);
    let r = x / (Vec3::ONE + x);
    Vec3::new(0.2126, 0.7152, 0.0722).dot(r).sqrt()
}

/// One scan direction: separation lines lie between consecutive `lines`; runs go along `len` positions.
struct Axis {
    lines: usize,
    len: usize,
    line_stride: usize,
    pos_stride: usize,
    /// Weight slot of a pixel on line k blending toward line k + 1, and of a pixel on line k + 1 toward line k.
    slots: [usize; 2],
}

/// Which side of a separation line (line k or line k + 1) a crossing edge lies on.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Side {
    Near,
    Far,
}

/// Counts of one pass.
#[derive(Default)]
struct PassCounts {
    edges: u64,
    l: u64,
    z: u64,
    u: u64,
}

/// Finds the runs of one direction, classifies them and adds their blend weights.
fn scan(luma: &[f32], weights: &mut [[f32; 4]], ax: &Axis, cfg: &MlaaConfig) -> PassCounts {
    let edge = |p: usize, q: usize| (luma[p] - luma[q]).abs() > cfg.threshold;
    let px = |line0: usize, i: usize| line0 + i * ax.pos_stride;
    let mut counts = PassCounts::default();
    for k in 0..ax.lines.saturating_sub(1) {
        let near = k * ax.line_stride;
        let far = near + ax.line_stride;
        // The crossing edge between positions i - 1 and i, if it is on exactly one side, and the share of the blend
        // its end keeps: `corner_rounding` when the crossing edge continues one line further from the separation
        // line (a corner), else 1 (a step of an aliased line).
        let crossing = |i: usize| -> Option<(Side, f32)> {
            if i == 0 || i == ax.len {
                return None;
            }
            let side = match (edge(px(near, i - 1), px(near, i)), edge(px(far, i - 1), px(far, i))) {
                (true, false) => Side::Near,
                (false, true) => Side::Far,
                _ => return None,
            };
            let beyond = match side {
                Side::Near => k.checked_sub(1).map(|b| b * ax.line_stride),
                Side::Far => (k + 2 < ax.lines).then(|| far + ax.line_stride),
            };
            let corner = beyond.is_some_and(|b| edge(px(b, i - 1), px(b, i)));
            Some((side, if corner { cfg.corner_rounding } else { 1.0 }))
        };
        let mut start = None;
        for i in 0..=ax.len {
            let on = i < ax.len && edge(px(near, i), px(far, i));
            match (on, start) {
                (true, None) => start = Some(i),
                (false, Some(a)) => {
                    start = None;
                    let run = i - a;
                    counts.edges += run as u64;
                    let (left, right) = (crossing(a), crossing(i));
                    match (left, right) {
                        (None, None) => continue,
                        (Some(_), None) | (None, Some(_)) => counts.l += 1,
                        (Some((s, _)), Some((t, _))) if s == t => counts.u += 1,
                        (Some(_), Some(_)) => counts.z += 1,
                    }
                    let half = (run as f32 * 0.5).min(cfg.max_search as f32);
                    add_end(weights, ax, [near, far], left, a, true, half);
                    add_end(weights, ax, [near, far], right, i - 1, false, half);
                }
                _ => {}
            }
        }
    }
    counts
}

/// Adds the trapezoid areas under one shape end's line: from height 1/2 at the run end (`first`, stepping
/// `forward` or backward into the run) down to 0 at `half` pixels in, onto the pixels on the crossing edge's side.
fn add_end(
    weights: &mut [[f32; 4]],
    ax: &Axis,
    lines: [usize; 2],
    end: Option<(Side, f32)>,
    first: usize,
    forward: bool,
    half: f32,
) {
    let Some((side, keep)) = end else { return };
    if keep <= 0.0 {
        return;
    }
    let (line0, slot) = match side {
        Side::Near => (lines[0], ax.slots[0]),
        Side::Far => (lines[1], ax.slots[1]),
    };
    for j in 0..half.ceil() as usize {
        let t0 = j as f32;
        let t1 = (t0 + 1.0).min(half);
        // ∫ 0.5·(1 − t/half) dt over [t0, t1].
        let area = keep * 0.5 * (t1 - t0) * (1.0 - (t0 + t1) / (2.0 * half));
        let pos = if forward { first + j } else { first - j };
        weights[line0 + pos * ax.pos_stride][slot] += area;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Plane = [f64; 3]; // {(x, y) : a·x + b·y <= d}

    fn inside(planes: &[Plane], x: f64, y: f64) -> bool {
        planes.iter().all(|&[a, b, d]| a * x + b * y <= d)
    }

    /// White where the pixel centre is inside the convex region, black elsewhere.
    fn aliased(w: u32, h: u32, planes: &[Plane]) -> Vec<Vec3> {
        let mut v = Vec::new();
        for y in 0..h {
            for x in 0..w {
                v.push(Vec3::splat(if inside(planes, x as f64 + 0.5, y as f64 + 0.5) { 1.0 } else { 0.0 }));
            }
        }
        v
    }

    /// Exact area of each pixel inside the convex region: the pixel square clipped by every plane.
    fn coverage(w: u32, h: u32, planes: &[Plane]) -> Vec<Vec3> {
        let mut v = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let (x, y) = (x as f64, y as f64);
                let mut poly = vec![(x, y), (x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0)];
                for &[a, b, d] in planes {
                    let mut next = Vec::new();
                    for i in 0..poly.len() {
                        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
                        let (fp, fq) = (a * p.0 + b * p.1 - d, a * q.0 + b * q.1 - d);
                        if fp <= 0.0 {
                            next.push(p);
                        }
                        if (fp <= 0.0) != (fq <= 0.0) {
                            let t = fp / (fp - fq);
                            next.push((p.0 + t * (q.0 - p.0), p.1 + t * (q.1 - p.1)));
                        }
                    }
                    poly = next;
                }
                let n = poly.len();
                let area2: f64 =
                    (0..n).map(|i| poly[i].0 * poly[(i + 1) % n].1 - poly[(i + 1) % n].0 * poly[i].1).sum();
                v.push(Vec3::splat((area2.abs() * 0.5) as f32));
            }
        }
        v
    }

    fn rmse(a: &[Vec3], b: &[Vec3]) -> f64 {
        let s: f64 = a.iter().zip(b).map(|(p, q)| f64::from((*p - *q).length_squared()) / 3.0).sum();
        (s / a.len() as f64).sqrt()
    }

    /// Runs MLAA on the aliased region and returns (error ratio vs exact coverage, stats).
    fn ratio(name: &str, w: u32, h: u32, planes: &[Plane]) -> (f64, MlaaStats) {
        let (img, exact) = (aliased(w, h, planes), coverage(w, h, planes));
        let (out, stats) = mlaa(&img, w, h, &MlaaConfig::default());
        let (e0, e1) = (rmse(&img, &exact), rmse(&out, &exact));
        println!("{name}: rmse aliased {e0:.4}, mlaa {e1:.4}, ratio {:.3}; {stats:?}", e1 / e0);
        (e1 / e0, stats)
    }

    /// Rotated square: centre, half side, angle.
    fn square(cx: f64, cy: f64, s: f64, angle: f64) -> Vec<Plane> {
        let (sn, cs) = angle.sin_cos();
        [(cs, sn), (-sn, cs), (-cs, -sn), (sn, -cs)].iter().map(|&(a, b)| [a, b, a * cx + b * cy + s]).collect()
    }

    fn xorshift(state: &mut u64) -> f32 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    #[test]
    fn constant_image_is_unchanged() {
        let img = vec![Vec3::new(0.3, 2.5, 0.01); 17 * 9];
        let (out, stats) = mlaa(&img, 17, 9, &MlaaConfig::default());
        assert!(out.iter().zip(&img).all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)));
        assert_eq!(stats, MlaaStats::default());
    }

    #[test]
    fn straight_axis_aligned_edges_are_unchanged() {
        let (a, b) = (Vec3::new(0.2, 0.5, 1.0), Vec3::new(3.0, 2.0, 0.0));
        let (w, h) = (20u32, 12u32);
        for vertical in [true, false] {
            let img: Vec<Vec3> =
                (0..w * h).map(|i| if (vertical && i % w < 7) || (!vertical && i / w < 5) { a } else { b }).collect();
            let (out, stats) = mlaa(&img, w, h, &MlaaConfig::default());
            assert_eq!(out, img, "vertical = {vertical}");
            let (edges, other) = if vertical { (stats.edges_v, stats.edges_h) } else { (stats.edges_h, stats.edges_v) };
            assert_eq!((edges, other), (u64::from(if vertical { h } else { w }), 0));
            assert_eq!(stats.shapes_l + stats.shapes_z + stats.shapes_u + stats.blended_pixels, 0, "{stats:?}");
        }
    }

    /// An axis-aligned rectangle's edges are exact: every blend at its corners is error. Corner rounding scales
    /// them (0 leaves the image as it is), while an aliased line's steps keep their full blend.
    #[test]
    fn corners_are_kept_sharp_by_corner_rounding() {
        let (w, h) = (24, 20);
        let img: Vec<Vec3> = (0..w * h)
            .map(|p| if (5..17).contains(&(p % w)) && (4..13).contains(&(p / w)) { Vec3::ONE } else { Vec3::ZERO })
            .collect();
        let with = |r: f32| mlaa(&img, w as u32, h as u32, &MlaaConfig { corner_rounding: r, ..MlaaConfig::default() });
        let (sharp, stats) = with(0.0);
        assert_eq!(sharp, img, "corner rounding 0 keeps the rectangle");
        assert!(stats.shapes_u >= 4, "{stats:?}");
        let err = |r: f32| rmse(&with(r).0, &img);
        let (mlaa_err, smaa_err) = (err(1.0), err(MlaaConfig::default().corner_rounding));
        assert!(mlaa_err > 0.0 && smaa_err > 0.0 && smaa_err < 0.3 * mlaa_err, "{smaa_err} vs {mlaa_err}");
        // A shallow line's steps are not corners: they keep their blend with corners kept fully sharp.
        let planes = [[-0.2, 1.0, 9.3]];
        let (exact, line) = (coverage(64, 24, &planes), aliased(64, 24, &planes));
        let sharp = mlaa(&line, 64, 24, &MlaaConfig { corner_rounding: 0.0, ..MlaaConfig::default() }).0;
        let r = rmse(&sharp, &exact) / rmse(&line, &exact);
        assert!(r < 0.6, "shallow line with corner rounding 0: rmse ratio {r:.3}");
    }

    #[test]
    fn shallow_slope_error_drops() {
        // y <= 0.25·x + 20.3, white below the line in image coordinates.
        let (r, s) = ratio("shallow 1/4", 64, 64, &[[-0.25, 1.0, 20.3]]);
        assert!(r < 0.6, "shallow slope: rmse ratio {r:.3}");
        assert!(s.shapes_z > 10 && s.blended_pixels > 0, "{s:?}");
    }

    #[test]
    fn steep_slope_error_drops() {
        let (r, s) = ratio("steep 4/1", 64, 64, &[[1.0, -0.25, 20.3]]);
        assert!(r < 0.6, "steep slope: rmse ratio {r:.3}");
        assert!(s.shapes_z > 10, "{s:?}");
        let (r2, _) = ratio("shallow 1/4", 64, 64, &[[-0.25, 1.0, 20.3]]);
        assert!((r - r2).abs() < 1e-4, "transpose changed the result: {r} vs {r2}");
    }

    #[test]
    fn diagonal_error_drops() {
        // A 45° staircase is ambiguous (each step is a 1-pixel Z); the reconstructed line runs through the steps'
        // midpoints, exact only for some offsets, so the mean over offsets is what is checked.
        let (mut sum, mut worst) = (0.0, 0.0_f64);
        for k in 0..8 {
            let r = ratio("45°", 64, 64, &[[-1.0, 1.0, 3.0 + f64::from(k) / 8.0]]).0;
            sum += r;
            worst = worst.max(r);
        }
        let r = sum / 8.0;
        println!("45° ratio: mean {r:.3}, worst {worst:.3}");
        assert!(r < 0.6 && worst < 0.85, "45° line: rmse ratio mean {r:.3}, worst {worst:.3}");
    }

    #[test]
    fn rotated_square_error_drops_and_has_all_shapes() {
        // Clipped by the right border (L shapes at the border), steps along its sides (Z), a tip at the top (U).
        let (r, s) = ratio("square 20°", 64, 64, &square(40.0, 30.0, 22.0, 20f64.to_radians()));
        assert!(r < 0.6, "rotated square: rmse ratio {r:.3}");
        assert!(s.shapes_l > 0 && s.shapes_z > 0 && s.shapes_u > 0, "{s:?}");
    }

    #[test]
    fn non_finite_input_does_not_propagate() {
        let mut st = 7u64;
        let (w, h) = (23u32, 19u32);
        let mut img: Vec<Vec3> = (0..w * h).map(|_| Vec3::splat(xorshift(&mut st) * 4.0)).collect();
        for (i, bad) in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX].iter().cycle().take(60).enumerate() {
            img[(i * 37) % (w * h) as usize] = Vec3::new(*bad, 0.5, *bad);
        }
        img[0] = Vec3::NAN;
        let (out, stats) = mlaa(&img, w, h, &MlaaConfig::default());
        assert!(out.iter().all(|c| c.is_finite()), "non-finite output");
        assert!(stats.blended_pixels > 0);
        // A lone NaN pixel in a black image reads as black: nothing to do.
        let mut black = vec![Vec3::ZERO; 25];
        black[12] = Vec3::new(f32::NAN, f32::INFINITY, 0.0);
        let (out, stats) = mlaa(&black, 5, 5, &MlaaConfig::default());
        assert_eq!((out, stats), (vec![Vec3::ZERO; 25], MlaaStats::default()));
    }

    #[test]
    fn output_stays_within_neighbourhood_range() {
        let mut st = 0x9e37_79b9_7f4a_7c15u64;
        let (w, h) = (61usize, 47usize);
        // Random blocky colours (long runs) plus noise, HDR range.
        let img: Vec<Vec3> = (0..w * h)
            .map(|i| {
                let block = ((i % w) / 5 + 3 * ((i / w) / 3)) as u64;
                let mut bs = block.wrapping_mul(0x2545_f491_4f6c_dd1d) | 1;
                let base = Vec3::new(xorshift(&mut bs), xorshift(&mut bs), xorshift(&mut bs)) * 5.0;
                if xorshift(&mut st) < 0.1 {
                    Vec3::new(xorshift(&mut st), xorshift(&mut st), xorshift(&mut st))
                } else {
                    base
                }
            })
            .collect();
        let (out, stats) = mlaa(&img, w as u32, h as u32, &MlaaConfig::default());
        assert!(stats.blended_pixels > 100 && stats.shapes_l + stats.shapes_z + stats.shapes_u > 100, "{stats:?}");
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                let (mut lo, mut hi) = (img[p], img[p]);
                let nbrs =
                    [(x > 0, p.wrapping_sub(1)), (x + 1 < w, p + 1), (y > 0, p.wrapping_sub(w)), (y + 1 < h, p + w)];
                for (ok, q) in nbrs {
                    if ok {
                        lo = lo.min(img[q]);
                        hi = hi.max(img[q]);
                    }
                }
                assert!(out[p].cmpge(lo).all() && out[p].cmple(hi).all(), "({x}, {y}): {} not in [{lo}, {hi}]", out[p]);
            }
        }
    }

    #[test]
    fn degenerate_sizes_do_not_panic() {
        let mut st = 3u64;
        for (w, h) in [(0u32, 0u32), (0, 5), (5, 0), (1, 1), (1, 9), (9, 1), (2, 2), (2, 7), (7, 2)] {
            let img: Vec<Vec3> = (0..w * h).map(|_| Vec3::splat(xorshift(&mut st).round())).collect();
            let (out, _) = mlaa(&img, w, h, &MlaaConfig::default());
            assert_eq!(out.len(), img.len());
            if w == 1 || h == 1 {
                assert_eq!(out, img, "{w}×{h}: a 1-wide image has no shape ends");
            }
        }
        let (out, _) =
            mlaa(&[Vec3::ONE; 4], 2, 2, &MlaaConfig { threshold: -1.0, max_search: 0, ..MlaaConfig::default() });
        assert_eq!(out, vec![Vec3::ONE; 4]);
    }

    #[test]
    #[cfg(debug_assertions)]
    #[should_panic(expected = "width × height")]
    fn length_mismatch_is_a_caller_bug() {
        let _ = mlaa(&[Vec3::ZERO; 5], 2, 3, &MlaaConfig::default());
    }

    #[test]
    #[ignore = "timing; run with cargo test --release -- --ignored --nocapture"]
    fn timing_1280x720() {
        let (w, h) = (1280u32, 720u32);
        let mut st = 11u64;
        let shapes: Vec<(Vec<Plane>, Vec3)> = (0..40)
            .map(|_| {
                let (x, y, s, a) = (xorshift(&mut st), xorshift(&mut st), xorshift(&mut st), xorshift(&mut st));
                let c = Vec3::new(xorshift(&mut st), xorshift(&mut st), xorshift(&mut st)) * 3.0;
                (
                    square(
                        f64::from(x) * 1280.0,
                        f64::from(y) * 720.0,
                        20.0 + f64::from(s) * 120.0,
                        f64::from(a) * 3.0,
                    ),
                    c,
                )
            })
            .collect();
        let mut img = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let (fx, fy) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
                let bg = Vec3::new(fx as f32 / 1280.0, fy as f32 / 720.0, 0.2);
                img.push(shapes.iter().rev().find(|(p, _)| inside(p, fx, fy)).map_or(bg, |s| s.1));
            }
        }
        let noise: Vec<Vec3> = (0..w * h).map(|_| Vec3::splat(xorshift(&mut st) * 2.0)).collect();
        for (name, img) in [("scene (40 rotated squares on a gradient)", &img), ("worst case (white noise)", &noise)] {
            let mut best = f64::INFINITY;
            let mut stats = MlaaStats::default();
            for _ in 0..10 {
                let t = std::time::Instant::now();
                let (out, s) = mlaa(img, w, h, &MlaaConfig::default());
                best = best.min(t.elapsed().as_secs_f64());
                stats = s;
                assert_eq!(out.len(), img.len());
            }
            println!("mlaa 1280×720 {name}: best of 10 {:.2} ms; {stats:?}", best * 1e3);
        }
    }

    #[test]
    fn display_blend_stays_in_range_and_pulls_less_toward_bright_pixels() {
        // A shallow staircase of radiance 100 over 0.1.
        let (w, h) = (32u32, 16u32);
        let img: Vec<Vec3> = (0..w * h)
            .map(|i| if (i / w) as f32 > 4.0 + 0.25 * (i % w) as f32 { Vec3::splat(100.0) } else { Vec3::splat(0.1) })
            .collect();
        let lin = mlaa(&img, w, h, &MlaaConfig::default()).0;
        let disp = mlaa(&img, w, h, &MlaaConfig { display_blend: true, ..MlaaConfig::default() }).0;
        let mut changed = 0;
        for ((&l, &d), &c) in lin.iter().zip(&disp).zip(&img) {
            assert!(d.is_finite() && d.min_element() >= 0.1 - 1e-6 && d.max_element() <= 100.0 + 1e-3, "{d}");
            if c.x < 1.0 && l.x > c.x {
                // A dark pixel blended toward the bright side moves less in display space.
                assert!(d.x <= l.x + 1e-4, "display {d} linear {l}");
                changed += 1;
            }
        }
        assert!(changed > 0, "the staircase was blended");
    }
}
