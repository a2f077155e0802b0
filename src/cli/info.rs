//! `gbuf info`: load a dump and describe it (size, samples, attributes and their sources, statistics, camera).

use crate::cli::common::{print_json, InputArgs};
use anyhow::Context;

/// Flags of `gbuf info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `info` plus the scene's needs (see `gbuf::analysis::needs`).
#[derive(serde::Serialize)]
struct WithNeeds<'a> {
    #[serde(flatten)]
    info: &'a gbuf::io::stats::Info,
    needs: gbuf::analysis::needs::Needs,
}

/// Runs `gbuf info`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let loaded = args.input.load().with_context(|| format!("cannot load {}", args.input.file.display()))?;
    let info = gbuf::io::stats::info(&loaded, &args.input.file);
    let needs = gbuf::analysis::needs_with_pruned_layout(&loaded.gbuffer);
    if args.json {
        print_json(&WithNeeds { info: &info, needs })
    } else {
        use std::io::Write;
        let mut out = std::io::stdout().lock();
        out.write_all(info.to_text().as_bytes())?;
        out.write_all(needs.to_text().as_bytes())?;
        Ok(())
    }
}
