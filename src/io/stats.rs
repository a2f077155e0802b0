//! What `gbuf info` prints: size, samples, per-attribute provenance and statistics, background, compression and
//! camera of a loaded dump. Computed here so the CLI is glue only; serializable for `--json`.

use crate::gbuffer::PlaneRef;
use crate::io::sidecar::SidecarCamera;
use crate::io::Loaded;
use serde::ser::{SerializeMap, Serializer};
use serde::Serialize;
use std::fmt::Write as _;

/// A statistic of a scalar attribute (one number) or a vector attribute (one per component).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Stat {
    /// Scalar attribute.
    One(f64),
    /// One value per component.
    Many(Vec<f64>),
}

/// Statistics of one attribute.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AttributeStats {
    /// File channels it was read from (empty when derived).
    pub channels: Vec<String>,
    /// Storage type in the file.
    pub file_type: String,
    /// Conversion applied by the reader, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// Minimum over covered samples (`None` when nothing is covered).
    pub min: Option<Stat>,
    /// Maximum over covered samples.
    pub max: Option<Stat>,
    /// Mean over covered samples.
    pub mean: Option<Stat>,
    /// NaN values found in the file (replaced by 0).
    pub nan: u64,
    /// ±Inf values found in the file (replaced by ±f32::MAX).
    pub inf: u64,
}

/// The attributes in canonical order (serialized as a JSON object keyed by attribute name).
#[derive(Clone, Debug, PartialEq)]
pub struct AttributeMap(pub Vec<(&'static str, AttributeStats)>);

impl Serialize for AttributeMap {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

/// The camera and where it came from.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CameraInfo {
    /// Where it came from.
    pub source: super::CameraSource,
    /// The parameters (sidecar form), when known.
    #[serde(flatten)]
    pub params: Option<SidecarCamera>,
}

/// The compression of the file.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CompressionInfo {
    /// OpenEXR name ("ZIP", "PIZ", "DWAA", …) or the container for non-EXR dumps.
    pub method: String,
    /// True when it loses information for these sample types (precision analysis on it misleads).
    pub lossy: bool,
}

/// Everything `gbuf info` reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Info {
    /// The file.
    pub file: String,
    /// Reader used.
    pub format: crate::io::SourceFormat,
    /// Width in pixels (after folding).
    pub width: u32,
    /// Height in pixels (after folding).
    pub height: u32,
    /// Samples per pixel (after folding).
    pub samples: u32,
    /// Sub-pixel sample positions, pixels from the centre, +y down.
    pub sample_positions: Vec<[f32; 2]>,
    /// Per-attribute provenance and statistics.
    pub attributes: AttributeMap,
    /// Samples with no surface.
    pub background_samples: u64,
    /// All samples (pixels × samples per pixel).
    pub total_samples: u64,
    /// Compression, when the container has one.
    pub compression: Option<CompressionInfo>,
    /// The camera.
    pub camera: CameraInfo,
    /// Number of lights (from the sidecar or the dump), `None` when there are none.
    pub lights: Option<usize>,
    /// Positions reprojected through the camera: [median, max] distance from their sample, pixels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reprojection_px: Option<[f32; 2]>,
    /// Plausibility warnings, with the numbers.
    pub warnings: Vec<crate::io::plausible::Warning>,
    /// For data read by naming: preset and conventions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reading: Option<crate::io::fileset::Reading>,
    /// The engine's materials the sidecar declares (empty when none).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<crate::gbuffer::MaterialParams>,
}

/// Min, max and mean of each component over covered samples, accumulated in f64.
fn component_stats(n_comp: usize, covered: &[bool], get: impl Fn(usize, usize) -> f64) -> Option<(Stat, Stat, Stat)> {
    let mut min = vec![f64::INFINITY; n_comp];
    let mut max = vec![f64::NEG_INFINITY; n_comp];
    let mut sum = vec![0f64; n_comp];
    let mut count = 0u64;
    for (i, _) in covered.iter().enumerate().filter(|(_, c)| **c) {
        count += 1;
        for c in 0..n_comp {
            let v = get(i, c);
            min[c] = min[c].min(v);
            max[c] = max[c].max(v);
            sum[c] += v;
        }
    }
    if count == 0 {
        return None;
    }
    let mean: Vec<f64> = sum.iter().map(|s| s / count as f64).collect();
    let wrap = |v: Vec<f64>| if n_comp == 1 { Stat::One(v[0]) } else { Stat::Many(v) };
    Some((wrap(min), wrap(max), wrap(mean)))
}

