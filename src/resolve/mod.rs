//! The CPU lighting resolve: tiled light culling, per-pixel and per-sample shading, and the reference.
