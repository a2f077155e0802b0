//! Error metrics between G-buffers and between images, and timing.
pub mod edges;
