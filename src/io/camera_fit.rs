//! Recovering the camera from a world-space position pass by least squares (positions ↔ pixel coordinates), for
//! dumps that come without a sidecar (Blender, Mitsuba).
//!
//! Method: the direct linear transform (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., §7.1, with the
//! normalisation of §4.4.4) on a deterministic subsample of the covered samples gives a 3×4 projection; an RQ
//! decomposition splits it into intrinsics and pose. Our [`Camera`] has a centred principal point and no skew, so the
//! pose, field of view and aspect are then refined by damped Gauss–Newton on the reprojection error under exactly
//! that model, and the RMS reprojection error in pixels is returned so the caller can judge the fit.
//!
//! Degenerate input gives `None`: fewer than [`MIN_POINTS`] finite points, points (nearly) on one plane, pixels
//! (nearly) on one line (points on a plane through the camera centre), or a solution that puts the points behind
//! the camera.

use crate::camera::Camera;
use glam::{DMat3, DMat4, DVec3, Mat4, Vec2, Vec3};

/// Fewest point ↔ pixel pairs we attempt a fit with (the DLT needs 6; a few more make degeneracy detectable).
pub const MIN_POINTS: usize = 8;
/// Most points the fit uses; larger inputs are subsampled with a fixed stride (deterministic).
pub const MAX_FIT_POINTS: usize = 4096;
/// Smallest/largest eigenvalue ratio of the normalised point (or pixel) covariance below which the points are
/// treated as coplanar (collinear): a plane with 1% thickness relative to its extent gives 1e-4.
const FLATNESS_RATIO: f64 = 1e-5;
/// Gauss–Newton iterations of the refinement (it converges in a handful on consistent data).
const REFINE_ITERATIONS: usize = 20;
/// Rounds of outlier rejection after the first fit.
const OUTLIER_ROUNDS: usize = 3;
/// A point is an outlier when its reprojection error exceeds this multiple of the median error ...
const OUTLIER_FACTOR: f64 = 4.0;
/// ... and this many pixels (so that exact data, with tiny errors, keeps every point).
const OUTLIER_FLOOR_PX: f64 = 0.5;
/// At least this many tenths of the points must survive the rejection, else the fit is refused.
const MIN_INLIER_TENTHS: usize = 8;

/// Fits a camera to `world_positions[i]` seen at continuous pixel coordinates `pixel_coords[i]` ((0, 0) = top-left
/// corner, pixel centres at +0.5, +y down) in a `width × height` image. Returns the camera (its near/far planes
/// bracket the points' depths) and the RMS reprojection error in pixels over the points kept (outliers — more than
/// 4× the median error and 0.5 px — are dropped in up to three refits; more than 20% outliers gives `None`);
/// `None` when the input is degenerate.
#[must_use]
pub fn fit_camera(world_positions: &[Vec3], pixel_coords: &[Vec2], width: u32, height: u32) -> Option<(Camera, f32)> {
    if width == 0 || height == 0 {
        return None;
    }
    let pairs: Vec<(DVec3, [f64; 2])> = world_positions
        .iter()
        .zip(pixel_coords)
        .filter(|(p, q)| p.is_finite() && q.is_finite())
        .map(|(p, q)| (p.as_dvec3(), [f64::from(q.x), f64::from(q.y)]))
        .collect();
    if pairs.len() < MIN_POINTS {
        return None;
    }
    let stride = pairs.len().div_ceil(MAX_FIT_POINTS);
    let pts: Vec<(DVec3, [f64; 2])> = pairs.into_iter().step_by(stride).collect();
    if pts.len() < MIN_POINTS || is_flat(&pts) {
        return None;
    }
    let (w, h) = (f64::from(width), f64::from(height));
    let all = pts.len();
    let mut pts = pts;
    let mut model = refine(decompose(&dlt(&pts)?, w, h)?, &pts, w, h);
    // Outlier rejection: samples that mix two surfaces (pixel-filtered edges), stray values. Keep points within
    // OUTLIER_FACTOR × the median error (at least OUTLIER_FLOOR_PX) and fit again.
    for _ in 0..OUTLIER_ROUNDS {
        let errs = model.errors(&pts, w, h);
        let mut sorted = errs.clone();
        sorted.sort_by(f64::total_cmp);
        let limit = (OUTLIER_FACTOR * sorted[sorted.len() / 2]).max(OUTLIER_FLOOR_PX);
        if sorted.last().is_some_and(|e| *e <= limit) {
            break;
        }
        pts = pts.into_iter().zip(&errs).filter(|(_, e)| **e <= limit).map(|(p, _)| p).collect();
        if pts.len() * 10 < all * MIN_INLIER_TENTHS || is_flat(&pts) {
            return None;
        }
        let start = dlt(&pts).and_then(|p| decompose(&p, w, h)).unwrap_or(model);
        model = refine(start, &pts, w, h);
    }
    let rms = model.rms(&pts, w, h);
    let depths: Vec<f64> = pts.iter().map(|(x, _)| -(model.rot * *x + model.t).z).collect();
    let front = depths.iter().filter(|d| **d > 0.0).count();
    if front * 10 < pts.len() * 9 || !rms.is_finite() {
        return None;
    }
    let dmin = depths.iter().copied().filter(|d| *d > 0.0).fold(f64::INFINITY, f64::min);
    let dmax = depths.iter().copied().fold(0.0, f64::max);
    let cam = model.camera((0.5 * dmin).max(1e-4), (2.0 * dmax).max(1e-3));
    cam.is_valid().then_some((cam, rms as f32))
}

