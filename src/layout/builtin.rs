//! The built-in layouts: one TOML file each in `src/layout/builtin/`, embedded in the binary and read by the same
//! [`LayoutSpec::parse`] as a user's layout file, so a built-in is an example of the file format and a user can
//! copy one and edit it. Each names its source; docs/LAYOUTS.md describes them with their sizes.
//!
//! Bits a real engine spends on things outside our G-buffer model (lighting accumulation, stencil, flags,
//! emissive, ambient occlusion) are `reserved` fields with a note: they count in the footprint and are written
//! as zero. Attributes a layout does not store get the constants its lighting model assumes.

use super::spec::LayoutSpec;
use std::path::Path;
use std::sync::OnceLock;

/// Every built-in layout file, in the order [`specs`] lists them.
const FILES: [(&str, &str); 8] = [
    ("fat-20.toml", include_str!("builtin/fat-20.toml")),
    ("rgba16f-2x.toml", include_str!("builtin/rgba16f-2x.toml")),
    ("lauritzen-15.toml", include_str!("builtin/lauritzen-15.toml")),
    ("destiny-96.toml", include_str!("builtin/destiny-96.toml")),
    ("bevy-deferred.toml", include_str!("builtin/bevy-deferred.toml")),
    ("unreal-like.toml", include_str!("builtin/unreal-like.toml")),
    ("minimal-8.toml", include_str!("builtin/minimal-8.toml")),
    ("reference-f32.toml", include_str!("builtin/reference-f32.toml")),
];

