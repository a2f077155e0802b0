//! Plausibility checks every load ends with: data that cannot be what the reader took it for is counted and
//! reported as warnings with the numbers (`gbuf info` prints them, `--json` lists them, every command prints them
//! on stderr), and data that cannot be right at all (most positions behind the camera: not view space) is an error.

use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use glam::Vec2;
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;

/// One finding.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Warning {
    /// Stable identifier (`invalid-normals`, `normals-face-away`, `position-depth`, `reprojection`,
    /// `behind-camera`, `depth-convention`, `sample-positions-assumed`, `no-surface`).
    pub code: &'static str,
    /// Samples affected.
    pub count: u64,
    /// Of how many (covered samples, or all samples).
    pub of: u64,
    /// What it means and what to do.
    pub message: String,
}

/// A normal whose length is off 1 by more than this is non-unit (f16 storage is good to ~1e-3).
pub const UNIT_TOLERANCE: f32 = 1e-2;
/// Below this length a normal is zero.
pub const ZERO_NORMAL: f32 = 1e-3;
/// Positions reprojecting further than this from their sample (pixels) disagree with the camera.
pub const REPROJECTION_PX: f32 = 1.0;
/// Position and depth disagree when `|−z − depth|` exceeds this fraction of the depth.
pub const POSITION_DEPTH_REL: f32 = 1e-3;
/// When at least this fraction of covered positions is behind the camera, loading fails.
pub const BEHIND_CAMERA_FAIL: f64 = 0.5;

/// Is the normal `n` usable (non-zero, unit within [`UNIT_TOLERANCE`])?
#[must_use]
pub fn normal_is_valid(n: glam::Vec3) -> bool {
    let l = n.length();
    l.is_finite() && (l - 1.0).abs() <= UNIT_TOLERANCE
}

/// What one pass over the covered samples counts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Counts {
    covered: u64,
    zero_normal: u64,
    bad_normal: u64,
    away: u64,
    behind: u64,
    below_near: u64,
    /// Covered albedos with a channel above 1 (more light reflected than arrives), and the largest channel.
    bright_albedo: u64,
    albedo_max: f32,
}

impl Counts {
    fn add(self, o: Counts) -> Counts {
        Counts {
            covered: self.covered + o.covered,
            zero_normal: self.zero_normal + o.zero_normal,
            bad_normal: self.bad_normal + o.bad_normal,
            away: self.away + o.away,
            behind: self.behind + o.behind,
            below_near: self.below_near + o.below_near,
            bright_albedo: self.bright_albedo + o.bright_albedo,
            albedo_max: self.albedo_max.max(o.albedo_max),
        }
    }
}

/// Samples per parallel block of the counting pass.
const CHUNK: usize = 1 << 14;

/// Every per-sample count of [`check`] in one parallel pass over the planes (the counts do not depend on the
/// order): covered samples, zero and invalid normals, valid normals facing away (from the view direction when
/// positions are known, else +z), positions behind the camera, depths nearer than the camera's near plane.
fn count(gb: &GBuffer) -> Counts {
    let near = gb.camera.as_ref().map(|c| c.znear * 0.999);
    let (normal, position, depth) = (gb.normal.as_deref(), gb.position.as_deref(), gb.depth.as_deref());
    let albedo = gb.albedo.as_deref();
    gb.coverage
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(k, cov)| {
            let r = k * CHUNK..k * CHUNK + cov.len();
            let (n, p, d) = (normal.map(|x| &x[r.clone()]), position.map(|x| &x[r.clone()]), depth.map(|x| &x[r]));
            let albedo = albedo.map(|x| &x[k * CHUNK..k * CHUNK + cov.len()]);
            crate::base::isa::run(crate::base::isa::Isa::detect(), CountChunk { cov, n, p, d, albedo, near })
        })
        .reduce(Counts::default, Counts::add)
}

/// A covered normal's checks from its length and its dot product with the direction to the camera (`−p`, or +Z
/// without positions): [near zero, not unit length, valid but facing away]. The one definition, used by [`count`]
/// and by the ISPC reader's row counts.
#[inline(always)]
pub(crate) fn normal_flags(len: f32, facing: f32) -> [bool; 3] {
    let valid = len.is_finite() & ((len - 1.0).abs() <= UNIT_TOLERANCE);
    [len < ZERO_NORMAL, !valid, valid & (facing < 0.0)]
}

