//! "Forward or deferred? Depends on context": one table per frame with a row per rendering pipeline, each measured
//! on the frame's own samples — footprint, modelled traffic, shading work, light-pair tests, SIMD utilisation,
//! CPU time where gbuf runs the pipeline, and the image error against the every-sample reference.
//!
//! Input: a G-buffer, its lights, a [`PipelinesConfig`]. Output: [`Pipelines`]. The counts come from
//! [`crate::analysis::forward`] (quads, fragment lists, utilisation) and from the resolve (light pairs, light
//! lists); the footprints and traffic come from one model, [`crate::analysis::traffic`] (also in docs/GUIDE.md).
//!
//! Which image each pipeline makes: forward without MSAA shades one sample per pixel (the `none` detector's image,
//! the no-AA image); forward MSAA, forward+ and the visibility buffer shade once per (triangle, pixel) (the
//! `forward-msaa` detector's image); the deferred rows shade what the chosen detector asks. Forward rows need
//! primitive IDs: without them they are listed with the reason and no numbers.

use crate::analysis::compress::{
    footprint, light_compressed, CompressFrame, FragmentKey, Method, StreamingConfig, STRIP_ROWS,
};
use crate::analysis::forward::{self, ForwardSamples, FragmentLists, QuadShading, Utilisation};
use crate::analysis::traffic::{bandwidth, Counts};
use crate::base::mask::EdgeMask;
use crate::detect::{self, Detector, DetectorConfig};
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use crate::image::mlaa::{mlaa, MlaaConfig, MlaaStats};
use crate::image::HdrImage;
use crate::layout::Layout;
use crate::light::Light;
use crate::measure::image::{error_set, flip_means, ErrorSet, Viewing};
use crate::resolve::{self, Culling, MsaaSchedule, ResolveConfig, Schedule};
use crate::scene::rematerialise::{rematerialise, Rematerialised};
use crate::scene::SceneName;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Instant;

pub use crate::analysis::traffic::Pipeline;

/// The detectors the anti-aliasing table compares by default (adaptive MSAA with each, beside no AA, MLAA, SSAA):
/// Lauritzen 2010's test, then depth, normal and ID discontinuities alone.
pub const DEFAULT_AA_DETECTORS: [Detector; 4] = [Detector::Lauritzen, Detector::Depth, Detector::Normal, Detector::Id];

/// The shading-rate tile of the anti-aliasing table's `vrs:gbuffer` row.
pub const VRS_TILE: u32 = 16;

/// What [`pipelines`] measures with.
#[derive(Clone, Debug)]
pub struct PipelinesConfig {
    /// The deferred rows' edge detector.
    pub detector: Detector,
    /// Its thresholds.
    pub detector_config: DetectorConfig,
    /// The resolve's BRDF, falloff and tile size (culling and schedule are set per row).
    pub resolve: ResolveConfig,
    /// G-buffer bytes per sample of the deferred rows (a layout's size).
    pub gbuffer_bytes: u32,
    /// The layout those bytes come from (for the table).
    pub layout: String,
    /// Warp widths of the utilisation table.
    pub warps: Vec<u32>,
    /// FLIP's viewing conditions; `None`: no FLIP.
    pub viewing: Option<Viewing>,
    /// Detectors of the anti-aliasing comparison's adaptive MSAA rows.
    pub aa_detectors: Vec<Detector>,
    /// MLAA's settings.
    pub mlaa: MlaaConfig,
    /// The analytic scene the dump was rendered from, when known (`gbuf scene`, the demo): the visibility buffer's
    /// attributes are then re-materialised from its triangles and compared with the G-buffer.
    pub geometry: Option<SceneName>,
    /// The visibility buffer's layout (IDs + depth, e.g. the built-in `visibility-8`): its bytes per sample set the
    /// row's footprint and traffic, and the frame is packed and unpacked with it to check its IDs and depth survive.
    pub visibility_layout: Layout,
    /// Surface slots per pixel of the streaming-compression rows ([`crate::analysis::compress`]); `None`: 1 to 4
    /// and the sample count (`default_slots`); empty: no compressed rows (nor the aggregates row).
    pub compression_slots: Option<Vec<u32>>,
}

/// The slot counts the compressed-G-buffer rows try by default: 1 to 4 (Kerzner & Salvi keep 3 at 8×) and the
/// sample count, at most the sample count.
#[must_use]
fn default_slots(samples: u32) -> Vec<u32> {
    let mut k: Vec<u32> = (1..=4).filter(|&k| k <= samples).collect();
    if !k.contains(&samples) {
        k.push(samples);
    }
    k
}

/// The frame's MSAA G-buffer compressed into `slots` surface slots per pixel (Kerzner & Salvi 2014's streaming
/// compression, [`crate::analysis::compress`]) and lit from them, against the every-sample reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompressedRow {
    /// Kerzner & Salvi's streaming slots, or AGAA-style aggregates.
    pub method: Method,
    /// Surface slots (or aggregates) per pixel.
    pub slots: u32,
    /// How the pixels' fragments were rebuilt from the dump.
    pub fragments_from: FragmentKey,
    /// Bytes of one slot (the layout's fields and the coverage word).
    pub slot_bytes: u32,
    /// Bytes per pixel compressed (slots and bookkeeping) and of the full MSAA G-buffer.
    pub bytes_per_pixel: u32,
    /// Bytes per pixel of the full MSAA G-buffer of the same layout.
    pub full_bytes_per_pixel: u32,
    /// The compressed G-buffer in MB.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub footprint_mb: f64,
    /// Shading evaluations: one per slot in use.
    pub evaluations: u64,
    /// Pixels by slots in use (0..=slots).
    pub slot_histogram: Vec<u64>,
    /// Fragments merged into a slot.
    pub merges: u64,
    /// Covered samples whose fragment was evicted, as a fraction of the covered samples.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub evicted_fraction: f64,
    /// Pixels that evicted a fragment.
    pub discarded_pixels: u64,
    /// CPU time: compressing and lighting, ms.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub ms: f64,
    /// Error against the reference.
    pub error: ErrorSet,
}

/// The visibility buffer's layout packed and unpacked on the frame: does it keep what re-materialisation needs?
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VisibilityPacking {
    /// The layout's name.
    pub layout: String,
    /// Its bytes per sample.
    pub bytes: u32,
    /// Covered samples whose triangle ID changed (saturated: more triangles than the field holds).
    pub primitive_id_mismatches: u64,
    /// Covered samples whose instance (object) ID changed.
    pub object_id_mismatches: u64,
    /// Largest relative depth error over covered samples.
    pub depth_max_rel_error: f64,
    /// Attributes the layout must hold for re-materialisation that the dump has but the layout does not store.
    pub missing: Vec<String>,
}

