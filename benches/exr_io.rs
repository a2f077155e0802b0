//! Canonical EXR write and read of a 1920×1080 × 4 dump (issue 14, target 4), each beside a baseline timed in the
//! same run:
//! - **write** (`io::canonical::write`: ZIP, parallel block compression) against writing the same number of bytes
//!   uncompressed to a file (`std::fs::write` of the raw samples: the copy and the page cache, no compression);
//!   target ≤ 1.5 s on 2 cores;
//! - **read** (`io::exr::read_raw`: every channel decoded, the part of a load that OpenEXR's reader also does) against
//!   OpenEXR's C++ reader through its Python package (`OpenEXR.File(path, separate_channels=True)`, every channel,
//!   timed inside Python so the interpreter's start is not counted); target ≤ 1.2× OpenEXR.
//!
//! Best of `GBUF_BENCH_RUNS` (default 3) runs each. Needs `python3` with `pip install openexr numpy` (as CI installs);
//! without them it fails, it does not skip. Another size: `GBUF_BENCH_SIZE=960x540x4`. Run: `cargo bench --bench exr_io`.

use gbuf::io::exr::read_raw;
use gbuf::io::ReadLimits;
use gbuf::scene::{render, SceneName};
use std::process::Command;
use std::time::Instant;

const WRITE_TARGET_S: f64 = 1.5;
const READ_TARGET_RATIO: f64 = 1.2;

fn best<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..runs {
        let t = Instant::now();
        let v = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(v);
    }
    (best, out.expect("at least one run"))
}

const OPENEXR_READ: &str = r#"
import sys, time, OpenEXR
path, runs = sys.argv[1], int(sys.argv[2])
best = float("inf")
for _ in range(runs):
    t = time.perf_counter()
    with OpenEXR.File(path, separate_channels=True) as f:
        n = sum(c.pixels.nbytes for c in f.channels().values())
    best = min(best, time.perf_counter() - t)
print(best, n)
"#;

fn main() {
    let size = std::env::var("GBUF_BENCH_SIZE").unwrap_or_else(|_| "1920x1080x4".into());
    let dims: Vec<u32> = size.split('x').filter_map(|v| v.parse().ok()).collect();
    let [w, h, s] = dims[..] else { panic!("GBUF_BENCH_SIZE={size}: expected WxHxS") };
    let name = format!("exr_io/{w}x{h}x{s}");
    let filters: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    if !filters.is_empty() && !filters.iter().any(|f| name.contains(f.as_str())) {
        return;
    }
    let runs: usize = std::env::var("GBUF_BENCH_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(3);
    let dir = tempfile::tempdir().expect("temp dir");
    let (exr, raw) = (dir.path().join("dump.exr"), dir.path().join("raw.bin"));
    let gb = render(SceneName::Room, w, h, s).expect("render");
    let threads = rayon::current_num_threads();
    println!("{name}: the room, every attribute, {threads} threads, best of {runs}");

    use gbuf::io::exr::WriteCompression;
    let mut others = Vec::new();
    for c in [WriteCompression::Piz, WriteCompression::Rle, WriteCompression::None] {
        let (t, ()) = best(runs, || gbuf::io::canonical::write_with(&exr, &gb, c).expect("write"));
        others.push((c, t, std::fs::metadata(&exr).map(|m| m.len()).unwrap_or(0) as f64 / 1e6));
    }
    let (write_s, ()) = best(runs, || gbuf::io::canonical::write(&exr, &gb).expect("write"));
    let (to_raw_s, image) = best(runs, || gbuf::io::canonical::to_raw(&gb));
    let raw_bytes: Vec<u8> = image
        .channels
        .iter()
        .flat_map(|c| match &c.data {
            gbuf::io::exr::RawData::F16(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>(),
            gbuf::io::exr::RawData::F32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            gbuf::io::exr::RawData::U32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
        })
        .collect();
    drop(image);
    let (raw_s, ()) = best(runs, || std::fs::write(&raw, &raw_bytes).expect("write raw"));
    let file_mb = std::fs::metadata(&exr).map(|m| m.len()).unwrap_or(0) as f64 / 1e6;
    let sample_mb = raw_bytes.len() as f64 / 1e6;
    drop(raw_bytes);
    drop(gb);
    println!(
        "  write: {write_s:.3} s ({sample_mb:.0} MB of samples → {file_mb:.1} MB ZIP) = {:.1}× writing the raw bytes \
         uncompressed ({raw_s:.3} s); of it {to_raw_s:.3} s making the channels; target ≤ {WRITE_TARGET_S} s: {}",
        write_s / raw_s,
        if write_s <= WRITE_TARGET_S { "met" } else { "NOT met" }
    );

    for (c, t, mb) in others {
        println!("  write --compression {c:?}: {t:.3} s, {mb:.1} MB");
    }

    let limits = ReadLimits::default();
    let (read_s, decoded) = best(runs, || read_raw(&exr, &limits).expect("read"));
    let decoded_mb = decoded.channels.iter().map(|c| c.data.len() * 4).sum::<usize>() as f64 / 1e6;
    drop(decoded);
    let out = Command::new("python3")
        .args(["-c", OPENEXR_READ])
        .arg(&exr)
        .arg(runs.to_string())
        .output()
        .expect("run python3");
    if !out.status.success() {
        eprintln!(
            "exr_io: OpenEXR's Python package failed (pip install openexr numpy): {}",
            String::from_utf8_lossy(&out.stderr)
        );
        std::process::exit(1);
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let mut it = text.split_whitespace();
    let openexr_s: f64 = it.next().and_then(|v| v.parse().ok()).expect("OpenEXR's time");
    let openexr_mb = it.next().and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0) / 1e6;
    let ratio = read_s / openexr_s;
    println!(
        "  read: gbuf {read_s:.3} s ({decoded_mb:.0} MB decoded), OpenEXR (C++, Python package) {openexr_s:.3} s \
         ({openexr_mb:.0} MB) = {ratio:.2}×; target ≤ {READ_TARGET_RATIO}×: {}",
        if ratio <= READ_TARGET_RATIO { "met" } else { "NOT met" }
    );
}
