//! The shared layer: the pieces more than one stage needs, so that every stage can import them without importing
//! another stage. Nothing here imports anything of the crate but [`crate::error`].
//!
//! | module      | what                                                                              |
//! |-------------|-----------------------------------------------------------------------------------|
//! | `fastmath`  | the one branch-free `log2` / `exp2` / `pow` (the shading kernel, FLIP)                |
//! | [`isa`]     | the CPU instruction-set levels the SIMD paths are compiled for, detected once      |
//! | [`names`]   | the one spelling rule for every closed choice (flags, JSON, layout files)          |
//! | [`timing`]  | wall-clock stage timing in milliseconds                                            |
//! | `lut`       | 8-bit codes of a monotone transfer curve by thresholds (gamma 2.2, sRGB)          |
//! | [`mask`]    | [`mask::EdgeMask`]: shading evaluations per pixel, what detectors produce and the resolve reads |
//! | [`picture`] | 8-bit pictures: sRGB, the colour map, PNG files                                    |
//! | [`files`]   | atomic writes, one command's outputs staged together ([`files::Staged`]), input protection |
//! | [`rng`]     | [`rng::SplitMix64`], the deterministic generator of fixtures, lights and sweeps    |
//! | `json`      | reading back JSON's `null` for non-finite numbers                                  |
//! | `memory`    | large planes from zeroed memory                                                    |
//! | [`png`]     | the PNG encoder: bands of rows filtered and deflated in parallel                   |
//! | [`alloc`]   | the command line's global allocator: large blocks in transparent huge pages        |
//! | [`table`]   | [`table::Table`], the one way a Markdown table is written                          |

pub mod alloc;
pub(crate) mod fastmath;
pub mod files;
pub mod isa;
pub(crate) mod json;
pub(crate) mod lut;
pub mod mask;
pub(crate) mod memory;
pub mod names;
pub mod picture;
pub mod png;
pub mod rng;
pub mod table;
pub mod timing;
