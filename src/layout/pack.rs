//! Packing a G-buffer into render-target bytes and reading it back.
//!
//! [`Layout::pack`] encodes every sample field by field, ORs the codes into the target's texel word and writes it
//! little-endian (background samples are a cleared texel: all zero bits but a depth field, which holds its
//! codec's clear code, the far plane: what a depth buffer cleared before the G-buffer pass holds). [`Layout::unpack`] reads the words
//! back, extracts each field's bits and decodes them; it is bit-exact with calling each codec's
//! `decode(encode(x))` by hand. Both run in parallel (rayon) over blocks of whole rows, and inside a block each
//! field goes through its codec's slice path (`encode_slice` / `decode_slice`: vectorised, bit-identical to the
//! per-element codec), so a block costs one virtual call per field rather than one per sample.

use super::bits::{extract, insert, load_le, mask, store_le};
use super::coder::{encode_id, Coder, Slot};
use super::material::MaterialTable;
use super::{Field, Format, Layout, DEFAULT_DEPTH_RANGE};
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, BandSource, GBuffer, PlaneSlot};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::ops::Range;
use std::time::{Duration, Instant};

/// Samples per parallel work item (rounded to whole rows): big enough to amortize scheduling and the per-field
/// slice calls, small enough for several per thread and for the block's scratch buffers to stay in L1/L2.
const CHUNK: usize = 4096;

/// Samples per work item for a G-buffer with `row` samples per row: a whole number of rows, at least one.
fn rows_chunk(row: usize) -> usize {
    let row = row.max(1);
    row * (CHUNK / row).max(1)
}

/// One render target's bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetPlane {
    /// Target name from the layout.
    pub name: String,
    /// Its format.
    pub format: Format,
    /// `samples × format.bytes()` bytes, pixel-major like the G-buffer planes, each texel little-endian.
    pub bytes: Vec<u8>,
}

/// A packed G-buffer: what the renderer's render targets would hold.
#[derive(Clone, Debug, PartialEq)]
pub struct Packed {
    /// The layout's name.
    pub layout: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub samples: u32,
    /// One byte plane per render target.
    pub targets: Vec<TargetPlane>,
    /// The material table, when the layout uses indirection.
    pub material_table: Option<MaterialTable>,
    /// Near/far planes the depth codecs were built with.
    pub depth_range: [f32; 2],
    /// Attributes that the input had and the layout stores (the others are not decoded).
    pub present: Vec<Attribute>,
}

impl Packed {
    /// Total bytes over all targets.
    #[must_use]
    pub fn total_bytes(&self) -> usize {
        self.targets.iter().map(|t| t.bytes.len()).sum()
    }
}

/// Samples per band of [`Layout::roundtrip_timed`] (rounded to whole rows): about 20 MB of packed bytes for an
/// 84-byte layout, several parallel blocks per thread.
pub const BAND_SAMPLES: usize = 1 << 18;

/// Every band of rows packed starts at a multiple of this many rows: the height of an AFRC coding unit.
const AFRC_ROWS: usize = 4;

/// Rows per band of about [`BAND_SAMPLES`] samples for rows of `row` samples: a multiple of [`AFRC_ROWS`].
fn band_rows(row: usize) -> usize {
    (BAND_SAMPLES / row.max(1) / AFRC_ROWS).max(1) * AFRC_ROWS
}

/// A timed roundtrip ([`Layout::roundtrip_timed`]).
#[derive(Clone, Debug)]
pub struct Roundtrip {
    /// The unpacked G-buffer.
    pub decoded: GBuffer,
    /// Each run's encode (pack) time, ms.
    pub encode_ms: Vec<f64>,
    /// Each run's decode (unpack) time, ms.
    pub decode_ms: Vec<f64>,
    /// Building the material table and every sample's index into it, ms, once (`None` without indirection): the
    /// content-build step an engine does offline, not per frame, so it is not part of `encode_ms`.
    pub table_ms: Option<f64>,
}

/// The packed texels of some samples, with what decoding them needs.
#[derive(Clone)]
struct Band<'a> {
    /// Per target: the samples' texel bytes and the bytes per texel.
    targets: Vec<(&'a [u8], usize)>,
    table: Option<&'a MaterialTable>,
    present: &'a [Attribute],
    /// Decoded planes are reused band after band: background samples are written 0.
    zero_background: bool,
    /// Decode only these attributes' fields and table parameters (`present` is already cut to them).
    only: Option<&'a [Attribute]>,
}

impl<'a> Band<'a> {
    /// Samples `range` of `targets` (whole planes).
    fn of(
        targets: &'a [TargetPlane],
        range: Range<usize>,
        table: Option<&'a MaterialTable>,
        present: &'a [Attribute],
    ) -> Self {
        let targets = targets
            .iter()
            .map(|t| {
                let size = t.format.bytes();
                (&t.bytes[range.start * size..range.end * size], size)
            })
            .collect();
        Band { targets, table, present, zero_background: false, only: None }
    }
}

