//! `gbuf scene NAME -o OUT.exr [--width W --height H --msaa N] [--lights N --seed S] [--json]`: render an analytic
//! scene into our canonical EXR plus its sidecar (`OUT.json`: camera and view-space lights).

use crate::cli::common::print_json;
use anyhow::Context;
use gbuf::scene::{self, SceneName};
use gbuf::GBuffer;
use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The most lights `--lights` accepts.
const MAX_CLI_LIGHTS: usize = 1_000_000;

/// Flags of `gbuf scene`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The scene: room or stress.
    #[arg(value_parser = parse_scene)]
    pub name: SceneName,
    /// Output EXR (canonical format; the sidecar goes next to it as `<stem>.json`), or `.bin` for the ISPC
    /// `deferred` sample's input (`--msaa 1`, point lights).
    #[arg(short, long, value_name = "OUT.exr")]
    pub out: PathBuf,
    /// Image width in pixels.
    #[arg(long, default_value_t = 960, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 540, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    /// Samples per pixel, at the standard D3D/Vulkan positions.
    #[arg(long, default_value_t = 4, value_parser = parse_msaa)]
    pub msaa: u32,
    /// Scatter N point lights in the visible volume instead of the scene's default lights.
    #[arg(long, value_name = "N")]
    pub lights: Option<usize>,
    /// Seed for `--lights`.
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub seed: u64,
    /// Compression of the EXR (all lossless): zip (default) is 10× smaller than none and about as fast to write;
    /// piz and rle are slower (docs/FORMAT.md has the times and sizes).
    #[arg(long, value_name = "C", default_value = "zip")]
    pub compression: gbuf::io::exr::WriteCompression,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

fn parse_msaa(s: &str) -> Result<u32, String> {
    match s.trim().parse::<u32>() {
        Ok(n) if gbuf::gbuffer::standard_sample_positions(n).is_some() => Ok(n),
        _ => Err(format!("{s:?} samples per pixel; use 1, 2, 4, 8 or 16")),
    }
}

fn parse_scene(s: &str) -> Result<SceneName, String> {
    SceneName::from_name(s)
        .ok_or_else(|| format!("unknown scene {s:?}; known: {}", SceneName::ALL.map(SceneName::name).join(", ")))
}

/// What `gbuf scene` reports.
#[derive(serde::Serialize)]
struct Summary {
    scene: &'static str,
    exr: PathBuf,
    /// `None` for a `.bin`, whose lights are in the file.
    sidecar: Option<PathBuf>,
    width: u32,
    height: u32,
    samples: u32,
    covered_fraction: f64,
    objects: usize,
    materials: usize,
    lights: usize,
    lights_source: &'static str,
    render_seconds: f64,
    write_seconds: f64,
}

/// The sidecar path for `out`, refusing paths where the two files would collide.
pub fn sidecar_path(out: &Path) -> anyhow::Result<PathBuf> {
    if out.file_name().is_none() || out.as_os_str().to_string_lossy().ends_with('/') {
        anyhow::bail!("{}: the output must be a file name", out.display());
    }
    if out.is_dir() {
        anyhow::bail!(
            "{}: is a directory; give a file name such as {}",
            out.display(),
            out.join("scene.exr").display()
        );
    }
    let sidecar = out.with_extension("json");
    if sidecar == out {
        anyhow::bail!("{}: the EXR would be overwritten by its own sidecar; name the output .exr", out.display());
    }
    if sidecar.is_dir() {
        anyhow::bail!("{}: the sidecar path is a directory", sidecar.display());
    }
    Ok(sidecar)
}

/// Runs `gbuf scene`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let sidecar = sidecar_path(&args.out)?;
    if let Some(n) = args.lights {
        if n > MAX_CLI_LIGHTS {
            anyhow::bail!("--lights {n}: at most {MAX_CLI_LIGHTS}");
        }
    }
    let pb =
        crate::cli::spinner(format!("rendering {} at {}×{}, {}× MSAA", args.name, args.width, args.height, args.msaa));
    let t0 = Instant::now();
    let gb = scene::render(args.name, args.width, args.height, args.msaa)
        .with_context(|| format!("rendering scene {}", args.name))?;
    let render_seconds = t0.elapsed().as_secs_f64();
    pb.set_message(format!("writing {}", args.out.display()));
    let (lights, lights_source) = match args.lights {
        Some(n) => (scene::scatter_lights(&gb, n, args.seed), "scattered"),
        None => (scene::default_lights(args.name, &gb), "default"),
    };
    let t1 = Instant::now();
    // `.bin`: the ISPC `deferred` sample's input (1 sample per pixel, point lights inside the file, no sidecar), so
    // the same frame can be run through that sample's C++ and through gbuf (docs/RESOLVE.md).
    let ispc = args.out.extension().is_some_and(|e| e.eq_ignore_ascii_case("bin"));
    if ispc {
        gbuf::io::ispc::write(&args.out, &gb, &lights).with_context(|| format!("writing {}", args.out.display()))?;
    } else {
        gbuf::io::canonical::write_with(&args.out, &gb, args.compression)
            .with_context(|| format!("writing {}", args.out.display()))?;
        let doc = scene::scene_sidecar(&gb, &lights);
        let mut text = serde_json::to_vec_pretty(&doc).context("serialising the sidecar")?;
        text.push(b'\n');
        gbuf::base::files::write_bytes_atomic(&sidecar, &text)
            .with_context(|| format!("writing {}", sidecar.display()))?;
    }
    let write_seconds = t1.elapsed().as_secs_f64();
    pb.finish_and_clear();

    let summary = Summary {
        scene: args.name.name(),
        exr: args.out.clone(),
        sidecar: (!ispc).then_some(sidecar),
        width: gb.width,
        height: gb.height,
        samples: gb.samples,
        covered_fraction: covered_fraction(&gb),
        objects: distinct(gb.object_id.as_deref(), &gb.coverage),
        materials: distinct(gb.material_id.as_deref(), &gb.coverage),
        lights: lights.len(),
        lights_source,
        render_seconds,
        write_seconds,
    };
    if args.json {
        return print_json(&summary);
    }
    let mut out = std::io::stdout().lock();
    writeln!(out, "scene     {}", summary.scene)?;
    match &summary.sidecar {
        Some(s) => writeln!(out, "wrote     {} and {}", summary.exr.display(), s.display())?,
        None => writeln!(out, "wrote     {} (lights in the file)", summary.exr.display())?,
    }
    writeln!(out, "size      {}×{}, {} samples per pixel", summary.width, summary.height, summary.samples)?;
    writeln!(out, "covered   {:.1} % of samples", 100.0 * summary.covered_fraction)?;
    writeln!(out, "visible   {} objects, {} materials", summary.objects, summary.materials)?;
    writeln!(out, "lights    {} ({}, view space)", summary.lights, summary.lights_source)?;
    writeln!(out, "time      render {:.2} s, write {:.2} s", summary.render_seconds, summary.write_seconds)?;
    Ok(())
}

fn covered_fraction(gb: &GBuffer) -> f64 {
    if gb.is_empty() {
        return 0.0;
    }
    gb.coverage.iter().filter(|c| **c).count() as f64 / gb.len() as f64
}

/// Number of distinct IDs among covered samples.
fn distinct(ids: Option<&[u32]>, coverage: &[bool]) -> usize {
    ids.map_or(0, |ids| ids.iter().zip(coverage).filter(|(_, c)| **c).map(|(i, _)| *i).collect::<BTreeSet<_>>().len())
}
