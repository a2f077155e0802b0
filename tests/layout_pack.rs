//! Whole-layout packing: every built-in packs and unpacks; unpacking is bit-exact with applying each field's codec
//! by hand; the reference layout is lossless; byte sizes add up; material indirection; hostile input.

use gbuf::base::rng::SplitMix64;
use gbuf::codec;
use gbuf::gbuffer::{Attribute, GBuffer};
use gbuf::layout::{pack::field_code, Layout, LayoutSpec, Slot};
use gbuf::Camera;
use glam::{Vec2, Vec3};

/// A synthetic G-buffer with every attribute, some background, and varied values (fixed seed).
fn synthetic(w: u32, h: u32, s: u32, seed: u64) -> GBuffer {
    let mut rng = SplitMix64::new(seed);
    let mut gb = GBuffer::new(w, h, s).unwrap();
    let n = gb.len();
    gb.camera = Some(Camera::identity(0.9, w as f32 / h as f32, 0.1, 200.0));
    gb.coverage = (0..n).map(|_| rng.next_f32() > 0.1).collect();
    let mut depth = Vec::with_capacity(n);
    let mut normal = Vec::with_capacity(n);
    for _ in 0..n {
        depth.push(rng.range_f32(0.2, 150.0));
        let v = Vec3::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), rng.range_f32(-0.2, 1.0));
        normal.push(v.normalize_or(Vec3::Z));
    }
    gb.depth = Some(depth);
    gb.normal = Some(normal);
    gb.albedo = Some((0..n).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())).collect());
    // Few distinct material tuples, as in a real scene: 5 materials.
    let mats: Vec<u32> = (0..n).map(|_| (rng.next_u64() % 5) as u32).collect();
    gb.specular = Some(mats.iter().map(|m| 0.04 + 0.1 * *m as f32).collect());
    gb.specular_power = Some(mats.iter().map(|m| 8.0 * (1 + m) as f32).collect());
    gb.roughness = Some(mats.iter().map(|m| 0.2 * *m as f32).collect());
    gb.metallic = Some(mats.iter().map(|m| (m % 2) as f32).collect());
    gb.material_id = Some(mats.clone());
    gb.object_id = Some((0..n).map(|_| (rng.next_u64() % 300) as u32).collect());
    gb.primitive_id = Some((0..n).map(|_| rng.next_u64() as u32).collect());
    gb.motion = Some((0..n).map(|_| Vec2::new(rng.range_f32(-0.9, 0.9), rng.range_f32(-0.9, 0.9))).collect());
    gb.derive_depth_or_position();
    // Loaders write 0 into planes at background samples; keep that convention.
    let cov = gb.coverage.clone();
    for i in (0..n).filter(|&i| !cov[i]) {
        for p in [&mut gb.depth, &mut gb.specular, &mut gb.specular_power, &mut gb.roughness, &mut gb.metallic] {
            p.as_mut().unwrap()[i] = 0.0;
        }
        for p in [&mut gb.position, &mut gb.normal, &mut gb.albedo] {
            p.as_mut().unwrap()[i] = Vec3::ZERO;
        }
        for p in [&mut gb.material_id, &mut gb.object_id, &mut gb.primitive_id] {
            p.as_mut().unwrap()[i] = 0;
        }
        gb.motion.as_mut().unwrap()[i] = Vec2::ZERO;
    }
    gb
}

#[test]
fn every_builtin_packs_to_its_declared_size_and_unpacks() {
    let gb = synthetic(13, 7, 4, 1);
    for layout in Layout::builtins() {
        let packed = layout.pack(&gb).unwrap();
        assert_eq!(packed.total_bytes(), gb.len() * layout.bytes_per_sample(), "{}", layout.name());
        let sum: usize = layout.formats().iter().map(|f| f.bytes()).sum();
        assert_eq!(layout.bytes_per_sample(), sum);
        let back = layout.unpack(&packed, &gb).unwrap();
        back.validate().unwrap();
        for a in layout.stored_attributes() {
            assert!(back.has(a), "{}: {} stored but not unpacked", layout.name(), a.name());
        }
        for (a, _) in layout.constants() {
            assert!(back.has(*a), "{}: constant {} missing", layout.name(), a.name());
        }
        // Background samples are zero everywhere.
        let bg = gb.coverage.iter().position(|c| !c).unwrap();
        assert_eq!(back.normal.as_ref().unwrap()[bg], Vec3::ZERO, "{}", layout.name());
        // Position is re-derived from depth and the camera.
        assert!(back.position.is_some(), "{}", layout.name());
    }
}

