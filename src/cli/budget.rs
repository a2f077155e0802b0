//! `gbuf budget`.

/// Flags of `gbuf budget`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gbuf budget`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let _ = args.json;
    anyhow::bail!("gbuf budget is not available yet")
}
