//! Packed render targets as an input: a folder holding `<target name>.<dds|bin|png|exr>` per target of a layout
//! (what `gbuf pack` writes, or an engine's capture saved target by target, e.g. from RenderDoc with "samples to
//! array slices"), decoded through the layout into a G-buffer, the way the engine's lighting pass would see it.
//!
//! What the files cannot say comes from beside them: the camera (near/far for the depth codecs, the projection for
//! positions), the lights and the sample positions from the sidecar (`scene.json`, found as for every dump); the
//! material table from `material_table.json`; coverage from `coverage.<ext>` (R8, nonzero = a surface) when
//! present, else from the depth field: a sample whose depth holds the codec's clear code (the far plane: 1.0 or all
//! ones standard, 0 reversed and linear) is background, as an engine's lighting pass tests the depth buffer. A
//! layout that stores no depth needs the coverage file. A folder holding `layout.toml` (`gbuf pack` writes it)
//! names its own layout; any other folder needs the layout from the caller (`--layout`).

use super::texture::{self, Texture};
use super::{Layout, MaterialTable, Packed, Slot, TargetPlane};
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer};
use crate::io::{AttributeSource, CameraSource, LoadOptions, Loaded, SourceFormat, MATERIAL_TABLE_FILE};
use crate::layout::formats::Format;
use glam::Vec2;
use std::path::{Path, PathBuf};

/// The layout file `gbuf pack` writes beside the targets: a folder holding it is read through it with no flag.
pub const LAYOUT_FILE: &str = "layout.toml";

/// The warning every packed input carries ([`crate::io::plausible::Warning::code`]): no float truth.
pub const NO_FLOAT_TRUTH: &str = "no-float-truth";

/// The coverage target's name (an optional R8 file: nonzero where a surface is).
pub const COVERAGE_TARGET: &str = "coverage";

/// File extensions a target may have, in the order they are looked for.
pub const EXTENSIONS: [&str; 4] = ["dds", "bin", "png", "exr"];

/// How to read packed render targets (the CLI's `--layout`/`--input-layout` and `--target NAME=FILE`).
#[derive(Clone, Debug, Default)]
pub struct PackedInput {
    /// The layout the targets were written with; `None`: the folder's `layout.toml`, if any.
    pub layout: Option<Layout>,
    /// Explicit files per target name (relative paths are relative to the folder).
    pub targets: Vec<(String, PathBuf)>,
}

impl PackedInput {
    /// True when this input asks for packed targets (a layout or a target file was given).
    #[must_use]
    pub fn is_given(&self) -> bool {
        self.layout.is_some() || !self.targets.is_empty()
    }
}

/// True when `dir` is a folder of packed targets that names its own layout (holds `layout.toml`).
#[must_use]
pub fn is_packed_dir(dir: &Path) -> bool {
    dir.is_dir() && dir.join(LAYOUT_FILE).is_file()
}

/// Loads `path` as packed render targets when `input` asks for them or the folder holds `layout.toml`, else as
/// any other dump ([`crate::io::load`]).
pub fn load(path: &Path, input: &PackedInput, opts: &LoadOptions) -> Result<Loaded> {
    if !input.is_given() && !is_packed_dir(path) {
        return crate::io::load(path, opts);
    }
    let layout = match &input.layout {
        Some(l) => l.clone(),
        None => Layout::load(&path.join(LAYOUT_FILE))?,
    };
    load_packed(path, &layout, &input.targets, opts)
}

/// The file holding target `name` in `dir`: `<name>.<ext>` (name matched ignoring case), or the explicit one.
fn target_file(dir: &Path, name: &str, explicit: &[(String, PathBuf)], files: &[PathBuf]) -> Result<Option<PathBuf>> {
    if let Some((_, f)) = explicit.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)) {
        let f = if f.is_relative() && !f.exists() { dir.join(f) } else { f.clone() };
        if !f.is_file() {
            return Err(Error::Argument(format!("--target {name}={}: no such file", f.display())));
        }
        return Ok(Some(f));
    }
    let found: Vec<&PathBuf> = files
        .iter()
        .filter(|f| {
            f.file_stem().and_then(|s| s.to_str()).is_some_and(|s| s.eq_ignore_ascii_case(name))
                && f.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| EXTENSIONS.iter().any(|x| x.eq_ignore_ascii_case(e)))
        })
        .collect();
    match found.as_slice() {
        [] => Ok(None),
        [one] => Ok(Some((*one).clone())),
        many => Err(Error::invalid(
            dir,
            format!(
                "{} files hold target {name:?} ({}): keep one, or name it with --target {name}=FILE",
                many.len(),
                many.iter().filter_map(|p| p.file_name()?.to_str()).collect::<Vec<_>>().join(", ")
            ),
        )),
    }
}

