//! File sets: a dump written as one image per render target or pass (a directory, or files named with `--map
//! attr=FILE[:CHANNEL;…]`), the way most engines and renderers write them — LuxCoreRender film outputs, Unreal
//! buffer-visualization dumps, Unity HDRP AOVs, Blender's File Output node, RenderDoc per-target saves.
//!
//! A [`Preset`] knows one tool's file names and conventions; [`detect`] picks it from the names when only one
//! preset fits, `--preset NAME` otherwise. Each file is an EXR (any channel names; one-channel data written as RGB
//! is read from its first channel) or a PNG (8- or 16-bit; IDs decoded as the conventions say). Every file must
//! have the same size. The images are read on their own one-sample grid and converted to view space by
//! [`Conventions::apply`]; folding (`supersample` in the sidecar, or `--fold`) follows as for every dump.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer};
use crate::io::conventions::{Background, Conventions, DepthKind, IdEncoding, NormalEncoding, Space, MAP_DEFAULT};
use crate::io::exr::{RawData, RawImage, ReadLimits};
use crate::io::sidecar::SidecarCamera;
use crate::io::{AttributeSource, LoadOptions, Loaded, SourceFormat};
use glam::{Vec2, Vec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A per-value transform some tools need (Unity stores smoothness, we store roughness).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transform {
    /// As stored.
    None,
    /// `1 − v` (smoothness → roughness).
    OneMinus,
}

/// One buffer of a preset: the attribute, the file names that hold it (case-insensitive stems; a stem matches
/// when it equals the name or ends with `_name`, `.name` or `-name`, ignoring a trailing frame number), and the
/// channels to read.
#[derive(Clone, Copy, Debug)]
pub struct PresetFile {
    /// The attribute.
    pub attr: Attribute,
    /// Accepted names, most preferred first.
    pub names: &'static [&'static str],
    /// Channels to read (EXR); a one-channel file is read whatever its channel's name.
    pub channels: &'static [&'static str],
    /// Per-value transform.
    pub transform: Transform,
}

/// A tool's naming and conventions.
#[derive(Clone, Copy, Debug)]
pub struct Preset {
    /// `--preset` name.
    pub name: &'static str,
    /// The tool, for messages.
    pub tool: &'static str,
    /// The buffers it writes.
    pub files: &'static [PresetFile],
    /// Its conventions.
    pub conventions: Conventions,
    /// Where the conventions come from (measured, or documentation).
    pub basis: &'static str,
}

const RGB: &[&str] = &["R", "G", "B"];
const R: &[&str] = &["R"];

const fn file(attr: Attribute, names: &'static [&'static str], channels: &'static [&'static str]) -> PresetFile {
    PresetFile { attr, names, channels, transform: Transform::None }
}