#[test]
fn footprint_of_the_seed_layout_matches_the_seed_arithmetic() {
    let fat = Layout::by_name("fat-20").unwrap();
    assert_eq!(fat.bytes_per_sample(), 20);
    assert_eq!(fat.footprint_bytes(1900, 1200, 4), 182_400_000);
    assert_eq!(Layout::by_name("lauritzen-15").unwrap().bytes_per_sample(), 15);
    assert_eq!(Layout::by_name("destiny-96").unwrap().bytes_per_sample() * 8, 96);
    assert_eq!(Layout::by_name("minimal-8").unwrap().bytes_per_sample(), 8);
    assert_eq!(Layout::by_name("bevy-deferred").unwrap().formats()[1].bytes(), 16);
}

/// The value a field's codec gives for sample `i` when applied by hand, as raw bits for exact comparison.
fn by_hand(layout: &Layout, gb: &GBuffer, range: [f32; 2], slot: Slot, codec_name: &str, i: usize) -> Vec<u32> {
    match slot {
        Slot::Whole(Attribute::Normal) => {
            let c = codec::normal_codec(codec_name).unwrap();
            c.decode(c.encode(gb.normal.as_ref().unwrap()[i])).to_array().map(f32::to_bits).to_vec()
        }
        Slot::Whole(Attribute::Albedo) => {
            let c = codec::color_codec(codec_name).unwrap();
            c.decode(c.encode(gb.albedo.as_ref().unwrap()[i])).to_array().map(f32::to_bits).to_vec()
        }
        Slot::Whole(Attribute::Depth) => {
            let c = codec::depth_codec(codec_name, range[0], range[1]).unwrap();
            vec![c.decode(c.encode(gb.depth.as_ref().unwrap()[i])).to_bits()]
        }
        Slot::Whole(a) if a.is_id() => {
            let bits: u32 = codec_name.trim_start_matches("uint-").parse().unwrap();
            let v = match gb.plane(a).unwrap() {
                gbuf::gbuffer::PlaneRef::U32(p) => p[i],
                _ => unreachable!(),
            };
            vec![u64::from(v).min((1u64 << bits) - 1) as u32]
        }
        Slot::Whole(a) => {
            let c = codec::scalar_codec(codec_name).unwrap();
            let v = match gb.plane(a).unwrap() {
                gbuf::gbuffer::PlaneRef::F32(p) => p[i],
                _ => unreachable!(),
            };
            vec![c.decode(c.encode(v)).to_bits()]
        }
        Slot::Component(a, k) => {
            let c = codec::scalar_codec(codec_name).unwrap();
            let v = match gb.plane(a).unwrap() {
                gbuf::gbuffer::PlaneRef::Vec3(p) => p[i][k],
                gbuf::gbuffer::PlaneRef::Vec2(p) => p[i][k],
                _ => unreachable!(),
            };
            vec![c.decode(c.encode(v)).to_bits()]
        }
        _ => panic!("{}: no codec for {}", layout.name(), slot.name()),
    }
}

fn unpacked_bits(back: &GBuffer, slot: Slot, i: usize) -> Vec<u32> {
    use gbuf::gbuffer::PlaneRef as P;
    let a = slot.attribute().unwrap();
    match (slot, back.plane(a).unwrap()) {
        (Slot::Whole(_), P::Vec3(p)) => p[i].to_array().map(f32::to_bits).to_vec(),
        (Slot::Whole(_), P::F32(p)) => vec![p[i].to_bits()],
        (Slot::Whole(_), P::U32(p)) => vec![p[i]],
        (Slot::Component(_, k), P::Vec3(p)) => vec![p[i][k].to_bits()],
        (Slot::Component(_, k), P::Vec2(p)) => vec![p[i][k].to_bits()],
        _ => unreachable!(),
    }
}