/// The specs of every built-in layout (parsed once).
#[must_use]
pub fn specs() -> Vec<LayoutSpec> {
    static SPECS: OnceLock<Vec<LayoutSpec>> = OnceLock::new();
    SPECS
        .get_or_init(|| {
            let path = |file: &str| Path::new("src/layout/builtin").join(file);
            FILES
                .iter()
                .map(|(file, text)| LayoutSpec::parse(&path(file), text).expect("built-in layout files parse"))
                .collect()
        })
        .clone()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_file_is_named_after_its_layout_and_validates() {
        for ((file, _), spec) in FILES.iter().zip(specs()) {
            assert_eq!(*file, format!("{}.toml", spec.name));
            assert!(!spec.sources.is_empty() && !spec.description.is_empty(), "{file}");
            crate::layout::Layout::from_spec(spec).unwrap();
        }
    }

    #[test]
    fn the_toml_files_hold_exactly_the_specs_written_before_in_rust() {
        assert_eq!(specs(), before_toml::specs());
    }

    /// The built-ins as they were written in Rust before they moved into TOML files.
    mod before_toml {
        use crate::layout::spec::{ConstantValue, FieldSpec, IndirectionSpec, LayoutSpec, TargetSpec};

        fn f(attribute: &str, codec: &str, offset: u32, bits: u32) -> FieldSpec {
            FieldSpec { attribute: attribute.into(), codec: codec.into(), offset, bits, note: String::new() }
        }

        fn reserved(offset: u32, bits: u32, note: &str) -> FieldSpec {
            FieldSpec { attribute: "reserved".into(), codec: String::new(), offset, bits, note: note.into() }
        }

        fn t(name: &str, format: &str, fields: Vec<FieldSpec>) -> TargetSpec {
            TargetSpec { name: name.into(), format: format.into(), note: String::new(), fields }
        }

        fn spec(name: &str, description: &str, sources: &[&str], targets: Vec<TargetSpec>) -> LayoutSpec {
            LayoutSpec {
                name: name.into(),
                description: description.into(),
                sources: sources.iter().map(|s| s.to_string()).collect(),
                depth_range: None,
                constants: Default::default(),
                material_indirection: None,
                targets,
            }
        }

        fn with_constants(mut s: LayoutSpec, constants: &[(&str, f32)]) -> LayoutSpec {
            s.constants = constants.iter().map(|(k, v)| (k.to_string(), ConstantValue::Scalar(*v))).collect();
            s
        }

        /// Killzone 2's 4×RGBA8 + D24S8 G-buffer: the 20-byte "fat" layout of the seeds.
        fn fat_20() -> LayoutSpec {
            let lighting = TargetSpec {
                note: "lighting accumulation RGB + intensity, written by the light pass".into(),
                ..t("lighting", "rgba8", vec![reserved(0, 32, "lighting accumulation")])
            };
            with_constants(
                spec(
                    "fat-20",
                    "Killzone 2 style: D24S8 + four RGBA8 (lighting, FP16 normal x/y, motion + specular, albedo + sun \
                     occlusion)",
                    &["Michal Valient, \"Deferred Rendering in Killzone 2\", Develop Conference 2007"],
                    vec![
                        t("depth", "d24s8", vec![f("depth", "unorm24", 0, 24), reserved(24, 8, "stencil")]),
                        lighting,
                        t("normal", "rgba8", vec![f("normal", "xy-hemi-f16-32", 0, 32)]),
                        t(
                            "motion_specular",
                            "rgba8",
                            vec![
                                f("motion.x", "snorm-8:32", 0, 8),
                                f("motion.y", "snorm-8:32", 8, 8),
                                f("specular_power", "log2-unorm-8", 16, 8),
                                f("specular", "unorm-8", 24, 8),
                            ],
                        ),
                        t("albedo", "rgba8", vec![f("albedo", "unorm8", 0, 24), reserved(24, 8, "sun occlusion")]),
                    ],
                ),
                &[("roughness", 0.5), ("metallic", 0.0)],
            )
        }

        /// Two RGBA16F targets plus a float depth buffer.
        fn rgba16f_2x() -> LayoutSpec {
            with_constants(
                spec(
                    "rgba16f-2x",
                    "2×RGBA16F (diffuse + roughness; normal xyz + index of refraction) over a D32F depth buffer",
                    &["the seeds' 2×RGBA16F layout; FP16 G-buffers as in Engel, \"Light Pre-Pass Renderer\", 2008"],
                    vec![
                        t("depth", "d32f", vec![f("depth", "f32", 0, 32)]),
                        t(
                            "diffuse_roughness",
                            "rgba16f",
                            vec![f("albedo", "f16", 0, 48), f("roughness", "f16", 48, 16)],
                        ),
                        t(
                            "normal_ior",
                            "rgba16f",
                            vec![f("normal", "xyz-f16-48", 0, 48), reserved(48, 16, "index of refraction")],
                        ),
                    ],
                ),
                &[("specular", 0.5), ("metallic", 0.0)],
            )
        }

        /// The ISPC `deferred` example's 15-byte G-buffer (Lauritzen's tiled deferred demo).
        fn lauritzen_15() -> LayoutSpec {
            with_constants(
                spec(
                    "lauritzen-15",
                    "Lauritzen / ISPC deferred: f32 depth, spheremap f16×2 normal, f16 specular amount + power, RGB8 albedo",
                    &[
                        "Andrew Lauritzen, \"Deferred Rendering for Current and Future Rendering Pipelines\", SIGGRAPH 2010 \
                         Beyond Programmable Shading",
                        "Intel ISPC, examples/deferred (kernels.ispc, InputDataArrays: zBuffer, normalEncoded_x/_y, \
                         specularAmount, specularPower, albedo_x/_y/_z)",
                    ],
                    vec![
                        t("depth", "r32f", vec![f("depth", "f32", 0, 32)]),
                        t("normal", "rg16f", vec![f("normal", "spheremap-cry-f16-32", 0, 32)]),
                        t("specular", "rg16f", vec![f("specular", "f16", 0, 16), f("specular_power", "f16", 16, 16)]),
                        t("albedo", "rgb8", vec![f("albedo", "unorm8", 0, 24)]),
                    ],
                ),
                &[("roughness", 0.5), ("metallic", 0.0)],
            )
        }

        /// A Destiny-style 96-bit layout: specular parameters behind an 8-bit material index.
        fn destiny_96() -> LayoutSpec {
            let mut s = spec(
                "destiny-96",
                "Destiny style, 96 bits: D24S8 + RGBA8 (albedo + AO) + RGBA8 (oct24 normal + 8-bit material index into a \
                 table of specular/roughness/metallic tuples)",
                &["Natalya Tatarchuk, Chris Tchou, Joe Venzon, \"Destiny: From Mythic Science Fiction to Rendering in \
                   Real-Time\", SIGGRAPH 2013 Advances in Real-Time Rendering"],
                vec![
                    t("depth", "d24s8", vec![f("depth", "unorm24", 0, 24), reserved(24, 8, "stencil")]),
                    t("albedo_ao", "rgba8-srgb", vec![f("albedo", "srgb8", 0, 24), reserved(24, 8, "ambient occlusion")]),
                    t("normal_material", "rgba8", vec![f("normal", "oct-24", 0, 24), f("material_index", "", 24, 8)]),
                ],
            );
            s.material_indirection =
                Some(IndirectionSpec { bits: 8, parameters: crate::layout::spec::default_indirection_parameters() });
            s
        }

        /// Bevy's deferred G-buffer: one Rgba32Uint texel plus the prepass depth.
        fn bevy_deferred() -> LayoutSpec {
            with_constants(
                spec(
                    "bevy-deferred",
                    "Bevy deferred: Rgba32Uint (sRGB base colour + roughness; emissive rgb9e5; reflectance, metallic, AO; \
                     oct24 normal + flags) over a reversed-Z D32F prepass depth",
                    &["Bevy 0.12+, crates/bevy_pbr/src/deferred/pbr_deferred_functions.wgsl \
                         (deferred_gbuffer_from_pbr_input) and DEFERRED_PREPASS_FORMAT = Rgba32Uint"],
                    vec![
                        t("depth", "d32f", vec![f("depth", "f32-reversed", 0, 32)]),
                        t(
                            "deferred",
                            "rgba32ui",
                            vec![
                                f("albedo", "srgb8", 0, 24),
                                f("roughness", "unorm-8", 24, 8),
                                reserved(32, 32, "emissive (rgb9e5)"),
                                f("specular", "unorm-8", 64, 8),
                                f("metallic", "unorm-8", 72, 8),
                                reserved(80, 8, "diffuse occlusion"),
                                reserved(88, 8, "spare (fragment depth on WebGL2)"),
                                f("normal", "oct-24", 96, 24),
                                reserved(120, 8, "mesh/material flags"),
                            ],
                        ),
                    ],
                ),
                &[],
            )
        }

        /// An Unreal-Engine-like GBuffer A–D over reversed-Z float depth.
        fn unreal_like() -> LayoutSpec {
            spec(
                "unreal-like",
                "Unreal-like GBufferA (RGB10A2 normal), B (metallic, specular, roughness, shading model), C (sRGB base \
                 colour + AO), D (custom data) over reversed-Z D32F",
                &["Unreal Engine 4/5, Engine/Shaders/Private/DeferredShadingCommon.ush (EncodeGBuffer)"],
                vec![
                    t("depth", "d32f", vec![f("depth", "f32-reversed", 0, 32)]),
                    t("gbuffer_a", "rgb10a2", vec![f("normal", "xyz-unorm-30", 0, 30), reserved(30, 2, "per-object data")]),
                    t(
                        "gbuffer_b",
                        "rgba8",
                        vec![
                            f("metallic", "unorm-8", 0, 8),
                            f("specular", "unorm-8", 8, 8),
                            f("roughness", "unorm-8", 16, 8),
                            reserved(24, 8, "shading model ID + selective output mask"),
                        ],
                    ),
                    t(
                        "gbuffer_c",
                        "rgba8-srgb",
                        vec![f("albedo", "srgb8", 0, 24), reserved(24, 8, "indirect irradiance / AO")],
                    ),
                    t("gbuffer_d", "rgba8", vec![reserved(0, 32, "custom data (subsurface colour, clear coat, ...)")]),
                ],
            )
        }

        /// The smallest useful layout: 8 bytes.
        fn minimal_8() -> LayoutSpec {
            with_constants(
                spec(
                    "minimal-8",
                    "8 bytes: D16 depth, RG8 octahedral normal, sRGB albedo + roughness",
                    &["ours: the cheapest layout that still lights (constants for everything else)"],
                    vec![
                        t("depth", "d16", vec![f("depth", "unorm16", 0, 16)]),
                        t("normal", "rg8", vec![f("normal", "oct-16", 0, 16)]),
                        t(
                            "albedo_roughness",
                            "rgba8-srgb",
                            vec![f("albedo", "srgb8", 0, 24), f("roughness", "unorm-8", 24, 8)],
                        ),
                    ],
                ),
                &[("specular", 0.5), ("metallic", 0.0)],
            )
        }

        /// Every attribute in f32 / u32: bit-exact for finite input.
        fn reference_f32() -> LayoutSpec {
            spec(
                "reference-f32",
                "lossless reference: every attribute as f32 / u32 (84 bytes)",
                &["ours: the unquantized baseline"],
                vec![
                    t("depth", "d32f", vec![f("depth", "f32", 0, 32)]),
                    t(
                        "position_specular",
                        "rgba32f",
                        vec![
                            f("position.x", "f32", 0, 32),
                            f("position.y", "f32", 32, 32),
                            f("position.z", "f32", 64, 32),
                            f("specular", "f32", 96, 32),
                        ],
                    ),
                    t(
                        "normal_power",
                        "rgba32f",
                        vec![
                            f("normal.x", "f32", 0, 32),
                            f("normal.y", "f32", 32, 32),
                            f("normal.z", "f32", 64, 32),
                            f("specular_power", "f32", 96, 32),
                        ],
                    ),
                    t(
                        "albedo_roughness",
                        "rgba32f",
                        vec![
                            f("albedo.r", "f32", 0, 32),
                            f("albedo.g", "f32", 32, 32),
                            f("albedo.b", "f32", 64, 32),
                            f("roughness", "f32", 96, 32),
                        ],
                    ),
                    t(
                        "metallic_motion",
                        "rgba32f",
                        vec![
                            f("metallic", "f32", 0, 32),
                            f("motion.x", "f32", 32, 32),
                            f("motion.y", "f32", 64, 32),
                            reserved(96, 32, "unused"),
                        ],
                    ),
                    t(
                        "ids",
                        "rgba32ui",
                        vec![
                            f("material_id", "uint-32", 0, 32),
                            f("object_id", "uint-32", 32, 32),
                            f("primitive_id", "uint-32", 64, 32),
                            reserved(96, 32, "unused"),
                        ],
                    ),
                ],
            )
        }

        /// The specs of every built-in layout.
        #[must_use]
        pub fn specs() -> Vec<LayoutSpec> {
            vec![
                fat_20(),
                rgba16f_2x(),
                lauritzen_15(),
                destiny_96(),
                bevy_deferred(),
                unreal_like(),
                minimal_8(),
                reference_f32(),
            ]
        }
    }
}
