//! Shared builders for the I/O tests: G-buffers with every attribute and adversarial values.
#![allow(dead_code)] // each test binary uses a subset

use gbuf::base::rng::SplitMix64;
use gbuf::gbuffer::{Attribute, GBuffer, PlaneRef};
use gbuf::Camera;
use glam::{Vec2, Vec3};

/// Values that break careless float handling: signed zero, denormals, extremes.
pub const TRICKY: [f32; 8] =
    [-0.0, 0.0, f32::MIN_POSITIVE / 8.0, -f32::MIN_POSITIVE / 3.0, f32::MAX, -3.4e38, 1e-30, 7.25];

/// A G-buffer of `w`×`h` pixels with `samples` samples carrying every attribute, filled with seeded random values
/// and [`TRICKY`] values, IDs up to `u32::MAX`, and a camera.
pub fn every_attribute(w: u32, h: u32, samples: u32, seed: u64) -> GBuffer {
    let mut gb = GBuffer::new(w, h, samples).expect("size");
    let n = gb.len();
    let mut r = SplitMix64::new(seed);
    let f = |i: usize, r: &mut SplitMix64| {
        if i % 7 == 3 {
            TRICKY[(r.next_u64() % 8) as usize]
        } else {
            r.range_f32(-100.0, 100.0)
        }
    };
    gb.coverage = (0..n).map(|i| i % 5 != 0).collect();
    gb.depth = Some((0..n).map(|i| f(i, &mut r)).collect());
    gb.position = Some((0..n).map(|i| Vec3::new(f(i, &mut r), f(i + 1, &mut r), f(i + 2, &mut r))).collect());
    gb.normal = Some((0..n).map(|i| Vec3::new(f(i, &mut r), -0.0, f(i + 3, &mut r))).collect());
    gb.albedo = Some((0..n).map(|i| Vec3::new(f(i, &mut r), f(i + 4, &mut r), 0.5)).collect());
    gb.specular = Some((0..n).map(|i| f(i, &mut r)).collect());
    gb.specular_power = Some((0..n).map(|i| f(i + 1, &mut r)).collect());
    gb.roughness = Some((0..n).map(|i| f(i + 2, &mut r)).collect());
    gb.metallic = Some((0..n).map(|i| f(i + 5, &mut r)).collect());
    gb.material_id = Some((0..n).map(|i| if i % 3 == 0 { u32::MAX } else { r.next_u64() as u32 }).collect());
    gb.object_id = Some((0..n).map(|i| (i as u32).wrapping_mul(2_654_435_761)).collect());
    gb.primitive_id = Some((0..n).map(|i| if i % 2 == 0 { 0 } else { u32::MAX - i as u32 }).collect());
    gb.motion = Some((0..n).map(|i| Vec2::new(f(i, &mut r), f(i + 6, &mut r))).collect());
    gb.camera = Some(Camera::look_at(
        Vec3::new(1.5, 2.25, 7.0),
        Vec3::new(0.1, 0.3, -1.0),
        Vec3::Y,
        0.6883,
        w as f32 / h as f32,
        0.1,
        517.3,
    ));
    gb
}

/// A plausible covered G-buffer (positive depth, unit normals facing the camera, IDs small) with a camera.
pub fn plausible(w: u32, h: u32, samples: u32, seed: u64) -> GBuffer {
    let mut gb = GBuffer::new(w, h, samples).expect("size");
    let n = gb.len();
    let mut r = SplitMix64::new(seed);
    let cam = Camera::identity(0.8, w as f32 / h as f32, 0.1, 100.0);
    gb.coverage = (0..n).map(|i| i % 11 != 0).collect();
    let depth: Vec<f32> = gb.coverage.iter().map(|&c| if c { r.range_f32(1.0, 50.0) } else { 0.0 }).collect();
    gb.normal = Some(
        gb.coverage
            .iter()
            .map(|&c| {
                if c {
                    Vec3::new(r.range_f32(-0.5, 0.5), r.range_f32(-0.5, 0.5), 1.0).normalize()
                } else {
                    Vec3::ZERO
                }
            })
            .collect(),
    );
    gb.albedo = Some((0..n).map(|_| Vec3::new(r.next_f32(), r.next_f32(), r.next_f32())).collect());
    gb.roughness = Some((0..n).map(|_| r.next_f32()).collect());
    gb.material_id = Some((0..n).map(|_| (r.next_u64() % 12) as u32).collect());
    gb.depth = Some(depth);
    gb.camera = Some(cam);
    gb.derive_depth_or_position();
    gb
}

/// Bit patterns of every plane (f32 bits, u32 values), for bit-exact comparisons.
pub fn plane_bits(gb: &GBuffer, attr: Attribute) -> Option<Vec<u32>> {
    Some(match gb.plane(attr)? {
        PlaneRef::F32(v) => v.iter().map(|x| x.to_bits()).collect(),
        PlaneRef::Vec2(v) => v.iter().flat_map(|x| [x.x.to_bits(), x.y.to_bits()]).collect(),
        PlaneRef::Vec3(v) => v.iter().flat_map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()]).collect(),
        PlaneRef::U32(v) => v.to_vec(),
    })
}