/// Is the point set (or its image) degenerate: all points nearly on a plane, or all pixels nearly on a line?
fn is_flat(pts: &[(DVec3, [f64; 2])]) -> bool {
    let n = pts.len() as f64;
    let mean = pts.iter().map(|(p, _)| *p).sum::<DVec3>() / n;
    let mut cov = [0.0f64; 9];
    let (mut pm, mut pc) = ([0.0f64; 2], [0.0f64; 4]);
    for (p, q) in pts {
        let d = *p - mean;
        let d = [d.x, d.y, d.z];
        for r in 0..3 {
            for c in 0..3 {
                cov[r * 3 + c] += d[r] * d[c] / n;
            }
        }
        pm[0] += q[0] / n;
        pm[1] += q[1] / n;
    }
    for (_, q) in pts {
        let d = [q[0] - pm[0], q[1] - pm[1]];
        for r in 0..2 {
            for c in 0..2 {
                pc[r * 2 + c] += d[r] * d[c] / n;
            }
        }
    }
    let (ev3, _) = jacobi_eigen(&cov, 3);
    let (ev2, _) = jacobi_eigen(&pc, 2);
    let ratio = |ev: &[f64]| {
        let max = ev.iter().copied().fold(0.0, f64::max);
        let min = ev.iter().copied().fold(f64::INFINITY, f64::min);
        if max > 0.0 {
            min / max
        } else {
            0.0
        }
    };
    ratio(&ev3) < FLATNESS_RATIO || ratio(&ev2) < FLATNESS_RATIO
}

/// Normalised DLT: the 3×4 projection (row-major) minimising the algebraic error.
fn dlt(pts: &[(DVec3, [f64; 2])]) -> Option<[[f64; 4]; 3]> {
    let n = pts.len() as f64;
    let cw = pts.iter().map(|(p, _)| *p).sum::<DVec3>() / n;
    let sw = 3f64.sqrt() / (pts.iter().map(|(p, _)| (*p - cw).length()).sum::<f64>() / n);
    let cp = [pts.iter().map(|(_, q)| q[0]).sum::<f64>() / n, pts.iter().map(|(_, q)| q[1]).sum::<f64>() / n];
    let sp = 2f64.sqrt()
        / (pts.iter().map(|(_, q)| ((q[0] - cp[0]).powi(2) + (q[1] - cp[1]).powi(2)).sqrt()).sum::<f64>() / n);
    if !(sw.is_finite() && sp.is_finite()) {
        return None;
    }
    let mut ata = [0.0f64; 144];
    for (p, q) in pts {
        let x = (*p - cw) * sw;
        let (u, v) = ((q[0] - cp[0]) * sp, (q[1] - cp[1]) * sp);
        let xh = [x.x, x.y, x.z, 1.0];
        let mut r1 = [0.0; 12];
        let mut r2 = [0.0; 12];
        for k in 0..4 {
            r1[k] = xh[k];
            r1[8 + k] = -u * xh[k];
            r2[4 + k] = xh[k];
            r2[8 + k] = -v * xh[k];
        }
        for r in 0..12 {
            for c in 0..12 {
                ata[r * 12 + c] += r1[r] * r1[c] + r2[r] * r2[c];
            }
        }
    }
    let (vals, vecs) = jacobi_eigen(&ata, 12);
    let k = (0..12).min_by(|&a, &b| vals[a].total_cmp(&vals[b]))?;
    let pn: Vec<f64> = (0..12).map(|r| vecs[r * 12 + k]).collect();
    // Undo the normalisation: P = Tp⁻¹ · Pn · Tw, with Tw = [sw·I | −sw·cw] and Tp⁻¹ = [I/sp | cp].
    let tw = [[sw, 0.0, 0.0, -sw * cw.x], [0.0, sw, 0.0, -sw * cw.y], [0.0, 0.0, sw, -sw * cw.z], [0.0, 0.0, 0.0, 1.0]];
    let tp_inv = [[1.0 / sp, 0.0, cp[0]], [0.0, 1.0 / sp, cp[1]], [0.0, 0.0, 1.0]];
    let mut pnt = [[0.0; 4]; 3];
    for (r, row) in pnt.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = (0..4).map(|k| pn[r * 4 + k] * tw[k][c]).sum();
        }
    }
    let mut out = [[0.0; 4]; 3];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| tp_inv[r][k] * pnt[k][c]).sum();
        }
    }
    out.iter().flatten().all(|v| v.is_finite()).then_some(out)
}

