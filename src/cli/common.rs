//! Flags shared by every command that reads a dump, and output helpers.
#![allow(dead_code)] // each subcommand uses a subset of these helpers

use anyhow::Context;
use gbuf::detect::{DetectorConfig, IdSource};
use gbuf::gbuffer::Attribute;
use gbuf::io::{LoadOptions, Loaded, ReadLimits};
use std::io::Write;
use std::path::PathBuf;

/// How to read a dump (every flag but the file itself).
#[derive(clap::Args, Debug, Clone)]
pub struct ReadArgs {
    /// Scene sidecar (camera + lights). Default: `<file stem>.json` beside the dump (a file set's `scene.json` or
    /// only JSON) when it is a gbuf sidecar; another program's JSON there is ignored with a warning.
    #[arg(long, conflicts_with = "no_scene")]
    pub scene: Option<PathBuf>,
    /// Use no sidecar, not even one found beside the dump.
    #[arg(long)]
    pub no_scene: bool,
    /// Fold k×k pixel blocks of a supersampled dump into k² samples per pixel.
    #[arg(long, value_name = "K")]
    pub fold: Option<u32>,
    /// Attribute → channel overrides: `normal=N.X;N.Y;N.Z,depth=Z` (components separated by `;`), or another
    /// file: `depth=DEPTH.exr:R`, `material_id=ids.png` (relative to the dump's directory).
    #[arg(hide_short_help = true, long, value_name = "ATTR=[FILE:]CHANNEL,…")]
    pub map: Option<String>,
    /// File-set preset (default: detected from the file names): luxcore, unreal, unity-hdrp, blender-file-output.
    #[arg(hide_short_help = true, long, value_name = "NAME")]
    pub preset: Option<String>,
    /// Space of positions and normals read by naming (`--map`, file sets): world needs the sidecar's camera.
    #[arg(hide_short_help = true, long)]
    pub space: Option<gbuf::io::conventions::Space>,
    /// What depth read by naming measures: view-z, ray (from the eye), ray-from-near, ndc.
    #[arg(hide_short_help = true, long)]
    pub depth: Option<gbuf::io::conventions::DepthKind>,
    /// Near plane for `--depth ray-from-near|ndc` (default: the camera's).
    #[arg(hide_short_help = true, long)]
    pub znear: Option<f32>,
    /// Far plane for `--depth ndc` (default: the camera's).
    #[arg(hide_short_help = true, long)]
    pub zfar: Option<f32>,
    /// With `--depth ndc`: 1 at the near plane.
    #[arg(hide_short_help = true, long)]
    pub reversed_z: bool,
    /// How IDs read by naming are stored: float, u32, rgb8 (R + 256·G + 65536·B).
    #[arg(hide_short_help = true, long, value_name = "ENCODING")]
    pub id_encoding: Option<gbuf::io::conventions::IdEncoding>,
    /// Background marker for data read by naming: auto, inf, nan, alpha, or a depth value.
    #[arg(hide_short_help = true, long, value_name = "VALUE")]
    pub background: Option<String>,
    /// Normal encoding for data read by naming: signed, unorm (n·0.5 + 0.5).
    #[arg(hide_short_help = true, long)]
    pub normals: Option<gbuf::io::conventions::NormalEncoding>,
    /// Refuse files whose decoded samples would need more than this many MiB [default: a quarter of the
    /// machine's available memory].
    #[arg(hide_short_help = true, long, value_name = "MIB")]
    pub max_memory: Option<u64>,
    /// Decode DWAA/DWAB-compressed EXRs (lossy; the decoder is less hardened).
    #[arg(hide_short_help = true, long)]
    pub allow_dwa: bool,
    /// The input is the packed render targets of this layout (a built-in name or a layout file): a folder of
    /// `<target>.dds|bin|png|exr` (RenderDoc DDS saves with samples as array slices; `gbuf pack` output). A folder
    /// holding `layout.toml` needs no flag.
    #[arg(long = "input-layout", value_name = "NAME|PATH")]
    pub input_layout: Option<String>,
    /// The images are RenderDoc "slices as grid" mosaics of a multisampled target: C×R tiles, tile s (row by
    /// row) holding sample s of every pixel (`--grid 2x2` for 4× MSAA).
    #[arg(hide_short_help = true, long, value_name = "CxR", value_parser = parse_grid)]
    pub grid: Option<(u32, u32)>,
    /// For a file-set folder holding a sequence (`Depth0001.exr`, `Depth0002.exr`, …): the frame to read.
    /// `report` and `budget` read every frame when it is not given.
    #[arg(hide_short_help = true, long, value_name = "N")]
    pub frame: Option<u32>,
    /// A packed target's file, when it is not `<target>.<ext>` in the folder: `--target gbuffer_a=cap/rt1.dds`
    /// (also `coverage=FILE`, `material_table=FILE`); for a RenderDoc capture, its attachment:
    /// `--target gbuffer_a=color4`, `--target depth=depth` (default: the target with the same debug name). Repeat
    /// per target.
    #[arg(hide_short_help = true, long = "target", value_name = "NAME=FILE")]
    pub targets: Vec<String>,
    /// For a RenderDoc capture (`.rdc`): read the targets bound at this event (`gbuf info FILE.rdc --list` lists
    /// them) [default: the last draw that writes colour targets].
    #[arg(long, value_name = "EID", conflicts_with = "marker")]
    pub event: Option<u32>,
    /// For a RenderDoc capture: read the targets after the last draw inside the marker region NAME (its own name or
    /// its path, `GBuffer/rod`).
    #[arg(long, value_name = "NAME")]
    pub marker: Option<String>,
}

