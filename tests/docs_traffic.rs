//! docs/GUIDE.md's footprint and traffic table is the one model of `gbuf::analysis::traffic`, printed: a change to
//! the model that the docs do not follow fails here (`GBUF_BLESS=1 cargo test --test docs_traffic` rewrites it).

use gbuf::analysis::traffic::markdown_table;

const HEADER: &str = "| row | footprint (bytes) | traffic (bytes per frame) |";

#[test]
fn guide_table_is_the_traffic_model() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/GUIDE.md");
    let text = std::fs::read_to_string(&path).expect("docs/GUIDE.md");
    let start = text.find(HEADER).expect("GUIDE.md holds the traffic table");
    let end = text[start..].find("\n\n").map_or(text.len(), |e| start + e + 1);
    let want = markdown_table();
    if std::env::var_os("GBUF_BLESS").is_some() {
        std::fs::write(&path, format!("{}{want}{}", &text[..start], &text[end..])).expect("rewrite GUIDE.md");
        return;
    }
    assert_eq!(&text[start..end], want, "docs/GUIDE.md's table differs from the model: rerun with GBUF_BLESS=1");
}