/// Texels sample-major (slice s = sample s of every pixel) → pixel-major (the samples of a pixel together).
fn pixel_major(t: &Texture, tb: usize) -> Vec<u8> {
    let (pixels, samples) = (t.width as usize * t.height as usize, t.slices as usize);
    let mut out = vec![0u8; t.bytes.len()];
    for s in 0..samples {
        for p in 0..pixels {
            let src = (s * pixels + p) * tb;
            let dst = (p * samples + s) * tb;
            out[dst..dst + tb].copy_from_slice(&t.bytes[src..src + tb]);
        }
    }
    out
}

/// A one-slice texture holding a "slices as grid" mosaic (RenderDoc) as `cols · rows` slices: tile s (row by row)
/// is slice s.
fn ungrid(t: Texture, (cols, rows): (u32, u32), tb: usize, path: &Path) -> Result<Texture> {
    if t.slices != 1 || cols == 0 || rows == 0 || !t.width.is_multiple_of(cols) || !t.height.is_multiple_of(rows) {
        return Err(Error::SizeMismatch {
            path: path.into(),
            what: format!(
                "--grid {cols}x{rows}: {}×{} texels in {} slice(s) is not such a mosaic",
                t.width, t.height, t.slices
            ),
        });
    }
    let (w, h) = ((t.width / cols) as usize, (t.height / rows) as usize);
    let src_w = t.width as usize;
    let mut bytes = Vec::with_capacity(t.bytes.len());
    for s in 0..(cols * rows) as usize {
        let (tx, ty) = (s % cols as usize, s / cols as usize);
        for y in 0..h {
            let at = ((ty * h + y) * src_w + tx * w) * tb;
            bytes.extend_from_slice(&t.bytes[at..at + w * tb]);
        }
    }
    Ok(Texture {
        width: w as u32,
        height: h as u32,
        slices: cols * rows,
        stored_as: format!("{} (grid {cols}x{rows})", t.stored_as),
        bytes,
    })
}

/// A packed frame read from files, before decoding.
#[derive(Clone, Debug)]
pub struct PackedFiles {
    /// The targets' bytes (pixel-major, as [`Layout::pack`] makes them) and what the layout stores.
    pub packed: Packed,
    /// The G-buffer without planes: size, samples, sample positions, camera, coverage.
    pub shell: GBuffer,
    /// Per target: the file and what it stores (`DDS DXGI 24 R10G10B10A2_UNORM`, …).
    pub files: Vec<(String, PathBuf, String)>,
    /// Where coverage came from (`coverage file …` or `depth field … ≠ clear code …`).
    pub coverage_from: String,
    /// True when no sample positions were given and the standard pattern was assumed.
    pub positions_assumed: bool,
}

/// Every `--target NAME=…` names a target of `layout` (or `coverage`, `material_table`).
fn check_target_names(layout: &Layout, explicit: &[(String, PathBuf)]) -> Result<()> {
    for (n, _) in explicit {
        let known = layout.spec().targets.iter().any(|t| t.name.eq_ignore_ascii_case(n))
            || n.eq_ignore_ascii_case(COVERAGE_TARGET)
            || n.eq_ignore_ascii_case("material_table");
        if !known {
            return Err(Error::Argument(format!(
                "--target {n}: layout {:?} has no such target (its targets: {}; also coverage, material_table)",
                layout.name(),
                layout.spec().targets.iter().map(|t| t.name.as_str()).collect::<Vec<_>>().join(", ")
            )));
        }
    }
    Ok(())
}

