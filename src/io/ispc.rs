//! Reader (and writer) for the input files of the ISPC `examples/cpu/deferred` sample (`.bin`, little-endian), a
//! port of Intel's 2010 tiled-deferred demo. One real G-buffer dump format that carries its own lights.
//!
//! Layout: a 152-byte header — `cameraProj` (4×4 f32, D3D left-handed, row-vector form: `[0][0]` x-scale,
//! `[1][1]` y-scale, `[2][2] = far/(far−near)`, `[2][3] = 1`, `[3][2] = −near·far/(far−near)`), near and far (f32),
//! width, height, numLights and the chunk size (i32), then 16 i32 byte offsets into the chunk that follows, for:
//! zBuffer (f32 post-projection depth, 1 = sky), normal x and y (f16, spheremap-encoded), specular amount and power
//! (f16), albedo r, g, b (unorm8 planes), and per light: view-space position x, y, z, attenuation begin, colour r,
//! g, b, attenuation end (f32 arrays, 1024 slots). Pixel row 0 is at the top.
//!
//! Conversion to our view space (right-handed, looking along −Z): the file's view space is left-handed with +Z
//! forward, so z is negated for positions, normals and light positions. View depth = `P[3][2] / (z − P[2][2])`.
//!
//! Every offset and length is checked against the file size before anything is read or allocated.

use super::{AttributeSource, LoadOptions, Loaded, SourceFormat};
use crate::camera::Camera;
use crate::codec::color::color_codec;
use crate::codec::normal::ispc_spheremap_decode;
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, BandSource, GBuffer};
use crate::light::{Light, LightKind};
use glam::Vec3;
use half::f16;
use std::io::Read;
use std::ops::Range;
use std::path::Path;

/// Size of the file header in bytes.
pub const HEADER_BYTES: usize = 152;
/// Light slots the sample allocates (`MAX_LIGHTS` in its `deferred.h`); files hold this many even when fewer are used.
pub const LIGHT_SLOTS: usize = 1024;
/// Largest width or height we accept in a header (the sample's own inputs are 1920×1080 at most).
pub const MAX_DIMENSION: i32 = 1 << 15;
/// Bytes per pixel of the G-buffer we build (depth, position, normal, albedo, specular, power, coverage), used to
/// check a declared size against the memory limit before allocating.
const GBUFFER_BYTES_PER_PIXEL: u64 = 4 + 12 + 12 + 12 + 4 + 4 + 1;
/// Alignment of the arrays our writer lays out in the chunk (the sample allocates 64-byte aligned memory).
const WRITE_ALIGN: usize = 64;

/// The 16 arrays of the chunk, in header order, with their element size and whether they are per pixel.
const ARRAYS: [(&str, u64, bool); 16] = [
    ("zBuffer", 4, true),
    ("normalEncoded_x", 2, true),
    ("normalEncoded_y", 2, true),
    ("specularAmount", 2, true),
    ("specularPower", 2, true),
    ("albedo_x", 1, true),
    ("albedo_y", 1, true),
    ("albedo_z", 1, true),
    ("lightPositionView_x", 4, false),
    ("lightPositionView_y", 4, false),
    ("lightPositionView_z", 4, false),
    ("lightAttenuationBegin", 4, false),
    ("lightColor_x", 4, false),
    ("lightColor_y", 4, false),
    ("lightColor_z", 4, false),
    ("lightAttenuationEnd", 4, false),
];

/// The decoded header.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// `cameraProj[row][col]`, D3D row-vector form.
    pub proj: [[f32; 4]; 4],
    /// Near plane.
    pub near: f32,
    /// Far plane.
    pub far: f32,
    /// Width in pixels.
    pub width: i32,
    /// Height in pixels.
    pub height: i32,
    /// Lights in use (≤ 1024).
    pub num_lights: i32,
    /// Bytes in the chunk after the header.
    pub chunk_size: i32,
    /// Byte offsets of the 16 arrays inside the chunk.
    pub offsets: [i32; 16],
}

fn f32_at(b: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}
fn i32_at(b: &[u8], i: usize) -> i32 {
    i32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

impl Header {
    /// Parses the first 152 bytes (no validation). `None` when `b` is shorter than the header.
    #[must_use]
    pub fn parse(b: &[u8]) -> Option<Header> {
        if b.len() < HEADER_BYTES {
            return None;
        }
        let mut proj = [[0.0; 4]; 4];
        for (r, row) in proj.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = f32_at(b, (r * 4 + c) * 4);
            }
        }
        let mut offsets = [0; 16];
        for (k, o) in offsets.iter_mut().enumerate() {
            *o = i32_at(b, 88 + 4 * k);
        }
        Some(Header {
            proj,
            near: f32_at(b, 64),
            far: f32_at(b, 68),
            width: i32_at(b, 72),
            height: i32_at(b, 76),
            num_lights: i32_at(b, 80),
            chunk_size: i32_at(b, 84),
            offsets,
        })
    }

    /// Encodes the header.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_BYTES);
        for row in &self.proj {
            for v in row {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        for v in [self.near, self.far] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in [self.width, self.height, self.num_lights, self.chunk_size].iter().chain(&self.offsets) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    /// Checks everything that does not need the file length: sizes, light count, camera, projection. Returns the
    /// first problem as text naming the field (as the sample's `deferred.h` spells it) and its value.
    fn check_fields(&self) -> std::result::Result<(), String> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_DIMENSION).contains(&v) {
                return Err(format!("{name} {v} outside 1..={MAX_DIMENSION}"));
            }
        }
        if !(0..=LIGHT_SLOTS as i32).contains(&self.num_lights) {
            return Err(format!("numLights {} outside 0..={LIGHT_SLOTS}", self.num_lights));
        }
        if self.chunk_size < 0 {
            return Err(format!("chunk size {} is negative", self.chunk_size));
        }
        if !(self.near.is_finite() && self.near > 0.0) {
            return Err(format!("camera near {} (need a finite near > 0)", self.near));
        }
        if !(self.far.is_finite() && self.far > self.near) {
            return Err(format!("camera far {} (need a finite far > near = {})", self.far, self.near));
        }
        let p = &self.proj;
        for (r, row) in p.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                if !v.is_finite() {
                    return Err(format!("cameraProj[{r}][{c}] = {v} is not finite"));
                }
            }
        }
        let bad = |r: usize, c: usize, need: &str| Err(format!("cameraProj[{r}][{c}] = {} (need {need})", p[r][c]));
        if p[0][0] <= 0.0 {
            return bad(0, 0, "an x scale > 0");
        }
        if p[1][1] <= 0.0 {
            return bad(1, 1, "a y scale > 0");
        }
        if p[2][3] != 1.0 {
            return bad(2, 3, "1, a D3D perspective projection");
        }
        if p[3][2] == 0.0 {
            return bad(3, 2, "−near·far/(far − near) ≠ 0");
        }
        Ok(())
    }

    /// Checks every array's byte range against the chunk size; the problem names the array, its offset field and
    /// the value.
    fn check_arrays(&self) -> std::result::Result<(), String> {
        let pixels = self.width as u64 * self.height as u64;
        for (k, &(name, elem, per_pixel)) in ARRAYS.iter().enumerate() {
            let off = self.offsets[k];
            let count = if per_pixel { pixels } else { self.num_lights as u64 };
            let Ok(o) = u64::try_from(off) else {
                return Err(format!("offset of array {name} (offsets[{k}]) {off} is negative"));
            };
            if o + count * elem > self.chunk_size as u64 {
                return Err(format!(
                    "offset of array {name} (offsets[{k}]) {off}: {count} × {elem} bytes from there end at byte {} \
                     of the chunk, past its declared size {}",
                    o + count * elem,
                    self.chunk_size
                ));
            }
        }
        // The arrays may not alias: a file must hold every array it declares (else a small file with every
        // offset at 0 would decode to a G-buffer many times its size).
        let mut spans: Vec<(u64, u64, usize)> = ARRAYS
            .iter()
            .enumerate()
            .map(|(k, &(_, elem, per_pixel))| {
                let o = self.offsets[k] as u64;
                (o, o + elem * if per_pixel { pixels } else { self.num_lights as u64 }, k)
            })
            .filter(|&(start, end, _)| end > start)
            .collect();
        spans.sort_unstable();
        for pair in spans.windows(2) {
            let ((_, a_end, a), (b_start, _, b)) = (pair[0], pair[1]);
            if b_start < a_end {
                return Err(format!(
                    "array {} (offsets[{b}] = {b_start}) starts inside array {} (offsets[{a}], which ends at byte \
                     {a_end}): arrays may not overlap",
                    ARRAYS[b].0, ARRAYS[a].0
                ));
            }
        }
        Ok(())
    }

    /// The camera the projection describes (view space = the file's, converted to right-handed: identity
    /// world→view, since the file has no world space).
    #[must_use]
    pub fn camera(&self) -> Camera {
        let p = &self.proj;
        Camera::identity(2.0 * (1.0 / p[1][1]).atan(), p[1][1] / p[0][0], self.near, self.far)
    }
}

