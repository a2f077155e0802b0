//! The budget search: never over the budget, never worse than the best built-in that fits, and its layout file
//! loads back with the same size.

use gbuf::analysis::budget::{search, BudgetConfig};
use gbuf::detect::{Detector, DetectorConfig};
use gbuf::layout::Layout;
use gbuf::resolve::ResolveConfig;
use gbuf::scene::{self, SceneName};

fn cfg(max_bytes: u32, max_error: Option<f64>) -> BudgetConfig {
    BudgetConfig {
        max_bytes,
        max_error,
        detector: Detector::Lauritzen,
        detector_config: DetectorConfig::default(),
        resolve: ResolveConfig::default(),
        over: Default::default(),
        shader_code: false,
        fit: Vec::new(),
    }
}

#[test]
fn budget_fits_beats_builtins_and_round_trips_through_a_file() {
    let gb = scene::render(SceneName::Room, 80, 45, 4).unwrap();
    let lights = scene::default_lights(SceneName::Room, &gb);
    for max in [8u32, 12, 20] {
        let res = search(&gb, &lights, &cfg(max, None)).unwrap();
        let w = &res.winner;
        assert!(w.bytes_per_sample <= max, "{} B over the {max} B budget", w.bytes_per_sample);
        let layout = Layout::from_spec(w.spec.clone()).unwrap();
        assert_eq!(layout.bytes_per_sample() as u32, w.bytes_per_sample);
        // Every measured candidate fits, and no fitting built-in measured better than the winner.
        for c in &res.measured {
            assert!(c.bytes_per_sample <= max, "{}", c.name);
            if c.kind == "built-in" {
                assert!(c.rmse.unwrap_or(f64::INFINITY) >= w.rmse.unwrap(), "{} beats the winner", c.name);
            }
        }
        // Every finalist is measured by layout error and predicted by the same model, built-ins too; the
        // prediction ratio is the measured over the predicted value.
        for c in res.measured.iter().filter(|c| c.error.is_none()) {
            let (m, p) = (c.rmse.unwrap(), c.predicted_rmse.unwrap());
            if p > 0.0 {
                assert!((c.prediction_ratio.unwrap() - m / p).abs() <= 1e-12 * (m / p), "{}", c.name);
            }
        }
        assert!(res.prediction.finalists >= 2 && res.prediction.median_ratio.is_some());
        for b in Layout::builtins().iter().filter(|b| b.bytes_per_sample() as u32 <= max) {
            assert!(res.measured.iter().any(|c| c.name == b.name()), "{} fits but was not measured", b.name());
        }
        // The layout file loads back with the same size.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("best.toml");
        layout.save(&path).unwrap();
        let back = Layout::load(&path).unwrap();
        assert_eq!(back.bytes_per_sample(), layout.bytes_per_sample());
        // The constant attributes of the scene cost no bits.
        for c in &res.needs.constant {
            let a = gbuf::Attribute::from_name(c).unwrap();
            assert!(!layout.stores(a), "{c} is constant but stored");
        }
    }
}

#[test]
fn error_cap_picks_a_layout_under_it_and_impossible_budgets_fail() {
    let gb = scene::render(SceneName::Room, 64, 36, 2).unwrap();
    let lights = scene::default_lights(SceneName::Room, &gb);
    let loose = search(&gb, &lights, &cfg(32, None)).unwrap();
    let cap = loose.winner.rmse.unwrap() * 4.0 + 1e-9;
    let capped = search(&gb, &lights, &cfg(32, Some(cap))).unwrap();
    assert!(capped.winner.rmse.unwrap() <= cap);
    assert!(capped.winner.bytes_per_sample <= loose.winner.bytes_per_sample);
    assert!(search(&gb, &lights, &cfg(0, None)).is_err());
    // The lossless layout measures layout error 0 (it fits in 96 bytes).
    let wide = search(&gb, &lights, &cfg(96, None)).unwrap();
    let lossless = wide.measured.iter().find(|c| c.name == "reference-f32").unwrap();
    assert_eq!(lossless.rmse, Some(0.0));
    assert_eq!(wide.winner.rmse, Some(0.0), "nothing beats no error");
    assert!(search(&gb, &lights, &cfg(1, None)).is_err(), "nothing useful fits in one byte");
}

/// `--fit`: every candidate the search measures binds as one pass on the platforms named, at the frame's sample
/// count; single-sampled, WebGPU keeps generated layouts, and at 4× (integer targets do not multisample there) the
/// search still answers with a layout that binds.
#[test]
fn budget_fit_keeps_only_layouts_that_bind_on_the_platforms() {
    use gbuf::layout::limits::{check, Platform};
    let webgpu = Platform::by_name("webgpu").unwrap();
    for samples in [1, 4] {
        let gb = scene::render(SceneName::Room, 64, 36, samples).unwrap();
        let lights = scene::default_lights(SceneName::Room, &gb);
        let unconstrained = search(&gb, &lights, &cfg(16, None)).unwrap();
        let fits = |spec: &gbuf::layout::spec::LayoutSpec| {
            check(webgpu, Layout::from_spec(spec.clone()).unwrap().formats(), samples).fits()
        };
        assert!(unconstrained.measured.iter().any(|c| !fits(&c.spec)), "{samples}×: the constraint must bite");
        let res = search(&gb, &lights, &BudgetConfig { fit: vec![webgpu], ..cfg(16, None) }).unwrap();
        assert!(fits(&res.winner.spec), "{samples}×: {}", res.winner.name);
        assert!(res.measured.iter().all(|c| fits(&c.spec)), "{samples}×");
        if samples == 1 {
            assert!(res.measured.iter().any(|c| c.kind == "generated"), "single-sampled generated layouts bind");
        }
    }
}

/// A single-sampled frame may store a built-in's 8-bit targets with AFRC: those candidates are measured within the
/// budget by the bytes they occupy in memory; a multisampled frame (which AFRC cannot hold) gets none.
#[test]
fn afrc_built_ins_join_the_budget_of_single_sampled_frames() {
    let one = scene::render(SceneName::Room, 64, 36, 1).unwrap();
    let lights = scene::default_lights(SceneName::Room, &one);
    let res = search(&one, &lights, &cfg(12, None)).unwrap();
    let afrc: Vec<_> = res.measured.iter().filter(|c| c.kind == "built-in AFRC").collect();
    assert!(
        afrc.iter().any(|c| c.name == "fat-20@afrc2"),
        "{:?}",
        res.measured.iter().map(|c| &c.name).collect::<Vec<_>>()
    );
    for c in &afrc {
        let l = Layout::from_spec(c.spec.clone()).unwrap();
        assert!(c.name.contains("@afrc") && c.error.is_none() && c.rmse.is_some(), "{}", c.name);
        assert_eq!(c.bytes_per_sample, l.stored_bytes_per_sample().ceil() as u32, "{}", c.name);
        assert!(c.bytes_per_sample <= 12 && l.bytes_per_sample() > l.stored_bytes_per_sample() as usize);
    }
    let four = scene::render(SceneName::Room, 64, 36, 4).unwrap();
    let res = search(&four, &lights, &cfg(12, None)).unwrap();
    assert!(res.measured.iter().all(|c| c.kind != "built-in AFRC"));
}