/// Pose and projection under our camera model, in view space (+Y up, looking along −Z).
#[derive(Clone, Copy, Debug)]
struct Model {
    rot: DMat3,
    t: DVec3,
    /// tan(yfov / 2).
    tan: f64,
    aspect: f64,
}

impl Model {
    fn project(&self, x: DVec3, w: f64, h: f64) -> Option<[f64; 2]> {
        let p = self.rot * x + self.t;
        if p.z >= 0.0 {
            return None;
        }
        let ndc_x = p.x / (-p.z * self.tan * self.aspect);
        let ndc_y = p.y / (-p.z * self.tan);
        Some([(ndc_x + 1.0) * 0.5 * w, (1.0 - ndc_y) * 0.5 * h])
    }

    /// Per-point reprojection errors in pixels (infinite behind the camera).
    fn errors(&self, pts: &[(DVec3, [f64; 2])], w: f64, h: f64) -> Vec<f64> {
        pts.iter()
            .map(|(x, q)| self.project(*x, w, h).map_or(f64::INFINITY, |p| (p[0] - q[0]).hypot(p[1] - q[1])))
            .collect()
    }

    fn rms(&self, pts: &[(DVec3, [f64; 2])], w: f64, h: f64) -> f64 {
        let mut sum = 0.0;
        for (x, q) in pts {
            match self.project(*x, w, h) {
                Some(p) => sum += (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2),
                None => return f64::INFINITY,
            }
        }
        (sum / pts.len() as f64).sqrt()
    }

    fn camera(&self, znear: f64, zfar: f64) -> Camera {
        let m = DMat4::from_cols(
            self.rot.x_axis.extend(0.0),
            self.rot.y_axis.extend(0.0),
            self.rot.z_axis.extend(0.0),
            self.t.extend(1.0),
        );
        Camera {
            world_to_view: Mat4::from_cols_array(&m.to_cols_array().map(|v| v as f32)),
            yfov: (2.0 * self.tan.atan()) as f32,
            aspect: self.aspect as f32,
            znear: znear as f32,
            zfar: zfar as f32,
            principal: glam::Vec2::ZERO,
        }
    }
}

