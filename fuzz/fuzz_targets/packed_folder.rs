//! Structure-aware: a folder of packed render targets as `gbuf pack` writes it — a small rendered frame (1–8 pixels a
//! side, 1, 2 or 4 samples) packed with a built-in layout into its DDS targets (DX10 headers), `layout.toml`,
//! `scene.json`, `material_table.json` (a layout with material-ID indirection) and `coverage.dds` (a layout without
//! depth) — then damaged the ways a capture goes wrong while every JSON stays valid:
//! - a DDS header rewritten field by field (size, array size, mips, DXGI format, pixel-format flags and masks), or
//!   replaced by the legacy header of an 8-bit RGBA or single-channel target (no DX10 extension);
//! - a target's data truncated, extended or changed byte by byte, or the file removed;
//! - material-table rows shortened or lengthened, parameters renamed (to an attribute the layout has, one it has not,
//!   or an unknown name) or dropped, `bits` changed;
//! - the sidecar's sample positions moved (anywhere, ±1e30 included) or their count changed.
//!
//! Read with `gbuf::load` as the command line reads a folder (no flag: `layout.toml` names the layout), under the
//! fuzzing memory limit; whatever loads must be a valid frame (`gbuf_fuzz::loaded`).
#![no_main]

use arbitrary::Arbitrary;
use gbuf_fuzz::gen::{self, Val};
use libfuzzer_sys::fuzz_target;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

#[derive(Debug, Arbitrary)]
struct Input {
    layout: u8,
    width: u8,
    height: u8,
    samples: u8,
    edits: Vec<Edit>,
}

#[derive(Debug, Arbitrary)]
enum Edit {
    /// The `field`-th little-endian u32 of a DDS file's first 148 bytes (magic, header, DX10 extension) set.
    HeaderWord { target: u8, field: u8, value: Word },
    /// The DX10 header replaced by a legacy one for `legacy` (RGBA8 with masks, or R8 luminance), data kept.
    Legacy { target: u8, legacy: bool },
    /// A byte of the file set.
    Byte { target: u8, offset: u16, value: u8 },
    /// The file cut to `keep` bytes.
    Truncate { target: u8, keep: u16 },
    /// `extra` bytes appended.
    Extend { target: u8, extra: u8 },
    /// The file removed.
    Remove { target: u8 },
    /// A material-table row shortened or lengthened.
    Row { row: u8, len: u8 },
    /// A material-table parameter renamed.
    Parameter { index: u8, name: u8 },
    /// A material-table parameter dropped.
    DropParameter { index: u8 },
    /// The material table's `bits`.
    TableBits { bits: u8 },
    /// A sample position moved.
    Position { index: u8, x: Val, y: Val },
    /// The sample positions cut or repeated to `count`.
    Positions { count: u8 },
}

/// Values a header field is set to: small sizes, a format, flags, or any word.
#[derive(Debug, Arbitrary)]
enum Word {
    Small(u8),
    Format(u8),
    Any(u32),
}

/// Names a renamed parameter takes: every scalar attribute, a vector one, and names that are none.
const NAMES: [&str; 8] = ["specular", "specular_power", "roughness", "metallic", "depth", "normal", "albedo", "nope"];

fuzz_target!(init: gbuf_fuzz::init(), |input: Input| {
    gbuf_fuzz::run(|| {
        let (w, h) = (gen::dim(input.width, 8), gen::dim(input.height, 8));
        let samples = [1, 2, 4][input.samples as usize % 3];
        let dir = gbuf_fuzz::scratch().join("packed");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch folder");
        let Some(files) = pristine(input.layout, w, h, samples) else { return };
        let mut targets = Vec::new();
        for (name, bytes) in files.iter() {
            let p = dir.join(name);
            std::fs::write(&p, bytes).expect("scratch file");
            if is_dds(&p) {
                targets.push(p);
            }
        }
        let pick = |t: u8| targets.get(t as usize % targets.len().max(1)).cloned();
        for e in input.edits.iter().take(8) {
            match *e {
                Edit::HeaderWord { target, field, ref value } => edit_file(pick(target), |b| {
                    let at = 4 * (field as usize % 37);
                    let v = match *value {
                        Word::Small(s) => u32::from(s),
                        Word::Format(f) => u32::from(f % 132),
                        Word::Any(a) => a,
                    };
                    if b.len() >= at + 4 {
                        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
                    }
                }),
                Edit::Legacy { target, legacy } => edit_file(pick(target), |b| legacy_header(b, legacy)),
                Edit::Byte { target, offset, value } => edit_file(pick(target), |b| {
                    if !b.is_empty() {
                        let i = offset as usize % b.len();
                        b[i] = value;
                    }
                }),
                Edit::Truncate { target, keep } => edit_file(pick(target), |b| b.truncate(keep as usize)),
                Edit::Extend { target, extra } => edit_file(pick(target), |b| b.extend(std::iter::repeat_n(0xA5, extra as usize))),
                Edit::Remove { target } => {
                    if let Some(p) = pick(target) {
                        let _ = std::fs::remove_file(p);
                    }
                }
                Edit::Row { row, len } => edit_json(&dir.join("material_table.json"), |v| {
                    if let Some(rows) = v.get_mut("entries").and_then(Value::as_array_mut) {
                        let n = rows.len().max(1);
                        if let Some(r) = rows.get_mut(row as usize % n).and_then(Value::as_array_mut) {
                            r.resize(len as usize % 7, Value::from(0.5));
                        }
                    }
                }),
                Edit::Parameter { index, name } => edit_json(&dir.join("material_table.json"), |v| {
                    if let Some(p) = v.get_mut("parameters").and_then(Value::as_array_mut) {
                        let n = p.len().max(1);
                        if let Some(slot) = p.get_mut(index as usize % n) {
                            *slot = Value::from(NAMES[name as usize % NAMES.len()]);
                        }
                    }
                }),
                Edit::DropParameter { index } => edit_json(&dir.join("material_table.json"), |v| {
                    if let Some(p) = v.get_mut("parameters").and_then(Value::as_array_mut) {
                        if !p.is_empty() {
                            let i = index as usize % p.len();
                            p.remove(i);
                        }
                    }
                }),
                Edit::TableBits { bits } => edit_json(&dir.join("material_table.json"), |v| {
                    if let Some(o) = v.as_object_mut() {
                        o.insert("bits".into(), Value::from(bits % 40));
                    }
                }),
                Edit::Position { index, ref x, ref y } => edit_json(&dir.join("scene.json"), |v| {
                    if let Some(p) = v.get_mut("sample_positions").and_then(Value::as_array_mut) {
                        let n = p.len().max(1);
                        let num = |f: f32| serde_json::Number::from_f64(f64::from(f)).map_or(Value::Null, Value::Number);
                        if let Some(slot) = p.get_mut(index as usize % n) {
                            *slot = Value::Array(vec![num(x.f32()), num(y.f32())]);
                        }
                    }
                }),
                Edit::Positions { count } => edit_json(&dir.join("scene.json"), |v| {
                    if let Some(p) = v.get_mut("sample_positions").and_then(Value::as_array_mut) {
                        let first = p.first().cloned().unwrap_or(Value::Array(vec![0.into(), 0.into()]));
                        p.resize(count as usize % 20, first);
                    }
                }),
            }
        }
        let opts = gbuf_fuzz::default_options();
        let result = gbuf::load(&dir, &opts);
        gbuf_fuzz::loaded(&result, &dir);
    });
});

