//! Analyse a dump: load it, pack it with every built-in layout, and print what each layout costs in the
//! G-buffer (normal angle, depth) and in the lit image against the every-sample reference.
//!
//! `cargo run --release --example analyse_dump -- fixtures/raster_4x.exr`
use gbuf::detect::{self, Detector};
use gbuf::layout::Layout;
use gbuf::{io, measure, resolve, scene};
use std::path::PathBuf;

fn main() -> Result<(), gbuf::Error> {
    let path = std::env::args_os().nth(1).map_or_else(|| PathBuf::from("fixtures/raster_4x.exr"), PathBuf::from);
    // Any input gbuf reads (a dump, a file-set folder, packed render targets) through the one door.
    let loaded = gbuf::load(&path, &io::LoadOptions::default())?;
    let gb = &loaded.gbuffer;
    // The dump's lights (sidecar or dump), else 16 scattered in its visible volume: the CLI's one rule.
    let (lights, _) = scene::choose_lights(gb, loaded.lights.as_deref(), None, Some(16), 1).expect("a fallback count");
    // The lighting model the data calls for (GGX when it stores roughness or metallic), as every command lights.
    let lighting = resolve::Lighting::choose(None, None, &gb.attributes());
    let cfg = lighting.apply(resolve::ResolveConfig::default());
    let reference = resolve::reference(gb, &lights, &cfg)?;
    println!("{}: {}×{} × {} samples, {} lights", path.display(), gb.width, gb.height, gb.samples, lights.len());
    println!("lit with {}", lighting.summary());
    println!("{:<16} {:>6} {:>12} {:>14} {:>10}", "layout", "bytes", "normal max°", "depth max rel", "PSNR dB");
    for layout in Layout::builtins() {
        let decoded = layout.roundtrip(gb)?;
        let attrs = measure::gbuffer::compare(gb, &decoded)?;
        let mask = detect::detect(&decoded, Detector::Lauritzen, &Default::default())?;
        let lit = resolve::resolve(&decoded, &lights, &mask, &cfg)?;
        let image = measure::image::compare(&reference, &lit.image);
        println!(
            "{:<16} {:>6} {:>12.3} {:>14.2e} {:>10.2}",
            layout.name(),
            layout.bytes_per_sample(),
            attrs.normal.as_ref().map_or(f64::NAN, |n| n.max_deg),
            attrs.depth.as_ref().map_or(f64::NAN, |d| d.rel_max),
            image.psnr_db
        );
    }
    Ok(())
}
