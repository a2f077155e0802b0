//! Loading G-buffer dumps (canonical EXR, Blender multilayer EXR, Mitsuba AOV EXR, ISPC `deferred` `.bin`, file
//! sets of one image per buffer) and writing our canonical EXR. Conversions to the crate's view-space convention happen here and nowhere else.

pub mod blender;
pub(crate) mod camera_fit;
pub mod canonical;
pub mod conventions;
pub mod exr;
mod exr_write;
pub mod fileset;
pub mod fold;
pub mod ispc;
pub mod mapped;
pub mod mitsuba;
pub mod plausible;
pub mod raw;
pub mod rdc;
pub(crate) mod sanitize;
pub mod sidecar;
pub mod stats;

use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer};
use crate::light::Light;
use std::path::{Path, PathBuf};

pub use self::exr::{RawImage, ReadLimits};
pub use self::sidecar::Sidecar;

/// Which reader produced a G-buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SourceFormat {
    /// Our canonical EXR (docs/FORMAT.md).
    Canonical,
    /// Blender Cycles multilayer EXR.
    Blender,
    /// Mitsuba 3 `aov` integrator EXR.
    Mitsuba,
    /// ISPC `examples/cpu/deferred` input `.bin`.
    IspcBin,
    /// Generic EXR mapped with `--map`.
    Mapped,
    /// A file set: one image per buffer (a directory, or files named with `--map attr=FILE`).
    FileSet,
    /// The render targets of a layout (DDS, PNG, EXR or `.bin` per target), decoded by the layout
    /// (`layout::targets`).
    PackedTargets,
}

/// How to load a dump.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Sidecar path; when `None`, the JSON found beside the dump (`<file stem>.json`, a file set's `scene.json` or
    /// only JSON) is used when it is a gbuf sidecar, and ignored with a warning when it is not.
    pub sidecar: Option<PathBuf>,
    /// Use no sidecar at all, not even one found beside the dump (`--no-scene`).
    pub no_sidecar: bool,
    /// The layout the input's packed render targets were written with, a built-in name or a layout file
    /// (`--input-layout`); [`crate::load`] reads them through it ([`load`] reads dumps only and refuses it).
    /// `None`: a folder's `layout.toml`, if it has one.
    pub input_layout: Option<String>,
    /// Packed targets' files when they are not `<target>.<ext>` in the folder (`--target NAME=FILE`; also
    /// `coverage` and `material_table`), for [`crate::load`].
    pub targets: Vec<(String, PathBuf)>,
    /// For a RenderDoc capture (`.rdc`, read through its layout by [`crate::load`]): which action's targets.
    pub capture: rdc::Selection,
    /// Fold k×k pixel blocks into k² samples (overrides the sidecar's `supersample`).
    pub fold: Option<u32>,
    /// Explicit attribute → channel mapping (`--map attr=channel,…`); channels are comma-free names.
    pub map: Vec<(Attribute, Vec<String>)>,
    /// Attributes read from other files (`--map attr=FILE[:CHANNEL;…]`): attribute, file (relative to the dump's
    /// directory), channels (empty: the default).
    pub files: Vec<(Attribute, PathBuf, Vec<String>)>,
    /// File-set preset (`--preset`); detected from the file names when `None`.
    pub preset: Option<String>,
    /// Declared conventions (`--space`, `--depth`, `--ids`, `--background`, …) for data read by naming.
    pub conventions: conventions::Overrides,
    /// Header limits.
    pub limits: ReadLimits,
    /// A RenderDoc "slices as grid" mosaic (`--grid CxR`): tile s of the image is sample s ([`fold::ungrid`]).
    pub grid: Option<(u32, u32)>,
    /// For a file-set folder holding a sequence (`Depth0001.exr`, `Depth0002.exr`, …): the frame to read
    /// (`--frame`); `None` when the folder holds one frame.
    pub frame: Option<u32>,
}