/// RQ-decomposes the 3×4 projection into K·[R | t] (computer-vision axes: +y down, +z forward), then converts to
/// our view axes and drops principal point and skew.
fn decompose(p: &[[f64; 4]; 3], w: f64, h: f64) -> Option<Model> {
    let row = |r: usize| DVec3::new(p[r][0], p[r][1], p[r][2]);
    let (mut m1, mut m2, mut m3) = (row(0), row(1), row(2));
    let mut p4 = DVec3::new(p[0][3], p[1][3], p[2][3]);
    if DMat3::from_cols(m1, m2, m3).determinant() < 0.0 {
        (m1, m2, m3, p4) = (-m1, -m2, -m3, -p4);
    }
    let k22 = m3.length();
    if k22 <= 0.0 {
        return None;
    }
    let r3 = m3 / k22;
    let k12 = m2.dot(r3);
    let m2p = m2 - k12 * r3;
    let k11 = m2p.length();
    let r2 = m2p / k11;
    let (k02, k01) = (m1.dot(r3), m1.dot(r2));
    let m1p = m1 - k02 * r3 - k01 * r2;
    let k00 = m1p.length();
    let r1 = m1p / k00;
    // t = K⁻¹ p4 (K upper triangular).
    let tz = p4.z / k22;
    let ty = (p4.y - k12 * tz) / k11;
    let tx = (p4.x - k01 * ty - k02 * tz) / k00;
    let (fx, fy) = (k00 / k22, k11 / k22);
    if !(fx > 0.0 && fy > 0.0 && fx.is_finite() && fy.is_finite()) {
        return None;
    }
    // Computer-vision camera axes (x right, y down, z forward) → ours (x right, y up, z backward).
    let rot = DMat3::from_cols(r1, -r2, -r3).transpose();
    let t = DVec3::new(tx, -ty, -tz);
    let tan = h / (2.0 * fy);
    let aspect = w * fy / (h * fx);
    Some(Model { rot, t, tan, aspect })
}

/// Damped Gauss–Newton on (rotation increment, translation, log tan, log aspect) with a numeric Jacobian; keeps a
/// step only when it lowers the reprojection error.
fn refine(mut m: Model, pts: &[(DVec3, [f64; 2])], w: f64, h: f64) -> Model {
    let mut err = m.rms(pts, w, h);
    let mut lambda = 1e-3;
    let apply = |m: &Model, d: &[f64; 8]| Model {
        rot: DMat3::from_quat(glam::DQuat::from_scaled_axis(DVec3::new(d[0], d[1], d[2]))) * m.rot,
        t: m.t + DVec3::new(d[3], d[4], d[5]),
        tan: m.tan * d[6].exp(),
        aspect: m.aspect * d[7].exp(),
    };
    let residuals = |m: &Model| -> Option<Vec<f64>> {
        let mut r = Vec::with_capacity(2 * pts.len());
        for (x, q) in pts {
            let p = m.project(*x, w, h)?;
            r.push(p[0] - q[0]);
            r.push(p[1] - q[1]);
        }
        Some(r)
    };
    for _ in 0..REFINE_ITERATIONS {
        let Some(r0) = residuals(&m) else { break };
        let scale = 1e-6 * (1.0 + m.t.length());
        let mut jac = vec![[0.0f64; 8]; r0.len()];
        for k in 0..8 {
            let mut d = [0.0; 8];
            d[k] = if (3..6).contains(&k) { scale } else { 1e-6 };
            let Some(rk) = residuals(&apply(&m, &d)) else { return m };
            for (j, row) in jac.iter_mut().enumerate() {
                row[k] = (rk[j] - r0[j]) / d[k];
            }
        }
        let mut jtj = [0.0f64; 64];
        let mut jtr = [0.0f64; 8];
        for (row, r) in jac.iter().zip(&r0) {
            for a in 0..8 {
                jtr[a] -= row[a] * r;
                for b in 0..8 {
                    jtj[a * 8 + b] += row[a] * row[b];
                }
            }
        }
        let mut improved = false;
        for _ in 0..8 {
            let mut a = jtj;
            for k in 0..8 {
                a[k * 9] *= 1.0 + lambda;
            }
            let Some(step) = solve8(a, jtr) else { break };
            let cand = apply(&m, &step);
            let e = cand.rms(pts, w, h);
            if e < err {
                (m, err, improved) = (cand, e, true);
                lambda = (lambda * 0.3).max(1e-9);
                break;
            }
            lambda *= 10.0;
        }
        if !improved || err < 1e-9 {
            break;
        }
    }
    m
}

