//! The analytic scene generator: a ray caster over primitives that renders per-sample G-buffers at the standard MSAA positions.
