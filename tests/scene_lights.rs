//! Default and scattered lights: deterministic, inside the visible volume, robust to degenerate G-buffers.

use gbuf::io::sidecar::Sidecar;
use gbuf::scene::{default_lights, lights::SCATTER_OVERLAP, render, scatter_lights, scene_sidecar, SceneName};
use gbuf::{Camera, GBuffer, LightKind};
use glam::Vec3;
use std::path::Path;

fn covered_depth_range(gb: &GBuffer) -> (f32, f32) {
    let d = gb.depth.as_ref().unwrap();
    (0..gb.len()).filter(|&i| gb.coverage[i]).fold((f32::INFINITY, 0.0f32), |(lo, hi), i| (lo.min(d[i]), hi.max(d[i])))
}

/// Lights are placed in f32; allow rounding at the frustum boundary (relative 1e-4 of the distance).
const BOUNDARY_TOL: f32 = 1e-4;

#[test]
fn scattered_lights_are_deterministic_and_inside_the_covered_frustum() {
    let gb = render(SceneName::Room, 160, 90, 1).unwrap();
    let a = scatter_lights(&gb, 500, 7);
    assert_eq!(a, scatter_lights(&gb, 500, 7));
    assert_ne!(a, scatter_lights(&gb, 500, 8));
    assert_eq!(a.len(), 500);
    let cam = gb.camera.unwrap();
    let (lo, hi) = covered_depth_range(&gb);
    for l in &a {
        assert_eq!(l.kind, LightKind::Point);
        let d = -l.position.z;
        assert!(d >= lo * (1.0 - BOUNDARY_TOL) && d <= hi * (1.0 + BOUNDARY_TOL), "depth {d} outside [{lo}, {hi}]");
        let px = cam.project(l.position, gb.width, gb.height).unwrap();
        let slack = BOUNDARY_TOL * gb.width as f32;
        assert!(px.x >= -slack && px.x <= gb.width as f32 + slack, "x {px}");
        assert!(px.y >= -slack && px.y <= gb.height as f32 + slack, "y {px}");
        assert!(l.range.is_finite() && l.range > 0.0 && l.intensity > 0.0 && l.color.min_element() >= 0.0);
    }
}

#[test]
fn scattered_lights_overlap_moderately() {
    let gb = render(SceneName::Room, 160, 90, 1).unwrap();
    let pos = gb.position.as_ref().unwrap();
    for n in [50, 2000] {
        let lights = scatter_lights(&gb, n, 1);
        // Average number of lights reaching a point of the visible volume, estimated at random points of it.
        let more = scatter_lights(&gb, 400, 99);
        let mean = more
            .iter()
            .map(|p| lights.iter().filter(|l| (l.position - p.position).length() < l.range).count())
            .sum::<usize>() as f32
            / more.len() as f32;
        assert!(mean > SCATTER_OVERLAP / 3.0 && mean < SCATTER_OVERLAP * 3.0, "{n} lights: {mean} reach a point");
        // And surfaces get light: most covered samples are within range of at least one light.
        let covered: Vec<Vec3> = (0..gb.len()).filter(|&i| gb.coverage[i]).step_by(13).map(|i| pos[i]).collect();
        let lit = covered.iter().filter(|&&p| lights.iter().any(|l| (l.position - p).length() < l.range)).count();
        assert!(lit * 2 > covered.len(), "{n} lights: only {lit} of {} surface points lit", covered.len());
    }
}

