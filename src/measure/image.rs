//! Image error metrics: a test image against the reference.
//!
//! PSNR's peak is stated explicitly: `psnr_db = 10·log10(peak² / mse)` with `peak` = the reference's largest
//! channel value (HDR images have no fixed white; 1 when the reference is black). Identical images report
//! [`PSNR_CAP_DB`] rather than infinity, so the JSON stays a number.
//!
//! [`against_full_deferred`] measures a second schedule (the light pre-pass) against full deferred shading of the
//! same input, the way the issue asks its error to be reported, separately from the error against the reference.

use crate::base::mask::EdgeMask;
use crate::image::{HdrImage, ToneCurve, ToneMap};
use crate::light::Light;
use crate::measure::flip;
use crate::resolve::{resolve, ResolveConfig, Schedule};
use rayon::prelude::*;
use serde::Serialize;
use std::borrow::Cow;

/// How far `test` is from `reference`, per channel value (3 per pixel), in f64.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ImageError {
    /// Root mean square error.
    pub rmse: f64,
    /// `10·log10(peak² / mse)` with `peak` = [`ImageError::peak`]; capped at [`PSNR_CAP_DB`] for identical
    /// images (so the value stays finite in JSON).
    pub psnr_db: f64,
    /// Largest absolute difference.
    pub max_abs: f64,
    /// Mean absolute difference.
    pub mean_abs: f64,
    /// Relative MSE: `Σ (t − r)² / Σ r²` (0 when both are black; 1 when the test is black).
    pub rel_mse: f64,
    /// The PSNR peak: the reference's largest channel value (1 when the reference is black).
    pub peak: f64,
    /// Pixels whose largest channel difference exceeds 1% of the peak.
    pub pixels_over_1pct: u64,
}

/// PSNR reported for identical images (and the upper bound of any PSNR we report), in dB.
pub const PSNR_CAP_DB: f64 = 200.0;

/// Pixels per chunk of [`try_compare`]'s sums.
const COMPARE_CHUNK: usize = 1 << 14;

/// [`try_compare`]'s running sums over a chunk of pixels.
#[derive(Clone, Copy, Default)]
struct Sums {
    se: f64,
    sa: f64,
    sr: f64,
    max_abs: f64,
    over: u64,
}

/// Compares `test` against `reference`; `None` when their sizes differ.
#[must_use]
pub fn try_compare(reference: &HdrImage, test: &HdrImage) -> Option<ImageError> {
    if reference.width != test.width || reference.height != test.height || reference.rgb.len() != test.rgb.len() {
        return None;
    }
    let peaks = reference.rgb.par_chunks(COMPARE_CHUNK).map(|c| c.iter().fold(0.0f32, |m, r| m.max(r.max_element())));
    let mut peak = f64::from(peaks.reduce(|| 0.0, f32::max));
    if peak.is_nan() || peak <= 0.0 || !peak.is_finite() {
        peak = 1.0;
    }
    // Sums per chunk of pixels, added in chunk order: the same bits whatever the thread count, and each chunk's
    // independent sums overlap in the pipeline where one running sum over the frame waited on every add.
    let parts: Vec<Sums> = reference
        .rgb
        .par_chunks(COMPARE_CHUNK)
        .zip(test.rgb.par_chunks(COMPARE_CHUNK))
        .map(|(rc, tc)| {
            let mut s = Sums::default();
            for (r, t) in rc.iter().zip(tc) {
                let mut pix_max = 0.0f64;
                for k in 0..3 {
                    let (a, b) = (f64::from(r[k]), f64::from(t[k]));
                    let d = (b - a).abs();
                    let d = if d.is_finite() { d } else { f64::MAX.sqrt() };
                    s.se += d * d;
                    s.sa += d;
                    s.sr += a * a;
                    pix_max = pix_max.max(d);
                }
                s.max_abs = s.max_abs.max(pix_max);
                s.over += u64::from(pix_max > 0.01 * peak);
            }
            s
        })
        .collect();
    let Sums { se, sa, sr, max_abs, over } = parts.iter().fold(Sums::default(), |a, b| Sums {
        se: a.se + b.se,
        sa: a.sa + b.sa,
        sr: a.sr + b.sr,
        max_abs: a.max_abs.max(b.max_abs),
        over: a.over + b.over,
    });
    let n = (reference.rgb.len() * 3).max(1) as f64;
    let mse = se / n;
    let psnr = if mse > 0.0 { (10.0 * (peak * peak / mse).log10()).min(PSNR_CAP_DB) } else { PSNR_CAP_DB };
    let rel_mse = if sr > 0.0 {
        se / sr
    } else if se > 0.0 {
        1.0
    } else {
        0.0
    };
    Some(ImageError {
        rmse: mse.sqrt(),
        psnr_db: psnr,
        max_abs,
        mean_abs: sa / n,
        rel_mse,
        peak,
        pixels_over_1pct: over,
    })
}