/// Is this (by its first bytes and length) an ISPC `deferred` input file? The format has no magic number; what
/// every such file has is a D3D perspective projection, whose `cameraProj[2][3]` is exactly 1.0 (the bytes
/// `00 00 80 3f` at offset 44), and at least the 152-byte header. That is all this checks — loosely, on purpose:
/// a file that looks like a `.bin` header goes to [`read`], which refuses a bad field by its name and value
/// (`width 100000 outside 1..=32768`) instead of calling the file unrecognisable.
#[must_use]
pub fn matches_file(head: &[u8], file_len: u64) -> bool {
    let Some(h) = Header::parse(head) else { return false };
    file_len >= HEADER_BYTES as u64 && h.proj[2][3].to_bits() == 1.0f32.to_bits()
}

/// Why `head` is not a valid ISPC `.bin` header (for the error of a file no reader recognised): the first bad
/// field with its value, or the missing header.
#[must_use]
pub fn header_problem(head: &[u8], file_len: u64) -> String {
    match Header::parse(head) {
        None => format!("{file_len} bytes, shorter than the {HEADER_BYTES}-byte header"),
        Some(h) => match h.check_fields().and_then(|()| h.check_arrays()) {
            Err(w) => w,
            Ok(()) => "no problem with the header".into(),
        },
    }
}

/// Reads an ISPC `deferred` input file into a single-sample G-buffer with its lights. Only the header and the
/// declared chunk are read, after the chunk size has been checked against the file length and the memory limit.
pub fn read(path: &Path, opts: &LoadOptions) -> Result<Loaded> {
    let arrays = Arrays::read(path, opts)?;
    decode(&arrays.header, arrays.chunk(), path)
}

/// Decodes an ISPC `deferred` input file held in memory (`path` only names it in errors). Same checks as
/// [`read`]; bytes past the declared chunk are ignored.
pub fn read_bytes(bytes: &[u8], path: &Path, opts: &LoadOptions) -> Result<Loaded> {
    let h = check_header(bytes, bytes.len() as u64, path, opts)?;
    let chunk = &bytes[HEADER_BYTES..HEADER_BYTES + h.chunk_size as usize];
    decode(&h, chunk, path)
}

/// Parses and validates the header against the file length and the memory limit.
fn check_header(head: &[u8], file_len: u64, path: &Path, opts: &LoadOptions) -> Result<Header> {
    let invalid = |what: String| Error::invalid(path, format!("ISPC deferred .bin: {what}"));
    let Some(h) = Header::parse(head) else {
        return Err(invalid(format!("file is {file_len} bytes, shorter than the {HEADER_BYTES}-byte header")));
    };
    h.check_fields().map_err(|w| invalid(format!("header: {w}")))?;
    let need = h.width as u64 * h.height as u64 * GBUFFER_BYTES_PER_PIXEL;
    if need > opts.limits.max_bytes || h.chunk_size as u64 > opts.limits.max_bytes {
        return Err(Error::TooLarge {
            path: path.into(),
            bytes: need.max(h.chunk_size as u64),
            limit: opts.limits.max_bytes,
            why: opts.limits.describe(),
        });
    }
    if HEADER_BYTES as u64 + h.chunk_size as u64 > file_len {
        return Err(invalid(format!(
            "truncated: the header declares a {}-byte chunk but only {} bytes follow it",
            h.chunk_size,
            file_len - HEADER_BYTES as u64
        )));
    }
    h.check_arrays().map_err(invalid)?;
    Ok(h)
}

/// An ISPC `.bin` held in memory as the file's own arrays (15 bytes a pixel), its header checked: a
/// [`BandSource`] that a packed frame over it (`layout::PackedFrame::of_source`) decodes a band of rows at a time
/// inside the resolve and the edge pass, as the example's own shading loop reads the file, instead of converting the frame into planes first
/// (49 bytes a pixel). A band's planes are [`read`]'s for those rows after [`crate::io::load`]'s sanitising, bit
/// for bit: both run the same conversion (`Arrays::checks` counts what the load's checks would).
#[derive(Debug)]
pub struct Arrays {
    header: Header,
    /// The header's bytes and the chunk's.
    bytes: Bytes,
    /// What the bands decoded so far with every surveyed plane found: the load's checks from the bands the resolve
    /// decodes anyway ([`Arrays::checks`]).
    tally: Tally,
}

/// The checks' counts of the bands decoded so far, by rows.
#[derive(Default)]
struct Tally(std::sync::Mutex<Vec<(Range<u32>, BandSurvey)>>);

