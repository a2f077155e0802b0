//! Render-target formats, bit packing, built-in layouts and material-ID indirection: whole G-buffers packed into
//! real words.
//!
//! A [`Layout`] is a list of render targets with real [`Format`]s and, inside each texel, fields: (attribute,
//! codec, bit range). [`Layout::pack`] turns a [`GBuffer`] into the bytes a renderer would hold in
//! its render targets ([`Packed`]); [`Layout::unpack`] reads them back into the G-buffer the lighting pass would
//! see. Layouts come from [`Layout::builtins`] or from TOML/JSON files ([`Layout::load`], docs/LAYOUTS.md).

pub mod afrc;
pub(crate) mod bits;
pub(crate) mod builtin;
pub(crate) mod coder;
pub mod codespace;
pub mod compression;
pub mod dds;
pub(crate) mod formats;
pub mod lighting;
pub mod limits;
pub mod material;
pub mod pack;
pub mod renderdoc;
pub mod shader;
pub mod spec;
pub(crate) mod summary;
pub mod targets;
pub mod texture;
pub mod wgsl;

pub use crate::gbuffer::BandSource;
pub use coder::{CodecKind, Slot};
pub use formats::{Component, ComponentKind, Format};
pub use lighting::{LightingSource, LitFrame, PreparedLighting};
pub use material::MaterialTable;
pub use pack::{Packed, PackedFrame, Roundtrip, TargetPlane};
pub use spec::{
    ConstantValue, FieldSpec, IndirectionSpec, LayoutSpec, MaterialKey, SpecSyntax, TargetSpec, DEFAULT_DEPTH_RANGE,
};
pub use summary::LayoutSummary;

use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer};
use std::collections::HashSet;
use std::path::Path;

/// One validated field.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    /// Index of its target.
    pub target: usize,
    /// What it stores.
    pub slot: Slot,
    /// Codec name (empty for reserved bits and the material index).
    pub codec: String,
    /// First bit in the texel.
    pub offset: u32,
    /// Width in bits.
    pub bits: u32,
}

/// Material-ID indirection, validated.
#[derive(Clone, Debug, PartialEq)]
pub struct Indirection {
    /// Bits of the index: the table has at most `2^bits` entries.
    pub bits: u32,
    /// The parameters the table holds.
    pub parameters: Vec<Attribute>,
    /// What indexes the table.
    pub key: MaterialKey,
}

/// The most targets a layout may have: D3D12 and Vulkan bind at most 8 colour targets plus depth; 16 leaves room
/// for CPU layouts while keeping a mistyped file from asking for gigabytes per G-buffer.
pub const MAX_TARGETS: usize = 16;

/// The largest material index we accept (a 2^24-entry table is already far beyond any real material count).
pub const MAX_INDIRECTION_BITS: u32 = 24;

/// A validated layout. Build one with [`Layout::from_spec`], [`Layout::load`], [`Layout::by_name`] or
/// [`Layout::builtins`].
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    spec: LayoutSpec,
    formats: Vec<Format>,
    fields: Vec<Field>,
    constants: Vec<(Attribute, Vec<f32>)>,
    indirection: Option<Indirection>,
}

impl Layout {
    /// Validates a spec: known formats and codecs, every field inside its target and as wide as its codec, no two
    /// fields overlapping, each attribute stored once (whole, per component, through the material table or as a
    /// constant — never two of these), and indirection consistent with a `material_index` field.
    pub fn from_spec(spec: LayoutSpec) -> Result<Layout> {
        validate(&spec).map_err(|what| Error::Argument(format!("layout {:?}: {what}", spec.name)))
    }

    /// Every built-in layout (see docs/LAYOUTS.md for their sources).
    #[must_use]
    pub fn builtins() -> Vec<Layout> {
        builtin::specs().into_iter().map(|s| Layout::from_spec(s).expect("built-in layouts are valid")).collect()
    }

