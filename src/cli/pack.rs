//! `gbuf pack DUMP --layout L -o DIR`: the dump packed with a layout, written as the render targets an engine would
//! hold: one DDS per target in its DXGI format, MSAA samples as array slices, and the material table as JSON.

use super::common::InputArgs;
use anyhow::Context;
use gbuf::layout::dds::{write_targets, WrittenTarget};
use gbuf::layout::Layout;
use serde::Serialize;
use std::path::PathBuf;

/// Flags of `gbuf pack`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// Layout: a built-in name (see `gbuf layouts`) or a TOML/JSON layout file.
    #[arg(long, value_name = "NAME|PATH")]
    pub layout: String,
    /// The folder to write `<target>.dds` (`.bin` for formats with no DXGI twin) and `material_table.json` into.
    #[arg(short = 'o', long = "out", value_name = "DIR")]
    pub out: PathBuf,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Output<'a> {
    file: String,
    layout: &'a str,
    size: [u32; 3],
    bytes_per_sample: usize,
    files: &'a [WrittenTarget],
}

/// Runs `gbuf pack`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let layout = Layout::by_name_or_path(&args.layout)?;
    let file = args.input.file.display().to_string();
    let loaded = args.input.load().with_context(|| format!("loading {file}"))?;
    let gb = &loaded.gbuffer;
    let packed = layout.pack(gb).with_context(|| format!("{file}: packing with layout {}", layout.name()))?;
    let files = write_targets(&packed, &args.out).with_context(|| format!("writing {}", args.out.display()))?;
    let out = Output {
        file,
        layout: layout.name(),
        size: [gb.width, gb.height, gb.samples],
        bytes_per_sample: layout.bytes_per_sample(),
        files: &files,
    };
    if args.json {
        return super::common::print_json(&out);
    }
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    writeln!(
        o,
        "{}: {}×{}×{} packed with {} ({} B/sample)",
        out.file, out.size[0], out.size[1], out.size[2], out.layout, out.bytes_per_sample
    )?;
    for f in &files {
        let dxgi = f.dxgi_format.map_or_else(String::new, |d| format!(" (DXGI format {d})"));
        writeln!(o, "  {:<16} {:<12} {:>10} B  {}{dxgi}", f.target, f.format, f.bytes, f.path.display())?;
    }
    Ok(())
}
