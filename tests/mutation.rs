//! Seeded mutation test over every fixture: truncations, header byte mutations and whole-file byte mutations must
//! give an `Err` or a valid G-buffer — never a panic, never an allocation beyond the memory limit.
//!
//! A counting global allocator measures the peak bytes allocated during each load. The short version runs in
//! `cargo test`; the long one: `cargo test --release --test mutation -- --ignored`.

mod support;

use gbuf::base::rng::SplitMix64;
use gbuf::gbuffer::PlaneRef;
use gbuf::io::{load_bytes, LoadOptions, ReadLimits};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::Mutex;
use support::alloc::{CURRENT, PEAK};

/// Panics raised anywhere (including ones the loader catches around the exr decoder as a last line of defence).
static PANICS: AtomicUsize = AtomicUsize::new(0);

#[global_allocator]
static ALLOC: support::alloc::Counting = support::alloc::Counting;

/// The decoded-sample limit the loads run with.
const MAX_BYTES: u64 = 64 << 20;
/// Peak allocation a single load may reach: the decoded samples (≤ `MAX_BYTES`) exist up to ~3 times at once
/// (the exr crate's buffers, our planes, the fold), plus the file and headroom.
const MAX_PEAK: usize = 256 << 20;

/// One test at a time: the peak counter is global.
static SERIAL: Mutex<()> = Mutex::new(());

struct Fixture {
    name: String,
    bytes: Vec<u8>,
    sidecar: Option<PathBuf>,
    /// Bytes from the start that hold headers (where mutations are most dangerous).
    header_len: usize,
}

fn fixtures() -> Vec<Fixture> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut out = Vec::new();
    let mut paths: Vec<PathBuf> =
        std::fs::read_dir(&dir).map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect()).unwrap_or_default();
    paths.sort();
    for p in paths {
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext != "exr" && ext != "bin" {
            continue;
        }
        let bytes = std::fs::read(&p).unwrap();
        let sidecar = Some(p.with_extension("json")).filter(|s| s.is_file());
        out.push(Fixture {
            name: p.file_name().unwrap().to_string_lossy().into(),
            header_len: header_len(&bytes),
            bytes,
            sidecar,
        });
    }
    // Canonical files built in code: every attribute at 4 samples, and a plain 1-sample one.
    for (name, gb) in
        [("every4.exr", support::every_attribute(6, 5, 4, 9)), ("plain1.exr", support::plausible(16, 12, 1, 9))]
    {
        let bytes = support::canonical_bytes(&gb);
        out.push(Fixture { name: name.into(), header_len: header_len(&bytes), bytes, sidecar: None });
    }
    out
}

/// Header bytes: the EXR attribute list plus the start of the offset table, or the ISPC 152-byte header.
fn header_len(bytes: &[u8]) -> usize {
    if !bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        return 152.min(bytes.len());
    }
    // Walk the attributes of the first header: name\0 type\0 size value.
    let mut i = 8;
    while i < bytes.len() && bytes[i] != 0 {
        let Some(n1) = bytes[i..].iter().position(|&b| b == 0) else { break };
        let Some(n2) = bytes[i + n1 + 1..].iter().position(|&b| b == 0) else { break };
        i += n1 + n2 + 2;
        let size = i32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
        i += 4 + size;
    }
    (i + 64).min(bytes.len())
}

struct Outcome {
    ok: usize,
    err: usize,
    peak: usize,
}

fn check(fx: &Fixture, bytes: &[u8], what: &str, out: &mut Outcome) {
    let opts = LoadOptions {
        sidecar: fx.sidecar.clone(),
        limits: ReadLimits { max_bytes: MAX_BYTES, allow_dwa: false },
        ..Default::default()
    };
    let path = Path::new("/nonexistent-dir").join(&fx.name);
    let base = CURRENT.load(Relaxed);
    PEAK.store(base, Relaxed);
    let result = std::panic::catch_unwind(|| load_bytes(bytes, &path, &opts));
    let peak = PEAK.load(Relaxed).saturating_sub(base);
    out.peak = out.peak.max(peak);
    assert!(peak <= MAX_PEAK, "{}: {what}: peak allocation {peak} bytes", fx.name);
    match result {
        Err(_) => panic!("{}: {what}: the loader panicked", fx.name),
        Ok(Err(e)) => {
            let msg = e.to_string();
            assert!(
                msg.contains(&fx.name) || msg.contains(".json"),
                "{}: {what}: error without a file name: {msg}",
                fx.name
            );
            out.err += 1;
        }
        Ok(Ok(l)) => {
            let gb = &l.gbuffer;
            gb.validate().unwrap_or_else(|e| panic!("{}: {what}: invalid G-buffer: {e}", fx.name));
            for a in gb.attributes() {
                let finite = match gb.plane(a).unwrap() {
                    PlaneRef::F32(p) => p.iter().all(|v| v.is_finite()),
                    PlaneRef::Vec2(p) => p.iter().all(|v| v.is_finite()),
                    PlaneRef::Vec3(p) => p.iter().all(|v| v.is_finite()),
                    PlaneRef::U32(_) => true,
                };
                assert!(finite, "{}: {what}: non-finite {} survived", fx.name, a.name());
            }
            out.ok += 1;
        }
    }
}

