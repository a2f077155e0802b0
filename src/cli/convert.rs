//! `gbuf convert INPUT [input flags] -o OUT.exr`: any input gbuf reads (canonical, Blender, Mitsuba, ISPC `.bin`,
//! file sets, packed render targets through a layout) written as the canonical EXR plus its sidecar (`OUT.json`:
//! camera, lights in view space, materials): the one way to hand a decoded frame to another tool, and to check a
//! reader.

use super::common::{print_json, InputArgs};
use anyhow::Context;
use serde::Serialize;
use std::path::PathBuf;

/// Flags of `gbuf convert`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// Output EXR (canonical format); the sidecar goes beside it as `<stem>.json`.
    #[arg(short = 'o', long = "out", value_name = "OUT.exr")]
    pub out: PathBuf,
    /// EXR compression: zip, none (lossless either way).
    #[arg(long, value_name = "C", default_value = "zip")]
    pub compression: gbuf::io::exr::WriteCompression,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Output {
    input: String,
    format: gbuf::io::SourceFormat,
    exr: PathBuf,
    sidecar: PathBuf,
    size: [u32; 3],
    attributes: Vec<&'static str>,
    lights: usize,
    sanitized: Vec<(&'static str, u64, u64)>,
}

/// Runs `gbuf convert`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let sidecar = super::scene::sidecar_path(&args.out)?;
    let input = args.input.file.display().to_string();
    let loaded = args.input.load().with_context(|| format!("loading {input}"))?;
    let gb = &loaded.gbuffer;
    gbuf::io::canonical::write_with(&args.out, gb, args.compression)
        .with_context(|| format!("writing {}", args.out.display()))?;
    let lights = loaded.lights.as_deref().unwrap_or_default();
    let doc = gbuf::scene::scene_sidecar(gb, lights);
    let mut text = serde_json::to_vec_pretty(&doc).context("serialising the sidecar")?;
    text.push(b'\n');
    gbuf::base::files::write_bytes_atomic(&sidecar, &text).with_context(|| format!("writing {}", sidecar.display()))?;
    let out = Output {
        input,
        format: loaded.format,
        exr: args.out.clone(),
        sidecar,
        size: [gb.width, gb.height, gb.samples],
        attributes: gbuf::gbuffer::Attribute::ALL.into_iter().filter(|a| gb.has(*a)).map(|a| a.name()).collect(),
        lights: lights.len(),
        sanitized: loaded.sanitized.clone(),
    };
    if args.json {
        return print_json(&out);
    }
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    let format = serde_json::to_value(out.format)?;
    let format = format.as_str().unwrap_or("?");
    writeln!(o, "{} ({format} input): {}×{}×{}", out.input, out.size[0], out.size[1], out.size[2])?;
    writeln!(o, "wrote  {} and {}", out.exr.display(), out.sidecar.display())?;
    writeln!(o, "attributes {}; {} lights", out.attributes.join(", "), out.lights)?;
    Ok(())
}
