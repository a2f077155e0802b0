//! A linear HDR RGB image: what the resolve produces and what the measures compare.

use glam::Vec3;

/// Linear RGB, row-major, row 0 at the top.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HdrImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` linear RGB values.
    pub rgb: Vec<Vec3>,
}

impl HdrImage {
    /// A black image.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        HdrImage { width, height, rgb: vec![Vec3::ZERO; width as usize * height as usize] }
    }
}
