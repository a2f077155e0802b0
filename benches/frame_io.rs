//! The fixed costs of every `gbuf resolve F.bin --png OUT.png` (issue 14, targets 2 and 5), each beside a baseline
//! timed in the same run, on the room at 1280×720 and 1920×1080, 1 sample, with the ISPC `.bin` it writes:
//! - **file read** (`std::fs::read` of the `.bin`), **convert** (`io::ispc::read_bytes`: the file's half floats
//!   and sphere-map normals into the G-buffer) and the whole **load** from memory (`io::load_bytes`: the conversion,
//!   then sanitising and the plausibility checks) against a memcpy of the same bytes into a fresh buffer;
//! - **8-bit encode** (`HdrImage::to_ldr_gamma22`, the ISPC sample's output) against a memcpy of the f32 image;
//! - **PNG** (`base::png`: the `png` crate at zlib level 3, adaptive filters) against the image crate's PNG encoder
//!   at its default (`Balanced`: zlib level 6, adaptive filters) and the `png` crate's `Fast` (fdeflate); with the
//!   file sizes.
//!
//! Best of `GBUF_BENCH_RUNS` (default 5) runs each. Run: `cargo bench --bench frame_io [-- 1920x1080]`.

use gbuf::io::{ispc, LoadOptions};
use gbuf::resolve::{fixture, resolve, ResolveConfig};
use image::ImageEncoder;
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn best<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..runs {
        let t = Instant::now();
        let v = black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(v);
    }
    (best * 1e3, out.expect("at least one run"))
}

fn memcpy(bytes: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(bytes.len());
    v.extend_from_slice(bytes);
    v
}

fn row(what: &str, ms: f64, base: &str, base_ms: f64) {
    println!("  {what:<34} {ms:8.2} ms   {:6.2}× {base} ({base_ms:.2} ms)", ms / base_ms);
}

fn main() {
    let filters: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    let runs: usize = std::env::var("GBUF_BENCH_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(5);
    let threads = rayon::current_num_threads();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
    let dir = tempfile::tempdir().expect("temp dir");
    for (w, h) in [(1280u32, 720u32), (1920, 1080)] {
        let name = format!("frame_io/{w}x{h}");
        if !filters.is_empty() && !filters.iter().any(|f| name.contains(f.as_str())) {
            continue;
        }
        let gb = fixture::room(w, h, 1).expect("room");
        let lights = fixture::lights_for_density(w, h, 256, 8.0, 7).expect("lights");
        let path = dir.path().join(format!("room{w}.bin"));
        ispc::write(&path, &gb, &lights).expect("write .bin");
        let bytes = std::fs::read(&path).expect("read .bin");
        let mask = gbuf::detect::baselines::none(&gb);
        let image = resolve(&gb, &lights, &mask, &ResolveConfig::default()).expect("resolve").image;
        let ldr = image.to_ldr_gamma22();
        println!("{name}: {} threads, best of {runs}; .bin {:.1} MB", threads, bytes.len() as f64 / 1e6);

        let (copy_ms, _) = best(runs, || memcpy(&bytes));
        let (read_ms, _) = best(runs, || std::fs::read(&path).expect("read"));
        row("file read (page cache)", read_ms, "memcpy", copy_ms);
        let opts = LoadOptions::default();
        let (convert_ms, loaded) =
            best(runs, || ispc::read_bytes(&bytes, Path::new("room.bin"), &opts).expect("convert"));
        assert_eq!(loaded.gbuffer.width, w);
        row("convert .bin → G-buffer", convert_ms, "memcpy", copy_ms);
        let (load_ms, _) = best(runs, || gbuf::io::load_bytes(&bytes, Path::new("room.bin"), &opts).expect("load"));
        row("load (convert, sanitise, checks)", load_ms, "memcpy", copy_ms);
        let (convert1_ms, _) =
            best(runs, || one.install(|| ispc::read_bytes(&bytes, Path::new("room.bin"), &opts).expect("convert")));
        row("convert, 1 thread", convert1_ms, &format!("{threads} threads"), convert_ms);

        let f32_bytes: &[u8] = bytemuck::cast_slice(&image.rgb);
        let (copy_img_ms, _) = best(runs, || memcpy(f32_bytes));
        let (ldr_ms, _) = best(runs, || image.to_ldr_gamma22());
        row("8-bit gamma-2.2 encode", ldr_ms, "memcpy of the f32 image", copy_img_ms);

        let (png_ms, png) = best(runs, || gbuf::base::png::encode_rgb8(w, h, &ldr).expect("png"));
        let image_crate = |level| {
            let mut out = Vec::new();
            image::codecs::png::PngEncoder::new_with_quality(&mut out, level, image::codecs::png::FilterType::Adaptive)
                .write_image(&ldr, w, h, image::ExtendedColorType::Rgb8)
                .expect("image crate png");
            out
        };
        let (crate_ms, crate_png) = best(runs, || image_crate(image::codecs::png::CompressionType::Default));
        let (fast_ms, fast_png) = best(runs, || image_crate(image::codecs::png::CompressionType::Fast));
        row("PNG (level 3)", png_ms, "image crate default (level 6)", crate_ms);
        row("PNG (level 3)", png_ms, "png crate Fast (fdeflate)", fast_ms);
        println!(
            "  PNG size: {:.3} MB (level 6 {:.3} MB, {:+.1}%; Fast {:.3} MB, {:+.1}%)",
            png.len() as f64 / 1e6,
            crate_png.len() as f64 / 1e6,
            100.0 * (png.len() as f64 / crate_png.len() as f64 - 1.0),
            fast_png.len() as f64 / 1e6,
            100.0 * (png.len() as f64 / fast_png.len() as f64 - 1.0)
        );
    }
}