    /// The built-in visibility-buffer layouts (IDs + depth; not lit as they are: see `builtin::visibility_specs`).
    #[must_use]
    pub fn visibility_builtins() -> Vec<Layout> {
        builtin::visibility_specs()
            .into_iter()
            .map(|s| Layout::from_spec(s).expect("built-in layouts are valid"))
            .collect()
    }

    /// A built-in layout by name (the lit layouts and the visibility buffer's); `NAME@afrcK` is the built-in with
    /// its eligible targets stored at AFRC `K` bits per component ([`Layout::with_afrc`]).
    #[must_use]
    pub fn by_name(name: &str) -> Option<Layout> {
        if let Some((base, rate)) = name.rsplit_once("@afrc") {
            return Layout::by_name(base)?.with_afrc(rate.parse().ok()?).ok();
        }
        builtin::specs()
            .into_iter()
            .chain(builtin::visibility_specs())
            .find(|s| crate::base::names::normalize(&s.name) == crate::base::names::normalize(name))
            .map(|s| Layout::from_spec(s).expect("built-in layouts are valid"))
    }

    /// Names of the built-in layouts (the lit ones, then the visibility buffer's).
    #[must_use]
    pub fn builtin_names() -> Vec<String> {
        builtin::specs().into_iter().chain(builtin::visibility_specs()).map(|s| s.name).collect()
    }

    /// Reads and validates a layout file (TOML or JSON, by extension or content). Errors name the file.
    pub fn load(path: &Path) -> Result<Layout> {
        let spec = LayoutSpec::read(path)?;
        validate(&spec)
            .map_err(|what| Error::Parse { path: path.into(), what: format!("layout {:?}: {what}", spec.name) })
    }

    /// A built-in name, or else a path to a layout file.
    pub fn by_name_or_path(name_or_path: &str) -> Result<Layout> {
        if let Some(l) = Layout::by_name(name_or_path) {
            return Ok(l);
        }
        // `NAME@afrcK`: the base layout's error, or the rate's.
        if let Some((base, rate)) = name_or_path.rsplit_once("@afrc") {
            let rate = rate.parse::<u32>().map_err(|_| {
                Error::Argument(format!("{name_or_path:?}: AFRC's rate is a number of bits per component (2, 3 or 4)"))
            })?;
            return Layout::by_name_or_path(base)?.with_afrc(rate);
        }
        let path = Path::new(name_or_path);
        // A path (a separator or a file extension) that does not exist is a missing file, read as such below.
        let looks_like_path = path.components().count() > 1 || path.extension().is_some();
        if !path.exists() && !looks_like_path {
            let names = Layout::builtin_names();
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            let hint = match crate::base::names::closest(name_or_path, names.iter().copied()) {
                Some(s) => format!("; did you mean {s:?}?"),
                None => String::new(),
            };
            return Err(Error::UnknownName(format!(
                "{name_or_path:?} is neither a built-in layout nor a layout file{hint} (built-in: {})",
                names.join(", ")
            )));
        }
        Layout::load(path)
    }

    /// Writes the layout's spec atomically (JSON for `.json`, TOML otherwise).
    pub fn save(&self, path: &Path) -> Result<()> {
        self.spec.save(path)
    }