#[test]
fn unpack_is_bit_exact_with_the_codecs_applied_one_by_one() {
    let gb = synthetic(9, 5, 4, 2);
    for layout in Layout::builtins() {
        let packed = layout.pack(&gb).unwrap();
        let back = layout.unpack(&packed, &gb).unwrap();
        for field in layout.fields() {
            if matches!(field.slot, Slot::Reserved | Slot::MaterialIndex) {
                continue;
            }
            for i in (0..gb.len()).filter(|&i| gb.coverage[i]) {
                let want = by_hand(&layout, &gb, packed.depth_range, field.slot, &field.codec, i);
                let got = unpacked_bits(&back, field.slot, i);
                assert_eq!(got, want, "{}: {} ({}) at sample {i}", layout.name(), field.slot.name(), field.codec);
            }
        }
        // Reserved bits are zero in the packed words.
        for field in layout.fields().iter().filter(|f| f.slot == Slot::Reserved) {
            assert!((0..gb.len()).all(|i| field_code(&packed, field, i) == 0), "{}", layout.name());
        }
    }
}

/// Large enough for many parallel row blocks (a row is 303 × 2 samples; blocks are whole rows) and a short last
/// block: every 11th sample of every field still equals the codecs applied by hand.
#[test]
fn unpack_is_bit_exact_across_parallel_row_blocks() {
    let gb = synthetic(303, 31, 2, 5);
    for layout in Layout::builtins() {
        let packed = layout.pack(&gb).unwrap();
        let back = layout.unpack(&packed, &gb).unwrap();
        for field in layout.fields().iter().filter(|f| !matches!(f.slot, Slot::Reserved | Slot::MaterialIndex)) {
            for i in (0..gb.len()).step_by(11).filter(|&i| gb.coverage[i]) {
                let want = by_hand(&layout, &gb, packed.depth_range, field.slot, &field.codec, i);
                assert_eq!(
                    unpacked_bits(&back, field.slot, i),
                    want,
                    "{}: {} at {i}",
                    layout.name(),
                    field.slot.name()
                );
            }
        }
        // Background texels are cleared in every target: zero, but a depth field holds its codec's clear code
        // (the far plane), so the coverage read back from the depth field is the G-buffer's.
        let bg: Vec<usize> = (0..gb.len()).filter(|&i| !gb.coverage[i]).collect();
        let [n, f] = packed.depth_range;
        for (ti, t) in packed.targets.iter().enumerate() {
            let size = t.format.bytes();
            let mut clear = [0u8; 16];
            for field in layout.fields().iter().filter(|x| x.target == ti && x.slot == Slot::Whole(Attribute::Depth)) {
                let code = codec::depth_codec(&field.codec, n, f).unwrap().clear_code();
                let word = u128::from(code) << field.offset;
                clear = word.to_le_bytes();
            }
            let ok = bg.iter().all(|&i| t.bytes[i * size..(i + 1) * size] == clear[..size]);
            assert!(ok, "{}: {}", layout.name(), t.name);
        }
        if layout.stores(Attribute::Depth) {
            let cov = layout.coverage_from_depth(&packed.targets, packed.depth_range).unwrap().unwrap();
            assert_eq!(cov, gb.coverage, "{}: coverage from the depth field", layout.name());
        }
    }
}

