//! The byte-budget search: the layout of at most N bytes per sample with the least image error on this dump (or
//! the smallest one whose error stays under a cap).
//!
//! The space: the built-in layouts, their pruned versions, and generated layouts — a depth target (D16, D24S8,
//! D32F with linear, post-projection or reversed encodings) plus integer targets (R16UI/R32UI/RG32UI/RGBA32UI,
//! real formats that hold arbitrary bit fields, as Bevy's Rgba32Uint G-buffer does) packed with a normal codec ×
//! bits, a colour encoding, a codec per scalar, and material-ID indirection on or off. The scene-needs analysis
//! decides what is stored at all: constant attributes become layout constants, absent and derivable ones cost
//! nothing, hemisphere-only normal codecs are offered only when every normal faces the camera, scalar codecs only
//! when their domain holds the scene's range, and the material index has exactly the bits the material count needs.
//!
//! How: (1) every option of every dimension is applied alone to the G-buffer (all else exact) and lit once per
//! pixel; its squared image error against the same lighting of the exact G-buffer is that option's cost. (2) Every
//! combination that fits the budget gets a predicted error (the root of the summed costs). (3) The best predicted
//! combinations and every fitting built-in are packed into real words, unpacked, run through the detector and the
//! full resolve, and compared with the exact G-buffer lit the same way: the measured *layout error* decides (the
//! same metric as the report's fronts; the detector's aliasing is the same for every layout and left out).
//! Every finalist also gets a prediction by the same model — built-ins too: each attribute of its roundtrip
//! applied alone, the costs summed — so the result says how far the model was off.
//!
//! Several frames: [`propose`] runs steps (1)–(2) on each frame, the union of the proposals is measured on every
//! frame ([`measure_frame`]), and [`decide`] picks by each candidate's mean or worst frame. Frames are visited one
//! at a time, so memory is that of one frame.

use crate::analysis::aggregate::{Over, Stat};
use crate::analysis::errors;
use crate::analysis::needs::{self, Needs, MATERIAL_PARAMETERS};
use crate::analysis::prune::prune_spec;
use crate::codec::{self, NormalScheme};
use crate::detect::{self, Detector, DetectorConfig};
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer};
use crate::image::HdrImage;
use crate::layout::{ConstantValue, FieldSpec, IndirectionSpec, Layout, LayoutSpec, TargetSpec, DEFAULT_DEPTH_RANGE};
use crate::light::Light;
use crate::measure;
use crate::measure::image::ErrorSet;
use crate::resolve::{self, ResolveConfig};
use serde::Serialize;
use std::collections::BTreeMap;

/// How many of the best predicted generated layouts are measured for real.
pub const VERIFY_GENERATED: usize = 6;

/// Normal codecs are pre-screened on at most this many covered normals (every k-th sample).
const SCREEN_SAMPLES: usize = 50_000;

/// What to search for.
#[derive(Clone, Debug)]
pub struct BudgetConfig {
    /// Largest layout size in bytes per sample.
    pub max_bytes: u32,
    /// With a cap: the smallest layout whose layout error (RMSE) stays at or under it (ties → lower error).
    pub max_error: Option<f64>,
    /// The detector the verification runs.
    pub detector: Detector,
    /// Its thresholds.
    pub detector_config: DetectorConfig,
    /// Resolve settings.
    pub resolve: ResolveConfig,
    /// Over several frames: rank by each candidate's mean or worst frame.
    pub over: Over,
    /// Only layouts gbuf can emit as shader code (`--emit`): codecs with a `codec::Recipe`, material tables of at
    /// most `layout::shader::MAX_TABLE_BITS` index bits.
    pub shader_code: bool,
    /// Only layouts whose targets bind as one pass at the frame's sample count on every one of these platforms
    /// ([`crate::layout::limits::check`]; empty: no such constraint).
    pub fit: Vec<&'static crate::layout::limits::Platform>,
}

/// A candidate's numbers on one frame.
#[derive(Clone, Debug, Serialize)]
pub struct FrameMeasure {
    /// The frame.
    pub frame: String,
    /// Predicted layout error (RMSE) by the single-option model.
    pub predicted_rmse: Option<f64>,
    /// Measured layout error against the exact G-buffer lit with the same detector.
    pub layout_error: Option<ErrorSet>,
    /// Why it could not be measured.
    pub error: Option<String>,
}

/// One measured (or predicted) candidate.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    /// Layout name.
    pub name: String,
    /// `built-in`, `built-in AFRC` (its 8-bit targets stored with Arm's fixed-rate compression, single-sampled frames
    /// only), `pruned built-in` or `generated`.
    pub kind: String,
    /// Bytes per sample in memory (an AFRC target at its fixed rate; rounded up to whole bytes).
    pub bytes_per_sample: u32,
    /// What it stores, in one line.
    pub summary: String,
    /// Predicted layout error RMSE (mean or worst frame, as [`BudgetConfig::over`]).
    pub predicted_rmse: Option<f64>,
    /// Measured layout error RMSE (mean or worst frame, as [`BudgetConfig::over`]).
    pub rmse: Option<f64>,
    /// Measured PSNR in dB of the same frame's layout error (single frame), or the worst frame's.
    pub psnr_db: Option<f64>,
    /// Measured over predicted error: how far the model was off (1 = exact; ∞ when the model predicted 0).
    pub prediction_ratio: Option<f64>,
    /// The frame with the largest measured layout error.
    pub worst_frame: Option<String>,
    /// Per frame: predicted and measured.
    pub frames: Vec<FrameMeasure>,
    /// Why it could not be measured.
    pub error: Option<String>,
    /// The layout spec.
    #[serde(skip)]
    pub spec: LayoutSpec,
}