/// One MSAA schedule run by the resolve on the CPU (tiled culling, the deferred rows' mask).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScheduleRun {
    /// The schedule.
    pub schedule: MsaaSchedule,
    /// Wall time of the resolve, ms.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub ms: f64,
    /// Shading evaluations.
    pub evaluations: u64,
    /// Lane steps run through the kernel, idle lanes included.
    pub lane_steps: u64,
    /// Light-sample pairs tested.
    pub light_pairs: u64,
    /// Bytes of G-buffer samples read (evaluations × the layout's bytes per sample).
    pub bytes_read: u64,
    /// Is the image bit-identical to the packed schedule's?
    pub same_image: bool,
}

/// One way to anti-alias the frame, against the every-sample reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AaRow {
    /// `no-aa`, `mlaa`, `msaa:<detector>` or `ssaa`.
    pub method: String,
    /// Shading evaluations.
    pub evaluations: u64,
    /// G-buffer (and post-process buffers) in MB at the deferred rows' bytes per sample.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub footprint_mb: f64,
    /// CPU time: the resolve, plus MLAA's pass for `mlaa`, ms.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub ms: f64,
    /// Error against the reference.
    pub error: ErrorSet,
    /// What the image stands on (for `no-aa` and `mlaa`: a 1-sample render at pixel centres, or sample 0 of the
    /// MSAA dump, off the centre).
    #[serde(default)]
    pub note: String,
}

/// One pipeline's row.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PipelineRow {
    /// The pipeline.
    pub pipeline: Pipeline,
    /// Render-target memory in MB (G-buffer or MSAA colour + depth, light or fragment lists, output).
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub footprint_mb: f64,
    /// Modelled traffic in MB per frame ([`Pipeline::traffic_model`]).
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub bandwidth_mb: f64,
    /// Shading work: fragment-shader lanes (forward, visibility buffer: helpers included) or shading evaluations
    /// (deferred).
    pub shading: u64,
    /// `lanes` or `evaluations`.
    pub shading_unit: String,
    /// Light-fragment pairs evaluated.
    pub light_pairs: u64,
    /// Useful lanes over issued lanes (forward: covered over all quad lanes; deferred: the packed schedule at the
    /// first warp width).
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub utilisation: f64,
    /// CPU time of gbuf's resolve running this pipeline, ms (deferred rows only).
    pub cpu_ms: Option<f64>,
    /// Image error against the every-sample reference.
    pub error: Option<ErrorSet>,
    /// Estimated rather than counted (forward without MSAA from an MSAA dump).
    pub estimated: bool,
    /// What this row stands on, or why it has no numbers.
    pub note: String,
}

/// The comparison on one frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pipelines {
    /// Width, height, samples.
    pub size: (u32, u32, u32),
    /// Lights.
    pub lights: usize,
    /// The deferred rows' detector.
    pub detector: Detector,
    /// The deferred rows' layout and its bytes per sample.
    pub layout: String,
    /// Bytes per sample of that layout.
    pub gbuffer_bytes: u32,
    /// One row per pipeline that could be measured.
    pub rows: Vec<PipelineRow>,
    /// Pipelines left out, with the reason.
    pub skipped: Vec<(Pipeline, String)>,
    /// Forward MSAA at quad granularity (needs primitive IDs).
    pub forward_msaa: Option<QuadShading>,
    /// Forward without MSAA.
    pub forward: Option<QuadShading>,
    /// The visibility buffer's fragment lists.
    pub fragment_lists: Option<FragmentLists>,
    /// Light-list bytes of forward+ (per tile: a 4-byte index per light, 8 bytes of offset and count).
    pub light_list_bytes: u64,
    /// Utilisation of each MSAA schedule at each warp width, on the deferred detector's mask.
    pub utilisation: Vec<Utilisation>,
    /// The MSAA schedules timed on the CPU.
    pub schedules: Vec<ScheduleRun>,
    /// The anti-aliasing comparison: no AA, MLAA on the no-AA image, adaptive MSAA per detector, SSAA.
    pub aa: Vec<AaRow>,
    /// What MLAA found on the no-AA image.
    pub mlaa: MlaaStats,
    /// The visibility buffer's re-materialisation from the scene's triangles ([`PipelinesConfig::geometry`]).
    #[serde(default)]
    pub rematerialised: Option<Rematerialised>,
    /// Why it was not done, when geometry was given but re-materialisation failed.
    #[serde(default)]
    pub rematerialise_error: Option<String>,
    /// The visibility buffer's layout packed and unpacked on this frame (needs primitive IDs).
    #[serde(default)]
    pub visibility_packing: Option<VisibilityPacking>,
    /// The compressed-G-buffer rows, one per slot count.
    #[serde(default)]
    pub compressed: Vec<CompressedRow>,
    /// The rectangle `(x, y, width, height)` of the anti-aliasing pictures: at most [`AA_CROP`] pixels where the
    /// no-AA image differs most from the reference ([`aa_crop`]); not serialised.
    #[serde(skip)]
    pub aa_crop: (u32, u32, u32, u32),
    /// That rectangle of each image of [`Pipelines::aa`] (same order), for pictures: the whole images (25 MB each
    /// at 1080p) are dropped once measured; not serialised.
    #[serde(skip)]
    pub aa_images: Vec<HdrImage>,
}

/// Size of the anti-aliasing crop in image pixels (smaller images are shown whole).
pub const AA_CROP: (u32, u32) = (64, 40);

/// The crop `(x, y, width, height)` of at most [`AA_CROP`] pixels where `image` differs most from `reference` (sum of
/// the differences of MLAA's display-encoded luma, [`crate::image::mlaa::display_luma`], non-finite as 0; the first
/// such window in reading order). Images of another size than the reference give the top-left corner.
#[must_use]
pub fn aa_crop(image: &HdrImage, reference: &HdrImage) -> (u32, u32, u32, u32) {
    use crate::image::mlaa::display_luma;
    let (w, h) = (reference.width, reference.height);
    let (cw, ch) = (AA_CROP.0.min(w), AA_CROP.1.min(h));
    if (image.width, image.height) != (w, h) || image.rgb.len() != reference.rgb.len() {
        return (0, 0, cw, ch);
    }
    let diff: Vec<f32> =
        image.rgb.iter().zip(&reference.rgb).map(|(&a, &b)| (display_luma(a) - display_luma(b)).abs()).collect();
    let (x, y) = crate::base::picture::busiest_window(&diff, w, h, cw, ch);
    (x, y, cw, ch)
}