/// A borrowed source plane for one field.
enum Src<'a> {
    F32(&'a [f32]),
    V3(&'a [Vec3]),
    V3c(&'a [Vec3], usize),
    V2c(&'a [Vec2], usize),
    U32(&'a [u32]),
    Absent,
}

/// The source of a position field `slot` from derived positions `p`.
fn position_source(p: &[Vec3], slot: Slot) -> Src<'_> {
    match slot {
        Slot::Whole(Attribute::Position) => Src::V3(p),
        Slot::Component(Attribute::Position, k) => Src::V3c(p, k),
        _ => Src::Absent,
    }
}

fn source<'a>(gb: &'a GBuffer, slot: Slot, index: &'a [u32]) -> Src<'a> {
    use crate::gbuffer::PlaneRef as P;
    match slot {
        Slot::MaterialIndex => Src::U32(index),
        Slot::Reserved => Src::Absent,
        Slot::Whole(a) => match gb.plane(a) {
            Some(P::F32(p)) => Src::F32(p),
            Some(P::Vec3(p)) => Src::V3(p),
            Some(P::U32(p)) => Src::U32(p),
            Some(P::Vec2(_)) | None => Src::Absent,
        },
        Slot::Component(a, k) => match gb.plane(a) {
            Some(P::Vec3(p)) => Src::V3c(p, k),
            Some(P::Vec2(p)) => Src::V2c(p, k),
            _ => Src::Absent,
        },
    }
}

/// Encodes samples `base..base + codes.len()` of `src` with `coder` into `codes` (slice paths; `tmp` is scratch
/// for gathering one component of a vector plane).
fn encode_block(coder: &Coder, src: &Src<'_>, base: usize, codes: &mut [u64], tmp: &mut Vec<f32>) {
    let r = base..base + codes.len();
    match (coder, src) {
        (Coder::Normal(c), Src::V3(p)) => c.encode_slice(&p[r.clone()], codes),
        (Coder::Color(c), Src::V3(p)) => c.encode_slice(&p[r.clone()], codes),
        (Coder::Depth(c), Src::F32(p)) => c.encode_slice(&p[r.clone()], codes),
        (Coder::Scalar(c), Src::F32(p)) => c.encode_slice(&p[r.clone()], codes),
        (Coder::Scalar(c), Src::V3c(p, k)) => c.encode_slice(gather(tmp, &p[r.clone()], |v| v[*k]), codes),
        (Coder::Scalar(c), Src::V2c(p, k)) => c.encode_slice(gather(tmp, &p[r.clone()], |v| v[*k]), codes),
        (Coder::Id(bits), Src::U32(p)) => {
            for (o, v) in codes.iter_mut().zip(&p[r.clone()]) {
                *o = encode_id(*v, *bits);
            }
        }
        (Coder::None, Src::U32(p)) => {
            for (o, v) in codes.iter_mut().zip(&p[r.clone()]) {
                *o = u64::from(*v);
            }
        }
        _ => codes.fill(0),
    }
}

/// One component of each vector, into `tmp`.
fn gather<'t, T>(tmp: &'t mut Vec<f32>, src: &[T], f: impl Fn(&T) -> f32) -> &'t [f32] {
    tmp.clear();
    tmp.extend(src.iter().map(f));
    tmp
}

/// A texel word: `u64` for formats of ≤ 8 bytes, `u128` for the 16-byte ones.
trait Word: Copy + Default + Send + Sync {
    /// ORs the low `bits` bits of `code` in at `offset`.
    fn put(&mut self, offset: u32, bits: u32, code: u64);
    /// The `bits` bits at `offset`.
    fn get(self, offset: u32, bits: u32) -> u64;
    /// Little-endian load of `src.len()` bytes.
    fn load(src: &[u8]) -> Self;
    /// Little-endian store of the low `out.len()` bytes.
    fn store(self, out: &mut [u8]);
    /// [`Word::put`] of each code into its word.
    #[inline(always)]
    fn put_all(words: &mut [Self], offset: u32, bits: u32, codes: &[u64]) {
        for (w, c) in words.iter_mut().zip(codes) {
            w.put(offset, bits, *c);
        }
    }
}

impl Word for u64 {
    #[inline(always)]
    fn put(&mut self, offset: u32, bits: u32, code: u64) {
        debug_assert!(offset + bits <= 64);
        *self |= (code & mask(bits)) << offset;
    }
    #[inline(always)]
    fn get(self, offset: u32, bits: u32) -> u64 {
        (self >> offset) & mask(bits)
    }
    #[inline(always)]
    fn load(src: &[u8]) -> Self {
        let mut b = [0u8; 8];
        b[..src.len()].copy_from_slice(src);
        u64::from_le_bytes(b)
    }
    #[inline(always)]
    fn store(self, out: &mut [u8]) {
        out.copy_from_slice(&self.to_le_bytes()[..out.len()]);
    }
    #[inline(always)]
    fn put_all(words: &mut [Self], offset: u32, bits: u32, codes: &[u64]) {
        debug_assert!(offset + bits <= 64);
        // The mask and shift hoisted: the loop is one vector and/shift/or per lane.
        let m = mask(bits);
        for (w, c) in words.iter_mut().zip(codes) {
            *w |= (c & m) << offset;
        }
    }
}

impl Word for u128 {
    #[inline(always)]
    fn put(&mut self, offset: u32, bits: u32, code: u64) {
        insert(self, offset, bits, code);
    }
    #[inline(always)]
    fn get(self, offset: u32, bits: u32) -> u64 {
        extract(self, offset, bits)
    }
    #[inline(always)]
    fn load(src: &[u8]) -> Self {
        load_le(src)
    }
    #[inline(always)]
    fn store(self, out: &mut [u8]) {
        store_le(self, out);
    }
}

/// Stores `words` as texels of `N` bytes (a constant, so the copies compile to single moves).
#[inline(always)]
fn store_words<W: Word, const N: usize>(words: &[W], out: &mut [u8]) {
    for (w, t) in words.iter().zip(out.chunks_exact_mut(N)) {
        w.store(t);
    }
}

/// Extracts the field at `offset`/`bits` of every texel of `N` bytes in `bytes` into `codes`.
#[inline(always)]
fn load_codes<W: Word, const N: usize>(bytes: &[u8], offset: u32, bits: u32, codes: &mut [u64]) {
    for (c, t) in codes.iter_mut().zip(bytes.chunks_exact(N)) {
        *c = W::load(t).get(offset, bits);
    }
}

/// Packs one target's bytes for the samples from `first` on (a whole row): blocks of whole rows in parallel, each
/// field through its codec's slice path.
fn pack_target<W: Word>(
    fields: &[(&Field, &Coder, Src<'_>, usize)],
    clear: W,
    cov: &[bool],
    size: usize,
    row: usize,
    first: usize,
    bytes: &mut [u8],
) {
    let chunk = rows_chunk(row);
    bytes.par_chunks_mut(chunk * size).enumerate().for_each(|(ci, out)| {
        let base = first + ci * chunk;
        let len = out.len() / size;
        let mut words = vec![W::default(); len];
        let mut codes = vec![0u64; len];
        let mut tmp = Vec::with_capacity(len);
        for (f, coder, src, start) in fields {
            encode_block(coder, src, base - start, &mut codes, &mut tmp);
            W::put_all(&mut words, f.offset, f.bits, &codes);
        }
        // Background samples are a cleared texel.
        for (w, c) in words.iter_mut().zip(&cov[base..base + len]) {
            *w = if *c { *w } else { clear };
        }
        match size {
            1 => store_words::<W, 1>(&words, out),
            2 => store_words::<W, 2>(&words, out),
            3 => store_words::<W, 3>(&words, out),
            4 => store_words::<W, 4>(&words, out),
            6 => store_words::<W, 6>(&words, out),
            12 => store_words::<W, 12>(&words, out),
            8 => store_words::<W, 8>(&words, out),
            16 => store_words::<W, 16>(&words, out),
            _ => {
                for (w, t) in words.iter().zip(out.chunks_exact_mut(size)) {
                    w.store(t);
                }
            }
        }
    });
}

impl Layout {
    /// Near/far planes for depth codecs: the G-buffer camera's, else the layout's `depth_range`, else the default.
    #[must_use]
    pub fn depth_range_for(&self, gb: &GBuffer) -> [f32; 2] {
        match gb.camera {
            Some(c) if c.znear > 0.0 && c.zfar > c.znear && c.zfar.is_finite() => [c.znear, c.zfar],
            _ => self.spec().depth_range.unwrap_or(DEFAULT_DEPTH_RANGE),
        }
    }

    /// Arithmetic operations a lighting pass spends decoding one sample of this layout: per stored field, 2 to
    /// extract its bits from the texel word (shift, mask) plus its codec's [`crate::codec::Codec::decode_ops`];
    /// an ID field is the extraction alone; the material index adds one table lookup per parameter. Reserved bits
    /// are not read. Rebuilding position from depth is the lighting's, the same for every layout, and not counted.
    #[must_use]
    pub fn decode_ops_per_sample(&self) -> u32 {
        const EXTRACT: u32 = 2;
        let coders = self.coders(DEFAULT_DEPTH_RANGE).unwrap_or_default();
        let lookups = self.indirection().map_or(0, |i| i.parameters.len() as u32);
        self.fields()
            .iter()
            .zip(&coders)
            .map(|(f, c)| match f.slot {
                Slot::Reserved => 0,
                Slot::MaterialIndex => EXTRACT + lookups,
                _ => EXTRACT + c.decode_ops(),
            })
            .sum()
    }

    fn coders(&self, [znear, zfar]: [f32; 2]) -> Result<Vec<Coder>> {
        self.fields()
            .iter()
            .map(|f| {
                Coder::build(f.slot, &f.codec, znear, zfar)
                    .map_err(|e| Error::Argument(format!("layout {:?}: {e}", self.name())))
            })
            .collect()
    }

    /// Packs `gb` into render-target bytes.
    pub fn pack(&self, gb: &GBuffer) -> Result<Packed> {
        self.pack_timed(gb, 1, 1).map(|(packed, _, _)| packed)
    }

    /// [`Layout::pack`], timed: the whole frame once, then `runs − 1` estimates that pack every `stride`-th band of
    /// [`BAND_SAMPLES`] (the others skipped) into scratch targets, scaled by the stride (a systematic sample of the
    /// frame; `stride` 1 packs it whole again). The material table is built once before the runs and timed on its
    /// own, as [`Layout::roundtrip_timed`] does. Returns the packed frame, each run's encode time and the table's
    /// (ms).
    pub fn pack_timed(&self, gb: &GBuffer, runs: usize, stride: u32) -> Result<(Packed, Vec<f64>, Option<f64>)> {
        gb.validate()?;
        self.check_afrc(gb)?;
        let depth_range = self.depth_range_for(gb);
        let coders = self.coders(depth_range)?;
        let t = Instant::now();
        let (material_table, index) = self.material_index(gb);
        let table_ms = material_table.is_some().then(|| t.elapsed().as_secs_f64() * 1e3);
        let mut targets = self.empty_targets();
        let t = Instant::now();
        self.pack_samples(gb, &coders, &index, 0..gb.len(), &mut targets, None);
        let mut encode_ms = vec![t.elapsed().as_secs_f64() * 1e3];
        let row = (gb.width as usize * gb.samples as usize).max(1);
        let band_len = row * band_rows(row);
        let bands = gb.len().div_ceil(band_len).max(1);
        let stride = stride.max(1) as usize;
        let mut scratch = self.empty_targets();
        for _ in 1..runs.max(1) {
            let t = Instant::now();
            for b in (0..bands).step_by(stride) {
                let range = b * band_len..((b + 1) * band_len).min(gb.len());
                self.pack_samples(gb, &coders, &index, range, &mut scratch, None);
            }
            let sampled = bands.div_ceil(stride);
            encode_ms.push(t.elapsed().as_secs_f64() * 1e3 * bands as f64 / sampled as f64);
        }
        let packed = Packed {
            layout: self.name().to_string(),
            width: gb.width,
            height: gb.height,
            samples: gb.samples,
            targets,
            material_table,
            depth_range,
            present: self.present(gb),
        };
        Ok((packed, encode_ms, table_ms))
    }

    /// Packs `gb` a band of `rows` rows at a time into band-sized targets and hands each band's [`Packed`] (its
    /// `height` the band's) to `each`: the frame's packed bytes seen whole without holding them whole.
    pub(crate) fn pack_bands(&self, gb: &GBuffer, rows: u32, mut each: impl FnMut(&Packed)) -> Result<()> {
        gb.validate()?;
        self.check_afrc(gb)?;
        debug_assert!((rows as usize).is_multiple_of(AFRC_ROWS));
        let depth_range = self.depth_range_for(gb);
        let coders = self.coders(depth_range)?;
        let (material_table, index) = self.material_index(gb);
        let row = gb.width as usize * gb.samples as usize;
        let mut band = Packed {
            layout: self.name().to_string(),
            width: gb.width,
            height: 0,
            samples: gb.samples,
            targets: self.empty_targets(),
            material_table,
            depth_range,
            present: self.present(gb),
        };
        for y0 in (0..gb.height).step_by(rows.max(1) as usize) {
            let h = rows.max(1).min(gb.height - y0);
            self.pack_samples(gb, &coders, &index, y0 as usize * row..(y0 + h) as usize * row, &mut band.targets, None);
            band.height = h;
            each(&band);
        }
        Ok(())
    }

    /// The texel of target `target` at a background sample: zero but a depth field, which holds its codec's
    /// [`crate::codec::DepthCodec::clear_code`].
    fn clear_texel(&self, coders: &[Coder], target: usize) -> u128 {
        let mut word = 0u128;
        for (f, c) in self.fields().iter().zip(coders).filter(|(f, _)| f.target == target) {
            if let Coder::Depth(d) = c {
                insert(&mut word, f.offset, f.bits, d.clear_code());
            }
        }
        word
    }

    /// The coverage of packed targets read from files (no float truth): a sample is covered unless its depth field
    /// holds the depth codec's clear code. `None` when the layout stores no depth field.
    pub fn coverage_from_depth(&self, targets: &[TargetPlane], depth_range: [f32; 2]) -> Result<Option<Vec<bool>>> {
        let coders = self.coders(depth_range)?;
        let Some((f, Coder::Depth(d))) =
            self.fields().iter().zip(&coders).find(|(f, _)| f.slot == Slot::Whole(Attribute::Depth))
        else {
            return Ok(None);
        };
        let t = &targets[f.target];
        let (size, clear) = (t.format.bytes(), d.clear_code());
        Ok(Some(
            t.bytes.par_chunks_exact(size).map(|texel| extract(load_le(texel), f.offset, f.bits) != clear).collect(),
        ))
    }

    /// The material table and every sample's index into it, when the layout uses indirection.
    fn material_index(&self, gb: &GBuffer) -> (Option<MaterialTable>, Vec<u32>) {
        match self.indirection() {
            Some(ind) => {
                let (t, i) = MaterialTable::build_keyed(gb, &ind.parameters, ind.bits, ind.key);
                (Some(t), i)
            }
            None => (None, Vec::new()),
        }
    }

    /// Attributes `gb` has that the layout stores.
    fn present(&self, gb: &GBuffer) -> Vec<Attribute> {
        self.stored_attributes()
            .into_iter()
            .filter(|&a| gb.has(a) || (a == Attribute::Position && gb.derives_position()))
            .collect()
    }

    /// One empty byte plane per render target.
    fn empty_targets(&self) -> Vec<TargetPlane> {
        self.formats()
            .iter()
            .zip(&self.spec().targets)
            .map(|(format, t)| TargetPlane { name: t.name.clone(), format: *format, bytes: Vec::new() })
            .collect()
    }

    /// Packs samples `range` (whole rows) of `gb` into `targets`, whose bytes are resized to the range (`index`:
    /// every sample's material index, empty without indirection). Only the targets `needed` marks are encoded (all of
    /// them with `None`); the others are sized to the range but not written (a decode of only some attributes never
    /// reads them).
    fn pack_samples(
        &self,
        gb: &GBuffer,
        coders: &[Coder],
        index: &[u32],
        range: Range<usize>,
        targets: &mut [TargetPlane],
        needed: Option<&[bool]>,
    ) {
        let row = gb.width as usize * gb.samples as usize;
        // Positions a target to be encoded stores but the G-buffer leaves to its depth and camera: the band's, derived
        // (what a renderer writing this G-buffer would store).
        let encodes_position = self
            .fields()
            .iter()
            .any(|f| f.slot.attribute() == Some(Attribute::Position) && needed.is_none_or(|n| n[f.target]));
        let derived = (encodes_position && gb.derives_position())
            .then(|| gb.derived_positions_of_rows(range.start / row.max(1)..range.end / row.max(1)))
            .flatten();
        for (ti, target) in targets.iter_mut().enumerate() {
            let size = target.format.bytes();
            if needed.is_some_and(|n| !n[ti]) {
                target.bytes.resize(range.len() * size, 0);
                continue;
            }
            // Each field's source and the sample index its slice starts at (0: a whole plane; the range's start: the
            // band's derived positions).
            let fields: Vec<(&Field, &Coder, Src<'_>, usize)> = self
                .fields()
                .iter()
                .zip(coders)
                .filter(|(f, _)| f.target == ti)
                .map(|(f, c)| match (source(gb, f.slot, index), &derived) {
                    (Src::Absent, Some(p)) => (f, c, position_source(p, f.slot), range.start),
                    (s, _) => (f, c, s, 0),
                })
                .filter(|(_, _, s, _)| !matches!(s, Src::Absent))
                .collect();
            // Every byte is written by `pack_target`: no clearing needed when the plane is reused.
            target.bytes.resize(range.len() * size, 0);
            let clear = self.clear_texel(coders, ti);
            if size <= 8 {
                pack_target::<u64>(&fields, clear as u64, &gb.coverage, size, row, range.start, &mut target.bytes);
            } else {
                pack_target::<u128>(&fields, clear, &gb.coverage, size, row, range.start, &mut target.bytes);
            }
            // What the GPU reads back of a fixed-rate target: the range starts at a whole coding unit (every caller's
            // bands are multiples of `AFRC_ROWS` rows) and the frame is single-sampled (`check_afrc`).
            if let Some(rate) = self.spec().targets[ti].afrc {
                debug_assert!(gb.samples == 1 && (range.start / row.max(1)).is_multiple_of(AFRC_ROWS));
                let rows = (range.len() / row.max(1)) as u32;
                super::afrc::roundtrip(&mut target.bytes, target.format, gb.width, rows, rate);
            }
        }
    }

    /// An AFRC target cannot hold a multisampled frame: the error that says so, naming the target.
    fn check_afrc(&self, gb: &GBuffer) -> Result<()> {
        match self.spec().targets.iter().find(|t| t.afrc.is_some()) {
            Some(t) if gb.samples > 1 => Err(Error::Argument(format!(
                "layout {:?}: target {:?} is stored with AFRC, which holds no multisampled image (the frame has {} \
                 samples per pixel)",
                self.name(),
                t.name,
                gb.samples
            ))),
            _ => Ok(()),
        }
    }

    /// Reads `packed` back into a G-buffer. Size, sample positions, camera and coverage come from `like` (the
    /// buffer that was packed, or one with the same geometry). Stored attributes are decoded; unstored ones get
    /// the layout's constants or stay absent; position (or depth) is re-derived from the other and the camera
    /// when the layout stores only one. Background samples are 0 in every plane.
    pub fn unpack(&self, packed: &Packed, like: &GBuffer) -> Result<GBuffer> {
        self.check(packed, like)?;
        let coders = self.coders(packed.depth_range)?;
        let mut out = like.shell();
        let mut index = Vec::new();
        let band = Band::of(&packed.targets, 0..like.len(), packed.material_table.as_ref(), &packed.present);
        let row = like.width as usize * like.samples as usize;
        self.unpack_samples(&band, &coders, &like.coverage, row, 0..like.len(), &mut out, &mut index)?;
        self.finish_unpack(&mut out, true);
        Ok(out)
    }

    /// Decodes the texels of `band` (whole rows of `row` samples, whose coverage is `cov`) into samples `r` of
    /// `out`'s planes, creating planes of `n` zeroes that are missing. Every sample of `r` in a decoded plane is
    /// written where covered, and 0 elsewhere when `band.zero_background`. `index` is scratch for the band's
    /// material indices.
    #[allow(clippy::too_many_arguments)]
    fn unpack_samples(
        &self,
        band: &Band<'_>,
        coders: &[Coder],
        cov: &[bool],
        row: usize,
        r: Range<usize>,
        out: &mut GBuffer,
        index: &mut Vec<u32>,
    ) -> Result<()> {
        let n = out.len();
        debug_assert!(cov.len() == r.len() && r.end <= n);
        let range = r.clone();
        let mut has_index = false;
        for (f, coder) in self.fields().iter().zip(coders) {
            let (bytes, size) = band.targets[f.target];
            let zero_background = band.zero_background;
            let src = Texels { bytes, size, offset: f.offset, bits: f.bits, cov, row, zero_background };
            let ids = |cs: &[u64], o: &mut [u32]| {
                for (o, c) in o.iter_mut().zip(cs) {
                    *o = *c as u32;
                }
            };
            match (f.slot, coder) {
                (Slot::Reserved, _) => {}
                (Slot::MaterialIndex, _) => {
                    index.clear();
                    index.resize(range.len(), 0);
                    src.fill(index, ids, whole);
                    has_index = true;
                }
                (Slot::Whole(a), _) if !band.present.contains(&a) => {}
                (Slot::Component(a, _), _) if !band.present.contains(&a) => {}
                (Slot::Whole(Attribute::Normal), Coder::Normal(c)) => {
                    let plane = out.normal.get_or_insert_with(|| crate::base::memory::zeroed_vec3(n));
                    src.fill(&mut plane[r.clone()], |cs, o| c.decode_slice(cs, o), whole);
                }
                (Slot::Whole(Attribute::Albedo), Coder::Color(c)) => {
                    let plane = out.albedo.get_or_insert_with(|| crate::base::memory::zeroed_vec3(n));
                    src.fill(&mut plane[r.clone()], |cs, o| c.decode_slice(cs, o), whole);
                }
                (Slot::Whole(Attribute::Depth), Coder::Depth(c)) => {
                    let plane = out.depth.get_or_insert_with(|| vec![0.0; n]);
                    src.fill(&mut plane[r.clone()], |cs, o| c.decode_slice(cs, o), whole);
                }
                (Slot::Whole(a), Coder::Scalar(c)) => {
                    src.fill(&mut scalar_plane(out, a, n)?[r.clone()], |cs, o| c.decode_slice(cs, o), whole);
                }
                (Slot::Whole(a), Coder::Id(_)) => {
                    src.fill(&mut id_plane(out, a, n)?[r.clone()], ids, whole);
                }
                (Slot::Component(a, k), Coder::Scalar(c)) => match a {
                    Attribute::Motion => {
                        let plane = out.motion.get_or_insert_with(|| vec![Vec2::ZERO; n]);
                        src.fill(&mut plane[r.clone()], |cs, o| c.decode_slice(cs, o), |d: &mut Vec2, v| d[k] = v);
                    }
                    _ => {
                        let plane = match a {
                            Attribute::Normal => &mut out.normal,
                            Attribute::Albedo => &mut out.albedo,
                            _ => &mut out.position,
                        };
                        let plane = plane.get_or_insert_with(|| crate::base::memory::zeroed_vec3(n));
                        src.fill(&mut plane[r.clone()], |cs, o| c.decode_slice(cs, o), |d: &mut Vec3, v| d[k] = v);
                    }
                },
                (slot, _) => {
                    return Err(Error::Mismatch(format!("layout {:?}: cannot decode {}", self.name(), slot.name())))
                }
            }
        }
        if let Some(table) = band.table {
            let chunk = rows_chunk(row);
            for (p, a) in table.attributes().into_iter().enumerate() {
                if band.only.is_some_and(|only| !only.contains(&a)) {
                    continue;
                }
                let plane = &mut scalar_plane(out, a, n)?[r.clone()];
                plane.par_chunks_mut(chunk).zip(cov.par_chunks(chunk)).enumerate().try_for_each(|(ci, (d, c))| {
                    for (j, (d, &covered)) in d.iter_mut().zip(c).enumerate() {
                        if covered {
                            let k = if has_index { index[ci * chunk + j] } else { 0 };
                            let entry = table.entries.get(k as usize).ok_or_else(|| {
                                Error::Mismatch(format!(
                                    "material index {k} outside the table of {} entries",
                                    table.entries.len()
                                ))
                            })?;
                            *d = entry[p];
                        } else if band.zero_background {
                            *d = 0.0;
                        }
                    }
                    Ok::<(), Error>(())
                })?;
            }
        }
        Ok(())
    }

    /// What unpacking does once every band is decoded: the layout's constants, and position (or depth) derived
    /// from the other when the layout stores only one (position only when `derive_position`: see
    /// [`Layout::roundtrip_for_lighting`]).
    fn finish_unpack(&self, out: &mut GBuffer, derive_position: bool) {
        self.finish_unpack_only(out, derive_position, None);
    }

    /// [`Layout::finish_unpack`] setting only the constants of `only` (all when `None`).
    fn finish_unpack_only(&self, out: &mut GBuffer, derive_position: bool, only: Option<&[Attribute]>) {
        let n = out.len();
        for (a, vals) in self.constants() {
            if only.is_none_or(|only| only.contains(a)) {
                set_constant(out, *a, vals, n);
            }
        }
        if !self.stores(Attribute::Position) && self.stores(Attribute::Depth) && out.depth.is_some() {
            if derive_position {
                out.fill_position_from_depth();
            }
        } else if !self.stores(Attribute::Depth) && self.stores(Attribute::Position) && out.position.is_some() {
            out.fill_depth_from_position();
        } else if !self.stores(Attribute::Position) || !self.stores(Attribute::Depth) {
            out.derive_depth_or_position();
        }
    }

    /// Packs and unpacks: the G-buffer the lighting pass of a renderer using this layout would see. Works band by
    /// band ([`Layout::roundtrip_timed`]), so only one band's packed bytes exist at a time.
    pub fn roundtrip(&self, gb: &GBuffer) -> Result<GBuffer> {
        self.roundtrip_timed(gb, 1).map(|r| r.decoded)
    }

    /// Packs and unpacks `gb` `runs` times (at least once), timing each run's encode and decode. Each run goes
    /// band by band (about [`BAND_SAMPLES`] samples of whole rows): the band is packed into render-target bytes
    /// and unpacked into the output at once, so the packed frame never exists whole (a lossless 84-byte layout of a
    /// 1080p × 4 frame would be 700 MB), and the band's bytes and the output planes are reused from run to run, so
    /// only the first run pays for fresh memory. The decoded G-buffer is bit-identical to
    /// `unpack(&pack(gb)?, gb)` (tested).
    ///
    /// The encode time of a run is every band's packing (with indirection, writing each sample's index into the
    /// table); the decode time every band's unpacking plus the constants and the derived depth or position. The
    /// material table is built once, before the runs, and timed on its own (`table_ms`): an engine builds its
    /// material table when its content is built, and a frame's G-buffer pass only writes each surface's index.
    pub fn roundtrip_timed(&self, gb: &GBuffer, runs: usize) -> Result<Roundtrip> {
        self.roundtrip_runs(gb, runs, true)
    }

    /// [`Layout::roundtrip_timed`] as a lighting pass reads the layout: when the layout stores depth but not
    /// position and the G-buffer has a camera, the decoded G-buffer has no position plane, because the lighting
    /// derives each position from depth and the camera (`resolve`'s reader does, bit for bit as
    /// [`GBuffer::fill_position_from_depth`] would), as a deferred renderer's lighting shader does. The report's
    /// decoded copies are then 12 bytes a sample smaller (100 MB at 1080p × 4) and their decode time holds only
    /// what the layout decodes. Every other plane is [`Layout::roundtrip_timed`]'s, and a resolve of either gives
    /// the same image bit for bit (tested).
    pub fn roundtrip_for_lighting(&self, gb: &GBuffer, runs: usize) -> Result<Roundtrip> {
        self.roundtrip_runs(gb, runs, false)
    }

    fn roundtrip_runs(&self, gb: &GBuffer, runs: usize, derive_position: bool) -> Result<Roundtrip> {
        gb.validate()?;
        self.check_afrc(gb)?;
        let depth_range = self.depth_range_for(gb);
        let coders = self.coders(depth_range)?;
        let present = self.present(gb);
        let row = (gb.width as usize * gb.samples as usize).max(1);
        let band_len = row * band_rows(row);
        let mut targets = self.empty_targets();
        let mut out = gb.shell();
        let mut index = Vec::new();
        let (mut encode_ms, mut decode_ms) = (Vec::new(), Vec::new());
        let t = Instant::now();
        let (table, material) = self.material_index(gb);
        let table_ms = table.is_some().then(|| t.elapsed().as_secs_f64() * 1e3);
        for _ in 0..runs.max(1) {
            let mut enc = Duration::ZERO;
            let mut dec = Duration::ZERO;
            let mut start = 0;
            while start < gb.len() {
                let range = start..(start + band_len).min(gb.len());
                let t = Instant::now();
                self.pack_samples(gb, &coders, &material, range.clone(), &mut targets, None);
                enc += t.elapsed();
                let t = Instant::now();
                let band = Band::of(&targets, 0..range.len(), table.as_ref(), &present);
                let cov = &gb.coverage[range.clone()];
                self.unpack_samples(&band, &coders, cov, row, range.clone(), &mut out, &mut index)?;
                dec += t.elapsed();
                start = range.end;
            }
            let t = Instant::now();
            self.finish_unpack(&mut out, derive_position);
            dec += t.elapsed();
            encode_ms.push(enc.as_secs_f64() * 1e3);
            decode_ms.push(dec.as_secs_f64() * 1e3);
        }
        Ok(Roundtrip { decoded: out, encode_ms, decode_ms, table_ms })
    }

    /// Decodes `band`, the texels of rows `rows` of a frame shaped like `like`, into `out` as a G-buffer of its own
    /// (`width × rows.len()`, its planes reused; background samples 0), in the lighting's form: no position is
    /// derived from depth (that needs the frame's pixel rows; see [`PackedFrame::decode_rows`]).
    fn decode_band(
        &self,
        band: &Band<'_>,
        coders: &[Coder],
        like: &GBuffer,
        rows: Range<u32>,
        out: &mut GBuffer,
        only: Option<&[Attribute]>,
    ) -> Result<()> {
        let row = like.width as usize * like.samples as usize;
        let range = rows.start as usize * row..rows.end as usize * row;
        (out.width, out.height, out.samples) = (like.width, rows.end - rows.start, like.samples);
        if out.sample_positions != like.sample_positions {
            out.sample_positions.clone_from(&like.sample_positions);
        }
        if out.materials.len() != like.materials.len() {
            out.materials.clone_from(&like.materials);
        }
        out.coverage.clear();
        out.coverage.extend_from_slice(&like.coverage[range.clone()]);
        out.resize_planes(range.len());
        let present: Vec<Attribute> = match only {
            Some(only) => band.present.iter().copied().filter(|a| only.contains(a)).collect(),
            None => band.present.to_vec(),
        };
        let band = Band { zero_background: true, present: &present, only, ..band.clone() };
        let mut index = Vec::new();
        let cov = &like.coverage[range.clone()];
        self.unpack_samples(&band, coders, cov, row, 0..range.len(), out, &mut index)?;
        // No camera while finishing: nothing may derive positions from the band's own pixel coordinates.
        out.camera = None;
        self.finish_unpack_only(out, false, only);
        out.camera = like.camera;
        Ok(())
    }

    /// Whether the lighting's G-buffer of this layout ([`Layout::roundtrip_for_lighting`]) is `gb` itself, bit for
    /// bit: the same planes, the same bits in every sample. Packs and unpacks band by band without keeping either
    /// (a lossless layout's packed frame would be as large as `gb`), and returns the encode and decode times (ms).
    pub fn roundtrip_matches(&self, gb: &GBuffer) -> Result<(bool, f64, f64)> {
        self.roundtrip_bands(gb, 1, true)
    }

    /// The encode and decode times (ms) of [`Layout::roundtrip_matches`]' whole frame, estimated from every
    /// `stride`-th band, scaled by the bands timed (a report's repeated timing runs; nothing is compared).
    pub fn roundtrip_time_sampled(&self, gb: &GBuffer, stride: u32) -> Result<(f64, f64)> {
        self.roundtrip_bands(gb, stride, false).map(|(_, enc, dec)| (enc, dec))
    }

    /// Packs and decodes every `stride`-th band, comparing each with `gb` when `check` (stopping at the first that
    /// differs); returns whether all compared equal and the encode and decode times (ms), scaled to the frame.
    fn roundtrip_bands(&self, gb: &GBuffer, stride: u32, check: bool) -> Result<(bool, f64, f64)> {
        let mut same = true;
        let (enc, dec, bands, timed) = self.each_roundtrip_band(gb, stride, None, |rows, out| {
            let row = gb.width as usize * gb.samples as usize;
            same = !check || same_planes(gb, rows.start as usize * row..rows.end as usize * row, out);
            Ok(same)
        })?;
        let scale = f64::from(bands) / f64::from(timed);
        let ms = |d: Duration| d.as_secs_f64() * 1e3 * scale;
        Ok((same, ms(enc), ms(dec)))
    }

    /// Packs `gb` with this layout band by band and decodes each band again (all planes, or those of `only` as
    /// [`PackedFrame::decode_rows_only`] does, depth and position together), without ever holding the frame's packed
    /// targets or decoded planes whole: `each(rows, band)` sees the frame's rows `rows` as the layout gives them
    /// back, and stops the walk by returning `false`. Every `stride`-th band is visited. Returns the time spent
    /// encoding and decoding, the frame's band count and how many bands were visited.
    pub fn each_roundtrip_band(
        &self,
        gb: &GBuffer,
        stride: u32,
        only: Option<&[Attribute]>,
        mut each: impl FnMut(Range<u32>, &GBuffer) -> Result<bool>,
    ) -> Result<(Duration, Duration, u32, u32)> {
        gb.validate()?;
        self.check_afrc(gb)?;
        let only = only.map(with_depth_and_position);
        // The targets a decode of `only` reads: those with a field of it, or the material index (its table gives
        // material attributes).
        let needed: Option<Vec<bool>> = only.as_ref().map(|only| {
            (0..self.formats().len())
                .map(|t| {
                    self.fields().iter().filter(|f| f.target == t).any(|f| match f.slot {
                        Slot::MaterialIndex => true,
                        slot => slot.attribute().is_some_and(|a| only.contains(&a)),
                    })
                })
                .collect()
        });
        let coders = self.coders(self.depth_range_for(gb))?;
        let present = self.present(gb);
        let (table, material) = self.material_index(gb);
        let rows_per_band = band_rows(gb.width as usize * gb.samples as usize) as u32;
        let mut targets = self.empty_targets();
        let mut out = GBuffer::default();
        let (mut enc, mut dec) = (Duration::ZERO, Duration::ZERO);
        let row = gb.width as usize * gb.samples as usize;
        let bands = gb.height.div_ceil(rows_per_band).max(1);
        let stride = stride.max(1);
        for b in (0..bands).step_by(stride as usize) {
            let rows = b * rows_per_band..((b + 1) * rows_per_band).min(gb.height);
            let range = rows.start as usize * row..rows.end as usize * row;
            let t = Instant::now();
            self.pack_samples(gb, &coders, &material, range.clone(), &mut targets, needed.as_deref());
            enc += t.elapsed();
            let t = Instant::now();
            let band = Band::of(&targets, 0..range.len(), table.as_ref(), &present);
            self.decode_band(&band, &coders, gb, rows.clone(), &mut out, only.as_deref())?;
            dec += t.elapsed();
            if !each(rows, &out)? {
                break;
            }
        }
        Ok((enc, dec, bands, bands.div_ceil(stride)))
    }

    /// `packed` ready to be decoded a band of rows at a time ([`PackedFrame::decode_rows`]), as a lighting pass
    /// reads it. Fails as [`Layout::unpack`] when `packed` does not fit this layout or `like`.
    pub fn frame<'a>(&'a self, packed: &'a Packed, like: &'a GBuffer) -> Result<PackedFrame<'a>> {
        self.check(packed, like)?;
        let coders = self.coders(packed.depth_range)?;
        Ok(PackedFrame { like, source: Source::Layout { layout: self, packed, coders } })
    }

    fn check(&self, packed: &Packed, like: &GBuffer) -> Result<()> {
        let bad = |what: String| Err(Error::Mismatch(format!("unpack with layout {:?}: {what}", self.name())));
        if packed.layout != self.name() {
            return bad(format!("the data was packed with layout {:?}", packed.layout));
        }
        if (packed.width, packed.height, packed.samples) != (like.width, like.height, like.samples) {
            return bad(format!(
                "packed {}×{}×{} but the reference is {}×{}×{}",
                packed.width, packed.height, packed.samples, like.width, like.height, like.samples
            ));
        }
        like.validate()?;
        if packed.targets.len() != self.formats().len() {
            return bad(format!("{} targets, the layout has {}", packed.targets.len(), self.formats().len()));
        }
        for (t, f) in packed.targets.iter().zip(self.formats()) {
            if t.format != *f || t.bytes.len() != like.len() * f.bytes() {
                return bad(format!("target {} has {} bytes of {}, expected {f}", t.name, t.bytes.len(), t.format));
            }
        }
        if self.indirection().is_some() != packed.material_table.is_some() {
            return bad("material table missing or unexpected".into());
        }
        Ok(())
    }
}

/// The `set` of [`Texels::fill`] for a whole-value field.
fn whole<T>(d: &mut T, v: T) {
    *d = v;
}

/// One field of one packed target, read back block by block.
struct Texels<'a> {
    bytes: &'a [u8],
    size: usize,
    offset: u32,
    bits: u32,
    cov: &'a [bool],
    row: usize,
    /// Write 0 at background samples (a reused band buffer); otherwise they are not touched, so the untouched
    /// pages of a fresh zeroed plane are never faulted in (a third of a 1080p frame's samples can be sky).
    zero_background: bool,
}

impl Texels<'_> {
    /// Decodes the field into `dst` in parallel over blocks of whole rows: the block's codes are extracted, turned
    /// into values by `decode` (a codec's slice path), and `set(dst[i], value)` runs for covered samples;
    /// `set(dst[i], 0)` for the others with `zero_background`, else they keep their value.
    fn fill<T: Send, V: Copy + Default + Send>(
        &self,
        dst: &mut [T],
        decode: impl Fn(&[u64], &mut [V]) + Sync,
        set: impl Fn(&mut T, V) + Sync,
    ) {
        let (size, offset, bits, zero) = (self.size, self.offset, self.bits, self.zero_background);
        let chunk = rows_chunk(self.row);
        dst.par_chunks_mut(chunk).zip(self.bytes.par_chunks(chunk * size)).zip(self.cov.par_chunks(chunk)).for_each(
            |((d, b), c)| {
                let mut codes = vec![0u64; d.len()];
                match size {
                    1 => load_codes::<u64, 1>(b, offset, bits, &mut codes),
                    2 => load_codes::<u64, 2>(b, offset, bits, &mut codes),
                    3 => load_codes::<u64, 3>(b, offset, bits, &mut codes),
                    4 => load_codes::<u64, 4>(b, offset, bits, &mut codes),
                    6 => load_codes::<u64, 6>(b, offset, bits, &mut codes),
                    8 => load_codes::<u64, 8>(b, offset, bits, &mut codes),
                    12 => load_codes::<u128, 12>(b, offset, bits, &mut codes),
                    16 => load_codes::<u128, 16>(b, offset, bits, &mut codes),
                    _ => {
                        for (code, t) in codes.iter_mut().zip(b.chunks_exact(size)) {
                            *code = extract(load_le(t), offset, bits);
                        }
                    }
                }
                let mut vals = vec![V::default(); d.len()];
                decode(&codes, &mut vals);
                for ((d, v), &covered) in d.iter_mut().zip(vals).zip(c) {
                    if covered {
                        set(d, v);
                    } else if zero {
                        set(d, V::default());
                    }
                }
            },
        );
    }
}