/// Where one attribute came from.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AttributeSource {
    /// The attribute.
    pub attribute: &'static str,
    /// The file's channel names it was read from (empty when derived).
    pub channels: Vec<String>,
    /// Storage type in the file ("half", "float", "uint", "unorm8", ...).
    pub file_type: String,
    /// Conversion applied, if any (e.g. "world→view", "derived from depth and camera").
    pub note: Option<String>,
}

crate::named_enum! {
    /// Where a loaded G-buffer's camera came from (`gbuf info` prints it; JSON `camera.source`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum CameraSource: "camera source" {
        /// Stored in the dump itself (canonical header, ISPC projection).
        File => "file",
        /// The sidecar's camera.
        Sidecar => "sidecar",
        /// Fitted to the dump's position pass (least squares over pixel rays).
        Fit => "fit",
        /// No camera: the dump has none and none could be recovered.
        Unknown => "unknown",
    }
}

impl PartialEq<&str> for CameraSource {
    fn eq(&self, other: &&str) -> bool {
        self.name() == *other
    }
}

/// A loaded dump: the G-buffer plus what came with it.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The G-buffer (validated).
    pub gbuffer: GBuffer,
    /// Which reader.
    pub format: SourceFormat,
    /// Per-attribute provenance.
    pub sources: Vec<AttributeSource>,
    /// Lights from the sidecar or the dump itself (ISPC), in view space; `None` when the dump has none.
    pub lights: Option<Vec<Light>>,
    /// Where the camera came from.
    pub camera_source: CameraSource,
    /// Compression of the file and whether it is lossy.
    pub compression: Option<(String, bool)>,
    /// NaN / Inf values found (and replaced by finite values) per attribute: (attribute, nan, inf).
    pub sanitized: Vec<(&'static str, u64, u64)>,
    /// Plausibility findings ([`plausible::check`]), with the numbers.
    pub warnings: Vec<plausible::Warning>,
    /// For data read by naming (file sets, `--map`): the preset and conventions used.
    pub reading: Option<fileset::Reading>,
    /// True when the dump has several samples per pixel but no sample positions: the standard pattern was assumed.
    pub positions_assumed: bool,
}

/// Loads a dump from `path`, whatever its format: resolves the sidecar, detects the format by content, reads,
/// folds (`opts.fold`, else the sidecar's `supersample`), attaches the sidecar's camera and lights, replaces NaN/±Inf
/// by finite values (counted in [`Loaded::sanitized`]) and validates the result.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Loaded> {
    crate::base::files::protect_input(path);
    if opts.input_layout.is_some() || !opts.targets.is_empty() {
        return Err(Error::Argument(
            "packed render targets (an input layout or target files) are read by gbuf::load, which decodes them \
             through their layout; io::load reads dumps"
                .into(),
        ));
    }
    let (side, ignored) = resolve_sidecar(path, opts)?;
    // Nothing the reader frees is kept for reuse: it would stay resident while the planes grow.
    crate::base::alloc::uncached(|| with_warning(load_with(path, opts, side), ignored))
}

/// `loaded` with the warning about an ignored JSON first among its warnings.
fn with_warning(loaded: Result<Loaded>, ignored: Option<plausible::Warning>) -> Result<Loaded> {
    let mut loaded = loaded?;
    if let Some(w) = ignored {
        loaded.warnings.insert(0, w);
    }
    Ok(loaded)
}