/// Every preset, in the order detection tries them.
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "luxcore",
        tool: "LuxCoreRender film outputs (Film.Save)",
        files: &[
            file(Attribute::Depth, &["DEPTH"], R),
            file(Attribute::Position, &["POSITION"], RGB),
            file(Attribute::Normal, &["SHADING_NORMAL", "GEOMETRY_NORMAL"], RGB),
            file(Attribute::Albedo, &["ALBEDO"], RGB),
            file(Attribute::MaterialId, &["MATERIAL_ID"], R),
            file(Attribute::ObjectId, &["OBJECT_ID"], R),
        ],
        conventions: Conventions { space: Space::World, depth: DepthKind::RayFromNear, ids: Some(IdEncoding::Rgb8), background: Background::Inf, ..MAP_DEFAULT },
        basis: "measured on pyluxcore 2.11.2 output (fixtures/luxcore/CONVENTIONS.md)",
    },
    Preset {
        name: "unreal",
        tool: "Unreal Engine buffer-visualization dumps (HighResShot with buffer targets, HDR/EXR)",
        files: &[
            file(Attribute::Depth, &["SceneDepthWorldUnits"], R),
            file(Attribute::Normal, &["WorldNormal"], RGB),
            file(Attribute::Albedo, &["BaseColor"], RGB),
            file(Attribute::Roughness, &["Roughness"], R),
            file(Attribute::Metallic, &["Metallic"], R),
            file(Attribute::Specular, &["Specular"], R),
        ],
        conventions: Conventions { space: Space::World, ..MAP_DEFAULT },
        basis: "from Unreal's public source and documentation, not measured: `<shot>_<Buffer>.exr` (half RGBA), \
                SceneDepthWorldUnits = planar view depth in world units (cm), WorldNormal in world space taken \
                as signed (its encoding is not documented; give --normals unorm if it is n·0.5+0.5)",
    },
    Preset {
        name: "unity-hdrp",
        tool: "Unity HDRP AOV Recorder (one image sequence per AOV)",
        files: &[
            file(Attribute::Depth, &["Depth"], R),
            file(Attribute::Normal, &["Normal"], RGB),
            file(Attribute::Albedo, &["Albedo"], RGB),
            PresetFile { attr: Attribute::Roughness, names: &["Smoothness"], channels: R, transform: Transform::OneMinus },
            file(Attribute::Metallic, &["Metal"], R),
        ],
        conventions: Conventions { space: Space::World, depth: DepthKind::Ndc, reversed_z: true, normals: NormalEncoding::Unorm, ..MAP_DEFAULT },
        basis: "from the Unity Recorder documentation and HDRP source, not measured: `<Recorder>_<AOV>_<Take>_<Frame>.exr`, \
                Normal world space as n·0.5+0.5, Depth the raw reversed-Z device depth (1 at near, 0 = far = \
                background; some HDRP versions export linear depth: give --depth view-z then), roughness = 1 − Smoothness",
    },
    Preset {
        name: "blender-file-output",
        tool: "Blender compositor File Output node (one image per slot)",
        files: &[
            file(Attribute::Depth, &["Depth"], R),
            file(Attribute::Position, &["Position"], RGB),
            file(Attribute::Normal, &["Normal"], RGB),
            file(Attribute::Albedo, &["DiffCol", "Albedo"], RGB),
            file(Attribute::MaterialId, &["IndexMA"], R),
            file(Attribute::ObjectId, &["IndexOB"], R),
            file(Attribute::Roughness, &["Roughness"], R),
        ],
        conventions: Conventions { space: Space::World, ids: Some(IdEncoding::Float), ..MAP_DEFAULT },
        basis: "from Blender's documentation and source, not measured on File Output files: `<slot><frame>.exr` \
                with R, G, B channels, Depth = view-axis distance (1e10 for sky), Normal and Position in world space, \
                IndexMA/IndexOB as floats",
    },
];

/// The preset called `name` (the crate's spelling rule: case, `-` and `_` ignored).
#[must_use]
pub fn preset(name: &str) -> Option<&'static Preset> {
    let n = crate::base::names::normalize(name);
    PRESETS.iter().find(|p| crate::base::names::normalize(p.name) == n)
}

/// Every preset name, comma-separated.
#[must_use]
fn preset_names() -> String {
    PRESETS.iter().map(|p| p.name).collect::<Vec<_>>().join(", ")
}

/// Image files (`.exr`, `.png`) directly in `dir`, sorted.
fn images_in(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && is_image(p))
        .collect();
    out.sort();
    Ok(out)
}

fn is_image(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr") || e.eq_ignore_ascii_case("png"))
}

/// Does `stem` name buffer `name`? See [`PresetFile`].
fn stem_matches(stem: &str, name: &str) -> bool {
    let s = stem.to_ascii_lowercase();
    let s = s.trim_end_matches(|c: char| c.is_ascii_digit() || matches!(c, '_' | '.' | '-'));
    let n = name.to_ascii_lowercase();
    s == n
        || [b'_', b'.', b'-']
            .iter()
            .any(|&sep| s.len() > n.len() && s.ends_with(&n) && s.as_bytes()[s.len() - n.len() - 1] == sep)
}

/// Buffers the tools write beside the ones the presets read, whose names end with a preset's name: a file named
/// after one of these is that buffer, not the shorter one (`AVG_SHADING_NORMAL.exr` is not `SHADING_NORMAL`).
/// LuxCoreRender's film outputs (`Film.Save()`, one file per output type).
pub const OTHER_BUFFERS: &[&str] = &[
    "AVG_SHADING_NORMAL",
    "RGB_IMAGEPIPELINE",
    "RGBA_IMAGEPIPELINE",
    "MATERIAL_ID_COLOR",
    "MATERIAL_ID_MASK",
    "OBJECT_ID_MASK",
    "BY_MATERIAL_ID",
    "BY_OBJECT_ID",
    "DIRECT_SHADOW_MASK",
    "INDIRECT_SHADOW_MASK",
];

