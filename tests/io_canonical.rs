//! Canonical EXR: bit-exact read-back of every attribute at every sample count, and its header.

mod support;

use gbuf::gbuffer::Attribute;
use gbuf::io::canonical;
use gbuf::io::LoadOptions;
use support::{assert_bit_exact, every_attribute};

#[test]
fn every_attribute_round_trips_bit_exactly_at_every_sample_count() {
    let dir = tempfile::tempdir().unwrap();
    for (i, samples) in [1u32, 2, 4, 8, 16].into_iter().enumerate() {
        let gb = every_attribute(7, 5, samples, 100 + i as u64);
        let p = dir.path().join(format!("s{samples}.exr"));
        canonical::write(&p, &gb).unwrap();
        let back = canonical::read(&p, &LoadOptions::default()).unwrap();
        assert_bit_exact(&gb, &back);
    }
}

#[test]
fn folded_nine_samples_round_trip_with_their_ordered_grid() {
    let dir = tempfile::tempdir().unwrap();
    let src = every_attribute(9, 6, 1, 7);
    let folded = gbuf::io::fold::fold(&src, 3).unwrap();
    assert_eq!(folded.samples, 9);
    let p = dir.path().join("f9.exr");
    canonical::write(&p, &folded).unwrap();
    let back = canonical::read(&p, &LoadOptions::default()).unwrap();
    assert_bit_exact(&folded, &back);
    assert_eq!(back.sample_positions, gbuf::gbuffer::ordered_grid_positions(3));
}

#[test]
fn absent_attributes_stay_absent_and_ids_are_uint_channels() {
    let mut gb = every_attribute(4, 3, 2, 1);
    gb.remove(Attribute::Motion);
    gb.remove(Attribute::Position);
    gb.camera = None;
    let raw = canonical::to_raw(&gb);
    assert!(canonical::matches(&raw));
    assert!(raw.channels.iter().all(|c| !c.name.contains("motion") && !c.name.contains("position")));
    let id = raw.channel("s1.material_id.ID").expect("id channel");
    assert_eq!(id.data.type_name(), "uint");
    assert_eq!(raw.channel("s0.depth.Z").unwrap().data.type_name(), "float");
    assert!(raw.attributes.iter().all(|(k, _)| k != canonical::ATTR_CAMERA));
    let back = canonical::from_raw(&raw, "mem.exr".as_ref()).unwrap();
    assert_bit_exact(&gb, &back);
}

#[test]
fn header_problems_are_named() {
    let gb = every_attribute(3, 2, 4, 2);
    let path = std::path::Path::new("bad.exr");
    let edit = |key: &str, value: Option<&str>| {
        let mut raw = canonical::to_raw(&gb);
        raw.attributes.retain(|(k, _)| k != key);
        if let Some(v) = value {
            raw.attributes.push((key.into(), v.into()));
        }
        canonical::from_raw(&raw, path).unwrap_err().to_string()
    };
    let e = edit(canonical::ATTR_VERSION, Some("2"));
    assert!(e.contains("bad.exr") && e.contains("version 2"), "{e}");
    let e = edit(canonical::ATTR_SAMPLES, Some("65"));
    assert!(e.contains("gbuf.samples"), "{e}");
    let e = edit(canonical::ATTR_SAMPLE_POSITIONS, Some("[[0,0]]"));
    assert!(e.contains("1 positions for 4 samples"), "{e}");
    let e = edit(canonical::ATTR_CAMERA, Some("{\"yfov\": 1}"));
    assert!(e.contains("gbuf.camera"), "{e}");
    // More samples declared than channels present: the missing channel is named, with the channels found.
    let mut raw = canonical::to_raw(&gb);
    raw.attributes.retain(|(k, _)| k != canonical::ATTR_SAMPLES && k != canonical::ATTR_SAMPLE_POSITIONS);
    raw.attributes.push((canonical::ATTR_SAMPLES.into(), "8".into()));
    let e = canonical::from_raw(&raw, path).unwrap_err().to_string();
    assert!(e.contains("s4.coverage.V") && e.contains("channels found"), "{e}");
    // An ID stored as float is refused rather than rounded.
    let mut raw = canonical::to_raw(&gb);
    let ch = raw.channels.iter_mut().find(|c| c.name == "s2.object_id.ID").unwrap();
    ch.data = gbuf::io::exr::RawData::F32(vec![1.0; 6]);
    let e = canonical::from_raw(&raw, path).unwrap_err().to_string();
    assert!(e.contains("s2.object_id.ID") && e.contains("float"), "{e}");
}

/// The conversion goes in blocks of pixels, in parallel: a frame of several blocks with a short last one reads back
/// bit for bit from float channels, and from half channels (values already half-representable, a file another tool
/// re-saved as half) to the same G-buffer.
#[test]
fn many_blocks_and_half_channels_read_back_exactly() {
    use gbuf::io::exr::RawData;
    let mut gb = every_attribute(97, 89, 4, 3); // 8633 pixels: two full blocks of 4096 and a short one
    let to_half = |v: f32| half::f16::from_f32(v).to_f32();
    for plane in [gb.normal.as_mut(), gb.albedo.as_mut()].into_iter().flatten() {
        plane.iter_mut().for_each(|c| *c = c.to_array().map(to_half).into());
    }
    let back = canonical::from_raw(&canonical::to_raw(&gb), std::path::Path::new("blocks.exr")).unwrap();
    assert_bit_exact(&gb, &back);
    let mut raw = canonical::to_raw(&gb);
    let mut halved = 0;
    for ch in raw.channels.iter_mut().filter(|c| c.name.contains(".normal.") || c.name.contains(".albedo.")) {
        if let RawData::F32(v) = &ch.data {
            ch.data = RawData::F16(v.iter().map(|&x| half::f16::from_f32(x)).collect());
            halved += 1;
        }
    }
    assert_eq!(halved, 4 * 6, "normal and albedo, 3 components, 4 samples");
    let back = canonical::from_raw(&raw, std::path::Path::new("half.exr")).unwrap();
    assert_bit_exact(&gb, &back);
}