impl ReadArgs {
    /// How to read packed render targets (`--input-layout`/`--layout`, `--target`).
    pub fn packed(&self) -> anyhow::Result<gbuf::layout::targets::PackedInput> {
        let layout = self.input_layout.as_deref().map(gbuf::layout::Layout::by_name_or_path).transpose()?;
        Ok(gbuf::layout::targets::PackedInput { layout, targets: self.target_files()? })
    }

    /// `--target NAME=FILE`, parsed.
    fn target_files(&self) -> anyhow::Result<Vec<(String, PathBuf)>> {
        self.targets
            .iter()
            .map(|t| {
                let (name, file) = t
                    .split_once('=')
                    .with_context(|| format!("--target {t:?}: write NAME=FILE (e.g. gbuffer_a=a.dds)"))?;
                Ok((name.trim().to_string(), PathBuf::from(file.trim())))
            })
            .collect()
    }

    /// Loads one input of any kind through the library's one door ([`gbuf::load`]).
    pub fn load(&self, path: &std::path::Path) -> anyhow::Result<Loaded> {
        Ok(gbuf::load(path, &self.options_with_targets()?)?)
    }

    /// [`ReadArgs::options`] with the packed-targets flags (`--input-layout`, `--target`) that only [`gbuf::load`]
    /// reads.
    fn options_with_targets(&self) -> anyhow::Result<LoadOptions> {
        Ok(LoadOptions { input_layout: self.input_layout.clone(), targets: self.target_files()?, ..self.options()? })
    }

    /// Library load options from the flags.
    pub fn options(&self) -> anyhow::Result<LoadOptions> {
        let gbuf::io::mapped::MapSpec { channels: map, files } = match &self.map {
            Some(spec) => gbuf::io::mapped::parse_map(spec).map_err(|e| anyhow::anyhow!(e))?,
            None => Default::default(),
        };
        Ok(LoadOptions {
            // The packed-targets flags only `gbuf::load` reads: `options_with_targets`.
            input_layout: None,
            targets: Vec::new(),
            sidecar: self.scene.clone(),
            no_sidecar: self.no_scene,
            capture: gbuf::io::rdc::Selection { event: self.event, marker: self.marker.clone() },
            fold: self.fold,
            map,
            files,
            preset: self.preset.clone(),
            conventions: gbuf::io::conventions::Overrides {
                space: self.space,
                depth: self.depth,
                reversed_z: self.reversed_z,
                znear: self.znear,
                zfar: self.zfar,
                ids: self.id_encoding,
                background: self
                    .background
                    .as_deref()
                    .map(gbuf::io::conventions::Background::parse)
                    .transpose()
                    .map_err(|e| anyhow::anyhow!("--background: {e}"))?,
                normals: self.normals,
            },
            limits: read_limits(self.max_memory, self.allow_dwa),
            frame: self.frame,
            grid: self.grid,
        })
    }
}