/// One block of [`count`]'s pass, compiled for the widest instruction set the CPU has (integer counts and a
/// maximum: the same on every path).
struct CountChunk<'a> {
    cov: &'a [bool],
    n: Option<&'a [glam::Vec3]>,
    p: Option<&'a [glam::Vec3]>,
    d: Option<&'a [f32]>,
    albedo: Option<&'a [glam::Vec3]>,
    near: Option<f32>,
}

impl crate::base::isa::Kernel for CountChunk<'_> {
    type Output = Counts;
    #[inline(always)]
    fn run(self, _: crate::base::isa::Isa) -> Counts {
        let CountChunk { cov, n, p, d, albedo, near } = self;
        // One branch-free loop per plane (each vectorises); `u64::from(covered && test)` counts.
        let mut c = Counts { covered: cov.iter().map(|&c| u64::from(c)).sum(), ..Counts::default() };
        if let Some(n) = n {
            for (j, (n, &cv)) in n.iter().zip(cov).enumerate() {
                let facing = match p {
                    Some(p) => n.dot(-p[j]),
                    None => n.z,
                };
                let [zero, bad, away] = normal_flags(n.length(), facing);
                c.zero_normal += u64::from(cv & zero);
                c.bad_normal += u64::from(cv & bad);
                c.away += u64::from(cv & away);
            }
        }
        if let Some(p) = p {
            c.behind = p.iter().zip(cov).map(|(p, &cv)| u64::from(cv && p.z >= 0.0)).sum();
        }
        if let (Some(d), Some(near)) = (d, near) {
            c.below_near = d.iter().zip(cov).map(|(d, &cv)| u64::from(cv && *d < near)).sum();
        }
        if let Some(a) = albedo {
            for (a, &cv) in a.iter().zip(cov) {
                let m = if cv { a.max_element() } else { 0.0 };
                c.bright_albedo += u64::from(m > 1.0);
                c.albedo_max = c.albedo_max.max(m);
            }
        }
        c
    }
}

/// What one pass over a G-buffer's samples counts for the checks, with the planes it has: of a whole frame
/// ([`Survey::of`]), or summed over its bands (a frame decoded band by band, never whole).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Survey {
    counts: Counts,
    samples: u64,
    normal: bool,
    position: bool,
    depth: bool,
    albedo: bool,
}

impl Survey {
    /// The survey of `gb`'s samples.
    pub(crate) fn of(gb: &GBuffer) -> Survey {
        Survey {
            counts: count(gb),
            samples: gb.len() as u64,
            normal: gb.normal.is_some(),
            position: gb.position.is_some(),
            depth: gb.depth.is_some(),
            albedo: gb.albedo.is_some(),
        }
    }

    /// The survey of `samples` samples with every plane but albedo, from counts taken elsewhere: the ISPC reader's
    /// row counts, counted row by row as it converts them, with `count`'s definitions.
    pub(crate) fn of_counts(samples: u64, [covered, zero_normal, bad_normal, away, below_near]: [u64; 5]) -> Survey {
        Survey {
            counts: Counts { covered, zero_normal, bad_normal, away, below_near, ..Counts::default() },
            samples,
            normal: true,
            position: true,
            depth: true,
            albedo: false,
        }
    }

    /// The survey of two disjoint parts of one frame.
    pub(crate) fn add(self, o: Survey) -> Survey {
        Survey {
            counts: self.counts.add(o.counts),
            samples: self.samples + o.samples,
            normal: self.normal | o.normal,
            position: self.position | o.position,
            depth: self.depth | o.depth,
            albedo: self.albedo | o.albedo,
        }
    }
}

