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
//! // Load: an analytic scene here; `gbuf::io::load(path, &Default::default())` reads a dump from disk.
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
pub mod util;

pub use camera::Camera;
pub use error::{Error, Result};
pub use gbuffer::{Attribute, GBuffer};
pub use light::{Light, LightKind};
