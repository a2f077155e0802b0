//! `gbuf`: the command-line front end. Flags and glue only; every stage is a library call.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

mod cli;

/// Large blocks (a frame's planes and images) in transparent huge pages: far fewer page faults.
#[global_allocator]
static ALLOCATOR: gbuf::base::alloc::LargePages = gbuf::base::alloc::LargePages;

/// G-buffer encoding and MSAA analysis for deferred shading.
#[derive(Parser)]
#[command(
    name = "gbuf",
    version,
    about,
    long_about = None,
    after_help = "Exit status: 0 success, 1 bad input (the message names the file and the problem), 2 usage error; \
                  `gbuf compare` follows idiff (0 pass, 1 warn, 2 fail, 3 size or kind differ, 4 file error).\n\
                  Documentation: docs/GUIDE.md; `gbuf man` prints the manual page."
)]
struct Cli {
    /// No progress bars.
    #[arg(short, long, global = true)]
    quiet: bool,
    /// Worker threads (default: one per core).
    #[arg(long, global = true, value_name = "N")]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the main job on the embedded default scene (no file needed).
    Demo(cli::demo::Args),
    /// Render an analytic scene into a canonical EXR dump plus its sidecar.
    Scene(cli::scene::Args),
    /// Describe a dump: size, samples, attributes and their sources, statistics, camera.
    Info(cli::info::Args),
    /// Normal codecs: angular error and speed for every scheme and bit count.
    Codecs(cli::codecs::Args),
    /// List the built-in G-buffer layouts with their sizes.
    Layouts(cli::layouts::Args),
    /// Pack a dump with a layout, unpack it, and report the error per attribute.
    Roundtrip(cli::roundtrip::Args),
    /// Write a dump packed with a layout as render-target files: DDS in the exact DXGI formats, MSAA samples as
    /// array slices, the material table as JSON.
    Pack(cli::pack::Args),
    /// Write any input gbuf reads (file sets, packed render targets, Blender, Mitsuba, ISPC) as the canonical EXR
    /// plus its sidecar.
    Convert(cli::convert::Args),
    /// Run an MSAA edge detector and evaluate it against ground truth.
    Edges(cli::edges::Args),
    /// Light a (packed) G-buffer on the CPU and measure its error against the reference.
    Resolve(cli::resolve::Args),
    /// Sweep layouts × detectors and write a report.
    Report(cli::report::Args),
    /// Find the best layout under a byte budget.
    Budget(cli::budget::Args),
    /// Forward, forward MSAA, forward+, deferred, light pre-pass and visibility buffer measured on one frame.
    Pipelines(cli::pipelines::Args),
    /// Shading less than once per pixel: gbuf's shading-rate image from the G-buffer per tile size, the lighting
    /// evaluations it saves and its error against the full-rate image and the reference, beside AMD FidelityFX VRS's
    /// (`ffx`), gbuf's rule previewing the full-rate image as a previous frame (`gbuffer-prev`) and the best SRI at
    /// gbuf's cost (`oracle`).
    Vrs(cli::vrs::Args),
    /// Merge the report.json of several `gbuf report` runs (one per frame) into one report.
    Merge(cli::merge::Args),
    /// This machine's limits (read bandwidth, each instruction set's multiply-add peak) and one frame of the resolve
    /// set against them, stage by stage.
    Bench(cli::bench::Args),
    /// Compare two images (EXR or PNG): FLIP's pooled statistics as NVIDIA's tool prints them, RMSE, PSNR, the
    /// largest difference, tev's relative MSE; thresholds with idiff's exit status (0 pass, 1 warn, 2 fail,
    /// 3 different size or kind, 4 file error).
    Compare(cli::compare::Args),
    /// Print a shell completion script: `gbuf completions bash > /etc/bash_completion.d/gbuf`.
    Completions {
        /// The shell.
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff): `gbuf man > gbuf.1; man ./gbuf.1`.
    Man,
}

