//! `gbuf` for Python (`pip install ./python`): FLIP with NVIDIA's pooled statistics, G-buffer dumps as numpy arrays,
//! and a layout's pack / unpack — the library's own code, so the numbers are the CLI's (python/tests checks it).
//!
//! Arrays follow the G-buffer's order: planes are `(H, W, S)` (scalars, IDs, coverage) or `(H, W, S, C)` (C = 2 or
//! 3), row 0 at the top; images `(H, W, 3)` (or `(H, W)` grey); packed targets `(H, W, S, bytes per texel)` of
//! little-endian texels.

use gbuf_core::gbuffer::{Attribute, PlaneRef, PlaneSlot};
use gbuf_core::image::file::{ImageFile, ImageKind};
use gbuf_core::image::{HdrImage, ToneCurve};
use gbuf_core::layout::pack::{Packed, TargetPlane};
use gbuf_core::layout::{Layout, MaterialTable};
use gbuf_core::measure::compare::{self, CompareOptions, FlipMode};
use gbuf_core::measure::image::Viewing;
use gbuf_core::GBuffer;
use glam::{Vec2, Vec3};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The library's loading errors name its options as the command line spells them (`--frame N`); a Python user
/// passes them as `load`'s keyword arguments, so those are named instead (`frame=N`). Options `load` does not take
/// keep their spelling and say so.
fn load_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(python_spelling(&e.to_string()))
}

/// `message` with the command line's spelling of `load`'s options replaced by the keyword arguments.
fn python_spelling(message: &str) -> String {
    // Longest first: `--no-scene` before `--scene`, `--input-layout` before `--layout`.
    const KEYWORDS: [(&str, &str); 7] = [
        ("--no-scene", "no_scene=True"),
        ("--input-layout", "input_layout"),
        ("--layout", "input_layout"),
        ("--scene", "scene"),
        ("--preset", "preset"),
        ("--frame", "frame"),
        ("--fold", "fold"),
    ];
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    'scan: while let Some(at) = rest.find("--") {
        out.push_str(&rest[..at]);
        let tail = &rest[at..];
        let flag_end = tail[2..].find(|c: char| !(c.is_ascii_alphanumeric() || c == '-')).map_or(tail.len(), |i| i + 2);
        let flag = &tail[..flag_end];
        let after_word = out.chars().last().is_some_and(|c| c.is_alphanumeric());
        if after_word || !flag[2..].starts_with(|c: char| c.is_ascii_lowercase()) {
            // Not an option: `1--2`, a dash rule.
            out.push_str("--");
            rest = &tail[2..];
            continue 'scan;
        }
        if flag == "--map" {
            out.push_str("map");
        } else if let Some((_, kw)) = KEYWORDS.iter().find(|(f, _)| *f == flag) {
            // `--frame N` reads `frame=N`; a bare flag reads as the argument's name.
            let value = tail[flag_end..].strip_prefix(' ').filter(|v| v.starts_with(|c: char| c.is_ascii_alphanumeric()));
            match value {
                Some(v) if !kw.contains('=') => {
                    out.push_str(kw);
                    out.push('=');
                    rest = v;
                    continue 'scan;
                }
                _ => out.push_str(kw),
            }
        } else {
            out.push_str(flag);
            out.push_str(" (a gbuf command-line option; Python's load does not take it)");
        }
        rest = &tail[flag_end..];
    }
    out.push_str(rest);
    out
}

/// A numpy array of `values` in `shape` (C order).
fn array<'py, T: numpy::Element>(py: Python<'py>, values: Vec<T>, shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, values).reshape(shape)?.into_any())
}