/// Does `stem` name buffer `name`, and not a longer buffer whose name ends with it (one of [`OTHER_BUFFERS`] or
/// another preset's name)?
fn names_buffer(stem: &str, name: &str) -> bool {
    let longer = |m: &str| m.len() > name.len() && m.to_ascii_lowercase().ends_with(&name.to_ascii_lowercase());
    stem_matches(stem, name)
        && !OTHER_BUFFERS
            .iter()
            .copied()
            .chain(PRESETS.iter().flat_map(|p| p.files.iter().flat_map(|f| f.names.iter().copied())))
            .any(|m| longer(m) && stem_matches(stem, m))
}

/// The files of `files` that preset `p` reads, per attribute (the first accepted name found wins). Errors when
/// one buffer matches several files (several frames in one directory).
fn assign(p: &Preset, files: &[PathBuf]) -> Result<Vec<(PresetFile, PathBuf)>> {
    let mut out = Vec::new();
    for pf in p.files {
        'names: for name in pf.names {
            let hits: Vec<&PathBuf> = files
                .iter()
                .filter(|f| f.file_stem().and_then(|s| s.to_str()).is_some_and(|s| names_buffer(s, name)))
                .collect();
            match hits.len() {
                0 => continue,
                1 => {
                    out.push((*pf, hits[0].clone()));
                    break 'names;
                }
                _ => {
                    let frames: Vec<String> =
                        hits.iter().filter_map(|h| frame_number(h)).map(|n| n.to_string()).collect();
                    let hint = if frames.len() == hits.len() {
                        format!(
                            "a sequence of frames {}: choose one with --frame N (report and budget read every frame)",
                            frames.join(", ")
                        )
                    } else {
                        "one frame per directory".to_string()
                    };
                    return Err(Error::invalid(
                        hits[0].parent().unwrap_or(Path::new(".")),
                        format!(
                            "{} files hold the {} buffer {name} ({}): {hint}, or name each file with --map {}=FILE",
                            hits.len(),
                            p.tool,
                            hits.iter().filter_map(|h| h.file_name()?.to_str()).collect::<Vec<_>>().join(", "),
                            pf.attr.name()
                        ),
                    ));
                }
            }
        }
    }
    Ok(out)
}

/// The frame number a file's name ends with (`Depth0001.exr` → 1, `HighResScreenshot_BaseColor_00001.exr` → 1),
/// `None` when its stem does not end in digits.
#[must_use]
fn frame_number(path: &Path) -> Option<u32> {
    let stem = path.file_stem()?.to_str()?;
    let digits = stem.len() - stem.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    (digits > 0 && digits < stem.len()).then(|| stem[stem.len() - digits..].parse().ok()).flatten()
}

/// The frames of a file-set folder that holds a sequence: the distinct trailing numbers of the images some preset
/// reads (its depth or position buffer among them), when there are at least two (sorted); empty for a folder of
/// one frame. Numbered images no preset reads (LuxCore's `RADIANCE_GROUP_0`, …) do not make a sequence.
pub fn frames_in(dir: &Path) -> Result<Vec<u32>> {
    let files = images_in(dir)?;
    for p in PRESETS {
        let read_by = |f: &PathBuf| {
            let stem = f.file_stem().and_then(|s| s.to_str()).unwrap_or("");
            p.files.iter().any(|pf| pf.names.iter().any(|n| names_buffer(stem, n)))
        };
        let geometry = |f: &PathBuf| {
            let stem = f.file_stem().and_then(|s| s.to_str()).unwrap_or("");
            p.files
                .iter()
                .filter(|pf| matches!(pf.attr, Attribute::Depth | Attribute::Position))
                .any(|pf| pf.names.iter().any(|n| names_buffer(stem, n)))
        };
        if !files.iter().any(geometry) {
            continue;
        }
        let mut frames: Vec<u32> = files.iter().filter(|f| read_by(f)).filter_map(|f| frame_number(f)).collect();
        frames.sort_unstable();
        frames.dedup();
        if frames.len() >= 2 {
            return Ok(frames);
        }
    }
    Ok(Vec::new())
}

/// The images of frame `frame` (their trailing number is `frame`; images without a number belong to every frame).
fn of_frame(files: Vec<PathBuf>, frame: u32) -> Vec<PathBuf> {
    files.into_iter().filter(|f| frame_number(f).is_none_or(|n| n == frame)).collect()
}

