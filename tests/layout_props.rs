//! Random user layouts: fields of random widths at random offsets (crossing byte and 64-bit boundaries) in random
//! formats. Every packed texel holds exactly each codec's code at its field's bits, and unpacking equals
//! `decode(encode(x))` bit for bit.

use gbuf::base::rng::SplitMix64;
use gbuf::codec;
use gbuf::gbuffer::{GBuffer, PlaneRef};
use gbuf::layout::{pack::field_code, FieldSpec, Format, Layout, LayoutSpec, Slot, TargetSpec};
use glam::{Vec2, Vec3};
use proptest::prelude::*;

/// Scalar slots a random layout may use, each at most once.
const SLOTS: [&str; 17] = [
    "specular",
    "specular_power",
    "roughness",
    "metallic",
    "motion.x",
    "motion.y",
    "albedo.r",
    "albedo.g",
    "albedo.b",
    "normal.x",
    "normal.y",
    "normal.z",
    "position.x",
    "position.y",
    "position.z",
    "object_id",
    "primitive_id",
];

/// A random codec for `slot` and its width.
fn codec_for(slot: &str, rng: &mut SplitMix64) -> (String, u32) {
    if slot.ends_with("_id") {
        let n = 1 + (rng.next_u64() % 32) as u32;
        return (format!("uint-{n}"), n);
    }
    match rng.next_u64() % 4 {
        0 => ("f16".into(), 16),
        1 => ("f32".into(), 32),
        _ => {
            let n = 1 + (rng.next_u64() % 24) as u32;
            (format!("unorm-{n}"), n)
        }
    }
}

/// A random valid spec: up to three targets, fields packed left to right with random gaps.
fn random_spec(seed: u64) -> LayoutSpec {
    let mut rng = SplitMix64::new(seed);
    let mut slots: Vec<&str> = SLOTS.to_vec();
    let mut targets = Vec::new();
    for t in 0..1 + rng.next_u64() % 3 {
        let format = Format::ALL[(rng.next_u64() % Format::ALL.len() as u64) as usize];
        let mut fields = Vec::new();
        let mut offset = 0;
        while !slots.is_empty() {
            let slot = slots.swap_remove((rng.next_u64() % slots.len() as u64) as usize);
            let (codec, bits) = codec_for(slot, &mut rng);
            let gap = (rng.next_u64() % 5) as u32;
            if offset + gap + bits > format.bits() {
                slots.push(slot);
                break;
            }
            fields.push(FieldSpec { attribute: slot.into(), codec, offset: offset + gap, bits, note: String::new() });
            offset += gap + bits;
        }
        targets.push(TargetSpec {
            name: format!("t{t}"),
            format: format.name().into(),
            note: String::new(),
            afrc: None,
            fields,
        });
    }
    LayoutSpec {
        name: format!("random-{seed}"),
        description: String::new(),
        sources: vec![],
        depth_range: None,
        constants: Default::default(),
        material_indirection: None,
        targets,
    }
}

fn buffer(seed: u64) -> GBuffer {
    let mut rng = SplitMix64::new(seed ^ 0x9e37_79b9);
    let mut gb = GBuffer::new(5, 3, 2).unwrap();
    let n = gb.len();
    gb.coverage = (0..n).map(|i| i != 3).collect();
    let mut v = |lo: f32, hi: f32| rng.range_f32(lo, hi);
    let v3 = |v: &mut dyn FnMut(f32, f32) -> f32| Vec3::new(v(-2.0, 2.0), v(-2.0, 2.0), v(-2.0, 2.0));
    gb.normal = Some((0..n).map(|_| v3(&mut v)).collect());
    gb.albedo = Some((0..n).map(|_| v3(&mut v)).collect());
    gb.position = Some((0..n).map(|_| v3(&mut v)).collect());
    gb.motion = Some((0..n).map(|_| Vec2::new(v(-3.0, 3.0), v(-3.0, 3.0))).collect());
    gb.specular = Some((0..n).map(|_| v(-0.5, 1.5)).collect());
    gb.specular_power = Some((0..n).map(|_| v(0.0, 5000.0)).collect());
    gb.roughness = Some((0..n).map(|_| v(0.0, 1.0)).collect());
    gb.metallic = Some((0..n).map(|_| v(0.0, 1.0)).collect());
    let mut r2 = SplitMix64::new(seed);
    gb.object_id = Some((0..n).map(|_| r2.next_u64() as u32).collect());
    gb.primitive_id = Some((0..n).map(|_| (r2.next_u64() % 1000) as u32).collect());
    gb
}

/// The input value of a scalar slot at sample `i`.
fn input(gb: &GBuffer, slot: Slot, i: usize) -> f32 {
    match (slot, gb.plane(slot.attribute().unwrap()).unwrap()) {
        (Slot::Whole(_), PlaneRef::F32(p)) => p[i],
        (Slot::Component(_, k), PlaneRef::Vec3(p)) => p[i][k],
        (Slot::Component(_, k), PlaneRef::Vec2(p)) => p[i][k],
        _ => unreachable!(),
    }
}

fn output_bits(gb: &GBuffer, slot: Slot, i: usize) -> u32 {
    match (slot, gb.plane(slot.attribute().unwrap()).unwrap()) {
        (Slot::Whole(_), PlaneRef::F32(p)) => p[i].to_bits(),
        (Slot::Whole(_), PlaneRef::U32(p)) => p[i],
        (Slot::Component(_, k), PlaneRef::Vec3(p)) => p[i][k].to_bits(),
        (Slot::Component(_, k), PlaneRef::Vec2(p)) => p[i][k].to_bits(),
        _ => unreachable!(),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_layouts_place_codes_exactly(seed in any::<u64>()) {
        let layout = Layout::from_spec(random_spec(seed)).unwrap();
        prop_assume!(!layout.fields().is_empty());
        let gb = buffer(seed);
        let packed = layout.pack(&gb).unwrap();
        let back = layout.unpack(&packed, &gb).unwrap();
        for f in layout.fields() {
            for i in 0..gb.len() {
                let code = field_code(&packed, f, i);
                if !gb.coverage[i] {
                    prop_assert_eq!(code, 0);
                    continue;
                }
                if let Some(bits) = f.codec.strip_prefix("uint-") {
                    let bits: u32 = bits.parse().unwrap();
                    let PlaneRef::U32(p) = gb.plane(f.slot.attribute().unwrap()).unwrap() else { unreachable!() };
                    let want = u64::from(p[i]).min((1u64 << bits) - 1);
                    prop_assert_eq!(code, want);
                    prop_assert_eq!(u64::from(output_bits(&back, f.slot, i)), want);
                    continue;
                }
                let c = codec::scalar_codec(&f.codec).unwrap();
                let x = input(&gb, f.slot, i);
                prop_assert_eq!(code, c.encode(x), "{} {} at {}", f.slot.name(), f.codec, i);
                prop_assert_eq!(output_bits(&back, f.slot, i), c.decode(c.encode(x)).to_bits());
            }
        }
    }
}
