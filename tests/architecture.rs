//! The tree is the pipeline (docs/ARCHITECTURE.md): every top-level module of `src/` imports only the modules
//! before it in [`LAYERS`], no two files of `src/` (in any directory) import each other in a circle, and every
//! `#[target_feature(enable = …)]` names one of the feature lists of `base::isa`.
//!
//! Files are read whole, as text, with only their `#[cfg(test)] mod NAME { … }` blocks left out (tests may reach
//! anywhere). The layer check reads `crate::<module>` paths anywhere, doc links included (a link up the pipeline is
//! a dependency a reader follows); the cycle check reads `crate::…`, `super::…` and `self::…` paths (and grouped
//! `use …::{a, b}` imports) outside comments, resolved to the file that defines the module, as
//! `../shared/tools/file_cycles.py` does. A parent (`mod.rs`, `lib.rs`, or `a.rs` beside a folder `a/`) naming its
//! own children is the parent re-exporting them, not an edge. `lib.rs`, `main.rs` and `cli/` (the binary) sit above
//! the layers; `main.rs` is left out of the cycle check.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The top-level modules in pipeline order: each may import only those before it.
const LAYERS: [&str; 16] = [
    "error", "base", "camera", "light", "gbuffer", "codec", "io", "image", "scene", "layout", "detect", "resolve",
    "measure", "analysis", "report", "study",
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

/// The file without its `#[cfg(test)] mod NAME { … }` blocks (braces matched).
fn non_test(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find("#[cfg(test)]") {
        let after = &rest[i + "#[cfg(test)]".len()..];
        let t = after.trim_start();
        let t = t.strip_prefix("pub(crate)").or_else(|| t.strip_prefix("pub")).unwrap_or(t).trim_start();
        let Some(m) = t.strip_prefix("mod ") else {
            out.push_str(&rest[..i + "#[cfg(test)]".len()]);
            rest = after;
            continue;
        };
        let Some(open) = m.find('{').filter(|&o| m[..o].trim().chars().all(|c| c.is_alphanumeric() || c == '_')) else {
            out.push_str(&rest[..i + "#[cfg(test)]".len()]);
            rest = after;
            continue;
        };
        out.push_str(&rest[..i]);
        let body = &m[open + 1..];
        let mut depth = 1;
        let mut end = body.len();
        for (j, c) in body.char_indices() {
            depth += match c {
                '{' => 1,
                '}' => -1,
                _ => 0,
            };
            if depth == 0 {
                end = j + 1;
                break;
            }
        }
        rest = &body[end..];
    }
    out.push_str(rest);
    out
}

/// `text` without `//` comments (doc links name modules without importing them).
fn without_comments(text: &str) -> String {
    text.lines().map(|l| l.find("//").map_or(l, |i| &l[..i])).collect::<Vec<_>>().join("\n")
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
        for m in paths(&non_test(&text), "crate::") {
            match layer(m) {
                Some(l) if l > own => wrong.push(format!("{} imports crate::{m} (a later stage)", rel.display())),
                _ => {}
            }
        }
    }
    assert!(wrong.is_empty(), "imports against the pipeline:\n{}", wrong.join("\n"));
    assert_eq!(seen.len(), LAYERS.len(), "every layer exists in src/: {seen:?}");
}

/// The module path of a file: `src/a/b.rs` → `[a, b]`, `src/a/mod.rs` → `[a]`, `src/lib.rs` → `[]`.
fn module_path(root: &Path, f: &Path) -> Vec<String> {
    let rel = f.strip_prefix(root).unwrap().with_extension("");
    let mut parts: Vec<String> = rel.components().map(|c| c.as_os_str().to_string_lossy().to_string()).collect();
    if parts.last().is_some_and(|l| l == "mod" || l == "lib") {
        parts.pop();
    }
    parts
}

