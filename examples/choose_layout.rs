//! Choose a layout for a byte budget over several frames: the least layout error that fits, measured on every
//! frame (the worst frame decides), and the layout file to take to the engine.
//!
//! `cargo run --release --example choose_layout -- 12 fixtures/raster_4x.exr fixtures/room_4x.exr`
use gbuf::analysis::aggregate::Over;
use gbuf::analysis::budget::{self, BudgetConfig};
use gbuf::detect::Detector;
use gbuf::{io, scene};

fn main() -> Result<(), gbuf::Error> {
    let mut args = std::env::args().skip(1);
    let max_bytes: u32 = args.next().and_then(|b| b.parse().ok()).unwrap_or(12);
    let mut paths: Vec<String> = args.collect();
    if paths.is_empty() {
        paths = vec!["fixtures/raster_4x.exr".into(), "fixtures/room_4x.exr".into()];
    }
    let cfg = BudgetConfig {
        max_bytes,
        max_error: None,
        detector: Detector::Lauritzen,
        detector_config: Default::default(),
        resolve: Default::default(),
        over: Over::Worst,
        shader_code: false,
        fit: Vec::new(),
    };
    // Each frame loaded when the search needs it (twice with several frames: propose, then measure).
    let (result, _size) = budget::search_frames(
        &paths,
        |i| {
            let loaded = gbuf::load(&paths[i], &io::LoadOptions::default())?;
            let lights = loaded.lights.clone().unwrap_or_else(|| scene::scatter_lights(&loaded.gbuffer, 16, 1));
            Ok::<_, gbuf::Error>((loaded.gbuffer, lights))
        },
        &cfg,
    )?;
    let w = &result.winner;
    println!(
        "budget {max_bytes} B/sample over {} frames: {} ({} B, {})",
        paths.len(),
        w.name,
        w.bytes_per_sample,
        w.kind
    );
    println!("  worst-frame layout RMSE {:?} on {:?}; stores {}", w.rmse, w.worst_frame, w.summary);
    println!("{}", toml::to_string(&w.spec).expect("a layout spec serialises"));
    Ok(())
}