/// Reads the targets of `layout` from `dir` (and the sidecar's camera and sample positions, the material table,
/// the coverage) without decoding them.
pub fn read_frame(
    dir: &Path,
    layout: &Layout,
    explicit: &[(String, PathBuf)],
    opts: &LoadOptions,
) -> Result<PackedFiles> {
    crate::base::files::protect_input(dir);
    if !dir.is_dir() && explicit.is_empty() {
        return Err(Error::invalid(
            dir,
            format!("packed render targets of layout {:?} are a folder of files", layout.name()),
        ));
    }
    let files: Vec<PathBuf> = if dir.is_dir() {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .map_err(|e| Error::io(dir, e))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file())
            .collect();
        v.sort();
        v
    } else {
        Vec::new()
    };
    check_target_names(layout, explicit)?;
    let mut planes = Vec::new();
    let mut read = Vec::new();
    let mut size: Option<(u32, u32, u32, PathBuf)> = None;
    let check = |size: &mut Option<(u32, u32, u32, PathBuf)>, t: &Texture, f: &Path| -> Result<()> {
        match size {
            None => *size = Some((t.width, t.height, t.slices, f.to_path_buf())),
            Some((w, h, s, first)) if (*w, *h, *s) != (t.width, t.height, t.slices) => {
                return Err(Error::SizeMismatch {
                    path: f.into(),
                    what: format!(
                        "{}×{} texels × {} slice(s), but {} has {w}×{h} × {s}: every target of a frame has the same \
                         size and sample count",
                        t.width,
                        t.height,
                        t.slices,
                        first.display()
                    ),
                })
            }
            Some(_) => {}
        }
        Ok(())
    };
    for (spec, &format) in layout.spec().targets.iter().zip(layout.formats()) {
        let f = target_file(dir, &spec.name, explicit, &files)?.ok_or_else(|| {
            Error::invalid(
                dir,
                format!(
                    "no file for target {:?} of layout {:?} (looked for {}.{{{}}}; files here: {}); name it with \
                     --target {}=FILE",
                    spec.name,
                    layout.name(),
                    spec.name,
                    EXTENSIONS.join(","),
                    if files.is_empty() {
                        "none".to_string()
                    } else {
                        files.iter().filter_map(|p| p.file_name()?.to_str()).collect::<Vec<_>>().join(", ")
                    },
                    spec.name
                ),
            )
        })?;
        let mut t = texture::read(&f, format, &opts.limits)?;
        if let Some(g) = opts.grid {
            t = ungrid(t, g, format.bytes(), &f)?;
        }
        check(&mut size, &t, &f)?;
        planes.push(TargetPlane { name: spec.name.clone(), format, bytes: pixel_major(&t, format.bytes()) });
        read.push((spec.name.clone(), f, t.stored_as));
    }
    let (width, height, samples, _) = size.clone().ok_or_else(|| Error::invalid(dir, "the layout has no targets"))?;
    let side = crate::io::sidecar_for(dir, opts)?;
    let mut shell = GBuffer::new(width, height, samples).map_err(|e| Error::invalid(dir, format!("{e}")))?;
    let mut positions_assumed = samples > 1;
    if let Some((s, sp)) = &side {
        if let Some(c) = &s.camera {
            shell.camera = Some(c.to_camera_for(width, height));
        }
        if let Some(p) = &s.sample_positions {
            if p.len() != samples as usize {
                return Err(Error::Parse {
                    path: sp.clone(),
                    what: format!("{} sample positions for targets of {samples} samples", p.len()),
                });
            }
            shell.sample_positions = p.iter().map(|&[x, y]| Vec2::new(x, y)).collect();
            crate::gbuffer::check_sample_positions(&shell.sample_positions)
                .map_err(|e| Error::Parse { path: sp.clone(), what: format!("sidecar sample_positions: {e}") })?;
            positions_assumed = false;
        }
    }
    let depth_range = layout.depth_range_for(&shell);
    // Coverage: the coverage file, else the depth field's clear code.
    let cov_file = target_file(dir, COVERAGE_TARGET, explicit, &files)?;
    let coverage_from = if let Some(f) = cov_file {
        let mut t = texture::read(&f, Format::R8, &opts.limits)?;
        if let Some(g) = opts.grid {
            t = ungrid(t, g, 1, &f)?;
        }
        check(&mut size, &t, &f)?;
        shell.coverage = pixel_major(&t, 1).iter().map(|&b| b != 0).collect();
        format!("{} (nonzero = a surface)", f.display())
    } else {
        let packed_targets = &planes;
        match layout.coverage_from_depth(packed_targets, depth_range)? {
            Some(c) => {
                shell.coverage = c;
                let f = layout.fields().iter().find(|f| f.slot == Slot::Whole(Attribute::Depth));
                format!(
                    "the depth field ({}): a sample holding the clear code (the far plane) is background",
                    f.map_or_else(String::new, |f| format!("{} {}", layout.spec().targets[f.target].name, f.codec))
                )
            }
            None => {
                return Err(Error::invalid(
                    dir,
                    format!(
                        "layout {:?} stores no depth, so nothing tells a surface from the background: add \
                         coverage.dds (R8, nonzero = a surface) or --target coverage=FILE",
                        layout.name()
                    ),
                ))
            }
        }
    };
    let material_table = match layout.indirection() {
        None => None,
        Some(ind) => {
            let f = explicit
                .iter()
                .find(|(n, _)| n.eq_ignore_ascii_case("material_table"))
                .map(|(_, f)| if f.is_relative() && !f.exists() { dir.join(f) } else { f.clone() })
                .unwrap_or_else(|| dir.join(MATERIAL_TABLE_FILE));
            let len = std::fs::metadata(&f).map(|m| m.len()).unwrap_or(0);
            if len > MAX_TABLE_BYTES {
                return Err(Error::invalid(
                    &f,
                    format!("material table of {len} bytes, over the {} MiB one may have", MAX_TABLE_BYTES >> 20),
                ));
            }
            let text = std::fs::read(&f).map_err(|e| {
                Error::invalid(&f, format!("layout {:?} indexes a material table; reading it: {e}", layout.name()))
            })?;
            let table: MaterialTable = serde_json::from_slice(&text)
                .map_err(|e| Error::Parse { path: f.clone(), what: format!("material table: {e}") })?;
            let problems = table.problems(ind);
            if !problems.is_empty() {
                return Err(Error::Parse {
                    path: f.clone(),
                    what: format!("material table of layout {:?}: {}", layout.name(), problems.join("; ")),
                });
            }
            Some(table)
        }
    };
    let packed = Packed {
        layout: layout.name().to_string(),
        width,
        height,
        samples,
        targets: planes,
        material_table,
        depth_range,
        present: layout.stored_attributes(),
    };
    Ok(PackedFiles { packed, shell, files: read, coverage_from, positions_assumed })
}