/// Does `dir` look like a file set of some preset (at least its depth or position file)? A sequence of frames
/// counts when its first frame does.
#[must_use]
pub fn looks_like_file_set(dir: &Path) -> bool {
    let Ok(files) = images_in(dir) else { return false };
    let files = match frames_in(dir).ok().and_then(|f| f.first().copied()) {
        Some(first) => of_frame(files, first),
        None => files,
    };
    PRESETS.iter().any(|p| {
        assign(p, &files).is_ok_and(|a| a.iter().any(|(f, _)| matches!(f.attr, Attribute::Depth | Attribute::Position)))
    })
}

/// Picks the preset for the files in `dir`: `--preset` when given, else the one preset whose depth or position
/// file is there (most buffers found wins, then most names in the tool's letter case; a tie is ambiguous and asks
/// for `--preset`).
pub fn detect(dir: &Path, files: &[PathBuf], asked: Option<&str>) -> Result<&'static Preset> {
    if let Some(name) = asked {
        return preset(name)
            .ok_or_else(|| Error::Argument(format!("unknown preset {name:?}; known: {}", preset_names())));
    }
    // Score: buffers found, then how many of them carry the name in the tool's own letter case (LuxCore writes
    // DEPTH.exr, Blender Depth0001.exr).
    let mut scored: Vec<((usize, usize), &'static Preset)> = PRESETS
        .iter()
        .filter_map(|p| {
            let a = assign(p, files).ok()?;
            let exact = a
                .iter()
                .filter(|(pf, f)| {
                    let stem = f.file_stem().and_then(|s| s.to_str()).unwrap_or("");
                    let stem = stem.trim_end_matches(|c: char| c.is_ascii_digit() || matches!(c, '_' | '.' | '-'));
                    pf.names.iter().any(|n| stem.ends_with(n))
                })
                .count();
            a.iter()
                .any(|(f, _)| matches!(f.attr, Attribute::Depth | Attribute::Position))
                .then_some(((a.len(), exact), p))
        })
        .collect();
    scored.sort_by_key(|s| std::cmp::Reverse(s.0));
    match scored.as_slice() {
        [] => Err(not_a_file_set(dir, files)),
        [(_, p)] => Ok(p),
        [(a, p), (b, q), ..] if a == b => Err(Error::invalid(
            dir,
            format!("the file names fit both the {} and the {} preset: choose one with --preset", p.name, q.name),
        )),
        [(_, p), ..] => Ok(p),
    }
}

/// The error for a directory that is no file set, saying what was found and what was expected.
fn not_a_file_set(dir: &Path, files: &[PathBuf]) -> Error {
    // Render targets (DDS) are read through a layout, not as a file set: say so first.
    let dds = std::fs::read_dir(dir).map_or(0, |it| {
        it.filter_map(|e| e.ok())
            .filter(|e| e.path().extension().is_some_and(|x| x.eq_ignore_ascii_case("dds")))
            .count()
    });
    if dds > 0 {
        return Error::invalid(
            dir,
            format!(
                "holds {dds} DDS render target(s) but no layout.toml: packed targets are decoded through the layout \
                 they were written with — name it with --input-layout LAYOUT (a built-in name or a layout file; \
                 `--layout` where the command has no layout of its own), or put it beside them as layout.toml"
            ),
        );
    }
    let found: Vec<String> = files.iter().filter_map(|f| f.file_name()?.to_str().map(String::from)).collect();
    let expected: Vec<String> = PRESETS
        .iter()
        .map(|p| {
            let names: Vec<&str> = p.files.iter().map(|f| f.names[0]).collect();
            format!("{} ({}: {})", p.name, p.tool, names.join(", "))
        })
        .collect();
    Error::invalid(
        dir,
        format!(
            "not a recognised file set: found {}; expected the images of one of: {}; or name the files with \
             --map attr=FILE[:CHANNEL;…] (e.g. --map 'depth=z.exr:R,normal=n.exr:R;G;B')",
            if found.is_empty() { "no .exr or .png image".to_string() } else { found.join(", ") },
            expected.join("; ")
        ),
    )
}

/// One decoded image of a file set.
enum Image {
    Exr(RawImage),
    Png(image::DynamicImage),
}

impl Image {
    fn size(&self) -> (u32, u32) {
        match self {
            Image::Exr(r) => (r.width, r.height),
            Image::Png(p) => (p.width(), p.height()),
        }
    }
}

