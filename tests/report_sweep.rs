//! The sweep on a small rendered room: rows consistent with their layouts, the lossless layout exact, Pareto flags
//! consistent with the numbers, and the needs analysis of a real scene.

use gbuf::analysis::pareto::dominates;
use gbuf::analysis::sweep::{sweep, FlipRows, SweepConfig};
use gbuf::detect::{Detector, DetectorConfig};
use gbuf::layout::Layout;
use gbuf::resolve::ResolveConfig;
use gbuf::scene::{self, SceneName};

/// The fast f32 resolve against the f64 reference on an exact G-buffer: what is left is the resolve's own
/// arithmetic (fast pow/exp), far below any quantization error.
const RESOLVE_VS_REFERENCE_REL_MSE: f64 = 1e-4;

fn small_room() -> (gbuf::GBuffer, Vec<gbuf::Light>) {
    let gb = scene::render(SceneName::Room, 96, 54, 4).expect("room renders");
    let lights = scene::default_lights(SceneName::Room, &gb);
    (gb, lights)
}

/// The room as a report's input, with all its planes (none left out), from `geometry` when given.
fn room_input<'a>(
    gb: &'a gbuf::GBuffer,
    lights: &'a [gbuf::Light],
    geometry: Option<SceneName>,
) -> gbuf::analysis::ReportInput<'a> {
    gbuf::analysis::ReportInput {
        name: "room".into(),
        gbuffer: gb,
        lights,
        lights_source: "default".into(),
        single: None,
        geometry,
        notes: Vec::new(),
        position_derived: false,
    }
}

/// A sweep of `layouts` × `detectors`, one timing run, default thresholds, resolve and viewing.
fn one_run(layouts: &[&str], detectors: Vec<Detector>, flip: FlipRows) -> SweepConfig {
    SweepConfig {
        layouts: layouts.iter().map(|n| Layout::by_name(n).expect("built-in")).collect(),
        detectors,
        detector_config: DetectorConfig::default(),
        culling: vec![],
        resolve: ResolveConfig::default(),
        runs: 1,
        flip,
        viewing: Default::default(),
    }
}