/// The search's answer.
#[derive(Clone, Debug, Serialize)]
pub struct BudgetResult {
    /// The budget.
    pub max_bytes: u32,
    /// The error cap, if any.
    pub max_error: Option<f64>,
    /// What the ranking used: the mean or the worst frame.
    pub over: Over,
    /// The frames searched.
    pub frame_names: Vec<String>,
    /// The winning layout.
    pub winner: Candidate,
    /// Every measured candidate, best first (the winner included).
    pub measured: Vec<Candidate>,
    /// The best built-in (or pruned built-in) that fits, if any.
    pub best_builtin: Option<String>,
    /// True when a built-in layout (as shipped) is the best the search found.
    pub builtin_is_best: bool,
    /// Generated combinations that fit the budget (summed over frames).
    pub combinations: usize,
    /// Single-option costs of the first frame, per dimension: (option, bits, image RMSE when applied alone).
    pub option_costs: BTreeMap<String, Vec<(String, u32, f64)>>,
    /// The scene-needs analysis of the first frame.
    pub needs: Needs,
    /// How far the predictions were off over the finalists: the median and the largest of measured / predicted
    /// (and its candidate).
    pub prediction: PredictionSummary,
    /// Wall time in seconds.
    pub seconds: f64,
}

/// How far the single-option model was from the measurement over the finalists.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PredictionSummary {
    /// Finalists with both numbers.
    pub finalists: usize,
    /// Median of measured / predicted.
    pub median_ratio: Option<f64>,
    /// The ratio furthest from 1 (in either direction).
    pub worst_ratio: Option<f64>,
    /// Its candidate.
    pub worst_candidate: Option<String>,
}

/// One option of one dimension.
#[derive(Clone, Debug)]
struct Opt {
    codec: String,
    bits: u32,
    /// Squared image error when applied alone.
    mse: f64,
}

/// Depth target options: (format, codec, bytes).
const DEPTH_OPTIONS: [(&str, &str, u32); 6] = [
    ("d32f", "f32", 4),
    ("d32f", "f32-reversed", 4),
    ("d24s8", "unorm24", 4),
    ("d24s8", "unorm24-reversed", 4),
    ("d16", "unorm16", 2),
    ("d16", "unorm16-reversed", 2),
];

const COLOR_OPTIONS: [&str; 8] = ["f32", "f16", "rgb9e5", "r11g11b10f", "unorm8", "srgb8", "unorm-6", "unorm-5"];

fn scalar_options(attr: Attribute) -> Vec<String> {
    let mut v: Vec<String> = vec!["f32".into(), "f16".into()];
    for n in [4, 5, 6, 8, 10, 12, 16] {
        v.push(format!("unorm-{n}"));
    }
    if attr == Attribute::SpecularPower {
        for n in [6, 8, 10, 12] {
            v.push(format!("log2-unorm-{n}"));
            v.push(format!("specpow-unorm-{n}"));
        }
    }
    v
}

/// Integer target formats the generator packs fields into: (format, bits).
const UINT_TARGETS: [(&str, u32); 4] = [("r16ui", 16), ("r32ui", 32), ("rg32ui", 64), ("rgba32ui", 128)];

/// Every multiset of up to 4 integer targets, smallest total first.
fn target_sets() -> Vec<Vec<usize>> {
    let mut sets = vec![vec![]];
    let mut frontier = vec![vec![]];
    for _ in 0..4 {
        let mut next = Vec::new();
        for s in &frontier {
            let lo = s.last().copied().unwrap_or(0);
            for t in lo..UINT_TARGETS.len() {
                let mut n: Vec<usize> = s.clone();
                n.push(t);
                next.push(n);
            }
        }
        sets.extend(next.iter().cloned());
        frontier = next;
    }
    let bits = |s: &Vec<usize>| s.iter().map(|&t| UINT_TARGETS[t].1).sum::<u32>();
    sets.sort_by_key(|s| (bits(s), s.len()));
    sets
}

/// Places fields (attribute, codec, bits) into the smallest set of integer targets (first fit, largest first).
/// Returns the targets, or `None` when a field is wider than 64 bits.
fn pack_fields(fields: &[(String, String, u32)], sets: &[Vec<usize>]) -> Option<Vec<TargetSpec>> {
    if fields.is_empty() {
        return Some(vec![]);
    }
    if fields.iter().any(|f| f.2 > 64) {
        return None;
    }
    let total: u32 = fields.iter().map(|f| f.2).sum();
    let mut order: Vec<usize> = (0..fields.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(fields[i].2));
    'sets: for set in sets {
        let cap: u32 = set.iter().map(|&t| UINT_TARGETS[t].1).sum();
        if cap < total || set.is_empty() {
            continue;
        }
        // Larger targets first so big fields land there.
        let mut tg: Vec<usize> = set.clone();
        tg.sort_by_key(|&t| std::cmp::Reverse(UINT_TARGETS[t].1));
        let mut used = vec![0u32; tg.len()];
        let mut placed: Vec<Vec<FieldSpec>> = vec![vec![]; tg.len()];
        for &i in &order {
            let (a, c, b) = &fields[i];
            let Some(k) = (0..tg.len()).find(|&k| used[k] + b <= UINT_TARGETS[tg[k]].1) else { continue 'sets };
            placed[k].push(FieldSpec {
                attribute: a.clone(),
                codec: c.clone(),
                offset: used[k],
                bits: *b,
                note: String::new(),
            });
            used[k] += b;
        }
        return Some(
            tg.iter()
                .zip(placed)
                .enumerate()
                .map(|(k, (&t, fields))| TargetSpec {
                    name: format!("gbuffer{k}"),
                    format: UINT_TARGETS[t].0.into(),
                    note: String::new(),
                    afrc: None,
                    fields,
                })
                .collect(),
        );
    }
    None
}