fn read_image(path: &Path, limits: &ReadLimits) -> Result<Image> {
    crate::base::files::protect_input(path);
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        let reader = image::ImageReader::open(path).map_err(|e| Error::io(path, e))?;
        let reader = reader.with_guessed_format().map_err(|e| Error::io(path, e))?;
        let mut reader = reader;
        let mut l = image::Limits::default();
        l.max_alloc = Some(limits.max_bytes);
        reader.limits(l);
        let img = reader.decode().map_err(|e| Error::invalid(path, format!("PNG: {e}")))?;
        Ok(Image::Png(img))
    } else {
        Ok(Image::Exr(crate::io::exr::read_raw(path, limits)?))
    }
}

/// One buffer to read: attribute, file, channels (empty: the preset's or the default), transform.
#[derive(Clone, Debug)]
pub struct Entry {
    /// The attribute.
    pub attr: Attribute,
    /// The file.
    pub file: PathBuf,
    /// EXR channels; empty = `R`, `G`, `B` (or the only channel).
    pub channels: Vec<String>,
    /// Per-value transform.
    pub transform: Transform,
}

/// What a file set was read with (for `gbuf info`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Reading {
    /// The preset, when one was used.
    pub preset: Option<String>,
    /// The conventions applied.
    pub conventions: Conventions,
    /// Where the preset's conventions come from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub basis: Option<String>,
    /// Images in the folder that no buffer was read from (other outputs of the tool, other frames).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub ignored: Vec<String>,
}

/// Reads the file set in directory (or file) `path`: preset by detection or `opts.preset`, entries from the
/// preset, overridden and extended by `opts.files` (`--map attr=FILE…`), conventions from the preset under the
/// user's flags.
pub fn read(path: &Path, camera: Option<&SidecarCamera>, opts: &LoadOptions) -> Result<Loaded> {
    let dir = if path.is_dir() { path.to_path_buf() } else { path.parent().unwrap_or(Path::new(".")).to_path_buf() };
    let mut entries: Vec<Entry> = Vec::new();
    let mut chosen: Option<&'static Preset> = None;
    if path.is_dir() && (opts.files.is_empty() || opts.preset.is_some()) {
        let mut files = images_in(&dir)?;
        if opts.frame.is_none() && opts.preset.is_none() && looks_like_file_set(&dir) {
            let frames = frames_in(&dir)?;
            if !frames.is_empty() {
                return Err(Error::invalid(
                    &dir,
                    format!(
                        "a sequence of {} frames ({}): choose one with --frame N (report and budget read every frame)",
                        frames.len(),
                        frames.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
                    ),
                ));
            }
        }
        if let Some(n) = opts.frame {
            files = of_frame(files, n);
            if !files.iter().any(|f| frame_number(f) == Some(n)) {
                let frames = frames_in(&dir)?;
                return Err(Error::invalid(
                    &dir,
                    format!(
                        "--frame {n}: no image of that frame here (frames: {})",
                        if frames.is_empty() {
                            "none numbered".into()
                        } else {
                            frames.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
                        }
                    ),
                ));
            }
        }
        let p = detect(&dir, &files, opts.preset.as_deref())?;
        for (pf, f) in assign(p, &files)? {
            entries.push(Entry { attr: pf.attr, file: f, channels: Vec::new(), transform: pf.transform });
        }
        // Channels from the preset.
        for e in &mut entries {
            if let Some(pf) = p.files.iter().find(|pf| pf.attr == e.attr) {
                e.channels = pf.channels.iter().map(|c| (*c).to_string()).collect();
            }
        }
        chosen = Some(p);
    } else if let Some(name) = &opts.preset {
        chosen = Some(
            preset(name)
                .ok_or_else(|| Error::Argument(format!("unknown preset {name:?}; known: {}", preset_names())))?,
        );
    }
    if path.is_file() {
        for (attr, chans) in &opts.map {
            entries.retain(|e| e.attr != *attr);
            entries.push(Entry {
                attr: *attr,
                file: path.to_path_buf(),
                channels: chans.clone(),
                transform: Transform::None,
            });
        }
    }
    for (attr, file, chans) in &opts.files {
        let file = if file.is_absolute() || file.exists() { file.clone() } else { dir.join(file) };
        entries.retain(|e| e.attr != *attr);
        entries.push(Entry { attr: *attr, file, channels: chans.clone(), transform: Transform::None });
    }
    if !entries.iter().any(|e| matches!(e.attr, Attribute::Depth | Attribute::Position)) {
        return Err(Error::invalid(
            path,
            "the file set names neither depth nor position: add --map depth=FILE (or position=FILE)",
        ));
    }
    let conventions = chosen.map_or_else(Conventions::default, |p| p.conventions).with(&opts.conventions);
    let mut loaded = read_entries(path, &entries, conventions, camera, &opts.limits, chosen)?;
    if path.is_dir() {
        let used: Vec<&PathBuf> = entries.iter().map(|e| &e.file).collect();
        let other_frame = |f: &PathBuf| opts.frame.is_some_and(|n| frame_number(f).is_some_and(|m| m != n));
        let all = images_in(&dir)?;
        let others = all.iter().filter(|f| other_frame(f)).count();
        let mut ignored: Vec<String> = all
            .iter()
            .filter(|f| !used.contains(f) && !other_frame(f))
            .filter_map(|f| f.file_name()?.to_str().map(str::to_string))
            .collect();
        if others > 0 {
            ignored.push(format!("{others} files of other frames"));
        }
        if let Some(r) = &mut loaded.reading {
            r.ignored = ignored;
        }
    }
    Ok(loaded)
}