#[test]
fn sweep_rows_match_layouts_and_lossless_is_exact() {
    let (gb, lights) = small_room();
    let layouts: Vec<Layout> =
        ["reference-f32", "fat-20", "minimal-8"].iter().map(|n| Layout::by_name(n).expect("built-in")).collect();
    let cfg = SweepConfig {
        layouts: layouts.clone(),
        detectors: vec![Detector::Lauritzen, Detector::Ssaa],
        detector_config: DetectorConfig::default(),
        culling: vec![],
        resolve: ResolveConfig::default(),
        runs: 2,
        flip: FlipRows::Decisive,
        viewing: Default::default(),
    };
    let mut calls = 0;
    let out = sweep(&gb, &lights, &cfg, &mut |done, total, _| {
        assert!(done <= total);
        calls += 1;
    })
    .unwrap();
    assert!(calls > 3);
    assert_eq!(out.rows.len(), 6);
    // Where the time went: each kind of stage once, in the order met, adding up to at most the sweep's time.
    let kinds: Vec<&str> = out.stage_seconds.iter().map(|(k, _)| k.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "reference",
            "detectors on the exact G-buffer",
            "pack/unpack",
            "compression models",
            "detect",
            "resolve",
            "FLIP",
            "error maps"
        ]
    );
    let staged: f64 = out.stage_seconds.iter().map(|(_, t)| t).sum();
    assert!(out.stage_seconds.iter().all(|(_, t)| *t >= 0.0) && staged <= out.seconds, "{staged} of {}", out.seconds);
    assert!(staged > 0.5 * out.seconds, "the stages cover the sweep: {staged} of {} s", out.seconds);
    for r in &out.rows {
        let l = layouts.iter().find(|l| l.name() == r.layout).unwrap();
        assert_eq!(r.bytes_per_sample as usize, l.bytes_per_sample(), "{}", r.layout);
        assert_eq!(r.footprint_bytes, l.footprint_bytes(gb.width, gb.height, gb.samples));
        assert!(r.error.is_none(), "{}: {:?}", r.layout, r.error);
        assert!(r.layout_error.is_some() && r.aa_error.is_some() && r.total_error.is_some());
        assert!(r.encode_ms.is_some() && r.decode_ms.is_some() && r.resolve_ms.is_some());
        // A resolve that read the packed targets decoded them itself; a planes resolve adds the decode.
        let pass = if r.packed_resolve { r.resolve_ms.unwrap() } else { r.decode_ms.unwrap() + r.resolve_ms.unwrap() };
        assert_eq!(r.resolve_pass_ms, Some(pass));
        assert_eq!(r.packed_resolve, l.bytes_per_sample() < 84, "{}: only the lossless layout is not packed", r.layout);
        // FLIP where it decides: the first detector's rows, and every detector's AA error.
        let first = r.detector == "lauritzen";
        assert_eq!(r.layout_error.unwrap().flip_ldr.is_some(), first, "{} × {}", r.layout, r.detector);
        assert!(r.aa_error.unwrap().flip_ldr.is_some() && r.aa_error.unwrap().flip_hdr.is_some());
        assert!(r.bandwidth_mb.tiled > 0.0 && r.bandwidth_mb.quad.unwrap() > r.bandwidth_mb.tiled / 2.0);
        // Bytes after the compression models: the library's, from the layout packed whole; never above nominal plus
        // metadata, and the traffic recomputed with them.
        let c = r.compressed.unwrap();
        let whole = gbuf::layout::compression::compressed_models(&l.pack(&gb).unwrap());
        let want = gbuf::layout::compression::bytes_per_sample(&whole, gb.len() as u64);
        for k in 0..3 {
            assert!(
                (c.bytes_per_sample[k] - want[k]).abs() * gb.len() as f64 <= 64.0,
                "{}: {c:?} vs {want:?}",
                r.layout
            );
            assert!(c.bytes_per_sample[k] <= 1.01 * f64::from(r.bytes_per_sample));
            let t = gbuf::analysis::traffic::bandwidth(&gb, c.bytes_per_sample[k], None).tiled;
            assert_eq!(c.tiled_mb[k], t);
        }
        assert_eq!(r.timings["encode"].runs, 2);
        let sf = r.shading_fraction.unwrap();
        assert!((0.0..=1.0).contains(&sf));
        if r.detector == "ssaa" {
            let covered = (gb.len() - gb.background_samples()) as f64 / gb.len() as f64;
            // Every covered sample and nothing else (issue 16: it used to count `samples` per pixel with coverage).
            assert!((sf - covered).abs() < 1e-12, "ssaa shades exactly the covered samples: {sf} vs {covered}");
        }
    }
    // The lossless layout with every sample shaded has exactly the error of resolving the unpacked input itself.
    let exact = out.rows.iter().find(|r| r.layout == "reference-f32" && r.detector == "ssaa").unwrap();
    let direct = gbuf::resolve::resolve(&gb, &lights, &gbuf::detect::baselines::ssaa(&gb), &cfg.resolve).unwrap();
    let e0 = gbuf::measure::image::compare(&out.reference, &direct.image);
    let total = exact.total_error.unwrap();
    assert_eq!(total.rmse, e0.rmse, "the f32 roundtrip is bit-exact");
    assert!(total.rel_mse <= RESOLVE_VS_REFERENCE_REL_MSE, "{total:?}");
    assert_eq!(exact.normal_max_deg, Some(0.0));
    // Decode work: the lossless f32 layout decodes cheaper than the packed ones (no unpacking math).
    let ops = |l: &str| out.rows.iter().find(|r| r.layout == l).unwrap().decode_ops_per_sample.unwrap();
    assert!(
        ops("reference-f32") > 0 && ops("reference-f32") < ops("fat-20"),
        "{} {}",
        ops("reference-f32"),
        ops("fat-20")
    );
    // The lossless layout has layout error 0 with every detector, by construction; its total error is the AA
    // error alone.
    for r in out.rows.iter().filter(|r| r.layout == "reference-f32") {
        let l = r.layout_error.unwrap();
        assert_eq!((l.rmse, l.max_abs), (0.0, 0.0), "{}", r.detector);
        assert_eq!(r.total_error.unwrap().rmse, r.aa_error.unwrap().rmse, "{}", r.detector);
        if let Some(f) = l.flip_ldr {
            assert_eq!((f, l.flip_hdr), (0.0, Some(0.0)));
            // Its image is its detector's exact image: its FLIP against the reference is that image's (taken, not
            // filtered again), which a lossy layout's is not.
            let (t, a) = (r.total_error.unwrap(), r.aa_error.unwrap());
            assert!(t.flip_ldr.is_some() && (t.flip_ldr, t.flip_hdr) == (a.flip_ldr, a.flip_hdr), "{t:?} {a:?}");
            let lossy = out.rows.iter().find(|x| x.layout == "minimal-8" && x.detector == r.detector).unwrap();
            assert_ne!(lossy.total_error.unwrap().flip_ldr, a.flip_ldr);
        }
    }
    // The AA error is the detector's, the same for every layout; shading more samples aliases less.
    let aa = |d: &str| out.detectors.iter().find(|x| x.detector == d).unwrap().aa_error.unwrap();
    for r in &out.rows {
        assert_eq!(r.aa_error.unwrap(), aa(&r.detector));
    }
    assert!(aa("ssaa").rmse < aa("lauritzen").rmse);
    // A lossy layout really is lossy.
    let min8 = out.rows.iter().find(|r| r.layout == "minimal-8" && r.detector == "ssaa").unwrap();
    assert!(min8.normal_max_deg.unwrap() > 0.0 && min8.layout_rmse().unwrap() > 0.0);
    // Pareto flags agree with the numbers, recomputed from the rows: layout error against bytes and against the
    // resolve pass time.
    for (axis, x) in [("bytes", 0), ("time", 1)] {
        let pts: Vec<(f64, f64)> = out
            .rows
            .iter()
            .map(|r| {
                let c = if x == 0 { f64::from(r.bytes_per_sample) } else { r.resolve_pass_ms.unwrap() };
                (c, r.layout_rmse().unwrap())
            })
            .collect();
        for (i, r) in out.rows.iter().enumerate() {
            let dominated = pts.iter().any(|&q| dominates(q, pts[i]));
            let flag = if x == 0 { r.pareto.bytes } else { r.pareto.time };
            assert_eq!(flag, !dominated, "{axis}: {} × {}", r.layout, r.detector);
        }
    }
    // The lossless layout is on the bytes front (nothing has less error), whatever its size.
    assert!(out.rows.iter().any(|r| r.layout == "reference-f32" && r.pareto.bytes));
    assert_eq!(out.maps.len(), 3);
    // Only the layouts with the largest layout error keep their per-pixel planes (the heatmaps drawn); the
    // lossless one, with error 0, is the one emptied.
    let kept: Vec<&str> = out.maps.iter().filter(|m| m.normal_deg.is_some()).map(|m| m.layout.as_str()).collect();
    assert_eq!(kept.len(), gbuf::analysis::sweep::HEATMAP_LAYOUTS, "{kept:?}");
    assert!(!kept.contains(&"reference-f32"), "{kept:?}");
    assert!(out.maps.iter().filter(|m| !kept.contains(&m.layout.as_str())).all(|m| m.image_abs.is_none()));
    // The attribute maps are NaN exactly at pixels without a covered sample, finite and ≥ 0 elsewhere.
    let s = gb.samples as usize;
    let covered: Vec<bool> = (0..gb.pixel_count()).map(|p| gb.coverage[p * s..(p + 1) * s].contains(&true)).collect();
    assert!(covered.contains(&false) && covered.contains(&true), "the room has sky and surfaces");
    for m in out.maps.iter().filter(|m| m.normal_deg.is_some()) {
        for map in [&m.normal_deg, &m.depth_rel, &m.albedo_abs].into_iter().flatten() {
            assert_eq!(map.len(), gb.pixel_count());
            for (&e, &c) in map.iter().zip(&covered) {
                assert_eq!(e.is_nan(), !c, "{}: {e} at a pixel covered: {c}", m.layout);
                assert!(e.is_nan() || e >= 0.0, "{}: {e}", m.layout);
            }
        }
        assert!(m.image_abs.as_ref().is_some_and(|v| v.len() == gb.pixel_count() && v.iter().all(|e| *e >= 0.0)));
    }
    assert_eq!(out.masks.len(), 2);
    assert_eq!(out.lights_per_pixel.as_ref().map(Vec::len), Some(gb.pixel_count()));
}