/// Largest `material_table.json` read: a 2^24-entry table (the most a material index addresses) of four
/// parameters takes about 1 GB of JSON; real ones are kilobytes. 64 MiB, as a sidecar.
pub const MAX_TABLE_BYTES: u64 = 64 << 20;

/// Bytes a frame of `like`'s size decoded through `layout` takes at its peak: every stored attribute as f32
/// components, the position derived from depth when the layout stores no position (and the depth from position),
/// the coverage, and the `packed` bytes of the targets held beside it.
fn decoded_bytes(layout: &Layout, like: &GBuffer, packed: u64) -> u64 {
    let attrs = layout.stored_attributes();
    let has = |a: Attribute| attrs.contains(&a);
    let mut per_sample: u64 = 1 + attrs.iter().map(|a| 4 * a.components() as u64).sum::<u64>();
    if has(Attribute::Depth) && !has(Attribute::Position) {
        per_sample += 12;
    }
    if has(Attribute::Position) && !has(Attribute::Depth) {
        per_sample += 4;
    }
    (like.len() as u64).saturating_mul(per_sample).saturating_add(packed)
}

/// Reads and decodes the targets of `layout` in `dir`: the G-buffer the engine's lighting pass would see, then
/// what [`crate::io::load`] does after every reader (sidecar lights, sanitising, validation, plausibility).
pub fn load_packed(dir: &Path, layout: &Layout, explicit: &[(String, PathBuf)], opts: &LoadOptions) -> Result<Loaded> {
    load_packed_frame(dir, layout, explicit, opts).map(|(loaded, _)| loaded)
}