impl Tally {
    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<(Range<u32>, BandSurvey)>> {
        // A band's counts are pushed whole: a panic elsewhere leaves the list consistent.
        self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl std::fmt::Debug for Tally {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Tally({} bands)", self.lock().len())
    }
}

/// A file's bytes: mapped (no copy, no page faults of a fresh buffer), or read when the file cannot be mapped.
#[derive(Debug)]
enum Bytes {
    Mapped(memmap2::Mmap),
    Read(Vec<u8>),
}

impl std::ops::Deref for Bytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        match self {
            Bytes::Mapped(m) => m,
            Bytes::Read(v) => v,
        }
    }
}

/// The planes the survey decodes: what the load's sanitising and checks can find anything in.
const SURVEYED: [Attribute; 5] =
    [Attribute::Depth, Attribute::Position, Attribute::Normal, Attribute::Specular, Attribute::SpecularPower];

/// One band's part of the load's checks: NaN and ±Inf replaced, the plausibility checks' counts.
type BandSurvey = (Vec<(&'static str, u64, u64)>, crate::io::plausible::Survey);

/// What the load's checks count on a whole decoded frame ([`Arrays::checks`]).
pub(crate) struct Checks {
    /// NaN and ±Inf replaced, per plane (as [`crate::io::load`]'s sanitising reports them).
    pub sanitized: Vec<(&'static str, u64, u64)>,
    /// The plausibility checks' counts.
    pub checks: crate::io::plausible::Survey,
}

impl Arrays {
    /// Reads and checks the file (the header against the file length and the memory limit, every array's byte
    /// range): the same checks and errors as [`read`], without decoding. The bytes are read into memory; see
    /// [`Arrays::map`] for a map of the file instead.
    pub fn read(path: &Path, opts: &LoadOptions) -> Result<Arrays> {
        Arrays::open(path, opts, false)
    }

    /// [`Arrays::read`] with the file memory-mapped instead of read (no copy, no page faults of a fresh buffer: a
    /// few milliseconds of a 720p frame's whole run); read as [`Arrays::read`] does when it cannot be mapped.
    ///
    /// # Safety
    /// No other process may change or truncate the file while the returned `Arrays` (or anything borrowing it)
    /// lives: the values read would change under gbuf, or the process would get SIGBUS. The caller signs for that,
    /// as every tool that maps its input does (docs/DECISIONS.md, "Mapping a .bin").
    pub unsafe fn map(path: &Path, opts: &LoadOptions) -> Result<Arrays> {
        Arrays::open(path, opts, true)
    }

    /// [`Arrays::read`], or [`Arrays::map`] when `map` (whose caller has signed its contract).
    fn open(path: &Path, opts: &LoadOptions, map: bool) -> Result<Arrays> {
        let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let file_len = file.metadata().map_err(|e| Error::io(path, e))?.len();
        let mut head = Vec::with_capacity(HEADER_BYTES);
        let mut reader = std::io::BufReader::new(&file);
        (&mut reader).take(HEADER_BYTES as u64).read_to_end(&mut head).map_err(|e| Error::io(path, e))?;
        let header = check_header(&head, file_len, path, opts)?;
        let want = HEADER_BYTES + header.chunk_size as usize;
        if map {
            // SAFETY: the map is read-only and its length was checked against the file's (`check_header`); every
            // read of it is a bounds-checked slice of that length. The caller of `Arrays::map` has promised that
            // no other process changes or truncates the file while it is mapped.
            let mapped = unsafe { memmap2::MmapOptions::new().len(want).populate().map(&file) };
            if let Ok(m) = mapped {
                return Ok(Arrays { header, bytes: Bytes::Mapped(m), tally: Tally::default() });
            }
        }
        let mut bytes = head;
        bytes.reserve_exact(want - bytes.len());
        // Read into the reserved capacity (no zero fill first); the header check bounded the size by the file's
        // length.
        (&mut reader).take(header.chunk_size as u64).read_to_end(&mut bytes).map_err(|e| Error::io(path, e))?;
        if bytes.len() != want {
            return Err(Error::invalid(
                path,
                format!(
                    "ISPC deferred .bin: the chunk declares {} bytes, the file holds {}",
                    header.chunk_size,
                    bytes.len()
                ),
            ));
        }
        Ok(Arrays { header, bytes: Bytes::Read(bytes), tally: Tally::default() })
    }

    /// The decoded header.
    #[must_use]
    pub fn header(&self) -> &Header {
        &self.header
    }

    fn chunk(&self) -> &[u8] {
        &self.bytes[HEADER_BYTES..]
    }

    /// The file's lights, in our view space (`path` names the file in errors).
    pub fn lights(&self, path: &Path) -> Result<Vec<Light>> {
        lights(&self.header, self.chunk(), path)
    }

    /// The frame without planes (its size, camera and coverage) and how many pixels have a depth with no surface
    /// in front of the camera (besides the cleared `z = 1`): one pass over the depth array, bands in parallel.
    pub(crate) fn coverage(&self) -> Result<(GBuffer, u64)> {
        use rayon::prelude::*;
        let h = &self.header;
        let mut like = GBuffer::new(h.width as u32, h.height as u32, 1)?;
        like.camera = Some(h.camera());
        let band_px = h.width as usize * BAND_ROWS;
        let out_of_range = like
            .coverage
            .par_chunks_mut(band_px)
            .enumerate()
            .map_init(GBuffer::default, |band, (k, coverage)| {
                let y0 = (k * BAND_ROWS) as u32;
                let rows = y0..y0 + (coverage.len() / h.width as usize) as u32;
                let out_of_range = self.decode_band(rows, band, Some(&[]));
                coverage.copy_from_slice(&band.coverage);
                out_of_range
            })
            .sum();
        Ok((like, out_of_range))
    }

    /// What the load's sanitising and plausibility checks count on the whole decoded frame, from the bands
    /// decoded since the file was opened with every surveyed plane (the resolve's): only rows no such band covered
    /// are decoded now, so after a resolve this costs nothing, before it one pass. Each band counts once however
    /// often it was decoded.
    pub(crate) fn checks(&self) -> Checks {
        use rayon::prelude::*;
        let mut seen = std::mem::take(&mut *self.tally.lock());
        seen.sort_by_key(|(r, _)| (r.start, r.end));
        // Bands in row order that do not overlap the ones taken before them; the rows between are missing.
        let (mut next, mut parts, mut missing) = (0, Vec::new(), Vec::new());
        for (rows, counts) in seen {
            if rows.start < next {
                continue;
            }
            missing.extend((next..rows.start).step_by(BAND_ROWS).map(|y| y..(y + BAND_ROWS as u32).min(rows.start)));
            next = rows.end;
            parts.push(counts);
        }
        let height = self.header.height as u32;
        missing.extend((next..height).step_by(BAND_ROWS).map(|y| y..(y + BAND_ROWS as u32).min(height)));
        let filled: Vec<BandSurvey> = missing
            .into_par_iter()
            .map_init(GBuffer::default, |band, rows| {
                let mut tally = RowCounts::default();
                self.decode_band_tallied(rows, band, Some(&SURVEYED), Some(&mut tally));
                tally.survey(band.len() as u64)
            })
            .collect();
        let mut out = Checks { sanitized: Vec::new(), checks: crate::io::plausible::Survey::default() };
        for (sanitized, checks) in parts.into_iter().chain(filled) {
            out.checks = out.checks.add(checks);
            for (plane, nan, inf) in sanitized {
                match out.sanitized.iter_mut().find(|s| s.0 == plane) {
                    Some(s) => (s.1, s.2) = (s.1 + nan, s.2 + inf),
                    None => out.sanitized.push((plane, nan, inf)),
                }
            }
        }
        // In the canonical attribute order, as the whole frame's sanitising lists them.
        out.sanitized.sort_by_key(|s| Attribute::ALL.iter().position(|a| a.name() == s.0));
        out
    }

    /// Rows `rows` into `out` (a G-buffer of `width × rows` pixels, its planes reused): the planes of `only`
    /// (`None`: all) as [`read`] converts them, not yet sanitised. Returns the pixels whose depth is out of range.
    fn decode_band(&self, rows: Range<u32>, out: &mut GBuffer, only: Option<&[Attribute]>) -> u64 {
        self.decode_band_tallied(rows, out, only, None)
    }

    /// [`Arrays::decode_band`], and when `tally` is given (every [`SURVEYED`] plane decoded) the load's sanitising
    /// and checks done on each row as it is converted: the band comes out sanitised, as `io::sanitize` leaves it.
    fn decode_band_tallied(
        &self,
        rows: Range<u32>,
        out: &mut GBuffer,
        only: Option<&[Attribute]>,
        tally: Option<&mut RowCounts>,
    ) -> u64 {
        let h = &self.header;
        let (w, n) = (h.width as u32, h.width as usize * rows.len());
        (out.width, out.height, out.samples) = (w, rows.end - rows.start, 1);
        if out.sample_positions.len() != 1 {
            out.sample_positions = vec![glam::Vec2::ZERO];
        }
        out.camera = Some(h.camera());
        out.coverage.clear();
        out.coverage.resize(n, false);
        let want = |a: Attribute| only.is_none_or(|o| o.contains(&a));
        fn plane<T: Copy>(p: &mut Option<Vec<T>>, want: bool, n: usize, zero: T) -> Option<&mut [T]> {
            if !want {
                *p = None;
                return None;
            }
            let v = p.get_or_insert_with(Vec::new);
            v.resize(n, zero);
            Some(v)
        }
        let geometry = want(Attribute::Depth) || want(Attribute::Position);
        let planes = Planes {
            y0: rows.start as usize,
            coverage: &mut out.coverage,
            depth: plane(&mut out.depth, geometry, n, 0.0),
            position: plane(&mut out.position, geometry, n, Vec3::ZERO),
            normal: plane(&mut out.normal, want(Attribute::Normal), n, Vec3::ZERO),
            albedo: plane(&mut out.albedo, want(Attribute::Albedo), n, Vec3::ZERO),
            spec: plane(&mut out.specular, want(Attribute::Specular), n, 0.0),
            power: plane(&mut out.specular_power, want(Attribute::SpecularPower), n, 0.0),
        };
        debug_assert!(tally.is_none() || SURVEYED.iter().all(|&a| want(a)), "a tally needs every surveyed plane");
        planes.convert(h, self.chunk(), tally)
    }
}

impl BandSource for Arrays {
    fn describe(&self) -> String {
        "the ISPC .bin's arrays".into()
    }

    fn decode_rows(
        &self,
        _like: &GBuffer,
        rows: Range<u32>,
        out: &mut GBuffer,
        only: Option<&[Attribute]>,
    ) -> Result<()> {
        // What the load does to the whole frame, on the band (NaN and ±Inf replaced), counted with the checks'
        // counts when the band holds every plane they read: the load's checks without a pass of their own, done
        // on each row as it is converted.
        if only.is_none_or(|o| SURVEYED.iter().all(|a| o.contains(a))) {
            let mut tally = RowCounts::default();
            self.decode_band_tallied(rows.clone(), out, only, Some(&mut tally));
            let counts = tally.survey(out.len() as u64);
            // A band decoded again (a frame lit twice) is counted once, and the list stays as long as the frame's
            // bands.
            let mut seen = self.tally.lock();
            if !seen.iter().any(|(r, _)| *r == rows) {
                seen.push((rows, counts));
            }
        } else {
            self.decode_band(rows, out, only);
            crate::io::sanitize::sanitize(out);
        }
        Ok(())
    }
}

/// Sanitises a band decoded with every surveyed plane and returns what the load's checks count on it (albedo is
/// unorm8: never sanitised, never checked).
#[cfg(test)]
fn band_survey(band: &mut GBuffer) -> BandSurvey {
    let sanitized = crate::io::sanitize::sanitize(band);
    let albedo = band.albedo.take();
    let checks = crate::io::plausible::Survey::of(band);
    band.albedo = albedo;
    (sanitized, checks)
}

/// Rows converted per parallel task.
const BAND_ROWS: usize = 16;

/// Rows `y0..` of the G-buffer's planes, converted from the file's arrays by one task: slices of a whole frame's
/// planes or a band's own. A plane that is `None` is not converted.
struct Planes<'a> {
    y0: usize,
    coverage: &'a mut [bool],
    depth: Option<&'a mut [f32]>,
    position: Option<&'a mut [Vec3]>,
    normal: Option<&'a mut [Vec3]>,
    albedo: Option<&'a mut [Vec3]>,
    spec: Option<&'a mut [f32]>,
    power: Option<&'a mut [f32]>,
}

impl Planes<'_> {
    /// Converts the rows' pixels (every sample of every plane written, uncovered ones 0); returns how many have a
    /// depth with no surface in front of the camera. Row by row: coverage and geometry first, then each plane the
    /// caller wants, the half-float arrays converted a row at a time (F16C where the CPU has it). Each loop is
    /// branch-free over its row, compiled for the widest instruction set the CPU has
    /// ([`crate::base::isa::run`]): the same IEEE operations in the same order on every path (no contraction),
    /// so the planes are the same bits everywhere.
    fn convert(self, h: &Header, chunk: &[u8], tally: Option<&mut RowCounts>) -> u64 {
        let mut out_of_range = 0;
        crate::base::isa::run(
            crate::base::isa::Isa::detect(),
            Convert { planes: self, h, chunk, out_of_range: &mut out_of_range, tally },
        );
        out_of_range
    }
}

/// What the load's sanitising pass (`io::sanitize`) and plausibility survey (`io::plausible`) count on a band, the
/// same numbers, counted by [`Planes::convert`] on each row while it is in cache, with the values replaced as it
/// goes (a unit test holds it to the two passes over the decoded band).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct RowCounts {
    /// NaN and ±Inf components replaced in position, normal, specular amount and specular power (depth and
    /// albedo are finite by construction).
    fixed: [(u64, u64); 4],
    covered: u64,
    zero_normal: u64,
    bad_normal: u64,
    away: u64,
    below_near: u64,
}