/// `bytes` as B, kB or MB.
fn fmt_bytes(bytes: u64) -> String {
    match bytes {
        b if b < 10_000 => format!("{b} B"),
        b if b < 10_000_000 => format!("{:.1} kB", b as f64 / 1e3),
        b => format!("{:.1} MB", b as f64 / 1e6),
    }
}

/// Each MSAA schedule run by the tiled resolve on `mask` (the packed schedule's run reused from `tiled` when the
/// caller has it), with its work and whether its image equals the first schedule's.
fn schedule_runs(
    gb: &GBuffer,
    lights: &[Light],
    mask: &EdgeMask,
    resolve_cfg: &ResolveConfig,
    tiled: Option<&Tiled>,
    gbuffer_bytes: u32,
) -> Result<Vec<ScheduleRun>> {
    let mut schedules: Vec<ScheduleRun> = Vec::new();
    let mut first_image: Option<Arc<HdrImage>> = None;
    for sched in MsaaSchedule::ALL {
        let (image, stats, ms) = match (tiled, sched) {
            (Some(t), MsaaSchedule::Packed) => (Arc::clone(&t.image.image), t.stats.clone(), t.ms),
            _ => {
                let rc = ResolveConfig {
                    culling: Culling::Tiled,
                    schedule: Schedule::Deferred,
                    msaa: sched,
                    ..*resolve_cfg
                };
                let t = Instant::now();
                let r = resolve::resolve(gb, lights, mask, &rc)?;
                (Arc::new(r.image), r.stats, t.elapsed().as_secs_f64() * 1e3)
            }
        };
        let same_image = first_image.as_ref().is_none_or(|p| p.rgb == image.rgb);
        schedules.push(ScheduleRun {
            schedule: sched,
            ms,
            evaluations: stats.shading_evaluations,
            lane_steps: stats.lane_steps,
            light_pairs: stats.light_pairs_tested,
            bytes_read: stats.shading_evaluations * u64::from(gbuffer_bytes),
            same_image,
        });
        if first_image.is_none() {
            first_image = Some(image);
        }
    }
    Ok(schedules)
}

/// Lights surviving each tile's culling, row-major over tiles: from a tiled resolve shading one sample per pixel,
/// where each pixel's light tests are its tile's list length.
fn tile_light_counts(heat: &[u32], width: u32, height: u32, ts: u32) -> Vec<u32> {
    let tx = width.div_ceil(ts);
    let mut counts = vec![0u32; (tx * height.div_ceil(ts)) as usize];
    for (p, &h) in heat.iter().enumerate() {
        let (x, y) = (p as u32 % width, p as u32 / width);
        let t = &mut counts[((y / ts) * tx + x / ts) as usize];
        *t = (*t).max(h);
    }
    counts
}

/// Pixels whose coverage may differ between an MSAA frame and its 1-sample render before they are taken for two
/// different frames: a centre sample can miss a triangle all MSAA samples see only on sub-pixel features.
pub const SINGLE_COVERAGE_MISMATCH_MAX: f64 = 0.02;

/// Checks that `one` can stand for `gb`'s frame rendered with 1 sample at pixel centres: same size, one sample, the
/// same camera when both have one, and coverage agreeing on all but [`SINGLE_COVERAGE_MISMATCH_MAX`] of the pixels
/// (covered at the centre but by no MSAA sample, or the other way round).
pub fn check_single(gb: &GBuffer, one: &GBuffer) -> Result<()> {
    if (one.width, one.height) != (gb.width, gb.height) || one.samples != 1 {
        return Err(Error::Mismatch(format!(
            "the 1-sample render is {}×{} × {} samples; it must be {}×{} × 1 (the same frame at pixel centres)",
            one.width, one.height, one.samples, gb.width, gb.height
        )));
    }
    if let (Some(a), Some(b)) = (&gb.camera, &one.camera) {
        if a != b {
            return Err(Error::Mismatch("the 1-sample render has another camera than the MSAA frame".into()));
        }
    }
    let covered = detect::covered_per_pixel(gb);
    let mismatched = (0..one.len()).filter(|&p| (covered[p] > 0) != one.coverage[p]).count();
    let fraction = mismatched as f64 / one.len().max(1) as f64;
    if fraction > SINGLE_COVERAGE_MISMATCH_MAX {
        return Err(Error::Mismatch(format!(
            "the 1-sample render does not look like the same frame: {mismatched} of {} pixels ({:.1}%) are covered in \
             one and empty in the other (at most {:.0}% allowed)",
            one.len(),
            100.0 * fraction,
            100.0 * SINGLE_COVERAGE_MISMATCH_MAX
        )));
    }
    Ok(())
}

/// Which row an image's FLIP goes to.
#[derive(Clone, Copy, Debug, PartialEq)]
enum FlipSlot {
    Row(Pipeline),
    Aa(usize),
    Compressed(usize),
}

/// An image whose FLIP against the pipelines' reference (with the same viewing conditions) the caller has already
/// computed: the report's sweep lights the exact G-buffer with each detector, the images of the pipelines' adaptive
/// MSAA rows. An image of the pipelines equal to it bit for bit takes these numbers instead of a FLIP of its own.
#[derive(Clone, Copy, Debug)]
pub struct KnownFlip<'a> {
    /// The image.
    pub image: &'a HdrImage,
    /// Its mean LDR-FLIP against the reference.
    pub ldr: f64,
    /// Its mean HDR-FLIP against the reference.
    pub hdr: f64,
}

/// Where a row's FLIP comes from: the batch's `n`th distinct image, or the caller's `n`th known FLIP.
#[derive(Clone, Copy, Debug)]
enum FlipKey {
    New(usize),
    Known(usize),
}

/// The images whose FLIP against the reference the pipelines need, each distinct image once, and the rows that
/// want each: computed in batches (the reference filtered once per batch), one when the caller flushes and one at
/// the end. Images equal to a known one are not computed again; an image equal to one an earlier batch measured is
/// measured again (the same numbers: only time).
struct FlipBatch<'a> {
    known: &'a [KnownFlip<'a>],
    images: std::cell::RefCell<Vec<Held>>,
    wants: std::cell::RefCell<Vec<(FlipSlot, Option<FlipKey>)>>,
}

/// A distinct image of a [`FlipBatch`]: waiting for its batch, or measured (its mean LDR- and HDR-FLIP, `None` when
/// they could not be computed) and let go.
enum Held {
    Waiting(Arc<HdrImage>),
    Measured(Option<(f64, f64)>),
}

/// An image a stage made, shared with the FLIP batch when the batch keeps it (no copy), and where its FLIP comes
/// from (`None`: FLIP not wanted).
#[derive(Clone)]
struct Shared {
    image: Arc<HdrImage>,
    key: Option<FlipKey>,
}

