//! `gbuf compare REF TEST`: two images (EXR or PNG) as NVIDIA's FLIP tool pools them (mean, weighted median and
//! quartiles, min, max, histogram) plus RMSE, PSNR, the largest difference and where, tev's relative MSE; with
//! thresholds that gate a script the way `idiff` does.
//!
//! Exit status (OpenImageIO's `idiff`): 0 pass, 1 a `--warn-above` threshold exceeded, 2 a `--fail-above` one,
//! 3 the images differ in size or kind, 4 a file could not be read or written. (A mistyped flag is clap's 2.)

use super::common::print_json;
use anyhow::Context;
use gbuf::image::file::ImageFile;
use gbuf::measure::compare::{self, Comparison, FlipMode, Gate, Pooled};
use gbuf::measure::image::Viewing;
use std::path::{Path, PathBuf};

/// Flags of `gbuf compare`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The reference image (EXR: linear; PNG: sRGB display values).
    pub reference: PathBuf,
    /// The test image, of the same size and kind.
    pub test: PathBuf,
    /// Which FLIP: auto (LDR for PNG, HDR for EXR, as NVIDIA's tool), ldr, hdr, both, none.
    #[arg(long, value_name = "MODE", default_value = "auto")]
    pub flip: FlipMode,
    /// Pixels per degree of the viewer FLIP models.
    #[arg(long, value_name = "PPD", default_value_t = gbuf::measure::flip::default_ppd())]
    pub ppd: f32,
    /// LDR-FLIP of EXR images: the tone map they are shown with (as `gbuf resolve --png`).
    #[arg(long, value_name = "TM", default_value = "reinhard")]
    pub tonemap: gbuf::image::ToneCurve,
    /// LDR-FLIP of EXR images: exposure multiplied in before the tone map.
    #[arg(long, value_name = "E", default_value_t = 1.0)]
    pub exposure: f32,
    /// Exit 2 (FAIL) when a measure exceeds its value: `flip=0.05,rmse=0.01`. Measures: flip (HDR when computed,
    /// else LDR), flip-ldr, flip-hdr, flip-median, flip-max, rmse, rel-mse (tev's), nmse, max-abs.
    #[arg(long, value_name = "M=V,…")]
    pub fail_above: Option<String>,
    /// Exit 1 (WARN) when a measure exceeds its value (same measures).
    #[arg(long, value_name = "M=V,…")]
    pub warn_above: Option<String>,
    /// Write a float EXR for tev: channels R, G, B = |test − reference|, and `flip` = the FLIP map (HDR when
    /// computed, else LDR).
    #[arg(long, value_name = "OUT.exr")]
    pub error_map: Option<PathBuf>,
    /// Write the FLIP map as a PNG in the magma colour map (as NVIDIA's tool).
    #[arg(long, value_name = "OUT.png")]
    pub flip_map: Option<PathBuf>,
    /// Append one line to this CSV (NVIDIA's columns, then gbuf's; the header when the file is new).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Refuse files whose decoded samples would need more than this many MiB.
    #[arg(long, value_name = "MIB")]
    pub max_memory: Option<u64>,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
    /// Compare two frames instead of two images: both are packed render targets of this layout (folders or
    /// RenderDoc captures). Also implied when either file is a RenderDoc capture (`.rdc`) or a folder holding
    /// `layout.toml`: per-attribute differences (angle for normals, relative for depth, mismatches for IDs) and the
    /// FLIP of the two frames lit alike (`--flip none`: without FLIP).
    #[arg(long = "input-layout", value_name = "NAME|PATH")]
    pub input_layout: Option<String>,
    /// Frames: the sidecar (camera, lights) of both [default: the one found beside each].
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// Frames from RenderDoc captures: the event read in both [default: each capture's last draw writing colour
    /// targets].
    #[arg(long, value_name = "EID", conflicts_with = "marker")]
    pub event: Option<u32>,
    /// Frames from RenderDoc captures: the last draw inside this marker region, in both.
    #[arg(long, value_name = "NAME")]
    pub marker: Option<String>,
}

/// An exit status other than 1, with the message to print (`gbuf: <message>`).
#[derive(Debug)]
pub struct Status {
    /// The process exit status.
    pub code: u8,
    /// What to print.
    pub message: String,
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Status {}

fn status(code: u8, message: String) -> anyhow::Error {
    anyhow::Error::new(Status { code, message })
}

/// A file problem: exit 4, the cause kept.
fn file_error(e: impl Into<anyhow::Error>, what: String) -> anyhow::Error {
    e.into().context(Status { code: 4, message: what })
}

#[derive(serde::Serialize)]
struct Output<'a> {
    reference: &'a Path,
    test: &'a Path,
    reference_storage: &'a str,
    test_storage: &'a str,
    #[serde(flatten)]
    comparison: &'a Comparison,
    verdict: &'static str,
    exceeded: Vec<String>,
}