fn scalar_plane(gb: &mut GBuffer, a: Attribute, n: usize) -> Result<&mut Vec<f32>> {
    match gb.slot(a) {
        PlaneSlot::F32(p) => Ok(p.get_or_insert_with(|| vec![0.0; n])),
        _ => Err(Error::Internal(format!("{} is not a scalar attribute", a.name()))),
    }
}

fn id_plane(gb: &mut GBuffer, a: Attribute, n: usize) -> Result<&mut Vec<u32>> {
    match gb.slot(a) {
        PlaneSlot::U32(p) => Ok(p.get_or_insert_with(|| vec![0; n])),
        _ => Err(Error::Internal(format!("{} is not an ID attribute", a.name()))),
    }
}

/// Sets attribute `a` to the constant `v` (its components; an ID is `v[0]` rounded down) on covered samples and 0
/// elsewhere, in place (the plane is created if missing, reused otherwise).
fn set_constant(gb: &mut GBuffer, a: Attribute, v: &[f32], n: usize) {
    fn fill<T: Copy + Send + Sync>(plane: &mut Option<Vec<T>>, cov: &[bool], n: usize, val: T, zero: T) {
        let plane = plane.get_or_insert_with(|| vec![zero; n]);
        plane.par_chunks_mut(CHUNK).zip(cov.par_chunks(CHUNK)).for_each(|(d, c)| {
            for (d, &c) in d.iter_mut().zip(c) {
                *d = if c { val } else { zero };
            }
        });
    }
    let cov = std::mem::take(&mut gb.coverage);
    match gb.slot(a) {
        PlaneSlot::F32(p) => fill(p, &cov, n, v[0], 0.0),
        PlaneSlot::Vec2(p) => fill(p, &cov, n, Vec2::new(v[0], v[1]), Vec2::ZERO),
        PlaneSlot::Vec3(p) => fill(p, &cov, n, Vec3::new(v[0], v[1], v[2]), Vec3::ZERO),
        PlaneSlot::U32(p) => fill(p, &cov, n, v[0] as u32, 0),
    }
    gb.coverage = cov;
}