/// Asserts two G-buffers are identical bit for bit (every plane, coverage, positions, camera).
pub fn assert_bit_exact(a: &GBuffer, b: &GBuffer) {
    assert_eq!((a.width, a.height, a.samples), (b.width, b.height, b.samples));
    assert_eq!(a.coverage, b.coverage, "coverage");
    let pa: Vec<u32> = a.sample_positions.iter().flat_map(|p| [p.x.to_bits(), p.y.to_bits()]).collect();
    let pb: Vec<u32> = b.sample_positions.iter().flat_map(|p| [p.x.to_bits(), p.y.to_bits()]).collect();
    assert_eq!(pa, pb, "sample positions");
    for attr in Attribute::ALL {
        let (x, y) = (plane_bits(a, attr), plane_bits(b, attr));
        assert_eq!(x.is_some(), y.is_some(), "{} presence", attr.name());
        if let (Some(x), Some(y)) = (x, y) {
            let first = x.iter().zip(&y).position(|(p, q)| p != q);
            assert!(first.is_none(), "{}: first difference at {first:?}", attr.name());
        }
    }
    match (&a.camera, &b.camera) {
        (Some(x), Some(y)) => {
            let bits = |c: &Camera| {
                let mut v: Vec<u32> = c.world_to_view.to_cols_array().iter().map(|f| f.to_bits()).collect();
                v.extend([c.yfov, c.aspect, c.znear, c.zfar].map(f32::to_bits));
                v
            };
            assert_eq!(bits(x), bits(y), "camera");
        }
        (x, y) => assert_eq!(x.is_some(), y.is_some(), "camera presence"),
    }
}

/// One header attribute of a single-part EXR.
#[derive(Clone, Debug)]
pub struct HeaderAttr {
    /// Attribute name.
    pub name: String,
    /// Attribute type name.
    pub kind: String,
    /// Raw value bytes.
    pub value: Vec<u8>,
}

/// Parses the header of a single-part EXR: (attributes, offset of the byte after the header's terminating 0).
pub fn parse_header(bytes: &[u8]) -> (Vec<HeaderAttr>, usize) {
    let mut i = 8;
    let mut out = Vec::new();
    let cstr = |i: &mut usize| {
        let end = bytes[*i..].iter().position(|&b| b == 0).unwrap() + *i;
        let s = String::from_utf8_lossy(&bytes[*i..end]).into_owned();
        *i = end + 1;
        s
    };
    loop {
        if bytes[i] == 0 {
            return (out, i + 1);
        }
        let name = cstr(&mut i);
        let kind = cstr(&mut i);
        let size = i32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
        i += 4;
        out.push(HeaderAttr { name, kind, value: bytes[i..i + size].to_vec() });
        i += size;
    }
}

/// Rebuilds a single-part scan-line EXR with edited header attributes, shifting the offset table so the chunks
/// stay addressable. `version_flags` are OR-ed into the version field.
pub fn rebuild(bytes: &[u8], attrs: &[HeaderAttr], version_flags: u32) -> Vec<u8> {
    let (_, end) = parse_header(bytes);
    let mut out = bytes[..8].to_vec();
    let v = u32::from_le_bytes(out[4..8].try_into().unwrap()) | version_flags;
    out[4..8].copy_from_slice(&v.to_le_bytes());
    for a in attrs {
        out.extend_from_slice(a.name.as_bytes());
        out.push(0);
        out.extend_from_slice(a.kind.as_bytes());
        out.push(0);
        out.extend_from_slice(&(a.value.len() as i32).to_le_bytes());
        out.extend_from_slice(&a.value);
    }
    out.push(0);
    let delta = out.len() as i64 - end as i64;
    // The offset table: one u64 per chunk up to the first chunk's offset.
    let first = u64::from_le_bytes(bytes[end..end + 8].try_into().unwrap()) as usize;
    let mut i = end;
    while i < first {
        let o = u64::from_le_bytes(bytes[i..i + 8].try_into().unwrap()) as i64 + delta;
        out.extend_from_slice(&(o as u64).to_le_bytes());
        i += 8;
    }
    out.extend_from_slice(&bytes[first..]);
    out
}

/// A small generic (non-canonical) single-part EXR with float channels `names`, `w`×`h`, values from `f(channel,
/// sample)`.
pub fn generic_exr(w: u32, h: u32, names: &[&str], f: impl Fn(usize, usize) -> f32) -> Vec<u8> {
    use gbuf::io::exr::{RawChannel, RawData, RawImage};
    let n = (w * h) as usize;
    let raw = RawImage {
        width: w,
        height: h,
        channels: names
            .iter()
            .enumerate()
            .map(|(c, name)| RawChannel {
                name: name.to_string(),
                data: RawData::F32((0..n).map(|i| f(c, i)).collect()),
            })
            .collect(),
        ..Default::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("g.exr");
    gbuf::io::exr::write_raw(&p, &raw).unwrap();
    std::fs::read(&p).unwrap()
}

/// Bytes of a canonical file of `gb`.
pub fn canonical_bytes(gb: &GBuffer) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("c.exr");
    gbuf::io::canonical::write(&p, gb).unwrap();
    std::fs::read(&p).unwrap()
}