/// [`load_packed`], also returning the targets as read (their codes), so a caller that needs both reads the
/// files once (`gbuf info`'s code space, `gbuf pack`'s copy of the codes).
pub fn load_packed_frame(
    dir: &Path,
    layout: &Layout,
    explicit: &[(String, PathBuf)],
    opts: &LoadOptions,
) -> Result<(Loaded, PackedFiles)> {
    if crate::io::rdc::is_capture(dir) {
        return load_capture_frame(dir, layout, explicit, opts);
    }
    let frame = read_frame(dir, layout, explicit, opts)?;
    // The decoded frame, not the files, is what the limit bounds: checked before it is made.
    let need = decoded_bytes(layout, &frame.shell, frame.packed.total_bytes() as u64);
    if need > opts.limits.max_bytes {
        return Err(Error::TooLarge {
            path: dir.into(),
            bytes: need,
            limit: opts.limits.max_bytes,
            why: format!(
                "{}; the estimate is the decoded frame ({} × {} × {} samples of {}) beside its packed targets",
                opts.limits.describe(),
                frame.shell.width,
                frame.shell.height,
                frame.shell.samples,
                layout.stored_attributes().iter().map(|a| a.name()).collect::<Vec<_>>().join(", ")
            ),
        });
    }
    let gbuffer = layout.unpack(&frame.packed, &frame.shell).map_err(|e| Error::invalid(dir, e.to_string()))?;
    if !gbuffer.coverage.iter().any(|&c| c) {
        return Err(Error::invalid(dir, format!("no sample holds a surface (coverage from {})", frame.coverage_from)));
    }
    let mut sources = Vec::new();
    for f in layout.fields() {
        let Some(a) = f.slot.attribute() else { continue };
        let (name, _, stored) = &frame.files[f.target];
        sources.push(AttributeSource {
            attribute: a.name(),
            channels: vec![format!("{name}[{}..{}]", f.offset, f.offset + f.bits)],
            file_type: stored.clone(),
            note: Some(format!(
                "{} through layout {}",
                if f.codec.is_empty() { "stored" } else { &f.codec },
                layout.name()
            )),
        });
    }
    if let Some(ind) = layout.indirection() {
        for a in &ind.parameters {
            sources.push(AttributeSource {
                attribute: a.name(),
                channels: vec!["material_index".into()],
                file_type: "material table".into(),
                note: Some(format!("through layout {}'s material table", layout.name())),
            });
        }
    }
    let camera_source = if gbuffer.camera.is_some() { CameraSource::Sidecar } else { CameraSource::Unknown };
    let covered = gbuffer.coverage.iter().filter(|&&c| c).count() as u64;
    let no_truth = crate::io::plausible::Warning {
        code: NO_FLOAT_TRUTH,
        count: covered,
        of: covered,
        message: format!(
            "decoded from the packed targets of layout {}: there is no float truth, so every error gbuf measures on \
             this frame is against the engine's decoded frame (what its lighting pass sees), not against the \
             surfaces it rendered",
            layout.name()
        ),
    };
    let loaded = Loaded {
        gbuffer,
        format: SourceFormat::PackedTargets,
        sources,
        lights: None,
        camera_source,
        compression: None,
        sanitized: Vec::new(),
        warnings: vec![no_truth],
        reading: None,
        positions_assumed: frame.positions_assumed,
    };
    // The targets were unfolded already: the decoded frame is not a mosaic.
    let opts = LoadOptions { grid: None, ..opts.clone() };
    Ok((crate::io::finish_loaded(loaded, dir, &opts)?, frame))
}