impl<'a> FlipBatch<'a> {
    fn new(known: &'a [KnownFlip<'a>]) -> Self {
        FlipBatch { known, images: Default::default(), wants: Default::default() }
    }

    /// `img` with where its FLIP comes from: a new distinct image is kept (shared, not copied); one equal to an
    /// image the batch holds is dropped for that one; one equal to a known image keeps its known numbers.
    fn share(&self, img: HdrImage, wanted: bool) -> Shared {
        if !wanted {
            return Shared { image: Arc::new(img), key: None };
        }
        let same = |m: &HdrImage| m.width == img.width && m.height == img.height && m.rgb == img.rgb;
        if let Some(k) = self.known.iter().position(|k| same(k.image)) {
            return Shared { image: Arc::new(img), key: Some(FlipKey::Known(k)) };
        }
        let mut images = self.images.borrow_mut();
        let waiting = images.iter().enumerate().find_map(|(k, m)| match m {
            Held::Waiting(m) if same(m) => Some((k, Arc::clone(m))),
            _ => None,
        });
        if let Some((k, image)) = waiting {
            return Shared { image, key: Some(FlipKey::New(k)) };
        }
        let image = Arc::new(img);
        images.push(Held::Waiting(Arc::clone(&image)));
        Shared { image, key: Some(FlipKey::New(images.len() - 1)) }
    }

    /// Row `slot` gets the FLIP of `img`.
    fn wants(&self, slot: FlipSlot, img: &Shared) {
        self.wants.borrow_mut().push((slot, img.key));
    }

    /// Measures the waiting images in one batch and lets them go (the batch's share of them: a stage may still hold
    /// its own).
    fn flush(&self, reference: &HdrImage, viewing: &Viewing) {
        let mut images = self.images.borrow_mut();
        let waiting: Vec<(usize, Arc<HdrImage>)> = images
            .iter()
            .enumerate()
            .filter_map(|(k, m)| match m {
                Held::Waiting(m) => Some((k, Arc::clone(m))),
                Held::Measured(_) => None,
            })
            .collect();
        if waiting.is_empty() {
            return;
        }
        let tests: Vec<&HdrImage> = waiting.iter().map(|(_, m)| &**m).collect();
        let results = flip_means(reference, &tests, viewing);
        for ((k, _), flip) in waiting.iter().zip(results) {
            images[*k] = Held::Measured(flip);
        }
    }

    /// Computes the FLIPs not yet measured and writes them all into the rows' error sets.
    fn fill(
        self,
        reference: &HdrImage,
        viewing: &Viewing,
        rows: &mut [PipelineRow],
        aa: &mut [AaRow],
        compressed: &mut [CompressedRow],
    ) {
        self.flush(reference, viewing);
        let results: Vec<Option<(f64, f64)>> = self
            .images
            .into_inner()
            .into_iter()
            .map(|m| match m {
                Held::Measured(flip) => flip,
                Held::Waiting(_) => unreachable!("flushed above"),
            })
            .collect();
        for (slot, key) in self.wants.into_inner() {
            let flip = match key {
                Some(FlipKey::New(k)) => results[k],
                Some(FlipKey::Known(k)) => Some((self.known[k].ldr, self.known[k].hdr)),
                None => None,
            };
            let Some((ldr, hdr)) = flip else { continue };
            let error = match slot {
                FlipSlot::Row(p) => rows.iter_mut().find(|r| r.pipeline == p).and_then(|r| r.error.as_mut()),
                FlipSlot::Aa(i) => aa.get_mut(i).map(|r| &mut r.error),
                FlipSlot::Compressed(i) => compressed.get_mut(i).map(|r| &mut r.error),
            };
            if let Some(e) = error {
                e.flip_ldr = Some(ldr);
                e.flip_hdr = Some(hdr);
            }
        }
    }
}

/// Measures every pipeline on `gb` lit by `lights`; `reference` is the every-sample reference image when the caller
/// has it (else it is computed). `single`, the same frame rendered with 1 sample at pixel centres, is the no-AA
/// image MLAA works on and gives the forward row's exact quads; without it sample 0 stands in (an estimate, flagged
/// in the notes).
pub fn pipelines(
    gb: &GBuffer,
    lights: &[Light],
    cfg: &PipelinesConfig,
    reference: Option<&HdrImage>,
    single: Option<&GBuffer>,
) -> Result<Pipelines> {
    pipelines_with(gb, lights, cfg, reference, single, &[])
}