/// An image argument: a path gbuf reads (EXR: HDR, PNG: LDR), or an `(H, W, 3)` / `(H, W)` float array (HDR when
/// `hdr`, else display values in [0, 1]).
fn image_arg(obj: &Bound<'_, PyAny>, hdr: Option<bool>, what: &str) -> PyResult<ImageFile> {
    if let Ok(path) = obj.extract::<PathBuf>() {
        let f = gbuf_core::image::file::read(&path, &gbuf_core::io::exr::ReadLimits::default())
            .map_err(|e| value_error(format!("{what}: {e}")))?;
        return Ok(f);
    }
    let a: PyReadonlyArrayDyn<'_, f32> = obj
        .extract()
        .or_else(|_| obj.call_method1("astype", ("float32",)).and_then(|o| o.extract()))
        .map_err(|_| value_error(format!("{what}: a path or a float array of shape (H, W, 3) or (H, W)")))?;
    let shape = a.shape().to_vec();
    let (h, w, c) = match shape[..] {
        [h, w] => (h, w, 1),
        [h, w, 3] => (h, w, 3),
        _ => return Err(value_error(format!("{what}: shape {shape:?}; expected (H, W, 3) or (H, W)"))),
    };
    if h == 0 || w == 0 || h > u32::MAX as usize || w > u32::MAX as usize {
        return Err(value_error(format!("{what}: an image of {w}×{h} pixels")));
    }
    let v = a.as_slice().map(<[f32]>::to_vec).unwrap_or_else(|_| a.as_array().iter().copied().collect());
    let kind = if hdr == Some(true) { ImageKind::Hdr } else { ImageKind::Ldr };
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        return Err(value_error(format!("{what}: value {i} is {} (FLIP needs finite values)", v[i])));
    }
    if kind == ImageKind::Ldr {
        if let Some(i) = v.iter().position(|x| !(0.0..=1.0).contains(x)) {
            return Err(value_error(format!(
                "{what}: value {i} is {}: an LDR image holds display values in [0, 1] (pass hdr=True for linear HDR)",
                v[i]
            )));
        }
    }
    let rgb = if c == 3 {
        v.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect()
    } else {
        v.iter().map(|&g| Vec3::splat(g)).collect()
    };
    Ok(ImageFile {
        image: HdrImage { width: w as u32, height: h as u32, rgb },
        kind,
        storage: format!("numpy float32 {}", if c == 3 { "RGB" } else { "grey" }),
        non_finite: 0,
    })
}

/// FLIP between `reference` and `test` (paths or arrays), with NVIDIA's pooled statistics and the error map, and
/// the numeric errors `gbuf compare` prints. `hdr`: None decides by the inputs (EXR: HDR-FLIP, PNG: LDR-FLIP;
/// arrays: LDR unless `hdr=True`); True or False forces the variant. `ppd`, `tonemap`, `exposure`: as `gbuf
/// compare` (defaults 67.02, reinhard, 1).
#[pyfunction]
#[pyo3(signature = (reference, test, hdr=None, ppd=None, tonemap=None, exposure=None))]
fn flip<'py>(
    py: Python<'py>,
    reference: &Bound<'py, PyAny>,
    test: &Bound<'py, PyAny>,
    hdr: Option<bool>,
    ppd: Option<f32>,
    tonemap: Option<&str>,
    exposure: Option<f32>,
) -> PyResult<Bound<'py, PyDict>> {
    let r = image_arg(reference, hdr, "reference")?;
    let t = image_arg(test, hdr, "test")?;
    let mut viewing = Viewing::default();
    if let Some(p) = ppd {
        if !(p.is_finite() && p > 0.0) {
            return Err(value_error(format!("ppd must be a positive number, got {p}")));
        }
        viewing.pixels_per_degree = p;
    }
    if let Some(e) = exposure {
        if !(e.is_finite() && e > 0.0) {
            return Err(value_error(format!("exposure must be a positive number, got {e}")));
        }
        viewing.exposure = e;
    }
    if let Some(name) = tonemap {
        viewing.tone_map = name.parse::<ToneCurve>().map_err(value_error)?;
    }
    let use_hdr = hdr.unwrap_or(r.kind == ImageKind::Hdr);
    let mode = if use_hdr { FlipMode::Hdr } else { FlipMode::Ldr };
    let c = compare::compare(&r, &t, &CompareOptions { flip: mode, viewing }).map_err(value_error)?;
    let (pooled, map) = if use_hdr { (&c.flip_hdr, &c.maps.1) } else { (&c.flip_ldr, &c.maps.0) };
    let (Some(p), Some(map)) = (pooled, map) else {
        return Err(value_error("FLIP was not computed for these images"));
    };
    let d = PyDict::new(py);
    d.set_item("hdr", use_hdr)?;
    d.set_item("mean", p.mean)?;
    d.set_item("weighted_median", p.weighted_median)?;
    d.set_item("weighted_q1", p.weighted_q1)?;
    d.set_item("weighted_q3", p.weighted_q3)?;
    d.set_item("min", p.min)?;
    d.set_item("max", p.max)?;
    d.set_item("min_at", (p.min_at[0], p.min_at[1]))?;
    d.set_item("max_at", (p.max_at[0], p.max_at[1]))?;
    d.set_item("histogram", array(py, p.histogram.clone(), &[p.histogram.len()])?)?;
    d.set_item("map", array(py, map.values.clone(), &[map.height, map.width])?)?;
    d.set_item("ppd", c.pixels_per_degree)?;
    let n = &c.numeric;
    d.set_item("rmse", n.rmse)?;
    d.set_item("psnr_db", n.psnr_db)?;
    d.set_item("max_abs", n.max_abs)?;
    d.set_item("max_abs_at", (n.max_abs_at[0], n.max_abs_at[1]))?;
    d.set_item("rel_mse", n.rel_mse)?;
    d.set_item("nmse", n.nmse)?;
    Ok(d)
}