impl RowCounts {
    /// The normal checks of `io::plausible`'s `count` on one row (normals already sanitised, zero where
    /// uncovered; positions `(x, y, −view)`), with the same operations in the same order.
    #[inline(always)]
    fn count_normals(
        &mut self,
        cov: &[bool],
        [nx, ny, nz]: [&mut Vec<f32>; 3],
        [px, py]: [&Vec<f32>; 2],
        view: &[f32],
    ) {
        // Counted in 32 bits (a row has fewer than 2³² pixels): twice the lanes of 64-bit sums.
        let (mut zero, mut bad, mut away) = (0u32, 0u32, 0u32);
        let normals = nx.iter().zip(ny.iter()).zip(nz.iter());
        let rest = cov.iter().zip(px.iter()).zip(py.iter()).zip(view);
        for (((&x, &y), &z), (((&c, &px), &py), &view)) in normals.zip(rest) {
            // `Vec3::length` and `n.dot(−p)`: −(−view) is view exactly.
            let len = ((x * x + y * y) + z * z).sqrt();
            let [z0, b, a] = crate::io::plausible::normal_flags(len, (x * -px + y * -py) + z * view);
            zero += u32::from(c & z0);
            bad += u32::from(c & b);
            away += u32::from(c & a);
        }
        self.zero_normal += u64::from(zero);
        self.bad_normal += u64::from(bad);
        self.away += u64::from(away);
    }