#[test]
fn degenerate_requests_do_not_panic() {
    let gb = render(SceneName::Stress, 64, 36, 1).unwrap();
    assert!(scatter_lights(&gb, 0, 1).is_empty());
    let many = scatter_lights(&gb, 100_000, 1);
    assert_eq!(many.len(), 100_000);
    assert!(many.iter().all(|l| l.position.is_finite() && l.range.is_finite() && l.range > 0.0));

    // No coverage, with a camera: the camera frustum from znear to min(zfar, 100 znear).
    let mut empty = GBuffer::new(32, 18, 4).unwrap();
    let cam = Camera::identity(0.8, 32.0 / 18.0, 0.5, 1000.0);
    empty.camera = Some(cam);
    let l = scatter_lights(&empty, 100, 3);
    assert_eq!(l.len(), 100);
    for x in &l {
        let d = -x.position.z;
        assert!((0.5 * (1.0 - BOUNDARY_TOL)..=50.0 * (1.0 + BOUNDARY_TOL)).contains(&d), "depth {d}");
        assert!(cam.project(x.position, 32, 18).is_some());
    }
    // No camera, no coverage: the unit box in front of the origin.
    let bare = GBuffer::new(0, 0, 1).unwrap();
    for x in scatter_lights(&bare, 50, 3) {
        assert!(x.position.abs().max_element() <= 1.5 && x.position.z < 0.0, "{}", x.position);
    }
    // Positions but no depth plane: the depth range comes from the positions.
    let mut no_depth = render(SceneName::Room, 64, 36, 1).unwrap();
    let (lo, hi) = covered_depth_range(&no_depth);
    no_depth.depth = None;
    for x in scatter_lights(&no_depth, 200, 4) {
        let d = -x.position.z;
        assert!(d >= lo * (1.0 - BOUNDARY_TOL) && d <= hi * (1.0 + BOUNDARY_TOL), "depth {d} outside [{lo}, {hi}]");
    }
    // A broken camera is ignored, not trusted.
    let mut broken = GBuffer::new(4, 4, 1).unwrap();
    broken.camera = Some(Camera::identity(f32::NAN, 1.0, 0.0, -1.0));
    assert!(scatter_lights(&broken, 10, 1).iter().all(|l| l.position.is_finite()));
    assert_eq!(default_lights(SceneName::Room, &broken).len(), 25);
}

#[test]
fn default_lights_are_deterministic_with_one_sun() {
    for name in SceneName::ALL {
        let gb = render(name, 96, 54, 1).unwrap();
        let a = default_lights(name, &gb);
        assert_eq!(a, default_lights(name, &gb));
        let suns: Vec<Vec3> = a
            .iter()
            .filter_map(|l| match l.kind {
                LightKind::Directional { direction } => Some(direction),
                _ => None,
            })
            .collect();
        assert_eq!(suns.len(), 1, "{name}");
        assert!((suns[0].length() - 1.0).abs() < 1e-5);
        assert!(a.len() >= 12, "{name}: {} lights", a.len());
        assert!(a.iter().all(|l| l.position.is_finite() && l.range > 0.0 && l.intensity > 0.0));
    }
    // The room's sun shines down (−Y in the world) into the room (its view-space direction points away from
    // the window, i.e. towards the camera: +z).
    let gb = render(SceneName::Room, 96, 54, 1).unwrap();
    let sun = default_lights(SceneName::Room, &gb).into_iter().find(|l| l.is_directional()).unwrap();
    let LightKind::Directional { direction } = sun.kind else { unreachable!() };
    assert!(direction.z > 0.5, "sun direction {direction}");
}

#[test]
fn sidecar_round_trips_camera_and_lights_exactly() {
    let gb = render(SceneName::Room, 96, 54, 4).unwrap();
    let mut lights = default_lights(SceneName::Room, &gb);
    lights.extend(scatter_lights(&gb, 20, 5));
    let text = serde_json::to_string(&scene_sidecar(&gb, &lights)).unwrap();
    let back = Sidecar::parse(&text, Path::new("mem.json")).unwrap();
    assert_eq!(back.camera.as_ref().unwrap().to_camera(), gb.camera.unwrap());
    assert_eq!(back.view_lights(None, Path::new("mem.json")).unwrap(), lights);
}

/// JSON has no infinity: a number beyond `f32::MAX` would read as one, light nothing sensible and not serialize
/// back (a fuzzer's find). Every such number is named with its path, in one error.
#[test]
fn sidecar_numbers_beyond_f32_are_refused_with_their_paths() {
    let text = r#"{"camera": {"world_to_view": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "yfov": 1.0,
        "aspect": 1.0, "znear": 0.1, "zfar": 100.0, "principal_point": [1e39, 0]},
        "lights": [{"type": "point", "position": [0, 0, -1], "range": -1e39}]}"#;
    let e = Sidecar::parse(text, Path::new("big.json")).unwrap_err().to_string();
    assert!(e.contains("big.json"), "{e}");
    assert!(e.contains("camera.principal_point[0]"), "{e}");
    assert!(e.contains("lights[0].range"), "{e}");
    // The largest finite f32 itself is a number like any other.
    let ok = text.replace("1e39", "3.4e38");
    assert!(Sidecar::parse(&ok, Path::new("ok.json")).is_ok());
}