/// `CxR` (also `C×R`): the tiles of a `--grid` mosaic.
fn parse_grid(s: &str) -> Result<(u32, u32), String> {
    let (c, r) = s.split_once(['x', 'X', '×']).ok_or_else(|| format!("{s:?}: write CxR, e.g. 2x2"))?;
    let n =
        |t: &str| t.trim().parse::<u32>().ok().filter(|v| *v > 0).ok_or_else(|| format!("{s:?}: write CxR, e.g. 2x2"));
    Ok((n(c)?, n(r)?))
}

/// The read limits of `--max-memory MIB` (default: the machine's share) and `--allow-dwa`.
pub fn read_limits(max_memory: Option<u64>, allow_dwa: bool) -> ReadLimits {
    ReadLimits {
        max_bytes: max_memory.map_or_else(ReadLimits::machine_max_bytes, |m| m.saturating_mul(1 << 20)),
        allow_dwa,
    }
}

/// How to read the input dump.
#[derive(clap::Args, Debug, Clone)]
pub struct InputArgs {
    /// The dump: canonical/Blender/Mitsuba EXR or ISPC `deferred` .bin.
    pub file: PathBuf,
    /// How to read it.
    #[command(flatten, next_help_heading = "Input")]
    pub read: ReadArgs,
}

impl InputArgs {
    /// Library load options from the flags.
    pub fn options(&self) -> anyhow::Result<LoadOptions> {
        self.read.options()
    }

    /// Loads the dump and prints its plausibility warnings on stderr.
    pub fn load(&self) -> anyhow::Result<Loaded> {
        let loaded = self.read.load(&self.file)?;
        print_warnings(&self.file, &loaded);
        Ok(loaded)
    }

    /// The dump as its own arrays, when it is one the resolve reads band by band (an ISPC `.bin`, not folded or
    /// remapped: [`gbuf::io::open_packed`]); `None`: [`InputArgs::load`] it. Its checks run after the lighting
    /// ([`InputArgs::check_packed`]).
    pub fn open_packed(&self) -> anyhow::Result<Option<gbuf::io::PackedDump>> {
        let input = self.read.packed()?;
        if input.is_given() || gbuf::layout::targets::is_packed_dir(&self.file) {
            return Ok(None);
        }
        // SAFETY: the command line maps the `.bin` it lights and accepts the hazard of every tool that maps its
        // input: a file changed or truncated by another process during the run (docs/DECISIONS.md, "Mapping a .bin").
        Ok(unsafe { gbuf::io::open_packed_mapped(&self.file, &self.options()?)? })
    }

    /// Runs an opened dump's checks ([`gbuf::io::PackedDump::check`], on the bands the resolve decoded) and prints
    /// their warnings on stderr.
    pub fn check_packed(&self, dump: &mut gbuf::io::PackedDump) -> anyhow::Result<()> {
        dump.check()?;
        print_warnings(&self.file, &dump.loaded);
        Ok(())
    }

    /// Reads another file (a companion of the dump) with the same flags.
    pub fn load_path(&self, path: &std::path::Path) -> anyhow::Result<Loaded> {
        let loaded = self.read.load(path)?;
        print_warnings(path, &loaded);
        Ok(loaded)
    }
}

/// Prints a loaded dump's plausibility warnings on stderr (`warning: FILE: …`).
pub fn print_warnings(file: &std::path::Path, loaded: &Loaded) {
    for w in &loaded.warnings {
        eprintln!("warning: {}: {}", file.display(), w.message);
    }
}

/// Point lights scattered on a frame that brings none (report, budget, pipelines, vrs, compare).
pub const DEFAULT_LIGHTS: usize = 64;

