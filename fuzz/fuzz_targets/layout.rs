//! Any text through the layout file parser `gbuf::layout::spec::LayoutSpec::parse` (TOML or JSON by content), then
//! validation `Layout::from_spec`; a valid layout packs and unpacks a small G-buffer with every attribute, and its
//! spec written back as TOML must parse and validate again.
#![no_main]

use gbuf::layout::spec::{LayoutSpec, SpecSyntax};
use gbuf::layout::Layout;
use libfuzzer_sys::fuzz_target;
use std::path::Path;
use std::sync::OnceLock;

fn gbuffer() -> &'static gbuf::gbuffer::GBuffer {
    static GB: OnceLock<gbuf::gbuffer::GBuffer> = OnceLock::new();
    GB.get_or_init(gbuf_fuzz::gen::sample_gbuffer)
}

fuzz_target!(init: gbuf_fuzz::init(), |data: &[u8]| {
    gbuf_fuzz::run(|| {
        let Ok(text) = std::str::from_utf8(data) else { return };
        let path = Path::new("layout");
        let Ok(spec) = LayoutSpec::parse(path, text) else { return };
        let Ok(layout) = Layout::from_spec(spec.clone()) else { return };
        let _ = layout.footprint_bytes(1920, 1080, 4);
        let _ = layout.roundtrip(gbuffer());
        let toml = spec.to_text(SpecSyntax::Toml).expect("a valid layout writes as TOML");
        let back = LayoutSpec::parse(Path::new("layout.toml"), &toml).expect("its TOML parses");
        Layout::from_spec(back).expect("its TOML validates");
    });
});