    /// The band's survey: the sanitising pass's list (canonical order, planes with anything replaced) and the
    /// checks' counts over `samples` samples.
    fn survey(&self, samples: u64) -> BandSurvey {
        let names = ["position", "normal", "specular", "specular_power"];
        let sanitized =
            names.into_iter().zip(self.fixed).filter(|(_, (nan, inf))| nan + inf > 0).map(|(n, (a, b))| (n, a, b));
        let counts = [self.covered, self.zero_normal, self.bad_normal, self.away, self.below_near];
        (sanitized.collect(), crate::io::plausible::Survey::of_counts(samples, counts))
    }
}

/// `io::sanitize`'s fix of `v` (NaN → 0, ±Inf → ±`f32::MAX`), its counts added to `counts`.
#[inline(always)]
fn fix_counted(v: &mut [f32], counts: &mut (u64, u64)) {
    let (nan, inf) = crate::io::sanitize::fix_run(v);
    (counts.0, counts.1) = (counts.0 + nan, counts.1 + inf);
}

/// [`Planes::convert`]'s work, run under [`crate::base::isa::run`].
struct Convert<'a, 'b> {
    planes: Planes<'a>,
    h: &'b Header,
    chunk: &'b [u8],
    out_of_range: &'b mut u64,
    tally: Option<&'b mut RowCounts>,
}

impl crate::base::isa::Kernel for Convert<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run(self, _: crate::base::isa::Isa) {
        use half::slice::{HalfBitsSliceExt, HalfFloatSliceExt};
        let Convert { planes, h, chunk, out_of_range, mut tally } = self;
        let (w, ht) = (h.width as usize, h.height as usize);
        let p = &h.proj;
        let (p22, p32, p00, p11) = (p[2][2], p[3][2], p[0][0], p[1][1]);
        let Planes { y0, coverage, mut depth, mut position, mut normal, mut albedo, mut spec, mut power } = planes;
        let mut bits = vec![0u16; w];
        let mut halves = [vec![0.0f32; w], vec![0.0f32; w]];
        let mut view = vec![0.0f32; w];
        // Rows of x, y, z in structure of arrays: each loop below computes one row's values into them (vectorised),
        // then one loop interleaves them into the plane's `Vec3`s.
        let mut soa = [vec![0.0f32; w], vec![0.0f32; w], vec![0.0f32; w]];
        let mut pxy = [vec![0.0f32; w], vec![0.0f32; w]];
        // The plausibility checks' near plane (`io::plausible`'s).
        let near = h.camera().znear * 0.999;
        // The pixel centres' x in normalised device coordinates, the same for every row.
        let ndc_x: Vec<f32> = (0..w).map(|x| (x as f32 + 0.5) * 2.0 / w as f32 - 1.0).collect();
        // Array `k` (elements of `elem` bytes) over row `y`; the header check bounded every array by the chunk.
        // Functions inlined, not closures: a closure called would be compiled apart, for the baseline.
        #[inline(always)]
        fn array_row<'c>(h: &Header, chunk: &'c [u8], w: usize, k: usize, elem: usize, y: usize) -> &'c [u8] {
            let o = h.offsets[k] as usize + elem * y * w;
            &chunk[o..o + elem * w]
        }
        #[inline(always)]
        fn halves_of(bytes: &[u8], bits: &mut [u16], out: &mut [f32]) {
            // The file's halves are little-endian: on such a CPU a copy of the bytes (the array need not be aligned
            // for `u16`), else swapped one by one.
            if cfg!(target_endian = "little") {
                bytemuck::cast_slice_mut::<u16, u8>(bits).copy_from_slice(bytes);
            } else {
                for (b, v) in bytes.chunks_exact(2).zip(bits.iter_mut()) {
                    *v = u16::from_le_bytes([b[0], b[1]]);
                }
            }
            bits.reinterpret_cast::<f16>().convert_to_f32_slice(out);
        }
        let mut oor = 0u64;
        for r in 0..coverage.len() / w {
            let y = y0 + r;
            let o = r * w;
            let cov = &mut coverage[o..o + w];
            // z = 1 is the cleared depth buffer (sky); anything outside [0, 1), or whose view depth is not finite
            // and positive, has no surface in front of the camera.
            // Counted in 32 bits per row (64-bit sums keep the AVX2 loop scalar).
            let mut row_oor = 0u32;
            for ((c, v), zb) in cov.iter_mut().zip(view.iter_mut()).zip(array_row(h, chunk, w, 0, 4, y).chunks_exact(4))
            {
                let z = f32::from_le_bytes([zb[0], zb[1], zb[2], zb[3]]);
                let view_z = p32 / (z - p22);
                let in_front = (0.0..1.0).contains(&z) & view_z.is_finite() & (view_z > 0.0);
                row_oor += u32::from(!in_front & (z != 1.0));
                *c = in_front;
                *v = if in_front { view_z } else { 0.0 };
            }
            oor += u64::from(row_oor);
            if let Some(t) = tally.as_deref_mut() {
                // Depth is finite by construction (0 where it is not finite and positive): nothing to sanitise.
                t.covered += u64::from(cov.iter().map(|&c| u32::from(c)).sum::<u32>());
                t.below_near += u64::from(cov.iter().zip(&view).map(|(&c, &d)| u32::from(c & (d < near))).sum::<u32>());
            }
            if let (Some(d), Some(pos)) = (depth.as_deref_mut(), position.as_deref_mut()) {
                let sy = -(((y as f32 + 0.5) * 2.0 / ht as f32) - 1.0);
                d[o..o + w].copy_from_slice(&view);
                // An uncovered pixel's view depth is 0: its position comes out 0 too.
                let [px, py] = &mut pxy;
                for (((px, py), &sx), &vz) in px.iter_mut().zip(py.iter_mut()).zip(&ndc_x).zip(&view) {
                    (*px, *py) = (sx * vz / p00, sy * vz / p11);
                }
                if let Some(t) = tally.as_deref_mut() {
                    // z = −view depth is finite; x and y need not be (a projection with a tiny scale).
                    fix_counted(px, &mut t.fixed[0]);
                    fix_counted(py, &mut t.fixed[0]);
                }
                for (((pos, &x), &y), &vz) in pos[o..o + w].iter_mut().zip(px.iter()).zip(py.iter()).zip(&view) {
                    *pos = Vec3::new(x, y, -vz);
                }
            }
            if let Some(n) = normal.as_deref_mut() {
                let [ex, ey] = &mut halves;
                halves_of(array_row(h, chunk, w, 1, 2, y), &mut bits, ex);
                halves_of(array_row(h, chunk, w, 2, 2, y), &mut bits, ey);
                let [nx, ny, nz] = &mut soa;
                for ((((nx, ny), nz), &x), &y) in
                    nx.iter_mut().zip(ny.iter_mut()).zip(nz.iter_mut()).zip(&*ex).zip(&*ey)
                {
                    let v = decode_spheremap(x, y);
                    (*nx, *ny, *nz) = (v.x, v.y, v.z);
                }
                for (((nx, ny), nz), &c) in nx.iter_mut().zip(ny.iter_mut()).zip(nz.iter_mut()).zip(cov.iter()) {
                    (*nx, *ny, *nz) = if c { (*nx, *ny, *nz) } else { (0.0, 0.0, 0.0) };
                }
                if let Some(t) = tally.as_deref_mut() {
                    for v in [&mut *nx, &mut *ny, &mut *nz] {
                        fix_counted(v, &mut t.fixed[1]);
                    }
                    t.count_normals(cov, [nx, ny, nz], [&pxy[0], &pxy[1]], &view);
                }
                let soa_rows = nx.iter().zip(ny.iter()).zip(nz.iter());
                for (n, ((&x, &y), &z)) in n[o..o + w].iter_mut().zip(soa_rows) {
                    *n = Vec3::new(x, y, z);
                }
            }
            for (k, plane) in [(3, spec.as_deref_mut()), (4, power.as_deref_mut())] {
                if let Some(v) = plane {
                    let row = &mut halves[0];
                    halves_of(array_row(h, chunk, w, k, 2, y), &mut bits, row);
                    for (s, &c) in row.iter_mut().zip(cov.iter()) {
                        *s = if c { *s } else { 0.0 };
                    }
                    if let Some(t) = tally.as_deref_mut() {
                        fix_counted(row, &mut t.fixed[k - 1]);
                    }
                    v[o..o + w].copy_from_slice(row);
                }
            }
            if let Some(a) = albedo.as_deref_mut() {
                let (ar, ag, ab) =
                    (array_row(h, chunk, w, 5, 1, y), array_row(h, chunk, w, 6, 1, y), array_row(h, chunk, w, 7, 1, y));
                let unorm8 = unorm8_table();
                for ((((a, &c), &r), &g), &b) in a[o..o + w].iter_mut().zip(cov.iter()).zip(ar).zip(ag).zip(ab) {
                    let v = Vec3::new(unorm8[r as usize], unorm8[g as usize], unorm8[b as usize]);
                    *a = if c { v } else { Vec3::ZERO };
                }
            }
        }
        *out_of_range = oor;
    }
}