/// Runs every check on `gb`. `depth_read` says the depth plane came from the file (not derived from positions);
/// `positions_read` that the positions did (not derived from depth through the camera, which makes them agree
/// with depth and reproject exactly by construction: those two checks are skipped); `positions_assumed` that the
/// sample positions were not in the file.
pub fn check(
    gb: &GBuffer,
    depth_read: bool,
    positions_read: bool,
    positions_assumed: bool,
    path: &Path,
) -> Result<Vec<Warning>> {
    // One pass counts what every check below needs, without a list of the covered samples' indices (8 bytes per
    // sample: 66 MB on a 1080p × 4 dump, on top of the G-buffer).
    let survey = Survey::of(gb);
    judge(&survey, gb, positions_assumed, path, |out, nc| {
        let Some(p) = &gb.position else { return };
        let covered = || (0..gb.len()).into_par_iter().filter(|&i| gb.coverage[i]);
        if let (Some(d), true, true) = (&gb.depth, depth_read, positions_read) {
            let off: Vec<usize> =
                covered().filter(|&i| (-p[i].z - d[i]).abs() > POSITION_DEPTH_REL * d[i].abs().max(1e-3)).collect();
            if !off.is_empty() {
                let mut ratios: Vec<f32> = off.iter().map(|&i| d[i] / -p[i].z).filter(|r| r.is_finite()).collect();
                ratios.sort_by(f32::total_cmp);
                let median = ratios.get(ratios.len() / 2).copied().unwrap_or(f32::NAN);
                let hint = if median > 1.0 && median < 2.0 {
                    " — depth is larger than −z by about the ray length: ray distance (--depth ray or ray-from-near)?"
                } else if median < 0.2 {
                    " — depth is far smaller than −z: normalised or NDC depth (--depth ndc)?"
                } else {
                    ""
                };
                out.push(Warning {
                    code: "position-depth",
                    count: off.len() as u64,
                    of: nc,
                    message: format!(
                        "{} of {nc} covered samples have depth ≠ −position.z by more than {POSITION_DEPTH_REL} \
                         relative (median depth / −z = {median:.4}){hint}",
                        off.len()
                    ),
                });
            }
        }
        if let Some((median, max, far)) = positions_read.then(|| reprojection(gb)).flatten() {
            if far > 0 {
                out.push(Warning {
                    code: "reprojection",
                    count: far,
                    of: nc,
                    message: format!(
                        "{far} of {nc} covered positions reproject through the camera more than {REPROJECTION_PX} px \
                         from their sample (median {median:.3} px, max {max:.2} px): the camera (field of view, \
                         aspect, principal point: sidecar `intrinsics`) or the positions' space is off"
                    ),
                });
            }
        }
    })
}