/// Compares `test` against `reference`; images of different sizes compare as completely wrong (`rmse`,
/// `max_abs` and `mean_abs` = ∞, `psnr_db` = −∞, `rel_mse` = ∞) — use [`try_compare`] to detect that case.
#[must_use]
pub fn compare(reference: &HdrImage, test: &HdrImage) -> ImageError {
    try_compare(reference, test).unwrap_or(ImageError {
        rmse: f64::INFINITY,
        psnr_db: f64::NEG_INFINITY,
        max_abs: f64::INFINITY,
        mean_abs: f64::INFINITY,
        rel_mse: f64::INFINITY,
        peak: 1.0,
        pixels_over_1pct: reference.rgb.len().max(test.rgb.len()) as u64,
    })
}

/// How the images are shown to the person FLIP models: the tone map and exposure of `gbuf resolve --png` (8-bit
/// sRGB) for LDR-FLIP, and the viewing distance in pixels per degree for both FLIP variants.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct Viewing {
    /// The tone curve of the displayed (LDR) image.
    pub tone_map: ToneCurve,
    /// Exposure multiplied in before the tone curve.
    pub exposure: f32,
    /// Pixels per degree of visual angle (FLIP's default, 67.02, is a 0.7 m wide 4K monitor seen from 0.7 m).
    pub pixels_per_degree: f32,
}

impl Default for Viewing {
    fn default() -> Self {
        Viewing { tone_map: ToneCurve::Reinhard, exposure: 1.0, pixels_per_degree: flip::default_ppd() }
    }
}

impl Viewing {
    /// The tone map of the displayed image.
    #[must_use]
    pub fn tone(&self) -> ToneMap {
        ToneMap::new(self.tone_map, self.exposure)
    }
}

/// One error between two images in every measure a report shows: the numerical ones of [`ImageError`] and, when
/// computed, the perceptual ones (mean FLIP, in [0, 1]: 0 = indistinguishable).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct ErrorSet {
    /// Root mean square error (linear radiance).
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub rmse: f64,
    /// PSNR in dB, peak = [`ErrorSet::psnr_peak`]; capped at [`PSNR_CAP_DB`].
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub psnr_db: f64,
    /// The PSNR peak: the largest channel value of the image compared against.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub psnr_peak: f64,
    /// Relative MSE: `Σ (t − r)² / Σ r²`.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub rel_mse: f64,
    /// Largest absolute difference.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub max_abs: f64,
    /// Mean LDR-FLIP of the displayed images ([`Viewing`]); `None` when not computed.
    pub flip_ldr: Option<f64>,
    /// Mean HDR-FLIP of the linear images (exposure range from the image compared against, ACES tone mapper, as
    /// NVIDIA's reference); `None` when not computed.
    pub flip_hdr: Option<f64>,
}

impl ErrorSet {
    /// The numerical measures of `e`, FLIP not computed.
    #[must_use]
    pub fn numeric(e: &ImageError) -> Self {
        ErrorSet {
            rmse: e.rmse,
            psnr_db: e.psnr_db,
            psnr_peak: e.peak,
            rel_mse: e.rel_mse,
            max_abs: e.max_abs,
            flip_ldr: None,
            flip_hdr: None,
        }
    }
}

/// FLIP of `test` against `reference` as `viewing` shows them: (LDR-FLIP map of the displayed images, mean
/// HDR-FLIP of the linear ones). `None` when the sizes differ.
#[must_use]
pub fn flip_pair(reference: &HdrImage, test: &HdrImage, viewing: &Viewing) -> Option<(flip::FlipMap, f64)> {
    flip_many(reference, &[test], viewing).pop().flatten()
}

/// An image as LDR-FLIP sees it on the display: tone-mapped, 8-bit sRGB (FLIP reads each byte as `byte / 255`).
fn shown(img: &HdrImage, viewing: &Viewing) -> Vec<u8> {
    img.to_srgb8(viewing.tone())
}