/// The file's lights, in our view space (z negated).
fn lights(h: &Header, chunk: &[u8], path: &Path) -> Result<Vec<Light>> {
    let off = |k: usize| h.offsets[k] as usize;
    let mut lights = Vec::with_capacity(h.num_lights as usize);
    for l in 0..h.num_lights as usize {
        let at = |k: usize| f32_at(chunk, off(k) + 4 * l);
        let pos = Vec3::new(at(8), at(9), -at(10));
        let (begin, end) = (at(11), at(15));
        let color = Vec3::new(at(12), at(13), at(14));
        if !(pos.is_finite() && color.is_finite() && begin.is_finite() && end.is_finite() && end > 0.0) {
            return Err(Error::invalid(
                path,
                format!("ISPC deferred .bin: light {l} has a non-finite value or attenuation end {end} ≤ 0"),
            ));
        }
        lights.push(Light { kind: LightKind::Point, position: pos, color, intensity: 1.0, range: end, begin });
    }
    Ok(lights)
}

/// Where each attribute came from; `out_of_range` pixels had a depth with no surface in front of the camera.
pub(crate) fn sources(out_of_range: u64) -> Vec<AttributeSource> {
    let src = |attribute: &'static str, arrays: &[&str], file_type: &str, note: Option<String>| AttributeSource {
        attribute,
        channels: arrays.iter().map(|s| (*s).to_string()).collect(),
        file_type: file_type.into(),
        note,
    };
    let mut depth_note = "view z = P[3][2] / (z − P[2][2]); z = 1 is background".to_string();
    if out_of_range > 0 {
        depth_note.push_str(&format!("; {out_of_range} pixels with z outside [0, 1) treated as background"));
    }
    vec![
        src("depth", &["zBuffer"], "float", Some(depth_note)),
        src(
            "position",
            &[],
            "float",
            Some("derived from zBuffer and cameraProj; z negated (left→right-handed)".into()),
        ),
        src(
            "normal",
            &["normalEncoded_x", "normalEncoded_y"],
            "half",
            Some("spheremap-decoded, renormalised, z negated (left→right-handed)".into()),
        ),
        src("albedo", &["albedo_x", "albedo_y", "albedo_z"], "unorm8", None),
        src("specular", &["specularAmount"], "half", None),
        src("specular_power", &["specularPower"], "half", None),
    ]
}