/// [`load`] with the sidecar resolved.
fn load_with(path: &Path, opts: &LoadOptions, side: Side) -> Result<Loaded> {
    if path.is_dir() || !opts.files.is_empty() {
        let camera = side.as_ref().and_then(|(s, _)| s.camera.as_ref());
        let loaded = fileset::read(path, camera, opts)?;
        return finish(loaded, path, side.as_ref().map(|(s, p)| (s, p.as_path())), opts);
    }
    let (head, len) = read_head(path)?;
    if head.starts_with(b"RDOC") {
        return Err(Error::invalid(
            path,
            "a RenderDoc capture is read through the layout its render targets were written with: give it with \
             --input-layout NAME|PATH (`gbuf info FILE.rdc --list` shows the actions and their bound targets)",
        ));
    }
    if head.starts_with(&PNG_MAGIC) {
        return Err(Error::invalid(
            path,
            "a PNG on its own is not a dump: give the directory of the file set it belongs to (LuxCore, Unreal, Unity, \
             Blender File Output presets), or name each buffer's file with --map attr=FILE[:CHANNEL;…]",
        ));
    }
    // EXR first: it has a magic number; the `.bin` check is loose (see `ispc::matches_file`).
    let loaded = if head.starts_with(&EXR_MAGIC) {
        let raw = exr::read_raw(path, &opts.limits)?;
        read_exr(raw, path, side.as_ref().map(|s| &s.0), opts)?
    } else if ispc::matches_file(&head, len) {
        ispc::read(path, opts)?
    } else {
        return Err(not_a_dump(path, &head, len));
    };
    finish(loaded, path, side.as_ref().map(|(s, p)| (s, p.as_path())), opts)
}

/// A dump loaded as its own arrays, not decoded into planes ([`open_packed`]): what [`load`] reports of it, and
/// the arrays its bands are decoded from inside the resolve and the edge pass (`layout::PackedFrame::of_source`
/// over `loaded.gbuffer` and `arrays`).
///
/// The load's sanitising counts and plausibility checks are counted on the bands the resolve decodes anyway:
/// they are in `loaded` once [`PackedDump::check`] has run (after lighting it costs nothing; before, one pass over
/// the file).
#[derive(Debug)]
pub struct PackedDump {
    /// What [`load`] returns (lights, sources, and after [`PackedDump::check`] the sanitising counts and
    /// warnings), but its G-buffer has no planes: its size, camera, sample positions and coverage only.
    pub loaded: Loaded,
    /// The file's arrays: every band's planes are [`load`]'s for those rows, bit for bit.
    pub arrays: ispc::Arrays,
    /// The file, for the checks' messages.
    path: PathBuf,
    /// Whether [`PackedDump::check`] has filled `loaded`'s counts and warnings.
    checked: bool,
}

impl PackedDump {
    /// The whole frame decoded into planes: [`load`]'s G-buffer (for what reads every plane at once, such as the
    /// every-sample reference).
    pub fn decode(&self, path: &Path) -> Result<GBuffer> {
        use crate::gbuffer::BandSource;
        let like = &self.loaded.gbuffer;
        let mut gb = GBuffer::default();
        self.arrays.decode_rows(like, 0..like.height, &mut gb, None)?;
        gb.materials.clone_from(&like.materials);
        gb.validate().map_err(|e| Error::invalid(path, e.to_string()))?;
        Ok(gb)
    }

    /// Runs the load's checks (once) and returns their warnings: [`load`]'s sanitising counts and plausibility
    /// warnings, put in `loaded`, from the bands decoded since the file was opened (the rows none covered are
    /// decoded now). An error is [`load`]'s for the same file.
    pub fn check(&mut self) -> Result<&[plausible::Warning]> {
        if !self.checked {
            let found = self.arrays.checks();
            self.loaded.sanitized = found.sanitized;
            // The positions are derived from depth (nothing to check against the camera): the counts are all the
            // checks need.
            let mut warnings = plausible::judge(&found.checks, &self.loaded.gbuffer, false, &self.path, |_, _| {})?;
            self.loaded.warnings.append(&mut warnings);
            self.checked = true;
        }
        Ok(&self.loaded.warnings)
    }
}

/// [`load`] without decoding, for a dump whose own arrays the resolve reads band by band as a GPU reads its
/// G-buffer (an ISPC `.bin`: 15 bytes a pixel, where the decoded planes take 49): the lights, sources and coverage
/// are [`load`]'s; its sanitising counts and plausibility warnings come from [`PackedDump::check`], counted on the
/// bands the resolve decodes.
/// `Ok(None)` when `path` is no such dump, or `opts` change its samples (folding, a grid, `--map`, file lists):
/// [`load`] it instead.
pub fn open_packed(path: &Path, opts: &LoadOptions) -> Result<Option<PackedDump>> {
    open_packed_with(path, opts, false)
}