/// [`load_packed_frame`] of a RenderDoc capture: the targets bound at the selected action (`opts.capture`) are
/// extracted ([`crate::io::rdc::extract`]) and matched to the layout's targets, by `--target NAME=colorN|depth`, else
/// by the resources' debug names; the sidecar is the one found beside the capture.
fn load_capture_frame(
    capture: &Path,
    layout: &Layout,
    explicit: &[(String, PathBuf)],
    opts: &LoadOptions,
) -> Result<(Loaded, PackedFiles)> {
    let x = crate::io::rdc::extract(capture, &opts.capture)?;
    let files = capture_targets(capture, layout, explicit, &x)?;
    let (sidecar, ignored) = crate::io::sidecar_found(capture, opts)?;
    let opts = LoadOptions { no_sidecar: sidecar.is_none(), sidecar, ..opts.clone() };
    let m = &x.manifest;
    let folder = x.folder();
    // Errors name the capture and the event, not the temporary folder.
    let inside = format!("{}{}", folder.display(), std::path::MAIN_SEPARATOR);
    let (mut loaded, frame) = load_packed_frame(&folder, layout, &files, &opts)
        .map_err(|e| Error::invalid(capture, format!("event {}: {}", m.event, e.to_string().replace(&inside, ""))))?;
    for s in &mut loaded.sources {
        let target = s.channels.first().and_then(|c| c.split('[').next()).unwrap_or("");
        let from = files.iter().find(|(n, _)| n == target).and_then(|(_, f)| {
            m.targets.iter().find(|t| x.file(t).as_deref() == Some(f.as_path())).map(|t| t.describe())
        });
        if let Some(from) = from {
            let from = format!("RenderDoc event {}: {from}", m.event);
            s.note = Some(s.note.take().map_or_else(|| from.clone(), |n| format!("{n}; {from}")));
        }
    }
    if let Some(w) = ignored {
        loaded.warnings.insert(0, w);
    }
    Ok((loaded, frame))
}

/// The files of `layout`'s targets among those extracted from `capture`: `--target NAME=colorN|depth` names an
/// attachment (another value is a file, relative to the capture's folder); a target not named is the bound target
/// whose debug name is the target's (ignoring case). `coverage` is optional; the material table is a file.
fn capture_targets(
    capture: &Path,
    layout: &Layout,
    explicit: &[(String, PathBuf)],
    x: &crate::io::rdc::Extracted,
) -> Result<Vec<(String, PathBuf)>> {
    let m = &x.manifest;
    let bound = || {
        let mut v: Vec<String> = m.targets.iter().map(crate::io::rdc::BoundTarget::describe).collect();
        v.extend(m.skipped.iter().map(|s| format!("{} ({}: {})", s.name, s.format, s.reason)));
        v.join("; ")
    };
    let is_attachment = |v: &str| {
        v.eq_ignore_ascii_case("depth")
            || v.get(..5).is_some_and(|p| p.eq_ignore_ascii_case("color"))
                && v.len() > 5
                && v[5..].bytes().all(|b| b.is_ascii_digit())
    };
    let here = capture.parent().unwrap_or(Path::new("."));
    check_target_names(layout, explicit)?;
    let mut files = Vec::new();
    let names = layout.spec().targets.iter().map(|t| (t.name.as_str(), true));
    for (name, needed) in names.chain([(COVERAGE_TARGET, false), ("material_table", false)]) {
        let given = explicit.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)).map(|(_, v)| v);
        let target = match given {
            Some(v) if is_attachment(&v.to_string_lossy()) => {
                let a = v.to_string_lossy();
                let t = m.targets.iter().find(|t| t.attachment().eq_ignore_ascii_case(&a));
                Some(t.ok_or_else(|| {
                    Error::Argument(format!(
                        "--target {name}={a}: {} has no readable {a} at event {} (bound there: {})",
                        capture.display(),
                        m.event,
                        bound()
                    ))
                })?)
            }
            Some(v) => {
                // A file: as given when it exists (relative to the working folder), else beside the capture.
                files.push((name.to_string(), if v.is_relative() && !v.exists() { here.join(v) } else { v.clone() }));
                continue;
            }
            None if name == "material_table" => continue,
            None => m.targets.iter().find(|t| t.name.eq_ignore_ascii_case(name)),
        };
        match target {
            Some(t) => {
                let f = x
                    .file(t)
                    .ok_or_else(|| Error::Internal(format!("RenderDoc bridge: no file for {}", t.describe())))?;
                files.push((name.to_string(), f));
            }
            None if needed => {
                return Err(Error::invalid(
                    capture,
                    format!(
                        "event {} ({}): no bound target is named {name:?}, a target of layout {:?}; name its \
                         attachment with --target {name}=colorN|depth, or pick another action with --event EID or \
                         --marker NAME (bound there: {})",
                        m.event,
                        m.action,
                        layout.name(),
                        bound()
                    ),
                ))
            }
            None => {}
        }
    }
    Ok(files)
}

