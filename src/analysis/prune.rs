//! The pruned layout: a layout with what the scene does not need left out.
//!
//! Input: a layout spec and the scene's [`Needs`]. Output: a new spec where fields of absent, constant or
//! derivable attributes are gone (constants become layout constants, so the lighting pass still sees the right
//! value), the material-ID index is only as wide as the scene's material count needs, emptied targets are dropped,
//! and targets whose remaining fields fit a smaller format of the same family shrink to it. Bits the layout marks
//! `reserved` (lighting accumulation, AO, emissive, …) belong to the engine, not the G-buffer model, and are kept.

use crate::analysis::needs::Needs;
use crate::gbuffer::Attribute;
use crate::layout::{ConstantValue, Format, LayoutSpec};

/// Format families whose members differ only in channel count, smallest first, with their channel width in bits
/// (1 for integer formats, whose texels hold arbitrary bit fields).
const FAMILIES: [(&[&str], u32); 5] = [
    (&["r8", "rg8", "rgb8", "rgba8"], 8),
    (&["r16f", "rg16f", "rgba16f"], 16),
    (&["r16-unorm", "rg16-unorm", "rgba16-unorm"], 16),
    (&["r32f", "rg32f", "rgba32f"], 32),
    (&["r32ui", "rg32ui", "rgba32ui"], 1),
];

fn family(format: &str) -> Option<(&'static [&'static str], u32)> {
    let name = Format::from_name(format)?.name();
    FAMILIES.iter().find(|(f, _)| f.contains(&name)).map(|&(f, w)| (f, w))
}

fn format_bits(name: &str) -> u32 {
    Format::from_name(name).map_or(0, Format::bits)
}

/// The attribute a field's `attribute` string names (`normal.x` → normal); `None` for reserved / material index.
fn field_attribute(s: &str) -> Option<Attribute> {
    Attribute::from_name(s.split('.').next().unwrap_or(s))
}

fn why(needs: &Needs, a: Attribute) -> &'static str {
    if needs.is_absent(a) {
        "absent from the scene"
    } else if needs.is_constant(a) {
        "constant in the scene"
    } else {
        "derivable from depth and the camera"
    }
}

