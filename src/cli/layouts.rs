//! `gbuf layouts`: every layout with its bytes per sample and footprint at a resolution.

use crate::cli::common::Resolution;
use anyhow::Context;
use gbuf::layout::{Layout, LayoutSummary};

/// Flags of `gbuf layouts`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Layouts to show in detail (built-in names or layout files); all built-ins when none is given.
    pub layouts: Vec<String>,
    /// Resolution the footprint is computed for, `WxH`.
    #[arg(long, value_name = "WxH", default_value = "1920x1080")]
    pub resolution: Resolution,
    /// Samples per pixel.
    #[arg(long, value_name = "S", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub msaa: u32,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
    /// Whether each layout's targets bind as one `--msaa` pass on each platform (WebGPU's bytes per sample, Vulkan's
    /// and D3D12's required formats, Metal's tile memory, AFBC): a fit table; `--platform` narrows it.
    #[arg(long, conflicts_with = "emit")]
    pub check: bool,
    /// With `--check`: only these platforms (comma-separated; `gbuf layouts --check` lists them all).
    #[arg(long, value_name = "LIST", value_delimiter = ',', requires = "check")]
    pub platform: Vec<String>,
    /// With `--check`: each layout packed from this dump, and its bytes per sample after the framebuffer-compression
    /// models (`gbuf roundtrip --layout L` gives them per target); the dump's sample count replaces `--msaa`.
    #[arg(long, value_name = "FILE", requires = "check")]
    pub dump: Option<std::path::PathBuf>,
    /// Print the one layout named as shader code instead (glsl, hlsl or wgsl): `GbufSurface`, `gbuf_pack_<target>`,
    /// `gbuf_unpack`, bit for bit what gbuf packs (docs/SHADERS.md). `renderdoc`: views for RenderDoc's texture
    /// viewer, one custom display shader per decoded attribute and the buffer viewer's format of each target, into
    /// the folder `-o DIR`.
    #[arg(long, value_name = "LANG")]
    pub emit: Option<Emit>,
    /// With `--emit`: write the code to this file instead of stdout (`renderdoc`: this folder).
    #[arg(short = 'o', long = "out", value_name = "FILE", requires = "emit")]
    pub out: Option<std::path::PathBuf>,
    /// With `--emit renderdoc`, for depth codecs that need the projection: the camera's near plane, written into
    /// the code (RenderDoc passes no uniforms of ours).
    #[arg(long, value_name = "Z", requires = "zfar")]
    pub znear: Option<f32>,
    /// With `--emit renderdoc`: the camera's far plane.
    #[arg(long, value_name = "Z", requires = "znear")]
    pub zfar: Option<f32>,
}

/// What `--emit` writes: shader code in a language, or RenderDoc views.
#[derive(Clone, Copy, Debug)]
pub enum Emit {
    /// `gbuf::layout::shader::emit` in this language.
    Code(gbuf::layout::shader::Lang),
    /// `gbuf::layout::renderdoc::views`.
    RenderDoc,
}

impl std::str::FromStr for Emit {
    type Err = String;
    fn from_str(s: &str) -> Result<Emit, String> {
        if s.eq_ignore_ascii_case("renderdoc") {
            return Ok(Emit::RenderDoc);
        }
        s.parse::<gbuf::layout::shader::Lang>()
            .map(Emit::Code)
            .map_err(|_| format!("{s:?}: not one of glsl, hlsl, wgsl, renderdoc"))
    }
}

