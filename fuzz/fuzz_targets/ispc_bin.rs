//! Any bytes through the ISPC `.bin` reader `gbuf::io::ispc::read_bytes` (header fields, array offsets, decoding),
//! and the refusal text `header_problem` gives for files no reader takes.
#![no_main]

use gbuf::io::ispc;
use libfuzzer_sys::fuzz_target;

fuzz_target!(init: gbuf_fuzz::init(), |data: &[u8]| {
    gbuf_fuzz::run(|| {
        let path = gbuf_fuzz::dump_path();
        let _ = ispc::matches_file(data, data.len() as u64);
        let _ = ispc::header_problem(data, data.len() as u64);
        let _ = ispc::read_bytes(data, &path, &gbuf_fuzz::default_options());
    });
});
