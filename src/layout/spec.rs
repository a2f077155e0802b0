//! The layout file format: [`LayoutSpec`] is what a TOML or JSON layout file holds, field for field.
//!
//! A spec is plain data; [`crate::layout::Layout::from_spec`] validates it (known formats and codecs, fields inside
//! their target, no overlaps, each attribute stored once) and is the only way to get a usable layout.
//! docs/LAYOUTS.md documents every key with a full example.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// A whole layout as written in a file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayoutSpec {
    /// Short kebab-case name (`fat-20`, `bevy-deferred`, …).
    pub name: String,
    /// One line saying what the layout is.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// Where the layout comes from (papers, talks, source files).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sources: Vec<String>,
    /// Near and far planes for projection-dependent depth codecs when the G-buffer has no camera
    /// (default [`DEFAULT_DEPTH_RANGE`]). With a camera, its planes are used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_range: Option<[f32; 2]>,
    /// Values of attributes the layout does not store (e.g. `specular = 0.5`): what the lighting pass assumes.
    /// A scalar for scalar and ID attributes, a list for vector ones (`albedo = [0.5, 0.5, 0.5]`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub constants: BTreeMap<String, ConstantValue>,
    /// Material-ID indirection: some material parameters are replaced by a `material_index` field into a table.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material_indirection: Option<IndirectionSpec>,
    /// The render targets, in binding order.
    pub targets: Vec<TargetSpec>,
}

/// Near/far planes assumed by projection-dependent depth codecs when neither the G-buffer's camera nor the layout
/// gives them.
pub const DEFAULT_DEPTH_RANGE: [f32; 2] = [0.1, 1000.0];

/// A constant for an unstored attribute.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ConstantValue {
    /// One value (scalar or ID attributes; for vectors, repeated in every component).
    Scalar(f32),
    /// One value per component.
    Vector(Vec<f32>),
}

/// One render target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetSpec {
    /// Name (`rt0`, `gbuffer_a`, `depth`, …).
    pub name: String,
    /// Format name, e.g. `rgba8`, `rgba16f`, `d24s8` (see [`crate::layout::Format`]).
    pub format: String,
    /// What the target holds beyond its fields (e.g. "lighting accumulation, written by the light pass").
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
    /// The fields. Bits not covered by a field are written as zero.
    #[serde(default)]
    pub fields: Vec<FieldSpec>,
    /// Stored with Arm's fixed-rate compression at this many bits per component (2, 3 or 4; 8-bit UNORM formats,
    /// single-sampled frames only): lossy, every coding unit at a fixed size (`layout::afrc`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub afrc: Option<u32>,
}

/// One field: an attribute (or a component of one), its codec, and its bit range within the target's texel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldSpec {
    /// What is stored: an attribute name (`normal`, `depth`, `albedo`, `roughness`, `object_id`, …), one component
    /// (`normal.x`, `motion.y`, `albedo.g`, `position.z`), `material_index` (with indirection), or `reserved`
    /// (bits owned by something outside the G-buffer model, written as zero).
    pub attribute: String,
    /// Codec name (see docs/LAYOUTS.md); empty for `reserved` and `material_index`.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub codec: String,
    /// First bit within the target's texel word (bit 0 = lowest bit of byte 0).
    pub offset: u32,
    /// Width in bits; must equal the codec's bit count.
    pub bits: u32,
    /// Free text (e.g. what a `reserved` field really holds).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// Material-ID indirection options.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IndirectionSpec {
    /// Bits of the `material_index` field: up to 2^bits table entries.
    pub bits: u32,
    /// The parameters kept in the table (default: specular, specular_power, roughness, metallic).
    #[serde(default = "default_indirection_parameters")]
    pub parameters: Vec<String>,
    /// What indexes the table: the engine's material IDs, a palette of the parameter tuples, or (default) the
    /// IDs when the dump has them and they fit, else the palette.
    #[serde(default, skip_serializing_if = "MaterialKey::is_auto")]
    pub key: MaterialKey,
}

crate::named_enum! {
    /// What indexes a material table.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum MaterialKey: "material table key" {
        /// The engine's material IDs when the dump has them and at most 2^bits distinct ones cover the image,
        /// else the palette.
        #[default]
        Auto => "auto",
        /// The engine's material IDs (Destiny's scheme): one entry per ID, the per-ID mean of the parameters.
        MaterialId => "material-id",
        /// A palette: the distinct parameter tuples, clustered to 2^bits entries when there are more.
        Palette => "palette",
    }
}

impl MaterialKey {
    /// Is this the default?
    #[must_use]
    pub fn is_auto(&self) -> bool {
        *self == MaterialKey::Auto
    }
}