fn set_bytes(targets: &[TargetSpec]) -> u32 {
    targets.iter().map(|t| UINT_TARGETS.iter().find(|u| u.0 == t.format).map_or(0, |u| u.1 / 8)).sum()
}

/// The planes the lighting pass reads, lit once per pixel: the cheap image used to price single options.
struct Pricer<'a> {
    gb: &'a GBuffer,
    lights: &'a [Light],
    cfg: ResolveConfig,
    mask: detect::EdgeMask,
    exact: HdrImage,
}

impl Pricer<'_> {
    fn mse(&self, test: &GBuffer) -> Result<f64> {
        let img = resolve::resolve(test, self.lights, &self.mask, &self.cfg)?.image;
        let e = measure::image::compare(&self.exact, &img);
        Ok(e.rmse * e.rmse)
    }
}

fn depth_planes(gb: &GBuffer) -> [f32; 2] {
    match gb.camera {
        Some(c) if c.znear > 0.0 && c.zfar > c.znear && c.zfar.is_finite() => [c.znear, c.zfar],
        _ => DEFAULT_DEPTH_RANGE,
    }
}

/// `gb` with one attribute replaced by its roundtrip through a codec.
fn with_codec(gb: &GBuffer, attr: Attribute, name: &str) -> Option<GBuffer> {
    let mut g = gb.clone();
    match attr {
        Attribute::Normal => {
            let c = codec::normal_codec(name)?;
            for n in g.normal.as_mut()? {
                *n = c.decode(c.encode(*n));
            }
        }
        Attribute::Albedo => {
            let c = codec::color_codec(name)?;
            for a in g.albedo.as_mut()? {
                *a = c.decode(c.encode(*a));
            }
        }
        Attribute::Depth => {
            let [n, f] = depth_planes(gb);
            let c = codec::depth_codec(name, n, f)?;
            let cov = g.coverage.clone();
            let d = g.depth.as_mut()?;
            let mut scale = vec![1.0f32; d.len()];
            for (i, z) in d.iter_mut().enumerate() {
                if cov[i] {
                    let q = c.decode(c.encode(*z));
                    scale[i] = q / z.max(f32::MIN_POSITIVE);
                    *z = q;
                }
            }
            // Position follows depth along the same camera ray.
            if let Some(p) = g.position.as_mut() {
                for (p, s) in p.iter_mut().zip(&scale) {
                    *p *= *s;
                }
            }
        }
        a => {
            let c = codec::scalar_codec(name)?;
            let plane = match a {
                Attribute::Specular => g.specular.as_mut()?,
                Attribute::SpecularPower => g.specular_power.as_mut()?,
                Attribute::Roughness => g.roughness.as_mut()?,
                Attribute::Metallic => g.metallic.as_mut()?,
                _ => return None,
            };
            for v in plane {
                *v = c.decode(c.encode(*v));
            }
        }
    }
    Some(g)
}

/// Covered samples, thinned to at most `n`.
fn screen_indices(gb: &GBuffer, n: usize) -> Vec<usize> {
    let covered: Vec<usize> = (0..gb.len()).filter(|&i| gb.coverage[i]).collect();
    let step = covered.len().div_ceil(n.max(1)).max(1);
    covered.into_iter().step_by(step).collect()
}

/// Normal codecs worth pricing: per bit count, the scheme with the smallest mean angular error on the scene's own
/// normals; hemisphere-only schemes only when every normal faces the camera.
fn normal_candidates(gb: &GBuffer, needs: &Needs) -> Vec<String> {
    let Some(normals) = gb.normal.as_deref() else { return vec![] };
    let idx = screen_indices(gb, SCREEN_SAMPLES);
    let mut best: BTreeMap<u32, (f64, String)> = BTreeMap::new();
    for s in NormalScheme::ALL {
        if s.hemisphere_only() && needs.normals_face_camera != Some(true) {
            continue;
        }
        for bits in s.valid_bits().into_iter().filter(|b| (16..=48).contains(b) && (b % 4 == 0)) {
            let Some(c) = s.codec(bits) else { continue };
            let err: f64 = idx
                .iter()
                .map(|&i| f64::from(codec::angle_deg(normals[i], c.decode(c.encode(normals[i])))))
                .sum::<f64>()
                / idx.len().max(1) as f64;
            let name = format!("{}-{bits}", s.name());
            if best.get(&bits).is_none_or(|(e, _)| err < *e) {
                best.insert(bits, (err, name));
            }
        }
    }
    best.into_values().map(|(_, n)| n).collect()
}

/// Scalar codecs worth pricing for `attr`: those whose domain holds the scene's range, best per bit count.
fn scalar_candidates(gb: &GBuffer, attr: Attribute, needs: &Needs) -> Vec<String> {
    let Some(range) = needs.ranges.get(attr.name()) else { return vec![] };
    let Some(crate::gbuffer::PlaneRef::F32(plane)) = gb.plane(attr) else { return vec![] };
    let idx = screen_indices(gb, SCREEN_SAMPLES);
    let mut best: BTreeMap<u32, (f64, String)> = BTreeMap::new();
    for name in scalar_options(attr) {
        let Some(c) = codec::scalar_codec(&name) else { continue };
        let (lo, hi) = c.domain();
        if range[0] < lo || range[1] > hi {
            continue;
        }
        let err = idx.iter().map(|&i| f64::from((c.decode(c.encode(plane[i])) - plane[i]).abs())).fold(0.0, f64::max);
        if best.get(&c.bits()).is_none_or(|(e, _)| err < *e) {
            best.insert(c.bits(), (err, name));
        }
    }
    best.into_values().map(|(_, n)| n).collect()
}

