//! Our FLIP (`gbuf::measure::flip`) against NVIDIA's own Python package, `flip-evaluator` (PyPI): the mean
//! error of LDR-FLIP and HDR-FLIP on deterministic image pairs must agree within 1e-3 (issue 17's bound; the
//! implementation was measured within 3e-5 on these kinds of pairs). Required in CI (`.ci/run` installs the
//! package; `support::python_has` fails the test there when it cannot run), skipped with a note elsewhere.

mod support;

use gbuf::base::rng::SplitMix64;
use gbuf::measure::flip::{hdr_flip, ldr_flip, FlipOptions};
use std::path::Path;
use std::process::Command;

/// The bound the issue sets on the mean.
const MEAN_TOL: f64 = 1e-3;

const ORACLE: &str = r#"
import sys, json, numpy as np, flip_evaluator as flip
out = []
for mode, r, t in zip(sys.argv[1::3], sys.argv[2::3], sys.argv[3::3]):
    ref = np.ascontiguousarray(np.load(r), dtype=np.float32)
    test = np.ascontiguousarray(np.load(t), dtype=np.float32)
    _, mean, _ = flip.evaluate(ref, test, mode, applyMagma=False, computeMeanError=True, parameters={})
    out.append(float(mean))
print(json.dumps(out))
"#;

/// A float32 `.npy` file of shape `h × w × 3`.
fn write_npy(path: &Path, rgb: &[f32], w: usize, h: usize) {
    let dict = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({h}, {w}, 3), }}");
    let mut header = dict.into_bytes();
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(b' ');
    }
    header.push(b'\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend((header.len() as u16).to_le_bytes());
    bytes.extend(header);
    bytes.extend(rgb.iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(path, bytes).unwrap();
}

/// A rendered-looking image: gradients, a disc and a bar with hard edges, and highlights up to `peak`.
fn scene(w: usize, h: usize, peak: f32) -> Vec<f32> {
    let mut v = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let (u, t) = (x as f32 / w as f32, y as f32 / h as f32);
            let disc = ((u - 0.4).powi(2) + (t - 0.5).powi(2)).sqrt() < 0.25;
            let bar = (0.7..0.8).contains(&u);
            let base = [0.2 + 0.6 * u, 0.3 + 0.4 * t, 0.5 - 0.3 * u * t];
            let c = if disc {
                [0.9, 0.2, 0.1]
            } else if bar {
                [0.05, 0.05, 0.6]
            } else {
                base
            };
            let glint = if disc && (u - 0.33).abs() < 0.02 && (t - 0.42).abs() < 0.02 { peak } else { 1.0 };
            v.extend(c.map(|k| k * glint));
        }
    }
    v
}

/// `img` with a 3×3 box blur, seeded noise of amplitude `noise`, and values quantised to `levels`.
fn degrade(img: &[f32], w: usize, h: usize, noise: f32, levels: f32, seed: u64) -> Vec<f32> {
    let mut rng = SplitMix64::new(seed);
    let at = |x: usize, y: usize, k: usize| img[(y * w + x) * 3 + k];
    let mut out = vec![0.0; img.len()];
    for y in 0..h {
        for x in 0..w {
            for k in 0..3 {
                let mut s = 0.0;
                for (dx, dy) in (0..9).map(|i| (i % 3, i / 3)) {
                    s += at((x + dx).saturating_sub(1).min(w - 1), (y + dy).saturating_sub(1).min(h - 1), k);
                }
                let n = (rng.next_u64() >> 40) as f32 / (1u64 << 24) as f32 - 0.5;
                let v = (s / 9.0 + noise * n).max(0.0);
                out[(y * w + x) * 3 + k] = if levels > 0.0 { (v * levels).round() / levels } else { v };
            }
        }
    }
    out
}

#[test]
fn our_flip_matches_nvidias_flip_evaluator() {
    if !support::python_has("flip_evaluator, numpy") {
        return;
    }
    let (w, h) = (160, 96);
    let dir = tempfile::tempdir().unwrap();
    let ldr_ref = scene(w, h, 1.0).iter().map(|v| v.min(1.0)).collect::<Vec<_>>();
    let ldr_test = degrade(&ldr_ref, w, h, 0.05, 32.0, 1).iter().map(|v| v.min(1.0)).collect::<Vec<_>>();
    let hdr_ref = scene(w, h, 40.0);
    let hdr_test = degrade(&hdr_ref, w, h, 0.2, 0.0, 2);
    let cases = [("LDR", &ldr_ref, &ldr_test), ("LDR", &ldr_ref, &ldr_ref), ("HDR", &hdr_ref, &hdr_test)];
    let mut args = vec!["-c".to_string(), ORACLE.to_string()];
    for (i, (mode, r, t)) in cases.iter().enumerate() {
        let (rp, tp) = (dir.path().join(format!("{i}_ref.npy")), dir.path().join(format!("{i}_test.npy")));
        write_npy(&rp, r, w, h);
        write_npy(&tp, t, w, h);
        args.extend([mode.to_string(), rp.display().to_string(), tp.display().to_string()]);
    }
    let out = Command::new("python3").args(&args).output().expect("run python3");
    assert!(out.status.success(), "flip-evaluator failed: {}", String::from_utf8_lossy(&out.stderr));
    let theirs: Vec<f64> = serde_json::from_slice(out.stdout.trim_ascii()).expect("JSON list of means");
    let opts = FlipOptions::default();
    let ours = [
        ldr_flip(&ldr_ref, &ldr_test, w, h, &opts).mean,
        ldr_flip(&ldr_ref, &ldr_ref, w, h, &opts).mean,
        hdr_flip(&hdr_ref, &hdr_test, w, h, &opts).mean(),
    ];
    println!("mean FLIP, ours vs flip-evaluator: {ours:?} vs {theirs:?}");
    for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        assert!((a - b).abs() <= MEAN_TOL, "case {i}: ours {a}, flip-evaluator {b}, difference {}", (a - b).abs());
    }
    assert_eq!(ours[1], 0.0, "identical images");
    assert!(ours[0] > 0.01 && ours[2] > 0.01, "the degraded pairs differ: {ours:?}");
}
