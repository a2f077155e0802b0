//! `gbuf demo [--out DIR] [--width W --height H --msaa S] [--json]`: renders the `room` scene in memory with its
//! default lights and runs the whole report on it. Needs no file.

use crate::cli::report::{run_and_write, FrameInput, SweepArgs};
use anyhow::Context;
use gbuf::scene::{self, SceneName};
use std::path::PathBuf;

/// Flags of `gbuf demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder (created if missing; other files in it are left alone).
    #[arg(short = 'o', long = "out", default_value = "gbuf-demo")]
    pub out: PathBuf,
    /// Image width in pixels.
    #[arg(long, default_value_t = 960, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 540, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub height: u32,
    /// MSAA samples per pixel (1, 2, 4, 8 or 16).
    #[arg(long, default_value_t = 4)]
    pub msaa: u32,
    /// What to sweep.
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gbuf demo`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let cfg = args.sweep.config()?;
    let gb = scene::render(SceneName::Room, args.width, args.height, args.msaa)
        .with_context(|| format!("rendering the room scene at {}×{} × {}", args.width, args.height, args.msaa))?;
    let lights = scene::default_lights(SceneName::Room, &gb);
    // The 1-sample render at pixel centres: the no-AA image of the pipelines section (what MLAA smooths).
    let single = if args.msaa > 1 {
        Some(scene::render(SceneName::Room, args.width, args.height, 1).context("rendering the 1-sample room")?)
    } else {
        None
    };
    let frame = FrameInput {
        name: "room (rendered in memory)".into(),
        gbuffer: gb,
        lights_source: format!("the room's {} default lights", lights.len()),
        lights,
        single,
        geometry: Some(SceneName::Room),
        notes: Vec::new(),
    };
    run_and_write(frame, &cfg, args.sweep.lighting()?, &args.out, args.json)?;
    Ok(())
}