/// The timed roundtrip goes band by band (a band of whole rows packed, then unpacked at once) and reuses its output
/// planes from run to run: its G-buffer equals unpacking the whole packed frame, for every layout, over two bands
/// with a short last one, and after a second run that overwrote the first run's planes (the material table built
/// once for both runs).
#[test]
fn banded_roundtrip_equals_whole_frame_pack_and_unpack() {
    let gb = synthetic(700, 200, 2, 9); // rows of 1,400 samples: bands of 261,800 and 18,200
    assert!(gb.len() > gbuf::layout::pack::BAND_SAMPLES);
    for layout in Layout::builtins().into_iter().chain(Layout::visibility_builtins()) {
        let whole = layout.unpack(&layout.pack(&gb).unwrap(), &gb).unwrap();
        let timed = layout.roundtrip_timed(&gb, 2).unwrap();
        assert_eq!((timed.encode_ms.len(), timed.decode_ms.len()), (2, 2));
        assert!(timed.encode_ms.iter().chain(&timed.decode_ms).all(|t| t.is_finite() && *t >= 0.0));
        // The material table is built once, outside the timed runs, and timed only with indirection.
        assert_eq!(timed.table_ms.is_some(), layout.indirection().is_some(), "{}", layout.name());
        assert!(timed.table_ms.is_none_or(|t| t.is_finite() && t >= 0.0));
        assert!(timed.decoded == whole, "{}: banded roundtrip differs from pack + unpack", layout.name());
        assert!(layout.roundtrip(&gb).unwrap() == whole, "{}", layout.name());
    }
}

/// fat-20 stores motion as two snorm-8 over ±32 pixels (Killzone 2's 2 × 8-bit motion).
#[test]
fn fat_20_stores_signed_8_bit_motion() {
    let mut gb = synthetic(8, 4, 2, 9);
    let specials = [(-31.7f32, 12.25f32), (40.0, -1e9), (f32::NAN, -0.0), (0.126, -32.0)];
    let covered: Vec<usize> = (0..gb.len()).filter(|&i| gb.coverage[i]).collect();
    for (&i, &(x, y)) in covered.iter().zip(&specials) {
        gb.motion.as_mut().unwrap()[i] = Vec2::new(x, y);
    }
    let layout = Layout::by_name("fat-20").unwrap();
    let fields: Vec<_> = layout.fields().iter().filter(|f| f.slot.attribute() == Some(Attribute::Motion)).collect();
    assert_eq!(fields.len(), 2);
    assert!(fields.iter().all(|f| f.codec == "snorm-8:32" && f.bits == 8));
    let back = layout.roundtrip(&gb).unwrap();
    let c = codec::scalar_codec("snorm-8:32").unwrap();
    let (m, b) = (gb.motion.as_ref().unwrap(), back.motion.as_ref().unwrap());
    for &i in &covered {
        for k in 0..2 {
            let v = m[i][k];
            let want = if v.is_nan() { 0.0 } else { v.clamp(-32.0, 32.0) };
            assert!((b[i][k] - want).abs() <= c.error_bound(want), "{i}.{k}: {v} → {}", b[i][k]);
        }
    }
    assert_eq!(b[covered[1]], Vec2::new(32.0, -32.0), "out-of-range motion clamps to ±32 px");
    assert_eq!(b[covered[2]], Vec2::ZERO, "NaN motion reads as 0");
}

#[test]
fn packed_words_hold_the_codec_output_at_the_field_offset() {
    let gb = synthetic(5, 4, 2, 3);
    let layout = Layout::by_name("lauritzen-15").unwrap();
    let packed = layout.pack(&gb).unwrap();
    let i = gb.coverage.iter().position(|c| *c).unwrap();
    // The depth target is an R32F: its 4 bytes are exactly the f32 depth, little-endian.
    assert_eq!(&packed.targets[0].bytes[i * 4..i * 4 + 4], &gb.depth.as_ref().unwrap()[i].to_le_bytes());
    // The albedo target is 3 bytes per sample, red first.
    let c = codec::color_codec("unorm8").unwrap();
    let code = c.encode(gb.albedo.as_ref().unwrap()[i]);
    assert_eq!(packed.targets[3].bytes[i * 3..i * 3 + 3], code.to_le_bytes()[..3]);
}