/// Generated-layout dimensions: name → priced options.
struct Space {
    depth: Vec<(usize, f64)>,
    normal: Vec<Opt>,
    albedo: Vec<Opt>,
    scalars: Vec<(Attribute, Vec<Opt>)>,
    /// Material index bits when indirection is possible.
    index_bits: Option<u32>,
    constants: BTreeMap<String, ConstantValue>,
    /// Position stored as f32 components (no camera to rebuild it from depth).
    store_position: bool,
    depth_range: Option<[f32; 2]>,
}

fn price(pricer: &Pricer<'_>, attr: Attribute, names: &[String]) -> Result<Vec<Opt>> {
    let mut v = Vec::new();
    for name in names {
        let bits = match attr {
            Attribute::Normal => codec::normal_codec(name).map(|c| c.bits()),
            Attribute::Albedo => codec::color_codec(name).map(|c| c.bits()),
            _ => codec::scalar_codec(name).map(|c| c.bits()),
        };
        let (Some(bits), Some(g)) = (bits, with_codec(pricer.gb, attr, name)) else { continue };
        v.push(Opt { codec: name.clone(), bits, mse: pricer.mse(&g)? });
    }
    Ok(keep_front(v, |o| (f64::from(o.bits), o.mse)))
}

/// Keeps the options no other option beats on both cost and error (a dominated option never helps a combination).
fn keep_front<T>(v: Vec<T>, key: impl Fn(&T) -> (f64, f64)) -> Vec<T> {
    let pts: Vec<(f64, f64)> = v.iter().map(&key).collect();
    let on = crate::analysis::pareto::front(&pts);
    let mut seen = Vec::new();
    v.into_iter()
        .zip(on)
        .filter(|(t, f)| {
            let k = key(t);
            // Of exact ties keep the first.
            let keep = *f && !seen.contains(&(k.0.to_bits(), k.1.to_bits()));
            seen.push((k.0.to_bits(), k.1.to_bits()));
            keep
        })
        .map(|(t, _)| t)
        .collect()
}

fn build_space(pricer: &Pricer<'_>, needs: &Needs) -> Result<Space> {
    let gb = pricer.gb;
    let needed = |a: Attribute| gb.has(a) && !needs.is_constant(a);
    let mut depth = Vec::new();
    if needed(Attribute::Depth) {
        for (k, (_, c, _)) in DEPTH_OPTIONS.iter().enumerate() {
            if let Some(g) = with_codec(gb, Attribute::Depth, c) {
                depth.push((k, pricer.mse(&g)?));
            }
        }
        depth = keep_front(depth, |&(k, m)| (f64::from(DEPTH_OPTIONS[k].2), m));
    }
    let normal = if needed(Attribute::Normal) {
        price(pricer, Attribute::Normal, &normal_candidates(gb, needs))?
    } else {
        vec![]
    };
    let colors: Vec<String> = COLOR_OPTIONS.iter().map(|s| s.to_string()).collect();
    let albedo = if needed(Attribute::Albedo) { price(pricer, Attribute::Albedo, &colors)? } else { vec![] };
    let mut scalars = Vec::new();
    for a in MATERIAL_PARAMETERS {
        if needed(a) {
            let opts = price(pricer, a, &scalar_candidates(gb, a, needs))?;
            if !opts.is_empty() {
                scalars.push((a, opts));
            }
        }
    }
    let mut constants = BTreeMap::new();
    for (name, v) in &needs.constant_values {
        let Some(a) = Attribute::from_name(name) else { continue };
        if a.is_id() || a == Attribute::Position || a == Attribute::Motion {
            continue;
        }
        let c = if v.len() == 1 {
            ConstantValue::Scalar(v[0] as f32)
        } else {
            ConstantValue::Vector(v.iter().map(|&x| x as f32).collect())
        };
        constants.insert(name.clone(), c);
    }
    let index_bits = needs.material_id_bits.filter(|&b| (1..=16).contains(&b) && scalars.len() >= 2);
    Ok(Space {
        depth,
        normal,
        albedo,
        scalars,
        index_bits,
        constants,
        store_position: gb.camera.is_none() && gb.has(Attribute::Position),
        depth_range: if gb.camera.is_none() { needs.depth_range.map(|[a, b]| [a * 0.99, b * 1.01]) } else { None },
    })
}

/// One combination: indices into the space's dimensions.
#[derive(Clone, Debug)]
struct Combo {
    depth: Option<usize>,
    normal: Option<usize>,
    albedo: Option<usize>,
    scalars: Vec<usize>,
    indirection: bool,
}

impl Space {
    /// Drops the options gbuf cannot emit as shader code (no `codec::Recipe`) and a table too wide for the
    /// emitted uniform block.
    fn keep_emittable(&mut self) {
        use crate::layout::shader::codec_emittable;
        use crate::layout::Slot;
        self.normal.retain(|o| codec_emittable(Slot::Whole(Attribute::Normal), &o.codec));
        self.albedo.retain(|o| codec_emittable(Slot::Whole(Attribute::Albedo), &o.codec));
        for (a, opts) in &mut self.scalars {
            opts.retain(|o| codec_emittable(Slot::Whole(*a), &o.codec));
        }
        self.index_bits = self.index_bits.filter(|&b| b <= crate::layout::shader::MAX_TABLE_BITS);
    }

    fn predicted_mse(&self, c: &Combo) -> f64 {
        let mut m = c.depth.map_or(0.0, |k| self.depth[k].1);
        m += c.normal.map_or(0.0, |k| self.normal[k].mse);
        m += c.albedo.map_or(0.0, |k| self.albedo[k].mse);
        if !c.indirection {
            m += self.scalars.iter().zip(&c.scalars).map(|((_, o), &k)| o[k].mse).sum::<f64>();
        }
        m
    }