/// The G-buffer as a dict of numpy arrays: `width`, `height`, `samples`, `coverage`, `sample_positions` (S, 2) and
/// each present attribute under its name.
fn gbuffer_dict<'py>(py: Python<'py>, gb: &GBuffer) -> PyResult<Bound<'py, PyDict>> {
    let (h, w, s) = (gb.height as usize, gb.width as usize, gb.samples as usize);
    let d = PyDict::new(py);
    d.set_item("width", gb.width)?;
    d.set_item("height", gb.height)?;
    d.set_item("samples", gb.samples)?;
    d.set_item("coverage", array(py, gb.coverage.clone(), &[h, w, s])?)?;
    let pos: Vec<f32> = gb.sample_positions.iter().flat_map(|p| [p.x, p.y]).collect();
    d.set_item("sample_positions", array(py, pos, &[s, 2])?)?;
    for attr in Attribute::ALL {
        let Some(plane) = gb.plane(attr) else { continue };
        let a = match plane {
            PlaneRef::F32(v) => array(py, v.to_vec(), &[h, w, s])?,
            PlaneRef::U32(v) => array(py, v.to_vec(), &[h, w, s])?,
            PlaneRef::Vec2(v) => array(py, v.iter().flat_map(|p| [p.x, p.y]).collect(), &[h, w, s, 2])?,
            PlaneRef::Vec3(v) => array(py, v.iter().flat_map(|p| [p.x, p.y, p.z]).collect(), &[h, w, s, 3])?,
        };
        d.set_item(attr.name(), a)?;
    }
    Ok(d)
}

/// Reads `planes[key]` as a C-order array of `T` of exactly `shape`.
fn plane_arg<T: numpy::Element + Copy>(
    planes: &Bound<'_, PyDict>,
    key: &str,
    shape: &[usize],
) -> PyResult<Option<Vec<T>>> {
    let Some(obj) = planes.get_item(key)? else { return Ok(None) };
    let a: PyReadonlyArrayDyn<'_, T> = obj
        .extract()
        .or_else(|_| {
            let np = obj.py().import("numpy")?;
            let dtype = np.getattr("dtype")?.call1((std::any::type_name::<T>().replace("bool", "bool_"),))?;
            obj.call_method1("astype", (dtype,))?.extract()
        })
        .map_err(|_| value_error(format!("planes[{key:?}]: not an array of {}", std::any::type_name::<T>())))?;
    if a.shape() != shape {
        return Err(value_error(format!("planes[{key:?}]: shape {:?}, expected {shape:?}", a.shape())));
    }
    Ok(Some(a.as_array().iter().copied().collect()))
}