#[test]
fn the_reference_layout_is_lossless() {
    let gb = synthetic(11, 6, 8, 4);
    let layout = Layout::by_name("reference-f32").unwrap();
    let back = layout.roundtrip(&gb).unwrap();
    for a in Attribute::ALL {
        assert_eq!(back.plane(a).is_some(), gb.plane(a).is_some(), "{}", a.name());
    }
    // Bit-exact, plane by plane (PartialEq on f32 would also accept -0.0 for 0.0; compare bits).
    let bits3 = |p: &Option<Vec<Vec3>>| -> Vec<[u32; 3]> {
        p.as_ref().unwrap().iter().map(|v| v.to_array().map(f32::to_bits)).collect()
    };
    let bits1 = |p: &Option<Vec<f32>>| -> Vec<u32> { p.as_ref().unwrap().iter().map(|v| v.to_bits()).collect() };
    for (a, b) in [(&back.normal, &gb.normal), (&back.position, &gb.position), (&back.albedo, &gb.albedo)] {
        assert!(bits3(a) == bits3(b));
    }
    for (a, b) in [
        (&back.depth, &gb.depth),
        (&back.specular, &gb.specular),
        (&back.specular_power, &gb.specular_power),
        (&back.roughness, &gb.roughness),
        (&back.metallic, &gb.metallic),
    ] {
        assert!(bits1(a) == bits1(b));
    }
    assert!(back.motion == gb.motion && back.material_id == gb.material_id);
    assert!(back.object_id == gb.object_id && back.primitive_id == gb.primitive_id);
    assert!(back == gb, "some plane differs");
}

#[test]
fn material_indirection_is_lossless_when_the_tuples_fit() {
    let gb = synthetic(16, 8, 4, 5); // 5 distinct tuples, 8-bit index
    let layout = Layout::by_name("destiny-96").unwrap();
    let packed = layout.pack(&gb).unwrap();
    let table = packed.material_table.as_ref().unwrap();
    assert!(table.lossless);
    assert_eq!(table.distinct_tuples, 5);
    assert_eq!(table.entries.len(), 5);
    let back = layout.unpack(&packed, &gb).unwrap();
    for a in [Attribute::Specular, Attribute::SpecularPower, Attribute::Roughness, Attribute::Metallic] {
        let (r, t) = match (gb.plane(a).unwrap(), back.plane(a).unwrap()) {
            (gbuf::gbuffer::PlaneRef::F32(r), gbuf::gbuffer::PlaneRef::F32(t)) => (r, t),
            _ => unreachable!(),
        };
        for i in (0..gb.len()).filter(|&i| gb.coverage[i]) {
            assert_eq!(r[i].to_bits(), t[i].to_bits(), "{} at {i}", a.name());
        }
    }
}

#[test]
fn material_indirection_clusters_and_reports_when_it_does_not_fit() {
    let mut gb = synthetic(32, 16, 2, 6);
    let mut rng = SplitMix64::new(9);
    for r in gb.roughness.as_mut().unwrap() {
        *r = rng.next_f32(); // ~1000 distinct tuples into 256 entries
    }
    let layout = Layout::by_name("destiny-96").unwrap();
    // With the dump's material IDs the table is keyed by them: one entry per ID, the error the variation inside
    // each material, as measured on the unpacked buffer.
    let packed = layout.pack(&gb).unwrap();
    let table = packed.material_table.as_ref().unwrap();
    let mut ids: Vec<u32> = gb.material_id.clone().unwrap();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!((table.key.as_str(), table.entries.len()), ("material-id", table.ids.len()));
    assert!(table.ids.iter().all(|i| ids.contains(i)));
    let k = table.parameters.iter().position(|p| p == "roughness").unwrap();
    let back = layout.unpack(&packed, &gb).unwrap();
    let measured = gbuf::measure::gbuffer::compare(&gb, &back).unwrap().scalar(Attribute::Roughness).unwrap().max_abs;
    assert!((measured - f64::from(table.max_abs_error[k])).abs() < 1e-6, "{measured} vs {:?}", table.max_abs_error);
    // Without IDs: a palette of the tuples, clustered.
    gb.material_id = None;
    let packed = layout.pack(&gb).unwrap();
    let table = packed.material_table.as_ref().unwrap();
    assert!(!table.lossless);
    assert!(table.distinct_tuples > 256);
    assert_eq!(table.entries.len(), 256);
    let k = table.parameters.iter().position(|p| p == "roughness").unwrap();
    assert!(table.max_abs_error[k] > 0.0);
    // 256 entries over ~1000 tuples spread over 5 × [0, 1): every sample lands within a small box.
    assert!(table.max_abs_error[k] < 0.1, "{:?}", table.max_abs_error);
    // The reported error is the measured one.
    let back = layout.unpack(&packed, &gb).unwrap();
    let e = gbuf::measure::gbuffer::compare(&gb, &back).unwrap();
    let measured = e.scalar(Attribute::Roughness).unwrap().max_abs;
    assert!((measured - f64::from(table.max_abs_error[k])).abs() < 1e-6, "{measured} vs {:?}", table.max_abs_error);
}

