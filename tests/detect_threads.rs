//! Every detector, the ID truth and the shading truth give the same answer on 1 and on 2 rayon threads (they
//! are parallel over rows; nothing may depend on how rows are split between threads).

use gbuf::detect::truth::{id_truth, TruthSource};
use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::measure::edges::{shading_truth, DEFAULT_SHADING_TOLERANCE};
use gbuf::scene::{default_lights, render, SceneName};

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap()
}

#[test]
fn masks_and_truths_are_identical_on_one_and_two_threads() {
    let (one, two) = (pool(1), pool(2));
    // Odd sizes so that rows do not split evenly; 1, 4 and 8 samples.
    for (w, h, s) in [(97, 61, 4), (83, 47, 1), (64, 33, 8)] {
        let gb = render(SceneName::Room, w, h, s).unwrap();
        let lights = default_lights(SceneName::Room, &gb);
        let cfgs = [DetectorConfig::default(), DetectorConfig { gradient_scale: 0.5, ..Default::default() }];
        for d in Detector::ALL {
            for cfg in &cfgs {
                let a = one.install(|| detect(&gb, d, cfg)).unwrap();
                let b = two.install(|| detect(&gb, d, cfg)).unwrap();
                assert_eq!(a, b, "{d} on {w}×{h}×{s}: masks differ between 1 and 2 threads");
            }
        }
        for src in [TruthSource::Object, TruthSource::Primitive] {
            assert_eq!(one.install(|| id_truth(&gb, src)), two.install(|| id_truth(&gb, src)), "{src:?}");
        }
        let truth = |p: &rayon::ThreadPool| {
            p.install(|| {
                let r = gbuf::resolve::reference_per_sample(&gb, &lights, &Default::default()).unwrap();
                shading_truth(&gb, &r, DEFAULT_SHADING_TOLERANCE)
            })
        };
        let t1 = truth(&one);
        assert!(s == 1 || t1.iter().any(|&e| e), "{w}×{h}×{s}: the shading truth should find edges");
        assert_eq!(t1, truth(&two), "shading truth on {w}×{h}×{s}");
    }
}