/// The layout of packed targets at `path` that `input` names (or the folder's `layout.toml`), `None` when the
/// input is not packed targets.
pub fn input_layout(path: &Path, input: &PackedInput) -> Result<Option<Layout>> {
    match &input.layout {
        Some(l) => Ok(Some(l.clone())),
        None if is_packed_dir(path) => Layout::load(&path.join(LAYOUT_FILE)).map(Some),
        None => Ok(None),
    }
}

/// Writes `gb` packed with `layout` into `dir` as a frame [`load`] reads back with no flags: every target
/// ([`super::dds::write_targets`]: `<target>.dds`/`.bin`, `material_table.json`), the layout as `layout.toml`, the
/// sidecar as `scene.json` (camera, `lights` in view space, sample positions, materials) and, for a layout that
/// stores no depth, `coverage.dds` (R8_UNORM, 255 = a surface). Reading it back gives `layout.unpack(pack(gb))`
/// bit for bit (tested).
pub fn write_frame(
    layout: &Layout,
    gb: &GBuffer,
    lights: &[crate::light::Light],
    dir: &Path,
) -> Result<Vec<super::dds::WrittenTarget>> {
    write_packed(layout, &layout.pack(gb)?, gb, lights, dir)
}

/// [`write_frame`] of targets already packed (`packed`, e.g. read by [`read_frame`]: repacking a packed frame
/// with its own layout copies its codes), with the coverage, camera, sample positions and materials of `gb`.
pub fn write_packed(
    layout: &Layout,
    packed: &Packed,
    gb: &GBuffer,
    lights: &[crate::light::Light],
    dir: &Path,
) -> Result<Vec<super::dds::WrittenTarget>> {
    if packed.layout != layout.name()
        || (packed.width, packed.height, packed.samples) != (gb.width, gb.height, gb.samples)
    {
        return Err(Error::Mismatch(format!(
            "targets of layout {:?} ({}×{}×{}) written as layout {:?} for a {}×{}×{} G-buffer",
            packed.layout,
            packed.width,
            packed.height,
            packed.samples,
            layout.name(),
            gb.width,
            gb.height,
            gb.samples
        )));
    }
    let mut out = super::dds::write_targets(packed, dir)?;
    let mut extra = |target: &str, format: &str, path: PathBuf| -> Result<()> {
        let bytes = std::fs::metadata(&path).map_err(|e| Error::io(&path, e))?.len() as usize;
        out.push(super::dds::WrittenTarget {
            target: target.into(),
            format: format.into(),
            dxgi_format: None,
            path,
            bytes,
        });
        Ok(())
    };
    if !layout.fields().iter().any(|f| f.slot == Slot::Whole(Attribute::Depth)) {
        let plane = TargetPlane {
            name: COVERAGE_TARGET.into(),
            format: Format::R8,
            bytes: gb.coverage.iter().map(|&c| if c { 255 } else { 0 }).collect(),
        };
        let path = dir.join(format!("{COVERAGE_TARGET}.dds"));
        crate::base::files::write_bytes_atomic(
            &path,
            &super::dds::dds_bytes(&plane, gb.width, gb.height, gb.samples)?,
        )?;
        extra(COVERAGE_TARGET, "r8", path)?;
    }
    let path = dir.join(LAYOUT_FILE);
    layout.save(&path)?;
    extra("layout", "toml", path)?;
    let mut side = crate::scene::scene_sidecar(gb, lights);
    side.sample_positions = Some(gb.sample_positions.iter().map(|p| [p.x, p.y]).collect());
    let mut text = serde_json::to_vec_pretty(&side).map_err(|e| Error::Internal(format!("sidecar: {e}")))?;
    text.push(b'\n');
    let path = dir.join("scene.json");
    crate::base::files::write_bytes_atomic(&path, &text)?;
    extra("scene", "json", path)?;
    Ok(out)
}