/// The non-albedo material parameters: what the Destiny-style table holds by default.
#[must_use]
fn default_indirection_parameters() -> Vec<String> {
    ["specular", "specular_power", "roughness", "metallic"].map(String::from).to_vec()
}

/// File syntax of a layout file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpecSyntax {
    /// TOML.
    Toml,
    /// JSON.
    Json,
}

impl SpecSyntax {
    /// By extension (`.toml`, `.json`), else by content (JSON starts with `{`).
    #[must_use]
    pub fn detect(path: &Path, text: &str) -> SpecSyntax {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("json") => SpecSyntax::Json,
            Some("toml") => SpecSyntax::Toml,
            _ if text.trim_start().starts_with('{') => SpecSyntax::Json,
            _ => SpecSyntax::Toml,
        }
    }
}

/// The largest layout file we read (a layout is a few kilobytes; this only guards against a wrong path).
pub const MAX_SPEC_FILE_BYTES: u64 = 1 << 20;

impl LayoutSpec {
    /// Parses spec text; errors name `path`.
    pub fn parse(path: &Path, text: &str) -> Result<LayoutSpec> {
        let parse_err = |what: String| Error::Parse { path: path.into(), what };
        match SpecSyntax::detect(path, text) {
            SpecSyntax::Json => serde_json::from_str(text).map_err(|e| parse_err(format!("layout JSON: {e}"))),
            SpecSyntax::Toml => toml::from_str(text).map_err(|e| parse_err(format!("layout TOML: {e}"))),
        }
    }

    /// Reads and parses a layout file (no validation beyond syntax).
    pub fn read(path: &Path) -> Result<LayoutSpec> {
        crate::base::files::protect_input(path);
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > MAX_SPEC_FILE_BYTES {
            return Err(Error::invalid(
                path,
                format!("{} bytes is too large for a layout file (limit {MAX_SPEC_FILE_BYTES})", meta.len()),
            ));
        }
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let text = String::from_utf8(bytes).map_err(|_| Error::invalid(path, "layout file is not UTF-8 text"))?;
        LayoutSpec::parse(path, &text)
    }

    /// Serializes in the given syntax.
    pub fn to_text(&self, syntax: SpecSyntax) -> Result<String> {
        match syntax {
            SpecSyntax::Json => serde_json::to_string_pretty(self).map_err(|e| Error::Internal(e.to_string())),
            SpecSyntax::Toml => toml::to_string_pretty(self).map_err(|e| Error::Internal(e.to_string())),
        }
    }

    /// Writes the spec atomically, TOML unless the extension is `.json`.
    pub fn save(&self, path: &Path) -> Result<()> {
        let syntax = SpecSyntax::detect(path, "");
        let text = self.to_text(syntax)?;
        crate::base::files::write_bytes_atomic(path, text.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> LayoutSpec {
        LayoutSpec {
            name: "t".into(),
            description: "test".into(),
            sources: vec!["nowhere".into()],
            depth_range: Some([0.5, 50.0]),
            constants: [("specular".to_string(), ConstantValue::Scalar(0.5))].into_iter().collect(),
            material_indirection: Some(IndirectionSpec {
                bits: 4,
                parameters: default_indirection_parameters(),
                key: MaterialKey::Auto,
            }),
            targets: vec![TargetSpec {
                name: "rt0".into(),
                format: "rgba8".into(),
                note: String::new(),
                afrc: None,
                fields: vec![FieldSpec {
                    attribute: "albedo".into(),
                    codec: "unorm8".into(),
                    offset: 0,
                    bits: 24,
                    note: String::new(),
                }],
            }],
        }
    }

    #[test]
    fn toml_and_json_round_trip() {
        let s = sample();
        for syntax in [SpecSyntax::Toml, SpecSyntax::Json] {
            let text = s.to_text(syntax).unwrap();
            let name = if syntax == SpecSyntax::Json { "x.json" } else { "x.toml" };
            assert_eq!(LayoutSpec::parse(Path::new(name), &text).unwrap(), s, "{text}");
        }
    }

    #[test]
    fn syntax_is_detected_by_extension_then_content() {
        assert_eq!(SpecSyntax::detect(Path::new("a.JSON"), ""), SpecSyntax::Json);
        assert_eq!(SpecSyntax::detect(Path::new("a"), "  {\"name\": 1}"), SpecSyntax::Json);
        assert_eq!(SpecSyntax::detect(Path::new("a.txt"), "name = 'x'"), SpecSyntax::Toml);
    }

    #[test]
    fn unknown_keys_are_refused_with_the_file_name() {
        let err = LayoutSpec::parse(Path::new("my.toml"), "name = 'x'\ntargets = []\ncolour = 1\n").unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("my.toml") && msg.contains("colour"), "{msg}");
    }
}