/// Runs every mutation kind over every fixture. `stride` thins the truncation lengths outside the header (files of
/// at most 64 KiB are always cut at every length when `stride` is 1); `header_muts` and `file_muts` are the numbers
/// of random mutations per fixture.
fn run(stride: usize, header_muts: usize, file_muts: usize) {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let fixtures = fixtures();
    assert!(fixtures.len() >= 2);
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        PANICS.fetch_add(1, Relaxed);
        default_hook(info);
    }));
    for fx in &fixtures {
        let mut out = Outcome { ok: 0, err: 0, peak: 0 };
        check(fx, &fx.bytes, "unmodified", &mut out);
        let n = fx.bytes.len();
        let mut lengths: Vec<usize> = (0..fx.header_len.min(n)).collect();
        let stride = if stride == 1 && n > 64 << 10 { 7 } else { stride.max(1) };
        lengths.extend((fx.header_len..n).step_by(stride));
        for len in lengths {
            check(fx, &fx.bytes[..len], &format!("truncated to {len}"), &mut out);
        }
        let mut rng = SplitMix64::new(0x6275_6600 ^ n as u64);
        for (count, span) in [(header_muts, fx.header_len), (file_muts, n)] {
            for _ in 0..count {
                let mut b = fx.bytes.clone();
                let edits = 1 + rng.next_u64() % 4;
                let mut what = String::from("bytes");
                for _ in 0..edits {
                    let at = (rng.next_u64() % span as u64) as usize;
                    let v = match rng.next_u64() % 4 {
                        0 => 0xff,
                        1 => 0,
                        2 => b[at] ^ (1 << (rng.next_u64() % 8)),
                        _ => rng.next_u64() as u8,
                    };
                    b[at] = v;
                    what += &format!(" [{at}]={v:#04x}");
                }
                check(fx, &b, &what, &mut out);
            }
        }
        eprintln!(
            "{}: {} loads ok, {} refused, peak allocation {:.1} MiB",
            fx.name,
            out.ok,
            out.err,
            out.peak as f64 / (1 << 20) as f64
        );
    }
    let _ = std::panic::take_hook();
    assert_eq!(PANICS.load(Relaxed), 0, "panics inside the loader (caught, but they print and must not happen)");
}

#[test]
fn mutations_short() {
    run(997, 150, 40);
}

#[test]
#[ignore = "long (minutes): every truncation length (every 7th beyond 64 KiB) and thousands of mutations per fixture"]
fn mutations_long() {
    run(1, 20_000, 3_000);
}

/// Files that declare far more pixels than they hold are refused from the header alone: the peak allocation stays
/// tiny whether the declared size is over the limit or under it.
#[test]
fn oversized_declarations_are_refused_without_allocating() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let bytes = support::generic_exr(4, 4, &["Z"], |_, i| i as f32);
    let (mut attrs, _) = support::parse_header(&bytes);
    for (w, h) in [(100_000, 100_000), (4000, 4000), (20_000, 16)] {
        let bx: Vec<u8> = [0i32, 0, w - 1, h - 1].iter().flat_map(|v| v.to_le_bytes()).collect();
        for a in attrs.iter_mut().filter(|a| a.name == "dataWindow" || a.name == "displayWindow") {
            a.value = bx.clone();
        }
        let evil = support::rebuild(&bytes, &attrs, 0);
        let opts = LoadOptions { limits: ReadLimits { max_bytes: MAX_BYTES, allow_dwa: false }, ..Default::default() };
        let base = CURRENT.load(Relaxed);
        PEAK.store(base, Relaxed);
        let e = load_bytes(&evil, Path::new("evil.exr"), &opts).unwrap_err();
        let peak = PEAK.load(Relaxed) - base;
        assert!(peak < 1 << 20, "{w}×{h}: peak {peak} bytes before refusing ({e})");
        assert!(e.to_string().contains("evil.exr"), "{e}");
    }
}
