//! gbuf: G-buffer encoding and MSAA analysis for deferred shading.
//!
//! The pipeline: load a dump ([`io`]) or render an analytic scene ([`scene`]) into a [`GBuffer`]; pack it with a
//! [`layout`] into real render-target words and unpack it again; find the pixels that need per-sample shading
//! ([`detect`]); light it ([`resolve`]); compare against the unquantized reference ([`measure`]); and summarise
//! ([`report`]).
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
