//! Shading rates below one per pixel: shading-rate images (SRIs) from the G-buffer, and what coarse shading lights.
//!
//! An SRI holds one [`Rate`] per `tile × tile` pixels (D3D12 Tier 2 / Vulkan fragment-shading-rate attachments):
//! one lighting evaluation per `w × h` coarse pixel, coarse pixels aligned to the tile grid. Composed with MSAA as
//! hardware composes them: a pixel the edge detector marks is shaded per sample whatever its tile's rate; the
//! other covered pixels of a coarse pixel share one evaluation, at its **representative**: the first of its
//! non-edge pixels, in row order, that has a covered sample (the top-left pixel when covered, as a GPU's coarse
//! pixel shades at its first covered pixel's position).
//!
//! [`gbuffer_sri`] is gbuf's generator, computed before any lighting from what the G-buffer holds (the rule is
//! written at [`Smoothness`]). `resolve::resolve_coarse` (a later stage) shades by an SRI (`broadcast`: the
//! representative's colour for every pixel; `lighting`: that colour remodulated by each pixel's own albedo, as
//! engines that shade lighting apart from albedo do), and [`evaluations`] counts beforehand what it evaluates.

use crate::base::mask::EdgeMask;
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use glam::Vec3;

/// One evaluation per `w × h` pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Rate {
    /// Full rate.
    R1x1,
    /// 1 wide, 2 tall.
    R1x2,
    /// 2 wide, 1 tall.
    R2x1,
    /// 2 × 2.
    R2x2,
    /// 2 wide, 4 tall (an additional rate).
    R2x4,
    /// 4 wide, 2 tall (an additional rate).
    R4x2,
    /// 4 × 4 (an additional rate).
    R4x4,
}

impl Rate {
    /// Every rate, finest first.
    pub const ALL: [Rate; 7] = [Rate::R1x1, Rate::R1x2, Rate::R2x1, Rate::R2x2, Rate::R2x4, Rate::R4x2, Rate::R4x4];

    /// Coarse-pixel width and height in pixels.
    #[must_use]
    pub fn size(self) -> (u32, u32) {
        match self {
            Rate::R1x1 => (1, 1),
            Rate::R1x2 => (1, 2),
            Rate::R2x1 => (2, 1),
            Rate::R2x2 => (2, 2),
            Rate::R2x4 => (2, 4),
            Rate::R4x2 => (4, 2),
            Rate::R4x4 => (4, 4),
        }
    }

    /// May a target of `samples` samples use this rate? D3D12's rule: the base rates (to 2 × 2), the additional
    /// ones (2 × 4, 4 × 2, 4 × 4) only with `extra` (`AdditionalShadingRatesSupported`), and a coarse pixel never
    /// spans more than 16 samples (2 × 2 up to 4× MSAA, 2 × 4 up to 2×, 4 × 4 single-sampled, none beyond 2 pixels
    /// at 8×).
    #[must_use]
    pub fn allowed(self, samples: u32, extra: bool) -> bool {
        let (w, h) = self.size();
        (w * h <= 4 || extra) && w * h * samples.max(1) <= 16
    }

    /// The largest rate allowed ([`Rate::allowed`]) that fits a `w × h` coarse pixel: the longer side halved until
    /// it is (a side of 4 against a side of 1, which no rate has, becomes 2).
    #[must_use]
    pub fn fit(w: u32, h: u32, extra: bool, samples: u32) -> Rate {
        let (mut w, mut h) = (w.clamp(1, 4), h.clamp(1, 4));
        loop {
            if w == 4 && h == 1 {
                w = 2;
            }
            if h == 4 && w == 1 {
                h = 2;
            }
            let r = Rate::of_size(w, h);
            if r.allowed(samples, extra) || (w, h) == (1, 1) {
                return r;
            }
            if w >= h {
                w /= 2;
            } else {
                h /= 2;
            }
        }
    }

    /// The rate of a `w × h` coarse pixel (sides 1, 2 or 4; `1 × 4` and `4 × 1` do not occur).
    fn of_size(w: u32, h: u32) -> Rate {
        match (w, h) {
            (1, 1) => Rate::R1x1,
            (1, _) => Rate::R1x2,
            (_, 1) => Rate::R2x1,
            (2, 2) => Rate::R2x2,
            (2, _) => Rate::R2x4,
            (_, 2) => Rate::R4x2,
            _ => Rate::R4x4,
        }
    }

    /// D3D12's `D3D12_SHADING_RATE` value (and Vulkan's fragment-shading-rate attachment texel): `log2(w) << 2 |
    /// log2(h)`.
    #[must_use]
    pub fn d3d12(self) -> u8 {
        let (w, h) = self.size();
        ((w.trailing_zeros() << 2) | h.trailing_zeros()) as u8
    }

    /// The rate of a `D3D12_SHADING_RATE` value ([`Rate::d3d12`]); a value that names none is full rate.
    #[must_use]
    pub fn from_d3d12(code: u8) -> Rate {
        Rate::ALL.into_iter().find(|r| r.d3d12() == code).unwrap_or(Rate::R1x1)
    }

    /// Name, `WxH`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Rate::R1x1 => "1x1",
            Rate::R1x2 => "1x2",
            Rate::R2x1 => "2x1",
            Rate::R2x2 => "2x2",
            Rate::R2x4 => "2x4",
            Rate::R4x2 => "4x2",
            Rate::R4x4 => "4x4",
        }
    }

    /// The colour engines' shading-rate debug views use (full rate clear, coarser rates warmer): green 1×1, cyan
    /// and blue for the 2-pixel rates, yellow 2×2, orange and red beyond.
    #[must_use]
    pub fn colour(self) -> [u8; 3] {
        match self {
            Rate::R1x1 => [40, 160, 60],
            Rate::R1x2 => [40, 160, 200],
            Rate::R2x1 => [60, 90, 220],
            Rate::R2x2 => [230, 210, 50],
            Rate::R2x4 => [240, 150, 40],
            Rate::R4x2 => [230, 110, 40],
            Rate::R4x4 => [210, 40, 40],
        }
    }
}

/// A shading-rate image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sri {
    /// Tile size in pixels (8, 16 or 32).
    pub tile: u32,
    /// Tiles across and down (the image's size rounded up).
    pub cols: u32,
    /// Tile rows.
    pub rows: u32,
    /// One rate per tile, row-major.
    pub rates: Vec<Rate>,
}

impl Sri {
    /// Every tile at `rate`.
    #[must_use]
    pub fn uniform(width: u32, height: u32, tile: u32, rate: Rate) -> Sri {
        let tile = tile.max(1);
        let (cols, rows) = (width.div_ceil(tile), height.div_ceil(tile));
        Sri { tile, cols, rows, rates: vec![rate; (cols * rows) as usize] }
    }

    /// Every tile's rate brought within what a target of `samples` samples allows ([`Rate::fit`]), as hardware
    /// clamps an SRI.
    #[must_use]
    pub fn clamped(mut self, samples: u32, extra: bool) -> Sri {
        for r in &mut self.rates {
            let (w, h) = r.size();
            *r = Rate::fit(w, h, extra, samples);
        }
        self
    }

    /// The rate of pixel (x, y).
    #[must_use]
    pub fn at(&self, x: u32, y: u32) -> Rate {
        self.rates[((y / self.tile) * self.cols + x / self.tile) as usize]
    }

    /// How many tiles have each rate, in [`Rate::ALL`]'s order.
    #[must_use]
    pub fn histogram(&self) -> [usize; 7] {
        let mut h = [0; 7];
        for r in &self.rates {
            h[Rate::ALL.iter().take_while(|&x| x != r).count()] += 1;
        }
        h
    }

    /// The SRI as D3D12 consumes it: one `R8_UINT` texel per tile, `D3D12_SHADING_RATE` values, rows top first.
    #[must_use]
    pub fn d3d12_texels(&self) -> Vec<u8> {
        self.rates.iter().map(|r| r.d3d12()).collect()
    }

    /// The SRI as a picture: each pixel in its tile's rate colour (interleaved RGB, `width × height`).
    #[must_use]
    pub fn picture(&self, width: u32, height: u32) -> Vec<u8> {
        let mut out = Vec::with_capacity(width as usize * height as usize * 3);
        for y in 0..height {
            for x in 0..width {
                let mut c = self.at(x, y).colour();
                if x % self.tile == 0 || y % self.tile == 0 {
                    c = c.map(|v| v / 2); // tile borders
                }
                out.extend_from_slice(&c);
            }
        }
        out
    }
}