#[test]
fn nan_and_infinite_input_do_not_panic_and_unpack_finite() {
    let mut gb = synthetic(6, 4, 4, 7);
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -0.0, 1e-42];
    for (i, v) in bad.iter().enumerate() {
        gb.coverage[i] = true;
        gb.depth.as_mut().unwrap()[i] = *v;
        gb.normal.as_mut().unwrap()[i] = Vec3::splat(*v);
        gb.albedo.as_mut().unwrap()[i] = Vec3::splat(*v);
        gb.roughness.as_mut().unwrap()[i] = *v;
        gb.specular_power.as_mut().unwrap()[i] = *v;
        gb.motion.as_mut().unwrap()[i] = Vec2::splat(*v);
    }
    for layout in Layout::builtins() {
        let back = layout.roundtrip(&gb).unwrap();
        if layout.name() == "reference-f32" {
            continue; // f32 stores what it is given (NaN is mapped by the codec, not by the layout)
        }
        for i in 0..bad.len() {
            assert!(back.normal.as_ref().unwrap()[i].is_finite(), "{}", layout.name());
            assert!(back.depth.as_ref().unwrap()[i].is_finite(), "{}", layout.name());
            assert!(back.albedo.as_ref().is_none_or(|a| a[i].is_finite()), "{}", layout.name());
        }
    }
}

#[test]
fn unpack_refuses_mismatched_input() {
    let gb = synthetic(4, 4, 2, 8);
    let a = Layout::by_name("fat-20").unwrap();
    let b = Layout::by_name("minimal-8").unwrap();
    let packed = a.pack(&gb).unwrap();
    assert!(b.unpack(&packed, &gb).unwrap_err().to_string().contains("fat-20"));
    let other = synthetic(4, 3, 2, 8);
    assert!(a.unpack(&packed, &other).is_err());
    let mut cut = packed.clone();
    cut.targets[1].bytes.pop();
    assert!(a.unpack(&cut, &gb).is_err());
}

#[test]
fn unstored_attributes_get_constants_or_stay_absent() {
    let gb = synthetic(4, 4, 1, 10);
    let layout = Layout::by_name("minimal-8").unwrap();
    let back = layout.roundtrip(&gb).unwrap();
    let i = gb.coverage.iter().position(|c| *c).unwrap();
    assert_eq!(back.specular.as_ref().unwrap()[i], 0.5);
    assert_eq!(back.metallic.as_ref().unwrap()[i], 0.0);
    assert!(back.object_id.is_none() && back.motion.is_none() && back.specular_power.is_none());
    let spec: &LayoutSpec = layout.spec();
    assert!(spec.constants.contains_key("specular"));
}