/// The checks on a frame's survey: `like` gives its camera and sample count (its planes are not read: `survey`
/// says which the frame has). `read_positions` adds, after the behind-camera check of a frame with positions,
/// the checks that need the planes themselves (positions read from the file against depth and the camera); it is
/// given the covered count.
pub(crate) fn judge(
    survey: &Survey,
    like: &GBuffer,
    positions_assumed: bool,
    path: &Path,
    read_positions: impl FnOnce(&mut Vec<Warning>, u64),
) -> Result<Vec<Warning>> {
    let mut out = Vec::new();
    let counts = survey.counts;
    let nc = counts.covered;
    let pct = |k: u64| 100.0 * k as f64 / nc.max(1) as f64;
    if nc == 0 {
        out.push(Warning {
            code: "no-surface",
            count: survey.samples,
            of: survey.samples,
            message: "every sample is background: nothing to shade (is the background marker right? --background)"
                .into(),
        });
        return Ok(out);
    }
    if survey.normal {
        let (zero, bad) = (counts.zero_normal, counts.bad_normal);
        if bad > 0 {
            out.push(Warning {
                code: "invalid-normals",
                count: bad,
                of: nc,
                message: format!(
                    "{bad} of {nc} covered samples ({:.2}%) have invalid normals: {zero} zero, {} not unit length \
                     (|len − 1| > {UNIT_TOLERANCE}); codec errors skip them{}",
                    pct(bad),
                    bad - zero,
                    if bad * 2 > nc {
                        " — most normals are not unit: is another buffer mapped as normal?"
                    } else {
                        ""
                    }
                ),
            });
        }
        let away = counts.away;
        if away * 4 > nc {
            out.push(Warning {
                code: "normals-face-away",
                count: away,
                of: nc,
                message: format!(
                    "{away} of {nc} covered normals ({:.1}%) face away from the camera: world-space normals read \
                     as view space (--space world), a flipped axis, or n·0.5+0.5 read as signed (--normals unorm)?",
                    pct(away)
                ),
            });
        }
    }
    if survey.position {
        let behind = counts.behind;
        if behind > 0 {
            let msg = format!(
                "{behind} of {nc} covered positions ({:.1}%) are behind the camera (z ≥ 0 in view space): \
                 world-space positions read as view space? (--space world with a camera, or the preset)",
                pct(behind)
            );
            if behind as f64 >= BEHIND_CAMERA_FAIL * nc as f64 {
                return Err(Error::invalid(path, format!("{msg}. These cannot be view-space positions.")));
            }
            out.push(Warning { code: "behind-camera", count: behind, of: nc, message: msg });
        }
        read_positions(&mut out, nc);
    }
    if let (true, Some(cam)) = (survey.depth, &like.camera) {
        let below = counts.below_near;
        if below * 2 > nc {
            out.push(Warning {
                code: "depth-convention",
                count: below,
                of: nc,
                message: format!(
                    "{below} of {nc} covered depths ({:.1}%) are nearer than the camera's near plane {}: NDC or \
                     normalised depth read as view depth (--depth ndc)?",
                    pct(below),
                    cam.znear
                ),
            });
        }
    }
    if survey.albedo && counts.bright_albedo > 0 {
        let bright = counts.bright_albedo;
        out.push(Warning {
            code: "albedo-above-one",
            count: bright,
            of: nc,
            message: format!(
                "{bright} of {nc} covered albedos ({:.2}%) have a channel above 1 (up to {:.3}): a surface cannot \
                 reflect more light than arrives. A renderer's colour pass that holds more than the base colour \
                 (emission, a texture's unclamped range, a multiplied tint)? Codecs for [0, 1] clamp these, and the \
                 clamp shows up as layout error",
                pct(bright),
                counts.albedo_max
            ),
        });
    }
    if positions_assumed && like.samples > 1 {
        out.push(Warning {
            code: "sample-positions-assumed",
            count: survey.samples,
            of: survey.samples,
            message: format!(
                "the file gives no sample positions: assumed the standard D3D/Vulkan {}× pattern (an OpenGL dump \
                 stored top row first has it mirrored in y); give them to be sure: the `gbuf.sample_positions` header \
                 attribute of an EXR, or `sample_positions` in the sidecar for packed targets and file sets",
                like.samples
            ),
        });
    }
    Ok(out)
}