/// [`pipelines`], with FLIPs the caller has already computed against `reference` under `cfg.viewing` (the report's
/// exact images per detector): an image equal to a known one bit for bit takes its numbers instead of being
/// compared again.
pub fn pipelines_with(
    gb: &GBuffer,
    lights: &[Light],
    cfg: &PipelinesConfig,
    reference: Option<&HdrImage>,
    single: Option<&GBuffer>,
    known: &[KnownFlip<'_>],
) -> Result<Pipelines> {
    let (w, h, s) = (gb.width, gb.height, gb.samples);
    if let Some(one) = single {
        check_single(gb, one)?;
    }
    let computed;
    let computed_reference = reference.is_none();
    let reference = match reference {
        Some(r) => r,
        None => {
            computed = resolve::reference(gb, lights, &cfg.resolve)?;
            &computed
        }
    };
    // Numerical errors as each image is made; FLIP at the end, once per distinct image and in one batch against the
    // reference (several rows share an image: forward MSAA, forward+ and the visibility buffer; the deferred
    // schedules). Known FLIPs are against the caller's reference: none apply to one computed here.
    let m = Measure { gb, lights, cfg, reference, flips: FlipBatch::new(if computed_reference { &[] } else { known }) };

    let no_aa = m.no_aa(single)?;
    let mut rows = Vec::new();
    let mut skipped = Vec::new();
    let forward = m.forward_rows(single, &no_aa, &mut rows, &mut skipped)?;
    let mask = detect::detect(gb, cfg.detector, &cfg.detector_config)?;
    let tiled = m.deferred_rows(&mask, &mut rows)?;
    if rows.is_empty() {
        return Err(Error::Implausible("no pipeline could be measured".into()));
    }
    let b = cfg.gbuffer_bytes;
    let schedules = schedule_runs(gb, lights, &mask, &cfg.resolve, tiled.as_ref(), b)?;
    let mut utilisation = Vec::new();
    for &warp in &cfg.warps {
        for sched in MsaaSchedule::ALL {
            utilisation.push(forward::utilisation(&mask, sched, warp, cfg.resolve.tile_size));
        }
    }
    rows.sort_by_key(|r| Pipeline::ALL.iter().position(|&p| p == r.pipeline));
    let (mut aa, aa_images, mlaa_stats) = m.aa_rows(no_aa, tiled)?;
    // Only the crop of each image is kept for the pictures, cut now: an image the FLIP batch does not hold (one whose
    // FLIP is known) is freed before the compressed rows and the batch, the others with the batch.
    let aa_crop = aa_images.first().map_or((0, 0, 0, 0), |no_aa| aa_crop(no_aa, reference));
    let aa_images: Vec<HdrImage> = aa_images
        .into_iter()
        .map(|i| if (i.width, i.height) == (w, h) { i.crop(aa_crop) } else { HdrImage::new(0, 0) })
        .collect();
    // The images so far are measured before the compressed rows make theirs: one batch of all of them was the
    // report's peak memory (each 25 MB at 1080p), for one more filtering of the reference.
    if let Some(v) = cfg.viewing.as_ref() {
        m.flips.flush(reference, v);
    }
    let mut compressed = m.compressed_rows()?;
    let Measure { flips, .. } = m;
    match cfg.viewing.as_ref() {
        Some(v) => flips.fill(reference, v, &mut rows, &mut aa, &mut compressed),
        None => drop(flips),
    }
    let (rematerialised, rematerialise_error) = match cfg.geometry {
        Some(name) => match rematerialise(name, gb) {
            Ok(r) => (Some(r), None),
            Err(e) => (None, Some(e.to_string())),
        },
        None => (None, None),
    };
    let visibility_packing = match gb.primitive_id {
        Some(_) => Some(visibility_packing(gb, &cfg.visibility_layout)?),
        None => None,
    };
    Ok(Pipelines {
        size: (w, h, s),
        lights: lights.len(),
        detector: cfg.detector,
        layout: cfg.layout.clone(),
        gbuffer_bytes: b,
        rows,
        skipped,
        forward_msaa: forward.msaa,
        forward: forward.one,
        fragment_lists: forward.lists,
        light_list_bytes: forward.light_list_bytes,
        utilisation,
        schedules,
        aa,
        mlaa: mlaa_stats,
        rematerialised,
        rematerialise_error,
        visibility_packing,
        compressed,
        aa_crop,
        aa_images,
    })
}

/// What every stage of [`pipelines_with`] reads: the frame, its lights and configuration, the reference, and the
/// batch of FLIPs the stages add their images to.
struct Measure<'a> {
    gb: &'a GBuffer,
    lights: &'a [Light],
    cfg: &'a PipelinesConfig,
    reference: &'a HdrImage,
    flips: FlipBatch<'a>,
}

/// The no-AA image: one sample per pixel through the tiled resolve (its image moved to `image`), the time it took,
/// and where its samples come from.
struct NoAa {
    resolved: resolve::Resolved,
    image: Shared,
    ms: f64,
    note: &'static str,
}

/// The tiled deferred run with the packed MSAA schedule: the schedules and the detector's anti-aliasing row are it.
struct Tiled {
    image: Shared,
    stats: resolve::ResolveStats,
    ms: f64,
}

/// The forward rows' measurements, kept in [`Pipelines`] (each `None` when the G-buffer cannot give it).
struct ForwardParts {
    msaa: Option<QuadShading>,
    one: Option<QuadShading>,
    lists: Option<FragmentLists>,
    light_list_bytes: u64,
}