/// Commands that read a dump and have no layout flag of their own, where `--input-layout` was once spelled
/// `--layout`: the old spelling still works there, hidden from the help and with a note, so that `--layout` always
/// names a layout a command applies (`pack`, `resolve`, `roundtrip`, `pipelines`). Not on `report`, whose list of
/// layouts to sweep is one letter away.
const OLD_INPUT_LAYOUT: [&str; 4] = ["info", "edges", "budget", "convert"];

/// The command line, with `--layout` as a hidden old spelling of `--input-layout` where it is free.
fn parse() -> Cli {
    let mut cmd = Cli::command();
    for name in OLD_INPUT_LAYOUT {
        cmd = cmd.mut_subcommand(name, |c| c.mut_arg("input_layout", |a| a.alias("layout")));
    }
    let matches = cmd.get_matches();
    if let Some((name, _)) = matches.subcommand().filter(|(n, _)| OLD_INPUT_LAYOUT.contains(n)) {
        let old = std::env::args_os().any(|a| a == "--layout" || a.to_string_lossy().starts_with("--layout="));
        if old {
            eprintln!("gbuf: note: `gbuf {name} --layout` is the old spelling of `--input-layout`; it still works");
        }
    }
    Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
}

fn main() -> ExitCode {
    let cli = parse();
    cli::set_quiet(cli.quiet);
    if let Some(n) = cli.threads {
        if n == 0 {
            eprintln!("gbuf: error: --threads must be at least 1");
            return ExitCode::from(2);
        }
        if let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(n).build_global() {
            eprintln!("gbuf: error: --threads {n}: {e}");
            return ExitCode::from(1);
        }
    }
    let result = match cli.command {
        Command::Demo(a) => cli::demo::run(a),
        Command::Bench(a) => cli::bench::run(a),
        Command::Scene(a) => cli::scene::run(a),
        Command::Info(a) => cli::info::run(a),
        Command::Codecs(a) => cli::codecs::run(a),
        Command::Layouts(a) => cli::layouts::run(a),
        Command::Roundtrip(a) => cli::roundtrip::run(a),
        Command::Pack(a) => cli::pack::run(a),
        Command::Convert(a) => cli::convert::run(a),
        Command::Edges(a) => cli::edges::run(a),
        Command::Resolve(a) => cli::resolve::run(a),
        Command::Report(a) => cli::report::run(a),
        Command::Budget(a) => cli::budget::run(a),
        Command::Merge(a) => cli::merge::run(a),
        Command::Pipelines(a) => cli::pipelines::run(a),
        Command::Vrs(a) => cli::vrs::run(a),
        Command::Compare(a) => cli::compare::run(a),
        Command::Completions { shell } => {
            clap_complete::generate(shell, &mut Cli::command(), "gbuf", &mut std::io::stdout());
            Ok(())
        }
        Command::Man => clap_mangen::Man::new(Cli::command()).render(&mut std::io::stdout()).map_err(Into::into),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) if cli::is_broken_pipe(&err) => ExitCode::SUCCESS,
        // A verdict (`gbuf compare`'s WARN/FAIL): the message, no "error".
        Err(err) if err.downcast_ref::<cli::compare::Status>().is_some_and(|s| s.code <= 2) => {
            eprintln!("gbuf: {err}");
            ExitCode::from(err.downcast_ref::<cli::compare::Status>().map_or(1, |s| s.code))
        }
        Err(err) => {
            eprintln!("gbuf: error: {err}");
            // One line per cause: an error that quotes its source already (`FILE: No such file…`) is not followed
            // by that source again.
            let mut last = err.to_string();
            for cause in err.chain().skip(1) {
                let text = cause.to_string();
                if !last.ends_with(&text) {
                    eprintln!("  caused by: {text}");
                }
                last = text;
            }
            let status = err.downcast_ref::<cli::compare::Status>().map(|s| s.code);
            ExitCode::from(status.unwrap_or(if cli::is_usage(&err) { 2 } else { 1 }))
        }
    }
}