/// Builds the report of a loaded dump.
#[must_use]
pub fn info(loaded: &Loaded, file: &std::path::Path) -> Info {
    let gb = &loaded.gbuffer;
    let cov = &gb.coverage;
    let mut attributes = Vec::new();
    for attr in gb.attributes() {
        let plane = gb.plane(attr).expect("present");
        let stats = match plane {
            PlaneRef::F32(p) => component_stats(1, cov, |i, _| f64::from(p[i])),
            PlaneRef::Vec2(p) => component_stats(2, cov, |i, c| f64::from(p[i][c])),
            PlaneRef::Vec3(p) => component_stats(3, cov, |i, c| f64::from(p[i][c])),
            PlaneRef::U32(p) => component_stats(1, cov, |i, _| f64::from(p[i])),
        };
        let src = loaded.sources.iter().find(|s| s.attribute == attr.name());
        let (nan, inf) =
            loaded.sanitized.iter().find(|s| s.0 == attr.name()).map_or((0, 0), |&(_, nan, inf)| (nan, inf));
        let (min, max, mean) = match stats {
            Some((a, b, c)) => (Some(a), Some(b), Some(c)),
            None => (None, None, None),
        };
        attributes.push((
            attr.name(),
            AttributeStats {
                channels: src.map(|s| s.channels.clone()).unwrap_or_default(),
                file_type: src.map_or_else(|| "unknown".to_string(), |s| s.file_type.clone()),
                note: src.and_then(|s| s.note.clone()),
                min,
                max,
                mean,
                nan,
                inf,
            },
        ));
    }
    Info {
        file: file.display().to_string(),
        format: loaded.format,
        width: gb.width,
        height: gb.height,
        samples: gb.samples,
        sample_positions: gb.sample_positions.iter().map(|p| [p.x, p.y]).collect(),
        attributes: AttributeMap(attributes),
        background_samples: gb.background_samples() as u64,
        total_samples: gb.len() as u64,
        compression: loaded.compression.as_ref().map(|(m, l)| CompressionInfo { method: m.clone(), lossy: *l }),
        camera: CameraInfo { source: loaded.camera_source, params: gb.camera.as_ref().map(SidecarCamera::from_camera) },
        lights: loaded.lights.as_ref().map(Vec::len),
        materials: gb.materials.clone(),
        reprojection_px: crate::io::plausible::reprojection(gb).map(|(m, x, _)| [m, x]),
        warnings: loaded.warnings.clone(),
        reading: loaded.reading.clone(),
    }
}

fn fmt_stat(s: &Option<Stat>) -> String {
    match s {
        None => "-".into(),
        Some(Stat::One(v)) => format!("{v:.6}"),
        Some(Stat::Many(v)) => {
            format!("({})", v.iter().map(|x| format!("{x:.4}")).collect::<Vec<_>>().join(", "))
        }
    }
}

impl Info {
    /// Human-readable text (what `gbuf info` prints without `--json`).
    #[must_use]
    pub fn to_text(&self) -> String {
        let mut t = String::new();
        let fmt = serde_json::to_value(self.format).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default();
        let _ = writeln!(t, "{}: {fmt} dump", self.file);
        let _ = writeln!(t, "size        {}×{} pixels, {} samples per pixel", self.width, self.height, self.samples);
        let pos: Vec<String> = self.sample_positions.iter().map(|p| format!("({:+.4}, {:+.4})", p[0], p[1])).collect();
        let _ = writeln!(t, "positions   {} (pixels from the centre, +y down)", pos.join(" "));
        let pct = 100.0 * self.background_samples as f64 / self.total_samples.max(1) as f64;
        let _ = writeln!(t, "background  {} of {} samples ({pct:.1}%)", self.background_samples, self.total_samples);
        if let Some(c) = &self.compression {
            let lossy = if c.lossy { " — LOSSY: precision measured on this file misleads" } else { " (lossless)" };
            let _ = writeln!(t, "compression {}{lossy}", c.method);
        }
        match &self.camera.params {
            Some(c) => {
                let _ = writeln!(
                    t,
                    "camera      from {}: yfov {:.4} rad, aspect {:.4}, znear {}, zfar {}",
                    self.camera.source, c.yfov, c.aspect, c.znear, c.zfar
                );
            }
            None => {
                let _ = writeln!(t, "camera      unknown (give a sidecar with --scene, or a position pass to fit one)");
            }
        }
        let _ = writeln!(t, "lights      {}", self.lights.map_or("none".to_string(), |n| n.to_string()));
        if !self.materials.is_empty() {
            let _ = writeln!(
                t,
                "materials   {} declared (material-ID indirection uses their values as its table)",
                self.materials.len()
            );
        }
        if let Some([m, x]) = self.reprojection_px {
            // About half a pixel everywhere: the positions were taken half a pixel off the samples (a renderer
            // that offsets its rays, or puts pixel centres at integer coordinates).
            let hint = if (0.35..=0.65).contains(&m) && x < 1.0 {
                " — about half a pixel: positions taken at pixel corners, not centres (a renderer's ray offset or a \
                 half-pixel convention); harmless for gbuf, which reads the positions as given"
            } else {
                ""
            };
            let _ = writeln!(
                t,
                "reprojection positions through the camera: median {m:.3} px, max {x:.3} px from their sample{hint}"
            );
        }
        if let Some(r) = &self.reading {
            let _ = writeln!(
                t,
                "read as     {}{}",
                r.preset.as_ref().map_or(String::new(), |p| format!("preset {p}: ")),
                r.conventions.describe()
            );
            if let Some(b) = &r.basis {
                let _ = writeln!(t, "            (conventions {b})");
            }
            if !r.ignored.is_empty() {
                let _ = writeln!(t, "ignored     {} (not buffers gbuf reads)", r.ignored.join(", "));
            }
        }
        for w in &self.warnings {
            let _ = writeln!(t, "WARNING     [{}] {}", w.code, w.message);
        }
        let _ = writeln!(t, "attributes  (statistics over covered samples)");
        for (name, a) in &self.attributes.0 {
            let chans = if a.channels.is_empty() { "-".to_string() } else { a.channels.join(" ") };
            let _ = writeln!(t, "  {name:<15} {:<6} from {chans}", a.file_type);
            let _ = writeln!(t, "      min {}  max {}  mean {}", fmt_stat(&a.min), fmt_stat(&a.max), fmt_stat(&a.mean));
            if a.nan + a.inf > 0 {
                let _ = writeln!(
                    t,
                    "      WARNING: {} NaN and {} ±Inf values in the file (replaced by finite values)",
                    a.nan, a.inf
                );
            }
            if let Some(n) = &a.note {
                let _ = writeln!(t, "      {n}");
            }
        }
        t
    }
}