impl Measure<'_> {
    /// The numerical errors of `img` against the reference (FLIP comes later, from the batch).
    fn err(&self, img: &HdrImage) -> ErrorSet {
        error_set(self.reference, img, None)
    }

    /// `img`, handed to the FLIP batch (kept there without a copy when FLIP is wanted).
    fn share(&self, img: HdrImage) -> Shared {
        self.flips.share(img, self.cfg.viewing.is_some())
    }

    /// Row `slot` gets the FLIP of `img`.
    fn flip(&self, slot: FlipSlot, img: &Shared) {
        self.flips.wants(slot, img);
    }

    /// Lights `gb` with `mask` under `culling` and `schedule`, timed in milliseconds.
    fn run(&self, mask: &EdgeMask, culling: Culling, schedule: Schedule) -> Result<(resolve::Resolved, f64)> {
        let rc = ResolveConfig { culling, schedule, ..self.cfg.resolve };
        let t = Instant::now();
        let r = resolve::resolve(self.gb, self.lights, mask, &rc)?;
        Ok((r, t.elapsed().as_secs_f64() * 1e3))
    }

    /// One sample per pixel through the tiled resolve: `single` when given, else every pixel's sample 0.
    fn no_aa(&self, single: Option<&GBuffer>) -> Result<NoAa> {
        let cfg = self.cfg;
        let (mut resolved, ms) = match single {
            Some(one) => {
                let none = detect::detect(one, Detector::None, &cfg.detector_config)?;
                let rc = ResolveConfig { culling: Culling::Tiled, schedule: Schedule::Deferred, ..cfg.resolve };
                let t = Instant::now();
                let r = resolve::resolve(one, self.lights, &none, &rc)?;
                (r, t.elapsed().as_secs_f64() * 1e3)
            }
            None => {
                let none = detect::detect(self.gb, Detector::None, &cfg.detector_config)?;
                self.run(&none, Culling::Tiled, Schedule::Deferred)?
            }
        };
        let note = if single.is_some() {
            "the 1-sample render at pixel centres"
        } else if self.gb.samples > 1 {
            "sample 0 of the MSAA dump, off the pixel centre (estimate: MLAA's reconstruction assumes centred samples)"
        } else {
            "the 1-sample dump"
        };
        let image = self.share(std::mem::take(&mut resolved.image));
        Ok(NoAa { resolved, image, ms, note })
    }

    /// The forward, forward MSAA, forward+ and visibility-buffer rows (skipped, with the reason, without primitive
    /// IDs).
    fn forward_rows(
        &self,
        single: Option<&GBuffer>,
        no_aa: &NoAa,
        rows: &mut Vec<PipelineRow>,
        skipped: &mut Vec<(Pipeline, String)>,
    ) -> Result<ForwardParts> {
        let (gb, cfg) = (self.gb, self.cfg);
        let (w, h, s) = (gb.width, gb.height, gb.samples);
        let pixels = f64::from(w) * f64::from(h);
        let n_lights = self.lights.len() as u64;
        let ts = cfg.resolve.tile_size;
        let tile_lights = tile_light_counts(&no_aa.resolved.lights_per_pixel, w, h, ts);
        let list_entries: u64 = tile_lights.iter().map(|&c| u64::from(c)).sum();
        let light_list_bytes = 4 * list_entries + 8 * tile_lights.len() as u64;
        let tile_of = |p: usize| {
            let (x, y) = (p as u32 % w, p as u32 / w);
            ((y / ts) * w.div_ceil(ts) + x / ts) as usize
        };
        // Light pairs of forward+ and the visibility buffer: each lane tests its tile's list.
        let tiled_pairs = |q: &QuadShading| -> u64 {
            q.lanes_per_pixel.iter().enumerate().map(|(p, &n)| u64::from(n) * u64::from(tile_lights[tile_of(p)])).sum()
        };
        let fwd_msaa = forward::forward_quads(gb, ForwardSamples::Msaa);
        let fwd_one = forward::forward_quads(single.unwrap_or(gb), ForwardSamples::Single { sample: 0 });
        let lists = forward::fragment_lists(gb, ts);
        match (&fwd_msaa, &fwd_one, &lists) {
            (Ok(fm), Ok(f1), Ok(fl)) => {
                // Forward MSAA's image: one shade per (triangle, pixel), resolved by coverage. The resolve gives a
                // pixel shaded once its one sample's value whole, which would drop the background from silhouette
                // pixels; those (partly covered) are shaded per sample instead, so the box filter weighs them by
                // coverage as the MSAA resolve does. Their shading then varies per sample where forward MSAA
                // replicates one value: a small advantage to the forward rows' error on silhouettes, none to their
                // lane counts (those come from quads).
                let mut fm_mask = detect::detect(gb, Detector::ForwardMsaa, &cfg.detector_config)?;
                let all = s.min(u32::from(u8::MAX)) as u8;
                for (c, &n) in fm_mask.shade_count.iter_mut().zip(&detect::covered_per_pixel(gb)) {
                    if n > 0 && u32::from(n) < s {
                        *c = all;
                    }
                }
                let (msaa_img, _) = self.run(&fm_mask, Culling::Tiled, Schedule::Deferred)?;
                let msaa_err = self.err(&msaa_img.image);
                // One image for three rows: shared once (the batch compares each new image with those it holds).
                let msaa = self.share(msaa_img.image);
                for p in [Pipeline::ForwardMsaa, Pipeline::ForwardPlus, Pipeline::VisibilityBuffer] {
                    self.flip(FlipSlot::Row(p), &msaa);
                }
                self.flip(FlipSlot::Row(Pipeline::Forward), &no_aa.image);
                let util = |q: &QuadShading| if q.lanes > 0 { q.covered_lanes as f64 / q.lanes as f64 } else { 1.0 };
                let vb = cfg.visibility_layout.bytes_per_sample() as f64;
                let n = Counts {
                    pixels,
                    samples: f64::from(s),
                    covered: (gb.len() - gb.background_samples()) as f64,
                    covered_pixels: covered_pixels(gb),
                    bytes: f64::from(cfg.gbuffer_bytes),
                    light_pairs: None,
                    light_list_bytes: light_list_bytes as f64,
                    fragments: fl.entries as f64,
                    visibility_bytes: vb,
                };
                debug_assert_eq!(fl.bytes, 8 * fl.entries, "the footprint model's 8·F");
                let row = |pipeline: Pipeline, q: &QuadShading, pairs, error, note: String| PipelineRow {
                    pipeline,
                    footprint_mb: pipeline.footprint(&n).expect("every count is known") / 1e6,
                    bandwidth_mb: pipeline.traffic(&n).expect("every count is known") / 1e6,
                    shading: q.lanes,
                    shading_unit: "lanes".into(),
                    light_pairs: pairs,
                    utilisation: util(q),
                    cpu_ms: None,
                    error: Some(error),
                    estimated: q.estimated,
                    note,
                };
                let forward_note = if f1.estimated {
                    "one sample per pixel: sample 0 stands for the pixel centre (estimate)"
                } else if single.is_some() {
                    "quads of the 1-sample render"
                } else {
                    "quads of the single-sample dump"
                };
                rows.push(row(
                    Pipeline::Forward,
                    f1,
                    f1.lanes * n_lights,
                    self.err(&no_aa.image.image),
                    forward_note.into(),
                ));
                rows.push(row(
                    Pipeline::ForwardMsaa,
                    fm,
                    fm.lanes * n_lights,
                    msaa_err,
                    format!(
                        "{} quads of {} triangles, {:.0}% helper lanes",
                        fm.quads,
                        fm.triangles,
                        100.0 * fm.helper_fraction
                    ),
                ));
                rows.push(row(
                    Pipeline::ForwardPlus,
                    fm,
                    tiled_pairs(fm),
                    msaa_err,
                    format!(
                        "light lists {} ({list_entries} entries in {} tiles)",
                        fmt_bytes(light_list_bytes),
                        tile_lights.len()
                    ),
                ));
                let mut vis = row(
                    Pipeline::VisibilityBuffer,
                    fm,
                    tiled_pairs(fm),
                    msaa_err,
                    format!(
                        "{} ({} B); fragment lists {} entries, longest {} ({})",
                        cfg.visibility_layout.name(),
                        cfg.visibility_layout.bytes_per_sample(),
                        fl.entries,
                        fl.max_entries,
                        fmt_bytes(fl.bytes)
                    ),
                );
                vis.shading = 4 * fl.entries;
                rows.push(vis);
            }
            _ => {
                let why = fwd_msaa.as_ref().err().map_or_else(String::new, ToString::to_string);
                for p in [Pipeline::Forward, Pipeline::ForwardMsaa, Pipeline::ForwardPlus, Pipeline::VisibilityBuffer] {
                    skipped.push((p, why.clone()));
                }
            }
        }
        Ok(ForwardParts { msaa: fwd_msaa.ok(), one: fwd_one.ok(), lists: lists.ok(), light_list_bytes })
    }

    /// The deferred rows (quad lights, tiled, light pre-pass): `mask`, the chosen detector's, through the resolve.
    /// Returns the tiled deferred run when the packed MSAA schedule made it (the schedules and the detector's
    /// anti-aliasing row reuse it).
    fn deferred_rows(&self, mask: &EdgeMask, rows: &mut Vec<PipelineRow>) -> Result<Option<Tiled>> {
        let (gb, cfg) = (self.gb, self.cfg);
        let b = cfg.gbuffer_bytes;
        let ts = cfg.resolve.tile_size;
        let packed = forward::utilisation(mask, MsaaSchedule::Packed, cfg.warps.first().copied().unwrap_or(16), ts);
        let n = Counts {
            pixels: f64::from(gb.width) * f64::from(gb.height),
            samples: f64::from(gb.samples),
            covered: (gb.len() - gb.background_samples()) as f64,
            covered_pixels: covered_pixels(gb),
            bytes: f64::from(b),
            ..Counts::default()
        };
        let footprint = |p: Pipeline| p.footprint(&n).expect("every count is known");
        let mut tiled: Option<Tiled> = None;
        for (pipeline, culling, schedule) in [
            (Pipeline::DeferredQuad, Culling::Quad, Schedule::Deferred),
            (Pipeline::TiledDeferred, Culling::Tiled, Schedule::Deferred),
            (Pipeline::LightPrepass, Culling::Tiled, Schedule::LightPrepass),
        ] {
            let (mut r, ms) = self.run(mask, culling, schedule)?;
            let error = self.err(&r.image);
            let image = self.share(std::mem::take(&mut r.image));
            self.flip(FlipSlot::Row(pipeline), &image);
            if pipeline == Pipeline::TiledDeferred && cfg.resolve.msaa == MsaaSchedule::Packed {
                // The packed schedule's run and the detector's anti-aliasing row below are this resolve.
                tiled = Some(Tiled { image, stats: r.stats.clone(), ms });
            }
            let st = &r.stats;
            let (footprint, traffic, note) = match pipeline {
                Pipeline::DeferredQuad => (
                    footprint(pipeline),
                    bandwidth(gb, b, Some(st.light_pairs_tested)).quad.unwrap_or(f64::NAN) * 1e6,
                    format!("{} G-buffer, {} B/sample; lights as screen quads", cfg.layout, b),
                ),
                Pipeline::TiledDeferred => (
                    footprint(pipeline),
                    bandwidth(gb, b, None).tiled * 1e6,
                    format!("{} G-buffer, {} B/sample; light lists stay on chip", cfg.layout, b),
                ),
                _ => (
                    footprint(pipeline),
                    pipeline.traffic(&n).expect("every count is known"),
                    "depth + normal/power 8 B and light buffer RGBA16F 8 B per sample".into(),
                ),
            };
            rows.push(PipelineRow {
                pipeline,
                footprint_mb: footprint / 1e6,
                bandwidth_mb: traffic / 1e6,
                shading: st.shading_evaluations,
                shading_unit: "evaluations".into(),
                light_pairs: st.light_pairs_tested,
                utilisation: packed.ratio,
                cpu_ms: Some(ms),
                error: Some(error),
                estimated: false,
                note,
            });
        }
        Ok(tiled)
    }

    /// Anti-aliasing: the no-AA image, MLAA on it, adaptive MSAA with each detector, SSAA. Returns the rows, their
    /// images (in row order) and MLAA's statistics.
    fn aa_rows(&self, no_aa: NoAa, tiled: Option<Tiled>) -> Result<(Vec<AaRow>, Vec<Arc<HdrImage>>, MlaaStats)> {
        let (gb, cfg) = (self.gb, self.cfg);
        let (w, h, s) = (gb.width, gb.height, gb.samples);
        let pixels = f64::from(w) * f64::from(h);
        let gbuf_mb = |samples: u32| f64::from(cfg.gbuffer_bytes) * f64::from(samples) * pixels / 1e6;
        let mut aa = Vec::new();
        let mut aa_images = Vec::new();
        let t = Instant::now();
        let (smoothed, mlaa_stats) = mlaa(&no_aa.image.image.rgb, w, h, &cfg.mlaa);
        let mlaa_ms = t.elapsed().as_secs_f64() * 1e3;
        let smoothed = HdrImage { width: w, height: h, rgb: smoothed };
        let evals = no_aa.resolved.stats.shading_evaluations;
        self.flip(FlipSlot::Aa(aa.len()), &no_aa.image);
        aa.push(AaRow {
            method: "no-aa".into(),
            evaluations: evals,
            footprint_mb: gbuf_mb(1),
            ms: no_aa.ms,
            error: self.err(&no_aa.image.image),
            note: no_aa.note.into(),
        });
        // MLAA's buffers on a GPU: an RG8 edge texture and an RGBA8 blend-weight texture.
        let error = self.err(&smoothed);
        let smoothed = self.share(smoothed);
        self.flip(FlipSlot::Aa(aa.len()), &smoothed);
        aa.push(AaRow {
            method: "mlaa".into(),
            evaluations: evals,
            footprint_mb: gbuf_mb(1) + 6.0 * pixels / 1e6,
            ms: no_aa.ms + mlaa_ms,
            error,
            note: format!("on {}", no_aa.note),
        });
        aa_images.push(no_aa.image.image);
        aa_images.push(smoothed.image);
        let mut methods: Vec<(String, Detector)> = cfg.aa_detectors.iter().map(|&d| (format!("msaa:{d}"), d)).collect();
        methods.push(("ssaa".into(), Detector::Ssaa));
        for (method, d) in methods {
            let (image, evaluations, ms) = match &tiled {
                Some(t) if d == cfg.detector => (t.image.clone(), t.stats.shading_evaluations, t.ms),
                _ => {
                    let Ok(m) = detect::detect(gb, d, &cfg.detector_config) else { continue };
                    let (r, ms) = self.run(&m, Culling::Tiled, Schedule::Deferred)?;
                    (self.share(r.image), r.stats.shading_evaluations, ms)
                }
            };
            self.flip(FlipSlot::Aa(aa.len()), &image);
            aa.push(AaRow {
                method,
                evaluations,
                footprint_mb: gbuf_mb(s),
                ms,
                error: self.err(&image.image),
                note: String::new(),
            });
            aa_images.push(image.image);
        }
        // Shading less than once per pixel where the G-buffer allows: gbuf's shading-rate image over the deferred
        // detector's adaptive MSAA (coarse pixels never cross a resolve tile of an even size).
        if cfg.resolve.tile_size.is_multiple_of(2) {
            let mask = detect::detect(gb, cfg.detector, &cfg.detector_config)?;
            let tone = cfg.viewing.as_ref().map_or_else(Default::default, Viewing::tone);
            let preview = resolve::LightPreview::new(gb, self.lights, cfg.resolve.falloff, cfg.resolve.brdf, tone)?;
            let sri =
                crate::detect::rate::gbuffer_sri(gb, Some(&preview), &mask, VRS_TILE, false, &Default::default())?;
            let rc = ResolveConfig { culling: Culling::Tiled, schedule: Schedule::Deferred, ..cfg.resolve };
            let coarse = resolve::Coarse { sri: &sri, mode: crate::detect::rate::CoarseMode::Broadcast };
            let t = Instant::now();
            let r = resolve::resolve_coarse(gb, self.lights, &mask, coarse, &rc)?;
            let ms = t.elapsed().as_secs_f64() * 1e3;
            let image = self.share(r.image);
            self.flip(FlipSlot::Aa(aa.len()), &image);
            let rates = sri.histogram();
            aa.push(AaRow {
                method: format!("vrs:gbuffer+msaa:{}", cfg.detector),
                evaluations: r.stats.shading_evaluations,
                // The SRI: one byte per tile.
                footprint_mb: gbuf_mb(s) + sri.rates.len() as f64 / 1e6,
                ms,
                error: self.err(&image.image),
                note: format!(
                    "gbuf's shading-rate image, tile {VRS_TILE}, {:.0}% of tiles coarser than 1×1",
                    100.0 * (1.0 - rates[0] as f64 / sri.rates.len().max(1) as f64)
                ),
            });
            aa_images.push(image.image);
        }
        Ok((aa, aa_images, mlaa_stats))
    }
}

