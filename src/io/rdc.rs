//! RenderDoc captures (`.rdc`) as input: the render targets bound at one action, read through RenderDoc's own
//! replay.
//!
//! RenderDoc's replay API is a Python module (`renderdoc`), not a C API, so gbuf carries a small script,
//! `rdc_bridge.py` (embedded in the binary, standard library + `renderdoc` only), and runs it with a Python that
//! imports the module. The script replays the capture to the chosen action and writes every MSAA sample of every
//! bound colour target and of the depth target as DDS arrays (sample s = array slice s, rows top first, depth
//! formats as DXGI stores them) with a `manifest.json`, into a temporary folder that [`Extracted`] owns. The layout
//! code (`layout::targets`) matches the layout's targets to them, by debug name or by attachment, and reads the
//! folder as any packed-targets folder.
//!
//! Which Python: `$GBUF_RDC_PYTHON`, else `/usr/bin/python3` (where Debian's `python3-renderdoc` installs the
//! module), else `python3` on the PATH; the next is tried while one cannot import the module.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The bridge script, as shipped.
pub const BRIDGE: &str = include_str!("rdc_bridge.py");

/// The environment variable naming the Python that runs the bridge.
pub const PYTHON_VAR: &str = "GBUF_RDC_PYTHON";

/// The bridge's exit code when its Python cannot import `renderdoc`.
const EXIT_NO_MODULE: i32 = 3;

/// The first bytes of every RenderDoc capture.
const MAGIC: &[u8; 4] = b"RDOC";

/// Which action of a capture to read.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Selection {
    /// The action with this event id (`gbuf info FILE.rdc --list` lists them).
    pub event: Option<u32>,
    /// The last draw inside the marker region with this name or path (`GBuffer/rod`).
    pub marker: Option<String>,
}

/// Is `path` a RenderDoc capture (by its first bytes; a missing or short file is not)?
#[must_use]
pub fn is_capture(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 4];
    path.is_file() && std::fs::File::open(path).and_then(|mut f| f.read_exact(&mut head)).is_ok() && &head == MAGIC
}

/// A target bound at an action, as the bridge reports it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoundTarget {
    /// The colour attachment's slot (`colorN`); `None` for the depth target.
    pub slot: Option<u32>,
    /// The resource's debug name (`glObjectLabel`, `VkDebugUtils`, D3D `SetName`); empty when none was set.
    #[serde(default)]
    pub name: String,
    /// RenderDoc's format name (`R10G10B10A2_UNORM`, `D32`, …).
    pub format: String,
    /// The DXGI format the bridge writes it as; `None` when it has none (the target cannot be read).
    pub dxgi: Option<u32>,
    /// Size of the bound mip level.
    pub width: u32,
    /// Height of the bound mip level.
    pub height: u32,
    /// MSAA samples.
    pub samples: u32,
    /// The file the bridge wrote it to (extraction only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// What the bridge did to its bits (a dropped stencil, rotated depth words).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl BoundTarget {
    /// The attachment's name as `--target NAME=ATTACHMENT` spells it: `colorN` or `depth`.
    #[must_use]
    pub fn attachment(&self) -> String {
        self.slot.map_or_else(|| "depth".to_string(), |s| format!("color{s}"))
    }

    /// One line: attachment, debug name, format, size and samples.
    #[must_use]
    pub fn describe(&self) -> String {
        let name = if self.name.is_empty() { "(no debug name)".to_string() } else { format!("\"{}\"", self.name) };
        format!("{} {name} {} {}×{}×{}", self.attachment(), self.format, self.width, self.height, self.samples)
    }
}

/// One action of a capture with the targets bound at it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Action {
    /// RenderDoc's event id.
    #[serde(rename = "eventId")]
    pub event: u32,
    /// The marker path and the call (`GBuffer/rod/glDrawElementsInstanced()`).
    pub name: String,
    /// The enclosing markers' path ("" at top level).
    #[serde(default)]
    pub marker: String,
    /// RenderDoc's action flags (`Drawcall`, `Clear`, …).
    #[serde(default)]
    pub flags: Vec<String>,
    /// Bound colour targets.
    #[serde(default)]
    pub colors: Vec<BoundTarget>,
    /// The bound depth target.
    #[serde(default)]
    pub depth: Option<BoundTarget>,
}

/// What `gbuf info FILE.rdc --list` shows: the capture's actions that write targets.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Listing {
    /// The graphics API of the capture.
    pub api: String,
    /// The action read when none is named (the last draw that writes colour targets).
    pub default_event: Option<u32>,
    /// The actions, in event order.
    pub actions: Vec<Action>,
}