    fn spec(&self, c: &Combo, sets: &[Vec<usize>]) -> Option<LayoutSpec> {
        let mut fields: Vec<(String, String, u32)> = Vec::new();
        let mut name = String::from("gen");
        if let Some(k) = c.normal {
            let o = &self.normal[k];
            fields.push(("normal".into(), o.codec.clone(), o.bits));
            name.push_str(&format!("-n{}", o.codec));
        }
        if let Some(k) = c.albedo {
            let o = &self.albedo[k];
            fields.push(("albedo".into(), o.codec.clone(), o.bits));
            name.push_str(&format!("-a{}", o.codec));
        }
        let mut indirection = None;
        if c.indirection {
            let bits = self.index_bits?;
            fields.push(("material_index".into(), String::new(), bits));
            indirection = Some(IndirectionSpec {
                bits,
                parameters: self.scalars.iter().map(|(a, _)| a.name().to_string()).collect(),
                key: Default::default(),
            });
            name.push_str(&format!("-mat{bits}"));
        } else {
            for ((a, opts), &k) in self.scalars.iter().zip(&c.scalars) {
                fields.push((a.name().into(), opts[k].codec.clone(), opts[k].bits));
                name.push_str(&format!("-{}{}", &a.name()[..1], opts[k].codec.replace("unorm-", "u")));
            }
        }
        if self.store_position {
            for comp in ["x", "y", "z"] {
                fields.push((format!("position.{comp}"), "f32".into(), 32));
            }
        }
        let mut targets = Vec::new();
        if let Some(k) = c.depth {
            let (fmt, codec, _) = DEPTH_OPTIONS[self.depth[k].0];
            let mut f = vec![FieldSpec {
                attribute: "depth".into(),
                codec: codec.into(),
                offset: 0,
                bits: if fmt == "d16" {
                    16
                } else if fmt == "d24s8" {
                    24
                } else {
                    32
                },
                note: String::new(),
            }];
            if fmt == "d24s8" {
                f.push(FieldSpec {
                    attribute: "reserved".into(),
                    codec: String::new(),
                    offset: 24,
                    bits: 8,
                    note: "stencil".into(),
                });
            }
            targets.push(TargetSpec {
                name: "depth".into(),
                format: fmt.into(),
                note: String::new(),
                afrc: None,
                fields: f,
            });
            name.push_str(&format!("-d{codec}"));
        }
        targets.extend(pack_fields(&fields, sets)?);
        Some(LayoutSpec {
            name,
            description: "generated by gbuf budget for one scene".into(),
            sources: vec![],
            depth_range: self.depth_range,
            constants: self.constants.clone(),
            material_indirection: indirection,
            targets,
        })
    }

    fn bytes(&self, c: &Combo, sets: &[Vec<usize>]) -> Option<u32> {
        let spec = self.spec(c, sets)?;
        let depth = c.depth.map_or(0, |k| DEPTH_OPTIONS[self.depth[k].0].2);
        let rest: Vec<TargetSpec> = spec.targets.into_iter().filter(|t| t.name != "depth").collect();
        Some(depth + set_bytes(&rest))
    }

    /// Every combination (cartesian product; indirection doubles it when possible).
    fn combos(&self) -> Vec<Combo> {
        let opt = |n: usize| -> Vec<Option<usize>> {
            if n == 0 {
                vec![None]
            } else {
                (0..n).map(Some).collect()
            }
        };
        let mut scalar_sets: Vec<Vec<usize>> = vec![vec![]];
        for (_, o) in &self.scalars {
            scalar_sets = scalar_sets
                .into_iter()
                .flat_map(|s| (0..o.len()).map(move |k| [s.clone(), vec![k]].concat()))
                .collect();
        }
        let mut out = Vec::new();
        for d in opt(self.depth.len()) {
            for n in opt(self.normal.len()) {
                for a in opt(self.albedo.len()) {
                    for s in &scalar_sets {
                        out.push(Combo { depth: d, normal: n, albedo: a, scalars: s.clone(), indirection: false });
                    }
                    if self.index_bits.is_some() {
                        let zeros = vec![0; self.scalars.len()];
                        out.push(Combo { depth: d, normal: n, albedo: a, scalars: zeros, indirection: true });
                    }
                }
            }
        }
        out
    }
}

fn summary(spec: &LayoutSpec) -> String {
    let mut parts: Vec<String> = spec
        .targets
        .iter()
        .map(|t| {
            let f: Vec<String> = t
                .fields
                .iter()
                .filter(|f| f.attribute != "reserved")
                .map(|f| {
                    if f.codec.is_empty() {
                        format!("{}:{}", f.attribute, f.bits)
                    } else {
                        format!("{} {}", f.attribute, f.codec)
                    }
                })
                .collect();
            format!("{}[{}]", t.format, f.join(", "))
        })
        .collect();
    if !spec.constants.is_empty() {
        parts.push(format!("constants: {}", spec.constants.keys().cloned().collect::<Vec<_>>().join(", ")));
    }
    parts.join(" + ")
}

/// Measures a layout: roundtrip, detector, full resolve, error against `exact` (the exact G-buffer lit with the
/// same detector).
fn measure_layout(
    gb: &GBuffer,
    lights: &[Light],
    exact: &HdrImage,
    cfg: &BudgetConfig,
    layout: &Layout,
) -> Result<ErrorSet> {
    let e = errors::layout_image_error(gb, lights, layout, exact, cfg.detector, &cfg.detector_config, &cfg.resolve)?;
    Ok(ErrorSet::numeric(&e))
}

