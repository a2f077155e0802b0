//! `gbuf::io::load_bytes` with options: input `OPTIONS\nSIDECAR\0DUMP`, where OPTIONS is a line of tokens
//! (`fold=K dwa max=MIB map=ATTR=CH;CH,… space=… depth=… reversed znear=F zfar=F ids=… background=… normals=…`),
//! SIDECAR the scene JSON (none when empty) and DUMP the file. Reaches folding, `--map` with declared
//! conventions, sidecar cameras and lights, DWA decoding.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(init: gbuf_fuzz::init(), |data: &[u8]| {
    gbuf_fuzz::run(|| {
        let (line, sidecar, dump) = gbuf_fuzz::split_options_input(data);
        let opts = gbuf_fuzz::parse_options(&line, sidecar.map(gbuf_fuzz::sidecar_file));
        let path = gbuf_fuzz::dump_path();
        gbuf_fuzz::loaded(&gbuf::io::load_bytes(dump, &path, &opts), &path);
    });
});