#[test]
fn failing_rows_say_why() {
    let (mut gb, lights) = small_room();
    // Without IDs the `id` detector cannot run; the row must carry the reason, not a number.
    gb.material_id = None;
    gb.object_id = None;
    let cfg = one_run(&["minimal-8"], vec![Detector::Id, Detector::Lauritzen], FlipRows::None);
    let out = sweep(&gb, &lights, &cfg, &mut |_, _, _| {}).unwrap();
    let id = out.rows.iter().find(|r| r.detector == "id").unwrap();
    assert!(id.error.as_deref().is_some_and(|e| e.contains("detector")), "{:?}", id.error);
    assert!(id.layout_error.is_none() && !id.pareto.bytes);
    let ok = out.rows.iter().find(|r| r.detector == "lauritzen").unwrap();
    assert!(ok.layout_error.is_some() && ok.layout_error.unwrap().flip_ldr.is_none(), "--flip none");
    assert!(ok.precision.is_none(), "no object IDs, no ground truth");
    assert!(ok.note.as_deref().is_some_and(|n| n.contains("ground truth")));
}

#[test]
fn needs_of_the_room() {
    let (gb, _) = small_room();
    let n = gbuf::analysis::needs::analyze(&gb);
    assert!(n.absent.contains(&"motion".to_string()));
    assert!(n.material_count >= 2, "the room has a dozen materials: {}", n.material_count);
    assert_eq!(n.material_id_bits, Some(gbuf::analysis::needs::bits_for_count(n.material_count)));
    let [lo, hi] = n.depth_range.unwrap();
    assert!(lo > 0.0 && hi > lo);
    assert_eq!(n.normals_face_camera, Some(n.back_facing_normals == 0));
}