/// A G-buffer from a dict of arrays (what [`load`] returns): `coverage` (H, W, S) gives the size; attributes by
/// name (`sample_positions` optional: the standard pattern otherwise).
fn gbuffer_arg(planes: &Bound<'_, PyDict>) -> PyResult<GBuffer> {
    let cov = planes.get_item("coverage")?.ok_or_else(|| value_error("planes: no \"coverage\" (H, W, S) array"))?;
    let shape: Vec<usize> = cov.getattr("shape")?.extract()?;
    let [h, w, s] = shape[..] else {
        return Err(value_error(format!("planes[\"coverage\"]: shape {shape:?}, expected (H, W, S)")));
    };
    let dim = |n: usize| u32::try_from(n).map_err(|_| value_error(format!("planes: dimension {n} too large")));
    let mut gb = GBuffer::new(dim(w)?, dim(h)?, dim(s)?).map_err(value_error)?;
    gb.coverage = plane_arg::<bool>(planes, "coverage", &[h, w, s])?.expect("present");
    if let Some(p) = plane_arg::<f32>(planes, "sample_positions", &[s, 2])? {
        gb.sample_positions = p.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect();
    }
    for attr in Attribute::ALL {
        let key = attr.name();
        match gb.slot(attr) {
            PlaneSlot::F32(o) => *o = plane_arg::<f32>(planes, key, &[h, w, s])?,
            PlaneSlot::U32(o) => *o = plane_arg::<u32>(planes, key, &[h, w, s])?,
            PlaneSlot::Vec2(o) => {
                *o = plane_arg::<f32>(planes, key, &[h, w, s, 2])?
                    .map(|v| v.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect());
            }
            PlaneSlot::Vec3(o) => {
                *o = plane_arg::<f32>(planes, key, &[h, w, s, 3])?
                    .map(|v| v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect());
            }
        }
    }
    for key in planes.keys() {
        let key: String = key.extract()?;
        let known = ["width", "height", "samples", "coverage", "sample_positions"].contains(&key.as_str())
            || Attribute::from_name(&key).is_some();
        if !known {
            return Err(value_error(format!(
                "planes[{key:?}]: not a G-buffer attribute (known: {})",
                Attribute::ALL.iter().map(|a| a.name()).collect::<Vec<_>>().join(", ")
            )));
        }
    }
    gb.validate().map_err(value_error)?;
    Ok(gb)
}

/// Reads anything the command line reads (canonical or multilayer EXR, Blender/Mitsuba EXRs, a file-set folder, the
/// ISPC `.bin`, packed render targets: a `gbuf pack` folder, or an engine's with `input_layout`) and returns its
/// planes as numpy arrays. As the command line's flags: `fold` (`--fold`), `preset` (`--preset`), `scene`
/// (`--scene`: the sidecar to use), `no_scene` (`--no-scene`: none, not even one beside the dump), `input_layout`
/// (`--input-layout`: the layout an engine's targets were written with, a built-in name or a layout file), `map`
/// (`--map`: `attr=channel;…,attr=FILE[:channel;…]`) and `frame` (`--frame`: one frame of a sequence folder).
#[pyfunction]
#[pyo3(signature = (path, fold=None, preset=None, scene=None, no_scene=false, input_layout=None, map=None, frame=None))]
#[allow(clippy::too_many_arguments)] // the command line's flags, by name
fn load<'py>(
    py: Python<'py>,
    path: PathBuf,
    fold: Option<u32>,
    preset: Option<String>,
    scene: Option<PathBuf>,
    no_scene: bool,
    input_layout: Option<String>,
    map: Option<String>,
    frame: Option<u32>,
) -> PyResult<Bound<'py, PyDict>> {
    if scene.is_some() && no_scene {
        return Err(value_error("scene and no_scene exclude each other"));
    }
    let map = map.as_deref().map(gbuf_core::io::mapped::parse_map).transpose().map_err(load_error)?.unwrap_or_default();
    let opts = gbuf_core::io::LoadOptions {
        fold,
        preset,
        sidecar: scene,
        no_sidecar: no_scene,
        map: map.channels,
        files: map.files,
        frame,
        input_layout,
        ..Default::default()
    };
    let loaded = gbuf_core::load(&path, &opts).map_err(load_error)?;
    gbuffer_dict(py, &loaded.gbuffer)
}

