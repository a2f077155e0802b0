//! What a field stores ([`Slot`]) and the codec that turns it into bits ([`Coder`]): the one place where layout
//! fields meet the codec registry.

use crate::codec::{self, ColorCodec, DepthCodec, NormalCodec, ScalarCodec};
use crate::gbuffer::Attribute;
use serde::Serialize;

/// What a field stores.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Slot {
    /// A whole attribute with a codec of its kind (normal, depth, colour, scalar, ID).
    Whole(Attribute),
    /// One component of a vector attribute (`normal.x`, `motion.y`, `albedo.g`) with a scalar codec.
    Component(Attribute, usize),
    /// The index into the material table (material-ID indirection).
    MaterialIndex,
    /// Bits owned by something outside the G-buffer model; written as zero.
    Reserved,
}

const COMPONENT_NAMES: [[&str; 3]; 2] = [["x", "y", "z"], ["r", "g", "b"]];

impl Slot {
    /// Parses a field's `attribute` string.
    pub fn parse(s: &str) -> Result<Slot, String> {
        let s = s.trim();
        match s {
            "reserved" => return Ok(Slot::Reserved),
            "material_index" | "material-index" => return Ok(Slot::MaterialIndex),
            _ => {}
        }
        let known = || {
            format!(
                "known: {}, a component such as normal.x or albedo.g, material_index, reserved",
                Attribute::ALL.map(|a| a.name()).join(", ")
            )
        };
        if let Some((attr, comp)) = s.split_once('.') {
            let a = Attribute::from_name(attr).ok_or_else(|| format!("unknown attribute {attr:?}; {}", known()))?;
            if a.components() == 1 {
                return Err(format!("{} has one component; write {:?}", a.name(), a.name()));
            }
            let k = COMPONENT_NAMES
                .iter()
                .find_map(|names| names.iter().position(|n| *n == comp))
                .or_else(|| comp.parse::<usize>().ok())
                .filter(|k| *k < a.components())
                .ok_or_else(|| format!("{} has no component {comp:?} (it has {})", a.name(), a.components()))?;
            return Ok(Slot::Component(a, k));
        }
        Attribute::from_name(s).map(Slot::Whole).ok_or_else(|| format!("unknown attribute {s:?}; {}", known()))
    }

    /// The spelling used in specs and output.
    #[must_use]
    pub fn name(self) -> String {
        match self {
            Slot::Whole(a) => a.name().to_string(),
            Slot::Component(a, k) => {
                let names = if a == Attribute::Albedo { COMPONENT_NAMES[1] } else { COMPONENT_NAMES[0] };
                format!("{}.{}", a.name(), names[k])
            }
            Slot::MaterialIndex => "material_index".into(),
            Slot::Reserved => "reserved".into(),
        }
    }

    /// The G-buffer attribute this slot carries, if any.
    #[must_use]
    pub fn attribute(self) -> Option<Attribute> {
        match self {
            Slot::Whole(a) | Slot::Component(a, _) => Some(a),
            Slot::MaterialIndex | Slot::Reserved => None,
        }
    }
}

/// The codec family a slot needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CodecKind {
    /// [`NormalCodec`].
    Normal,
    /// [`DepthCodec`].
    Depth,
    /// [`ColorCodec`].
    Color,
    /// [`ScalarCodec`].
    Scalar,
    /// `uint-N`: the low N bits of an ID, saturating.
    Id,
    /// No codec (material index, reserved bits).
    None,
}

impl CodecKind {
    /// The family a slot needs, or why the slot cannot be stored whole.
    pub fn for_slot(slot: Slot) -> Result<CodecKind, String> {
        Ok(match slot {
            Slot::Whole(Attribute::Normal) => CodecKind::Normal,
            Slot::Whole(Attribute::Depth) => CodecKind::Depth,
            Slot::Whole(Attribute::Albedo) => CodecKind::Color,
            Slot::Whole(a @ (Attribute::Position | Attribute::Motion)) => {
                return Err(format!(
                    "{} is stored per component ({}.x, {}.y{}) with scalar codecs",
                    a.name(),
                    a.name(),
                    a.name(),
                    if a.components() == 3 { format!(", {}.z", a.name()) } else { String::new() }
                ))
            }
            Slot::Whole(a) if a.is_id() => CodecKind::Id,
            Slot::Whole(_) | Slot::Component(..) => CodecKind::Scalar,
            Slot::MaterialIndex | Slot::Reserved => CodecKind::None,
        })
    }
}

/// A built codec for one field.
pub enum Coder {
    /// A normal codec.
    Normal(Box<dyn NormalCodec>),
    /// A depth codec (built with the near/far planes in force).
    Depth(Box<dyn DepthCodec>),
    /// A colour codec.
    Color(Box<dyn ColorCodec>),
    /// A scalar codec.
    Scalar(Box<dyn ScalarCodec>),
    /// IDs: the low `bits` bits, saturating at `2^bits − 1`.
    Id(u32),
    /// No codec: the field's bits come from elsewhere (material index) or are zero (reserved).
    None,
}