/// Lights of a loaded frame ([`gbuf::scene::choose_lights`]): `--lights N` scattered when given, else the dump's or
/// sidecar's, else [`DEFAULT_LIGHTS`] scattered.
pub fn frame_lights(loaded: &gbuf::io::Loaded, n: Option<u32>, seed: u64) -> (Vec<gbuf::Light>, String) {
    let (lights, source) = gbuf::scene::choose_lights(
        &loaded.gbuffer,
        loaded.lights.as_deref(),
        n.map(|n| n as usize),
        Some(DEFAULT_LIGHTS),
        seed,
    )
    .expect("a fallback light count");
    (lights, source.to_string())
}

/// `--lights N --seed S`: which lights light a frame ([`frame_lights`]).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct LightsArgs {
    /// Scatter N point lights (replacing the dump's own, if any); without it, the dump's or sidecar's lights, or 64
    /// scattered when it brings none.
    #[arg(long, value_name = "N")]
    pub lights: Option<u32>,
    /// Seed of the scattered lights.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

impl LightsArgs {
    /// The lights of `loaded` and where they come from.
    #[must_use]
    pub fn of(&self, loaded: &gbuf::io::Loaded) -> (Vec<gbuf::Light>, String) {
        frame_lights(loaded, self.lights, self.seed)
    }
}

/// One frame of several: a dump, or frame `frame` of a file-set folder holding a sequence.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct FrameRef {
    /// The dump or folder.
    pub path: PathBuf,
    /// The frame of a sequence folder.
    pub frame: Option<u32>,
}

impl FrameRef {
    /// `path` or `path (frame N)`.
    pub fn name(&self) -> String {
        match self.frame {
            Some(n) => format!("{} (frame {n})", self.path.display()),
            None => self.path.display().to_string(),
        }
    }
}

/// Several dumps (the frames of a capture), read one after another.
#[derive(clap::Args, Debug, Clone)]
pub struct FramesArgs {
    /// The dumps: files, directories (every .exr and .bin file in them, sorted) or glob patterns (`'cap/*.exr'`).
    #[arg(required = true, num_args = 1.., value_name = "FILE")]
    pub files: Vec<PathBuf>,
    /// How to read them (`--scene` only with a single dump: each frame's sidecar is found beside it).
    #[command(flatten, next_help_heading = "Input")]
    pub read: ReadArgs,
}

impl FramesArgs {
    /// The frames, expanded and checked: every path exists, none twice; a file-set folder holding a sequence is
    /// one frame per number (or the `--frame` given).
    pub fn frames(&self) -> anyhow::Result<Vec<FrameRef>> {
        let mut out = Vec::new();
        for path in self.paths()? {
            let frames = if path.is_dir() && self.read.frame.is_none() {
                gbuf::io::fileset::frames_in(&path).unwrap_or_default()
            } else {
                Vec::new()
            };
            if frames.is_empty() || !gbuf::io::fileset::looks_like_file_set(&path) {
                out.push(FrameRef { path, frame: self.read.frame });
            } else {
                out.extend(frames.into_iter().map(|n| FrameRef { path: path.clone(), frame: Some(n) }));
            }
        }
        Ok(out)
    }