    /// The layout's name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.spec.name
    }

    /// The spec it was built from.
    #[must_use]
    pub fn spec(&self) -> &LayoutSpec {
        &self.spec
    }

    /// Formats of the targets, in order.
    #[must_use]
    pub fn formats(&self) -> &[Format] {
        &self.formats
    }

    /// All fields, target by target.
    #[must_use]
    pub fn fields(&self) -> &[Field] {
        &self.fields
    }

    /// Constants for unstored attributes (one value per component).
    #[must_use]
    pub fn constants(&self) -> &[(Attribute, Vec<f32>)] {
        &self.constants
    }

    /// Material-ID indirection, if the layout uses it.
    #[must_use]
    pub fn indirection(&self) -> Option<&Indirection> {
        self.indirection.as_ref()
    }

    /// Bytes per sample: the sum of the targets' texel sizes.
    #[must_use]
    pub fn bytes_per_sample(&self) -> usize {
        self.formats.iter().map(|f| f.bytes()).sum()
    }

    /// Bytes one sample occupies in memory: [`Layout::bytes_per_sample`] with each AFRC target at its fixed rate
    /// (fractional: RGBA8 at 3 bits per component is 1.5 bytes).
    #[must_use]
    pub fn stored_bytes_per_sample(&self) -> f64 {
        self.formats
            .iter()
            .zip(&self.spec.targets)
            .map(|(f, t)| t.afrc.map_or(f.bytes() as f64, |r| f64::from(afrc::bits_per_texel(*f, r)) / 8.0))
            .sum()
    }

    /// This layout with every target AFRC can hold stored at `rate` bits per component, named `NAME@afrcRATE`. An
    /// error when no target is eligible or the rate is not one of [`afrc::RATES`].
    pub fn with_afrc(&self, rate: u32) -> Result<Layout> {
        let mut spec = self.spec.clone();
        let mut any = false;
        for (t, f) in spec.targets.iter_mut().zip(&self.formats) {
            if afrc::eligible(*f) {
                t.afrc = Some(rate);
                any = true;
            }
        }
        if !any {
            return Err(Error::Argument(format!(
                "layout {:?} has no target AFRC can hold (8-bit UNORM: r8, rg8, rgba8, rgba8-srgb)",
                self.name()
            )));
        }
        spec.name = format!("{}@afrc{rate}", self.name());
        Layout::from_spec(spec)
    }

    /// Bits actually used by fields (excluding reserved bits).
    #[must_use]
    pub fn used_bits(&self) -> u32 {
        self.fields.iter().filter(|f| f.slot != Slot::Reserved).map(|f| f.bits).sum()
    }

    /// Memory for a whole G-buffer: `width × height × samples ×` [`Layout::stored_bytes_per_sample`] (whole bytes).
    #[must_use]
    pub fn footprint_bytes(&self, width: u32, height: u32, samples: u32) -> u64 {
        let bits: u64 = self
            .formats
            .iter()
            .zip(&self.spec.targets)
            .map(|(f, t)| u64::from(t.afrc.map_or(f.bits(), |r| afrc::bits_per_texel(*f, r))))
            .sum();
        (u64::from(width) * u64::from(height) * u64::from(samples) * bits).div_ceil(8)
    }

    /// Attributes the layout stores (in fields or through the material table), in canonical order.
    #[must_use]
    pub fn stored_attributes(&self) -> Vec<Attribute> {
        let mut set: HashSet<Attribute> = self.fields.iter().filter_map(|f| f.slot.attribute()).collect();
        if let Some(ind) = &self.indirection {
            set.extend(ind.parameters.iter().copied());
        }
        Attribute::ALL.into_iter().filter(|a| set.contains(a)).collect()
    }

    /// Does the layout store `attr`?
    #[must_use]
    pub fn stores(&self, attr: Attribute) -> bool {
        self.stored_attributes().contains(&attr)
    }

    /// Whether `gb` packed with this layout takes fewer bytes than the planes it decodes to (4 per float or ID
    /// component of every attribute it stores and `gb` has): then lighting from the packed targets
    /// ([`Layout::frame`]) holds less than a decoded copy. A lossless 84-byte layout does not.
    #[must_use]
    pub fn packs_smaller(&self, gb: &GBuffer) -> bool {
        let decoded: usize = self.stored_attributes().iter().filter(|a| gb.has(**a)).map(|a| 4 * a.components()).sum();
        self.bytes_per_sample() < decoded
    }
}

