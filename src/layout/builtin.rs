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

/// Built-in layouts that are not G-buffers to light: the visibility buffer's (triangle and instance IDs + depth),
/// whose surface attributes are re-materialised from the scene. `Layout::by_name` finds them; the lists of lit
/// layouts (reports, budgets, `gbuf layouts`' main table) leave them out.
const VISIBILITY_FILES: [(&str, &str); 1] = [("visibility-8.toml", include_str!("builtin/visibility-8.toml"))];

fn parse(files: &[(&str, &str)]) -> Vec<LayoutSpec> {
    let path = |file: &str| Path::new("src/layout/builtin").join(file);
    files
        .iter()
        .map(|(file, text)| LayoutSpec::parse(&path(file), text).expect("built-in layout files parse"))
        .collect()
}

/// The specs of every built-in G-buffer layout (parsed once).
#[must_use]
pub fn specs() -> Vec<LayoutSpec> {
    static SPECS: OnceLock<Vec<LayoutSpec>> = OnceLock::new();
    SPECS.get_or_init(|| parse(&FILES)).clone()
}

/// The specs of the built-in visibility-buffer layouts (parsed once).
#[must_use]
pub fn visibility_specs() -> Vec<LayoutSpec> {
    static SPECS: OnceLock<Vec<LayoutSpec>> = OnceLock::new();
    SPECS.get_or_init(|| parse(&VISIBILITY_FILES)).clone()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_file_is_named_after_its_layout_and_validates() {
        for ((file, _), spec) in
            FILES.iter().chain(&VISIBILITY_FILES).zip(specs().into_iter().chain(visibility_specs()))
        {
            assert_eq!(*file, format!("{}.toml", spec.name));
            assert!(!spec.sources.is_empty() && !spec.description.is_empty(), "{file}");
            crate::layout::Layout::from_spec(spec).unwrap();
        }
    }
}