/// The single-option model's prediction for any layout: each attribute of its roundtrip applied alone (the rest
/// exact), lit once per pixel, the squared errors summed.
fn predict_layout(pricer: &Pricer<'_>, layout: &Layout) -> Result<f64> {
    let decoded = layout.roundtrip(pricer.gb)?;
    let mut mse = 0.0;
    for a in Attribute::ALL {
        if !pricer.gb.has(a) || a.is_id() || a == Attribute::Position {
            continue;
        }
        let mut g = pricer.gb.clone();
        if !g.copy_plane_from(&decoded, a) {
            continue;
        }
        if a == Attribute::Depth {
            if let (Some(p), Some(q)) = (g.position.as_mut(), decoded.position.as_ref()) {
                p.clone_from(q);
            }
        }
        mse += pricer.mse(&g)?;
    }
    Ok(mse.sqrt())
}

/// Bytes per sample a layout occupies in memory, whole bytes rounded up (an AFRC target at its fixed rate).
fn stored_bytes(l: &Layout) -> u32 {
    l.stored_bytes_per_sample().ceil() as u32
}

fn candidate(spec: LayoutSpec, kind: &str, predicted: Option<f64>) -> Candidate {
    Candidate {
        name: spec.name.clone(),
        kind: kind.into(),
        bytes_per_sample: 0,
        summary: summary(&spec),
        predicted_rmse: predicted,
        rmse: None,
        psnr_db: None,
        prediction_ratio: None,
        worst_frame: None,
        frames: vec![],
        error: None,
        spec,
    }
}

/// What one frame proposes: its generated finalists and the fitting (pruned) built-ins.
#[derive(Clone, Debug)]
pub struct Proposal {
    /// The candidates (unmeasured).
    pub candidates: Vec<Candidate>,
    /// Generated combinations that fit.
    pub combinations: usize,
    /// The frame's single-option costs.
    pub option_costs: BTreeMap<String, Vec<(String, u32, f64)>>,
    /// The frame's needs.
    pub needs: Needs,
}

fn pricer<'a>(gb: &'a GBuffer, lights: &'a [Light], cfg: &BudgetConfig) -> Result<Pricer<'a>> {
    let once = detect::detect(gb, Detector::None, &cfg.detector_config)?;
    let exact = resolve::resolve(gb, lights, &once, &cfg.resolve)?.image;
    Ok(Pricer { gb, lights, cfg: cfg.resolve, mask: once, exact })
}

/// Steps (1) and (2) on one frame: prices every option, predicts every fitting combination, and proposes the
/// best few with every fitting built-in and pruned built-in.
pub fn propose(gb: &GBuffer, lights: &[Light], cfg: &BudgetConfig) -> Result<Proposal> {
    if cfg.max_bytes == 0 {
        return Err(Error::Argument("the byte budget must be at least 1 byte per sample".into()));
    }
    let needs = needs::analyze(gb);
    let pricer = pricer(gb, lights, cfg)?;
    let mut space = build_space(&pricer, &needs)?;
    if cfg.shader_code {
        space.keep_emittable();
    }
    let sets = target_sets();

    // Predict every combination that fits; keep the best few (or, under an error cap, the smallest few).
    let mut fitting: Vec<(u32, f64, Combo)> = space
        .combos()
        .into_iter()
        .filter_map(|c| {
            let b = space.bytes(&c, &sets)?;
            (b <= cfg.max_bytes).then(|| (b, space.predicted_mse(&c).sqrt(), c))
        })
        .collect();
    let combinations = fitting.len();
    match cfg.max_error {
        None => fitting.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0))),
        Some(e) => fitting.sort_by(|a, b| ((a.1 > e), a.0).cmp(&((b.1 > e), b.0)).then(a.1.total_cmp(&b.1))),
    }
    let mut cands: Vec<Candidate> = Vec::new();
    let binds = |l: &Layout| cfg.fit.iter().all(|p| crate::layout::limits::check(p, l.formats(), gb.samples).fits());
    for (_, pred, c) in &fitting {
        if cands.len() == VERIFY_GENERATED {
            break;
        }
        if let Some(spec) = space.spec(c, &sets) {
            if cfg.fit.is_empty() || Layout::from_spec(spec.clone()).is_ok_and(|l| binds(&l)) {
                cands.push(candidate(spec, "generated", Some(*pred)));
            }
        }
    }
    for l in Layout::builtins() {
        if l.bytes_per_sample() as u32 <= cfg.max_bytes && binds(&l) {
            cands.push(candidate(l.spec().clone(), "built-in", None));
        }
        // A single-sampled frame may store the built-in's 8-bit targets with AFRC: fewer bytes in memory, lossy.
        if gb.samples == 1 {
            for rate in crate::layout::afrc::RATES {
                if let Ok(al) = l.with_afrc(rate) {
                    if stored_bytes(&al) <= cfg.max_bytes && binds(&al) {
                        cands.push(candidate(al.spec().clone(), "built-in AFRC", None));
                    }
                }
            }
        }
        let (p, changes) = prune_spec(l.spec(), &needs);
        if !changes.is_empty() {
            if let Ok(pl) = Layout::from_spec(p.clone()) {
                if pl.bytes_per_sample() as u32 <= cfg.max_bytes && binds(&pl) {
                    cands.push(candidate(p, "pruned built-in", None));
                }
            }
        }
    }
    if cfg.shader_code {
        cands.retain(|c| {
            // Code that gives gbuf's bits: emitted, and every codec exact (no driver transcendental).
            Layout::from_spec(c.spec.clone()).is_ok_and(|l| {
                crate::layout::shader::emit(&l, crate::layout::shader::Lang::Glsl).is_ok()
                    && l.fields().iter().all(|f| crate::layout::shader::codec_emittable(f.slot, &f.codec))
            })
        });
    }
    Ok(Proposal { candidates: cands, combinations, option_costs: option_costs(&space), needs })
}