/// `rgb9e5` as a render-target format (issue 16): one 32-bit target holding an RGB9E5 colour. Every code of each
/// channel (32 exponents × 512 mantissas, the other channels 0), and the midpoints between neighbouring codes, pack
/// to exactly the codec's word at offset 0, unpack to exactly the codec's decode, and round-trip within the codec's
/// documented bound.
#[test]
fn rgb9e5_target_round_trips_every_channel_code() {
    let text = r#"
name = "hdr-9e5"
[[targets]]
name = "emissive"
format = "rgb9e5"
fields = [{ attribute = "albedo", codec = "rgb9e5", offset = 0, bits = 32 }]
"#;
    let spec = gbuf::layout::LayoutSpec::parse(std::path::Path::new("hdr-9e5.toml"), text).unwrap();
    let layout = Layout::from_spec(spec).unwrap();
    assert_eq!(layout.bytes_per_sample(), 4);
    let c = codec::color_codec("rgb9e5").unwrap();
    let mut values = Vec::new();
    for k in 0..3 {
        for e in 0u64..32 {
            for m in 0u64..512 {
                let code = (m << (9 * k)) | (e << 27);
                let v = c.decode(code);
                let step = c.decode((1 << (9 * k)) | (e << 27));
                values.push(v);
                values.push(v + step * 0.5);
            }
        }
    }
    let mut gb = GBuffer::new(values.len() as u32, 1, 1).unwrap();
    gb.coverage = vec![true; values.len()];
    gb.albedo = Some(values.clone());
    let packed = layout.pack(&gb).unwrap();
    let back = layout.unpack(&packed, &gb).unwrap();
    let got = back.albedo.as_ref().unwrap();
    for (i, v) in values.iter().enumerate() {
        let word = u32::from_le_bytes(packed.targets[0].bytes[i * 4..i * 4 + 4].try_into().unwrap());
        let code = c.encode(*v);
        assert_eq!(u64::from(word), code, "value {v}: texel {word:#010x}, codec {code:#010x}");
        assert_eq!(got[i].to_array().map(f32::to_bits), c.decode(code).to_array().map(f32::to_bits), "{v}");
        let bound = c.error_bound(*v);
        assert!((got[i] - *v).abs().cmple(bound).all(), "{v} → {}: off by {} > {bound}", got[i], (got[i] - *v).abs());
    }
}

/// The report's roundtrip leaves positions to the lighting where the layout stores depth only: no position plane,
/// every other plane the same as the plain roundtrip's, and the resolve of either gives the same image bit for bit
/// (the lighting derives each position exactly as the plain roundtrip's plane holds it), also for an off-centre
/// camera; layouts that store position keep it.
#[test]
fn lighting_roundtrip_leaves_positions_to_the_lighting_with_the_same_image() {
    use gbuf::resolve::{resolve, ResolveConfig};
    let mut gb = synthetic(40, 24, 2, 5);
    let mut cam = gb.camera.unwrap();
    cam.principal = Vec2::new(0.1, -0.05);
    gb.camera = Some(cam);
    gb.position = None;
    gb.fill_position_from_depth();
    let lights: Vec<gbuf::light::Light> = (0..6)
        .map(|k| {
            let p = Vec3::new(-3.0 + k as f32, 0.5 * (k % 3) as f32 - 0.5, -2.0 - 9.0 * k as f32);
            gbuf::light::Light::point(p, Vec3::new(1.0, 0.8, 0.6), 40.0, 200.0)
        })
        .collect();
    let mask = gbuf::detect::baselines::ssaa(&gb);
    let cfg = ResolveConfig::default();
    let mut derived = 0;
    for layout in Layout::builtins() {
        let full = layout.roundtrip_timed(&gb, 1).unwrap().decoded;
        let mut lit = layout.roundtrip_for_lighting(&gb, 1).unwrap().decoded;
        let depth_only = layout.stores(Attribute::Depth) && !layout.stores(Attribute::Position);
        assert_eq!(lit.position.is_none(), depth_only, "{}", layout.name());
        assert!(full.position.is_some(), "{}", layout.name());
        let a = resolve(&full, &lights, &mask, &cfg).unwrap();
        let b = resolve(&lit, &lights, &mask, &cfg).unwrap();
        assert!(a.image.rgb.iter().any(|c| c.max_element() > 0.0), "{}: lit", layout.name());
        assert!(a.image.rgb == b.image.rgb, "{}: the image changed without the position plane", layout.name());
        if depth_only {
            derived += 1;
            lit.position.clone_from(&full.position);
        }
        assert!(lit == full, "{}: a plane other than position differs", layout.name());
    }
    assert!(derived >= 4, "most built-ins store depth only ({derived})");
}

