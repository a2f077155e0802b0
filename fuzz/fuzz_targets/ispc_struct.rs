//! Structure-aware: an ISPC `deferred` `.bin` built field by field — a D3D projection from a field of view, aspect
//! and planes (any entry replaceable), 1–16 pixels a side (or any i32), up to 16 lights (or any count), arrays laid
//! out packed, 64-byte aligned, all at offset 0 (aliased) or at offsets of its own, a declared chunk size off by a
//! fuzzed amount, and fuzzed contents (depths around [0, 1], spheremap normals, …) — loaded with `load_bytes` under
//! fuzzed options (fold, a sidecar whose lights replace the file's, a memory limit).
#![no_main]

use arbitrary::Arbitrary;
use gbuf::io::ispc::Header;
use gbuf_fuzz::gen::{self, Fill, LoadIn, Val};
use libfuzzer_sys::fuzz_target;

const ELEM: [usize; 16] = [4, 2, 2, 2, 2, 1, 1, 1, 4, 4, 4, 4, 4, 4, 4, 4];

#[derive(Debug, Arbitrary)]
struct Input {
    width: u8,
    height: u8,
    raw_size: Option<(i32, i32)>,
    fov: u8,
    aspect: u8,
    near: Option<Val>,
    far: Option<Val>,
    proj_edit: Option<(u8, Val)>,
    num_lights: u8,
    raw_lights: Option<i32>,
    layout: u8,
    offsets: Vec<i32>,
    chunk_delta: i16,
    fills: [Fill; 8],
    lights: Vec<Fill>,
    trailing: u8,
    load: LoadIn,
}

fuzz_target!(init: gbuf_fuzz::init(), |input: Input| {
    gbuf_fuzz::run(|| {
        let (w, h) = (gen::dim(input.width, 16), gen::dim(input.height, 16));
        let (hw, hh) = input.raw_size.unwrap_or((w as i32, h as i32));
        let pixels = w as usize * h as usize;
        let nl = input.num_lights as usize % 17;
        let t = (0.1 + f32::from(input.fov % 120) * 0.025).tan();
        let aspect = 0.25 + f32::from(input.aspect) / 64.0;
        let (near, far) = (input.near.map_or(0.1, Val::f32), input.far.map_or(100.0, Val::f32));
        let mut proj = [[0.0f32; 4]; 4];
        proj[0][0] = 1.0 / (t * aspect);
        proj[1][1] = 1.0 / t;
        proj[2][2] = far / (far - near);
        proj[2][3] = 1.0;
        proj[3][2] = -near * far / (far - near);
        if let Some((k, v)) = input.proj_edit {
            proj[(k as usize / 4) % 4][k as usize % 4] = v.f32();
        }
        // Array bytes.
        let arrays: Vec<Vec<u8>> = (0..16)
            .map(|k| {
                let count = if k < 8 { pixels } else { nl };
                let fill = match k {
                    0..8 => &input.fills[k],
                    _ => input.lights.get((k - 8) % input.lights.len().max(1)).unwrap_or(&input.fills[0]),
                };
                (0..count)
                    .flat_map(|i| match ELEM[k] {
                        4 => fill.f32_at(i).to_le_bytes().to_vec(),
                        2 => half::f16::from_f32(fill.f32_at(i)).to_bits().to_le_bytes().to_vec(),
                        _ => vec![fill.u32_at(i) as u8],
                    })
                    .collect()
            })
            .collect();
        let mut offsets = [0i32; 16];
        let mut size = 0usize;
        for k in 0..16 {
            offsets[k] = match input.layout % 4 {
                0 => size as i32,
                1 => size.next_multiple_of(64) as i32,
                2 => 0,
                _ => input.offsets.get(k).map_or(0, |o| o.rem_euclid(1 << 16)),
            };
            size = size.max(offsets[k] as usize + arrays[k].len());
            if input.layout % 4 < 2 {
                size = offsets[k] as usize + arrays[k].len();
            }
        }
        let mut chunk = vec![0u8; size];
        for k in 0..16 {
            let o = offsets[k] as usize;
            chunk[o..o + arrays[k].len()].copy_from_slice(&arrays[k]);
        }
        let declared = (size as i64 + i64::from(input.chunk_delta)).clamp(i32::MIN as i64, i32::MAX as i64) as i32;
        let header = Header {
            proj,
            near,
            far,
            width: hw,
            height: hh,
            num_lights: input.raw_lights.unwrap_or(nl as i32),
            chunk_size: declared,
            offsets,
        };
        let mut bytes = header.to_bytes();
        bytes.extend(chunk);
        bytes.extend(std::iter::repeat_n(0xa5, input.trailing as usize % 8));
        let path = gen::path();
        let opts = input.load.options(w, h);
        gbuf_fuzz::loaded(&gbuf::io::load_bytes(&bytes, &path, &opts), &path);
    });
});
