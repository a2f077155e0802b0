//! The full-sphere Lambert equal-area and stereographic codecs (`lambert-sphere`, `stereo-sphere`) against
//! Cigolle et al. 2014: every code cell of the 16-, 20- and 24-bit codecs enumerated ([`cell_sweep`]), mean and
//! worst case compared with the published figures and with each codec's proven bound; the same sweep run on
//! octahedral, whose construction and published numbers are both known, as the check that the sweep measures
//! what the paper measured. Round-trip properties on the shared adversarial unit vectors.
//!
//! The 20- and 24-bit sweeps (2^20 and 2^24 cells) take minutes in a debug build:
//! `cargo test --release --test codec_sphere -- --ignored`.

#[path = "../src/codec/strategies.rs"]
mod strategies;

use gbuf::codec::eval::{cell_sweep, CellSweep, UNIT_LENGTH_TOL};
use gbuf::codec::normal::{LambertSphere, Oct, Planar, Projection, Quant, StereoSphere};
use gbuf::codec::{angle_deg, normal_codec, Codec, NormalCodec};
use glam::Vec3;
use proptest::prelude::*;
use strategies::{adversarial_unit_vector, stiff_unit_vectors};

/// How close to the paper's figures the issue asks us to come (relative).
const PAPER_TOLERANCE: f64 = 0.02;

/// Cigolle et al. 2014, table 1, octahedral (`oct`, snorm, rounding): (bits, mean °, max °), as quoted in
/// Unreal's `OctahedralCommon.ush` (docs/CODECS.md).
const PAPER_OCT: [(u32, f64, f64); 3] = [(16, 0.33709, 0.94424), (20, 0.08380, 0.23467), (24, 0.02091, 0.05874)];

/// Cigolle et al. 2014's 16-bit worst cases for full-sphere Lambert equal-area and stereographic, degrees, as
/// quoted in issue 16. Their means and their 20/24-bit figures were not available to us.
const PAPER_LAMBERT_SPHERE_16_MAX: f64 = 1.007;
/// See [`PAPER_LAMBERT_SPHERE_16_MAX`].
const PAPER_STEREO_SPHERE_16_MAX: f64 = 1.008;

/// Our own exhaustive figures (bits, mean °, max °), as measured by this sweep (seed [`SEED`]) and listed in
/// docs/CODECS.md; pinned so that a change to either codec shows up here.
const OURS_LAMBERT_SPHERE: [(u32, f64, f64); 3] =
    [(16, 0.33477, 0.96471), (20, 0.08319, 0.24037), (24, 0.02077, 0.06005)];
/// See [`OURS_LAMBERT_SPHERE`].
const OURS_STEREO_SPHERE: [(u32, f64, f64); 3] =
    [(16, 0.34416, 1.00406), (20, 0.08555, 0.25017), (24, 0.02135, 0.06249)];
/// How far a re-run may drift from the pinned figures: the mean's stratified sampling varies in the fourth
/// digit with the seed, the maximum only with f32 rounding.
const PINNED_TOLERANCE: f64 = 0.002;

/// Stratified sampling seed.
const SEED: u64 = 0x5eed_0016;

/// The sum of the cells' solid angles must be the sphere's (the cells tile it once); the cells are measured as
/// two geodesic triangles each, which misses a little where a cell straddles a fold or an axis.
const AREA_TOL: f64 = 1e-3;

fn sweep<P: Projection + std::fmt::Debug>(proj: P, bits: u32) -> CellSweep {
    let codec = Planar::new(proj, Quant::Snorm(bits / 2));
    let s = cell_sweep(&codec, SEED).expect("≤ 24-bit snorm codecs are enumerable");
    let sphere = 4.0 * std::f64::consts::PI;
    assert!((s.area_sr / sphere - 1.0).abs() < AREA_TOL, "{}: cells cover {} sr of {sphere}", codec.name(), s.area_sr);
    // Sampled points on a cell's edge may round into the neighbour; nearly all must stay in their own cell.
    assert!(
        s.other_code * 100 < s.cells,
        "{}: {} of {} cells' samples left their cell",
        codec.name(),
        s.other_code,
        s.cells
    );
    let bound = f64::from(codec.max_error_deg());
    assert!(s.max_deg <= bound, "{}: {:.5}° > bound {bound:.5}° at {:?}", codec.name(), s.max_deg, s.worst_input);
    eprintln!(
        "{}: cells {}, mean {:.5}°, max {:.5}° at {:?}, bound {bound:.5}°, area {:.6} sr, off-cell samples {}",
        codec.name(),
        s.cells,
        s.mean_deg,
        s.max_deg,
        s.worst_input,
        s.area_sr,
        s.other_code
    );
    s
}

/// `|measured / reference − 1| ≤ tol`, with both values in the message.
fn assert_close(what: &str, measured: f64, reference: f64, tol: f64) {
    let rel = measured / reference - 1.0;
    assert!(
        rel.abs() <= tol,
        "{what}: measured {measured:.5}° vs {reference:.5}° ({:+.2}%, tolerance ±{:.1}%)",
        100.0 * rel,
        100.0 * tol
    );
}

fn check_oct(bits: u32) {
    let (_, mean, max) = PAPER_OCT.iter().copied().find(|r| r.0 == bits).unwrap();
    let s = sweep(Oct, bits);
    assert_close(&format!("oct-{bits} mean vs paper"), s.mean_deg, mean, PAPER_TOLERANCE);
    assert_close(&format!("oct-{bits} max vs paper"), s.max_deg, max, PAPER_TOLERANCE);
}