/// Runs `gbuf compare`.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(args.ppd.is_finite() && args.ppd > 0.0, "--ppd must be a positive number, got {}", args.ppd);
    anyhow::ensure!(
        args.exposure.is_finite() && args.exposure > 0.0,
        "--exposure must be a positive number, got {}",
        args.exposure
    );
    if args.input_layout.is_some() || [&args.reference, &args.test].iter().any(|p| is_frame(p)) {
        return compare_frames(&args);
    }
    let gates = |s: &Option<String>, flag: &str| -> anyhow::Result<Vec<(Gate, f64)>> {
        match s {
            Some(s) => {
                compare::parse_gates(s).map_err(|e| anyhow::Error::new(super::UsageError(format!("{flag}: {e}"))))
            }
            None => Ok(Vec::new()),
        }
    };
    let fail = gates(&args.fail_above, "--fail-above")?;
    let warn = gates(&args.warn_above, "--warn-above")?;
    let limits = super::common::read_limits(args.max_memory, false);
    let read = |p: &Path| -> anyhow::Result<ImageFile> {
        gbuf::image::file::read(p, &limits).map_err(|e| file_error(e, format!("cannot read {}", p.display())))
    };
    let (reference, test) = (read(&args.reference)?, read(&args.test)?);
    for f in [(&args.reference, &reference), (&args.test, &test)] {
        if f.1.non_finite > 0 {
            eprintln!("gbuf: warning: {}: {} NaN or infinite values read as 0", f.0.display(), f.1.non_finite);
        }
    }
    let viewing = Viewing { tone_map: args.tonemap, exposure: args.exposure, pixels_per_degree: args.ppd };
    let c = compare::compare(&reference, &test, &compare::CompareOptions { flip: args.flip, viewing })
        .map_err(|e| status(3, format!("{} vs {}: {e}", args.reference.display(), args.test.display())))?;
    // Gates asked for but not computed are usage errors (a FLIP threshold with --flip none, or flip-hdr on LDR).
    let mut exceeded_fail = Vec::new();
    let mut exceeded_warn = Vec::new();
    for (list, out) in [(&fail, &mut exceeded_fail), (&warn, &mut exceeded_warn)] {
        for &(g, limit) in list.iter() {
            let Some(v) = c.value(g) else {
                crate::usage!("threshold on {g}: that measure was not computed (see --flip)");
            };
            // NaN exceeds every threshold (a measure that cannot be trusted does not pass).
            if v.is_nan() || v > limit {
                out.push(format!("{g} = {v:.6} > {limit}"));
            }
        }
    }
    let verdict = if !exceeded_fail.is_empty() {
        "FAIL"
    } else if !exceeded_warn.is_empty() {
        "WARN"
    } else {
        "PASS"
    };
    write_outputs(&args, &reference, &test, &c)?;
    let exceeded: Vec<String> = exceeded_fail.iter().chain(&exceeded_warn).cloned().collect();
    if args.json {
        print_json(&Output {
            reference: &args.reference,
            test: &args.test,
            reference_storage: &reference.storage,
            test_storage: &test.storage,
            comparison: &c,
            verdict,
            exceeded: exceeded.clone(),
        })?;
    } else {
        print_text(&args, &reference, &test, &c)?;
        if !fail.is_empty() || !warn.is_empty() {
            use std::io::Write as _;
            let mut out = std::io::stdout().lock();
            writeln!(
                out,
                "{verdict}{}",
                if exceeded.is_empty() { String::new() } else { format!(": {}", exceeded.join(", ")) }
            )?;
        }
    }
    match verdict {
        "FAIL" => Err(status(2, format!("FAIL: {}", exceeded_fail.join(", ")))),
        "WARN" => Err(status(1, format!("WARN: {}", exceeded_warn.join(", ")))),
        _ => Ok(()),
    }
}