/// [`open_packed`] with the file memory-mapped ([`ispc::Arrays::map`]) instead of read.
///
/// # Safety
/// As [`ispc::Arrays::map`]: no other process may change or truncate the file while the returned dump lives.
pub unsafe fn open_packed_mapped(path: &Path, opts: &LoadOptions) -> Result<Option<PackedDump>> {
    open_packed_with(path, opts, true)
}

fn open_packed_with(path: &Path, opts: &LoadOptions, map: bool) -> Result<Option<PackedDump>> {
    if path.is_dir() || !opts.files.is_empty() || !opts.map.is_empty() || opts.grid.is_some() || opts.fold.is_some() {
        return Ok(None);
    }
    crate::base::files::protect_input(path);
    let (side, ignored) = resolve_sidecar(path, opts)?;
    if side.as_ref().is_some_and(|(s, _)| s.supersample.is_some_and(|k| k > 1)) {
        return Ok(None);
    }
    let (head, len) = read_head(path)?;
    if head.starts_with(&EXR_MAGIC) || !ispc::matches_file(&head, len) {
        return Ok(None);
    }
    let arrays = if map {
        // SAFETY: the caller of `open_packed_mapped` has signed `Arrays::map`'s contract.
        unsafe { ispc::Arrays::map(path, opts)? }
    } else {
        ispc::Arrays::read(path, opts)?
    };
    let (like, out_of_range) = arrays.coverage()?;
    let mut loaded = Loaded {
        gbuffer: like,
        format: SourceFormat::IspcBin,
        sources: ispc::sources(out_of_range),
        lights: Some(arrays.lights(path)?),
        camera_source: CameraSource::File,
        compression: None,
        sanitized: Vec::new(),
        warnings: Vec::new(),
        reading: None,
        positions_assumed: false,
    };
    // What `load` does with a sidecar, as for every reader (its lights replace the file's).
    if let Some((s, sp)) = &side {
        apply_sidecar(&mut loaded, path, s, sp, 1)?;
    }
    loaded.gbuffer.validate().map_err(|e| Error::invalid(path, e.to_string()))?;
    loaded.warnings = ignored.into_iter().collect();
    Ok(Some(PackedDump { loaded, arrays, path: path.to_path_buf(), checked: false }))
}

/// Loads a dump (EXR or ISPC `.bin`) held in memory, exactly as [`load`] would from a file (`path` names it in
/// errors and locates the default sidecar beside it).
pub fn load_bytes(bytes: &[u8], path: &Path, opts: &LoadOptions) -> Result<Loaded> {
    crate::base::files::protect_input(path);
    let (side, ignored) = resolve_sidecar(path, opts)?;
    with_warning(load_bytes_with(bytes, path, opts, side), ignored)
}

/// [`load_bytes`] with the sidecar resolved.
fn load_bytes_with(bytes: &[u8], path: &Path, opts: &LoadOptions, side: Side) -> Result<Loaded> {
    let loaded = if bytes.starts_with(&EXR_MAGIC) {
        let raw = exr::read_raw_bytes(bytes, path, &opts.limits)?;
        read_exr(raw, path, side.as_ref().map(|s| &s.0), opts)?
    } else if ispc::matches_file(bytes, bytes.len() as u64) {
        ispc::read_bytes(bytes, path, opts)?
    } else {
        return Err(not_a_dump(path, bytes, bytes.len() as u64));
    };
    finish(loaded, path, side.as_ref().map(|(s, p)| (s, p.as_path())), opts)
}

/// The OpenEXR magic number.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
/// The PNG signature.
const PNG_MAGIC: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];

/// The error for a file no reader recognised: its first bytes, and what is wrong with it read as an ISPC `.bin`
/// header (the format without a magic number: a damaged one must still be told by its field).
fn not_a_dump(path: &Path, head: &[u8], len: u64) -> Error {
    let shown: Vec<String> = head.iter().take(8).map(|b| format!("{b:02x}")).collect();
    Error::invalid(
        path,
        format!(
            "neither an OpenEXR file (no magic number) nor an ISPC `deferred` .bin (read as its header: {}; first \
             bytes: {})",
            ispc::header_problem(head, len),
            if shown.is_empty() { "none, the file is empty".to_string() } else { shown.join(" ") }
        ),
    )
}

