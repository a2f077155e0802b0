//! `gbuf pack DUMP --layout L -o DIR`: the dump packed with a layout, written as the render targets an engine would
//! hold: one DDS per target in its DXGI format, MSAA samples as array slices, and the material table as JSON; with
//! the layout (`layout.toml`) and the sidecar (`scene.json`) beside them, so every command reads the folder back
//! with no flags.

use super::common::InputArgs;
use anyhow::Context;
use gbuf::layout::dds::WrittenTarget;
use gbuf::layout::targets;
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
    /// The folder to write `<target>.dds` (`.bin` for formats with no DXGI twin), `material_table.json`,
    /// `layout.toml` and `scene.json` into (created if missing; every file written atomically).
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
    /// True when the input was packed targets of the same layout and their codes were copied, not re-encoded.
    codes_copied: bool,
    files: &'a [WrittenTarget],
}

/// Runs `gbuf pack`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let layout = Layout::by_name_or_path(&args.layout)?;
    let file = args.input.file.display().to_string();
    // A packed frame repacked with its own layout keeps its codes: decoding and encoding again need not give the
    // same code (a normal codec that normalises on decode; a material index re-keyed), and the engine's bits are
    // the data. The targets are read once, for the frame and its codes.
    let input = args.input.read.packed()?;
    let path = &args.input.file;
    let (loaded, codes) = match targets::input_layout(path, &input)? {
        Some(own) if own == layout => {
            let (loaded, frame) = targets::load_packed_frame(path, &layout, &input.targets, &args.input.options()?)
                .with_context(|| format!("loading {file}"))?;
            super::common::print_warnings(path, &loaded);
            (loaded, Some(frame.packed))
        }
        _ => (args.input.load().with_context(|| format!("loading {file}"))?, None),
    };
    let gb = &loaded.gbuffer;
    let lights = loaded.lights.as_deref().unwrap_or_default();
    let context = || format!("{file}: packing with layout {} into {}", layout.name(), args.out.display());
    let copied = codes.is_some();
    let files = match &codes {
        Some(packed) => targets::write_packed(&layout, packed, gb, lights, &args.out).with_context(context)?,
        None => targets::write_frame(&layout, gb, lights, &args.out).with_context(context)?,
    };
    let out = Output {
        file,
        layout: layout.name(),
        size: [gb.width, gb.height, gb.samples],
        bytes_per_sample: layout.bytes_per_sample(),
        codes_copied: copied,
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
    if copied {
        writeln!(o, "  (the input holds this layout's targets: their codes are copied, not decoded and re-encoded)")?;
    }
    for f in &files {
        let dxgi = f.dxgi_format.map_or_else(String::new, |d| format!(" (DXGI format {d})"));
        writeln!(o, "  {:<16} {:<12} {:>10} B  {}{dxgi}", f.target, f.format, f.bytes, f.path.display())?;
    }
    Ok(())
}
