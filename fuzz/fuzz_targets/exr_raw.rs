//! Any bytes through the EXR layer `gbuf::io::exr::read_raw_bytes` with DWA decoding allowed (header checks, the exr
//! crate's decoders, channel-name decoding), then the canonical reader `canonical::from_raw` on what it returns.
#![no_main]

use gbuf::io::canonical;
use libfuzzer_sys::fuzz_target;

fuzz_target!(init: gbuf_fuzz::init(), |data: &[u8]| {
    gbuf_fuzz::run(|| {
        let path = gbuf_fuzz::dump_path();
        let Ok(raw) = gbuf::io::exr::read_raw_bytes(data, &path, &gbuf_fuzz::limits(true)) else { return };
        let _ = gbuf::io::blender::matches(&raw);
        let _ = gbuf::io::mitsuba::matches(&raw);
        if canonical::matches(&raw) {
            if let Ok(gb) = canonical::from_raw(&raw, &path) {
                let _ = canonical::sources(&raw, &gb);
            }
        }
    });
});
