//! Compare two HDR images (EXR with R, G, B channels) as `gbuf resolve` and `gbuf report` do: RMSE, PSNR and
//! NVIDIA's FLIP (LDR after a Reinhard tone map, and HDR over exposures). Without arguments, it lights the room
//! with two layouts, writes both images to a temporary folder and compares them.
//!
//! `cargo run --release --example compare_images -- reference.exr test.exr`
use gbuf::image::HdrImage;
use gbuf::measure::image::{error_set, Viewing};
use gbuf::{detect, io, layout::Layout, resolve, scene};
use std::path::{Path, PathBuf};

fn read_rgb(path: &Path) -> Result<HdrImage, gbuf::Error> {
    let raw = io::exr::read_raw(path, &io::exr::ReadLimits::default())?;
    let mut img = HdrImage::new(raw.width, raw.height);
    for (k, name) in ["R", "G", "B"].into_iter().enumerate() {
        let ch = raw.channel(name).ok_or_else(|| gbuf::Error::invalid(path, format!("no channel {name}")))?;
        img.rgb.iter_mut().zip(ch.data.to_f32_vec()).for_each(|(p, v)| p[k] = v);
    }
    Ok(img)
}

fn main() -> Result<(), gbuf::Error> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let (a, b) = if let [a, b] = &args[..] {
        (a.clone(), b.clone())
    } else {
        let dir = std::env::temp_dir().join(format!("gbuf-compare-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|e| gbuf::Error::io(&dir, e))?;
        let gb = scene::render(scene::SceneName::Room, 320, 180, 4)?;
        let lights = scene::default_lights(scene::SceneName::Room, &gb);
        for (name, layout) in [("fat-20.exr", "fat-20"), ("minimal-8.exr", "minimal-8")] {
            let decoded = Layout::by_name(layout).expect("built-in").roundtrip(&gb)?;
            let mask = detect::detect(&decoded, detect::Detector::Lauritzen, &Default::default())?;
            resolve::resolve(&decoded, &lights, &mask, &Default::default())?.image.write_exr(&dir.join(name))?;
        }
        (dir.join("fat-20.exr"), dir.join("minimal-8.exr"))
    };
    let (reference, test) = (read_rgb(&a)?, read_rgb(&b)?);
    let e = error_set(&reference, &test, Some(&Viewing::default()));
    println!("{} vs {}", a.display(), b.display());
    println!("RMSE {:.6}  PSNR {:.2} dB  LDR-FLIP {:?}  HDR-FLIP {:?}", e.rmse, e.psnr_db, e.flip_ldr, e.flip_hdr);
    Ok(())
}
