//! fixtures/room_4x.exr and room_1x.exr + their .json (written by fixtures/scripts/make_canonical.sh) still equal a
//! fresh render.

use gbuf::io::canonical;
use gbuf::io::sidecar::Sidecar;
use gbuf::io::LoadOptions;
use gbuf::scene::{default_lights, render, SceneName};
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

#[test]
fn room_fixture_matches_a_fresh_render_bit_for_bit() {
    for samples in [4, 1] {
        check(samples);
    }
}

fn check(samples: u32) {
    let path = fixture(&format!("room_{samples}x.exr"));
    let got = canonical::read(&path, &LoadOptions::default()).unwrap();
    let expect = render(SceneName::Room, 160, 90, samples).unwrap();
    assert_eq!((got.width, got.height, got.samples), (160, 90, samples));
    assert!(
        got == expect,
        "{} differs from the current room scene: rerun fixtures/scripts/make_canonical.sh",
        path.display()
    );

    let side_path = fixture(&format!("room_{samples}x.json"));
    let side = Sidecar::load(&side_path).unwrap();
    assert_eq!(side.camera.as_ref().unwrap().to_camera(), expect.camera.unwrap());
    assert_eq!(side.view_lights(None, &side_path).unwrap(), default_lights(SceneName::Room, &expect));
}
