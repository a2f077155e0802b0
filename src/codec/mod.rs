//! Packing schemes for single attributes: every codec maps a value to an integer code of `bits()` bits (the low
//! bits of a `u64`) and back. Layouts place those codes into render-target words.
//!
//! Every codec documents its source, its error bound, its domain, and what it does with zero, NaN and infinite
//! input. No codec ever returns NaN.

use glam::Vec3;

/// A unit-normal encoding.
pub trait NormalCodec: Send + Sync {
    /// Short kebab-case name including the bit count, e.g. `oct-16`.
    fn name(&self) -> String;
    /// Total bits per normal.
    fn bits(&self) -> u32;
    /// Encodes a (nominally unit) view-space normal.
    fn encode(&self, n: Vec3) -> u64;
    /// Decodes a code; always a finite unit vector.
    fn decode(&self, code: u64) -> Vec3;
}

/// A scalar encoding (specular, roughness, metallic, AO, specular power).
pub trait ScalarCodec: Send + Sync {
    /// Short kebab-case name, e.g. `unorm-8`.
    fn name(&self) -> String;
    /// Bits per value.
    fn bits(&self) -> u32;
    /// Encodes a value.
    fn encode(&self, v: f32) -> u64;
    /// Decodes a code; always finite.
    fn decode(&self, code: u64) -> f32;
}

/// An RGB colour encoding.
pub trait ColorCodec: Send + Sync {
    /// Short kebab-case name, e.g. `srgb8`.
    fn name(&self) -> String;
    /// Bits per colour.
    fn bits(&self) -> u32;
    /// Encodes a linear RGB colour.
    fn encode(&self, c: Vec3) -> u64;
    /// Decodes a code to linear RGB; always finite.
    fn decode(&self, code: u64) -> Vec3;
}

/// A view-depth encoding. Codecs that depend on the projection are built with the near/far planes.
pub trait DepthCodec: Send + Sync {
    /// Short kebab-case name, e.g. `unorm24`.
    fn name(&self) -> String;
    /// Bits per depth.
    fn bits(&self) -> u32;
    /// Encodes a positive view depth.
    fn encode(&self, depth: f32) -> u64;
    /// Decodes a code to view depth; always finite and positive.
    fn decode(&self, code: u64) -> f32;
}