/// Reads `entries` and converts them with `conventions`.
fn read_entries(
    path: &Path,
    entries: &[Entry],
    conventions: Conventions,
    camera: Option<&SidecarCamera>,
    limits: &ReadLimits,
    chosen: Option<&'static Preset>,
) -> Result<Loaded> {
    let mut images: BTreeMap<PathBuf, Image> = BTreeMap::new();
    for e in entries {
        if !images.contains_key(&e.file) {
            if !e.file.is_file() {
                return Err(Error::invalid(&e.file, format!("{} file: no such file", e.attr.name())));
            }
            images.insert(e.file.clone(), read_image(&e.file, limits)?);
        }
    }
    let first = &entries[0];
    let (w, h) = images[&first.file].size();
    for (f, img) in &images {
        if img.size() != (w, h) {
            let (fw, fh) = img.size();
            return Err(Error::SizeMismatch {
                path: f.clone(),
                what: format!(
                    "{fw}×{fh} pixels, but {} is {w}×{h}: every file of a set must have one size",
                    first.file.display()
                ),
            });
        }
    }
    let camera: Option<Camera> = camera.map(|c| c.to_camera_for(w, h));
    let camera = camera.as_ref();
    let mut gb = GBuffer::new(w, h, 1).map_err(|e| Error::invalid(path, e.to_string()))?;
    let mut sources = Vec::new();
    let mut alpha: Option<Vec<f32>> = None;
    for e in entries {
        let img = &images[&e.file];
        let fname = e.file.file_name().and_then(|s| s.to_str()).unwrap_or("?").to_string();
        let (file_type, chans, note) = match img {
            Image::Exr(raw) => {
                let comps = exr_components(raw, &e.file, e.attr, &e.channels)?;
                let names: Vec<String> = comps.iter().map(|&i| raw.channels[i].name.clone()).collect();
                let ty = raw.channels[comps[0]].data.type_name().to_string();
                if e.attr.is_id() {
                    let ids = exr_ids(&raw.channels[comps[0]].data, conventions.ids, &e.file)?;
                    set_ids(&mut gb, e.attr, ids);
                } else {
                    let planes: Vec<Vec<f32>> = comps.iter().map(|&i| raw.channels[i].data.to_f32_vec()).collect();
                    set_floats(&mut gb, e.attr, planes, e.transform);
                }
                if matches!(e.attr, Attribute::Depth | Attribute::Position) && alpha.is_none() {
                    alpha = raw
                        .channels
                        .iter()
                        .find(|c| c.name == "A" || c.name.ends_with(".A"))
                        .map(|c| c.data.to_f32_vec());
                }
                (ty, names.iter().map(|c| format!("{fname}:{c}")).collect::<Vec<_>>(), None)
            }
            Image::Png(p) => {
                let (ty, note) = png_plane(&mut gb, e.attr, p, conventions.ids, e.transform, &e.file)?;
                if matches!(e.attr, Attribute::Depth | Attribute::Position) && alpha.is_none() && p.color().has_alpha()
                {
                    alpha = Some(p.to_rgba32f().pixels().map(|px| px.0[3]).collect());
                }
                (ty, vec![fname.clone()], note)
            }
        };
        sources.push(AttributeSource { attribute: e.attr.name(), channels: chans, file_type, note });
    }
    let notes = conventions.apply(&mut gb, camera, alpha.as_deref(), path)?;
    for (attr, note) in notes {
        if let Some(s) = sources.iter_mut().find(|s| s.attribute == attr) {
            s.note = Some(match s.note.take() {
                Some(n) => format!("{n}; {note}"),
                None => note,
            });
        }
    }
    let kinds: Vec<&str> = images
        .values()
        .map(|i| match i {
            Image::Exr(_) => "EXR",
            Image::Png(_) => "PNG",
        })
        .collect();
    let lossy = images.values().any(|i| matches!(i, Image::Exr(r) if r.lossy));
    let compression = images
        .values()
        .filter_map(|i| match i {
            Image::Exr(r) => Some(r.compression.clone()),
            Image::Png(_) => None,
        })
        .next()
        .unwrap_or_else(|| "none".into());
    let mut set_kinds = kinds.clone();
    set_kinds.sort_unstable();
    set_kinds.dedup();
    Ok(Loaded {
        gbuffer: gb,
        format: SourceFormat::FileSet,
        sources,
        lights: None,
        camera_source: crate::io::CameraSource::Unknown,
        compression: Some((
            format!("file set of {} images ({}; EXR {compression})", images.len(), set_kinds.join("+")),
            lossy,
        )),
        sanitized: Vec::new(),
        warnings: Vec::new(),
        reading: Some(Reading {
            preset: chosen.map(|p| p.name.to_string()),
            conventions,
            basis: chosen.map(|p| p.basis.to_string()),
            ignored: Vec::new(),
        }),
        positions_assumed: false,
    })
}

