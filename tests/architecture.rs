//! The tree is the pipeline (docs/ARCHITECTURE.md): every top-level module of `src/` imports only the modules
//! before it in [`LAYERS`], the files of `src/resolve` import each other without a cycle, and every
//! `#[target_feature(enable = …)]` names one of the feature lists of `base::isa`.
//!
//! Imports are read as text, as `crate::<module>` paths anywhere outside a file's `#[cfg(test)]` part (doc links
//! count: a link up the pipeline is a dependency a reader follows), and `super::<file>` inside `src/resolve`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The top-level modules in pipeline order: each may import only those before it.
const LAYERS: [&str; 16] = [
    "error", "util", "base", "camera", "light", "gbuffer", "io", "image", "scene", "codec", "layout", "detect",
    "resolve", "measure", "analysis", "report",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The part of a file before its test module.
fn non_test(text: &str) -> &str {
    text.split("#[cfg(test)]").next().unwrap_or("")
}

/// Every `<prefix><ident>` in `text` (identifiers of lower-case letters, digits and `_`) not followed by `!`.
fn paths<'a>(text: &'a str, prefix: &str) -> Vec<&'a str> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find(prefix) {
        let after = &rest[i + prefix.len()..];
        let n =
            after.find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')).unwrap_or(after.len());
        if n > 0 && !after[n..].starts_with('!') {
            out.push(&after[..n]);
        }
        rest = &after[n..];
    }
    out
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn every_import_points_down_the_pipeline() {
    let root = src();
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    let layer = |m: &str| LAYERS.iter().position(|l| *l == m);
    let mut wrong = Vec::new();
    let mut seen = BTreeSet::new();
    for f in &files {
        let rel = f.strip_prefix(&root).unwrap();
        let first = rel.components().next().unwrap().as_os_str().to_string_lossy().trim_end_matches(".rs").to_string();
        if matches!(first.as_str(), "lib" | "main" | "cli") {
            continue;
        }
        let own = layer(&first).unwrap_or_else(|| panic!("src/{first} is not in LAYERS: add it where it belongs"));
        seen.insert(first.clone());
        let text = std::fs::read_to_string(f).unwrap();
        for m in paths(non_test(&text), "crate::") {
            match layer(m) {
                Some(l) if l > own => wrong.push(format!("{} imports crate::{m} (a later stage)", rel.display())),
                _ => {}
            }
        }
    }
    assert!(wrong.is_empty(), "imports against the pipeline:\n{}", wrong.join("\n"));
    assert_eq!(seen.len(), LAYERS.len(), "every layer exists in src/: {seen:?}");
}

#[test]
fn the_resolve_files_import_each_other_without_a_cycle() {
    let dir = src().join("resolve");
    let mut files = Vec::new();
    rust_files(&dir, &mut files);
    let name = |p: &Path| p.file_stem().unwrap().to_string_lossy().to_string();
    let names: BTreeSet<String> = files.iter().map(|p| name(p)).collect();
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let me = name(f);
        let text = std::fs::read_to_string(f).unwrap();
        let body = non_test(&text);
        let deps = paths(body, "super::").into_iter().chain(paths(body, "crate::resolve::"));
        let deps: BTreeSet<String> =
            deps.filter(|d| names.contains(*d) && *d != me && *d != "mod").map(String::from).collect();
        graph.insert(me, deps);
    }
    // Depth-first search for a back edge.
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) {
        match state.get(n) {
            Some(2) => return,
            Some(1) => panic!("import cycle in src/resolve: {} -> {n}", path.join(" -> ")),
            _ => {}
        }
        state.insert(n.to_string(), 1);
        path.push(n.to_string());
        for d in g.get(n).into_iter().flatten() {
            visit(d, g, state, path);
        }
        path.pop();
        state.insert(n.to_string(), 2);
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        visit(n, &graph, &mut state, &mut Vec::new());
    }
    assert!(graph["kernel"].contains("worklist") && graph["surface"].contains("worklist"), "the graph was read");
}

#[test]
fn every_target_feature_list_is_one_of_the_isa_levels() {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    let levels = [gbuf::base::isa::AVX2_FEATURES, gbuf::base::isa::AVX512_FEATURES];
    let mut found = 0;
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        const ATTR: &str = "#[target_feature(enable = \"";
        for (i, _) in text.match_indices(ATTR) {
            let list = &text[i + ATTR.len()..];
            let list = &list[..list.find('"').unwrap()];
            assert!(levels.contains(&list), "{}: target_feature {list:?} is not a level of base::isa", f.display());
            found += 1;
        }
    }
    assert!(found > 10, "target_feature attributes were found ({found})");
}

#[test]
fn the_reader_finds_paths_and_skips_macros() {
    let t = "use crate::gbuffer::GBuffer; crate::named!(X); [`crate::measure::edges`] super::kernel::shade";
    assert_eq!(paths(t, "crate::"), ["gbuffer", "measure"]);
    assert_eq!(paths(t, "super::"), ["kernel"]);
    assert_eq!(non_test("a\n#[cfg(test)]\nuse crate::report;"), "a\n");
}