    /// The dump paths, expanded and checked: every one exists, none twice.
    pub fn paths(&self) -> anyhow::Result<Vec<PathBuf>> {
        let mut out: Vec<PathBuf> = Vec::new();
        for p in &self.files {
            let text = p.to_string_lossy();
            let packed = |d: &std::path::Path| {
                gbuf::layout::targets::is_packed_dir(d) || (self.read.input_layout.is_some() && holds_targets(d))
            };
            if p.is_dir() && (gbuf::io::fileset::looks_like_file_set(p) || packed(p)) {
                out.push(p.clone());
            } else if p.is_dir() {
                let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                    .with_context(|| format!("reading the directory {}", p.display()))?
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|f| {
                        (f.is_file()
                            && f.extension()
                                .is_some_and(|e| e.eq_ignore_ascii_case("exr") || e.eq_ignore_ascii_case("bin")))
                            || (f.is_dir() && (gbuf::io::fileset::looks_like_file_set(f) || packed(f)))
                    })
                    .collect();
                found.sort();
                anyhow::ensure!(
                    !found.is_empty(),
                    "{}: the directory is neither a file set (LuxCore, Unreal, Unity HDRP or Blender File Output \
                     images; --preset, --map attr=FILE) nor holds .exr/.bin dumps or file-set directories",
                    p.display()
                );
                out.extend(found);
            } else if !p.exists() && text.contains(['*', '?', '[']) {
                let mut found: Vec<PathBuf> = glob::glob(&text)
                    .with_context(|| format!("bad glob pattern {text:?}"))?
                    .filter_map(std::result::Result::ok)
                    .filter(|f| f.is_file())
                    .collect();
                found.sort();
                anyhow::ensure!(!found.is_empty(), "{text}: the pattern matches no file");
                out.extend(found);
            } else {
                anyhow::ensure!(p.exists(), "{}: no such file", p.display());
                out.push(p.clone());
            }
        }
        let mut seen = std::collections::HashSet::new();
        for p in &out {
            anyhow::ensure!(seen.insert(p.clone()), "{} is given twice: each frame once", p.display());
        }
        anyhow::ensure!(
            out.len() == 1 || self.read.scene.is_none(),
            "--scene names one sidecar but {} dumps are given: put each frame's sidecar beside it as <stem>.json",
            out.len()
        );
        Ok(out)
    }

    /// Loads one of the frames.
    pub fn load(&self, frame: &FrameRef) -> anyhow::Result<Loaded> {
        let read = ReadArgs { frame: frame.frame, ..self.read.clone() };
        let loaded = read.load(&frame.path).with_context(|| format!("loading {}", frame.name()))?;
        print_warnings(&frame.path, &loaded);
        Ok(loaded)
    }

    /// Loads a companion file (e.g. `--single`) with the same flags.
    pub fn load_file(&self, path: &std::path::Path) -> anyhow::Result<Loaded> {
        let loaded = self.read.load(path).with_context(|| format!("loading {}", path.display()))?;
        print_warnings(path, &loaded);
        Ok(loaded)
    }
}

/// True when `dir` holds a file with a render target's extension (`dds`, `bin`, `png`, `exr`): with
/// `--input-layout`, such a folder is one frame of packed targets (PNG and EXR captures included, not only DDS).
fn holds_targets(dir: &std::path::Path) -> bool {
    let target = |p: &std::path::Path| {
        p.extension()
            .and_then(|x| x.to_str())
            .is_some_and(|x| gbuf::layout::targets::EXTENSIONS.iter().any(|e| e.eq_ignore_ascii_case(x)))
    };
    std::fs::read_dir(dir).is_ok_and(|mut it| it.any(|e| e.is_ok_and(|e| e.path().is_file() && target(&e.path()))))
}

/// Prints a value as pretty JSON on stdout.
pub fn print_json<T: serde::Serialize>(value: &T) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    serde_json::to_writer_pretty(&mut out, value)?;
    writeln!(out)?;
    Ok(())
}

/// Checks, before any work, that every output's folder exists and the output is no folder itself: a command that
/// would fail writing its last output fails first instead.
pub fn check_output_folders<'a>(outputs: impl IntoIterator<Item = &'a std::path::Path>) -> anyhow::Result<()> {
    for p in outputs {
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
        anyhow::ensure!(
            dir.is_dir(),
            "{}: its folder {} does not exist (nothing was written; create it or choose another path)",
            p.display(),
            dir.display()
        );
        anyhow::ensure!(!p.is_dir(), "{}: is a folder, not a file (nothing was written)", p.display());
    }
    Ok(())
}

/// The lighting model of a command that lights (`--brdf`, `--falloff`): the user's, or the data's choice
/// ([`gbuf::resolve::Lighting`]).
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct LightingArgs {
    /// BRDF: lambert, blinn-phong or ggx (default: from the frame — ggx when it stores roughness or metallic,
    /// else blinn-phong).
    #[arg(long, value_name = "B")]
    pub brdf: Option<gbuf::resolve::Brdf>,
    /// Distance falloff: linear or gltf (default: linear).
    #[arg(long, value_name = "F")]
    pub falloff: Option<gbuf::resolve::Falloff>,
}