/// Whether two neighbouring pixels may share an evaluation: gbuf's rule, on what a deferred renderer holds before
/// it lights.
///
/// Two pixels are **smooth** when neither is an edge pixel of the mask, both are covered or both are not, they hold
/// the same object and material IDs (when the frame has them), their depths differ by at most `depth_relative`
/// of the nearer, their normals by at most `normal_deg` scaled by the surface's roughness (`normal_deg · (0.25 +
/// roughness)`: a sharp highlight moves with a small turn of the normal, a rough lobe does not; on metals, where the
/// highlight is all of the colour, also at most `lobe` times the GGX lobe width `roughness²` in radians, since a
/// polished curved metal's highlight is narrower than a pixel), and — when the
/// coarse pixel's colour is broadcast — their albedos by at most `albedo` in every channel (broadcast copies one
/// albedo to the whole coarse pixel, so albedo contrast shows directly). Specular amount and roughness must agree
/// within `albedo` too (they shape the lobe). A coarse pixel is allowed when every pair of horizontally (for its
/// width) or vertically (for its height) adjacent pixels inside it is smooth; a tile takes the coarsest rate every
/// coarse pixel in it allows, per direction. Given a [`Preview`] of the lighting, the tile then takes the coarsest of
/// those sizes whose mean preview error stays within [`Smoothness::preview`]: what the G-buffer cannot see, the
/// lighting's own gradients (docs/DECISIONS.md, "Shading rates from the G-buffer").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Smoothness {
    /// Largest relative depth step.
    pub depth_relative: f32,
    /// Largest normal turn in degrees at roughness 0.75 (scaled by `0.25 + roughness`).
    pub normal_deg: f32,
    /// Largest albedo, specular and roughness difference (linear, any channel).
    pub albedo: f32,
    /// Whether albedo differences count (broadcast mode).
    pub broadcast: bool,
    /// On metals (metallic ≥ 0.5), the largest normal turn in units of the GGX lobe width `roughness²` (radians;
    /// 0: no such limit).
    pub lobe: f32,
    /// When a [`Preview`] of the lighting is given: the largest mean error per covered pixel of a tile, in displayed
    /// units (sRGB-encoded [0, 1]: 1/255 is one 8-bit code), that sharing evaluations may cost, estimated from the
    /// lighting's preview (`resolve::LightPreview`). A tile takes the coarsest rate the other tests allow whose
    /// pixels' previews differ from their coarse pixel's representative's by at most this on average (0: no such
    /// limit). The previews are the broadcast colour's: in `lighting` mode, whose remodulation restores each pixel's
    /// albedo, they bound its error from above.
    pub preview: f32,
}

/// [`Smoothness::preview`] by default: an eighth of an 8-bit code on average.
pub const DEFAULT_PREVIEW: f32 = 0.125 / 255.0;

impl Default for Smoothness {
    fn default() -> Self {
        Smoothness {
            depth_relative: 0.01,
            normal_deg: 4.0,
            albedo: 0.02,
            broadcast: true,
            lobe: 0.5,
            preview: DEFAULT_PREVIEW,
        }
    }
}

/// One band of tile rows of a frame in the form the smoothness tests read (structure of arrays, one entry per pixel,
/// at its first covered sample): built once per band, then every adjacent pair is tested from it.
#[derive(Default)]
struct Band {
    /// 0: uncovered, 1: covered, 2: an edge pixel (never smooth).
    state: Vec<u8>,
    depth: Vec<f32>,
    nx: Vec<f32>,
    ny: Vec<f32>,
    nz: Vec<f32>,
    /// The cosine of the pixel's largest normal turn (`normal_deg · (0.25 + roughness)`).
    cos_turn: Vec<f32>,
    rough: Vec<f32>,
    spec: Vec<f32>,
    ar: Vec<f32>,
    ag: Vec<f32>,
    ab: Vec<f32>,
    material: Vec<u32>,
    object: Vec<u32>,
    /// The lighting's displayed preview (empty without a [`Preview`]).
    preview: Vec<f32>,
}

/// `cos x` for `x` in [0, π] by its Taylor series to x¹² (within 1e-9 below 80°, 1e-4 at π): the smoothness test's
/// threshold, per pixel, in straight-line code the compiler vectorises.
#[inline(always)]
fn cos_taylor(x: f32) -> f32 {
    let x2 = x * x;
    let mut c = 1.0 / 479_001_600.0; // 1/12!
    for k in [-1.0 / 3_628_800.0, 1.0 / 40_320.0, -1.0 / 720.0, 1.0 / 24.0, -0.5, 1.0] {
        c = c * x2 + k;
    }
    c
}

impl Band {
    /// Rows `y0..y1` of `gb`. Inlined into the kernel, so that it and the preview are compiled for its instruction
    /// set.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn fill(
        &mut self,
        gb: &GBuffer,
        mask: &EdgeMask,
        rule: &Smoothness,
        preview: Option<&dyn Preview>,
        block: usize,
        y0: u32,
        y1: u32,
    ) {
        let (w, s) = (gb.width as usize, gb.samples as usize);
        let (p0, p1) = (y0 as usize * w, y1 as usize * w);
        let n = p1 - p0;
        self.state.clear();
        let mut at = Vec::with_capacity(n);
        for p in p0..p1 {
            let a = (p * s..(p + 1) * s).find(|&i| gb.coverage[i]);
            self.state.push(if mask.is_edge(p) { 2 } else { u8::from(a.is_some()) });
            at.push(a.unwrap_or(p * s));
        }
        fn take<T: Copy + Default>(out: &mut Vec<T>, plane: Option<&Vec<T>>, at: &[usize], default: T) {
            out.clear();
            match plane {
                Some(v) => out.extend(at.iter().map(|&i| v[i])),
                None => out.resize(at.len(), default),
            }
        }
        take(&mut self.depth, gb.depth.as_ref(), &at, 0.0);
        take(&mut self.rough, gb.roughness.as_ref(), &at, f32::NAN);
        take(&mut self.spec, gb.specular.as_ref(), &at, 0.0);
        take(&mut self.material, gb.material_id.as_ref(), &at, 0);
        take(&mut self.object, gb.object_id.as_ref(), &at, 0);
        for v in [&mut self.nx, &mut self.ny, &mut self.nz, &mut self.ar, &mut self.ag, &mut self.ab] {
            v.clear();
        }
        let unit = |v: Vec3| v.normalize_or_zero();
        match &gb.normal {
            Some(nv) => {
                for &i in &at {
                    let u = unit(nv[i]);
                    self.nx.push(u.x);
                    self.ny.push(u.y);
                    self.nz.push(u.z);
                }
            }
            None => {
                self.nx.resize(n, 0.0);
                self.ny.resize(n, 0.0);
                self.nz.resize(n, 1.0);
            }
        }
        match gb.albedo.as_ref().filter(|_| rule.broadcast || preview.is_some()) {
            Some(al) => {
                for &i in &at {
                    self.ar.push(al[i].x);
                    self.ag.push(al[i].y);
                    self.ab.push(al[i].z);
                }
            }
            None => {
                self.ar.resize(n, 0.0);
                self.ag.resize(n, 0.0);
                self.ab.resize(n, 0.0);
            }
        }
        // A missing or unreadable roughness stands at 0.75 (the rule's reference).
        for r in &mut self.rough {
            *r = if r.is_nan() { 0.75 } else { r.clamp(0.0, 1.0) };
        }
        let to_rad = rule.normal_deg.to_radians();
        let mut metal = Vec::new();
        take(&mut metal, gb.metallic.as_ref(), &at, 0.0);
        self.cos_turn.clear();
        self.cos_turn.extend(self.rough.iter().zip(&metal).map(|(&r, &m)| {
            let turn = to_rad * (0.25 + r);
            // A metal's highlight: at most `lobe` lobe widths (α = r², at least 1e-3 as the resolve clamps it).
            let turn = if m >= 0.5 && rule.lobe > 0.0 { turn.min(rule.lobe * (r * r).max(1e-3)) } else { turn };
            cos_taylor(turn.clamp(0.0, std::f32::consts::PI))
        }));
        match preview {
            Some(lit) => {
                let g = Gathered {
                    depth: &self.depth,
                    normal: [&self.nx, &self.ny, &self.nz],
                    albedo: [&self.ar, &self.ag, &self.ab],
                    roughness: &self.rough,
                    metallic: &metal,
                };
                lit.pixels(p0, &at, &g, block, &mut self.preview);
            }
            None => self.preview.clear(),
        }
    }

    /// The previews' error if the pixels `x0..x1` of rows `0..rows` (band width `w`) shared one evaluation per
    /// `cw × ch` coarse pixel: the sum over covered pixels of the distance of their preview from their coarse
    /// pixel's representative's (its first covered pixel in row order; edge pixels are shaded per sample and count
    /// nothing).
    fn shared_error(&self, w: usize, rows: usize, x0: usize, x1: usize, cw: usize, ch: usize) -> f32 {
        let mut err = 0.0;
        for by in (0..rows).step_by(ch) {
            for bx in (x0..x1).step_by(cw) {
                let mut rep = None;
                for r in by..(by + ch).min(rows) {
                    for x in bx..(bx + cw).min(x1) {
                        let i = r * w + x;
                        if self.state[i] != 1 {
                            continue;
                        }
                        match rep {
                            None => rep = Some(self.preview[i]),
                            Some(v) => err += (self.preview[i] - v).abs(),
                        }
                    }
                }
            }
        }
        err
    }

    /// `out[k]`: whether pixels `k` and `k + off` of the band are smooth ([`Smoothness`]), for `k < out.len()`:
    /// `off` 1 for horizontal pairs, the width for vertical ones. Branch-free over slices of one length, so the
    /// compiler vectorises it.
    #[inline(always)]
    fn pairs(&self, rule: &Smoothness, off: usize, out: &mut [bool]) {
        let m = out.len();
        fn split(v: &[f32], m: usize, off: usize) -> (&[f32], &[f32]) {
            (&v[..m], &v[off..off + m])
        }
        let both = |v| split(v, m, off);
        let (st0, st1) = (&self.state[..m], &self.state[off..off + m]);
        let (d0, d1) = both(&self.depth);
        let ((x0, x1), (y0, y1), (z0, z1)) = (both(&self.nx), both(&self.ny), both(&self.nz));
        let (c0, c1) = both(&self.cos_turn);
        let ((r0, r1), (s0, s1)) = (both(&self.rough), both(&self.spec));
        let ((a0, a1), (g0, g1), (b0, b1)) = (both(&self.ar), both(&self.ag), both(&self.ab));
        let (m0, m1) = (&self.material[..m], &self.material[off..off + m]);
        let (o0, o1) = (&self.object[..m], &self.object[off..off + m]);
        let close = |a: f32, b: f32| (a - b).abs() <= rule.albedo;
        for k in 0..m {
            let (si, sj) = (st0[k], st1[k]);
            let both = (si == 1) & (sj == 1);
            let depth_ok = (d0[k] - d1[k]).abs() <= rule.depth_relative * d0[k].abs().min(d1[k].abs());
            let cos = (x0[k] * x1[k] + y0[k] * y1[k] + z0[k] * z1[k]).clamp(-1.0, 1.0);
            // The looser of the two thresholds: the pair's smaller roughness has the larger cosine.
            let normal_ok = cos >= c0[k].max(c1[k]);
            let scalars_ok = close(s0[k], s1[k]) & close(r0[k], r1[k]);
            let albedo_ok = (close(a0[k], a1[k]) & close(g0[k], g1[k]) & close(b0[k], b1[k])) | !rule.broadcast;
            let ids_ok = (m0[k] == m1[k]) & (o0[k] == o1[k]);
            // Two uncovered pixels are smooth; an edge pixel or a covered one beside an uncovered one is not.
            out[k] = (both & depth_ok & normal_ok & scalars_ok & albedo_ok & ids_ok) | ((si == 0) & (sj == 0));
        }
    }
}