/// Module paths named in `text` (comments and test modules already removed) by a file at module path `me`:
/// `crate::a::b`, `super::x` (any number of `super::`), `self::x`, and the items of grouped imports.
fn named_paths(text: &str, me: &[String]) -> Vec<Vec<String>> {
    let ident = |s: &str| s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_') && !s.is_empty();
    let mut out = Vec::new();
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < text.len() {
        let starts_word =
            i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_' || bytes[i - 1] == b':');
        let rest = &text[i..];
        let head = ["crate::", "super::", "self::"].into_iter().find(|h| starts_word && rest.starts_with(h));
        let Some(head) = head else {
            i += rest.chars().next().map_or(1, char::len_utf8);
            continue;
        };
        // The base module and the remaining `a::b::{…}` path.
        let mut base: Vec<String> = match head {
            "crate::" => vec![],
            "self::" => me.to_vec(),
            _ => me.to_vec(),
        };
        let mut j = i + head.len();
        if head == "super::" {
            base.pop();
            while text[j..].starts_with("super::") {
                base.pop();
                j += "super::".len();
            }
        }
        let mut path = base;
        loop {
            let seg_end =
                text[j..].find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).map_or(text.len(), |e| j + e);
            let seg = &text[j..seg_end];
            if !ident(seg) {
                if text[j..].starts_with('{') {
                    let close = text[j..].find('}').map_or(text.len(), |e| j + e);
                    for item in text[j + 1..close].split(',') {
                        let item = item.trim().split(" as ").next().unwrap_or("").trim();
                        let segs: Vec<String> =
                            item.split("::").filter(|s| ident(s) && *s != "self").map(String::from).collect();
                        if !segs.is_empty() {
                            out.push(path.iter().cloned().chain(segs).collect());
                        }
                    }
                    j = close;
                }
                break;
            }
            path.push(seg.to_string());
            j = seg_end;
            if text[j..].starts_with("::") {
                j += 2;
            } else {
                break;
            }
        }
        if !text[j..].starts_with('!') {
            out.push(path);
        }
        i = j.max(i + 1);
    }
    out
}

/// Every group of files that import each other (strongly connected components of more than one file).
fn file_cycles(root: &Path) -> Vec<Vec<String>> {
    let mut files = Vec::new();
    rust_files(root, &mut files);
    files.retain(|f| f.file_name().is_some_and(|n| n != "main.rs"));
    let by_module: BTreeMap<Vec<String>, usize> =
        files.iter().enumerate().map(|(i, f)| (module_path(root, f), i)).collect();
    let file_of = |path: &[String]| (0..=path.len()).rev().find_map(|k| by_module.get(&path[..k]).copied());
    let mut graph: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); files.len()];
    for (i, f) in files.iter().enumerate() {
        let me = module_path(root, f);
        let is_parent = matches!(f.file_name().and_then(|n| n.to_str()), Some("mod.rs" | "lib.rs"))
            || f.with_extension("").is_dir();
        let text = without_comments(&non_test(&std::fs::read_to_string(f).unwrap()));
        for p in named_paths(&text, &me) {
            let Some(q) = file_of(&p) else { continue };
            let target = module_path(root, &files[q]);
            if q == i || (is_parent && target.starts_with(&me)) {
                continue;
            }
            graph[i].insert(q);
        }
    }
    // Tarjan's strongly connected components.
    struct T<'a> {
        g: &'a [BTreeSet<usize>],
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
    }
    fn visit(t: &mut T<'_>, v: usize) {
        t.index[v] = Some(t.next);
        t.low[v] = t.next;
        t.next += 1;
        t.stack.push(v);
        t.on[v] = true;
        for &w in t.g[v].iter() {
            match t.index[w] {
                None => {
                    visit(t, w);
                    t.low[v] = t.low[v].min(t.low[w]);
                }
                Some(iw) if t.on[w] => t.low[v] = t.low[v].min(iw),
                _ => {}
            }
        }
        if Some(t.low[v]) == t.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on[w] = false;
                comp.push(w);
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                t.out.push(comp);
            }
        }
    }
    let n = files.len();
    let mut t =
        T { g: &graph, index: vec![None; n], low: vec![0; n], on: vec![false; n], stack: vec![], next: 0, out: vec![] };
    for v in 0..n {
        if t.index[v].is_none() {
            visit(&mut t, v);
        }
    }
    let name = |i: usize| files[i].strip_prefix(root).unwrap().display().to_string();
    let mut out: Vec<Vec<String>> = t
        .out
        .iter()
        .map(|c| {
            let mut c: Vec<String> = c.iter().map(|&i| name(i)).collect();
            c.sort();
            c
        })
        .collect();
    out.sort();
    out
}

