//! `gbuf pack` writes DDS files another reader opens: a Python reader written here from Microsoft's documentation
//! of the DDS layout (`DDS_HEADER`, `DDS_PIXELFORMAT`, `DDS_HEADER_DXT10`, the `DXGI_FORMAT` numbers) parses every
//! file `gbuf pack` writes for three built-in layouts on the 4× MSAA llvmpipe fixture, checks the header against
//! the layout (size, pitch, DXGI format, one array slice per sample) and hands back each slice's texels, which must
//! be the layout's packed words for that sample of every pixel.

mod support;

use gbuf::io::{load, LoadOptions};
use gbuf::layout::Layout;
use std::path::Path;
use std::process::Command;
use support::gbuf;

/// The reader: prints `name format width height arraysize` per file and writes the texels (slice after slice)
/// to `<file>.texels`. Formats are named by their DXGI numbers from dxgiformat.h.
const READER: &str = r#"
import struct, sys, os
DXGI = {61: "r8", 49: "rg8", 28: "rgba8", 29: "rgba8-srgb", 31: "rgba8-snorm", 24: "rgb10a2", 26: "r11g11b10f",
        67: "rgb9e5", 54: "r16f", 34: "rg16f", 10: "rgba16f", 56: "r16-unorm", 35: "rg16-unorm", 37: "rg16-snorm",
        11: "rgba16-unorm", 57: "r16ui", 41: "r32f", 16: "rg32f", 2: "rgba32f", 42: "r32ui", 17: "rg32ui",
        3: "rgba32ui", 55: "d16", 45: "d24s8", 40: "d32f"}
BYTES = {61: 1, 49: 2, 28: 4, 29: 4, 31: 4, 24: 4, 26: 4, 67: 4, 54: 2, 34: 4, 10: 8, 56: 2, 35: 4, 37: 4, 11: 8,
         57: 2, 41: 4, 16: 8, 2: 16, 42: 4, 17: 8, 3: 16, 55: 2, 45: 4, 40: 4}
for path in sorted(sys.argv[1:]):
    data = open(path, "rb").read()
    assert data[:4] == b"DDS ", path
    size, flags, height, width, pitch, depth, mips = struct.unpack_from("<7I", data, 4)
    assert size == 124 and flags & 0x1007 == 0x1007, (size, flags)
    pf_size, pf_flags, fourcc = struct.unpack_from("<II4s", data, 4 + 72)
    assert pf_size == 32 and pf_flags & 0x4 and fourcc == b"DX10", (pf_size, pf_flags, fourcc)
    caps = struct.unpack_from("<I", data, 4 + 104)[0]
    assert caps & 0x1000, caps
    fmt, dim, misc, array, misc2 = struct.unpack_from("<5I", data, 128)
    assert dim == 3, dim
    tb = BYTES[fmt]
    assert pitch == width * tb, (pitch, width, tb)
    texels = data[148:]
    assert len(texels) == width * height * array * tb, (len(texels), width, height, array, tb)
    open(path + ".texels", "wb").write(texels)
    print(os.path.basename(path), DXGI[fmt], width, height, array)
"#;

#[test]
fn an_independent_reader_opens_every_target_with_its_format_and_samples() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dump = root.join("fixtures/raster_4x.exr");
    let gb = load(&dump, &LoadOptions::default()).unwrap().gbuffer;
    let reader = dir.path().join("read_dds.py");
    std::fs::write(&reader, READER).unwrap();
    for name in ["unreal-like", "destiny-96", "bevy-deferred"] {
        let out = dir.path().join(name);
        let o = gbuf(dir.path(), &["pack", dump.to_str().unwrap(), "--layout", name, "-o", out.to_str().unwrap()]);
        assert!(o.status.success(), "{name}: {}", support::stderr(&o));
        let layout = Layout::by_name(name).unwrap();
        let packed = layout.pack(&gb).unwrap();
        let files: Vec<String> =
            packed.targets.iter().map(|t| out.join(format!("{}.dds", t.name)).display().to_string()).collect();
        let py = Command::new("python3").arg(&reader).args(&files).output().expect("python3");
        assert!(py.status.success(), "{name}: {}", String::from_utf8_lossy(&py.stderr));
        let listing = String::from_utf8(py.stdout).unwrap();
        let (w, h, s) = (gb.width as usize, gb.height as usize, gb.samples as usize);
        for t in &packed.targets {
            let want = format!("{}.dds {} {w} {h} {s}", t.name, t.format);
            assert!(listing.lines().any(|l| l == want), "{name}: {want:?} not in\n{listing}");
            let texels = std::fs::read(out.join(format!("{}.dds.texels", t.name))).unwrap();
            let tb = t.format.bytes();
            for sample in 0..s {
                for p in 0..w * h {
                    let got = &texels[(sample * w * h + p) * tb..][..tb];
                    let packed_word = &t.bytes[(p * s + sample) * tb..][..tb];
                    assert_eq!(got, packed_word, "{name} {}: sample {sample} of pixel {p}", t.name);
                }
            }
        }
        assert_eq!(out.join("material_table.json").exists(), packed.material_table.is_some(), "{name}");
    }
}

/// Bad input: an unknown layout or a missing dump is a clear error, and nothing is written.
#[test]
fn bad_input_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let dump = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/raster_4x.exr");
    let o = gbuf(dir.path(), &["pack", dump.to_str().unwrap(), "--layout", "nosuch", "-o", "out"]);
    assert_eq!(o.status.code(), Some(2), "a name that names nothing is a usage error: {}", support::stderr(&o));
    assert!(support::stderr(&o).contains("nosuch"), "{}", support::stderr(&o));
    let o = gbuf(dir.path(), &["pack", "missing.exr", "--layout", "fat-20", "-o", "out"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(support::stderr(&o).contains("missing.exr"), "{}", support::stderr(&o));
    assert!(!dir.path().join("out").exists(), "nothing written on bad input");
}