/// The report's pipelines take the sweep's FLIP of each detector's exact image instead of comparing that image
/// again: the numbers equal those of a pipelines run that computes every FLIP itself, and (with made-up known
/// numbers) they really are the known ones, for exactly the rows whose image is the known image.
#[test]
fn pipelines_take_known_flips_for_equal_images_only() {
    use gbuf::analysis::pipelines::{pipelines, pipelines_with, KnownFlip};
    use gbuf::measure::image::error_set;
    let (gb, lights) = small_room();
    let cfg = gbuf::study::pipelines_config(&one_run(
        &["fat-20"],
        vec![Detector::Lauritzen, Detector::Normal],
        FlipRows::Decisive,
    ));
    let viewing = cfg.viewing.expect("FLIP on");
    let reference = gbuf::resolve::reference(&gb, &lights, &cfg.resolve).unwrap();
    let exact: Vec<(Detector, gbuf::image::HdrImage)> = cfg
        .aa_detectors
        .iter()
        .map(|&d| {
            let mask = gbuf::detect::detect(&gb, d, &cfg.detector_config).unwrap();
            (d, gbuf::resolve::resolve(&gb, &lights, &mask, &cfg.resolve).unwrap().image)
        })
        .collect();
    let flips: Vec<(f64, f64)> = exact
        .iter()
        .map(|(_, img)| {
            let e = error_set(&reference, img, Some(&viewing));
            (e.flip_ldr.unwrap(), e.flip_hdr.unwrap())
        })
        .collect();
    let known: Vec<KnownFlip<'_>> =
        exact.iter().zip(&flips).map(|((_, image), &(ldr, hdr))| KnownFlip { image, ldr, hdr }).collect();
    let own = pipelines(&gb, &lights, &cfg, Some(&reference), None).unwrap();
    let reused = pipelines_with(&gb, &lights, &cfg, Some(&reference), None, &known).unwrap();
    let numbers = |p: &gbuf::analysis::pipelines::Pipelines| {
        let rows = p.rows.iter().map(|r| r.error.map(|e| (e.flip_ldr, e.flip_hdr)));
        rows.chain(p.aa.iter().map(|a| Some((a.error.flip_ldr, a.error.flip_hdr)))).collect::<Vec<_>>()
    };
    assert_eq!(numbers(&own), numbers(&reused), "known FLIPs equal FLIPs computed again");
    assert!(numbers(&own).iter().flatten().all(|(l, h)| l.is_some() && h.is_some()));

    // Made-up numbers for the first detector's image: its adaptive MSAA row and the tiled deferred row (the same
    // image) take them; the no-AA, MLAA, SSAA and light pre-pass rows do not.
    let fake = [KnownFlip { image: &exact[0].1, ldr: 0.123, hdr: 4.5 }];
    let p = pipelines_with(&gb, &lights, &cfg, Some(&reference), None, &fake).unwrap();
    let first = format!("msaa:{}", exact[0].0);
    for a in &p.aa {
        let took = a.error.flip_ldr == Some(0.123) && a.error.flip_hdr == Some(4.5);
        assert_eq!(took, a.method == first, "{}: {:?}", a.method, a.error);
    }
    let tiled = p.rows.iter().find(|r| r.pipeline == gbuf::analysis::pipelines::Pipeline::TiledDeferred).unwrap();
    assert_eq!(tiled.error.unwrap().flip_ldr, Some(0.123));
    let prepass = p.rows.iter().find(|r| r.pipeline == gbuf::analysis::pipelines::Pipeline::LightPrepass).unwrap();
    assert_ne!(prepass.error.unwrap().flip_ldr, Some(0.123));
    // Without the caller's reference (the pipelines compute their own) no known number applies.
    let own_ref = pipelines_with(&gb, &lights, &cfg, None, None, &fake).unwrap();
    assert!(own_ref.aa.iter().all(|a| a.error.flip_ldr != Some(0.123)));
}