#[test]
fn no_files_import_each_other_in_a_circle() {
    let cycles = file_cycles(&src());
    assert!(
        cycles.is_empty(),
        "files of src/ that import each other (move the shared data below the code that fills it):\n{}",
        cycles.iter().map(|c| c.join(", ")).collect::<Vec<_>>().join("\n")
    );
}

/// The cycle finder finds a cycle through `super::`, `self::` and grouped imports, ignores a parent naming its
/// children, comments and test modules.
#[test]
fn the_cycle_finder_sees_every_kind_of_import() {
    let dir = std::env::temp_dir().join(format!("gbuf-arch-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let put = |p: &str, t: &str| {
        let f = dir.join(p);
        std::fs::create_dir_all(f.parent().unwrap()).unwrap();
        std::fs::write(f, t).unwrap();
    };
    put("lib.rs", "pub mod a;\npub mod b;\n");
    put("a/mod.rs", "pub mod x;\npub mod y;\nuse self::x::X;\n");
    put("a/x.rs", "use super::{y::Y, z};\n");
    put("a/y.rs", "// crate::a::x::X is only named here\n#[cfg(test)]\nmod tests { use crate::a::x; }\n");
    put("b.rs", "");
    assert!(file_cycles(&dir).is_empty(), "{:?}", file_cycles(&dir));
    put("a/y.rs", "pub fn f() { crate::a::x::g(); }\n");
    assert_eq!(file_cycles(&dir), [vec!["a/x.rs".to_string(), "a/y.rs".to_string()]]);
    put("a/y.rs", "");
    put("b.rs", "use crate::a::{x::X as Z};\n");
    put("a/x.rs", "fn f() { super::super::b::g() }\n");
    assert_eq!(file_cycles(&dir), [vec!["a/x.rs".to_string(), "b.rs".to_string()]]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn every_target_feature_list_is_one_of_the_isa_levels() {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    let levels = [gbuf::base::isa::AVX2_FEATURES, gbuf::base::isa::AVX512_FEATURES];
    // One ISA dispatch idiom: `base::isa::run` and its two wrappers. Besides them only functions written in
    // intrinsics carry the attribute (the resolve's surface reads), never a wrapper of their own.
    let users = ["src/base/isa.rs", "src/resolve/surface.rs"];
    let mut found = BTreeMap::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        const ATTR: &str = "#[target_feature(enable = \"";
        let rel = f.strip_prefix(env!("CARGO_MANIFEST_DIR")).unwrap().display().to_string();
        for (i, _) in text.match_indices(ATTR) {
            let list = &text[i + ATTR.len()..];
            let list = &list[..list.find('"').unwrap()];
            assert!(levels.contains(&list), "{rel}: target_feature {list:?} is not a level of base::isa");
            assert!(
                users.contains(&rel.as_str()),
                "{rel}: a #[target_feature] wrapper of its own: run the work under base::isa::run (a Kernel)"
            );
            *found.entry(rel.clone()).or_insert(0) += 1;
        }
    }
    assert_eq!(found.get("src/base/isa.rs"), Some(&2), "base::isa's two wrappers: {found:?}");
}

#[test]
fn the_reader_finds_paths_and_skips_macros() {
    let t = "use crate::gbuffer::GBuffer; crate::named!(X); [`crate::measure::edges`] super::kernel::shade";
    assert_eq!(paths(t, "crate::"), ["gbuffer", "measure"]);
    assert_eq!(paths(t, "super::"), ["kernel"]);
    assert_eq!(non_test("a\n#[cfg(test)]\nmod tests { use crate::report; }\nb"), "a\n\nb");
    assert_eq!(non_test("#[cfg(test)]\nfn f() { crate::report::x() }"), "#[cfg(test)]\nfn f() { crate::report::x() }");
}

/// The folders of the repository a document or comment may name a path in.
const REPO_DIRS: [&str; 10] =
    ["src/", "tests/", "docs/", "benches/", "fixtures/", "examples/", "fuzz/", "python/", "scripts/", ".ci/"];

/// Paths a document names in another repository (the ISPC example, NVIDIA's FLIP, LuxCoreRender), folders the
/// fuzz scripts create, and the examples of a doc comment.
const ELSEWHERE: [&str; 8] = [
    "examples/cpu/deferred",
    "examples/deferred",
    "src/cpp/",
    "src/slg/",
    "fuzz/corpus/",
    "fuzz/logs/",
    "src/a/",
    "src/a.",
];

/// Every repository path named in the documents (`*.md` outside `target/`) and in the comments of `src/`, `tests/`,
/// `benches/` and `examples/` — `docs/RESOLVE.md`, `src/io/ispc.rs:120`, `fixtures/scripts/` — exists, from the
/// repository's root or from the naming file's folder. Tokens with
/// placeholders (`<`, `*`, `{`, `…`, `NAME`) are patterns, not paths, and are skipped.
#[test]
fn every_path_the_docs_name_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            if p.is_dir() {
                if !matches!(name.as_str(), "target" | ".git" | "seeds" | "corpus" | "artifacts" | "node_modules") {
                    walk(&p, out);
                }
            } else if name.ends_with(".md") || name.ends_with(".rs") || name.ends_with(".sh") || name.ends_with(".py") {
                out.push(p);
            }
        }
    }
    walk(root, &mut files);
    let mut missing = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let rel = f.strip_prefix(root).unwrap().display().to_string();
        let md = rel.ends_with(".md");
        for (n, line) in text.lines().enumerate() {
            // In code, only comments: string literals name paths a test creates.
            let prose = if md {
                line
            } else {
                match line.find("//").or_else(|| line.find("# ").filter(|_| !rel.ends_with(".rs"))) {
                    Some(i) => &line[i..],
                    None => continue,
                }
            };
            let here = f.parent().unwrap();
            for token in doc_paths(prose) {
                let foreign = ELSEWHERE.iter().any(|p| token.starts_with(p));
                if !foreign && !root.join(&token).exists() && !here.join(&token).exists() {
                    missing.push(format!("{rel}:{}: {token}", n + 1));
                }
            }
        }
    }
    assert!(missing.is_empty(), "paths named in docs and comments that do not exist:\n{}", missing.join("\n"));
}