/// Prunes `spec` for a scene with `needs`. Returns the new spec (named `<name>-pruned`) and one line per change;
/// no changes means nothing could be left out.
#[must_use]
pub fn prune_spec(spec: &LayoutSpec, needs: &Needs) -> (LayoutSpec, Vec<String>) {
    let unneeded = needs.unneeded();
    let mut out = spec.clone();
    out.name = format!("{}-pruned", spec.name);
    out.description = format!("{} — pruned for one scene by gbuf", spec.description);
    let mut changes = Vec::new();
    let constant_of = |a: Attribute| {
        needs.constant_values.get(a.name()).map(|v| {
            if v.len() == 1 {
                ConstantValue::Scalar(v[0] as f32)
            } else {
                ConstantValue::Vector(v.iter().map(|&x| x as f32).collect())
            }
        })
    };

    // Material-ID indirection: constant parameters leave the table; the index shrinks to the material count.
    let mut index_bits: Option<u32> = None;
    let mut drop_index = false;
    if let Some(ind) = out.material_indirection.as_mut() {
        let before = ind.parameters.clone();
        ind.parameters.retain(|p| Attribute::from_name(p).is_none_or(|a| !unneeded.contains(&a)));
        for p in before.iter().filter(|p| !ind.parameters.contains(p)) {
            if let Some(a) = Attribute::from_name(p) {
                if let Some(c) = constant_of(a) {
                    out.constants.insert(a.name().to_string(), c);
                }
                changes.push(format!("{p} left the material table ({})", why(needs, a)));
            }
        }
        if ind.parameters.is_empty() {
            drop_index = true;
            changes.push("material index dropped (no varying material parameter left)".into());
        } else if let Some(b) = needs.material_id_bits.filter(|&b| b >= 1 && b < ind.bits) {
            changes.push(format!("material index {} → {b} bits ({} material tuples)", ind.bits, needs.material_count));
            ind.bits = b;
            index_bits = Some(b);
        }
    }
    if drop_index {
        out.material_indirection = None;
    }

    for t in &mut out.targets {
        let before = t.fields.len();
        let mut dropped = Vec::new();
        t.fields.retain(|f| {
            if f.attribute == "material_index" || f.attribute == "material-index" {
                return !drop_index;
            }
            match field_attribute(&f.attribute) {
                Some(a) if unneeded.contains(&a) => {
                    dropped.push((f.attribute.clone(), f.bits, a));
                    false
                }
                _ => true,
            }
        });
        for (name, bits, a) in dropped {
            if let Some(c) = constant_of(a) {
                out.constants.insert(a.name().to_string(), c);
            }
            changes.push(format!("dropped {name} ({bits} bits, target {}): {}", t.name, why(needs, a)));
        }
        if let Some(b) = index_bits {
            for f in t.fields.iter_mut().filter(|f| f.attribute.starts_with("material")) {
                if f.attribute == "material_index" || f.attribute == "material-index" {
                    f.bits = b;
                }
            }
        }
        debug_assert!(t.fields.len() <= before);
    }
    let n = out.targets.len();
    let emptied: Vec<String> = out.targets.iter().filter(|t| t.fields.is_empty()).map(|t| t.name.clone()).collect();
    out.targets.retain(|t| !t.fields.is_empty());
    for name in &emptied {
        changes.push(format!("dropped target {name} (nothing left in it)"));
    }
    debug_assert_eq!(out.targets.len() + emptied.len(), n);

    for t in &mut out.targets {
        let Some((fam, w)) = family(&t.format) else { continue };
        // Compact channel-aligned fields to the lowest channels, in their original order.
        if t.fields.iter().all(|f| f.offset % w == 0 && f.bits % w == 0) {
            let mut order: Vec<usize> = (0..t.fields.len()).collect();
            order.sort_by_key(|&i| t.fields[i].offset);
            let mut at = 0;
            for i in order {
                t.fields[i].offset = at;
                at += t.fields[i].bits;
            }
        }
        let end = t.fields.iter().map(|f| f.offset + f.bits).max().unwrap_or(0);
        let old = Format::from_name(&t.format).map_or(t.format.clone(), |f| f.name().to_string());
        if let Some(smaller) = fam.iter().find(|n| format_bits(n) >= end && format_bits(n) < format_bits(&old)) {
            changes.push(format!("target {}: {old} → {smaller} ({end} bits used)", t.name));
            t.format = (*smaller).to_string();
        }
    }
    (out, changes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::needs::analyze;
    use crate::layout::Layout;
    use crate::GBuffer;
    use glam::{Vec2, Vec3};

    fn scene(constant_metallic: bool) -> GBuffer {
        let mut g = GBuffer::new(8, 4, 2).unwrap();
        let n = g.len();
        g.coverage = vec![true; n];
        g.depth = Some((0..n).map(|i| 1.0 + i as f32 * 0.1).collect());
        g.normal = Some((0..n).map(|i| Vec3::new(0.01 * i as f32, 0.3, 1.0).normalize()).collect());
        g.albedo = Some((0..n).map(|i| Vec3::splat(0.01 * i as f32)).collect());
        g.specular = Some((0..n).map(|i| [0.2, 0.8][i % 2]).collect());
        g.specular_power = Some((0..n).map(|i| [8.0, 64.0][i % 2]).collect());
        g.roughness = Some((0..n).map(|i| [0.3, 0.6][i % 2]).collect());
        g.metallic = Some((0..n).map(|i| if constant_metallic { 0.0 } else { (i % 2) as f32 }).collect());
        g.motion = Some(vec![Vec2::ZERO; n]);
        g
    }

    #[test]
    fn every_builtin_prunes_to_a_valid_layout_no_larger() {
        let needs = analyze(&scene(true));
        for l in Layout::builtins() {
            let (spec, changes) = prune_spec(l.spec(), &needs);
            let p = Layout::from_spec(spec).unwrap_or_else(|e| panic!("{}: {e}; changes {changes:?}", l.name()));
            assert!(p.bytes_per_sample() <= l.bytes_per_sample(), "{}", l.name());
            assert_eq!(
                changes.is_empty(),
                p.spec().targets == l.spec().targets && p.spec().constants == l.spec().constants
            );
            assert!(!p.stores(Attribute::Motion), "{}: constant motion dropped", l.name());
            assert!(!p.stores(Attribute::Metallic), "{}: constant metallic dropped", l.name());
        }
    }

    #[test]
    fn constant_fields_leave_and_their_target_shrinks() {
        use crate::layout::{FieldSpec, TargetSpec};
        let f = |a: &str, c: &str, offset| FieldSpec {
            attribute: a.into(),
            codec: c.into(),
            offset,
            bits: 8,
            note: String::new(),
        };
        let spec = LayoutSpec {
            name: "test".into(),
            description: String::new(),
            sources: vec![],
            depth_range: None,
            constants: Default::default(),
            material_indirection: None,
            targets: vec![
                TargetSpec {
                    name: "depth".into(),
                    format: "d32f".into(),
                    note: String::new(),
                    afrc: None,
                    fields: vec![FieldSpec {
                        attribute: "depth".into(),
                        codec: "f32".into(),
                        offset: 0,
                        bits: 32,
                        note: String::new(),
                    }],
                },
                TargetSpec {
                    name: "params".into(),
                    format: "rgba8".into(),
                    note: String::new(),
                    afrc: None,
                    fields: vec![
                        f("metallic", "unorm-8", 0),
                        f("roughness", "unorm-8", 8),
                        f("specular", "unorm-8", 16),
                        f("specular_power", "log2-unorm-8", 24),
                    ],
                },
            ],
        };
        let base = Layout::from_spec(spec.clone()).unwrap();
        let mut g = scene(true);
        g.specular = Some(vec![0.5; g.len()]);
        let needs = analyze(&g);
        let (pruned, changes) = prune_spec(&spec, &needs);
        let p = Layout::from_spec(pruned).unwrap();
        assert!(changes.iter().any(|c| c.contains("dropped metallic")), "{changes:?}");
        assert!(changes.iter().any(|c| c.contains("rgba8 → rg8")), "{changes:?}");
        assert_eq!(p.bytes_per_sample(), base.bytes_per_sample() - 2);
        // The constants the lighting pass now assumes are the scene's values, so the roundtrip keeps them.
        let back = p.roundtrip(&g).unwrap();
        assert!(back.specular.as_deref().unwrap().iter().all(|&s| s == 0.5));
        assert!(back.metallic.as_deref().unwrap().iter().all(|&m| m == 0.0));
    }

    #[test]
    fn destiny_index_shrinks_to_the_material_count() {
        let g = scene(true);
        let needs = analyze(&g);
        assert_eq!(needs.material_count, 2);
        let (spec, changes) = prune_spec(Layout::by_name("destiny-96").unwrap().spec(), &needs);
        let p = Layout::from_spec(spec).unwrap();
        assert_eq!(p.indirection().map(|i| i.bits), Some(1), "{changes:?}");
        assert!(!p.indirection().unwrap().parameters.contains(&Attribute::Metallic));
        // The pruned layout still reproduces the scene's materials exactly.
        let back = p.roundtrip(&g).unwrap();
        assert_eq!(back.metallic.as_deref().map(|m| m.iter().all(|&x| x == 0.0)), Some(true));
    }
}