/// Adds `new` to `into` unless an equal spec is there; a different spec under a taken name gets a `#k` suffix.
fn merge_candidates(into: &mut Vec<Candidate>, new: Vec<Candidate>) {
    for mut c in new {
        if into.iter().any(|o| o.spec == c.spec) {
            continue;
        }
        let mut k = 2;
        let base = c.name.clone();
        while into.iter().any(|o| o.name == c.name) {
            c.name = format!("{base}#{k}");
            k += 1;
        }
        c.spec.name.clone_from(&c.name);
        into.push(c);
    }
}

/// Measures every candidate on one frame: its layout error and, for candidates without one from this frame's
/// search, the model's prediction.
pub fn measure_frame(
    name: &str,
    gb: &GBuffer,
    lights: &[Light],
    cfg: &BudgetConfig,
    cands: &mut [Candidate],
    proposed_here: &[String],
) -> Result<()> {
    let exact = errors::lit(gb, lights, cfg.detector, &cfg.detector_config, &cfg.resolve)?.image;
    let pricer = pricer(gb, lights, cfg)?;
    for c in cands.iter_mut() {
        let mut m = FrameMeasure { frame: name.to_string(), predicted_rmse: None, layout_error: None, error: None };
        match Layout::from_spec(c.spec.clone()) {
            Ok(l) => {
                c.bytes_per_sample = stored_bytes(&l);
                m.predicted_rmse = match (c.kind.as_str(), proposed_here.contains(&c.name)) {
                    ("generated", true) => c.predicted_rmse,
                    _ => predict_layout(&pricer, &l).ok(),
                };
                match measure_layout(gb, lights, &exact, cfg, &l) {
                    Ok(e) => m.layout_error = Some(e),
                    Err(e) => m.error = Some(e.to_string()),
                }
            }
            Err(e) => m.error = Some(e.to_string()),
        }
        c.frames.push(m);
    }
    Ok(())
}

/// Step (3) over the frames measured: ranks by measured layout error (mean or worst frame), checks the budget
/// and the cap, and says how far the predictions were off.
pub fn decide(
    frame_names: Vec<String>,
    mut cands: Vec<Candidate>,
    first: Proposal,
    combinations: usize,
    cfg: &BudgetConfig,
    seconds: f64,
) -> Result<BudgetResult> {
    let n = frame_names.len();
    for c in &mut cands {
        let failed = c.frames.iter().find_map(|m| m.error.clone());
        let measured = Stat::of(c.frames.iter().map(|m| (m.frame.as_str(), m.layout_error.map(|e| e.rmse))));
        let predicted = Stat::of(c.frames.iter().map(|m| (m.frame.as_str(), m.predicted_rmse)));
        c.error = failed.map(|e| if n > 1 { format!("{e} (on at least one frame)") } else { e });
        if c.error.is_none() && measured.as_ref().is_some_and(|s| s.frames == n) {
            let st = measured.unwrap_or_else(|| unreachable!());
            c.rmse = Some(st.over(cfg.over));
            c.psnr_db =
                c.frames.iter().find(|m| m.frame == st.worst_frame).and_then(|m| m.layout_error.map(|e| e.psnr_db));
            c.worst_frame = Some(st.worst_frame.clone());
        }
        c.predicted_rmse = predicted.map(|p| p.over(cfg.over));
        c.prediction_ratio = match (c.rmse, c.predicted_rmse) {
            (Some(m), Some(p)) if p > 0.0 => Some(m / p),
            (Some(m), Some(_)) if m > 0.0 => Some(f64::INFINITY),
            (Some(_), Some(_)) => Some(1.0),
            _ => None,
        };
    }
    let key = |c: &Candidate| c.rmse.unwrap_or(f64::INFINITY);
    match cfg.max_error {
        None => cands.sort_by(|a, b| key(a).total_cmp(&key(b)).then(a.bytes_per_sample.cmp(&b.bytes_per_sample))),
        Some(e) => cands.sort_by(|a, b| {
            ((key(a) > e), a.bytes_per_sample).cmp(&((key(b) > e), b.bytes_per_sample)).then(key(a).total_cmp(&key(b)))
        }),
    }
    let winner =
        cands.iter().find(|c| c.rmse.is_some() && c.bytes_per_sample <= cfg.max_bytes).cloned().ok_or_else(|| {
            Error::Implausible(format!(
                "no layout of at most {} bytes per sample could be measured on {}",
                cfg.max_bytes,
                if n > 1 { "every frame" } else { "this scene" }
            ))
        })?;
    if let Some(e) = cfg.max_error {
        if winner.rmse.is_some_and(|r| r > e) {
            return Err(Error::Implausible(format!(
                "no layout of at most {} bytes per sample reaches layout error RMSE ≤ {e}; the best is {} with {:.6}",
                cfg.max_bytes,
                winner.name,
                winner.rmse.unwrap_or(f64::NAN)
            )));
        }
    }
    let best_builtin = cands.iter().find(|c| c.kind != "generated" && c.rmse.is_some()).map(|c| c.name.clone());
    let mut ratios: Vec<(f64, &str)> = cands
        .iter()
        .filter_map(|c| c.prediction_ratio.filter(|r| r.is_finite()).map(|r| (r, c.name.as_str())))
        .collect();
    ratios.sort_by(|a, b| a.0.total_cmp(&b.0));
    let far = |r: f64| if r > 0.0 { r.max(1.0 / r) } else { f64::INFINITY };
    let worst = ratios.iter().max_by(|a, b| far(a.0).total_cmp(&far(b.0)));
    let prediction = PredictionSummary {
        finalists: ratios.len(),
        median_ratio: (!ratios.is_empty()).then(|| ratios[ratios.len() / 2].0),
        worst_ratio: worst.map(|w| w.0),
        worst_candidate: worst.map(|w| w.1.to_string()),
    };
    Ok(BudgetResult {
        max_bytes: cfg.max_bytes,
        max_error: cfg.max_error,
        over: cfg.over,
        frame_names,
        builtin_is_best: winner.kind == "built-in",
        winner,
        measured: cands,
        best_builtin,
        combinations,
        option_costs: first.option_costs,
        needs: first.needs,
        prediction,
        seconds,
    })
}