/// FLIP of several tests against one reference (`None` for a test of another size): each test's numbers are those
/// of `flip::ldr_flip` / `flip::hdr_flip` on the pair (the means within the last bits of their sums' order), with
/// the reference filtered once per pass instead of once per test. The HDR exposures run first and keep nothing per
/// test beyond a band, then the LDR pass makes the maps; the displayed and linear copies of the tests exist one kind
/// at a time.
#[must_use]
pub fn flip_many(reference: &HdrImage, tests: &[&HdrImage], viewing: &Viewing) -> Vec<Option<(flip::FlipMap, f64)>> {
    let (w, h) = (reference.width as usize, reference.height as usize);
    let opts = flip::FlipOptions { pixels_per_degree: viewing.pixels_per_degree };
    let zero = || flip::FlipMap { width: w, height: h, values: vec![0.0; w * h], mean: 0.0 };
    flip_batch(reference, tests, viewing, zero, |r, t| flip::ldr_flip_many_srgb8(r, t, w, h, &opts))
}

/// [`flip_many`]'s means alone, (LDR-FLIP, HDR-FLIP) per test: no map is made, so a test costs no memory beyond
/// its displayed copy and a band of errors.
#[must_use]
pub fn flip_means(reference: &HdrImage, tests: &[&HdrImage], viewing: &Viewing) -> Vec<Option<(f64, f64)>> {
    let (w, h) = (reference.width as usize, reference.height as usize);
    let opts = flip::FlipOptions { pixels_per_degree: viewing.pixels_per_degree };
    flip_batch(reference, tests, viewing, || 0.0, |r, t| flip::ldr_flip_means_srgb8(r, t, w, h, &opts))
}

/// [`flip_many`] and [`flip_means`]: HDR means of the tests that fit and differ from the reference, then `ldr` on
/// their displayed copies (a map or a mean each, `zero` for a test equal to the reference).
fn flip_batch<L>(
    reference: &HdrImage,
    tests: &[&HdrImage],
    viewing: &Viewing,
    zero: impl Fn() -> L,
    ldr: impl FnOnce(&[u8], &[&[u8]]) -> Vec<L>,
) -> Vec<Option<(L, f64)>> {
    let same = |t: &&HdrImage| {
        t.width == reference.width && t.height == reference.height && t.rgb.len() == reference.rgb.len()
    };
    // A test equal to the reference bit for bit has FLIP 0 everywhere (equal features at every exposure): it is
    // not filtered. The report's lossless layout gives such an image.
    let equal = |t: &&HdrImage| same(t) && t.rgb == reference.rgb;
    let fit: Vec<&HdrImage> = tests.iter().copied().filter(|t| same(t) && !equal(t)).collect();
    let (w, h) = (reference.width as usize, reference.height as usize);
    let opts = flip::FlipOptions { pixels_per_degree: viewing.pixels_per_degree };
    let hdr = {
        let tests: Vec<Cow<'_, [f32]>> = fit.iter().map(|t| linear(t)).collect();
        let views: Vec<&[f32]> = tests.iter().map(|t| &**t).collect();
        flip::hdr_flip_means(&linear(reference), &views, w, h, &opts)
    };
    let ldr = {
        // The displayed images as bytes: a quarter of their floats (a 1080p test is 6 MB instead of 25).
        let tests: Vec<Vec<u8>> = fit.iter().map(|t| shown(t, viewing)).collect();
        let views: Vec<&[u8]> = tests.iter().map(Vec::as_slice).collect();
        ldr(&shown(reference, viewing), &views)
    };
    let mut results = ldr.into_iter().zip(hdr).map(|(l, h)| Some((l, h)));
    tests
        .iter()
        .map(|t| match (same(t), equal(t)) {
            (true, true) => Some((zero(), 0.0)),
            (true, false) => results.next().expect("one result per fitting test"),
            (false, _) => None,
        })
        .collect()
}

/// An image as HDR-FLIP takes it: interleaved linear RGB, finite and non-negative. What the resolve writes already
/// is, and is then borrowed as it is (a 1080p image is 25 MB, and the report holds several); a dump's reference may
/// not be, and is copied with its negative and non-finite values set to 0.
fn linear(img: &HdrImage) -> Cow<'_, [f32]> {
    let floats: &[f32] = bytemuck::cast_slice(&img.rgb);
    let usable = |x: &f32| x.is_finite() && *x >= 0.0;
    if floats.par_iter().all(usable) {
        Cow::Borrowed(floats)
    } else {
        Cow::Owned(floats.par_iter().map(|&x| if usable(&x) { x } else { 0.0 }).collect())
    }
}

