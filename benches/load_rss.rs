//! Peak memory of loading a large dump (issue 16, part 2): `gbuf info` on a 1920×1080 × 4 canonical EXR of the room
//! (every attribute), run as a child process so its peak resident set is the operating system's own figure
//! (`wait4`'s `ru_maxrss` of that child alone, what `/usr/bin/time -v` prints as "Maximum resident set size").
//! The dump is written by a `gbuf scene` child too: a child forked from a parent holding the G-buffer would start
//! with the parent's resident set on its account.
//!
//! Reported, all measured in the same run:
//! - the G-buffer's bytes once loaded (the planes plus coverage: bytes per sample from a 16×16 render, which has the
//!   same attributes, times the samples);
//! - the baseline: peak RSS of `gbuf info` on a 16×16 × 1 dump (the binary, its thread pool, the allocator);
//! - the peak RSS of `gbuf info` on the large dump, and `(peak − baseline) / G-buffer`, the ratio the target bounds
//!   (≤ 1.5; the baseline is the "small constant").
//!
//! Run: `cargo bench --bench load_rss` (about 30 s: rendering and writing the dump is most of it). Another size:
//! `GBUF_BENCH_SIZE=960x540x4 cargo bench --bench load_rss`. Linux and macOS only (getrusage); elsewhere it says so.
//! The process exits non-zero when the ratio is over the target, so a regression is seen, not read past.

use gbuf::scene::{render, SceneName};
use std::process::{Command, Stdio};

/// The target: peak load memory at most this many times the G-buffer, beyond the baseline process.
const TARGET_RATIO: f64 = 1.5;

/// Runs `gbuf ARGS…` as a child (output discarded) and returns its own peak RSS in bytes; panics if it fails.
#[cfg(unix)]
#[allow(clippy::zombie_processes)] // reaped by wait4 below, which std cannot know
fn child_peak_rss(args: &[&std::ffi::OsStr]) -> u64 {
    let child = Command::new(env!("CARGO_BIN_EXE_gbuf"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("run gbuf");
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: wait4 reaps our own child (std never waits for it: `child` is only dropped) and writes one `rusage`
    // into the zeroed struct we own.
    let ru = unsafe {
        let mut ru: libc::rusage = std::mem::zeroed();
        assert_eq!(libc::wait4(pid, &mut status, 0, &mut ru), pid, "wait4 failed");
        ru
    };
    assert!(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0, "gbuf {args:?} failed: status {status}");
    // Linux reports kilobytes, macOS bytes.
    let k = if cfg!(target_os = "macos") { 1 } else { 1024 };
    ru.ru_maxrss as u64 * k
}

#[cfg(unix)]
fn main() {
    let size = std::env::var("GBUF_BENCH_SIZE").unwrap_or_else(|_| "1920x1080x4".into());
    let dims: Vec<u32> = size.split('x').filter_map(|v| v.parse().ok()).collect();
    let [w, h, s] = dims[..] else { panic!("GBUF_BENCH_SIZE={size}: expected WxHxS") };
    // `cargo bench -- FILTER` passes the filter to every bench: run only when it names this one (or there is none).
    let name = format!("load_rss/{w}x{h}x{s}");
    let filters: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    if !filters.is_empty() && !filters.iter().any(|f| name.contains(f.as_str())) {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let (small, large) = (dir.path().join("small.exr"), dir.path().join("large.exr"));
    let tiny = render(SceneName::Room, 16, 16, 1).expect("render");
    gbuf::io::canonical::write(&small, &tiny).expect("write small");
    let per_sample = tiny.plane_bytes() / tiny.len();
    let bytes = per_sample * (w as usize * h as usize * s as usize);
    drop(tiny);
    let os = |v: &str| std::ffi::OsString::from(v);
    let (ws, hs, ss) = (w.to_string(), h.to_string(), s.to_string());
    let scene: Vec<std::ffi::OsString> =
        ["scene", "room", "--width", &ws, "--height", &hs, "--msaa", &ss, "-o"].iter().map(|v| os(v)).collect();
    let mut scene: Vec<&std::ffi::OsStr> = scene.iter().map(|v| v.as_os_str()).collect();
    scene.push(large.as_os_str());
    child_peak_rss(&scene);
    let file_mb = std::fs::metadata(&large).map(|m| m.len()).unwrap_or(0) as f64 / 1e6;
    let base = child_peak_rss(&[std::ffi::OsStr::new("info"), small.as_os_str()]);
    let peak = child_peak_rss(&[std::ffi::OsStr::new("info"), large.as_os_str()]);
    let mb = |b: f64| b / 1e6;
    let ratio = (peak.saturating_sub(base)) as f64 / bytes as f64;
    println!("{name}: file {file_mb:.1} MB, G-buffer {:.1} MB", mb(bytes as f64));
    println!("  baseline (gbuf info, 16×16 × 1): peak RSS {:.1} MB", mb(base as f64));
    println!(
        "  gbuf info {w}×{h} × {s}: peak RSS {:.1} MB = {:.2}× the G-buffer whole, {ratio:.2}× beyond the baseline \
         (target ≤ {TARGET_RATIO})",
        mb(peak as f64),
        peak as f64 / bytes as f64
    );
    if ratio > TARGET_RATIO {
        eprintln!("load_rss: over the target: {ratio:.2} > {TARGET_RATIO}");
        std::process::exit(1);
    }
}

#[cfg(not(unix))]
fn main() {
    eprintln!("load_rss: needs getrusage (Linux, macOS); not measured on this system");
}