/// The rates of one band of tile rows (`rates`: its tiles), from the band's pixels: each tile takes, per direction,
/// the coarsest size every adjacent pair inside its coarse pixels allows.
struct BandRates<'a> {
    gb: &'a GBuffer,
    preview: Option<&'a dyn Preview>,
    mask: &'a EdgeMask,
    rule: &'a Smoothness,
    tile: u32,
    extra: bool,
    ty: u32,
    rates: &'a mut [Rate],
}

impl crate::base::isa::Kernel for BandRates<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self, _: crate::base::isa::Isa) {
        let (gb, rule, tile) = (self.gb, self.rule, self.tile);
        let (w, h) = (gb.width, gb.height);
        let (y0, y1) = (self.ty * tile, ((self.ty + 1) * tile).min(h));
        let mut band = Band::default();
        band.fill(gb, self.mask, rule, self.preview, tile as usize, y0, y1);
        let (wu, rows) = (w as usize, (y1 - y0) as usize);
        // Pair bits: right[i] for (i, i + 1), down[i] for (i, i + width), within the band.
        let mut right = vec![false; wu * rows];
        let mut down = vec![false; wu * rows];
        let n = wu * rows;
        band.pairs(rule, 1, &mut right[..n.saturating_sub(1)]);
        band.pairs(rule, wu, &mut down[..n.saturating_sub(wu)]);
        let cap = if self.extra { 4 } else { 2 };
        for (tx, rate) in self.rates.iter_mut().enumerate() {
            let x0 = tx * tile as usize;
            let x1 = (x0 + tile as usize).min(wu);
            let mut rw = cap;
            while rw > 1 {
                // Pairs that straddle two coarse pixels (x − x0 ≡ rw − 1) do not count (rw is a power of two).
                let ok = (0..rows).all(|r| (x0..x1 - 1).all(|x| (x - x0) & (rw - 1) == rw - 1 || right[r * wu + x]));
                if ok {
                    break;
                }
                rw /= 2;
            }
            let mut rh = cap;
            while rh > 1 {
                let ok = (0..rows.saturating_sub(1))
                    .all(|r| r & (rh - 1) == rh - 1 || down[r * wu + x0..r * wu + x1].iter().all(|&d| d));
                if ok {
                    break;
                }
                rh /= 2;
            }
            if !band.preview.is_empty() {
                // The coarsest size within the other tests' whose previewed error stays in the budget.
                let covered =
                    (0..rows).map(|r| band.state[r * wu + x0..r * wu + x1].iter().filter(|&&s| s == 1).count());
                let budget = rule.preview * covered.sum::<usize>() as f32;
                let mut sizes: Vec<(usize, usize)> = [1, 2, 4]
                    .iter()
                    .flat_map(|&cw| [1, 2, 4].map(|ch| (cw, ch)))
                    .filter(|&(cw, ch)| cw <= rw && ch <= rh)
                    // Only the sizes the rate set holds as they are (others would be checked but emitted smaller).
                    .filter(|&(cw, ch)| {
                        Rate::fit(cw as u32, ch as u32, self.extra, gb.samples).size() == (cw as u32, ch as u32)
                    })
                    .collect();
                // Fewest evaluations first; of equal ones, the squarer (2 × 2 before 4 × 1).
                sizes.sort_by_key(|&(cw, ch)| (std::cmp::Reverse(cw * ch), cw.abs_diff(ch)));
                (rw, rh) = sizes
                    .into_iter()
                    .find(|&(cw, ch)| cw * ch == 1 || band.shared_error(wu, rows, x0, x1, cw, ch) <= budget)
                    .unwrap_or((1, 1));
            }
            *rate = Rate::fit(rw as u32, rh as u32, self.extra, gb.samples);
        }
    }
}