/// The repository paths in a line of prose: words starting with one of [`REPO_DIRS`] (after a space, a quote, a
/// bracket or a backtick), cut at the first character a path does not hold, with `:LINE` and `#anchor` dropped.
fn doc_paths(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (i, _) in line.char_indices() {
        let before = line[..i].chars().last();
        if before.is_some_and(|c| !matches!(c, ' ' | '(' | '`' | '"' | '\'' | '[' | ',')) {
            continue;
        }
        let rest = &line[i..];
        if !REPO_DIRS.iter().any(|d| rest.starts_with(d)) {
            continue;
        }
        let end = rest
            .find(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '/' | '.' | '_' | '-')))
            .unwrap_or(rest.len());
        let after = rest[end..].chars().next();
        if after.is_some_and(|c| matches!(c, '<' | '*' | '{' | '…' | '$')) {
            continue;
        }
        let token = rest[..end].trim_end_matches(['.', ',']);
        if token.chars().any(|c| c.is_ascii_uppercase())
            && token.split('/').any(|s| s.chars().all(|c| c.is_ascii_uppercase() || c == '_'))
        {
            continue; // a placeholder such as fixtures/NAME
        }
        out.push(token.to_string());
    }
    out
}

/// The files of `src/` that list the G-buffer's planes one by one — name at least [`LIST_THRESHOLD`] of the
/// [`PLANES`], as fields (`.albedo`, `albedo:`) or as `Attribute::` variants. A new attribute is added in each of
/// them; docs/ARCHITECTURE.md ("Walking the planes") names every one. A file that starts listing the planes fails
/// [`the_planes_are_listed_only_where_the_architecture_says`] until it goes through `GBuffer::plane`/`slot` instead,
/// or joins this list and the document.
const PLANE_LISTS: [&str; 10] = [
    "src/gbuffer.rs",
    "src/io/canonical.rs",
    "src/io/fileset.rs",
    "src/io/mapped.rs",
    "src/io/blender.rs",
    "src/io/mitsuba.rs",
    "src/scene/raycast.rs",
    "src/scene/rematerialise.rs",
    "src/resolve/fixture.rs",
    "src/analysis/budget.rs",
];

