//! Any bytes through `gbuf::io::load_bytes` with gbuf's default options (declared size capped, see
//! `max_declared_bytes`): format detection, the EXR and `.bin` readers, sanitizing, validation, plausibility checks,
//! then `gbuf info`'s statistics of what loaded.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(init: gbuf_fuzz::init(), |data: &[u8]| {
    gbuf_fuzz::run(|| {
        let path = gbuf_fuzz::dump_path();
        gbuf_fuzz::loaded(&gbuf::io::load_bytes(data, &path, &gbuf_fuzz::default_options()), &path);
    });
});