/// What the rule's preview term reads ([`Smoothness::preview`]): the lit frame's luminance per pixel as shown,
/// before anything is lit (`resolve::LightPreview`, made from the lights and the lighting model).
pub trait Preview: Sync {
    /// `out[k]`: the displayed preview (sRGB-encoded, in [0, 1]) of sample `at[k]`, a flat index of pixel `p0 + k` of
    /// whole rows of the frame (0 where that sample is uncovered or has no usable position). `g` holds what the
    /// caller has read at `at` already; `block` is the tile size (pixels are lit a block of columns at a time).
    fn pixels(&self, p0: usize, at: &[usize], g: &Gathered<'_>, block: usize, out: &mut Vec<f32>);

    /// The frame size the preview was made for, when it has one of its own (a lit image's): the rule refuses a frame
    /// of another size.
    fn size(&self) -> Option<(u32, u32)> {
        None
    }
}

/// What the rule has read of a band, per pixel at its sample (`at` of [`Preview::pixels`]): the view depth (0 where the
/// frame has none), the unit normal (+Z where the frame has none, zero where it is bad), the raw albedo (read only when
/// the frame has one), the roughness in [0, 1] (read only when the frame has one) and the raw metallic (0 where the
/// frame has none).
pub struct Gathered<'b> {
    /// View depth.
    pub depth: &'b [f32],
    /// Unit normal, by component.
    pub normal: [&'b [f32]; 3],
    /// Albedo, by channel.
    pub albedo: [&'b [f32]; 3],
    /// Roughness in [0, 1].
    pub roughness: &'b [f32],
    /// Metallic.
    pub metallic: &'b [f32],
}

/// gbuf's SRI of `gb` (tile size `tile`: 8, 16 or 32), from the edge `mask`, the G-buffer and, when given, the
/// `preview` of its lighting ([`Smoothness`]); `extra` allows the rates beyond 2 × 2. Bands of tile rows run in
/// parallel on rayon's current pool, each compiled for the CPU's widest instruction set.
pub fn gbuffer_sri(
    gb: &GBuffer,
    preview: Option<&dyn Preview>,
    mask: &EdgeMask,
    tile: u32,
    extra: bool,
    rule: &Smoothness,
) -> Result<Sri> {
    use rayon::prelude::*;
    if ![8, 16, 32].contains(&tile) {
        return Err(Error::Argument(format!("shading-rate tile size {tile}: use 8, 16 or 32")));
    }
    if (mask.width, mask.height) != (gb.width, gb.height) {
        return Err(Error::Mismatch("the edge mask is not the G-buffer's size".into()));
    }
    let mut sri = Sri::uniform(gb.width, gb.height, tile, Rate::R1x1);
    let cols = sri.cols as usize;
    if cols == 0 {
        return Ok(sri);
    }
    let preview = preview.filter(|_| rule.preview > 0.0);
    if let Some((w, h)) = preview.and_then(|p| p.size()).filter(|&s| s != (gb.width, gb.height)) {
        return Err(Error::Mismatch(format!("the preview is {w}×{h}, the G-buffer {}×{}", gb.width, gb.height)));
    }
    sri.rates.par_chunks_mut(cols).enumerate().for_each(|(ty, rates)| {
        let k = BandRates { gb, preview, mask, rule, tile, extra, ty: ty as u32, rates };
        crate::base::isa::run(crate::base::isa::Isa::detect(), k);
    });
    Ok(sri)
}

/// AMD FidelityFX Variable Shading 1.2's SRI (the base rates, 1×1 to 2×2), re-implemented from its public
/// description and source, of `image` given as "the previous frame" with no motion (a static camera: no
/// reprojection, no motion allowance). `variance_cutoff` is AMD's `VarianceCutoff` (its sample's default 0.015).
///
/// Per 2×2 coarse pixel at (x, y): the luminances `0.30 R + 0.59 G + 0.11 B` of its four pixels (coordinates
/// clamped to the image) give the horizontal and vertical deltas (the larger of the two pairs each way), the range
/// and its min and max; the deltas are raised by how far the coarse pixel's min lies above its four neighbours'
/// smallest min and its max below their largest max. A group of coarse pixels classifies the maximum of each delta
/// over its hardware wave — range under the cutoff: 2×2; else the direction of the larger delta stays full rate,
/// the other coarse if its delta is under the cutoff — and a tile of several waves takes the bitwise AND of their
/// codes (`wave` lanes per wave: 64 as AMD's SDK compiles it for its GPUs). The tile-8 path reproduces AMD's
/// grouping (a 16 × 16 group's four tiles gather its coarse pixels by the parity of their column and row, written
/// transposed), so that the SRI equals the shader's tile for tile.
///
/// With `extra` it is AMD's other build of the pass (`FFX_VARIABLESHADING_ADDITIONALSHADINGRATES`), with the rates
/// to 4 × 4, re-implemented with its behaviour kept where it departs from its comments (below, `ffx_sri_additional`).
pub fn ffx_sri(image: &crate::image::HdrImage, tile: u32, variance_cutoff: f32, wave: u32, extra: bool) -> Result<Sri> {
    if ![8, 16, 32].contains(&tile) {
        return Err(Error::Argument(format!("shading-rate tile size {tile}: use 8, 16 or 32")));
    }
    if extra {
        return Ok(ffx_sri_additional(image, tile, variance_cutoff, wave));
    }
    use rayon::prelude::*;
    let (w, h) = (image.width, image.height);
    let mut sri = Sri::uniform(w, h, tile, Rate::R1x1);
    if w == 0 || h == 0 {
        return Ok(sri);
    }
    // Threads per group side (a thread per coarse pixel): a group covers 2T × 2T pixels.
    let t = if tile == 32 { 16 } else { 8 };
    let gw = if tile == 8 { sri.cols.div_ceil(2) } else { sri.cols };
    // Each coarse pixel's statistics once, from its four pixels' luminances `0.30 R + 0.59 G + 0.11 B` (coordinates
    // clamped to the image): dx, dy, range, min and max. On a grid one coarse pixel wider than the groups on every
    // side (the outer ones' neighbours): grid cell (i, j) is the coarse pixel at pixel (2i − 2, 2j − 2). Then each
    // inner cell's deltas raised by its neighbours' min and max. Planes of one value each, row by row (each row
    // compiled for the CPU's widest instruction set).
    // Each row of groups on its own (the two grid rows beside it computed again), so that its planes stay in cache.
    let nx = (gw * t) as usize + 2;
    let tu = t as usize;
    let rows_of = |gy: usize, lum: &mut Vec<f32>, stats: &mut Vec<f32>, deltas: &mut Vec<f32>| {
        stats.resize(5 * nx * (tu + 2), 0.0);
        for (k, out) in stats.chunks_mut(5 * nx).enumerate() {
            let j = (gy * tu + k) as i64;
            let y = (2 * j - 2).clamp(0, i64::from(h) - 1) as u32;
            let y1 = (2 * j - 1).clamp(0, i64::from(h) - 1) as u32;
            crate::base::isa::run(crate::base::isa::Isa::detect(), FfxStats { image, rows: [y, y1], lum, out });
        }
        deltas.resize(3 * (nx - 2) * tu, 0.0);
        for (j, out) in deltas.chunks_mut(3 * (nx - 2)).enumerate() {
            let rows = [j, j + 1, j + 2].map(|r| &stats[5 * nx * r..5 * nx * (r + 1)]);
            crate::base::isa::run(crate::base::isa::Isa::detect(), FfxDeltas { rows, out });
        }
    };
    let cw = nx - 2;
    let classify = |d: [f32; 3]| ffx_classify(d, variance_cutoff);
    let rate_of = ffx_rate;
    let max3 = |a: [f32; 3], b: [f32; 3]| [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])];
    let wave = wave.max(1) as usize;
    let cols = sri.cols as usize;
    // A row of groups writes one row of tiles (two at tile 8).
    let rows_per_group = if tile == 8 { 2 } else { 1 };
    let work = || (Vec::new(), Vec::new(), Vec::new(), Vec::with_capacity(tu * tu));
    sri.rates.par_chunks_mut(cols * rows_per_group).enumerate().for_each_init(work, |buffers, (gy, rates)| {
        let (lum, stats, planes, deltas) = buffers;
        rows_of(gy, lum, stats, planes);
        // The deltas of the coarse pixel at cell (i, j) of this row of groups.
        let delta = |i: usize, j: usize| -> [f32; 3] {
            let row = &planes[3 * cw * j..3 * cw * (j + 1)];
            [row[i], row[cw + i], row[2 * cw + i]]
        };
        for gx in 0..gw as usize {
            let ci = gx * tu;
            deltas.clear();
            if tile == 8 || !wave.is_multiple_of(tu) {
                deltas.extend((0..tu * tu).map(|g| delta(ci + g % tu, g / tu)));
            }
            if tile == 8 {
                // Slot k = (ty & 1)·2 + (tx & 1), maxed over the first wave; slot g goes to tile (2gx + g/2, 2gy + g%2).
                let mut slots = [[0.0f32; 3]; 4];
                for (g, d) in deltas.iter().enumerate().take(wave) {
                    let (tx, ty) = (g % t as usize, g / t as usize);
                    let k = (ty & 1) * 2 + (tx & 1);
                    slots[k] = max3(slots[k], *d);
                }
                for (g, slot) in slots.iter().enumerate() {
                    let (cx, cy) = (2 * gx + g / 2, g % 2);
                    if cx < cols && cy * cols < rates.len() {
                        rates[cy * cols + cx] = rate_of(classify(*slot));
                    }
                }
            } else if wave.is_multiple_of(tu) {
                // Whole rows of the group per wave: each plane's maximum over their spans.
                let mut code = 5u8;
                for r0 in (0..tu).step_by(wave / tu) {
                    let mut m = [0.0f32; 3];
                    for j in r0..(r0 + wave / tu).min(tu) {
                        for (k, m) in m.iter_mut().enumerate() {
                            let at = 3 * cw * j + k * cw + ci;
                            *m = planes[at..at + tu].iter().fold(*m, |a, &d| a.max(d));
                        }
                    }
                    code &= classify(m);
                }
                rates[gx] = rate_of(code);
            } else {
                let code = deltas
                    .chunks(wave)
                    .map(|lanes| classify(lanes.iter().fold([0.0f32; 3], |a, &d| max3(a, d))))
                    .fold(5u8, |a, c| a & c);
                rates[gx] = rate_of(code);
            }
        }
    });
    Ok(sri)
}

/// AMD's classification of a tile's deltas (dx, dy, range) against the cutoff, as a `D3D12_SHADING_RATE` code of
/// the base rates: range under it 2 × 2; else the direction of the larger delta stays full rate, the other is coarse
/// if its delta is under it.
fn ffx_classify([x, y, z]: [f32; 3], cutoff: f32) -> u8 {
    if z < cutoff {
        5
    } else if x > y {
        if y > cutoff {
            0
        } else {
            1
        }
    } else if x > cutoff {
        0
    } else {
        4
    }
}

/// The base rate of an [`ffx_classify`] code (an AND of several).
fn ffx_rate(code: u8) -> Rate {
    match code {
        5 => Rate::R2x2,
        1 => Rate::R1x2,
        4 => Rate::R2x1,
        _ => Rate::R1x1,
    }
}

/// One row of [`ffx_sri`]'s grid of coarse pixels: from the luminances of its two rows of pixels (`rows`, already
/// clamped; columns clamped here), the planes dx, dy, range, min and max, one after the other in `out`.
struct FfxStats<'a> {
    image: &'a crate::image::HdrImage,
    rows: [u32; 2],
    lum: &'a mut Vec<f32>,
    out: &'a mut [f32],
}

impl crate::base::isa::Kernel for FfxStats<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self, _: crate::base::isa::Isa) {
        let nx = self.out.len() / 5;
        let w = self.image.width as usize;
        // Pixels −2 .. 2·nx − 2 of each row, the outer ones clamped to the edge.
        let n = 2 * nx;
        self.lum.clear();
        self.lum.resize(2 * n, 0.0);
        for (r, lum) in self.rows.iter().zip(self.lum.chunks_mut(n)) {
            let row = &self.image.rgb[*r as usize * w..(*r as usize + 1) * w];
            let inner = (n - 2).min(w);
            for (l, c) in lum[2..2 + inner].iter_mut().zip(row) {
                *l = c.x * 0.30 + c.y * 0.59 + c.z * 0.11;
            }
            let (first, last) = (lum[2], lum[1 + inner]);
            lum[..2].fill(first);
            lum[2 + inner..].fill(last);
        }
        let (l0, l1) = self.lum.split_at(n);
        let (dx, rest) = self.out.split_at_mut(nx);
        let (dy, rest) = rest.split_at_mut(nx);
        let (range, rest) = rest.split_at_mut(nx);
        let (lo, hi) = rest.split_at_mut(nx);
        for i in 0..nx {
            let (a, b, c, d) = (l0[2 * i], l0[2 * i + 1], l1[2 * i], l1[2 * i + 1]);
            let (mn, mx) = (a.min(b).min(c).min(d), a.max(b).max(c).max(d));
            dx[i] = (a - b).abs().max((c - d).abs());
            dy[i] = (a - c).abs().max((b - d).abs());
            range[i] = mx - mn;
            (lo[i], hi[i]) = (mn, mx);
        }
    }
}