fn check_pinned<P: Projection + std::fmt::Debug>(
    proj: P,
    name: &str,
    pinned: &[(u32, f64, f64)],
    bits: u32,
) -> CellSweep {
    let (_, mean, max) = pinned.iter().copied().find(|r| r.0 == bits).unwrap();
    let s = sweep(proj, bits);
    assert_close(&format!("{name}-{bits} mean vs pinned"), s.mean_deg, mean, PINNED_TOLERANCE);
    assert_close(&format!("{name}-{bits} max vs pinned"), s.max_deg, max, PINNED_TOLERANCE);
    s
}

#[test]
fn octahedral_sweep_reproduces_the_published_numbers_at_16_bits() {
    check_oct(16);
}

#[test]
#[ignore]
fn octahedral_sweep_reproduces_the_published_numbers_at_20_and_24_bits() {
    check_oct(20);
    check_oct(24);
}

#[test]
fn stereo_sphere_16_is_within_2_percent_of_the_published_max() {
    let s = check_pinned(StereoSphere, "stereo-sphere", &OURS_STEREO_SPHERE, 16);
    assert_close("stereo-sphere-16 max vs paper", s.max_deg, PAPER_STEREO_SPHERE_16_MAX, PAPER_TOLERANCE);
}

/// Not within 2%: the equal-area construction's worst case is 4% below the figure quoted for the paper, and
/// none of the other constructions we tried comes within 2% of it either (docs/CODECS.md). Pinned, with the
/// gap, so that the discrepancy stays visible.
#[test]
fn lambert_sphere_16_is_4_percent_below_the_published_max() {
    let s = check_pinned(LambertSphere, "lambert-sphere", &OURS_LAMBERT_SPHERE, 16);
    let rel = s.max_deg / PAPER_LAMBERT_SPHERE_16_MAX - 1.0;
    assert!(
        (-0.045..=-0.035).contains(&rel),
        "lambert-sphere-16 max {:.5}° vs paper {PAPER_LAMBERT_SPHERE_16_MAX}°: {:+.2}%",
        s.max_deg,
        100.0 * rel
    );
}

#[test]
#[ignore]
fn full_sphere_codecs_at_20_and_24_bits() {
    for bits in [20, 24] {
        check_pinned(LambertSphere, "lambert-sphere", &OURS_LAMBERT_SPHERE, bits);
        check_pinned(StereoSphere, "stereo-sphere", &OURS_STEREO_SPHERE, bits);
    }
}

/// The error shrinks by 4× per 2 extra bits per component, as for any Lipschitz map quantized on a grid: a
/// check that the 20/24-bit pinned figures are consistent with the 16-bit ones.
#[test]
fn pinned_figures_scale_with_the_step() {
    for pinned in [OURS_LAMBERT_SPHERE, OURS_STEREO_SPHERE] {
        for w in pinned.windows(2) {
            let (mean_ratio, max_ratio) = (w[0].1 / w[1].1, w[0].2 / w[1].2);
            assert!((3.9..4.1).contains(&mean_ratio) && (3.9..4.1).contains(&max_ratio), "{w:?}");
        }
    }
}

#[test]
fn poles_axes_and_fold_lines_round_trip_within_the_bound() {
    for name in ["lambert-sphere", "stereo-sphere"] {
        for bits in [8, 16, 20, 24, 32] {
            let c = normal_codec(&format!("{name}-{bits}")).unwrap();
            for n in stiff_unit_vectors() {
                let d = c.decode(c.encode(n));
                assert!(angle_deg(n, d) <= c.max_error_deg(), "{}: {n} → {d}", c.name());
            }
            // The poles are codes: +Z the centre, −Z the corner.
            assert_eq!(c.decode(c.encode(Vec3::Z)), Vec3::Z, "{}", c.name());
            assert_eq!(c.decode(c.encode(Vec3::NEG_Z)), Vec3::NEG_Z, "{}", c.name());
        }
    }
}

fn sphere_codecs() -> Vec<Box<dyn NormalCodec>> {
    ["lambert-sphere", "stereo-sphere"]
        .iter()
        .flat_map(|s| (4..=16).map(move |k| normal_codec(&format!("{s}-{}", 2 * k)).unwrap()))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2048, ..ProptestConfig::default() })]

    #[test]
    fn round_trip_within_the_bound_over_the_whole_sphere(n in adversarial_unit_vector()) {
        for c in sphere_codecs() {
            prop_assert!(c.in_domain(n));
            let d = c.decode(c.encode(n));
            prop_assert!(d.is_finite() && (d.length() - 1.0).abs() <= UNIT_LENGTH_TOL, "{}: {n} → {d}", c.name());
            let e = angle_deg(n, d);
            prop_assert!(e <= c.max_error_deg(), "{}: {n} → {d}: {e}° > {}°", c.name(), c.max_error_deg());
        }
    }

    /// Mirroring the input through the equator (z → −z) keeps its error bound: the two hemispheres are coded
    /// alike, one in the diamond and one in the corners.
    #[test]
    fn both_hemispheres_are_coded_alike(n in adversarial_unit_vector()) {
        let m = Vec3::new(n.x, n.y, -n.z);
        for c in sphere_codecs() {
            let (d, dm) = (c.decode(c.encode(n)), c.decode(c.encode(m)));
            prop_assert!(angle_deg(m, dm) <= c.max_error_deg(), "{}: {m} → {dm}", c.name());
            prop_assert!((d.z.abs() - dm.z.abs()).abs() <= 2.0 * c.max_error_deg().to_radians(), "{}: {d} vs {dm}", c.name());
        }
    }

    #[test]
    fn every_code_reencodes_to_itself(code in any::<u64>()) {
        for c in sphere_codecs() {
            let d = c.decode(code);
            prop_assert_eq!(c.decode(c.encode(d)), d, "{}: code {:#x}", c.name(), code);
        }
    }
}