/// Packs the G-buffer `planes` (a dict as [`load`] returns) with `layout` (a built-in name or a layout file): the
/// render targets as `(H, W, S, bytes)` uint8 arrays under `targets`, with what `unpack` needs.
#[pyfunction]
fn pack<'py>(py: Python<'py>, layout: &str, planes: &Bound<'py, PyDict>) -> PyResult<Bound<'py, PyDict>> {
    let layout = Layout::by_name_or_path(layout).map_err(value_error)?;
    let gb = gbuffer_arg(planes)?;
    let packed = layout.pack(&gb).map_err(value_error)?;
    let (h, w, s) = (gb.height as usize, gb.width as usize, gb.samples as usize);
    let d = PyDict::new(py);
    d.set_item("layout", &packed.layout)?;
    d.set_item("depth_range", (packed.depth_range[0], packed.depth_range[1]))?;
    d.set_item("present", PyList::new(py, packed.present.iter().map(|a| a.name()))?)?;
    let table = packed.material_table.as_ref().map(serde_json::to_string).transpose().map_err(value_error)?;
    d.set_item("material_table", table)?;
    d.set_item("coverage", array(py, gb.coverage.clone(), &[h, w, s])?)?;
    d.set_item("sample_positions", array(py, gb.sample_positions.iter().flat_map(|p| [p.x, p.y]).collect(), &[s, 2])?)?;
    let targets = PyDict::new(py);
    for t in &packed.targets {
        targets.set_item(&t.name, array(py, t.bytes.clone(), &[h, w, s, t.format.bytes()])?)?;
    }
    d.set_item("targets", targets)?;
    Ok(d)
}

/// Decodes what [`pack`] returned (`packed`) with `layout` into planes, as [`load`] returns them.
#[pyfunction]
fn unpack<'py>(py: Python<'py>, layout: &str, packed: &Bound<'py, PyDict>) -> PyResult<Bound<'py, PyDict>> {
    let layout = Layout::by_name_or_path(layout).map_err(value_error)?;
    let get =
        |k: &str| packed.get_item(k)?.ok_or_else(|| value_error(format!("packed: no {k:?} (pass what pack returned)")));
    let shell = PyDict::new(py);
    shell.set_item("coverage", get("coverage")?)?;
    if let Some(p) = packed.get_item("sample_positions")? {
        shell.set_item("sample_positions", p)?;
    }
    let like = gbuffer_arg(&shell)?;
    let (h, w, s) = (like.height as usize, like.width as usize, like.samples as usize);
    let targets_obj = get("targets")?;
    let targets = targets_obj.downcast::<PyDict>().map_err(|_| value_error("packed[\"targets\"]: not a dict"))?;
    let mut planes = Vec::new();
    for (spec, &format) in layout.spec().targets.iter().zip(layout.formats()) {
        let bytes = plane_arg::<u8>(targets, &spec.name, &[h, w, s, format.bytes()])?
            .ok_or_else(|| value_error(format!("packed[\"targets\"]: no target {:?}", spec.name)))?;
        planes.push(TargetPlane { name: spec.name.clone(), format, bytes });
    }
    let present = get("present")?
        .extract::<Vec<String>>()?
        .iter()
        .map(|n| {
            Attribute::from_name(n).ok_or_else(|| value_error(format!("packed[\"present\"]: unknown attribute {n:?}")))
        })
        .collect::<PyResult<Vec<_>>>()?;
    let material_table = match get("material_table")?.extract::<Option<String>>()? {
        Some(json) => Some(serde_json::from_str::<MaterialTable>(&json).map_err(value_error)?),
        None => None,
    };
    let depth_range: (f32, f32) = get("depth_range")?.extract()?;
    let p = Packed {
        layout: get("layout")?.extract()?,
        width: like.width,
        height: like.height,
        samples: like.samples,
        targets: planes,
        material_table,
        depth_range: [depth_range.0, depth_range.1],
        present,
    };
    let gb = layout.unpack(&p, &like).map_err(value_error)?;
    gbuffer_dict(py, &gb)
}

/// The names of the built-in layouts.
#[pyfunction]
fn layouts() -> Vec<String> {
    Layout::builtin_names()
}

/// gbuf: G-buffer encoding and MSAA analysis for deferred shading (Python bindings of the Rust library).
#[pymodule]
fn gbuf(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(flip, m)?)?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(pack, m)?)?;
    m.add_function(wrap_pyfunction!(unpack, m)?)?;
    m.add_function(wrap_pyfunction!(layouts, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