/// Solves the 8×8 system `a x = b` by Gaussian elimination with partial pivoting.
fn solve8(mut a: [f64; 64], mut b: [f64; 8]) -> Option<[f64; 8]> {
    for col in 0..8 {
        let piv = (col..8).max_by(|&i, &j| a[i * 8 + col].abs().total_cmp(&a[j * 8 + col].abs()))?;
        if a[piv * 8 + col].abs() < 1e-300 {
            return None;
        }
        for k in 0..8 {
            a.swap(col * 8 + k, piv * 8 + k);
        }
        b.swap(col, piv);
        for r in col + 1..8 {
            let f = a[r * 8 + col] / a[col * 8 + col];
            for k in col..8 {
                a[r * 8 + k] -= f * a[col * 8 + k];
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0; 8];
    for r in (0..8).rev() {
        let s: f64 = (r + 1..8).map(|k| a[r * 8 + k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r * 8 + r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Eigen-decomposition of a symmetric `n × n` matrix (row-major) by cyclic Jacobi rotations. Returns the
/// eigenvalues and the eigenvectors as the columns of a row-major `n × n` matrix.
fn jacobi_eigen(m: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut a = m.to_vec();
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    let norm: f64 = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    for _sweep in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i * n + j].powi(2))
            .sum();
        if off.sqrt() <= 1e-22 * norm.max(1e-300) {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| a[i * n + i]).collect(), v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;

    /// Exact synthetic correspondences (f32 input) recover the camera to f32 precision; these bounds leave room for
    /// the f32 rounding of positions and pixels, nothing more.
    const ANGLE_TOL: f32 = 1e-4;
    const POSE_TOL: f32 = 1e-3;
    const RMS_TOL_PX: f32 = 1e-3;

    fn scene_points(cam: &Camera, w: u32, h: u32, seed: u64, n: usize) -> (Vec<Vec3>, Vec<Vec2>) {
        let inv = cam.world_to_view.inverse();
        let mut rng = SplitMix64::new(seed);
        let (mut ps, mut qs) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let px = Vec2::new(rng.range_f32(0.0, w as f32), rng.range_f32(0.0, h as f32));
            let d = rng.range_f32(2.0, 30.0);
            let world = inv.transform_point3(cam.view_position(px, d, w, h));
            ps.push(world);
            qs.push(cam.project(cam.to_view_point(world), w, h).unwrap());
        }
        (ps, qs)
    }

    #[test]
    fn recovers_a_known_camera() {
        let cases = [
            Camera::look_at(Vec3::new(3.0, 2.0, 8.0), Vec3::new(0.0, 0.5, 0.0), Vec3::Y, 0.7, 4.0 / 3.0, 0.1, 100.0),
            Camera::look_at(Vec3::new(-5.0, 1.0, -2.0), Vec3::new(1.0, 0.0, 3.0), Vec3::Z, 1.2, 16.0 / 9.0, 0.1, 50.0),
            Camera::identity(0.4, 1.0, 0.1, 100.0),
        ];
        for (i, cam) in cases.iter().enumerate() {
            let (w, h) = ((96.0 * cam.aspect) as u32, 96);
            let cam = Camera { aspect: w as f32 / h as f32, ..*cam };
            let (ps, qs) = scene_points(&cam, w, h, i as u64, 500);
            let (fit, rms) = fit_camera(&ps, &qs, w, h).expect("fit");
            assert!(rms < RMS_TOL_PX, "case {i}: rms {rms}");
            assert!((fit.yfov - cam.yfov).abs() < ANGLE_TOL, "case {i}: yfov {} vs {}", fit.yfov, cam.yfov);
            assert!((fit.aspect - cam.aspect).abs() < ANGLE_TOL, "case {i}: aspect {} vs {}", fit.aspect, cam.aspect);
            let diff = (fit.world_to_view - cam.world_to_view).abs_diff_eq(Mat4::ZERO, POSE_TOL);
            assert!(diff, "case {i}:\n{}\nvs\n{}", fit.world_to_view, cam.world_to_view);
            // Every point is inside the fitted clip range.
            for p in &ps {
                let d = -fit.to_view_point(*p).z;
                assert!(d > fit.znear && d < fit.zfar);
            }
        }
    }

    #[test]
    fn noisy_pixels_give_a_close_fit_and_an_honest_rms() {
        let cam = Camera::look_at(Vec3::new(2.0, 3.0, 6.0), Vec3::ZERO, Vec3::Y, 0.8, 1.5, 0.1, 100.0);
        let (ps, mut qs) = scene_points(&cam, 150, 100, 9, 2000);
        let mut rng = SplitMix64::new(1);
        for q in &mut qs {
            *q += Vec2::new(rng.range_f32(-0.25, 0.25), rng.range_f32(-0.25, 0.25));
        }
        let (fit, rms) = fit_camera(&ps, &qs, 150, 100).unwrap();
        // Uniform noise of ±0.25 px per axis has an RMS of 0.25·√(2/3) ≈ 0.204 px.
        assert!((0.15..0.25).contains(&rms), "rms {rms}");
        assert!((fit.yfov - cam.yfov).abs() < 5e-3, "yfov {} vs {}", fit.yfov, cam.yfov);
    }

    #[test]
    fn outliers_are_rejected() {
        let cam = Camera::look_at(Vec3::new(-2.0, 4.0, 7.0), Vec3::ZERO, Vec3::Y, 0.9, 1.25, 0.1, 100.0);
        let (mut ps, qs) = scene_points(&cam, 120, 96, 11, 1000);
        let mut rng = SplitMix64::new(2);
        // 8% of the positions replaced by unrelated points (some behind the camera).
        for p in ps.iter_mut().step_by(12) {
            *p = Vec3::new(rng.range_f32(-20.0, 20.0), rng.range_f32(-20.0, 20.0), rng.range_f32(-20.0, 20.0));
        }
        let (fit, rms) = fit_camera(&ps, &qs, 120, 96).expect("fit despite outliers");
        assert!(rms < RMS_TOL_PX, "rms over inliers {rms}");
        assert!((fit.yfov - cam.yfov).abs() < ANGLE_TOL, "yfov {} vs {}", fit.yfov, cam.yfov);
        assert!(fit.world_to_view.abs_diff_eq(cam.world_to_view, POSE_TOL));
        // Half the points wrong: no fit rather than a wrong one.
        for p in ps.iter_mut().step_by(2) {
            *p = Vec3::new(rng.range_f32(-20.0, 20.0), rng.range_f32(-20.0, 20.0), rng.range_f32(-20.0, 20.0));
        }
        assert!(fit_camera(&ps, &qs, 120, 96).is_none_or(|(_, rms)| rms > 1.0));
    }

    #[test]
    fn degenerate_input_gives_none() {
        let cam = Camera::look_at(Vec3::new(0.0, 3.0, 6.0), Vec3::ZERO, Vec3::Y, 0.8, 1.0, 0.1, 100.0);
        let (ps, qs) = scene_points(&cam, 64, 64, 3, 300);
        // Too few points.
        assert!(fit_camera(&ps[..5], &qs[..5], 64, 64).is_none());
        // Mismatched lengths use the common prefix; empty input is degenerate.
        assert!(fit_camera(&[], &qs, 64, 64).is_none());
        // All points on one plane (a floor seen from above).
        let inv = cam.world_to_view.inverse();
        let mut rng = SplitMix64::new(5);
        let (mut fp, mut fq) = (Vec::new(), Vec::new());
        for _ in 0..300 {
            let p = Vec3::new(rng.range_f32(-3.0, 3.0), 0.0, rng.range_f32(-3.0, 3.0));
            if let Some(q) = cam.project(cam.to_view_point(p), 64, 64) {
                fp.push(p);
                fq.push(q);
            }
        }
        assert!(fp.len() > 100);
        assert!(fit_camera(&fp, &fq, 64, 64).is_none());
        // Points on a plane through the camera centre: they all image onto one line.
        let (mut lp, mut lq) = (Vec::new(), Vec::new());
        for _ in 0..300 {
            let v = Vec3::new(rng.range_f32(-1.0, 1.0), 0.0, -rng.range_f32(1.0, 20.0));
            lp.push(inv.transform_point3(v));
            lq.push(cam.project(v, 64, 64).unwrap());
        }
        assert!(fit_camera(&lp, &lq, 64, 64).is_none());
        // Non-finite values are skipped, leaving too few.
        let nan = vec![Vec3::NAN; 50];
        assert!(fit_camera(&nan, &qs[..50], 64, 64).is_none());
    }

    #[test]
    fn jacobi_diagonalises() {
        let m = [4.0, 1.0, 2.0, 1.0, 3.0, 0.5, 2.0, 0.5, 5.0];
        let (vals, vecs) = jacobi_eigen(&m, 3);
        for k in 0..3 {
            let v = DVec3::new(vecs[k], vecs[3 + k], vecs[6 + k]);
            let mv = DMat3::from_cols_array(&m).transpose() * v;
            assert!((mv - v * vals[k]).length() < 1e-12, "eigenpair {k}");
        }
        assert!((vals.iter().sum::<f64>() - 12.0).abs() < 1e-12);
    }
}
