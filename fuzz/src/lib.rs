//! Shared code of gbuf's fuzz targets (docs/FUZZING.md): the panic policy, load options built from fuzz input,
//! in-memory EXR writing, generators for structure-aware targets and the seed writer.

pub mod gen;
pub mod seeds;

use gbuf::io::conventions::{Background, Overrides};
use gbuf::io::{LoadOptions, ReadLimits};
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// The most decoded bytes a fuzzed file may declare (`--max-memory 16`). gbuf's default is 4 GiB, and for
/// compressions without an expansion bound (PIZ, DWA) the exr crate allocates before reading: the image buffer (a
/// few kilobytes of PIZ declaring gigabytes, issue 16 part 2) and each chunk's buffer, as large as the chunk says up
/// to a whole block (32 lines for PIZ, 256 for DWAB, whatever the image height) before checking the file holds it.
/// libFuzzer would report out-of-memory on every such input instead of looking further. At 16 MiB a PIZ chunk
/// stays under 512 MiB, every path of the readers is still reachable, and a run stays within `-rss_limit_mb=2048`
/// — except with DWA, see [`dwa_enabled`].
/// `GBUF_FUZZ_MAX_MIB` overrides it (see [`max_declared_bytes`]).
pub const MAX_DECLARED_BYTES: u64 = 16 << 20;

/// The cap in use: [`MAX_DECLARED_BYTES`], or `GBUF_FUZZ_MAX_MIB` MiB (to reproduce what a finding does under a
/// larger `--max-memory`).
pub fn max_declared_bytes() -> u64 {
    static MAX: OnceLock<u64> = OnceLock::new();
    *MAX.get_or_init(|| {
        std::env::var("GBUF_FUZZ_MAX_MIB")
            .ok()
            .and_then(|v| v.parse::<u64>().ok())
            .map_or(MAX_DECLARED_BYTES, |m| m << 20)
    })
}

/// Header limits for fuzzing: [`max_declared_bytes`], DWA as asked (and as [`dwa_enabled`] allows).
#[must_use]
pub fn limits(allow_dwa: bool) -> ReadLimits {
    ReadLimits { max_bytes: max_declared_bytes(), allow_dwa: allow_dwa && dwa_enabled() }
}

/// May targets decode DWA (`--allow-dwa`)? Yes unless `GBUF_FUZZ_DWA=0`. A DWAB chunk may claim 256 lines × the
/// width × the pixel size, which the exr crate allocates and zeroes before finding the file shorter: a 504-byte
/// file declaring 589810×9 pixels takes 1.6 GB (fuzz/regressions/exr_raw/). Runs that decode DWA can therefore end
/// in an out-of-memory report at random; `fuzz/smoke.sh` sets `GBUF_FUZZ_DWA=0` until gbuf checks chunk sizes
/// against the file before decoding (issue 16, part 2).
pub fn dwa_enabled() -> bool {
    static ON: OnceLock<bool> = OnceLock::new();
    *ON.get_or_init(|| std::env::var("GBUF_FUZZ_DWA").map_or(true, |v| v != "0"))
}

/// gbuf's default load options, with [`max_declared_bytes`].
#[must_use]
pub fn default_options() -> LoadOptions {
    LoadOptions { limits: limits(false), ..LoadOptions::default() }
}

// ---------------------------------------------------------------------------------------------------------------
// Panic policy.
//
// libfuzzer-sys aborts at the first panic, before unwinding. gbuf catches panics of the exr crate on purpose
// (`io::exr::guarded`, its last line of defence against damaged files), so aborting there would report inputs that
// gbuf handles. Here a panic only records its report; `run` aborts (a crash for libFuzzer) when a panic unwinds out
// of gbuf, printing the report taken at the panic (message, location and, with RUST_BACKTRACE=1, the stack).
// Contained panics are counted and the first of each location is printed once; GBUF_FUZZ_STRICT=1 makes them
// crashes too (to hunt bugs in the exr crate itself).

