//! What the integration tests share, in one module (`mod support;` at the top of a test file): builders of
//! G-buffers with every attribute and adversarial values ([`io`]), a tiny analytic ray caster for the detector
//! tests ([`detect`]), tolerances of the scene tests ([`scene`]), the command helper that runs the built `gbuf`
//! binary, and the check that a Python cross-check can run.
#![allow(dead_code, unused_imports)] // each test binary uses a subset

pub mod alloc;
pub mod detect;
pub mod io;
pub mod resolve;
pub mod scene;

pub use detect::*;
pub use io::*;
pub use resolve::*;
pub use scene::*;

use std::path::Path;
use std::process::{Command, Output};

/// The built `gbuf` binary as a command.
pub fn gbuf_command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gbuf"))
}

/// Runs `gbuf args…` in `dir` and returns what it printed and its exit status.
pub fn gbuf(dir: &Path, args: &[&str]) -> Output {
    gbuf_command().current_dir(dir).args(args).output().expect("run gbuf")
}

/// Standard error of a finished command, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Can `python3` import every module of `modules` (e.g. `"OpenEXR, numpy"`)? A cross-check that cannot run is a
/// failure in CI (`CI` set, as `.ci/run` runs): there the answer must be yes, so this panics instead of
/// letting the test skip. Elsewhere it says so on stderr and returns false.
pub fn python_has(modules: &str) -> bool {
    let ok =
        Command::new("python3").args(["-c", &format!("import {modules}")]).output().is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but python3 cannot import {modules}: the cross-check must run in CI (.ci/run installs it)"
        );
        skipped(
            &format!("python3 cannot import {modules}"),
            "python3 -m pip install openexr numpy flip-evaluator moderngl glcontext",
        );
    }
    ok
}

/// Can gbuf's RenderDoc bridge import RenderDoc's Python module (`$GBUF_RDC_PYTHON`, else `/usr/bin/python3`, else
/// `python3`, as `gbuf::io::rdc` tries them)? The same rule as [`python_has`]: required in CI, a noted skip elsewhere.
pub fn renderdoc_has() -> bool {
    let pythons: Vec<std::ffi::OsString> = match std::env::var_os("GBUF_RDC_PYTHON") {
        Some(p) => vec![p],
        None => vec!["/usr/bin/python3".into(), "python3".into()],
    };
    let imports = |py: &std::ffi::OsString| {
        let code = "import sys; sys.path.append('/usr/lib/python3/dist-packages'); import renderdoc";
        Command::new(py).args(["-c", code]).output().is_ok_and(|o| o.status.success())
    };
    let ok = pythons.iter().any(imports);
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but no Python imports RenderDoc's module: the capture tests must run in CI (.ci/run installs it)"
        );
        skipped("no Python imports RenderDoc's module", "apt-get install renderdoccmd python3-renderdoc");
    }
    ok
}

/// Is the command-line tool `tool` on the PATH (it can be started)? The same rule as [`python_has`]: required in
/// CI, a noted skip elsewhere.
pub fn tool_has(tool: &str) -> bool {
    let ok = Command::new(tool).arg("--help").output().is_ok();
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but {tool} is missing: the cross-check must run in CI (.ci/run installs it)"
        );
        skipped(&format!("{tool} is missing"), "apt-get install glslang-tools spirv-cross chromium (see .ci/run)");
    }
    ok
}

/// Says that a cross-check was skipped, past the test harness's capture (a plain write to the process's stderr, not
/// `eprintln!`), so that `cargo test` shows it without `--nocapture`: which test, why, and how to install what it
/// needs.
fn skipped(why: &str, install: &str) {
    use std::io::Write as _;
    let test = std::thread::current().name().unwrap_or("a test").to_string();
    let _ = writeln!(std::io::stderr(), "SKIPPED cross-check in {test}: {why} (required in CI; install: {install})");
}
