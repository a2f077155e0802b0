//! Error metrics between G-buffers and between images, and timing.

pub mod edges;
pub mod gbuffer;
pub mod image;
pub mod timing;
