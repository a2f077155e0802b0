//! Error metrics between G-buffers and between images.

pub mod compare;
pub mod edges;
pub mod flip;
pub mod gbuffer;
pub mod image;
pub mod machine;
pub mod roundtrip;