/// The first 4 KiB of the file and its length.
fn read_head(path: &Path) -> Result<(Vec<u8>, u64)> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut head = Vec::with_capacity(4096);
    file.take(4096).read_to_end(&mut head).map_err(|e| Error::io(path, e))?;
    Ok((head, len))
}

/// The sidecar to use and its path: `opts.sidecar`, none with `opts.no_sidecar`, else the JSON found beside the
/// dump when it is a gbuf sidecar. A found JSON that is not one (a renderer's own `<stem>.json`) is ignored, and the
/// warning saying so is returned for the loaded dump's warnings.
fn resolve_sidecar(path: &Path, opts: &LoadOptions) -> Result<(Side, Option<plausible::Warning>)> {
    if opts.no_sidecar {
        return Ok((None, None));
    }
    let p = match &opts.sidecar {
        Some(p) => return Ok((Some((Sidecar::load(p)?, p.clone())), None)),
        None if path.is_dir() => match dir_sidecar(path)? {
            Some(p) => p,
            None => return Ok((None, None)),
        },
        None => {
            let p = path.with_extension("json");
            if p == path || !p.is_file() {
                return Ok((None, None));
            }
            p
        }
    };
    match Sidecar::load_found(&p)? {
        sidecar::Found::Sidecar(s) => Ok((Some((s, p)), None)),
        sidecar::Found::Other(why) => Ok((None, Some(ignored_json(&p, &why)))),
    }
}

/// A sidecar found for a dump, and its path.
type Side = Option<(Sidecar, PathBuf)>;

/// The warning for a JSON beside a dump that is not a gbuf sidecar.
fn ignored_json(p: &Path, why: &str) -> plausible::Warning {
    plausible::Warning {
        code: SIDECAR_IGNORED,
        count: 1,
        of: 1,
        message: format!(
            "{} is not a gbuf sidecar ({why}) and was ignored: no camera or lights from it. Name a sidecar with \
             --scene FILE, or give --no-scene to look for none",
            p.display()
        ),
    }
}

/// The warning code of a JSON found beside a dump and ignored because it is not a gbuf sidecar.
pub const SIDECAR_IGNORED: &str = "sidecar-ignored";

/// The file name of a packed frame's material table (`gbuf pack` writes it; never taken for a sidecar).
pub const MATERIAL_TABLE_FILE: &str = "material_table.json";

/// The sidecar of a file-set directory: `scene.json` in it, else its only `.json` file, else `<dir>.json` beside it.
fn dir_sidecar(dir: &Path) -> Result<Option<PathBuf>> {
    let scene = dir.join("scene.json");
    if scene.is_file() {
        return Ok(Some(scene));
    }
    let jsons: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")))
        // The material table of packed render targets (`gbuf pack`) is not a sidecar.
        .filter(|p| !p.file_name().is_some_and(|n| n.eq_ignore_ascii_case(MATERIAL_TABLE_FILE)))
        .collect();
    // Of several, only those that read as gbuf sidecars are candidates.
    let jsons = if jsons.len() > 1 {
        jsons
            .into_iter()
            .filter(|p| matches!(Sidecar::load_found(p), Ok(sidecar::Found::Sidecar(_)) | Err(_)))
            .collect()
    } else {
        jsons
    };
    match jsons.as_slice() {
        [one] => Ok(Some(one.clone())),
        [] => {
            let beside = dir.with_extension("json");
            Ok(beside.is_file().then_some(beside))
        }
        many => Err(Error::invalid(
            dir,
            format!(
                "{} JSON files read as gbuf sidecars and none is scene.json: name the one to use with --scene, or \
                 give --no-scene ({})",
                many.len(),
                many.iter().filter_map(|p| p.file_name()?.to_str()).collect::<Vec<_>>().join(", ")
            ),
        )),
    }
}