/// The report says where its time outside the sweep went: each step of a frame once, none negative, and all of
/// them within the frame's wall time.
#[test]
fn a_frame_times_its_steps_outside_the_sweep() {
    let (gb, lights) = small_room();
    let cfg = one_run(&["fat-20"], vec![Detector::Lauritzen], FlipRows::Decisive);
    let input = room_input(&gb, &lights, None);
    let t = std::time::Instant::now();
    let r = gbuf::study::run_frame(&input, &cfg, true, "", &mut |_, _, _| {}).unwrap();
    let wall = t.elapsed().as_secs_f64();
    let kinds: Vec<&str> = r.frame.other_seconds.iter().map(|(k, _)| k.as_str()).collect();
    assert_eq!(kinds, ["needs analysis", "figures", "pruned layout", "pipelines"]);
    let other: f64 = r.frame.other_seconds.iter().map(|(_, s)| s).sum();
    assert!(r.frame.other_seconds.iter().all(|(_, s)| *s >= 0.0));
    assert!(other + r.frame.sweep_seconds <= wall, "{other} + {} s of {wall} s", r.frame.sweep_seconds);
    assert!(r.frame.other_seconds.iter().any(|(k, s)| k == "pipelines" && *s > 0.0));
}

/// The library's frames loop (what `gbuf report` calls): frames asked for one at a time, one lighting model for all
/// (the first frame's choice, a differing later frame announced), figure files prefixed per frame, and a frame that
/// fails to load stops the loop with its error.
#[test]
fn the_frames_loop_lights_every_frame_as_the_first_and_names_them() {
    use gbuf::study::{run_frames, Assembly, Event, FrameInput};
    let (gb, lights) = small_room();
    let mut flat = gb.clone();
    flat.roughness = None;
    flat.metallic = None;
    let frames = [gb, flat];
    let cfg = one_run(&["fat-20"], vec![Detector::Lauritzen], FlipRows::None);
    let how = Assembly::of(&cfg, gbuf::analysis::aggregate::Over::Worst, None, "");
    let mut asked = Vec::new();
    let mut events = Vec::new();
    let next = |i: usize| -> gbuf::Result<FrameInput> {
        asked.push(i);
        Ok(FrameInput {
            name: format!("f{i}"),
            gbuffer: frames[i].clone(),
            lights: lights.clone(),
            lights_source: "default".into(),
            single: None,
            geometry: None,
            notes: Vec::new(),
        })
    };
    let mut on = |e: Event<'_>| match e {
        Event::Lighting(l) => events.push(format!("lighting {}", l.brdf)),
        Event::LightingDiffers { frame, would, .. } => events.push(format!("{frame} would {}", would.brdf)),
        Event::Progress { .. } => {}
    };
    let (rep, files) =
        run_frames(2, next, &cfg, &|a| gbuf::resolve::Lighting::choose(None, None, a), &how, &mut on).unwrap();
    assert_eq!(asked, [0, 1]);
    assert_eq!(events, ["lighting ggx", "f1 would blinn-phong"]);
    assert_eq!(rep.lighting.as_ref().unwrap().brdf, gbuf::resolve::Brdf::Ggx);
    assert_eq!(rep.frames.len(), 2);
    assert!(rep.rows.iter().any(|r| r.frame == "f0") && rep.rows.iter().any(|r| r.frame == "f1"));
    assert!(files.iter().any(|f| f.name.starts_with("frame1_")) && files.iter().any(|f| f.name.starts_with("frame2_")));
    // A frame that cannot be read stops the loop with its own error.
    let failing = |i: usize| -> gbuf::Result<FrameInput> { Err(gbuf::Error::Argument(format!("frame {i} is gone"))) };
    let err = run_frames(1, failing, &cfg, &|_| unreachable!(), &how, &mut |_| {}).unwrap_err();
    assert!(err.to_string().contains("frame 0 is gone"), "{err}");
}

