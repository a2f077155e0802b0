//! Any text through the sidecar parser `gbuf::io::Sidecar::parse`; for a sidecar it accepts: its camera for a few
//! image sizes, its lights in view space (with its own camera and with none), and a JSON round trip that must give
//! the same sidecar back.
#![no_main]

use gbuf::io::Sidecar;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(init: gbuf_fuzz::init(), |data: &[u8]| {
    gbuf_fuzz::run(|| {
        let Ok(text) = std::str::from_utf8(data) else { return };
        let path = Path::new("scene.json");
        let Ok(s) = Sidecar::parse(text, path) else { return };
        if let Some(c) = &s.camera {
            for (w, h) in [(1, 1), (16, 9), (1920, 1080)] {
                let _ = c.to_camera_for(w, h).is_valid();
            }
        }
        let _ = s.view_lights(None, path);
        let cam = s.camera.as_ref().map(|c| c.to_camera());
        let _ = s.view_lights(cam.as_ref(), path);
        let json = serde_json::to_string(&s).expect("a parsed sidecar serializes");
        let back = Sidecar::parse(&json, path).expect("a serialized sidecar parses");
        assert_eq!(back, s, "sidecar JSON round trip");
    });
});