/// `roundtrip_matches` says whether a layout's lighting G-buffer is the input bit for bit, band by band: true for
/// the lossless reference layout, false for a lossy one. The sampled timing runs compare nothing and give finite,
/// non-negative times for any stride, a lossy layout's included.
#[test]
fn roundtrip_matches_tells_lossless_from_lossy_and_sampled_timing_compares_nothing() {
    let gb = gbuf::scene::render(gbuf::scene::SceneName::Room, 61, 300, 4).unwrap();
    let lossless = Layout::by_name("reference-f32").unwrap();
    let lossy = Layout::by_name("lauritzen-15").unwrap();
    assert!(lossless.roundtrip_matches(&gb).unwrap().0, "reference-f32 keeps the room");
    assert!(!lossy.roundtrip_matches(&gb).unwrap().0, "lauritzen-15 quantises the room");
    for stride in [1, 8, 1000] {
        let (enc, dec) = lossy.roundtrip_time_sampled(&gb, stride).unwrap();
        assert!(enc.is_finite() && dec.is_finite() && enc >= 0.0 && dec >= 0.0, "stride {stride}: {enc} {dec}");
    }
}

/// A frame whose positions are what its depth and camera give (`gbuf report` leaves such a plane out) packs to the
/// same bytes without them: a layout storing positions stores the derived ones, band by band, and a lossless
/// layout's roundtrip still leaves the frame as it was. The derived positions are the plane's bit for bit, whole,
/// by rows and sample by sample; a plane that differs in one sample is not derivable.
#[test]
fn a_frame_without_the_positions_its_depth_gives_packs_as_with_them() {
    let gb = synthetic(700, 200, 2, 9); // several packing bands
    assert!(gb.len() > gbuf::layout::pack::BAND_SAMPLES);
    assert!(gb.position_is_derived());
    let mut bare = gb.clone();
    bare.position = None;
    assert!(!bare.position_is_derived(), "no plane: nothing to leave out");
    let bits = |p: &[Vec3]| p.iter().flat_map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<u32>>();
    let want = bits(gb.position.as_ref().unwrap());
    assert_eq!(bits(&bare.derived_positions().unwrap()), want);
    let row = (gb.width * gb.samples) as usize;
    assert_eq!(bits(&bare.derived_positions_of_rows(37..121).unwrap()), want[37 * row * 3..121 * row * 3]);
    let rays = gb.camera.unwrap().ray_caster(gb.width, gb.height);
    assert!((0..gb.len()).all(|i| bits(&[bare.position_or_derived(Some(&rays), i).unwrap()]) == want[3 * i..3 * i + 3]));
    for layout in Layout::builtins().into_iter().chain(Layout::visibility_builtins()) {
        let (with, without) = (layout.pack(&gb).unwrap(), layout.pack(&bare).unwrap());
        for (a, b) in with.targets.iter().zip(&without.targets) {
            assert!(a.bytes == b.bytes, "{}: target {} differs", layout.name(), a.name);
        }
        assert_eq!(with.present, without.present, "{}", layout.name());
        assert_eq!(
            layout.roundtrip_matches(&gb).unwrap().0,
            layout.roundtrip_matches(&bare).unwrap().0,
            "{}",
            layout.name()
        );
    }
    let lossless = Layout::by_name("reference-f32").unwrap();
    assert!(lossless.stores(Attribute::Position) && lossless.roundtrip_matches(&bare).unwrap().0);
    let back = lossless.unpack(&lossless.pack(&bare).unwrap(), &bare).unwrap();
    assert_eq!(bits(back.position.as_ref().unwrap()), want);
    let mut moved = gb.clone();
    let i = gb.coverage.iter().position(|&c| c).unwrap();
    moved.position.as_mut().unwrap()[i].x += 1e-3;
    assert!(!moved.position_is_derived());
}