fn print_text(args: &Args, r: &ImageFile, t: &ImageFile, c: &Comparison) -> anyhow::Result<()> {
    use std::io::Write as _;
    let mut o = std::io::stdout().lock();
    writeln!(
        o,
        "{} vs {}: {}×{} ({} / {})",
        args.reference.display(),
        args.test.display(),
        c.size[0],
        c.size[1],
        r.storage,
        t.storage
    )?;
    let pooled = |o: &mut std::io::StdoutLock<'_>, name: &str, p: &Pooled| -> std::io::Result<()> {
        writeln!(o, "{name} ({:.2} pixels per degree)", c.pixels_per_degree)?;
        writeln!(o, "     Mean: {:.6}", p.mean)?;
        writeln!(o, "     Weighted median: {:.6}", p.weighted_median)?;
        writeln!(o, "     1st weighted quartile: {:.6}", p.weighted_q1)?;
        writeln!(o, "     3rd weighted quartile: {:.6}", p.weighted_q3)?;
        writeln!(o, "     Min: {:.6} at ({}, {})", p.min, p.min_at[0], p.min_at[1])?;
        writeln!(o, "     Max: {:.6} at ({}, {})", p.max, p.max_at[0], p.max_at[1])
    };
    if let Some(p) = &c.flip_ldr {
        pooled(&mut o, "LDR-FLIP", p)?;
    }
    if let Some(p) = &c.flip_hdr {
        pooled(&mut o, "HDR-FLIP", p)?;
    }
    let n = &c.numeric;
    writeln!(
        o,
        "RMSE {:.6}, PSNR {:.2} dB (peak {}), largest difference {:.6} at ({}, {}), relative MSE (tev) {:.6}, \
         normalised MSE {:.6}",
        n.rmse, n.psnr_db, n.psnr_peak, n.max_abs, n.max_abs_at[0], n.max_abs_at[1], n.rel_mse, n.nmse
    )?;
    Ok(())
}

/// The FLIP map a single-map output shows: HDR when computed, else LDR.
fn main_map(c: &Comparison) -> Option<&gbuf::measure::flip::FlipMap> {
    c.maps.1.as_ref().or(c.maps.0.as_ref())
}

fn write_outputs(args: &Args, r: &ImageFile, t: &ImageFile, c: &Comparison) -> anyhow::Result<()> {
    if let Some(p) = &args.error_map {
        write_error_map(p, r, t, c).map_err(|e| file_error(e, format!("cannot write {}", p.display())))?;
    }
    if let Some(p) = &args.flip_map {
        let Some(map) = main_map(c) else {
            crate::usage!("--flip-map: no FLIP was computed (see --flip)");
        };
        let bytes = gbuf::measure::flip::flip_map_to_magma_rgb8(map);
        gbuf::base::picture::write_rgb8_png(p, c.size[0], c.size[1], bytes)
            .map_err(|e| file_error(e, format!("cannot write {}", p.display())))?;
    }
    if let Some(p) = &args.csv {
        append_csv(p, args, c).map_err(|e| file_error(e, format!("cannot write {}", p.display())))?;
    }
    Ok(())
}

fn write_error_map(path: &Path, r: &ImageFile, t: &ImageFile, c: &Comparison) -> anyhow::Result<()> {
    use gbuf::io::raw::{RawChannel, RawData, RawImage};
    let diff = |k: usize| RawChannel {
        name: ["R", "G", "B"][k].into(),
        data: RawData::F32(r.image.rgb.iter().zip(&t.image.rgb).map(|(a, b)| (b[k] - a[k]).abs()).collect()),
    };
    let mut channels = vec![diff(0), diff(1), diff(2)];
    if let Some(m) = main_map(c) {
        channels.push(RawChannel { name: "flip".into(), data: RawData::F32(m.values.clone()) });
    }
    let raw = RawImage { width: c.size[0], height: c.size[1], channels, ..Default::default() };
    gbuf::io::exr::write_raw(path, &raw).with_context(|| format!("writing {}", path.display()))
}

fn append_csv(path: &Path, args: &Args, c: &Comparison) -> anyhow::Result<()> {
    let old = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => return Err(e.into()),
    };
    let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(old);
    if w.get_ref().is_empty() {
        w.write_record([
            "Reference",
            "Test",
            "Mean",
            "Weighted median",
            "1st weighted quartile",
            "3rd weighted quartile",
            "Min",
            "Max",
            "FLIP",
            "RMSE",
            "PSNR (dB)",
            "Relative MSE (tev)",
            "Normalised MSE",
            "Largest difference",
        ])?;
    }
    let f = |v: f64| format!("{v:.6}");
    let p = main_map(c).map(|_| c.flip_hdr.as_ref().or(c.flip_ldr.as_ref()).expect("a map has its statistics"));
    let stat = |g: fn(&Pooled) -> f64| p.map_or_else(String::new, |p| f(g(p)));
    let n = &c.numeric;
    w.write_record([
        args.reference.display().to_string(),
        args.test.display().to_string(),
        stat(|p| p.mean),
        stat(|p| p.weighted_median),
        stat(|p| p.weighted_q1),
        stat(|p| p.weighted_q3),
        stat(|p| p.min),
        stat(|p| p.max),
        match (&c.flip_ldr, &c.flip_hdr) {
            (_, Some(_)) => "HDR".into(),
            (Some(_), None) => "LDR".into(),
            _ => String::new(),
        },
        f(n.rmse),
        format!("{:.2}", n.psnr_db),
        f(n.rel_mse),
        f(n.nmse),
        f(n.max_abs),
    ])?;
    let bytes = w.into_inner().map_err(|e| anyhow::anyhow!("{e}"))?;
    gbuf::base::files::write_bytes_atomic(path, &bytes)?;
    Ok(())
}