static REPORT: Mutex<Option<String>> = Mutex::new(None);
static STRICT: OnceLock<bool> = OnceLock::new();
static CONTAINED: Mutex<Option<HashSet<String>>> = Mutex::new(None);

fn report_slot() -> std::sync::MutexGuard<'static, Option<String>> {
    REPORT.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Called once per process from each target's `init`: installs the panic hook, cleans scratch directories of
/// finished runs, and writes seeds instead of fuzzing when `GBUF_FUZZ_MAKE_SEEDS` names a directory.
pub fn init() {
    STRICT.get_or_init(|| std::env::var("GBUF_FUZZ_STRICT").is_ok_and(|v| !v.is_empty() && v != "0"));
    std::panic::set_hook(Box::new(|info| {
        let thread = std::thread::current().name().unwrap_or("<unnamed>").to_string();
        let bt = std::backtrace::Backtrace::capture();
        let mut text = format!("thread '{thread}' {info}");
        if bt.status() == std::backtrace::BacktraceStatus::Captured {
            text.push_str(&format!("\nstack backtrace:\n{bt}"));
        }
        let mut slot = report_slot();
        if slot.is_none() {
            *slot = Some(text);
        }
    }));
    clean_stale_scratch();
    if let Some(out) = std::env::var_os("GBUF_FUZZ_MAKE_SEEDS") {
        let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        match seeds::write_all(&repo, Path::new(&out)) {
            Ok(n) => {
                eprintln!("gbuf-fuzz: wrote {n} seeds under {}", Path::new(&out).display());
                std::process::exit(0);
            }
            Err(e) => {
                eprintln!("gbuf-fuzz: writing seeds failed: {e}");
                std::process::exit(1);
            }
        }
    }
}

/// Runs one input: a panic that leaves `f` is a crash; a panic contained inside it is noted (or a crash under
/// GBUF_FUZZ_STRICT).
pub fn run(f: impl FnOnce()) {
    *report_slot() = None;
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    let report = report_slot().take();
    match result {
        Err(_) => {
            eprintln!("{}", report.as_deref().unwrap_or("panic without a report"));
            eprintln!("gbuf-fuzz: the panic above escaped gbuf");
            std::process::abort();
        }
        Ok(()) => {
            if let Some(r) = report {
                contained(&r);
            }
        }
    }
}

fn contained(report: &str) {
    if *STRICT.get().unwrap_or(&false) {
        eprintln!("{report}");
        eprintln!("gbuf-fuzz: the panic above was contained by gbuf (a crash because GBUF_FUZZ_STRICT is set)");
        std::process::abort();
    }
    let first_line = report.lines().take(2).collect::<Vec<_>>().join(" ");
    let key = first_line.split(':').take(3).collect::<Vec<_>>().join(":");
    let mut seen = CONTAINED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let seen = seen.get_or_insert_with(HashSet::new);
    if seen.len() < 32 && seen.insert(key) {
        eprintln!("gbuf-fuzz: contained panic (gbuf turned it into an error): {first_line}");
    }
}

/// Drops a panic report recorded by harness code (e.g. the exr crate's writer refusing what a generator built):
/// only panics of the code under test count.
pub fn forget_panic() {
    *report_slot() = None;
}

// ---------------------------------------------------------------------------------------------------------------
// Scratch files (the sidecar is a file for `io::load_bytes`).

const SCRATCH_PREFIX: &str = "gbuf-fuzz-";

/// This process's scratch directory.
pub fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("{SCRATCH_PREFIX}{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("scratch directory");
        d
    })
}

