//! Deterministic sweeps: every normal scheme × every valid bit count in one loop, held to its documented bound;
//! exhaustive enumeration of small code spaces.

use gbuf::codec::eval::{evaluation_set, exhaustive, measure_error, UNIT_LENGTH_TOL};
use gbuf::codec::{angle_deg, NormalCodec, NormalScheme};
use glam::Vec3;

fn all_codecs() -> Vec<(NormalScheme, Box<dyn NormalCodec>)> {
    NormalScheme::ALL.iter().flat_map(|&s| s.valid_bits().into_iter().map(move |b| (s, s.codec(b).unwrap()))).collect()
}

#[test]
fn every_scheme_and_bit_count_stays_within_its_documented_bound() {
    let inputs = evaluation_set(40_000, 20_000);
    let mut failures = Vec::new();
    for (_, codec) in all_codecs() {
        let s = measure_error(codec.as_ref(), &inputs);
        let bound = f64::from(codec.max_error_deg());
        if s.max_domain_deg > bound {
            failures.push(format!(
                "{}: {:.5}° > bound {:.5}° at {:?}",
                codec.name(),
                s.max_domain_deg,
                bound,
                s.worst_input
            ));
        }
        // The bound must also mean something: not more than 40× the measured error (loose only where the
        // analysis is dominated by a rim singularity, which the sweep does sample).
        if bound > 40.0 * s.max_domain_deg.max(1e-4) && codec.bits() < 48 {
            failures.push(format!(
                "{}: bound {bound:.5}° is vacuous against measured {:.5}°",
                codec.name(),
                s.max_domain_deg
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn error_shrinks_as_bits_grow() {
    let inputs = evaluation_set(20_000, 0);
    for s in NormalScheme::ALL.iter().filter(|s| !s.is_f16()) {
        let errs: Vec<f64> =
            s.valid_bits().iter().map(|&b| measure_error(s.codec(b).unwrap().as_ref(), &inputs).mean_deg).collect();
        for w in errs.windows(2) {
            assert!(w[1] < w[0], "{}: mean error does not shrink with bits: {errs:?}", s.name());
        }
    }
}

/// Every code of every codec of at most `max_bits` bits decodes to a unit vector and re-encodes to itself (or, for
/// codecs that are not idempotent, within their error bound).
fn every_code_decodes_and_reencodes(max_bits: u32) {
    for (_, codec) in all_codecs().into_iter().filter(|(_, c)| c.bits() <= max_bits) {
        let e = exhaustive(codec.as_ref()).unwrap();
        assert_eq!(e.bad_decodes, 0, "{}: {e:?}", codec.name());
        if codec.is_idempotent() {
            assert_eq!(e.reencode_mismatches, 0, "{}: {e:?}", codec.name());
        } else {
            assert!(e.reencode_max_deg <= f64::from(codec.max_error_deg()), "{}: {e:?}", codec.name());
        }
    }
}

#[test]
fn every_code_of_small_codecs_decodes_to_a_unit_vector_and_reencodes_stably() {
    // Up to 16 bits in debug builds: 2^16 codes × ~40 codecs stays well under a second.
    every_code_decodes_and_reencodes(16);
}

/// The full 2^24 enumeration of every codec with ≤ 24 bits; minutes in debug, run with
/// `cargo test --release --test codec_sweep -- --ignored`.
#[test]
#[ignore]
fn every_code_of_codecs_up_to_24_bits() {
    every_code_decodes_and_reencodes(24);
}

#[test]
fn published_octahedral_and_snorm_numbers_are_reproduced_in_shape() {
    // Cigolle et al. 2014 (via Unreal's OctahedralCommon.ush): max error oct16 0.94424°, oct24 0.05874°,
    // snorm8×3 0.38588°. Our sweep must come within 10% of these maxima from below (they are sampled maxima
    // too) and never exceed the analytic bounds.
    let inputs = evaluation_set(400_000, 200_000);
    for (name, published_max) in [("oct-16", 0.94424), ("oct-24", 0.05874), ("xyz-snorm-24", 0.38588)] {
        let c = gbuf::codec::normal_codec(name).unwrap();
        let s = measure_error(c.as_ref(), &inputs);
        assert!(
            (s.max_deg - published_max).abs() < 0.1 * published_max,
            "{name}: measured max {:.5}° vs published {published_max}°",
            s.max_deg
        );
    }
}

#[test]
fn degenerate_inputs_decode_to_defined_unit_vectors() {
    let cases = [
        (Vec3::ZERO, Vec3::Z),
        (Vec3::new(-0.0, -0.0, -0.0), Vec3::Z),
        (Vec3::NAN, Vec3::Z),
        (Vec3::new(f32::NAN, 1.0, 0.0), Vec3::Z),
        (Vec3::new(f32::INFINITY, 0.5, 0.0), Vec3::X),
        (Vec3::new(0.0, 0.0, 1e30), Vec3::Z),
        (Vec3::new(0.0, 1e-30, 0.0), Vec3::Y),
    ];
    for (_, codec) in all_codecs() {
        for (input, expected) in cases {
            let d = codec.decode(codec.encode(input));
            assert!(d.is_finite() && (d.length() - 1.0).abs() < UNIT_LENGTH_TOL, "{}: {input} → {d}", codec.name());
            if codec.in_domain(expected) {
                let e = angle_deg(d, expected);
                assert!(e <= codec.max_error_deg(), "{}: {input} → {d}, expected ≈ {expected} ({e}°)", codec.name());
            }
        }
    }
}