/// One row of [`ffx_sri`]'s inner coarse pixels: their dx, dy and range raised by how far their min lies above their
/// four neighbours' smallest min and their max below the neighbours' largest (AMD's guard against burn-in), from
/// three rows of [`FfxStats`] planes; the three planes one after the other in `out`.
struct FfxDeltas<'a> {
    rows: [&'a [f32]; 3],
    out: &'a mut [f32],
}

impl crate::base::isa::Kernel for FfxDeltas<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self, _: crate::base::isa::Isa) {
        let cw = self.out.len() / 3;
        let nx = cw + 2;
        let plane = |r: usize, k: usize| &self.rows[r][k * nx..(k + 1) * nx];
        let (up_lo, lo, down_lo) = (plane(0, 3), plane(1, 3), plane(2, 3));
        let (up_hi, hi, down_hi) = (plane(0, 4), plane(1, 4), plane(2, 4));
        let var = [plane(1, 0), plane(1, 1), plane(1, 2)];
        let (ox, rest) = self.out.split_at_mut(cw);
        let (oy, oz) = rest.split_at_mut(cw);
        for i in 0..cw {
            let c = i + 1;
            // In AMD's order: up, left, down, right.
            let n_lo = f32::INFINITY.min(up_lo[c]).min(lo[c - 1]).min(down_lo[c]).min(lo[c + 1]);
            let n_hi = f32::NEG_INFINITY.max(up_hi[c]).max(hi[c - 1]).max(down_hi[c]).max(hi[c + 1]);
            let (d_min, d_max) = ((lo[c] - n_lo).max(0.0), (n_hi - hi[c]).max(0.0));
            ox[i] = (var[0][c] + d_min + d_max).max(0.0);
            oy[i] = (var[1][c] + d_min + d_max).max(0.0);
            oz[i] = (var[2][c] + d_min + d_max).max(0.0);
        }
    }
}

/// `ffx_sri` as AMD's pass computes it with the additional rates (`FFX_VARIABLESHADING_ADDITIONALSHADINGRATES`),
/// re-implemented from its public source with its behaviour kept where it departs from its comments, so that the
/// SRI equals the shader's tile for tile (benches/ffx_lavapipe):
/// - A thread group of 8 × 8 threads covers 32 × 32 pixels. Each 4 × 4 region of a 10 × 10 grid starting at the
///   group's corner gets a rate code: the coarsest of 4 × 4, 4 × 2, 2 × 4, 2 × 2, 2 × 1, 1 × 2 whose luminance
///   range (over the region's 2 × 2 blocks for the last three) is under the cutoff. The vertical delta is computed
///   as the horizontal one, so 1 × 2 is never chosen (2 × 1 is tried first with the same value). The ranges of the
///   4-pixel-wide and -tall rates start from a minimum of `variance_cutoff`, not +∞.
/// - Thread (x, y) takes the smallest code (`D3D12_SHADING_RATE` values compared as numbers) of grid cell
///   (x + 1, y + 1) and its four neighbours: the grid is read one cell in, 4 pixels right and down of the tiles it
///   is written to.
/// - Tiles 16 and 32: the group's tiles gather threads by the parity of their column and row (as the base pass's
///   tile 8), each reduced by a minimum over the wave of the thread that writes it (thread k writes tile k: the
///   first wave for 4 lanes or more), and written transposed.
/// - Tile 8: the group reduction ANDs into shared words that start at 0, so every tile is 1 × 1.
fn ffx_sri_additional(image: &crate::image::HdrImage, tile: u32, variance_cutoff: f32, wave: u32) -> Sri {
    let (w, h) = (image.width, image.height);
    let mut sri = Sri::uniform(w, h, tile, Rate::R1x1);
    if tile < 16 || w == 0 || h == 0 {
        return sri;
    }
    let lum = |x: i64, y: i64| -> f32 {
        let (x, y) = (x.clamp(0, i64::from(w) - 1) as usize, y.clamp(0, i64::from(h) - 1) as usize);
        let c = image.rgb[y * w as usize + x];
        c.x * 0.30 + c.y * 0.59 + c.z * 0.11
    };
    let cut = variance_cutoff;
    // The rate code of the 4 × 4 region at pixel (x, y) (with AMD's motion allowance `v` at 0: a static camera).
    let region = |x: i64, y: i64| -> u8 {
        let (mut v2x1, mut v1x2, mut v2x2) = (0.0f32, 0.0f32, 0.0f32);
        let (mut mm4x2, mut mm2x4, mut mm4x4) = ([(cut, 0.0f32); 2], [(cut, 0.0f32); 2], (cut, 0.0f32));
        for (by, row) in mm4x2.iter_mut().enumerate() {
            for (bx, col) in mm2x4.iter_mut().enumerate() {
                let (px, py) = (x + 2 * bx as i64, y + 2 * by as i64);
                let (a, b, c, d) = (lum(px, py), lum(px + 1, py), lum(px, py + 1), lum(px + 1, py + 1));
                let (mn, mx) = (a.min(b).min(c.min(d)), a.max(b).max(c.max(d)));
                let dx = (a - b).abs().max((c - d).abs()).max(0.0);
                v2x1 = v2x1.max(dx);
                v1x2 = v1x2.max(dx);
                v2x2 = v2x2.max((mx - mn).max(0.0));
                let widen = |m: &mut (f32, f32)| *m = (m.0.min(mn), m.1.max(mx));
                widen(row);
                widen(col);
                widen(&mut mm4x4);
            }
        }
        let v4x2 = (mm4x2[0].1 - mm4x2[0].0).max(mm4x2[1].1 - mm4x2[1].0).max(0.0);
        let v2x4 = (mm2x4[0].1 - mm2x4[0].0).max(mm2x4[1].1 - mm2x4[1].0).max(0.0);
        let v4x4 = (mm4x4.1 - mm4x4.0).max(0.0);
        let rate = [(v4x4, Rate::R4x4), (v4x2, Rate::R4x2), (v2x4, Rate::R2x4), (v2x2, Rate::R2x2)]
            .into_iter()
            .chain([(v2x1, Rate::R2x1), (v1x2, Rate::R1x2)])
            .find(|&(v, _)| v < cut)
            .map_or(Rate::R1x1, |(_, r)| r);
        rate.d3d12()
    };
    let blocks = (32 / tile) as usize; // tiles per group side
    let wave = (wave.max(1) as usize).min(64);
    use rayon::prelude::*;
    let gw = (sri.cols as usize * tile as usize).div_ceil(32);
    let cols = sri.cols as usize;
    // A row of groups writes `blocks` rows of tiles: rows of groups in parallel.
    sri.rates.par_chunks_mut(cols * blocks).enumerate().for_each(|(gy, rates)| {
        let mut codes = [0u8; 100];
        for gx in 0..gw {
            let (ox, oy) = (gx as i64 * 32, gy as i64 * 32);
            for (i, c) in codes.iter_mut().enumerate() {
                *c = region(ox + 4 * (i % 10) as i64, oy + 4 * (i / 10) as i64);
            }
            // Thread g's code (the smallest of its cell's and its four neighbours') and the tile it gathers into.
            let thread = |g: usize| {
                let (tx, ty) = (g % 8, g / 8);
                let at = |dx: usize, dy: usize| codes[(ty + dy) * 10 + tx + dx];
                let own = at(1, 1).min(at(1, 0)).min(at(0, 1)).min(at(2, 1)).min(at(1, 2));
                ((ty & (blocks - 1)) * blocks + (tx & (blocks - 1)), own)
            };
            // Tile k is written by thread k: the minimum over its wave's threads that gather into tile k (4 × 4, the
            // start, where none does).
            let mut slots = [Rate::R4x4.d3d12(); 4];
            for (k, slot) in slots.iter_mut().enumerate().take(blocks * blocks) {
                let lanes = k / wave * wave..(k / wave * wave + wave).min(64);
                *slot = lanes.map(thread).filter(|&(to, _)| to == k).fold(*slot, |a, (_, c)| a.min(c));
            }
            for (k, &code) in slots.iter().enumerate().take(blocks * blocks) {
                let (cx, cy) = (gx * blocks + k / blocks, k % blocks);
                if cx < cols && cy * cols < rates.len() {
                    rates[cy * cols + cx] = Rate::from_d3d12(code);
                }
            }
        }
    });
    sri
}

/// The coarse pixels of tile (`tx`, `ty`) of `sri` over a `width × height` image: for each, its pixels (row-major
/// indices) in row order.
fn tile_blocks(sri: &Sri, width: u32, height: u32, tx: u32, ty: u32) -> Vec<Vec<usize>> {
    let (cw, ch) = sri.rates[(ty * sri.cols + tx) as usize].size();
    let (x0, y0) = (tx * sri.tile, ty * sri.tile);
    let (x1, y1) = ((x0 + sri.tile).min(width), (y0 + sri.tile).min(height));
    let mut out = Vec::new();
    for by in (y0..y1).step_by(ch as usize) {
        for bx in (x0..x1).step_by(cw as usize) {
            let mut v = Vec::with_capacity((cw * ch) as usize);
            for y in by..(by + ch).min(y1) {
                for x in bx..(bx + cw).min(x1) {
                    v.push((y * width + x) as usize);
                }
            }
            out.push(v);
        }
    }
    out
}