/// Is `path` a frame rather than an image: a RenderDoc capture, a packed-targets folder or a file gbuf reads as a
/// dump (not an EXR image: EXRs are images here unless `--input-layout` says otherwise)?
fn is_frame(path: &Path) -> bool {
    gbuf::io::rdc::is_capture(path) || gbuf::layout::targets::is_packed_dir(path)
}

/// What `gbuf compare` of two frames measures.
#[derive(serde::Serialize)]
struct FrameComparison {
    /// The reference frame.
    reference: String,
    /// The test frame.
    test: String,
    /// Per attribute, the test against the reference.
    attributes: gbuf::measure::gbuffer::AttributeErrors,
    /// Both frames lit alike (the reference's lights, the same BRDF and detector): the test's image against the
    /// reference's.
    lit: gbuf::measure::image::ErrorSet,
    /// The lights' source.
    lights: String,
}

/// `gbuf compare A B` of two frames: per-attribute differences and the lit images' FLIP.
fn compare_frames(args: &Args) -> anyhow::Result<()> {
    if args.fail_above.is_some()
        || args.warn_above.is_some()
        || args.error_map.is_some()
        || args.flip_map.is_some()
        || args.csv.is_some()
    {
        crate::usage!(
            "--fail-above, --warn-above, --error-map, --flip-map and --csv apply to images; two frames are compared"
        );
    }
    let opts = gbuf::io::LoadOptions {
        input_layout: args.input_layout.clone(),
        sidecar: args.scene.clone(),
        capture: gbuf::io::rdc::Selection { event: args.event, marker: args.marker.clone() },
        limits: super::common::read_limits(args.max_memory, false),
        ..Default::default()
    };
    let load = |p: &Path| -> anyhow::Result<gbuf::io::Loaded> {
        let l = gbuf::load(p, &opts).map_err(|e| file_error(e, format!("cannot read {}", p.display())))?;
        super::common::print_warnings(p, &l);
        Ok(l)
    };
    let (a, b) = (load(&args.reference)?, load(&args.test)?);
    let pair = format!("{} vs {}", args.reference.display(), args.test.display());
    let attributes =
        gbuf::measure::gbuffer::compare(&a.gbuffer, &b.gbuffer).map_err(|e| status(3, format!("{pair}: {e}")))?;
    let (lights, source) = super::common::frame_lights(&a, None, 1);
    let lighting = super::common::LightingArgs::default().choose(&a.gbuffer.attributes());
    let cfg = lighting.apply(gbuf::resolve::ResolveConfig::default());
    let lit = |gb: &gbuf::GBuffer| -> anyhow::Result<gbuf::image::HdrImage> {
        let mask = gbuf::detect::detect(gb, gbuf::detect::Detector::Lauritzen, &Default::default())?;
        Ok(gbuf::resolve::resolve(gb, &lights, &mask, &cfg)?.image)
    };
    let viewing = Viewing { tone_map: args.tonemap, exposure: args.exposure, pixels_per_degree: args.ppd };
    let shown = (args.flip != FlipMode::None).then_some(&viewing);
    let lit = gbuf::measure::image::error_set(&lit(&a.gbuffer)?, &lit(&b.gbuffer)?, shown);
    let c = FrameComparison {
        reference: args.reference.display().to_string(),
        test: args.test.display().to_string(),
        attributes,
        lit,
        lights: source,
    };
    if args.json {
        return print_json(&c);
    }
    let g = &a.gbuffer;
    println!(
        "{pair}: {}×{}×{} frames, {} covered samples compared",
        g.width, g.height, g.samples, c.attributes.covered_samples
    );
    print!("{}", super::roundtrip::attribute_lines(&c.attributes));
    if !c.attributes.missing.is_empty() {
        println!("  only in {}: {}", args.reference.display(), c.attributes.missing.join(", "));
    }
    println!(
        "lit alike ({}, {} lights: {}): RMSE {:.4e}, LDR-FLIP {}, HDR-FLIP {}",
        cfg.brdf.name(),
        lights.len(),
        c.lights,
        c.lit.rmse,
        c.lit.flip_ldr.map_or("-".into(), |v| format!("{v:.4}")),
        c.lit.flip_hdr.map_or("-".into(), |v| format!("{v:.4}"))
    );
    Ok(())
}