impl Measure<'_> {
    /// The compressed-G-buffer rows: the frame compressed into each slot count (merging as Kerzner & Salvi do) and
    /// lit from the slots, then into 2 AGAA-style aggregates. None when the frame has one sample per pixel (nothing to
    /// compress).
    fn compressed_rows(&self) -> Result<Vec<CompressedRow>> {
        let (gb, cfg) = (self.gb, self.cfg);
        if gb.samples < 2 {
            return Ok(Vec::new());
        }
        let slots = cfg.compression_slots.clone().unwrap_or_else(|| default_slots(gb.samples));
        if slots.is_empty() {
            return Ok(Vec::new());
        }
        let covered = (gb.len() - gb.background_samples()) as f64;
        let pixels = f64::from(gb.width) * f64::from(gb.height);
        let rc = ResolveConfig { culling: Culling::Tiled, schedule: Schedule::Deferred, ..cfg.resolve };
        let mut rows = Vec::new();
        let runs = slots.iter().map(|&k| (Method::Streaming, k)).chain(
            // AGAA's configuration: 2 aggregates per pixel.
            (gb.samples >= 2).then_some((Method::Aggregate, 2)),
        );
        // Positions, depth and slopes, derived once for every row (not part of a row's time: a renderer has them).
        let frame = CompressFrame::new(gb)?;
        for (method, k) in runs {
            let t = Instant::now();
            let slots = StreamingConfig { slots: k, merge: true };
            let mut lit = light_compressed(&frame, method, &slots, self.lights, &rc, STRIP_ROWS)?;
            let ms = t.elapsed().as_secs_f64() * 1e3;
            let f = footprint(cfg.gbuffer_bytes, gb.samples, k);
            let error = self.err(&lit.image);
            self.flip(FlipSlot::Compressed(rows.len()), &self.share(std::mem::take(&mut lit.image)));
            rows.push(CompressedRow {
                method,
                slots: k,
                fragments_from: lit.key,
                slot_bytes: f.slot_bytes,
                bytes_per_pixel: f.compressed_bytes_per_pixel,
                full_bytes_per_pixel: f.full_bytes_per_pixel,
                footprint_mb: f64::from(f.compressed_bytes_per_pixel) * pixels / 1e6,
                evaluations: lit.evaluations,
                slot_histogram: lit.slot_histogram,
                merges: lit.merges,
                evicted_fraction: if covered > 0.0 { lit.evicted_samples as f64 / covered } else { 0.0 },
                discarded_pixels: lit.discarded_pixels,
                ms,
                error,
            });
        }
        Ok(rows)
    }
}