/// The [`ErrorSet`] of `test` against `reference`, with FLIP when `viewing` is given. Images of different sizes
/// compare as completely wrong (see [`compare`]) and get no FLIP.
#[must_use]
pub fn error_set(reference: &HdrImage, test: &HdrImage, viewing: Option<&Viewing>) -> ErrorSet {
    let mut e = ErrorSet::numeric(&compare(reference, test));
    if let Some((ldr, hdr)) = viewing.and_then(|v| flip_pair(reference, test, v)) {
        e.flip_ldr = Some(ldr.mean);
        e.flip_hdr = Some(hdr);
    }
    e
}

/// The three image errors of a lit test image, kept apart: what the layout costs (`layout`: the test against the
/// exact G-buffer lit the same way), what the detector's anti-aliasing costs (`aa`: the exact image against the
/// every-sample reference) and both (`total`: the test against the reference). Each is `None` when its image is.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorTriad {
    /// The test image against the exact one.
    pub layout: Option<ErrorSet>,
    /// The exact image against the reference.
    pub aa: Option<ErrorSet>,
    /// The test image against the reference.
    pub total: Option<ErrorSet>,
}

/// The [`ErrorTriad`] of `test`, with FLIP when `viewing` is given.
#[must_use]
pub fn error_triad(
    test: &HdrImage,
    exact: Option<&HdrImage>,
    reference: Option<&HdrImage>,
    viewing: Option<&Viewing>,
) -> ErrorTriad {
    ErrorTriad {
        layout: exact.map(|x| error_set(x, test, viewing)),
        aa: exact.zip(reference).map(|(x, r)| error_set(r, x, viewing)),
        total: reference.map(|r| error_set(r, test, viewing)),
    }
}

