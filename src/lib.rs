//! gbuf: G-buffer encoding and MSAA analysis for deferred shading.
//!
//! The pipeline: load a dump ([`io`]) or render an analytic scene ([`scene`]) into a [`GBuffer`]; pack it with a
//! [`layout`] into real render-target words and unpack it again; find the pixels that need per-sample shading
//! ([`detect`]); light it ([`resolve`]); compare against the unquantized reference ([`measure`]); sweep and
//! summarise many layouts and detectors ([`analysis`], [`study`], [`report`]).
//!
//! In code, one frame, one layout, one detector (the examples in `examples/` do more: analyse a dump, choose a
//! layout for a byte budget, compare two images):
//!
//! ```
//! use gbuf::{detect, layout::Layout, measure, resolve, scene};
//!
//! // Load: an analytic scene here; `gbuf::load(path, &Default::default())` reads any input from disk.
//! let gb = scene::render(scene::SceneName::Room, 64, 36, 4)?;
//! let lights = scene::lights::default_lights(scene::SceneName::Room, &gb);
//! // Pack into the layout's render targets and unpack: what a renderer reading this G-buffer sees.
//! let layout = Layout::by_name("lauritzen-15").expect("a built-in layout");
//! let decoded = layout.roundtrip(&gb)?;
//! // Detect the pixels that need per-sample shading, and light the decoded G-buffer.
//! let cfg = resolve::ResolveConfig::default();
//! let mask = detect::detect(&decoded, detect::Detector::Lauritzen, &Default::default())?;
//! let lit = resolve::resolve(&decoded, &lights, &mask, &cfg)?;
//! // Compare against the f64 reference that shades every sample of the exact G-buffer.
//! let reference = resolve::reference(&gb, &lights, &cfg)?;
//! let error = measure::image::compare(&reference, &lit.image);
//! assert!(error.rmse > 0.0 && error.psnr_db > 20.0, "{error:?}");
//! # Ok::<(), gbuf::Error>(())
//! ```
#![warn(missing_docs)]

pub mod analysis;
pub mod base;
pub mod camera;
pub mod codec;
pub mod detect;
pub mod error;
pub mod gbuffer;
pub mod image;
pub mod io;
pub mod layout;
pub mod light;
pub mod measure;
pub mod report;
pub mod resolve;
pub mod scene;
pub mod study;

pub use camera::Camera;
pub use error::{Error, Result};
pub use gbuffer::{Attribute, GBuffer};
pub use light::{Light, LightKind};

/// Reads anything gbuf reads, the one door the command line, the Python module and the examples use: a dump file
/// (canonical, Blender or Mitsuba EXR, an ISPC `.bin`), a file-set folder (one image per buffer), or packed render
/// targets decoded through their layout — a folder `gbuf pack` wrote (its `layout.toml` says which), or an
/// engine's targets with [`io::LoadOptions::input_layout`]. The sidecar, folding, naming and limits of `opts`
/// apply to every kind ([`io::load`] is the dumps' reader beneath it).
///
/// ```
/// use gbuf::{layout::Layout, scene};
///
/// // A frame packed into DDS render targets, as `gbuf pack` writes them…
/// let gb = scene::render(scene::SceneName::Room, 32, 18, 4)?;
/// let layout = Layout::by_name("unreal-like").expect("a built-in layout");
/// let dir = tempfile::tempdir().expect("a temporary folder");
/// gbuf::layout::targets::write_frame(&layout, &gb, &[], dir.path())?;
/// // …read back through the one door: the folder's layout.toml says how to decode it.
/// let loaded = gbuf::load(dir.path(), &Default::default())?;
/// assert_eq!(loaded.format, gbuf::io::SourceFormat::PackedTargets);
/// assert_eq!(loaded.gbuffer.coverage, gb.coverage);
/// assert_eq!(loaded.gbuffer.normal, layout.roundtrip(&gb)?.normal);
/// # Ok::<(), gbuf::Error>(())
/// ```
pub fn load(path: impl AsRef<std::path::Path>, opts: &io::LoadOptions) -> Result<io::Loaded> {
    let path = path.as_ref();
    let input_layout = opts.input_layout.as_deref().map(layout::Layout::by_name_or_path).transpose()?;
    let input = layout::targets::PackedInput { layout: input_layout, targets: opts.targets.clone() };
    let plain = io::LoadOptions { input_layout: None, targets: Vec::new(), ..opts.clone() };
    layout::targets::load(path, &input, &plain)
}