impl Coder {
    /// Operations its decoder spends per value ([`crate::codec::Codec::decode_ops`]; an ID or no codec: 0).
    #[must_use]
    pub fn decode_ops(&self) -> u32 {
        match self {
            Coder::Normal(c) => c.decode_ops(),
            Coder::Depth(c) => c.decode_ops(),
            Coder::Color(c) => c.decode_ops(),
            Coder::Scalar(c) => c.decode_ops(),
            Coder::Id(_) | Coder::None => 0,
        }
    }
}

/// Parses `uint-N` (1 ≤ N ≤ 32).
fn id_bits(name: &str) -> Option<u32> {
    let n: u32 = name.strip_prefix("uint-").or_else(|| name.strip_prefix("uint"))?.parse().ok()?;
    (1..=32).contains(&n).then_some(n)
}

impl Coder {
    /// Builds the codec `name` for `slot`; `znear`/`zfar` configure projection-dependent depth codecs.
    pub fn build(slot: Slot, name: &str, znear: f32, zfar: f32) -> Result<Coder, String> {
        let kind = CodecKind::for_slot(slot)?;
        // The registry's errors list the valid names; keep its message without the "invalid argument" prefix.
        let msg = |e: crate::Error| match e {
            crate::Error::Argument(m) | crate::Error::UnknownName(m) => m,
            other => other.to_string(),
        };
        Ok(match kind {
            CodecKind::Normal => Coder::Normal(codec::try_normal_codec(name).map_err(msg)?),
            CodecKind::Depth => Coder::Depth(codec::try_depth_codec(name, znear, zfar).map_err(msg)?),
            CodecKind::Color => Coder::Color(codec::try_color_codec(name).map_err(msg)?),
            CodecKind::Scalar => Coder::Scalar(codec::try_scalar_codec(name).map_err(msg)?),
            CodecKind::Id => Coder::Id(
                id_bits(name)
                    .ok_or_else(|| format!("unknown ID codec {name:?} for {} (use uint-N, 1 ≤ N ≤ 32)", slot.name()))?,
            ),
            CodecKind::None => {
                if !name.is_empty() {
                    return Err(format!("{} takes no codec (got {name:?})", slot.name()));
                }
                Coder::None
            }
        })
    }

    /// Bits the codec produces (`None` when the field's width is free).
    #[must_use]
    pub fn bits(&self) -> Option<u32> {
        match self {
            Coder::Normal(c) => Some(c.bits()),
            Coder::Depth(c) => Some(c.bits()),
            Coder::Color(c) => Some(c.bits()),
            Coder::Scalar(c) => Some(c.bits()),
            Coder::Id(b) => Some(*b),
            Coder::None => None,
        }
    }
}

/// Encodes an ID into `bits` bits, saturating.
#[inline]
#[must_use]
pub fn encode_id(v: u32, bits: u32) -> u64 {
    u64::from(v).min(crate::layout::bits::mask(bits))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_parse_and_print() {
        for (s, slot) in [
            ("normal", Slot::Whole(Attribute::Normal)),
            ("normal.z", Slot::Component(Attribute::Normal, 2)),
            ("albedo.g", Slot::Component(Attribute::Albedo, 1)),
            ("motion.y", Slot::Component(Attribute::Motion, 1)),
            ("material_index", Slot::MaterialIndex),
            ("reserved", Slot::Reserved),
            ("object_id", Slot::Whole(Attribute::ObjectId)),
        ] {
            assert_eq!(Slot::parse(s).unwrap(), slot, "{s}");
            assert_eq!(Slot::parse(&slot.name()).unwrap(), slot);
        }
        assert!(Slot::parse("motion.z").unwrap_err().contains("no component"));
        assert!(Slot::parse("depth.x").unwrap_err().contains("one component"));
        assert!(Slot::parse("colour").unwrap_err().contains("unknown attribute"));
    }

    #[test]
    fn kinds_follow_the_attribute() {
        assert_eq!(CodecKind::for_slot(Slot::Whole(Attribute::Normal)), Ok(CodecKind::Normal));
        assert_eq!(CodecKind::for_slot(Slot::Component(Attribute::Normal, 0)), Ok(CodecKind::Scalar));
        assert_eq!(CodecKind::for_slot(Slot::Whole(Attribute::PrimitiveId)), Ok(CodecKind::Id));
        assert!(CodecKind::for_slot(Slot::Whole(Attribute::Motion)).unwrap_err().contains("motion.x"));
    }

    #[test]
    fn id_codec_saturates() {
        assert_eq!(id_bits("uint-8"), Some(8));
        assert_eq!(id_bits("uint-33"), None);
        assert_eq!(encode_id(300, 8), 255);
        assert_eq!(encode_id(7, 8), 7);
        assert_eq!(encode_id(u32::MAX, 32), u64::from(u32::MAX));
        assert!(Coder::build(Slot::Reserved, "unorm-8", 0.1, 1.0).is_err());
    }
}
