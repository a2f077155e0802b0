//! `gbuf demo`.

/// Flags of `gbuf demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gbuf demo`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let _ = args.json;
    anyhow::bail!("gbuf demo is not available yet")
}