/// Removes scratch directories whose process is gone.
fn clean_stale_scratch() {
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else { return };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = name.to_str().and_then(|n| n.strip_prefix(SCRATCH_PREFIX)) else { continue };
        if pid.parse::<u32>().is_ok() && !Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// The name the fuzzed dump goes by (no file of that name, nor its `.json` sidecar, exists).
pub fn dump_path() -> PathBuf {
    scratch().join("dump.exr")
}

/// Writes `text` as this process's sidecar file and returns its path.
pub fn sidecar_file(text: &[u8]) -> PathBuf {
    let p = scratch().join("scene.json");
    std::fs::write(&p, text).expect("writing the scratch sidecar");
    p
}

// ---------------------------------------------------------------------------------------------------------------
// Load options from text (the `load_options` target's first line; docs/FUZZING.md).

/// Load options from a line of space-separated tokens: `fold=K`, `dwa`, `max=MIB` (at most
/// [`max_declared_bytes`]), `map=SPEC`, `space=…`, `depth=…`, `reversed`, `znear=F`, `zfar=F`, `ids=…`,
/// `background=…`, `normals=…`. Unknown or malformed tokens are ignored.
#[must_use]
pub fn parse_options(line: &str, sidecar: Option<PathBuf>) -> LoadOptions {
    let mut o = default_options();
    o.sidecar = sidecar;
    let mut c = Overrides::default();
    for tok in line.split_whitespace() {
        let (k, v) = tok.split_once('=').unwrap_or((tok, ""));
        match k {
            "fold" => o.fold = v.parse().ok(),
            "dwa" => o.limits.allow_dwa = dwa_enabled(),
            "max" => {
                if let Ok(m) = v.parse::<u64>() {
                    o.limits.max_bytes = m.saturating_mul(1 << 20).min(max_declared_bytes());
                }
            }
            "map" => {
                // The CLI's own grammar; a malformed value is refused before loading, so it maps nothing here.
                if let Ok(m) = gbuf::io::mapped::parse_map(v) {
                    o.map.extend(m.channels);
                }
            }
            "space" => c.space = v.parse().ok(),
            "depth" => c.depth = v.parse().ok(),
            "reversed" => c.reversed_z = true,
            "znear" => c.znear = v.parse().ok(),
            "zfar" => c.zfar = v.parse().ok(),
            "ids" => c.ids = v.parse().ok(),
            "background" => c.background = Background::parse(v).ok(),
            "normals" => c.normals = v.parse().ok(),
            _ => {}
        }
    }
    o.conventions = c;
    o
}

/// Splits a `load_options` input `OPTIONS\nSIDECAR\0DUMP` into its parts (the sidecar is `None` when empty; without
/// a NUL after the first line the rest is the dump).
#[must_use]
pub fn split_options_input(data: &[u8]) -> (String, Option<&[u8]>, &[u8]) {
    let (line, rest) = match data.iter().position(|&b| b == b'\n') {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &data[data.len()..]),
    };
    let line = String::from_utf8_lossy(line).into_owned();
    match rest.iter().position(|&b| b == 0) {
        Some(i) => {
            let side = &rest[..i];
            (line, (!side.is_empty()).then_some(side), &rest[i + 1..])
        }
        None => (line, None, rest),
    }
}

/// With `GBUF_FUZZ_VERBOSE=1`, prints what a load gave (to check seeds: `GBUF_FUZZ_VERBOSE=1 <target> FILE…`), and
/// on success computes `gbuf info`'s statistics either way.
pub fn loaded(result: &gbuf::error::Result<gbuf::io::Loaded>, path: &Path) {
    static VERBOSE: OnceLock<bool> = OnceLock::new();
    let verbose = *VERBOSE.get_or_init(|| std::env::var("GBUF_FUZZ_VERBOSE").is_ok_and(|v| !v.is_empty() && v != "0"));
    match result {
        Ok(l) => {
            let info = gbuf::io::stats::info(l, path).to_text();
            if verbose {
                eprintln!("{info}");
                eprintln!(
                    "gbuf-fuzz: loaded {:?} {}×{}×{}, {} warnings",
                    l.format,
                    l.gbuffer.width,
                    l.gbuffer.height,
                    l.gbuffer.samples,
                    l.warnings.len()
                );
            }
        }
        Err(e) if verbose => eprintln!("gbuf-fuzz: refused: {e}"),
        Err(_) => {}
    }
}
