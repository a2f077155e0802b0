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
    /// For a RenderDoc capture (`.rdc`): list its actions that write render targets, with the targets bound at
    /// each (attachment, debug name, format, size, samples), instead of reading one.
    #[arg(long)]
    pub list: bool,
}

/// `info` plus the scene's needs (see `gbuf::analysis::needs`).
#[derive(serde::Serialize)]
struct WithNeeds<'a> {
    #[serde(flatten)]
    info: &'a gbuf::io::stats::Info,
    needs: gbuf::analysis::needs::Needs,
    /// How many surfaces each pixel holds (by IDs and by geometry).
    surfaces_per_pixel: gbuf::analysis::surfaces::SurfacesPerPixel,
    /// For packed render targets: how much of each field's code space the frame uses.
    #[serde(skip_serializing_if = "Option::is_none")]
    code_space: Option<Vec<gbuf::layout::codespace::FieldCodes>>,
}

/// Runs `gbuf info`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let input = args.input.read.packed()?;
    let path = &args.input.file;
    if args.list {
        if !gbuf::io::rdc::is_capture(path) {
            anyhow::bail!(
                "{}: --list lists the actions of a RenderDoc capture (.rdc); this is not one",
                path.display()
            );
        }
        let listing = gbuf::io::rdc::list(path)?;
        if args.json {
            return print_json(&listing);
        }
        print!("{}", listing.to_text(path));
        return Ok(());
    }
    // Packed targets are read once: the decoded frame and, for the code space, their codes.
    let (loaded, code_space) = match gbuf::layout::targets::input_layout(path, &input)? {
        Some(layout) => {
            let (loaded, frame) =
                gbuf::layout::targets::load_packed_frame(path, &layout, &input.targets, &args.input.options()?)
                    .with_context(|| format!("cannot load {}", path.display()))?;
            let rows = gbuf::layout::codespace::code_space(&layout, &frame.packed, &loaded.gbuffer.coverage);
            (loaded, Some((layout.name().to_string(), rows)))
        }
        None => (args.input.read.load(path).with_context(|| format!("cannot load {}", path.display()))?, None),
    };
    // The text lists the warnings itself (WARNING lines); beside JSON they go to stderr, once.
    if args.json {
        super::common::print_warnings(path, &loaded);
    }
    let info = gbuf::io::stats::info(&loaded, &args.input.file);
    let needs = gbuf::analysis::needs_with_pruned_layout(&loaded.gbuffer);
    let surfaces = gbuf::analysis::surfaces::surfaces_per_pixel(&loaded.gbuffer);
    if args.json {
        print_json(&WithNeeds { info: &info, needs, surfaces_per_pixel: surfaces, code_space: code_space.map(|c| c.1) })
    } else {
        use std::io::Write;
        let mut out = std::io::stdout().lock();
        out.write_all(info.to_text().as_bytes())?;
        out.write_all(needs.to_text().as_bytes())?;
        out.write_all(surfaces.to_text().as_bytes())?;
        if let Some((name, rows)) = &code_space {
            writeln!(out, "code space  of layout {name}'s fields over the covered samples (no float truth: the codes are the data)")?;
            out.write_all(gbuf::layout::codespace::text(rows).as_bytes())?;
        }
        Ok(())
    }
}