/// The channel indices of `attr`'s components in an EXR of a file set: the named ones (exact, or as the last
/// `.`-separated part), else `R`, `G`, `B` (`R` alone for one component), else a one-channel file's channel (for
/// every component).
fn exr_components(raw: &RawImage, path: &Path, attr: Attribute, asked: &[String]) -> Result<Vec<usize>> {
    let k = attr.components();
    let find = |name: &str| {
        raw.channels
            .iter()
            .position(|c| c.name == name)
            .or_else(|| raw.channels.iter().position(|c| c.name.rsplit('.').next() == Some(name)))
    };
    let default: Vec<String> = ["R", "G", "B"].iter().take(k.max(1)).map(|s| (*s).to_string()).collect();
    let wanted: Vec<String> = if asked.is_empty() { default } else { asked.to_vec() };
    if wanted.len() < k {
        return Err(Error::Argument(format!(
            "{}: {} needs {k} channel(s), {} named",
            path.display(),
            attr.name(),
            wanted.len()
        )));
    }
    let found: Option<Vec<usize>> = wanted.iter().take(k).map(|n| find(n)).collect();
    if let Some(f) = found {
        return Ok(f);
    }
    if raw.channels.len() == 1 && asked.is_empty() {
        return Ok(vec![0; k]);
    }
    // One-component data from a luminance or single named channel.
    if k == 1 && asked.is_empty() {
        if let Some(i) = ["Y", "V", "Z", "A"].iter().find_map(|n| find(n)) {
            return Ok(vec![i]);
        }
    }
    Err(Error::MissingChannel {
        path: path.into(),
        name: format!("{} ({}) for {}", wanted.join(";"), "EXR channels", attr.name()),
        found: raw.channel_list(),
    })
}

fn exr_ids(data: &RawData, enc: Option<IdEncoding>, path: &Path) -> Result<Vec<u32>> {
    match (data, enc) {
        (_, Some(IdEncoding::Rgb8)) => Err(Error::invalid(
            path,
            "IDs in rgb8 encoding need an 8-bit RGB PNG; this is an EXR (use --id-encoding float or u32)",
        )),
        (RawData::U32(v), _) => Ok(v.clone()),
        (other, _) => Ok(other
            .to_f32_vec()
            .into_iter()
            .map(|f| if f.is_finite() && f > 0.0 { f.round().min(u32::MAX as f32) as u32 } else { 0 })
            .collect()),
    }
}

fn set_ids(gb: &mut GBuffer, attr: Attribute, ids: Vec<u32>) {
    match attr {
        Attribute::MaterialId => gb.material_id = Some(ids),
        Attribute::ObjectId => gb.object_id = Some(ids),
        Attribute::PrimitiveId => gb.primitive_id = Some(ids),
        _ => unreachable!("ID attribute"),
    }
}