fn constant_components(attr: Attribute, value: &ConstantValue) -> std::result::Result<Vec<f32>, String> {
    let n = attr.components();
    let v = match value {
        ConstantValue::Scalar(x) => vec![*x; n],
        ConstantValue::Vector(v) if v.len() == n => v.clone(),
        ConstantValue::Vector(v) => {
            return Err(format!("constant {} has {} values, expected {n}", attr.name(), v.len()));
        }
    };
    if v.iter().any(|x| !x.is_finite()) {
        return Err(format!("constant {} is not finite", attr.name()));
    }
    if attr.is_id() && v.iter().any(|x| *x < 0.0 || x.fract() != 0.0 || *x > u32::MAX as f32) {
        return Err(format!("constant {} must be a non-negative integer", attr.name()));
    }
    Ok(v)
}

fn validate(spec: &LayoutSpec) -> std::result::Result<Layout, String> {
    if spec.name.trim().is_empty() {
        return Err("the layout has no name".into());
    }
    if spec.targets.is_empty() {
        return Err("the layout has no targets".into());
    }
    if spec.targets.len() > MAX_TARGETS {
        return Err(format!("{} targets; a layout has at most {MAX_TARGETS}", spec.targets.len()));
    }
    let [znear, zfar] = spec.depth_range.unwrap_or(DEFAULT_DEPTH_RANGE);
    if !(znear > 0.0 && zfar > znear && zfar.is_finite()) {
        return Err(format!("depth_range [{znear}, {zfar}] must satisfy 0 < near < far < ∞"));
    }
    let mut formats = Vec::new();
    let mut fields = Vec::new();
    let mut names = HashSet::new();
    for (ti, t) in spec.targets.iter().enumerate() {
        if !names.insert(t.name.as_str()) {
            return Err(format!("two targets are named {:?}", t.name));
        }
        let format = Format::from_name(&t.format).ok_or_else(|| {
            format!("target {:?}: unknown format {:?}; known: {}", t.name, t.format, Format::known_names())
        })?;
        if let Some(rate) = t.afrc {
            if !afrc::eligible(format) {
                return Err(format!(
                    "target {:?}: AFRC (fixed-rate compression) holds only 8-bit UNORM targets (r8, rg8, rgba8, \
                     rgba8-srgb), not {format}",
                    t.name
                ));
            }
            if !afrc::RATES.contains(&rate) {
                return Err(format!(
                    "target {:?}: AFRC at {rate} bits per component; the rates are 2, 3 and 4",
                    t.name
                ));
            }
        }
        formats.push(format);
        let mut placed: Vec<(u32, u32, String)> = Vec::new();
        for f in &t.fields {
            let what = format!("target {:?} ({format}, {} bits): field {}", t.name, format.bits(), f.attribute);
            let slot = Slot::parse(&f.attribute).map_err(|e| format!("{what}: {e}"))?;
            if f.bits == 0 {
                return Err(format!("{what}: zero bits"));
            }
            let end = u64::from(f.offset) + u64::from(f.bits);
            if end > u64::from(format.bits()) {
                return Err(format!(
                    "{what}: bits {}..{end} run past the end of the {}-bit texel",
                    f.offset,
                    format.bits()
                ));
            }
            if f.bits > 64 {
                return Err(format!("{what}: {} bits; a field holds at most 64", f.bits));
            }
            for (o, b, other) in &placed {
                if f.offset < o + b && *o < f.offset + f.bits {
                    return Err(format!(
                        "{what}: bits {}..{} overlap field {other} (bits {o}..{})",
                        f.offset,
                        f.offset + f.bits,
                        o + b
                    ));
                }
            }
            let coder = coder::Coder::build(slot, &f.codec, znear, zfar).map_err(|e| format!("{what}: {e}"))?;
            if let Some(cb) = coder.bits() {
                if cb != f.bits {
                    let rel = if f.bits > cb { "wider" } else { "narrower" };
                    return Err(format!(
                        "{what}: {} bits is {rel} than codec {} ({cb} bits); the field must be exactly {cb} bits",
                        f.bits, f.codec
                    ));
                }
            }
            placed.push((f.offset, f.bits, f.attribute.clone()));
            fields.push(Field { target: ti, slot, codec: f.codec.clone(), offset: f.offset, bits: f.bits });
        }
    }
    // Each attribute (or component) stored at most once.
    let mut seen: HashSet<Slot> = HashSet::new();
    for f in &fields {
        if f.slot == Slot::Reserved {
            continue;
        }
        let clash = match f.slot {
            Slot::Whole(a) => (0..a.components()).any(|k| seen.contains(&Slot::Component(a, k))),
            Slot::Component(a, _) => seen.contains(&Slot::Whole(a)),
            _ => false,
        };
        if clash || !seen.insert(f.slot) {
            return Err(format!("{} is stored twice", f.slot.name()));
        }
    }
    let stored: HashSet<Attribute> = fields.iter().filter_map(|f| f.slot.attribute()).collect();
    // Indirection.
    let has_index = fields.iter().any(|f| f.slot == Slot::MaterialIndex);
    let indirection = match (&spec.material_indirection, has_index) {
        (None, false) => None,
        (None, true) => return Err("a material_index field needs a [material_indirection] section".into()),
        (Some(_), false) => return Err("[material_indirection] needs a material_index field".into()),
        (Some(ind), true) => {
            if ind.bits == 0 || ind.bits > MAX_INDIRECTION_BITS {
                return Err(format!("material_indirection bits {} outside 1..={MAX_INDIRECTION_BITS}", ind.bits));
            }
            let field_bits = fields.iter().find(|f| f.slot == Slot::MaterialIndex).map(|f| f.bits).unwrap_or(0);
            if field_bits != ind.bits {
                return Err(format!(
                    "the material_index field has {field_bits} bits but material_indirection has {}",
                    ind.bits
                ));
            }
            let mut parameters = Vec::new();
            for p in &ind.parameters {
                let a = Attribute::from_name(p)
                    .filter(|a| a.components() == 1 && !a.is_id() && *a != Attribute::Depth)
                    .ok_or_else(|| format!("material_indirection: {p:?} is not a scalar material parameter"))?;
                if stored.contains(&a) {
                    return Err(format!("{} is both stored in a field and in the material table", a.name()));
                }
                if parameters.contains(&a) {
                    return Err(format!("material_indirection lists {} twice", a.name()));
                }
                parameters.push(a);
            }
            if parameters.is_empty() {
                return Err("material_indirection has no parameters".into());
            }
            Some(Indirection { bits: ind.bits, parameters, key: ind.key })
        }
    };
    let mut constants = Vec::new();
    for (name, value) in &spec.constants {
        let a = Attribute::from_name(name).ok_or_else(|| format!("constant for unknown attribute {name:?}"))?;
        if stored.contains(&a) || indirection.as_ref().is_some_and(|i| i.parameters.contains(&a)) {
            return Err(format!("{} is stored, so it cannot also be a constant", a.name()));
        }
        constants.push((a, constant_components(a, value)?));
    }
    Ok(Layout { spec: spec.clone(), formats, fields, constants, indirection })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_validate_and_have_the_documented_sizes() {
        let sizes: Vec<(String, usize)> =
            Layout::builtins().iter().map(|l| (l.name().to_string(), l.bytes_per_sample())).collect();
        // The sizes README.md, docs/LAYOUTS.md and docs/GUIDE.md quote.
        let want = [
            ("fat-20", 20),
            ("rgba16f-2x", 20),
            ("lauritzen-15", 15),
            ("destiny-96", 12),
            ("bevy-deferred", 20),
            ("unreal-like", 20),
            ("minimal-8", 8),
            ("reference-f32", 84),
        ];
        for (name, bytes) in want {
            let got =
                sizes.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("built-in {name} missing: {sizes:?}"));
            assert_eq!(got.1, bytes, "{name}");
        }
        assert_eq!(sizes.len(), want.len(), "every built-in has a documented size: {sizes:?}");
    }
}