/// The sidecar [`load`] would use for `path` and its path (for readers above `io`, such as the packed render
/// targets of `layout::targets`, which need the camera before they decode).
pub fn sidecar_for(path: &Path, opts: &LoadOptions) -> Result<Option<(Sidecar, PathBuf)>> {
    resolve_sidecar(path, opts).map(|(side, _)| side)
}

/// [`sidecar_for`] with the warning [`load`] gives when the JSON found beside `path` is not a gbuf sidecar.
pub fn sidecar_found(path: &Path, opts: &LoadOptions) -> Result<(Option<PathBuf>, Option<plausible::Warning>)> {
    resolve_sidecar(path, opts).map(|(side, ignored)| (side.map(|(_, p)| p), ignored))
}

/// What [`load`] does after its reader, for readers above `io`: folding, the sidecar's camera, lights and
/// materials, derived depth, sanitising, validation and the plausibility checks.
pub fn finish_loaded(loaded: Loaded, path: &Path, opts: &LoadOptions) -> Result<Loaded> {
    crate::base::files::protect_input(path);
    let (side, ignored) = resolve_sidecar(path, opts)?;
    with_warning(finish(loaded, path, side.as_ref().map(|(s, p)| (s, p.as_path())), opts), ignored)
}

/// Picks the EXR reader: canonical; the `--map` reader when the map names depth or position; Blender; Mitsuba;
/// else the `--map` reader (which explains what is missing). Other `--map` entries override scalar and ID
/// attributes of the format-specific readers.
fn read_exr(mut raw: RawImage, path: &Path, sidecar: Option<&Sidecar>, opts: &LoadOptions) -> Result<Loaded> {
    let raw = &mut raw;
    if canonical::matches(raw) {
        // `--map` entries read channels after the conversion: keep the samples for them.
        let gbuffer = if opts.map.is_empty() {
            canonical::from_raw_releasing(raw, path)?
        } else {
            canonical::from_raw(raw, path)?
        };
        let sources = canonical::sources(raw, &gbuffer);
        let camera_source = if gbuffer.camera.is_some() { CameraSource::File } else { CameraSource::Unknown };
        let mut loaded = Loaded {
            gbuffer,
            format: SourceFormat::Canonical,
            sources,
            lights: None,
            camera_source,
            compression: Some((raw.compression.clone(), raw.lossy)),
            sanitized: Vec::new(),
            warnings: Vec::new(),
            reading: None,
            positions_assumed: canonical::header(raw, canonical::ATTR_SAMPLE_POSITIONS).is_none(),
        };
        mapped::override_scalars(&mut loaded, raw, path, opts)?;
        return Ok(loaded);
    }
    // A map naming the geometry (depth or position) describes the whole file: read it as view space as mapped.
    let geometry_mapped = opts.map.iter().any(|(a, _)| matches!(a, Attribute::Depth | Attribute::Position));
    let camera = sidecar.and_then(|s| s.camera.as_ref()).map(|c| c.to_camera_for(raw.width, raw.height));
    let mut loaded = if geometry_mapped {
        return mapped::read(raw, path, camera.as_ref(), opts);
    } else if blender::matches(raw) {
        blender::read(raw, path, sidecar, opts)?
    } else if mitsuba::matches(raw) {
        mitsuba::read(raw, path, sidecar, opts)?
    } else {
        return mapped::read(raw, path, camera.as_ref(), opts);
    };
    mapped::override_scalars(&mut loaded, raw, path, opts)?;
    Ok(loaded)
}