/// The code a field holds for sample `i` of a packed target (for tests and tools that inspect raw bytes).
#[must_use]
pub fn field_code(packed: &Packed, field: &Field, i: usize) -> u64 {
    let t = &packed.targets[field.target];
    let size = t.format.bytes();
    extract(load_le(&t.bytes[i * size..(i + 1) * size]), field.offset, field.bits) & mask(field.bits)
}

/// A packed G-buffer with what decoding it needs, built once ([`Layout::frame`], or [`PackedFrame::of_source`] over
/// a dump's own arrays): what a lighting pass reads. A band of rows is decoded into a small G-buffer of its own
/// ([`PackedFrame::decode_rows`]), so a frame can be lit (or analysed) band by band without its decoded copy ever
/// existing whole.
pub struct PackedFrame<'a> {
    like: &'a GBuffer,
    source: Source<'a>,
}

/// Where a [`PackedFrame`]'s samples are.
enum Source<'a> {
    /// A layout's packed render targets.
    Layout { layout: &'a Layout, packed: &'a Packed, coders: Vec<Coder> },
    /// Other storage (a dump's own arrays).
    Other(&'a dyn BandSource),
}

impl std::fmt::Debug for PackedFrame<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let l = self.like;
        let mut d = f.debug_struct("PackedFrame");
        d.field("source", &self.describe()).field("size", &(l.width, l.height, l.samples));
        if let Source::Layout { packed, .. } = &self.source {
            d.field("bytes", &packed.total_bytes());
        }
        d.finish_non_exhaustive()
    }
}