/// Lighting evaluations of a coarse-shaded resolve, per tile (row-major): edge pixels as the mask shades them (one
/// per covered sample), and one per coarse pixel that holds a covered non-edge pixel.
#[must_use]
pub fn tile_evaluations(gb: &GBuffer, mask: &EdgeMask, sri: &Sri) -> Vec<u64> {
    let covered = crate::detect::covered_per_pixel(gb);
    let mut out = Vec::with_capacity(sri.rates.len());
    for ty in 0..sri.rows {
        for tx in 0..sri.cols {
            let mut n = 0u64;
            for block in tile_blocks(sri, gb.width, gb.height, tx, ty) {
                let mut shared = false;
                for p in block {
                    if mask.is_edge(p) {
                        n += u64::from(mask.shade_count[p].min(covered[p]));
                    } else if covered[p] > 0 && mask.shade_count[p] > 0 {
                        shared = true;
                    }
                }
                n += u64::from(shared);
            }
            out.push(n);
        }
    }
    out
}

/// Lighting evaluations of a coarse-shaded resolve ([`tile_evaluations`] summed). With an all-1×1 SRI this is
/// [`EdgeMask::evaluations`].
#[must_use]
pub fn evaluations(gb: &GBuffer, mask: &EdgeMask, sri: &Sri) -> u64 {
    tile_evaluations(gb, mask, sri).iter().sum()
}

