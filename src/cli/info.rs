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

/// Runs `gbuf info`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let loaded = args.input.load().with_context(|| format!("cannot load {}", args.input.file.display()))?;
    let info = gbuf::io::stats::info(&loaded, &args.input.file);
    if args.json {
        print_json(&info)
    } else {
        use std::io::Write;
        let mut out = std::io::stdout().lock();
        out.write_all(info.to_text().as_bytes())?;
        Ok(())
    }
}