impl Listing {
    /// The listing as text: one line per action, its targets below it.
    #[must_use]
    pub fn to_text(&self, capture: &Path) -> String {
        let mut s =
            format!("{}: {} capture, {} actions with targets bound\n", capture.display(), self.api, self.actions.len());
        // An action's targets are shown when they differ from the previous action's (a pass binds them once).
        let mut shown: Option<(&[BoundTarget], &Option<BoundTarget>)> = None;
        for a in &self.actions {
            let default = if Some(a.event) == self.default_event { "   (read by default)" } else { "" };
            s += &format!("event {:>5}  {}{default}\n", a.event, a.name);
            if shown != Some((&a.colors, &a.depth)) {
                for t in a.colors.iter().chain(&a.depth) {
                    s += &format!("             {}\n", t.describe());
                }
                shown = Some((&a.colors, &a.depth));
            }
        }
        s += "Read one with --event EID or --marker NAME; match targets to the layout by debug name, or name them: \
              --target TARGET=colorN|depth.\n";
        s
    }
}

/// A target the bridge could not read.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Skipped {
    /// Slot (`None`: depth).
    pub slot: Option<u32>,
    /// Debug name.
    #[serde(default)]
    pub name: String,
    /// RenderDoc's format name.
    pub format: String,
    /// Why.
    pub reason: String,
}

/// The bridge's `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Graphics API.
    pub api: String,
    /// The event read.
    pub event: u32,
    /// Its action's name.
    pub action: String,
    /// Its markers' path.
    #[serde(default)]
    pub marker: String,
    /// The targets written.
    pub targets: Vec<BoundTarget>,
    /// Targets bound but not written.
    #[serde(default)]
    pub skipped: Vec<Skipped>,
}

/// The targets of one action, extracted into a temporary folder (removed when this is dropped).
#[derive(Debug)]
pub struct Extracted {
    dir: tempfile::TempDir,
    /// What was written.
    pub manifest: Manifest,
}

impl Extracted {
    /// The folder holding the targets' DDS files.
    #[must_use]
    pub fn folder(&self) -> PathBuf {
        self.dir.path().join("targets")
    }

    /// The path of a written target's file.
    #[must_use]
    pub fn file(&self, t: &BoundTarget) -> Option<PathBuf> {
        t.file.as_ref().map(|f| self.folder().join(f))
    }
}

/// Lists the actions of `capture` that write targets.
pub fn list(capture: &Path) -> Result<Listing> {
    let work = work_dir(capture)?;
    let out = run_bridge(capture, work.path(), &["list".as_ref(), capture.as_os_str()])?;
    serde_json::from_slice(&out)
        .map_err(|e| Error::Internal(format!("RenderDoc bridge: unreadable listing of {}: {e}", capture.display())))
}

/// Replays `capture` to the selected action and extracts every sample of its bound targets.
pub fn extract(capture: &Path, sel: &Selection) -> Result<Extracted> {
    let work = work_dir(capture)?;
    let folder = work.path().join("targets");
    let mut args: Vec<std::ffi::OsString> = vec!["extract".into(), capture.into(), folder.clone().into()];
    if let Some(e) = sel.event {
        args.extend(["--event".into(), e.to_string().into()]);
    }
    if let Some(m) = &sel.marker {
        args.extend(["--marker".into(), m.into()]);
    }
    let argv: Vec<&std::ffi::OsStr> = args.iter().map(std::ffi::OsString::as_os_str).collect();
    run_bridge(capture, work.path(), &argv)?;
    let text = std::fs::read(folder.join("manifest.json")).map_err(|e| {
        Error::Internal(format!(
            "RenderDoc bridge: it exited cleanly but wrote no manifest for {} ({e})",
            capture.display()
        ))
    })?;
    let manifest: Manifest = serde_json::from_slice(&text).map_err(|e| {
        Error::Internal(format!("RenderDoc bridge: unreadable manifest for {}: {e}", capture.display()))
    })?;
    Ok(Extracted { dir: work, manifest })
}

/// A temporary folder for one run of the bridge (the script and what it writes).
fn work_dir(capture: &Path) -> Result<tempfile::TempDir> {
    if !capture.is_file() {
        return Err(Error::invalid(capture, "no such file"));
    }
    if !is_capture(capture) {
        return Err(Error::invalid(capture, "not a RenderDoc capture (a .rdc starts with \"RDOC\")"));
    }
    let dir = tempfile::Builder::new().prefix("gbuf-rdc-").tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
    std::fs::write(dir.path().join("rdc_bridge.py"), BRIDGE).map_err(|e| Error::io(dir.path(), e))?;
    Ok(dir)
}

/// The environment variable giving the replay's time limit in seconds.
pub const TIMEOUT_VAR: &str = "GBUF_RDC_TIMEOUT";

/// How long one run of the bridge may take: `$GBUF_RDC_TIMEOUT` seconds, else 600 (a replay that hangs in a
/// driver must not hang the command).
fn timeout() -> u64 {
    std::env::var(TIMEOUT_VAR).ok().and_then(|v| v.trim().parse().ok()).filter(|&t| t > 0).unwrap_or(600)
}

