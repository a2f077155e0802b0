//! `gbuf roundtrip`.

/// Flags of `gbuf roundtrip`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gbuf roundtrip`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let _ = args.json;
    anyhow::bail!("gbuf roundtrip is not available yet")
}