/// The error of `image` (e.g. the light pre-pass's output) against full deferred shading of the same G-buffer,
/// lights and edge mask: `cfg` with its schedule set to [`Schedule::Deferred`] (culling, BRDF, falloff and tiles
/// as given). The PSNR peak is the deferred image's largest channel value. Also returns the deferred resolve's
/// wall time in milliseconds.
pub fn against_full_deferred<'a>(
    gb: impl Into<crate::resolve::ResolveInput<'a>>,
    lights: &[Light],
    mask: &EdgeMask,
    cfg: &ResolveConfig,
    image: &HdrImage,
) -> crate::Result<(ImageError, f64)> {
    let deferred = resolve(gb, lights, mask, &ResolveConfig { schedule: Schedule::Deferred, ..*cfg })?;
    let err = try_compare(&deferred.image, image).ok_or_else(|| {
        crate::Error::Mismatch(format!(
            "image is {}×{} but the G-buffer is {}×{}",
            image.width, image.height, deferred.image.width, deferred.image.height
        ))
    })?;
    Ok((err, deferred.stats.ms.total))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The chunked sums agree with one running f64 sum over the frame to rounding (1e-12 relative), count the
    /// same pixels over 1% and the same maximum exactly, and give the same bits on 1 and 2 threads.
    #[test]
    fn chunked_sums_match_one_running_sum_and_ignore_the_thread_count() {
        let (w, h) = (301, 173); // several chunks and a partial one
        let mut a = HdrImage::new(w, h);
        let mut b = HdrImage::new(w, h);
        for (i, (x, y)) in a.rgb.iter_mut().zip(b.rgb.iter_mut()).enumerate() {
            let f = i as f32;
            *x = Vec3::new((f * 0.013).sin().abs() * 3.0, (f * 0.007).cos().abs(), 0.25);
            *y = *x + Vec3::new((f * 0.31).sin() * 0.05, 0.0, if i % 97 == 0 { 0.2 } else { 0.0 });
        }
        let (mut se, mut sa, mut sr, mut max, mut over) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0u64);
        let peak = a.rgb.iter().fold(0.0f64, |m, r| m.max(f64::from(r.max_element())));
        for (r, t) in a.rgb.iter().zip(&b.rgb) {
            let mut pm = 0.0f64;
            for k in 0..3 {
                let d = (f64::from(t[k]) - f64::from(r[k])).abs();
                (se, sa, sr) = (se + d * d, sa + d, sr + f64::from(r[k]) * f64::from(r[k]));
                pm = pm.max(d);
            }
            max = max.max(pm);
            over += u64::from(pm > 0.01 * peak);
        }
        let n = 3.0 * f64::from(w * h);
        let e = compare(&a, &b);
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs();
        assert!(close(e.rmse, (se / n).sqrt()) && close(e.mean_abs, sa / n) && close(e.rel_mse, se / sr), "{e:?}");
        assert_eq!((e.max_abs, e.pixels_over_1pct, e.peak), (max, over, peak));
        let on = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| compare(&a, &b))
        };
        let (one, two) = (on(1), on(2));
        assert_eq!((one.rmse.to_bits(), one.mean_abs.to_bits()), (two.rmse.to_bits(), two.mean_abs.to_bits()));
    }

    #[test]
    fn identical_images_have_zero_error_and_capped_psnr() {
        let mut a = HdrImage::new(2, 2);
        a.rgb[1] = Vec3::new(2.0, 1.0, 0.5);
        let e = compare(&a, &a);
        assert_eq!((e.rmse, e.max_abs, e.rel_mse, e.pixels_over_1pct), (0.0, 0.0, 0.0, 0));
        assert_eq!(e.psnr_db, PSNR_CAP_DB);
        assert_eq!(e.peak, 2.0);
    }

    #[test]
    fn known_difference_gives_known_numbers() {
        let mut a = HdrImage::new(2, 1);
        a.rgb = vec![Vec3::splat(1.0), Vec3::ZERO];
        let mut b = a.clone();
        b.rgb[1] = Vec3::new(0.5, 0.0, 0.0);
        let e = compare(&a, &b);
        // mse = 0.25 / 6; peak 1.
        assert!((e.rmse - (0.25f64 / 6.0).sqrt()).abs() < 1e-12);
        assert!((e.psnr_db - 10.0 * (6.0f64 / 0.25).log10()).abs() < 1e-9);
        assert_eq!(e.max_abs, 0.5);
        assert!((e.rel_mse - 0.25 / 3.0).abs() < 1e-12);
        assert_eq!(e.pixels_over_1pct, 1);
        let black = HdrImage::new(2, 1);
        assert_eq!(compare(&a, &black).rel_mse, 1.0);
    }

    #[test]
    fn size_mismatch_is_reported() {
        assert!(try_compare(&HdrImage::new(2, 1), &HdrImage::new(1, 2)).is_none());
        assert_eq!(compare(&HdrImage::new(2, 1), &HdrImage::new(1, 1)).rmse, f64::INFINITY);
    }

    /// Pre-pass and deferred shading sum the same f32 terms in a different order (the pre-pass multiplies the
    /// albedo in after the sum): when they are mathematically equal they still differ by a few ulp per value, so a
    /// relative MSE up to this bound counts as "equal" (1e-5 relative per value, squared).
    const SAME_UP_TO_ROUNDING_REL_MSE: f64 = 1e-10;

    fn prepass_error(gb: &crate::GBuffer, lights: &[Light], brdf: crate::resolve::Brdf) -> ImageError {
        let mask = crate::detect::detect(gb, crate::detect::Detector::Lauritzen, &Default::default()).unwrap();
        let cfg = ResolveConfig { brdf, schedule: Schedule::LightPrepass, ..Default::default() };
        let pre = resolve(gb, lights, &mask, &cfg).unwrap();
        against_full_deferred(gb, lights, &mask, &cfg, &pre.image).unwrap().0
    }

    #[test]
    fn light_prepass_equals_deferred_for_one_light_colour_and_not_for_coloured_specular() {
        use crate::resolve::{fixture, Brdf};
        let gb = fixture::spheres(48, 32, 4).unwrap();
        let coloured = fixture::lights_on_surfaces(&gb, 12, 2.0, 7);
        assert!(coloured.windows(2).any(|w| w[0].color != w[1].color), "the fixture's lights must differ in colour");
        let recolour = |c: Vec3| coloured.iter().map(|l| Light { color: c, ..*l }).collect::<Vec<_>>();
        let (white, orange) = (recolour(Vec3::ONE), recolour(Vec3::new(0.9, 0.4, 0.1)));
        // GGX is left out: its pre-pass puts (1 − F0) on the diffuse instead of the per-light (1 − F(v·h)) and
        // replaces a metal's coloured F0 by the light's colour, so it is approximate even under white light.
        for brdf in [Brdf::BlinnPhong, Brdf::Lambert] {
            for (name, lights) in [("white", &white), ("one colour", &orange)] {
                let e = prepass_error(&gb, lights, brdf);
                assert!(e.rel_mse <= SAME_UP_TO_ROUNDING_REL_MSE && e.peak > 0.0, "{brdf} {name}: {e:?}");
            }
        }
        // Without specular (Lambert) the pre-pass is exact whatever the colours; with it, coloured lights make
        // the monochrome specular take the wrong hue.
        let e = prepass_error(&gb, &coloured, Brdf::Lambert);
        assert!(e.rel_mse <= SAME_UP_TO_ROUNDING_REL_MSE, "lambert: {e:?}");
        for brdf in [Brdf::BlinnPhong, Brdf::Ggx] {
            let e = prepass_error(&gb, &coloured, brdf);
            assert!(e.rel_mse > 1e3 * SAME_UP_TO_ROUNDING_REL_MSE && e.max_abs > 0.0, "{brdf}: {e:?}");
        }
    }

    #[test]
    fn against_full_deferred_refuses_an_image_of_another_size() {
        let gb = crate::resolve::fixture::spheres(8, 4, 1).unwrap();
        let mask = crate::detect::detect(&gb, crate::detect::Detector::None, &Default::default()).unwrap();
        let e = against_full_deferred(&gb, &[], &mask, &ResolveConfig::default(), &HdrImage::new(4, 8));
        assert!(e.unwrap_err().to_string().contains("4×8"));
    }

    #[test]
    fn error_set_flip_is_zero_for_identical_images_and_grows_with_the_difference() {
        let mut a = HdrImage::new(16, 16);
        for (i, c) in a.rgb.iter_mut().enumerate() {
            *c = Vec3::splat((i % 7) as f32 * 0.3);
        }
        let v = Viewing::default();
        let same = error_set(&a, &a, Some(&v));
        assert_eq!((same.rmse, same.flip_ldr, same.flip_hdr), (0.0, Some(0.0), Some(0.0)));
        let mut b = a.clone();
        b.rgb[40] += Vec3::splat(0.5);
        let small = error_set(&a, &b, Some(&v));
        for c in b.rgb.iter_mut().step_by(3) {
            *c += Vec3::splat(0.5);
        }
        let large = error_set(&a, &b, Some(&v));
        assert!(
            small.flip_ldr.unwrap() > 0.0 && large.flip_ldr.unwrap() > small.flip_ldr.unwrap(),
            "{small:?} {large:?}"
        );
        assert!(small.flip_hdr.unwrap() > 0.0 && large.flip_hdr.unwrap() > small.flip_hdr.unwrap());
        assert_eq!(error_set(&a, &b, None).flip_ldr, None);
        assert_eq!(error_set(&a, &HdrImage::new(2, 2), Some(&v)).flip_ldr, None, "sizes differ: no FLIP");
    }

    #[test]
    fn a_test_equal_to_the_reference_skips_the_filters_with_their_numbers() {
        let mut a = HdrImage::new(40, 24);
        for (i, c) in a.rgb.iter_mut().enumerate() {
            *c = Vec3::new((i % 7) as f32 * 0.3, (i % 5) as f32 * 2.0, (i % 11) as f32 * 0.05);
        }
        let mut b = a.clone();
        b.rgb[100] += Vec3::splat(0.5);
        let v = Viewing::default();
        let got = flip_many(&a, &[&a, &b, &a], &v);
        // What the filters give for the equal pair, computed through them.
        let opts = flip::FlipOptions { pixels_per_degree: v.pixels_per_degree };
        let shown_a = shown(&a, &v);
        let ldr = flip::ldr_flip_many_srgb8(&shown_a, &[&shown_a], 40, 24, &opts).remove(0);
        let hdr = flip::hdr_flip_means(&linear(&a), &[&linear(&a)], 40, 24, &opts)[0];
        for k in [0, 2] {
            let (map, mean) = got[k].as_ref().expect("same size");
            assert_eq!((&map.values, map.mean, *mean), (&ldr.values, ldr.mean, hdr), "test {k}");
        }
        let (map, mean) = got[1].as_ref().expect("same size");
        assert!(map.mean > 0.0 && *mean > 0.0);
        assert_eq!(map.values, flip_pair(&a, &b, &v).unwrap().0.values, "the other test is filtered as before");
    }
}
