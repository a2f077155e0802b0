//! The detectors on the built-in `room` scene at 4× MSAA: relations that must hold on any real scene, and the
//! numbers printed for the record (`cargo test --test detect_room -- --nocapture`).

use gbuf::detect::truth::{id_truth, object_truth, TruthSource};
use gbuf::detect::{detect, Detector, DetectorConfig, EdgeMask};
use gbuf::measure::edges::{evaluate, evaluate_against, shading_truth, truth_agreement, DEFAULT_SHADING_TOLERANCE};
use gbuf::scene::{default_lights, render, SceneName};

const W: u32 = 240;
const H: u32 = 135;

fn masks(gb: &gbuf::GBuffer) -> Vec<(Detector, EdgeMask)> {
    Detector::ALL.into_iter().map(|d| (d, detect(gb, d, &DetectorConfig::default()).unwrap())).collect()
}

#[test]
fn room_at_4x_relations_between_detectors() {
    let gb = render(SceneName::Room, W, H, 4).unwrap();
    let all = masks(&gb);
    let get = |d: Detector| &all.iter().find(|(x, _)| *x == d).unwrap().1;
    let truth = object_truth(&gb).unwrap();
    let prim = id_truth(&gb, TruthSource::Primitive).unwrap();
    let radiance = gbuf::resolve::reference_per_sample(
        &gb,
        &default_lights(SceneName::Room, &gb),
        &gbuf::resolve::ResolveConfig::default(),
    )
    .unwrap();
    let shading = shading_truth(&gb, &radiance, DEFAULT_SHADING_TOLERANCE);
    println!("room {W}x{H}x4: true edges {:.4}, shading truth {:.4}", frac(&truth), frac(&shading));
    println!(
        "{:<13} {:>7} {:>9} {:>9} {:>7} {:>9} {:>9}",
        "detector", "edge", "shading", "precision", "recall", "sh.prec", "sh.recall"
    );
    for (d, m) in &all {
        let s = evaluate(&gb, m).unwrap();
        let sh = evaluate_against(m, &shading);
        println!(
            "{:<13} {:>7.4} {:>9.4} {:>9.4} {:>7.4} {:>9.4} {:>9.4}",
            d.name(),
            s.edge_fraction,
            s.shading_fraction,
            s.precision,
            s.recall,
            sh.precision,
            sh.recall
        );
    }
    // The shading truth at the default tolerance (one display code step beyond the smooth gradient) is a small
    // part of the frame, under twice the ID edges (at 1/255 linear it was 43% of the pixels); it contains nearly
    // every ID edge (different objects are lit differently), and the id detector's flags are nearly all in it.
    let agree = truth_agreement(&shading, &truth);
    println!("shading truth vs ID truth: {agree:?}");
    assert!(frac(&shading) < 2.0 * frac(&truth), "{} vs {}", frac(&shading), frac(&truth));
    assert!(agree.b_covered_by_a > 0.95, "{agree:?}");
    assert!(evaluate_against(get(Detector::Id), &shading).precision > 0.95);
    // Scene sanity: the room has silhouettes, and its triangles make more primitive edges than object edges.
    assert!(frac(&truth) > 0.005, "{}", frac(&truth));
    assert!(prim.iter().filter(|&&p| p).count() >= truth.iter().filter(|&&t| t).count());
    // Baselines bracket every detector's cost.
    let none = get(Detector::None).shading_fraction();
    let ssaa = get(Detector::Ssaa).shading_fraction();
    for (d, m) in &all {
        assert!(none <= m.shading_fraction() && m.shading_fraction() <= ssaa, "{d}");
    }
    assert_eq!(evaluate(&gb, get(Detector::Ssaa)).unwrap().recall, 1.0);
    // combined = lauritzen ∪ id, so it flags a superset of both.
    let comb = get(Detector::Combined);
    for d in [Detector::Lauritzen, Detector::Id] {
        let m = get(d);
        assert!((0..m.shade_count.len()).all(|p| !m.is_edge(p) || comb.is_edge(p)), "{d} ⊄ combined");
    }
    // Object IDs are the truth, and the id detector compares them (among others): it misses nothing.
    assert_eq!(evaluate(&gb, get(Detector::Id)).unwrap().recall, 1.0);
    // Forward MSAA shades exactly the pixels that span several primitives (or mix in background with ≥ 2).
    let fwd = get(Detector::ForwardMsaa);
    assert!(fwd.shading_fraction() >= none);
    // Lauritzen's test is the normal test plus the depth test: it flags a superset of `normal`.
    let (l, n) = (get(Detector::Lauritzen), get(Detector::Normal));
    assert!((0..l.shade_count.len()).all(|p| !n.is_edge(p) || l.is_edge(p)), "normal ⊄ lauritzen");
    let ls = evaluate(&gb, l).unwrap();
    assert!(ls.recall >= evaluate(&gb, n).unwrap().recall);
    // It finds silhouettes (a good part of the object edges) while shading far fewer samples than SSAA.
    assert!(ls.recall > 0.3 && ls.tp > 100, "{ls:?}");
    assert!(ls.shading_fraction < 0.5 * ssaa, "{ls:?}");
}

fn frac(t: &[bool]) -> f64 {
    t.iter().filter(|&&x| x).count() as f64 / t.len() as f64
}