/// The report leaves out a position plane that depth and the camera give bit for bit (every reader derives the same
/// bits), and says the same as with it: every row's numbers, the needs analysis (position derivable, not absent),
/// the visibility buffer's packing and the re-materialisation, including its positions.
#[test]
fn a_frame_reports_the_same_without_the_positions_its_depth_gives() {
    use gbuf::analysis::row::Row;
    use gbuf::study::{run_frame, run_frames, Assembly, FrameInput};
    let (gb, lights) = small_room();
    assert!(gb.position_is_derived(), "the room's positions are its depth along the camera rays");
    let cfg = one_run(&["reference-f32", "fat-20"], vec![Detector::Lauritzen], FlipRows::Decisive);
    let how = Assembly::of(&cfg, gbuf::analysis::aggregate::Over::Worst, None, "");
    let next = |_: usize| -> gbuf::Result<FrameInput> {
        Ok(FrameInput {
            name: "room".into(),
            gbuffer: gb.clone(),
            lights: lights.clone(),
            lights_source: "default".into(),
            single: None,
            geometry: Some(SceneName::Room),
            notes: Vec::new(),
        })
    };
    let choose = |a: &[gbuf::gbuffer::Attribute]| gbuf::resolve::Lighting::choose(None, None, a);
    let (dropped, _) = run_frames(1, next, &cfg, &choose, &how, &mut |_| {}).unwrap();
    let mut kept_cfg = cfg.clone();
    kept_cfg.resolve = choose(&gb.attributes()).apply(kept_cfg.resolve);
    let input = room_input(&gb, &lights, Some(SceneName::Room));
    let kept = run_frame(&input, &kept_cfg, true, "", &mut |_, _, _| {}).unwrap();
    let untimed = |r: &Row| Row {
        encode_ms: None,
        decode_ms: None,
        detect_ms: None,
        resolve_ms: None,
        resolve_pass_ms: None,
        total_ms: None,
        timings: Default::default(),
        pareto: Default::default(),
        ..r.clone()
    };
    assert_eq!(dropped.rows.len(), kept.rows.len());
    for (a, b) in dropped.rows.iter().zip(&kept.rows) {
        assert_eq!(untimed(a), untimed(b), "{} × {}", a.layout, a.detector);
    }
    let (a, b) = (&dropped.frames[0], &kept.frame);
    assert_eq!(a.needs, b.needs);
    assert!(b.needs.derivable.contains(&"position".to_string()) && !b.needs.absent.contains(&"position".to_string()));
    let (pa, pb) = (a.pipelines.as_ref().unwrap(), b.pipelines.as_ref().unwrap());
    assert_eq!(pa.visibility_packing, pb.visibility_packing);
    assert_eq!(pa.rematerialised, pb.rematerialised);
    let remat = pa.rematerialised.as_ref().unwrap();
    assert!(remat.attributes.iter().any(|x| x.attribute == "position"), "{remat:?}");
}