impl LightingArgs {
    /// The lighting for a frame that stores `attributes`.
    #[must_use]
    pub fn choose(&self, attributes: &[Attribute]) -> gbuf::resolve::Lighting {
        let mut l = gbuf::resolve::Lighting::choose(self.brdf, self.falloff, attributes);
        if self.brdf.is_none() {
            l.why.push_str("; --brdf to choose another");
        } else {
            l.why = "--brdf".into();
        }
        l
    }
}

/// Prints the lighting a command lights with on stderr (stdout may be JSON).
pub fn say_lighting(l: &gbuf::resolve::Lighting) {
    eprintln!("lighting: {}", l.summary());
}

/// Detector threshold flags, shared by every command that runs a detector (flatten it into their `Args`).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ThresholdArgs {
    /// lauritzen: multiplier on |∂z/∂x| + |∂z/∂y| (default 1).
    #[arg(long, value_name = "X")]
    pub gradient_scale: Option<f32>,
    /// lauritzen: relative depth slack added to the derivative bound (default 1e-4).
    #[arg(long, value_name = "X")]
    pub depth_slack: Option<f32>,
    /// depth: relative threshold, a fraction of the view depth (default 0.02).
    #[arg(long, value_name = "X")]
    pub depth_relative: Option<f32>,
    /// depth: absolute threshold in view-space units (default 0).
    #[arg(long, value_name = "X")]
    pub depth_absolute: Option<f32>,
    /// normal and lauritzen: angle threshold in degrees (default 8.11, i.e. n_i·n_0 < 0.99).
    #[arg(long, value_name = "DEG")]
    pub normal_angle: Option<f32>,
    /// id and combined: which IDs to compare (default either).
    #[arg(long, value_name = "IDS")]
    pub ids: Option<IdSource>,
}

impl ThresholdArgs {
    /// The library configuration: defaults overridden by the flags given, validated.
    pub fn config(&self) -> anyhow::Result<DetectorConfig> {
        let d = DetectorConfig::default();
        let cfg = DetectorConfig {
            gradient_scale: self.gradient_scale.unwrap_or(d.gradient_scale),
            depth_slack: self.depth_slack.unwrap_or(d.depth_slack),
            depth_relative: self.depth_relative.unwrap_or(d.depth_relative),
            depth_absolute: self.depth_absolute.unwrap_or(d.depth_absolute),
            normal_angle_deg: self.normal_angle.unwrap_or(d.normal_angle_deg),
            ids: self.ids.unwrap_or(d.ids),
        };
        cfg.validate()?;
        Ok(cfg)
    }
}

/// `WxH` (also `W×H`): a resolution a footprint is quoted at. One parser for every command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Resolution {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl std::str::FromStr for Resolution {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(|| format!("{s:?} is not WxH, e.g. 1920x1080"))?;
        let parse = |v: &str| v.trim().parse::<u32>().ok().filter(|v| (1..=65536).contains(v));
        match (parse(w), parse(h)) {
            (Some(width), Some(height)) => Ok(Resolution { width, height }),
            _ => Err(format!("{s:?}: width and height must be integers in 1..=65536")),
        }
    }
}

/// The platforms named by `--platform`/`--fit` (`flag`), or a usage error listing the known ones.
pub fn platforms(flag: &str, names: &[String]) -> anyhow::Result<Vec<&'static gbuf::layout::limits::Platform>> {
    use gbuf::layout::limits::{Platform, PLATFORMS};
    let mut out = Vec::new();
    for name in names {
        match Platform::by_name(&name.to_ascii_lowercase()) {
            Some(p) => out.push(p),
            None => {
                let known: Vec<&str> = PLATFORMS.iter().map(|p| p.name).collect();
                crate::usage!("{flag} {name}: not a known platform; known: {}", known.join(", "))
            }
        }
    }
    Ok(out)
}