fn decode(h: &Header, chunk: &[u8], path: &Path) -> Result<Loaded> {
    let (w, ht) = (h.width as u32, h.height as u32);
    let mut gb = GBuffer::new(w, ht, 1)?;
    gb.camera = Some(h.camera());
    let n = gb.len();
    // Zeroed allocations (the OS zeroes pages as the parallel conversion first writes them).
    let zeroed = crate::base::memory::zeroed_vec3;
    let (mut depth, mut position, mut normal) = (vec![0.0; n], zeroed(n), zeroed(n));
    let (mut albedo, mut spec, mut power) = (zeroed(n), vec![0.0; n], vec![0.0; n]);
    // Bands of rows converted in parallel: the conversion is a fixed cost of every run on a `.bin`.
    let band = w as usize * BAND_ROWS;
    let bands: Vec<Planes> = gb
        .coverage
        .chunks_mut(band)
        .zip(depth.chunks_mut(band))
        .zip(position.chunks_mut(band))
        .zip(normal.chunks_mut(band))
        .zip(albedo.chunks_mut(band))
        .zip(spec.chunks_mut(band))
        .zip(power.chunks_mut(band))
        .enumerate()
        .map(|(k, ((((((coverage, depth), position), normal), albedo), spec), power))| Planes {
            y0: k * BAND_ROWS,
            coverage,
            depth: Some(depth),
            position: Some(position),
            normal: Some(normal),
            albedo: Some(albedo),
            spec: Some(spec),
            power: Some(power),
        })
        .collect();
    use rayon::prelude::*;
    let out_of_range: u64 = bands.into_par_iter().map(|b| b.convert(h, chunk, None)).sum();
    gb.depth = Some(depth);
    gb.position = Some(position);
    gb.normal = Some(normal);
    gb.albedo = Some(albedo);
    gb.specular = Some(spec);
    gb.specular_power = Some(power);
    gb.validate()?;
    Ok(Loaded {
        gbuffer: gb,
        format: SourceFormat::IspcBin,
        sources: sources(out_of_range),
        lights: Some(lights(h, chunk, path)?),
        camera_source: super::CameraSource::File,
        compression: None,
        sanitized: Vec::new(),
        warnings: Vec::new(),
        reading: None,
        positions_assumed: false,
    })
}

/// Decodes the sample's spheremap normal with the codec's decoder ([`ispc_spheremap_decode`]: `f = (x−x²)+(y−y²)`,
/// `m = √(4f−1)`, `n = (m(4x−2), m(4y−2), 3−8f)`, in the file's left-handed view space) and returns it in ours (z
/// negated), renormalised. Encodings outside the disc (4f − 1 < 0) clamp to the rim.
#[inline]
#[must_use]
pub fn decode_spheremap(x: f32, y: f32) -> Vec3 {
    let n = ispc_spheremap_decode(glam::Vec2::new(x, y));
    Vec3::new(n.x, n.y, -n.z).normalize_or_zero()
}

/// The unorm8 albedo code → value table, from the `unorm8` colour codec's decoder, built once.
fn unorm8_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let codec = color_codec("unorm8").expect("the built-in unorm8 colour codec");
        std::array::from_fn(|c| codec.decode(c as u64 * 0x1_0101).x)
    })
}

/// Encodes a unit normal in our view space into the sample's spheremap pair (inverse of [`decode_spheremap`]).
/// The one direction it cannot represent, facing straight away from the camera (z = −1), maps to the rim.
#[must_use]
pub fn encode_spheremap(n: Vec3) -> (f32, f32) {
    let d = (8.0 + 8.0 * n.z).max(1e-12).sqrt();
    (n.x / d + 0.5, n.y / d + 0.5)
}

fn align(v: usize) -> usize {
    v.div_ceil(WRITE_ALIGN) * WRITE_ALIGN
}