/// The G-buffer's planes besides coverage: field name and `Attribute` variant.
const PLANES: [(&str, &str); 12] = [
    ("depth", "Depth"),
    ("position", "Position"),
    ("normal", "Normal"),
    ("albedo", "Albedo"),
    ("specular", "Specular"),
    ("specular_power", "SpecularPower"),
    ("roughness", "Roughness"),
    ("metallic", "Metallic"),
    ("material_id", "MaterialId"),
    ("object_id", "ObjectId"),
    ("primitive_id", "PrimitiveId"),
    ("motion", "Motion"),
];

/// Naming this many of the 12 planes makes a file a list of them (the resolve, which reads the 8 it lights with,
/// is a reader of planes, not a list).
const LIST_THRESHOLD: usize = 9;

/// How many of [`PLANES`] `text` names as a field or an `Attribute` variant (whichever names more).
fn planes_named(text: &str) -> usize {
    let word_at = |hay: &str, needle: &str| {
        hay.match_indices(needle).any(|(i, _)| {
            let after = hay[i + needle.len()..].chars().next();
            !after.is_some_and(|c| c.is_alphanumeric() || c == '_')
        })
    };
    let fields =
        PLANES.iter().filter(|(f, _)| word_at(text, &format!(".{f}")) || word_at(text, &format!(" {f}:"))).count();
    let variants = PLANES.iter().filter(|(_, v)| word_at(text, &format!("Attribute::{v}"))).count();
    fields.max(variants)
}

#[test]
fn the_planes_are_listed_only_where_the_architecture_says() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    let mut lists = BTreeSet::new();
    for f in &files {
        let rel = f.strip_prefix(root).unwrap().display().to_string();
        if rel.starts_with("src/cli/") {
            continue; // the binary prints what the library gives it
        }
        if planes_named(&non_test(&std::fs::read_to_string(f).unwrap())) >= LIST_THRESHOLD {
            lists.insert(rel);
        }
    }
    let allowed: BTreeSet<String> = PLANE_LISTS.iter().map(|s| s.to_string()).collect();
    let new: Vec<_> = lists.difference(&allowed).collect();
    let gone: Vec<_> = allowed.difference(&lists).collect();
    assert!(
        new.is_empty(),
        "these files list the G-buffer's planes one by one: walk them with GBuffer::plane/slot instead, or add them \
         to PLANE_LISTS and to docs/ARCHITECTURE.md (\"Walking the planes\"): {new:?}"
    );
    assert!(gone.is_empty(), "no longer plane lists: take them out of PLANE_LISTS and the document: {gone:?}");
    let doc = std::fs::read_to_string(root.join("docs/ARCHITECTURE.md")).unwrap();
    let section = &doc[doc.find("**Walking the planes**").expect("the section")..];
    let section = &section[..section.find("\n- **").unwrap_or(section.len())];
    for f in PLANE_LISTS {
        let module = f.trim_start_matches("src/").trim_end_matches(".rs").replace('/', "::");
        assert!(
            section.contains(f) || section.contains(&format!("`{module}`")) || section.contains(&format!("{module}::")),
            "docs/ARCHITECTURE.md's \"Walking the planes\" does not name {f}"
        );
    }
    // The detector itself: a made-up file listing the planes is a list; the resolve's reading of eight is not.
    let made_up = PLANES.iter().map(|(f, _)| format!("let x = gb.{f};")).collect::<Vec<_>>().join("\n");
    assert!(planes_named(&made_up) >= LIST_THRESHOLD);
    assert!(planes_named(&std::fs::read_to_string(root.join("src/resolve/surface.rs")).unwrap()) < LIST_THRESHOLD);
}