impl<'a> PackedFrame<'a> {
    /// A frame decoded from `source`, of the size, sample positions, camera and coverage of `like` (whose planes,
    /// if any, are not read). Fails when `like` is not a valid G-buffer.
    pub fn of_source(like: &'a GBuffer, source: &'a dyn BandSource) -> Result<Self> {
        like.validate()?;
        Ok(PackedFrame { like, source: Source::Other(source) })
    }

    /// The layout, when the frame is a layout's packed targets.
    #[must_use]
    pub fn layout(&self) -> Option<&'a Layout> {
        match &self.source {
            Source::Layout { layout, .. } => Some(layout),
            Source::Other(_) => None,
        }
    }

    /// The packed targets, when the frame is a layout's.
    #[must_use]
    pub fn packed(&self) -> Option<&'a Packed> {
        match &self.source {
            Source::Layout { packed, .. } => Some(packed),
            Source::Other(_) => None,
        }
    }

    /// What the samples are stored as, for messages (`layout "lauritzen-15"`, `the ISPC .bin's arrays`).
    #[must_use]
    pub fn describe(&self) -> String {
        match &self.source {
            Source::Layout { layout, .. } => format!("layout {:?}", layout.name()),
            Source::Other(s) => s.describe(),
        }
    }

    /// The G-buffer whose size, sample positions, camera and coverage the packed targets have.
    #[must_use]
    pub fn like(&self) -> &'a GBuffer {
        self.like
    }

    /// Decodes rows `rows` into `out`, which becomes a G-buffer of `width × rows.len()` pixels (its planes reused
    /// when `out` held an earlier band of this frame: pass the same `GBuffer` band after band). Its planes are the
    /// same samples of [`Layout::unpack`]'s bit for bit, in the form the lighting reads
    /// ([`Layout::roundtrip_for_lighting`]): a layout storing depth but not position gets no position plane (the
    /// reader derives it from depth and the camera with the frame's pixel coordinates: a band's own would be
    /// wrong). `out`'s camera is the frame's; its coverage and planes are the band's.
    pub fn decode_rows(&self, rows: Range<u32>, out: &mut GBuffer) -> Result<()> {
        self.decode(rows, out, None)
    }

    /// [`PackedFrame::decode_rows`] decoding only the planes of `only` (what a pass reads: the others' fields are not
    /// extracted, and their planes are absent), each plane the same as `decode_rows` gives bit for bit. Depth and
    /// position come together (either one is derived from the other).
    pub fn decode_rows_only(&self, rows: Range<u32>, out: &mut GBuffer, only: &[Attribute]) -> Result<()> {
        self.decode(rows, out, Some(&with_depth_and_position(only)))
    }

    /// Rows `rows` into `out`, every plane or only those of `only`.
    fn decode(&self, rows: Range<u32>, out: &mut GBuffer, only: Option<&[Attribute]>) -> Result<()> {
        let like = self.like;
        if rows.start > rows.end || rows.end > like.height {
            return Err(Error::Mismatch(format!("rows {rows:?} outside the frame's {} rows", like.height)));
        }
        match &self.source {
            Source::Layout { layout, packed: p, coders } => {
                let row = like.width as usize * like.samples as usize;
                let range = rows.start as usize * row..rows.end as usize * row;
                let band = Band::of(&p.targets, range, p.material_table.as_ref(), &p.present);
                layout.decode_band(&band, coders, like, rows, out, only)
            }
            Source::Other(s) => s.decode_rows(like, rows, out, only),
        }
    }
}

