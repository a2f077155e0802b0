//! What the tests of the resolve's packed inputs share: the comparison of two resolves, and the configurations
//! they sweep.

use gbuf::resolve::{Brdf, Culling, MsaaSchedule, ResolveConfig, Resolved, Schedule};

/// Asserts two resolves equal in everything but their timings: the image bit for bit, the heatmap, every count.
pub fn assert_same_resolve(a: &Resolved, b: &Resolved, what: &str) {
    assert_eq!((a.image.width, a.image.height), (b.image.width, b.image.height), "{what}");
    for (i, (x, y)) in a.image.rgb.iter().zip(&b.image.rgb).enumerate() {
        assert!(x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits), "{what}: pixel {i}: {x} vs {y}");
    }
    assert_eq!(a.lights_per_pixel, b.lights_per_pixel, "{what}: heatmap");
    let (mut sa, mut sb) = (a.stats.clone(), b.stats.clone());
    (sa.ms, sb.ms) = (Default::default(), Default::default());
    assert_eq!(sa, sb, "{what}: statistics");
}

/// Every valid configuration of 3 BRDFs × every culling mode × 3 MSAA/light schedules (per-pixel with clustered
/// culling is not one), with its label.
pub fn resolve_configs() -> Vec<(ResolveConfig, String)> {
    let mut out = Vec::new();
    for brdf in Brdf::ALL {
        for culling in Culling::ALL {
            for (schedule, msaa) in [
                (Schedule::Deferred, MsaaSchedule::Packed),
                (Schedule::Deferred, MsaaSchedule::PerPixel),
                (Schedule::LightPrepass, MsaaSchedule::TwoPass),
            ] {
                let cfg = ResolveConfig { brdf, culling, schedule, msaa, ..Default::default() };
                if cfg.validate().is_ok() {
                    out.push((cfg, format!("{brdf} / {culling} / {schedule} / {msaa}")));
                }
            }
        }
    }
    out
}