/// Why [`wait_for`] returned no output.
enum Waited {
    TimedOut(u64),
    Io(std::io::Error),
}

/// The child's output once it exits, reading its pipes meanwhile (so a full pipe cannot stall it); killed after
/// `seconds`.
fn wait_for(mut child: std::process::Child, seconds: u64) -> std::result::Result<std::process::Output, Waited> {
    use std::io::Read;
    let drain = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut buf);
            }
            buf
        })
    };
    let stdout = drain(child.stdout.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let stderr = drain(child.stderr.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(seconds);
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status,
            Ok(None) if std::time::Instant::now() >= deadline => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(Waited::TimedOut(seconds));
            }
            Ok(None) => std::thread::sleep(std::time::Duration::from_millis(20)),
            Err(e) => return Err(Waited::Io(e)),
        }
    };
    let (stdout, stderr) = (stdout.join().unwrap_or_default(), stderr.join().unwrap_or_default());
    Ok(std::process::Output { status, stdout, stderr })
}

/// The Pythons tried, in order.
fn pythons() -> Vec<PathBuf> {
    if let Some(p) = std::env::var_os(PYTHON_VAR).filter(|p| !p.is_empty()) {
        return vec![p.into()];
    }
    vec!["/usr/bin/python3".into(), "python3".into()]
}

/// Runs the bridge with `args` (its standard output on success), trying each Python until one imports `renderdoc`.
fn run_bridge(capture: &Path, work: &Path, args: &[&std::ffi::OsStr]) -> Result<Vec<u8>> {
    let script = work.join("rdc_bridge.py");
    let mut why = Vec::new();
    for py in pythons() {
        let child = Command::new(&py)
            .arg(&script)
            .args(args)
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn();
        let child = match child {
            Ok(c) => c,
            Err(e) => {
                why.push(format!("{}: {e}", py.display()));
                continue;
            }
        };
        let out = wait_for(child, timeout()).map_err(|e| match e {
            Waited::TimedOut(t) => Error::invalid(
                capture,
                format!(
                    "RenderDoc's replay (through {}) did not finish in {t} s and was stopped; set {TIMEOUT_VAR} to \
                     wait longer",
                    py.display()
                ),
            ),
            Waited::Io(e) => Error::io(capture, e),
        })?;
        let stderr = String::from_utf8_lossy(&out.stderr);
        // The bridge's own error line, else what the process said last and how it ended (a crash in RenderDoc's
        // module prints no error line).
        let message = match stderr.lines().rev().find_map(|l| l.trim().strip_prefix("rdc_bridge: error: ")) {
            Some(m) => m.to_string(),
            None => {
                let last = stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("(nothing on stderr)");
                format!("{} ({})", last.trim(), out.status)
            }
        };
        match out.status.code() {
            Some(0) => return Ok(out.stdout),
            Some(EXIT_NO_MODULE) => why.push(format!("{}: {message}", py.display())),
            _ => {
                return Err(Error::invalid(
                    capture,
                    format!("RenderDoc's replay (through {}) failed: {message}", py.display()),
                ))
            }
        }
    }
    Err(Error::Unsupported {
        path: capture.into(),
        what: format!(
            "reading a RenderDoc capture needs RenderDoc's Python module (`renderdoc`), and no Python here imports it \
             ({}). Install it (Debian/Ubuntu: apt-get install renderdoccmd python3-renderdoc) or set {PYTHON_VAR} to \
             a Python that imports it. Without a display server, RenderDoc's OpenGL replay also needs \
             EGL_PLATFORM=surfaceless (set by gbuf's bridge when neither DISPLAY nor WAYLAND_DISPLAY is set)",
            why.join("; ")
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_child_that_does_not_finish_is_stopped() {
        let child = Command::new("sleep")
            .arg("30")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn();
        let Ok(child) = child else { return }; // no `sleep` on this system
        let t = std::time::Instant::now();
        assert!(matches!(wait_for(child, 1), Err(Waited::TimedOut(1))));
        assert!(t.elapsed() < std::time::Duration::from_secs(10));
        let child = Command::new("sh")
            .args(["-c", "echo out; echo err >&2"])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let out = wait_for(child, 10).ok().unwrap();
        assert_eq!(
            (out.stdout.as_slice(), out.stderr.as_slice(), out.status.success()),
            (&b"out\n"[..], &b"err\n"[..], true)
        );
    }

    #[test]
    fn captures_are_told_by_their_first_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let (rdc, other) = (dir.path().join("a.bin"), dir.path().join("b.rdc"));
        std::fs::write(&rdc, b"RDOC\0\0\0\0").unwrap();
        std::fs::write(&other, b"DDS ").unwrap();
        assert!(is_capture(&rdc));
        assert!(!is_capture(&other) && !is_capture(dir.path()) && !is_capture(&dir.path().join("none.rdc")));
        assert!(matches!(extract(&other, &Selection::default()), Err(Error::Invalid { .. })));
    }
}
