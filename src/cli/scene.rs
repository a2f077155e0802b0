//! `gbuf scene`.

/// Flags of `gbuf scene`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gbuf scene`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let _ = args.json;
    anyhow::bail!("gbuf scene is not available yet")
}