/// `only` with depth and position both in when either is (each is derived from the other).
fn with_depth_and_position(only: &[Attribute]) -> Vec<Attribute> {
    let mut only = only.to_vec();
    if only.iter().any(|a| matches!(a, Attribute::Depth | Attribute::Position)) {
        only.extend([Attribute::Depth, Attribute::Position]);
    }
    only
}

/// Whether `band`'s planes are samples `range` of `gb`'s, bit for bit, with the same attributes present (positions `gb`
/// leaves to depth and the camera count as present when the band holds the derived ones).
fn same_planes(gb: &GBuffer, range: Range<usize>, band: &GBuffer) -> bool {
    fn bits<T: bytemuck::Pod>(a: &[T], b: &[T]) -> bool {
        bytemuck::cast_slice::<T, u8>(a) == bytemuck::cast_slice::<T, u8>(b)
    }
    use crate::gbuffer::PlaneRef as P;
    // Positions `gb` leaves to depth and the camera: the band's are the same when they are the derived ones.
    let row = (gb.width as usize * gb.samples as usize).max(1);
    let derived = (gb.derives_position() && band.position.is_some())
        .then(|| gb.derived_positions_of_rows(range.start / row..range.end / row))
        .flatten();
    let band_attributes: Vec<Attribute> =
        band.attributes().into_iter().filter(|&a| !(a == Attribute::Position && derived.is_some())).collect();
    gb.attributes() == band_attributes
        && gb.attributes().into_iter().all(|a| match (gb.plane(a), band.plane(a)) {
            (Some(P::F32(x)), Some(P::F32(y))) => bits(&x[range.clone()], y),
            (Some(P::Vec2(x)), Some(P::Vec2(y))) => bits(&x[range.clone()], y),
            (Some(P::Vec3(x)), Some(P::Vec3(y))) => bits(&x[range.clone()], y),
            (Some(P::U32(x)), Some(P::U32(y))) => x[range.clone()] == *y,
            _ => false,
        })
        && match (&derived, &band.position) {
            (Some(d), Some(p)) => bits(d, p),
            _ => true,
        }
}