fn set_floats(gb: &mut GBuffer, attr: Attribute, planes: Vec<Vec<f32>>, t: Transform) {
    let tr = |v: f32| match t {
        Transform::None => v,
        Transform::OneMinus => 1.0 - v,
    };
    let one = |p: &Vec<f32>| p.iter().map(|&v| tr(v)).collect::<Vec<f32>>();
    let v3 = |p: &[Vec<f32>]| (0..p[0].len()).map(|i| Vec3::new(p[0][i], p[1][i], p[2][i])).collect::<Vec<Vec3>>();
    match attr {
        Attribute::Depth => gb.depth = Some(one(&planes[0])),
        Attribute::Specular => gb.specular = Some(one(&planes[0])),
        Attribute::SpecularPower => gb.specular_power = Some(one(&planes[0])),
        Attribute::Roughness => gb.roughness = Some(one(&planes[0])),
        Attribute::Metallic => gb.metallic = Some(one(&planes[0])),
        Attribute::Position => gb.position = Some(v3(&planes)),
        Attribute::Normal => gb.normal = Some(v3(&planes)),
        Attribute::Albedo => gb.albedo = Some(v3(&planes)),
        Attribute::Motion => {
            gb.motion = Some((0..planes[0].len()).map(|i| Vec2::new(planes[0][i], planes[1][i])).collect())
        }
        Attribute::MaterialId | Attribute::ObjectId | Attribute::PrimitiveId => unreachable!("IDs are set by set_ids"),
    }
}

/// Sets `attr` from a PNG. IDs: `rgb8` packs R + 256·G + 65536·B (the default for 8-bit RGB), 16-bit grey is
/// the ID itself, 8-bit grey too. Values: 8-bit and 16-bit channels scaled to [0, 1]; albedo decoded from sRGB.
/// Returns the storage type and a note saying which encoding was used.
fn png_plane(
    gb: &mut GBuffer,
    attr: Attribute,
    img: &image::DynamicImage,
    enc: Option<IdEncoding>,
    t: Transform,
    path: &Path,
) -> Result<(String, Option<String>)> {
    use image::ColorType;
    let color = img.color();
    let sixteen = matches!(color, ColorType::L16 | ColorType::La16 | ColorType::Rgb16 | ColorType::Rgba16);
    let grey = matches!(color, ColorType::L8 | ColorType::La8 | ColorType::L16 | ColorType::La16);
    let ty = format!("png {}", format!("{color:?}").to_ascii_lowercase());
    if attr.is_id() {
        let enc = enc.unwrap_or(if grey { IdEncoding::U32 } else { IdEncoding::Rgb8 });
        let (ids, note): (Vec<u32>, &str) = match enc {
            IdEncoding::Rgb8 => {
                if sixteen {
                    return Err(Error::invalid(path, "rgb8 ID encoding needs an 8-bit PNG; this one is 16-bit"));
                }
                let rgb = img.to_rgb8();
                (
                    rgb.pixels().map(|p| u32::from(p[0]) | u32::from(p[1]) << 8 | u32::from(p[2]) << 16).collect(),
                    "IDs decoded as R + 256·G + 65536·B (rgb8)",
                )
            }
            IdEncoding::U32 | IdEncoding::Float => {
                if !grey {
                    return Err(Error::invalid(
                        path,
                        format!(
                            "IDs as {} need a grey PNG; this one is {color:?} (use --id-encoding rgb8)",
                            enc.name()
                        ),
                    ));
                }
                (
                    img.to_luma16().pixels().map(|p| u32::from(p[0]) >> if sixteen { 0 } else { 8 }).collect(),
                    "IDs read as grey values",
                )
            }
        };
        set_ids(gb, attr, ids);
        return Ok((ty, Some(note.to_string())));
    }
    let px = img.to_rgb32f();
    let comp = |c: usize| -> Vec<f32> { px.pixels().map(|p| p.0[c]).collect() };
    let k = attr.components();
    let mut planes: Vec<Vec<f32>> = (0..k).map(|c| if grey { comp(0) } else { comp(c.min(2)) }).collect();
    let mut note = None;
    if attr == Attribute::Albedo {
        for p in &mut planes {
            p.iter_mut().for_each(|v| *v = crate::base::picture::srgb_decode(*v));
        }
        note = Some("PNG albedo decoded from sRGB".to_string());
    }
    if attr == Attribute::Depth || attr == Attribute::Position {
        return Err(Error::invalid(
            path,
            format!("{} from a PNG: 8/16-bit images cannot hold {}; give an EXR", attr.name(), attr.name()),
        ));
    }
    set_floats(gb, attr, planes, t);
    Ok((ty, note))
}