/// The files `gbuf pack` writes for the room rendered at `w`×`h`×`samples` and packed with built-in layout number
/// `layout` (name, bytes), made once per combination and kept (rendering and packing every input cost most of its
/// time).
fn pristine(layout: u8, w: u32, h: u32, samples: u32) -> Option<Arc<Vec<(String, Vec<u8>)>>> {
    type Files = Arc<Vec<(String, Vec<u8>)>>;
    static LAYOUTS: OnceLock<Vec<gbuf::layout::Layout>> = OnceLock::new();
    static MADE: Mutex<BTreeMap<(u8, u32, u32, u32), Option<Files>>> = Mutex::new(BTreeMap::new());
    let layouts = LAYOUTS.get_or_init(gbuf::layout::Layout::builtins);
    let layout_index = (layout as usize % layouts.len()) as u8;
    let key = (layout_index, w, h, samples);
    let mut made = MADE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    made.entry(key)
        .or_insert_with(|| {
            let gb = gbuf::scene::render(gbuf::scene::SceneName::Room, w, h, samples).ok()?;
            let lights = gbuf::scene::default_lights(gbuf::scene::SceneName::Room, &gb);
            let dir = gbuf_fuzz::scratch().join("pristine");
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).ok()?;
            gbuf::layout::targets::write_frame(&layouts[layout_index as usize], &gb, &lights, &dir)
                .expect("a built-in layout packs");
            let mut files = Vec::new();
            for e in std::fs::read_dir(&dir).ok()?.flatten() {
                files.push((e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).ok()?));
            }
            files.sort();
            Some(Arc::new(files))
        })
        .clone()
}

fn is_dds(p: &Path) -> bool {
    p.extension().is_some_and(|e| e == "dds")
}

/// Rewrites a file through `f` (nothing when there is no such file).
fn edit_file(path: Option<std::path::PathBuf>, f: impl FnOnce(&mut Vec<u8>)) {
    let Some(path) = path else { return };
    let Ok(mut bytes) = std::fs::read(&path) else { return };
    f(&mut bytes);
    std::fs::write(&path, bytes).expect("scratch file");
}

/// Rewrites a JSON file through `f`, keeping it valid JSON (nothing when there is no such file).
fn edit_json(path: &Path, f: impl FnOnce(&mut Value)) {
    let Ok(text) = std::fs::read_to_string(path) else { return };
    let Ok(mut v) = serde_json::from_str::<Value>(&text) else { return };
    f(&mut v);
    std::fs::write(path, serde_json::to_vec(&v).expect("a JSON value serializes")).expect("scratch file");
}

/// Replaces a DX10 DDS header (4 + 124 + 20 bytes) by a legacy one (4 + 124: no extension), keeping the data:
/// 32-bit RGBA with masks, or 8-bit luminance.
fn legacy_header(b: &mut Vec<u8>, rgba: bool) {
    const DX10_END: usize = 4 + 124 + 20;
    if b.len() < DX10_END {
        return;
    }
    let data = b.split_off(DX10_END);
    b.truncate(4 + 124);
    let mut put = |at: usize, v: u32| b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    // The pixel format starts at byte 4 + 72: size, flags, fourCC, bit count, masks.
    put(4 + 72, 32);
    if rgba {
        put(4 + 76, 0x41); // DDPF_RGB | DDPF_ALPHAPIXELS
        put(4 + 80, 0);
        put(4 + 84, 32);
        put(4 + 88, 0x0000_00ff);
        put(4 + 92, 0x0000_ff00);
        put(4 + 96, 0x00ff_0000);
        put(4 + 100, 0xff00_0000);
    } else {
        put(4 + 76, 0x2_0000); // DDPF_LUMINANCE
        put(4 + 80, 0);
        put(4 + 84, 8);
        put(4 + 88, 0xff);
        put(4 + 92, 0);
        put(4 + 96, 0);
        put(4 + 100, 0);
    }
    b.extend(data);
}