/// Writes `layout`'s RenderDoc views into the folder `out` (every file staged, then all renamed into place).
fn emit_renderdoc(layout: &Layout, camera: Option<(f32, f32)>, out: Option<&std::path::Path>) -> anyhow::Result<()> {
    let Some(dir) = out else {
        crate::usage!("--emit renderdoc writes several files: name their folder with -o DIR");
    };
    let v = gbuf::layout::renderdoc::views(layout, camera)?;
    if v.views.is_empty() {
        anyhow::bail!("layout {:?}: no attribute can be viewed ({})", layout.name(), v.skipped.join("; "));
    }
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut staged = gbuf::base::files::Staged::default();
    for view in &v.views {
        staged.stage_bytes(&dir.join(&view.file), view.code.as_bytes())?;
    }
    let mut formats = String::from(
        "# RenderDoc buffer-viewer formats, one texel per struct (open the target with \"Open Texture data in Buffer\n\
         # Viewer\"; OpenGL rows start at the bottom). Fields show codes; the display shaders show decoded values.\n",
    );
    for (target, f) in &v.buffer_formats {
        formats += &format!("\n# {target}\n{f}\n");
    }
    staged.stage_bytes(&dir.join("buffer_formats.txt"), formats.as_bytes())?;
    staged.commit()?;
    for view in &v.views {
        println!("{}  {} of target {}", dir.join(&view.file).display(), view.attribute.name(), view.target);
    }
    println!("{}  the buffer viewer's format of each target", dir.join("buffer_formats.txt").display());
    for s in &v.skipped {
        eprintln!("warning: no view for {s}");
    }
    Ok(())
}

/// Writes `layout` as shader code in `lang` to `out` (atomically) or stdout.
pub fn emit(layout: &Layout, lang: gbuf::layout::shader::Lang, out: Option<&std::path::Path>) -> anyhow::Result<()> {
    let code = gbuf::layout::shader::emit(layout, lang)?;
    match out {
        Some(p) => gbuf::base::files::write_bytes_atomic(p, code.as_bytes())
            .with_context(|| format!("writing {}", p.display()))?,
        None => {
            use std::io::Write;
            std::io::stdout().lock().write_all(code.as_bytes())?;
        }
    }
    Ok(())
}

/// Runs `gbuf layouts`.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(lang) = args.emit {
        if args.layouts.len() != 1 {
            crate::usage!("--emit writes one layout's code: name exactly one layout (got {})", args.layouts.len());
        }
        let layout =
            Layout::by_name_or_path(&args.layouts[0]).with_context(|| format!("layout {:?}", args.layouts[0]))?;
        return match lang {
            Emit::Code(lang) => emit(&layout, lang, args.out.as_deref()),
            Emit::RenderDoc => emit_renderdoc(&layout, args.znear.zip(args.zfar), args.out.as_deref()),
        };
    }
    let detailed = !args.layouts.is_empty();
    let named: Vec<Layout> = args
        .layouts
        .iter()
        .map(|n| Layout::by_name_or_path(n).with_context(|| format!("layout {n:?}")))
        .collect::<anyhow::Result<_>>()?;
    if args.check {
        let layouts = if detailed { named } else { Layout::builtins() };
        let dump = match &args.dump {
            Some(path) => Some(
                gbuf::load(path, &Default::default()).with_context(|| format!("loading {}", path.display()))?.gbuffer,
            ),
            None => None,
        };
        let samples = dump.as_ref().map_or(args.msaa, |g| g.samples);
        return check(&layouts, &args.platform, samples, args.json, detailed, dump.as_ref());
    }
    let layouts: Vec<Layout> =
        if detailed { named } else { Layout::builtins().into_iter().chain(Layout::visibility_builtins()).collect() };
    let visibility: Vec<String> = Layout::visibility_builtins().iter().map(|l| l.name().to_string()).collect();
    let (w, h) = (args.resolution.width, args.resolution.height);
    let rows: Vec<LayoutSummary> = layouts.iter().map(|l| LayoutSummary::new(l, w, h, args.msaa)).collect();
    if args.json {
        return super::common::print_json(&rows);
    }
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    writeln!(out, "Footprints at {w}×{h}, {}× MSAA:", args.msaa)?;
    writeln!(out, "{:<16} {:>7} {:>9} {:>15} {:>10}  targets", "layout", "B/smp", "used bits", "bytes", "MiB")?;
    for (i, r) in rows.iter().enumerate() {
        if !detailed && visibility.contains(&r.name) && (i == 0 || !visibility.contains(&rows[i - 1].name)) {
            writeln!(out, "visibility buffer (IDs + depth; every surface attribute re-materialised, none stored):")?;
        }
        let targets: Vec<String> = r.targets.iter().map(|t| t.format.to_string()).collect();
        writeln!(
            out,
            "{:<16} {:>7} {:>9} {:>15} {:>10.1}  {}",
            r.name,
            r.bytes_per_sample,
            r.used_bits,
            r.footprint_bytes,
            r.footprint_mib,
            targets.join(" + ")
        )?;
    }
    if detailed {
        for r in &rows {
            writeln!(out, "\n{} — {}", r.name, r.description)?;
            for s in &r.sources {
                writeln!(out, "  source: {s}")?;
            }
            for t in &r.targets {
                writeln!(out, "  {} ({}, {} B){}", t.name, t.format, t.bytes, note(&t.note))?;
                for f in &t.fields {
                    writeln!(
                        out,
                        "    bits {:>3}..{:<3} {:<16} {:<18} [{}]{}",
                        f.offset,
                        f.offset + f.bits,
                        f.attribute,
                        f.codec,
                        f.components.join(""),
                        note(&f.note)
                    )?;
                }
            }
            if let Some((bits, params)) = &r.material_indirection {
                writeln!(out, "  material table: {bits}-bit index → {}", params.join(", "))?;
            }
            for (a, v) in &r.constants {
                writeln!(out, "  constant {a} = {v:?}")?;
            }
        }
    }
    Ok(())
}