/// Searches for the best layout within the budget on one frame `gb` lit by `lights`.
pub fn search(gb: &GBuffer, lights: &[Light], cfg: &BudgetConfig) -> Result<BudgetResult> {
    let frame = || Ok::<_, Error>((gb, lights.to_vec()));
    search_frames(&["frame".to_string()], |_| frame(), cfg).map(|(r, _)| r)
}

/// Searches for the best layout within the budget over the frames `names`, reading frame `i` with `load(i)` when
/// the search needs it: with one frame once (propose and measure in one visit); with several twice (every frame
/// proposes its candidates, then every candidate is measured on every frame), so one frame is in memory at a
/// time. Returns the result and the first frame's width, height and samples. A failed step names its frame
/// ([`Error::InFrame`]).
pub fn search_frames<G, E>(
    names: &[String],
    mut load: impl FnMut(usize) -> std::result::Result<(G, Vec<Light>), E>,
    cfg: &BudgetConfig,
) -> std::result::Result<(BudgetResult, (u32, u32, u32)), E>
where
    G: std::borrow::Borrow<GBuffer>,
    E: From<Error>,
{
    let start = std::time::Instant::now();
    let in_frame = |i: usize, step: &'static str| {
        move |e: Error| E::from(Error::InFrame { frame: names[i].clone(), step, source: Box::new(e) })
    };
    let mut cands = Vec::new();
    let mut first = None;
    let mut combinations = 0;
    let mut proposed: Vec<Vec<String>> = Vec::new();
    let mut size = (0, 0, 0);
    for i in 0..names.len() {
        let (gb, lights) = load(i)?;
        let gb = gb.borrow();
        if i == 0 {
            size = (gb.width, gb.height, gb.samples);
        }
        let prop = propose(gb, &lights, cfg).map_err(in_frame(i, "budget search"))?;
        combinations += prop.combinations;
        let before: Vec<String> = cands.iter().map(|c: &Candidate| c.name.clone()).collect();
        merge_candidates(&mut cands, prop.candidates.clone());
        proposed.push(cands.iter().map(|c| c.name.clone()).filter(|n| !before.contains(n)).collect());
        if names.len() == 1 {
            measure_frame(&names[0], gb, &lights, cfg, &mut cands, &proposed[0])
                .map_err(in_frame(i, "measuring the candidates"))?;
        }
        first.get_or_insert(prop);
    }
    if names.len() > 1 {
        for i in 0..names.len() {
            let (gb, lights) = load(i)?;
            measure_frame(&names[i], gb.borrow(), &lights, cfg, &mut cands, &proposed[i])
                .map_err(in_frame(i, "measuring the candidates"))?;
        }
    }
    let first = first.ok_or_else(|| Error::Argument("no frame given to the budget search".into()))?;
    let res = decide(names.to_vec(), cands, first, combinations, cfg, start.elapsed().as_secs_f64())?;
    Ok((res, size))
}

fn option_costs(space: &Space) -> BTreeMap<String, Vec<(String, u32, f64)>> {
    let mut m = BTreeMap::new();
    let rows = |o: &[Opt]| o.iter().map(|o| (o.codec.clone(), o.bits, o.mse.sqrt())).collect::<Vec<_>>();
    m.insert(
        "depth".into(),
        space
            .depth
            .iter()
            .map(|&(k, mse)| {
                (format!("{} {}", DEPTH_OPTIONS[k].0, DEPTH_OPTIONS[k].1), DEPTH_OPTIONS[k].2 * 8, mse.sqrt())
            })
            .collect(),
    );
    m.insert("normal".into(), rows(&space.normal));
    m.insert("albedo".into(), rows(&space.albedo));
    for (a, o) in &space.scalars {
        m.insert(a.name().into(), rows(o));
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn target_sets_are_sorted_and_packing_fits() {
        let sets = target_sets();
        let bits: Vec<u32> = sets.iter().map(|s| s.iter().map(|&t| UINT_TARGETS[t].1).sum()).collect();
        assert!(bits.windows(2).all(|w| w[0] <= w[1]));
        let f = |b| ("normal".to_string(), "x".to_string(), b);
        let t = pack_fields(&[f(24), f(8), f(32)], &sets).unwrap();
        assert_eq!(set_bytes(&t), 8, "64 bits → one rg32ui");
        let t = pack_fields(&[f(24), f(24), f(24)], &sets).unwrap();
        assert_eq!(set_bytes(&t), 12, "three 24-bit fields: no 10-byte set holds them without splitting a field");
        for t in &t {
            let cap = UINT_TARGETS.iter().find(|u| u.0 == t.format).unwrap().1;
            let mut fs = t.fields.clone();
            fs.sort_by_key(|f| f.offset);
            assert!(fs.windows(2).all(|w| w[0].offset + w[0].bits <= w[1].offset));
            assert!(fs.iter().all(|f| f.offset + f.bits <= cap));
        }
        assert!(pack_fields(&[f(65)], &sets).is_none());
        assert_eq!(pack_fields(&[], &sets).unwrap().len(), 0);
    }
}
