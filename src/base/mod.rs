//! The shared layer: the pieces more than one stage needs, so that every stage can import them without importing
//! another stage. Nothing here imports anything of the crate but [`crate::error`] and [`crate::util`].
//!
//! | module      | what                                                                              |
//! |-------------|-----------------------------------------------------------------------------------|
//! | `fastmath`  | the one branch-free `log2` / `exp2` / `pow` (the shading kernel, FLIP)                |
//! | [`isa`]     | the CPU instruction-set levels the SIMD paths are compiled for, detected once      |
//! | [`names`]   | the one spelling rule for every closed choice (flags, JSON, layout files)          |
//! | [`timing`]  | wall-clock stage timing in milliseconds                                            |
//! | [`lut`]     | 8-bit codes of a monotone transfer curve by thresholds (gamma 2.2, sRGB)          |
//! | [`mask`]    | [`mask::EdgeMask`]: shading evaluations per pixel, what detectors produce and the resolve reads |
//! | [`picture`] | 8-bit pictures: sRGB, the colour map, PNG files                                    |
//! | [`png`]     | the PNG encoder: bands of rows filtered and deflated in parallel                   |

pub(crate) mod fastmath;
pub mod isa;
pub mod lut;
pub mod mask;
pub mod names;
pub mod picture;
pub mod png;
pub mod timing;