/// After any reader: fold, camera and lights from the sidecar, derived depth, sanitizing, validation.
fn finish(mut loaded: Loaded, path: &Path, side: Option<(&Sidecar, &Path)>, opts: &LoadOptions) -> Result<Loaded> {
    if let Some((c, r)) = opts.grid {
        if opts.fold.is_some() {
            return Err(Error::Argument(
                "--grid and --fold describe two different layouts of samples: give one".into(),
            ));
        }
        loaded.gbuffer = fold::ungrid(&loaded.gbuffer, c, r)
            .map_err(|e| Error::SizeMismatch { path: path.into(), what: e.to_string() })?;
        loaded.positions_assumed = false;
        if loaded.camera_source == CameraSource::File {
            loaded.camera_source = CameraSource::Unknown;
        }
    }
    let fold_k = opts.fold.or(side.and_then(|(s, _)| s.supersample));
    if let Some(k) = fold_k.filter(|&k| k > 1) {
        let from = match (opts.fold, side) {
            (Some(_), _) => "--fold".to_string(),
            (None, Some((_, sp))) => format!("sidecar {} (supersample)", sp.display()),
            (None, None) => unreachable!("fold factor comes from --fold or the sidecar"),
        };
        let gb = &loaded.gbuffer;
        loaded.gbuffer = fold::fold(gb, k).map_err(|e| match (opts.fold, side) {
            (None, Some((_, sp))) => {
                Error::Parse { path: sp.into(), what: format!("does not match {}: {e}", path.display()) }
            }
            _ => Error::SizeMismatch { path: path.into(), what: format!("{from}: {e}") },
        })?;
    }
    if let Some((s, sp)) = side {
        apply_sidecar(&mut loaded, path, s, sp, fold_k.unwrap_or(1).max(1))?;
    }
    if loaded.gbuffer.depth.is_none() && loaded.gbuffer.derive_depth_or_position() == Some(Attribute::Depth) {
        loaded.sources.push(AttributeSource {
            attribute: Attribute::Depth.name(),
            channels: Vec::new(),
            file_type: "derived".into(),
            note: Some("derived from position (depth = −z)".into()),
        });
    }
    let depth_read = loaded.sources.iter().any(|s| s.attribute == Attribute::Depth.name() && !s.channels.is_empty());
    loaded.sanitized = sanitize::sanitize(&mut loaded.gbuffer);
    loaded.gbuffer.validate().map_err(|e| Error::invalid(path, e.to_string()))?;
    let positions_read =
        loaded.sources.iter().any(|s| s.attribute == Attribute::Position.name() && !s.channels.is_empty());
    let mut warnings = plausible::check(&loaded.gbuffer, depth_read, positions_read, loaded.positions_assumed, path)?;
    loaded.warnings.append(&mut warnings);
    Ok(loaded)
}

/// The sidecar `s` (at `sp`) applied to a dump read from `path`, folded by `k`: its camera (checked against the
/// image's aspect; used when the file has none), its materials and its lights (when the file has none).
fn apply_sidecar(loaded: &mut Loaded, path: &Path, s: &Sidecar, sp: &Path, k: u32) -> Result<()> {
    if let Some(sc) = &s.camera {
        let (w, h) = (loaded.gbuffer.width, loaded.gbuffer.height);
        let c = sc.to_camera_for(w * k, h * k);
        let image_aspect = w as f32 / h.max(1) as f32;
        if (c.aspect / image_aspect - 1.0).abs() > ASPECT_TOLERANCE {
            return Err(Error::Parse {
                path: sp.into(),
                what: format!(
                    "camera aspect {} does not match the image {} ({w}×{h} pixels, aspect {image_aspect:.4})",
                    c.aspect,
                    path.display()
                ),
            });
        }
        if loaded.gbuffer.camera.is_none() {
            loaded.gbuffer.camera = Some(c);
            loaded.camera_source = CameraSource::Sidecar;
        }
    }
    if loaded.gbuffer.materials.is_empty() {
        loaded.gbuffer.materials.clone_from(&s.materials);
    }
    // The lights the user put beside the file replace the file's own (an ISPC .bin carries some): one rule for
    // every reader. They are in the file's view space unless the sidecar says world (then its camera, or the
    // file's, places them).
    if !s.lights.is_empty() {
        loaded.lights = Some(s.view_lights(loaded.gbuffer.camera.as_ref(), sp)?);
    }
    Ok(())
}

/// A sidecar camera's aspect may differ from the image's by this fraction: engines round the aspect they export
/// (16:9 as 1.77 or 1.78), but a real mismatch (a sidecar from another render) is off by far more.
pub const ASPECT_TOLERANCE: f32 = 0.01;