/// One layout's fit on one platform (`--check --json`).
#[derive(serde::Serialize)]
struct FitRow {
    layout: String,
    platform: &'static str,
    fits: bool,
    /// Colour bytes per sample (WebGPU) or per pixel (Metal tile memory), where the platform has such a budget.
    color_bytes: Option<u32>,
    color_bytes_limit: Option<u32>,
    problems: Vec<String>,
    needs: Vec<&'static str>,
    /// Per target: whether Arm's AFBC can keep it compressed at this sample count.
    afbc: Vec<(String, &'static str)>,
    /// With `--dump`: bytes per sample in memory and after each compression model (`dcc`, `ccs`, `afbc`), or why the
    /// layout could not be packed.
    #[serde(skip_serializing_if = "Option::is_none")]
    compressed: Option<Result<Bytes, String>>,
}

/// A layout's bytes on a dump (`--check --dump`).
#[derive(Clone, serde::Serialize)]
struct Bytes {
    stored: f64,
    dcc: f64,
    ccs: f64,
    afbc: f64,
}

/// `layout`'s bytes per sample on `gb` after the compression models.
fn bytes_on(layout: &Layout, gb: &gbuf::gbuffer::GBuffer) -> Result<Bytes, String> {
    use gbuf::layout::compression;
    let mut targets = compression::compressed_models_of(layout, gb).map_err(|e| e.to_string())?;
    compression::fixed_rate(&mut targets, layout);
    let [dcc, ccs, afbc] = compression::bytes_per_sample(&targets, gb.len() as u64);
    Ok(Bytes { stored: layout.stored_bytes_per_sample(), dcc, ccs, afbc })
}

/// `gbuf layouts --check`: each layout's fit per platform.
fn check(
    layouts: &[Layout],
    only: &[String],
    samples: u32,
    json: bool,
    detailed: bool,
    dump: Option<&gbuf::gbuffer::GBuffer>,
) -> anyhow::Result<()> {
    use gbuf::layout::limits::{self, Afbc, PLATFORMS};
    let mut platforms = super::common::platforms("--platform", only)?;
    if platforms.is_empty() {
        platforms = PLATFORMS.iter().collect();
    }
    let mut rows = Vec::new();
    for l in layouts {
        let formats = l.formats();
        let compressed = dump.map(|gb| bytes_on(l, gb));
        let afbc: Vec<(String, &'static str)> = l
            .spec()
            .targets
            .iter()
            .zip(formats)
            .map(|(t, &f)| {
                let a = match limits::afbc(f, samples) {
                    Afbc::AllMali => "every Mali with AFBC",
                    Afbc::FromMaliG77 => "from Mali-G77",
                    Afbc::Never => "never",
                };
                (t.name.clone(), a)
            })
            .collect();
        for p in &platforms {
            let c = limits::check(p, formats, samples);
            rows.push(FitRow {
                layout: l.name().to_string(),
                platform: p.name,
                fits: c.fits(),
                color_bytes: c.color_bytes,
                color_bytes_limit: p.color_bytes_limit,
                problems: c.problems,
                needs: c.needs,
                afbc: afbc.clone(),
                compressed: compressed.clone(),
            });
        }
    }
    if json {
        return super::common::print_json(&rows);
    }
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "Fit at {samples}× MSAA (what every conforming device guarantees; ok = binds as one pass, feature = needs an \
         optional feature, no = does not):"
    )?;
    write!(out, "{:<16}", "layout")?;
    for p in &platforms {
        write!(out, " {:>13}", p.name)?;
    }
    writeln!(out)?;
    for chunk in rows.chunks(platforms.len()) {
        write!(out, "{:<16}", chunk[0].layout)?;
        for r in chunk {
            let verdict = if r.fits {
                "ok"
            } else if r.problems.is_empty() {
                "feature"
            } else {
                "no"
            };
            let cell = match (r.color_bytes, r.color_bytes_limit) {
                (Some(b), Some(l)) => format!("{verdict} {b}/{l}"),
                _ => verdict.to_string(),
            };
            write!(out, " {cell:>13}")?;
        }
        writeln!(out)?;
    }
    writeln!(out, "(n/m: colour bytes per sample on WebGPU, per pixel of tile memory on Metal, against the budget)")?;
    let why: Vec<&FitRow> = rows.iter().filter(|r| !r.fits).collect();
    if detailed || why.len() <= 24 {
        for r in why {
            let mut reasons = r.problems.clone();
            reasons.extend(r.needs.iter().map(|n| format!("needs {n}")));
            writeln!(out, "  {} on {}: {}", r.layout, r.platform, reasons.join("; "))?;
        }
    } else {
        writeln!(out, "(name layouts to see why each does not fit)")?;
    }
    if detailed {
        for chunk in rows.chunks(platforms.len()) {
            let afbc: Vec<String> = chunk[0].afbc.iter().map(|(t, a)| format!("{t} {a}")).collect();
            writeln!(out, "  {} AFBC at {samples}×: {}", chunk[0].layout, afbc.join(", "))?;
        }
    }
    if dump.is_some() {
        writeln!(
            out,
            "\nBytes per sample on the dump after framebuffer compression (models of published constraints, not a \
             vendor's compressor):\n{:<16} {:>8} {:>8} {:>8} {:>8}",
            "layout", "stored", "dcc", "ccs", "afbc"
        )?;
        for chunk in rows.chunks(platforms.len()) {
            match &chunk[0].compressed {
                Some(Ok(b)) => writeln!(
                    out,
                    "{:<16} {:>8.2} {:>8.2} {:>8.2} {:>8.2}",
                    chunk[0].layout, b.stored, b.dcc, b.ccs, b.afbc
                )?,
                Some(Err(e)) => writeln!(out, "{:<16} not packed: {e}", chunk[0].layout)?,
                None => {}
            }
        }
    }
    Ok(())
}

fn note(n: &str) -> String {
    if n.is_empty() {
        String::new()
    } else {
        format!("  — {n}")
    }
}