/// Writes `gb` (1 sample per pixel, with a camera, depth and normal; absent albedo/specular default to 0 and the
/// specular power to 1) and up to 1024 point lights (view space) as an ISPC `deferred` input file, atomically.
/// The camera's world→view transform is ignored: the file is in view space. An off-centre principal point is
/// refused (the format's projection is centred).
pub fn write(path: &Path, gb: &GBuffer, lights: &[Light]) -> Result<()> {
    let arg = |what: &str| Error::Argument(format!("{}: cannot write ISPC .bin: {what}", path.display()));
    gb.validate()?;
    if gb.samples != 1 {
        return Err(arg(&format!("{} samples per pixel (the format has 1)", gb.samples)));
    }
    let cam = gb.camera.as_ref().ok_or_else(|| arg("no camera"))?;
    if cam.principal != glam::Vec2::ZERO {
        // The format's readers (the ISPC example's and ours) rebuild positions from cameraProj[0][0] and [1][1]
        // only: an off-centre camera would come back with every position shifted.
        return Err(arg(&format!(
            "the camera's principal point ({}, {}) is off centre; the format's projection is centred",
            cam.principal.x, cam.principal.y
        )));
    }
    let depth = gb.depth.as_ref().ok_or_else(|| arg("no depth"))?;
    let normal = gb.normal.as_ref().ok_or_else(|| arg("no normal"))?;
    if lights.len() > LIGHT_SLOTS {
        return Err(arg(&format!("{} lights (at most {LIGHT_SLOTS})", lights.len())));
    }
    if let Some(l) = lights.iter().find(|l| !matches!(l.kind, LightKind::Point) || !l.range.is_finite()) {
        return Err(arg(&format!("only point lights with a finite range are representable (found {:?})", l.kind)));
    }
    if gb.width as i32 > MAX_DIMENSION || gb.height as i32 > MAX_DIMENSION {
        return Err(arg("image too large"));
    }
    let (n_near, f_far) = (cam.znear, cam.zfar);
    let t = cam.tan_half_fov();
    let mut proj = [[0.0f32; 4]; 4];
    proj[0][0] = 1.0 / (t * cam.aspect);
    proj[1][1] = 1.0 / t;
    proj[2][2] = f_far / (f_far - n_near);
    proj[2][3] = 1.0;
    proj[3][2] = -n_near * f_far / (f_far - n_near);

    let n = gb.len();
    let mut offsets = [0i32; 16];
    let mut size = 0usize;
    for (k, &(_, elem, per_pixel)) in ARRAYS.iter().enumerate() {
        offsets[k] = i32::try_from(size).map_err(|_| arg("chunk over 2 GiB"))?;
        size = align(size + elem as usize * if per_pixel { n } else { LIGHT_SLOTS });
    }
    let chunk_size = i32::try_from(size).map_err(|_| arg("chunk over 2 GiB"))?;
    let mut chunk = vec![0u8; size];
    let put = |chunk: &mut Vec<u8>, at: usize, bytes: &[u8]| chunk[at..at + bytes.len()].copy_from_slice(bytes);
    let o = |k: usize| offsets[k] as usize;
    for i in 0..n {
        let covered = gb.coverage[i];
        let z = if covered { proj[2][2] + proj[3][2] / depth[i] } else { 1.0 };
        put(&mut chunk, o(0) + 4 * i, &z.to_le_bytes());
        let (ex, ey) = if covered { encode_spheremap(normal[i]) } else { (0.5, 0.5) };
        let spec = gb.specular.as_ref().map_or(0.0, |v| v[i]);
        let power = gb.specular_power.as_ref().map_or(1.0, |v| v[i]);
        for (k, v) in [(1, ex), (2, ey), (3, spec), (4, power)] {
            put(&mut chunk, o(k) + 2 * i, &f16::from_f32(if covered { v } else { 0.0 }).to_bits().to_le_bytes());
        }
        let a = gb.albedo.as_ref().map_or(Vec3::ZERO, |v| v[i]);
        for (k, c) in [(5, a.x), (6, a.y), (7, a.z)] {
            chunk[o(k) + i] = if covered { (c.clamp(0.0, 1.0) * 255.0).round() as u8 } else { 0 };
        }
    }
    for (l, light) in lights.iter().enumerate() {
        let vals = [light.position.x, light.position.y, -light.position.z, light.begin, light.color.x, light.color.y];
        for (k, v) in vals.into_iter().enumerate() {
            put(&mut chunk, o(8 + k) + 4 * l, &v.to_le_bytes());
        }
        put(&mut chunk, o(14) + 4 * l, &light.color.z.to_le_bytes());
        put(&mut chunk, o(15) + 4 * l, &light.range.to_le_bytes());
    }
    let header = Header {
        proj,
        near: n_near,
        far: f_far,
        width: gb.width as i32,
        height: gb.height as i32,
        num_lights: lights.len() as i32,
        chunk_size,
        offsets,
    };
    let mut bytes = header.to_bytes();
    bytes.extend_from_slice(&chunk);
    crate::base::files::write_bytes_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The load's sanitising and checks counted row by row as the band is converted ([`RowCounts`]) equal the passes
    /// over the decoded band ([`band_survey`]), counts and replaced values alike, on a room whose arrays are
    /// spoiled with NaN and ±Inf halves, depths outside [0, 1) and normal pairs that decode to nothing, for every
    /// band height and instruction set the CPU has.
    #[test]
    fn counting_while_converting_equals_the_passes_over_the_band() {
        let gb = crate::scene::render(crate::scene::SceneName::Room, 71, 37, 1).unwrap();
        let lights = crate::resolve::fixture::lights_on_surfaces(&gb, 10, 3.0, 7);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("spoiled.bin");
        write(&path, &gb, &lights).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        let h = Header::parse(&bytes).unwrap();
        let at = |k: usize, elem: usize, i: usize| HEADER_BYTES + h.offsets[k] as usize + elem * i;
        for i in (0..gb.len()).filter(|&i| gb.coverage[i]) {
            for (k, m, v) in [
                (3, 11, f16::NAN),
                (4, 13, f16::INFINITY),
                (4, 17, f16::NEG_INFINITY),
                (1, 19, f16::NAN),
                (2, 37, f16::INFINITY),
                (1, 41, f16::from_f32(0.5)),
            ] {
                if i % m == 0 {
                    bytes[at(k, 2, i)..at(k, 2, i) + 2].copy_from_slice(&v.to_bits().to_le_bytes());
                }
            }
            for (m, z) in [(23, 2.0f32), (29, -0.5), (31, f32::NAN)] {
                if i % m == 0 {
                    bytes[at(0, 4, i)..at(0, 4, i) + 4].copy_from_slice(&z.to_le_bytes());
                }
            }
        }
        std::fs::write(&path, &bytes).unwrap();
        let arrays = Arrays::read(&path, &LoadOptions::default()).unwrap();
        let mut fixed = 0;
        for band_rows in [1u32, 5, 16, 37] {
            for y in (0..37).step_by(band_rows as usize) {
                let rows = y..(y + band_rows).min(37);
                let (mut a, mut b) = (GBuffer::default(), GBuffer::default());
                arrays.decode_band(rows.clone(), &mut a, Some(&SURVEYED));
                let want = band_survey(&mut a);
                let mut tally = RowCounts::default();
                arrays.decode_band_tallied(rows.clone(), &mut b, Some(&SURVEYED), Some(&mut tally));
                let got = tally.survey(b.len() as u64);
                assert_eq!(got, want, "rows {rows:?}");
                assert_eq!(a, b, "rows {rows:?}: the band's planes");
                fixed += want.0.iter().map(|s| s.1 + s.2).sum::<u64>();
            }
        }
        assert!(fixed > 100, "the spoiled values were found: {fixed}");
    }

    /// f16 carries 11 significant bits; a spheremap pair decoded from f16 is within this of the unit normal.
    const F16_NORMAL_TOL: f32 = 4e-3;

    #[test]
    fn the_codecs_decode_the_file_as_the_format_defines_it() {
        // Albedo: every unorm8 code is c / 255 in f32 (what the sample's `c / 255.f` gives), through the codec.
        for c in 0..=255u8 {
            assert_eq!(unorm8_table()[c as usize].to_bits(), (f32::from(c) / 255.0).to_bits(), "code {c}");
        }
        // Normal: the sample's formula, z negated, on a grid of encodings and at the centre and rim.
        for i in 0..=64 {
            for j in 0..=64 {
                let (x, y) = (i as f32 / 64.0, j as f32 / 64.0);
                let f = (x - x * x) + (y - y * y);
                let m = (4.0 * f - 1.0).max(0.0).sqrt();
                let want = Vec3::new(m * (4.0 * x - 2.0), m * (4.0 * y - 2.0), -(3.0 - 8.0 * f)).normalize_or_zero();
                assert_eq!(decode_spheremap(x, y), want, "({x}, {y})");
            }
        }
    }

    #[test]
    fn spheremap_round_trips_over_the_front_hemisphere() {
        for i in 0..40 {
            for j in 0..80 {
                let theta = (i as f32 + 0.5) / 40.0 * 1.5; // up to ~86° from +Z
                let phi = j as f32 / 80.0 * std::f32::consts::TAU;
                let n = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                let (x, y) = encode_spheremap(n);
                let back = decode_spheremap(x, y);
                assert!((back - n).length() < 1e-5, "{n} -> ({x}, {y}) -> {back}");
                let (hx, hy) = (f16::from_f32(x).to_f32(), f16::from_f32(y).to_f32());
                assert!((decode_spheremap(hx, hy) - n).length() < F16_NORMAL_TOL);
            }
        }
        // The centre of the map is the normal facing the camera.
        assert_eq!(decode_spheremap(0.5, 0.5), Vec3::Z);
    }

    #[test]
    fn header_round_trips_and_camera_matches_projection() {
        let cam = Camera::identity(0.9, 1.5, 0.5, 80.0);
        let mut gb = GBuffer::new(4, 3, 1).unwrap();
        gb.camera = Some(cam);
        gb.depth = Some(vec![0.0; 12]);
        gb.normal = Some(vec![Vec3::Z; 12]);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("h.bin");
        write(&p, &gb, &[]).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let h = Header::parse(&bytes).unwrap();
        assert_eq!(Header::parse(&h.to_bytes()).unwrap(), h);
        assert!(matches_file(&bytes[..HEADER_BYTES], bytes.len() as u64));
        let c = h.camera();
        assert!((c.yfov - 0.9).abs() < 1e-6 && (c.aspect - 1.5).abs() < 1e-6);
        assert_eq!((c.znear, c.zfar), (0.5, 80.0));
        // Post-projection depth from the matrix agrees with the camera's D3D depth.
        let d = 7.0;
        let z = h.proj[2][2] + h.proj[3][2] / d;
        assert!((z - cam.post_projection_depth(d)).abs() < 1e-6);
        assert!(!matches_file(&bytes[..100], bytes.len() as u64));
    }
}