/// How far covered positions in front of the camera reproject from their own sample, in pixels: (median, max,
/// count beyond [`REPROJECTION_PX`]). `None` without positions, camera or such samples.
#[must_use]
pub fn reprojection(gb: &GBuffer) -> Option<(f32, f32, u64)> {
    let (p, cam) = (gb.position.as_ref()?, gb.camera.as_ref()?);
    let spp = gb.samples as usize;
    let proj = cam.projector(gb.width, gb.height);
    let mut errs: Vec<f32> = (0..gb.len())
        .into_par_iter()
        .filter(|&i| gb.coverage[i] && p[i].z < 0.0)
        .filter_map(|i| {
            let pix = i / spp;
            let at = Vec2::new((pix as u32 % gb.width) as f32 + 0.5, (pix as u32 / gb.width) as f32 + 0.5)
                + gb.sample_positions[i % spp];
            proj.project(p[i]).map(|q| (q - at).length())
        })
        .collect();
    if errs.is_empty() {
        return None;
    }
    let far = errs.par_iter().filter(|e| **e > REPROJECTION_PX).count() as u64;
    let max = errs.par_iter().copied().reduce(|| f32::NEG_INFINITY, f32::max);
    // The median by selection, not a full sort (the same element a sort would put in the middle).
    let mid = errs.len() / 2;
    let (_, median, _) = errs.select_nth_unstable_by(mid, f32::total_cmp);
    Some((*median, max, far))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Camera;
    use glam::Vec3;

    /// A 40×30 × 2 G-buffer with positions through `cam` at depth 5, normals towards the camera, and the listed
    /// samples changed: `away` normals flipped, `bad` normals halved, `near` depths set inside the near plane.
    fn frame(cam: Camera, away: &[usize], bad: &[usize], near: &[usize]) -> GBuffer {
        let mut gb = GBuffer::new(40, 30, 2).unwrap();
        gb.camera = Some(cam);
        gb.coverage = (0..gb.len()).map(|i| i % 7 != 0).collect();
        gb.depth = Some(vec![5.0; gb.len()]);
        gb.fill_position_from_depth();
        let p = gb.position.clone().unwrap();
        gb.normal = Some(p.iter().map(|p| (-*p).normalize_or(Vec3::Z)).collect());
        let n = gb.normal.as_mut().unwrap();
        for &i in away {
            n[i] = -n[i];
        }
        for &i in bad {
            n[i] *= 0.5;
        }
        for &i in near {
            gb.depth.as_mut().unwrap()[i] = 0.01;
        }
        gb
    }

    #[test]
    fn one_pass_counts_every_check() {
        let cam = Camera::identity(0.9, 40.0 / 30.0, 0.1, 100.0);
        let covered: Vec<usize> = (0..2400).filter(|i| i % 7 != 0).collect();
        // Covered samples only count: 1 and 8 are covered, 0 and 7 are not.
        let gb = frame(cam, &covered[..700], &[1, 8, 0, 7], &covered[..1100]);
        let c = count(&gb);
        assert_eq!(c.covered, covered.len() as u64);
        assert_eq!((c.bad_normal, c.zero_normal, c.behind, c.below_near), (2, 0, 0, 1100));
        assert_eq!(c.away, 700 - 2, "the two halved normals are invalid, not away");
        let w = check(&gb, true, true, false, Path::new("f")).unwrap();
        let codes: Vec<&str> = w.iter().map(|w| w.code).collect();
        assert_eq!(codes, ["invalid-normals", "normals-face-away", "position-depth", "depth-convention"], "{w:?}");
    }

    /// Positions read from a file are reprojected through the camera; positions the loader derived from depth
    /// through that camera agree by construction, and the check is skipped.
    #[test]
    fn albedo_above_one_is_counted_on_covered_samples_only_with_its_largest_channel() {
        let mut gb = frame(Camera::identity(0.9, 40.0 / 30.0, 0.1, 100.0), &[], &[], &[]);
        let mut albedo = vec![Vec3::splat(0.5); gb.len()];
        albedo[1] = Vec3::new(0.2, 3.81, 0.4); // covered
        albedo[8] = Vec3::new(1.5, 0.0, 0.0); // covered
        albedo[0] = Vec3::splat(9.0); // background: not counted
        gb.albedo = Some(albedo);
        let c = count(&gb);
        assert_eq!((c.bright_albedo, c.albedo_max), (2, 3.81));
        let w = check(&gb, true, true, false, Path::new("f")).unwrap();
        let bright: Vec<&Warning> = w.iter().filter(|w| w.code == "albedo-above-one").collect();
        assert_eq!(bright.len(), 1, "{w:?}");
        assert!(bright[0].count == 2 && bright[0].message.contains("3.810"), "{}", bright[0].message);
        gb.albedo.as_mut().unwrap()[1] = Vec3::ONE; // exactly 1 is plausible
        gb.albedo.as_mut().unwrap()[8] = Vec3::ONE;
        assert!(check(&gb, true, true, false, Path::new("f")).unwrap().iter().all(|w| w.code != "albedo-above-one"));
    }

    #[test]
    fn reprojection_is_checked_for_positions_read_not_derived() {
        let gb = frame(Camera::identity(0.9, 40.0 / 30.0, 0.1, 100.0), &[], &[], &[]);
        let mut wrong = gb.clone();
        wrong.camera = Some(Camera::identity(1.2, 40.0 / 30.0, 0.1, 100.0));
        let codes = |gb: &GBuffer, read: bool| -> Vec<&'static str> {
            check(gb, true, read, false, Path::new("f")).unwrap().iter().map(|w| w.code).collect()
        };
        assert!(codes(&gb, true).is_empty());
        assert_eq!(codes(&wrong, true), ["reprojection"]);
        assert!(codes(&wrong, false).is_empty(), "derived positions are not reprojected");
    }
}