/// Pixels with at least one covered sample.
fn covered_pixels(gb: &GBuffer) -> f64 {
    detect::covered_per_pixel(gb).iter().filter(|&&c| c > 0).count() as f64
}

/// Packs and unpacks `gb` with the visibility buffer's `layout` and counts what changed in what re-materialisation
/// reads: triangle and instance IDs (exact or not) and depth.
pub fn visibility_packing(gb: &GBuffer, layout: &Layout) -> Result<VisibilityPacking> {
    use crate::gbuffer::Attribute;
    use rayon::prelude::*;
    /// What the bands find: ID mismatches, the largest relative depth error, and which of depth, primitive and
    /// object IDs every decoded band holds.
    #[derive(Default)]
    struct Found {
        primitive: u64,
        object: u64,
        depth: f64,
        kept: [bool; 3],
    }
    // Packed and decoded band by band: neither the packed frame nor its decoded planes are ever held whole (the
    // packed frame was the report's largest allocation at its end).
    let only = [Attribute::Depth, Attribute::PrimitiveId, Attribute::ObjectId];
    let row = gb.width as usize * gb.samples as usize;
    let mut total = Found { kept: [true; 3], ..Found::default() };
    layout.each_roundtrip_band(gb, 1, Some(&only), |rows, band| {
        let range = rows.start as usize * row..rows.end as usize * row;
        let covered = || range.clone().into_par_iter().filter(|&i| gb.coverage[i]);
        let mismatches = |a: Option<&Vec<u32>>, b: Option<&Vec<u32>>| match (a, b) {
            (Some(a), Some(b)) => covered().filter(|&i| a[i] != b[i - range.start]).count() as u64,
            (Some(_), None) => covered().count() as u64,
            _ => 0,
        };
        let depth = match (&gb.depth, &band.depth) {
            (Some(a), Some(b)) => covered()
                .map(|i| {
                    let (x, y) = (f64::from(a[i]), f64::from(b[i - range.start]));
                    if x == y {
                        0.0
                    } else {
                        (x - y).abs() / x.abs().max(f64::from(f32::MIN_POSITIVE))
                    }
                })
                .reduce(|| 0.0, f64::max),
            (Some(_), None) => f64::INFINITY,
            _ => 0.0,
        };
        total.primitive += mismatches(gb.primitive_id.as_ref(), band.primitive_id.as_ref());
        total.object += mismatches(gb.object_id.as_ref(), band.object_id.as_ref());
        total.depth = total.depth.max(depth);
        for (k, plane) in
            total.kept.iter_mut().zip([band.depth.is_some(), band.primitive_id.is_some(), band.object_id.is_some()])
        {
            *k &= plane;
        }
        Ok(true)
    })?;
    let mut missing = Vec::new();
    for ((name, had), kept) in [
        ("depth", gb.depth.is_some()),
        ("primitive_id", gb.primitive_id.is_some()),
        ("object_id", gb.object_id.is_some()),
    ]
    .into_iter()
    .zip(total.kept)
    {
        if had && !kept {
            missing.push(name.to_string());
        }
    }
    Ok(VisibilityPacking {
        layout: layout.name().to_string(),
        bytes: layout.bytes_per_sample() as u32,
        primitive_id_mismatches: total.primitive,
        object_id_mismatches: total.object,
        depth_max_rel_error: total.depth,
        missing,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_light_counts_take_each_tiles_list_length() {
        // 4×2 pixels, tiles of 2: tile 0 has lists of 3, tile 1 of 5 (one blank pixel reading 0).
        let heat = [3, 3, 5, 0, 3, 3, 5, 5];
        assert_eq!(tile_light_counts(&heat, 4, 2, 2), vec![3, 5]);
    }
}