/// The SRI minimising `Σ error[t][r]` over tiles `t` with at most `budget` evaluations, `error[t][k]` and
/// `evals[t][k]` given per tile for each of `rates`: per tile the rate minimising `error + λ · evaluations`, with
/// the smallest λ (found by bisection) whose total fits the budget. Such a choice is optimal for its own total of
/// evaluations (a Lagrangian optimum); `None` when even the coarsest rates do not fit.
#[must_use]
pub fn cheapest_sri(
    template: &Sri,
    rates: &[Rate],
    error: &[Vec<f64>],
    evals: &[Vec<u64>],
    budget: u64,
) -> Option<Sri> {
    let pick = |lambda: f64| -> (Vec<Rate>, u64, f64) {
        let (mut chosen, mut total, mut err) = (Vec::with_capacity(error.len()), 0u64, 0.0);
        for (e, n) in error.iter().zip(evals) {
            let k = (0..rates.len())
                .min_by(|&a, &b| {
                    let (ca, cb) = (e[a] + lambda * n[a] as f64, e[b] + lambda * n[b] as f64);
                    ca.total_cmp(&cb).then(n[a].cmp(&n[b]))
                })
                .expect("at least one rate");
            chosen.push(rates[k]);
            total += n[k];
            err += e[k];
        }
        (chosen, total, err)
    };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    if pick(0.0).1 > budget {
        while pick(hi).1 > budget {
            hi *= 4.0;
            if hi > 1e30 {
                return None;
            }
        }
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if pick(mid).1 > budget {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    } else {
        hi = 0.0;
    }
    Some(Sri { rates: pick(hi).0, ..template.clone() })
}

/// How a coarse pixel's evaluation reaches its pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoarseMode {
    /// The representative's colour for every pixel.
    Broadcast,
    /// The representative's lighting times each pixel's own albedo.
    Lighting,
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn rates_encode_as_d3d12_and_fit_the_allowed_set() {
        let want = [0u8, 0x1, 0x4, 0x5, 0x6, 0x9, 0xa]; // D3D12_SHADING_RATE_1X1 … _4X4
        assert_eq!(Rate::ALL.map(Rate::d3d12), want);
        assert_eq!(Rate::fit(4, 4, false, 1), Rate::R2x2);
        assert_eq!(Rate::fit(4, 1, true, 1), Rate::R2x1);
        assert_eq!(Rate::fit(1, 4, true, 1), Rate::R1x2);
        assert_eq!(Rate::fit(4, 4, true, 1), Rate::R4x4);
        assert_eq!(Rate::fit(2, 4, true, 1), Rate::R2x4);
        // D3D12's limit of 16 samples per coarse pixel.
        assert_eq!(Rate::fit(4, 4, true, 2), Rate::R2x4);
        assert_eq!(Rate::fit(4, 4, true, 4), Rate::R2x2);
        assert_eq!(Rate::fit(2, 2, true, 8), Rate::R1x2);
        assert_eq!(Rate::fit(2, 2, false, 16), Rate::R1x1);
        let allowed = |s: u32| Rate::ALL.iter().filter(|r| r.allowed(s, true)).count();
        assert_eq!([1, 2, 4, 8, 16].map(allowed), [7, 6, 4, 3, 1]);
    }

    #[test]
    fn the_cheapest_sri_fits_its_budget_and_nothing_with_fewer_evaluations_errs_less() {
        // Four tiles, three rates: random errors falling and evaluations falling with coarseness, every budget.
        let mut rng = crate::base::rng::SplitMix64::new(9);
        let rates = [Rate::R1x1, Rate::R2x1, Rate::R2x2];
        let template = Sri::uniform(32, 8, 8, Rate::R1x1);
        for _ in 0..50 {
            let error: Vec<Vec<f64>> = (0..4)
                .map(|_| {
                    let a = rng.next_f32() as f64;
                    vec![0.0, a, a + rng.next_f32() as f64]
                })
                .collect();
            let evals: Vec<Vec<u64>> =
                (0..4).map(|_| vec![64, 32 + rng.next_u64() % 8, 16 + rng.next_u64() % 8]).collect();
            for budget in [64, 100, 150, 200, 256] {
                let Some(s) = cheapest_sri(&template, &rates, &error, &evals, budget) else {
                    assert!(budget < evals.iter().map(|e| e[2]).sum::<u64>());
                    continue;
                };
                let k = |r: Rate| rates.iter().position(|&x| x == r).unwrap();
                let total: u64 = s.rates.iter().enumerate().map(|(t, &r)| evals[t][k(r)]).sum();
                let err: f64 = s.rates.iter().enumerate().map(|(t, &r)| error[t][k(r)]).sum();
                assert!(total <= budget);
                // Every other choice with no more evaluations has no less error.
                for code in 0..81u32 {
                    let pick: Vec<usize> = (0..4).map(|t| (code / 3u32.pow(t)) as usize % 3).collect();
                    let n: u64 = pick.iter().enumerate().map(|(t, &c)| evals[t][c]).sum();
                    let e: f64 = pick.iter().enumerate().map(|(t, &c)| error[t][c]).sum();
                    assert!(n > total || e >= err - 1e-12, "{pick:?}: {e} < {err} with {n} ≤ {total}");
                }
            }
        }
    }

    /// A `w × h` image whose pixel (x, y) is grey `f(x, y)`.
    fn grey_image(w: u32, h: u32, f: &dyn Fn(u32, u32) -> f32) -> crate::image::HdrImage {
        let mut img = crate::image::HdrImage::new(w, h);
        for y in 0..h {
            for x in 0..w {
                img.rgb[(y * w + x) as usize] = Vec3::splat(f(x, y));
            }
        }
        img
    }

    /// The base pass as first written: every coarse pixel's statistics recomputed from clamped pixel reads for
    /// itself and each neighbour. What the faster [`ffx_sri`] must equal.
    fn ffx_naive(image: &crate::image::HdrImage, tile: u32, variance_cutoff: f32, wave: u32) -> Result<Sri> {
        let (w, h) = (image.width, image.height);
        let mut sri = Sri::uniform(w, h, tile, Rate::R1x1);
        let lum = |x: i64, y: i64| -> f32 {
            let (x, y) = (x.clamp(0, i64::from(w) - 1) as usize, y.clamp(0, i64::from(h) - 1) as usize);
            let c = image.rgb[y * w as usize + x];
            c.x * 0.30 + c.y * 0.59 + c.z * 0.11
        };
        // Per coarse pixel at pixel (x, y): (dx, dy, range) and (min, max).
        let stats = |x: i64, y: i64| -> ([f32; 3], f32, f32) {
            let (a, b, c, d) = (lum(x, y), lum(x + 1, y), lum(x, y + 1), lum(x + 1, y + 1));
            let (mn, mx) = (a.min(b).min(c).min(d), a.max(b).max(c).max(d));
            ([(a - b).abs().max((c - d).abs()), (a - c).abs().max((b - d).abs()), mx - mn], mn, mx)
        };
        let delta = |x: i64, y: i64| -> [f32; 3] {
            let (var, mn, mx) = stats(x, y);
            let n = [(x, y - 2), (x - 2, y), (x, y + 2), (x + 2, y)].map(|(a, b)| stats(a, b));
            let d_min = (mn - n.iter().map(|s| s.1).fold(f32::INFINITY, f32::min)).max(0.0);
            let d_max = (n.iter().map(|s| s.2).fold(f32::NEG_INFINITY, f32::max) - mx).max(0.0);
            var.map(|v| (v + d_min + d_max).max(0.0))
        };
        let classify = |d: [f32; 3]| ffx_classify(d, variance_cutoff);
        let rate_of = ffx_rate;
        let max3 = |a: [f32; 3], b: [f32; 3]| [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])];
        // Threads per group side (a thread per coarse pixel): a group covers 2T × 2T pixels.
        let t = if tile == 32 { 16 } else { 8 };
        let wave = wave.max(1) as usize;
        let (gw, gh) = if tile == 8 { (sri.cols.div_ceil(2), sri.rows.div_ceil(2)) } else { (sri.cols, sri.rows) };
        for gy in 0..gh {
            for gx in 0..gw {
                let (ox, oy) = (i64::from(gx * 2 * t), i64::from(gy * 2 * t));
                let deltas: Vec<[f32; 3]> =
                    (0..t * t).map(|g| delta(ox + 2 * i64::from(g % t), oy + 2 * i64::from(g / t))).collect();
                if tile == 8 {
                    // Slot k = (ty & 1)·2 + (tx & 1), maxed over the first wave; slot g goes to tile (2gx + g/2, 2gy + g%2).
                    let mut slots = [[0.0f32; 3]; 4];
                    for (g, d) in deltas.iter().enumerate().take(wave) {
                        let (tx, ty) = (g as u32 % t, g as u32 / t);
                        let k = ((ty & 1) * 2 + (tx & 1)) as usize;
                        slots[k] = max3(slots[k], *d);
                    }
                    for (g, slot) in slots.iter().enumerate() {
                        let (cx, cy) = (2 * gx + g as u32 / 2, 2 * gy + g as u32 % 2);
                        if cx < sri.cols && cy < sri.rows {
                            sri.rates[(cy * sri.cols + cx) as usize] = rate_of(classify(*slot));
                        }
                    }
                } else {
                    let code = deltas
                        .chunks(wave)
                        .map(|lanes| classify(lanes.iter().fold([0.0f32; 3], |a, &d| max3(a, d))))
                        .fold(5u8, |a, c| a & c);
                    sri.rates[(gy * sri.cols + gx) as usize] = rate_of(code);
                }
            }
        }
        Ok(sri)
    }

    #[test]
    fn ffx_equals_its_first_writing_on_noise_and_ramps() {
        let mut seed = 7u64;
        let mut next = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        for (w, h) in [(1u32, 1u32), (17, 9), (64, 48), (101, 67), (130, 33)] {
            // Blocks of 8 × 8 pixels, each flat, striped one way or the other, or noisy, near the cutoff: every
            // class in one group, and waves that disagree.
            let blocks: Vec<u32> = (0..(w.div_ceil(8) * h.div_ceil(8))).map(|_| (next() * 4.0) as u32).collect();
            for kind in 0..4 {
                let mut img = crate::image::HdrImage::new(w, h);
                for (p, c) in img.rgb.iter_mut().enumerate() {
                    let (x, y) = ((p as u32 % w) as f32, (p as u32 / w) as f32);
                    *c = match kind {
                        0 => Vec3::new(next(), next(), next()),
                        // Smooth: mostly coarse, with a few busy spots.
                        1 => Vec3::splat(0.002 * x + 0.001 * y + if next() < 0.01 { 1.0 } else { 0.0 }),
                        2 => Vec3::splat(if (x as u32 / 3 + y as u32 / 5).is_multiple_of(2) { 0.2 } else { 0.205 }),
                        _ => {
                            let (xi, yi) = (x as u32, y as u32);
                            let a = 0.02 * next();
                            Vec3::splat(match blocks[((yi / 8) * w.div_ceil(8) + xi / 8) as usize] {
                                0 => 0.3,
                                1 => 0.3 + if yi.is_multiple_of(2) { 0.02 } else { 0.0 },
                                2 => 0.3 + if xi.is_multiple_of(2) { 0.02 } else { 0.0 },
                                _ => 0.3 + a,
                            })
                        }
                    };
                }
                let mut seen = std::collections::BTreeSet::new();
                for tile in [8, 16, 32] {
                    for wave in [1, 3, 4, 5, 8, 16, 32, 64, 128] {
                        let fast = ffx_sri(&img, tile, 0.015, wave, false).unwrap();
                        seen.extend(fast.rates.iter().copied());
                        assert_eq!(
                            fast,
                            ffx_naive(&img, tile, 0.015, wave).unwrap(),
                            "{w}×{h} kind {kind} tile {tile}"
                        );
                    }
                }
                if kind == 3 && w >= 64 {
                    assert_eq!(seen.len(), 4, "every base rate occurs: {seen:?}");
                }
            }
        }
    }

    #[test]
    fn ffx_follows_amds_classification_and_tile_8_grouping() {
        let image = grey_image;
        let all = |s: &Sri, r: Rate| s.rates.iter().all(|&x| x == r);
        for tile in [8, 16, 32] {
            // Flat: 2×2. Rows alternating (no horizontal delta): 2 wide, 1 tall. Columns alternating: 1×2.
            assert!(all(&ffx_sri(&image(64, 64, &|_, _| 0.5), tile, 0.015, 64, false).unwrap(), Rate::R2x2));
            assert!(all(&ffx_sri(&image(64, 64, &|_, y| (y % 2) as f32), tile, 0.015, 64, false).unwrap(), Rate::R2x1));
            assert!(all(&ffx_sri(&image(64, 64, &|x, _| (x % 2) as f32), tile, 0.015, 64, false).unwrap(), Rate::R1x2));
            // A checkerboard: full rate.
            assert!(all(
                &ffx_sri(&image(64, 64, &|x, y| ((x + y) % 2) as f32), tile, 0.015, 64, false).unwrap(),
                Rate::R1x1
            ));
        }
        // Tile 8: a 16×16 group's four tiles gather coarse pixels by column and row parity, written transposed.
        // One busy coarse pixel (column 1, row 0) raises itself and its neighbours (columns 0 and 2 of row 0, and
        // column 1 of row 1): every parity class but (odd row, even column), which AMD writes to tile (1, 0). A
        // spatial grouping would have kept tiles (1, 0), (0, 1) and (1, 1) at 2×2.
        let one = image(16, 16, &|x, y| if x / 2 == 1 && y / 2 == 0 { ((x + y) % 2) as f32 } else { 0.5 });
        let s = ffx_sri(&one, 8, 0.015, 64, false).unwrap();
        assert_eq!(s.rates, vec![Rate::R1x1, Rate::R2x2, Rate::R1x1, Rate::R1x1], "{s:?}");
    }

    #[test]
    fn ffx_with_additional_rates_follows_amds_pass() {
        let image = grey_image;
        let rates = |img: &crate::image::HdrImage, tile: u32, wave: u32| {
            let s = ffx_sri(img, tile, 0.015, wave, true).unwrap();
            let mut r = s.rates.clone();
            r.dedup();
            r
        };
        for tile in [16, 32] {
            // Dark and flat: 4 × 4. Bright and flat: the 4-pixel rates' ranges start from the cutoff as their
            // minimum, so 2 × 2 (AMD's pass as written).
            assert_eq!(rates(&image(64, 64, &|_, _| 0.01), tile, 64), vec![Rate::R4x4]);
            assert_eq!(rates(&image(64, 64, &|_, _| 0.5), tile, 64), vec![Rate::R2x2]);
            // Rows alternating (no horizontal delta): 2 wide, 1 tall. Columns alternating: full rate, not 1 × 2
            // (the pass computes its vertical delta as the horizontal one).
            assert_eq!(rates(&image(64, 64, &|_, y| (y % 2) as f32), tile, 64), vec![Rate::R2x1]);
            assert_eq!(rates(&image(64, 64, &|x, _| (x % 2) as f32), tile, 64), vec![Rate::R1x1]);
            // Dark columns in pairs, 0.01 and 0.025: 4 wide spans a range of the cutoff, 2 × 4 fits.
            assert_eq!(
                rates(&image(64, 64, &|x, _| if x / 2 % 2 == 1 { 0.025 } else { 0.01 }), tile, 64),
                vec![Rate::R2x4]
            );
        }
        // Tile 8: the group's reduction starts from 0, so every tile is full rate whatever the image.
        assert_eq!(rates(&image(64, 64, &|_, _| 0.01), 8, 64), vec![Rate::R1x1]);
        // Only the first wave's threads reach the tile: a checkerboard in the lower half of a 32 × 32 group makes it
        // full rate with 64 lanes, and leaves it 4 × 4 with 8 (the first row of threads reads pixel rows 0 to 11).
        let lower = image(32, 32, &|x, y| if y >= 16 { ((x + y) % 2) as f32 } else { 0.01 });
        assert_eq!(rates(&lower, 32, 64), vec![Rate::R1x1]);
        assert_eq!(rates(&lower, 32, 8), vec![Rate::R4x4]);
        // Tile 16: the group's four tiles gather threads by the parity of their column and row, written transposed.
        // A busy 4 × 4 region at grid cell (3, 2) reaches the threads reading it as their own cell (2, 1) or as a
        // neighbour ((2, 2), (3, 1), (1, 1), (2, 0)): every parity class but (odd column, even row), tile 1, which
        // is written to tile (0, 1).
        let busy = image(32, 32, &|x, y| if x / 4 == 3 && y / 4 == 2 { ((x + y) % 2) as f32 } else { 0.01 });
        let s = ffx_sri(&busy, 16, 0.015, 64, true).unwrap();
        assert_eq!(s.rates, vec![Rate::R1x1, Rate::R1x1, Rate::R4x4, Rate::R1x1]);
        // Waves of 1 lane: tile k takes thread k's own code alone (threads 0 and 1 read dark cells; tiles 2 and 3 get
        // no thread and stay 4 × 4).
        let s = ffx_sri(&busy, 16, 0.015, 1, true).unwrap();
        assert_eq!(s.rates, vec![Rate::R4x4; 4]);
        // The grid is read one cell in: a checkerboard in the group's first 4 rows and columns touches no cell a
        // thread reads (cells (1, 1) on, and their neighbours (0, 1) and (1, 0) only beside it).
        let corner = image(32, 32, &|x, y| if x < 4 && y < 4 { ((x + y) % 2) as f32 } else { 0.01 });
        assert_eq!(rates(&corner, 32, 64), vec![Rate::R4x4]);
    }

    #[test]
    fn a_constant_gbuffer_is_coarsest_and_noise_is_full_rate() {
        let (w, h) = (32u32, 32u32);
        let n = (w * h) as usize;
        let mut gb = GBuffer {
            width: w,
            height: h,
            samples: 1,
            sample_positions: vec![glam::Vec2::ZERO],
            coverage: vec![true; n],
            depth: Some(vec![5.0; n]),
            normal: Some(vec![Vec3::Z; n]),
            albedo: Some(vec![Vec3::splat(0.5); n]),
            ..Default::default()
        };
        let mask = EdgeMask::filled(w, h, 1, 1);
        let rule = Smoothness::default();
        let sri = gbuffer_sri(&gb, None, &mask, 16, true, &rule).unwrap();
        assert!(sri.rates.iter().all(|&r| r == Rate::R4x4), "{sri:?}");
        assert_eq!(gbuffer_sri(&gb, None, &mask, 16, false, &rule).unwrap().rates[0], Rate::R2x2);
        // Evaluations: one per 4×4 coarse pixel.
        assert_eq!(evaluations(&gb, &mask, &sri), (n / 16) as u64);
        // Noise in the albedo: full rate when broadcast, still coarse when only the lighting is shared.
        let mut rng = crate::base::rng::SplitMix64::new(3);
        gb.albedo = Some((0..n).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())).collect());
        assert!(gbuffer_sri(&gb, None, &mask, 16, true, &rule).unwrap().rates.iter().all(|&r| r == Rate::R1x1));
        let lighting = Smoothness { broadcast: false, ..rule };
        assert!(gbuffer_sri(&gb, None, &mask, 16, true, &lighting).unwrap().rates.iter().all(|&r| r == Rate::R4x4));
        // Noise in the normals: full rate in both modes.
        gb.normal = Some((0..n).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), 1.0).normalize()).collect());
        assert!(gbuffer_sri(&gb, None, &mask, 16, true, &lighting).unwrap().rates.iter().all(|&r| r == Rate::R1x1));
    }

    /// A wall facing the camera, 64 × 32 pixels of 5 cm at 5 m: white light from a direction only (the same at every
    /// pixel but for the glossy part's view direction), then a point light 10 cm in front of its left end.
    fn lit_wall() -> (GBuffer, Vec<crate::light::Light>) {
        let (w, h) = (64u32, 32u32);
        let n = (w * h) as usize;
        let gb = GBuffer {
            width: w,
            height: h,
            samples: 1,
            sample_positions: vec![glam::Vec2::ZERO],
            coverage: vec![true; n],
            position: Some(
                (0..n).map(|p| Vec3::new((p % 64) as f32 * 0.05 - 1.6, (p / 64) as f32 * 0.05 - 0.8, -5.0)).collect(),
            ),
            normal: Some(vec![Vec3::Z; n]),
            albedo: Some(vec![Vec3::splat(0.5); n]),
            roughness: Some(vec![0.8; n]),
            metallic: Some(vec![0.0; n]),
            ..Default::default()
        };
        let sun = crate::light::Light {
            kind: crate::light::LightKind::Directional { direction: Vec3::new(0.3, -0.2, -1.0) },
            ..crate::light::Light::point(Vec3::ZERO, Vec3::ONE, 0.5, f32::INFINITY)
        };
        (gb, vec![sun])
    }

    #[test]
    fn the_preview_refines_only_where_the_lighting_changes() {
        let (gb, mut lights) = lit_wall();
        let mask = EdgeMask::filled(gb.width, gb.height, 1, 1);
        let rule = Smoothness::default();
        let preview = |lights: &[crate::light::Light]| {
            let (falloff, brdf) = (crate::resolve::Falloff::Linear, crate::resolve::Brdf::Ggx);
            crate::resolve::LightPreview::new(&gb, lights, falloff, brdf, Default::default()).unwrap()
        };
        let lit =
            |lights: &[crate::light::Light]| gbuffer_sri(&gb, Some(&preview(lights)), &mask, 16, false, &rule).unwrap();
        let unlit = gbuffer_sri(&gb, None, &mask, 16, false, &rule).unwrap();
        assert!(unlit.rates.iter().all(|&r| r == Rate::R2x2), "{unlit:?}");
        // Even light: the preview changes nothing.
        assert_eq!(lit(&lights).rates, unlit.rates);
        // A light at the wall's left end: finer there, unchanged beyond its range (the right quarter).
        lights.push(crate::light::Light::point(Vec3::new(-1.2, 0.0, -4.9), Vec3::ONE, 5.0, 2.0));
        let near = lit(&lights);
        assert!(near.rates[0] == Rate::R1x1 && near.rates[4] == Rate::R1x1, "{near:?}");
        assert_eq!((near.rates[3], near.rates[7]), (Rate::R2x2, Rate::R2x2), "{near:?}");
        assert!(evaluations(&gb, &mask, &near) > evaluations(&gb, &mask, &unlit));
        // A preview limit of 0 turns the term off.
        let off = Smoothness { preview: 0.0, ..rule };
        assert_eq!(gbuffer_sri(&gb, Some(&preview(&lights)), &mask, 16, false, &off).unwrap().rates, unlit.rates);
    }

    /// The preview against the resolve's image of the room (160 × 90 at one sample, GGX, 25 coloured lights), both
    /// shown as the luminance through the default tone map and sRGB: within a hundredth of an 8-bit code on average
    /// and a twentieth at the 99th percentile (measured 2·10⁻⁵ and 2·10⁻⁴: f32 rounding in another order). A
    /// luminance-only preview (the product of the light's and the albedo's luminances) was 2.4 codes off on average,
    /// and Hammon's visibility without square roots 1.2.
    #[test]
    fn the_preview_is_the_resolves_luminance_as_shown() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/room_1x.exr");
        let loaded = crate::io::load(&path, &Default::default()).unwrap();
        let (gb, lights) = (&loaded.gbuffer, loaded.lights.clone().unwrap());
        let mask = EdgeMask::filled(gb.width, gb.height, 1, 1);
        let cfg = crate::resolve::ResolveConfig { brdf: crate::resolve::Brdf::Ggx, ..Default::default() };
        let image = crate::resolve::resolve(gb, &lights, &mask, &cfg).unwrap().image;
        let tone = crate::image::ToneMap::default();
        let preview = crate::resolve::LightPreview::new(gb, &lights, cfg.falloff, cfg.brdf, tone).unwrap();
        let mut band = Band::default();
        band.fill(gb, &mask, &Smoothness::default(), Some(&preview), 16, 0, gb.height);
        let shown =
            |rgb: Vec3| crate::base::picture::srgb_encode(tone.apply(rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722))));
        let mut diff: Vec<f32> = (0..gb.pixel_count())
            .filter(|&p| band.state[p] == 1)
            .map(|p| 255.0 * (band.preview[p] - shown(image.rgb[p])).abs())
            .collect();
        assert!(diff.len() > gb.pixel_count() / 2);
        diff.sort_by(f32::total_cmp);
        let mean = diff.iter().sum::<f32>() / diff.len() as f32;
        let p99 = diff[diff.len() * 99 / 100];
        assert!(mean < 0.01 && p99 < 0.05, "mean {mean} codes, 99th percentile {p99}");
        // The lit image itself as the preview (a renderer's previous frame): each pixel's luminance as shown.
        let from_image = crate::resolve::ImagePreview::new(&image, tone);
        let mut seen = Band::default();
        seen.fill(gb, &mask, &Smoothness::default(), Some(&from_image), 16, 0, gb.height);
        for p in (0..gb.pixel_count()).filter(|&p| band.state[p] == 1) {
            assert!((seen.preview[p] - shown(image.rgb[p])).abs() < 2e-6, "pixel {p}");
        }
        // Either preview gives the rule the same rates on nearly every tile.
        let rule = Smoothness::default();
        let lit = gbuffer_sri(gb, Some(&preview), &mask, 16, false, &rule).unwrap();
        let prev = gbuffer_sri(gb, Some(&from_image), &mask, 16, false, &rule).unwrap();
        let same = lit.rates.iter().zip(&prev.rates).filter(|(a, b)| a == b).count();
        assert!(same * 100 >= lit.rates.len() * 98, "{same} of {} tiles", lit.rates.len());
        assert!(lit.rates.iter().any(|&r| r != Rate::R1x1) && lit.rates.contains(&Rate::R1x1));
        // A lit image of another size is refused.
        let other = crate::resolve::ImagePreview::new(&crate::image::HdrImage::new(gb.width + 1, gb.height), tone);
        let err = gbuffer_sri(gb, Some(&other), &mask, 16, false, &rule).unwrap_err();
        assert!(err.to_string().contains("the preview is"), "{err}");
    }

    #[test]
    fn full_rate_evaluations_are_the_masks_and_coarse_rates_count_fewer() {
        let gb = crate::scene::render(crate::scene::SceneName::Room, 40, 24, 4).unwrap();
        let mask = crate::detect::detect(&gb, crate::detect::Detector::Lauritzen, &Default::default()).unwrap();
        let full = Sri::uniform(gb.width, gb.height, 8, Rate::R1x1);
        let at_full = evaluations(&gb, &mask, &full);
        assert_eq!(at_full, mask.evaluations(&crate::detect::covered_per_pixel(&gb)));
        let coarse = Sri::uniform(gb.width, gb.height, 8, Rate::R2x2);
        assert!(evaluations(&gb, &mask, &coarse) < at_full);
    }
}
