//! `report.html`: the report as one self-contained file to share (a review, a chat, a wiki): report.md's content
//! with every figure inline (PNG as data URIs, SVG as markup), every table sortable (click a header) and
//! filterable (a box above it), and nothing fetched from anywhere: a Content-Security-Policy forbids every request
//! but inline data, so a browser shows it offline exactly as written (tests/report_html.rs loads it in headless
//! Chromium and checks for console errors and a rendered screenshot).
//!
//! It is rendered from the report's own Markdown, the subset `report::markdown` writes (headings, pipe tables,
//! lists, paragraphs with `**bold**`, `` `code` `` and links, images on their own line), so the two cannot say
//! different things.

use crate::report::format::Attachment;
use base64::Engine as _;
use std::fmt::Write as _;

/// The page's style: readable tables that scroll inside their own box instead of the page.
const STYLE: &str = r"
body { font: 15px/1.45 system-ui, sans-serif; margin: 0 auto; max-width: 1200px; padding: 1em 2em; color: #222; }
h1 { font-size: 1.6em; } h2 { font-size: 1.3em; margin-top: 2em; border-bottom: 1px solid #ddd; } h3 { font-size: 1.1em; }
code { background: #f3f3f3; padding: 0 .25em; border-radius: 3px; }
.table { overflow-x: auto; margin: .5em 0 1.5em; }
table { border-collapse: collapse; font-size: 13px; }
th, td { border: 1px solid #ddd; padding: .2em .5em; }
th, td.num { white-space: nowrap; } td { max-width: 42em; overflow-wrap: anywhere; }
th { background: #f6f6f6; cursor: pointer; user-select: none; position: sticky; top: 0; }
th.asc::after { content: ' ▲'; } th.desc::after { content: ' ▼'; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr:hover td { background: #fffbe6; }
input.filter { margin: .3em 0; padding: .2em .4em; width: 20em; }
figure { margin: 1em 0; } figure img, figure svg { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 13px; color: #555; }
.ab-view { position: relative; display: inline-block; cursor: pointer; line-height: 0; }
.ab-view img { display: block; max-width: 100%; image-rendering: pixelated; }
.ab-view img.ab-a { position: absolute; left: 0; top: 0; clip-path: inset(0 50% 0 0); }
.ab-label { position: absolute; left: 4px; top: 4px; font: 12px/1.3 system-ui, sans-serif; color: #fff;
  background: rgba(0,0,0,.6); padding: 0 .3em; border-radius: 3px; }
input.ab-wipe { display: block; width: 20em; }
";

/// Sorting and filtering, in plain JavaScript (no library, no request).
const SCRIPT: &str = r"
(function () {
  function key(text) {
    var t = text.replace(/[,%×]/g, '').trim();
    var n = parseFloat(t);
    return isNaN(n) ? t.toLowerCase() : n;
  }
  document.querySelectorAll('table').forEach(function (table) {
    var body = table.tBodies[0];
    if (!body) return;
    table.querySelectorAll('th').forEach(function (th, col) {
      th.addEventListener('click', function () {
        var asc = !th.classList.contains('asc');
        table.querySelectorAll('th').forEach(function (h) { h.classList.remove('asc', 'desc'); });
        th.classList.add(asc ? 'asc' : 'desc');
        var rows = Array.prototype.slice.call(body.rows);
        rows.sort(function (a, b) {
          var x = key(a.cells[col] ? a.cells[col].textContent : ''), y = key(b.cells[col] ? b.cells[col].textContent : '');
          if (typeof x !== typeof y) { x = String(x); y = String(y); }
          return (x < y ? -1 : x > y ? 1 : 0) * (asc ? 1 : -1);
        });
        rows.forEach(function (r) { body.appendChild(r); });
      });
    });
    var box = table.parentNode.previousElementSibling;
    if (box && box.classList.contains('filter')) {
      box.addEventListener('input', function () {
        var q = box.value.toLowerCase();
        Array.prototype.forEach.call(body.rows, function (r) {
          r.style.display = r.textContent.toLowerCase().indexOf(q) >= 0 ? '' : 'none';
        });
      });
    }
  });
  document.querySelectorAll('figure.ab').forEach(function (fig) {
    var view = fig.querySelector('.ab-view'), a = fig.querySelector('img.ab-a'), b = fig.querySelector('img.ab-b');
    var label = fig.querySelector('.ab-label'), wipe = fig.querySelector('input.ab-wipe'), timer = null;
    function show(v) {
      a.style.clipPath = 'inset(0 ' + (100 - v) + '% 0 0)';
      label.textContent = v >= 100 ? a.alt : v <= 0 ? b.alt : a.alt + ' | ' + b.alt;
    }
    wipe.addEventListener('input', function () { show(+wipe.value); });
    view.addEventListener('click', function () {
      if (timer) { clearInterval(timer); timer = null; show(+wipe.value); return; }
      var on = true;
      timer = setInterval(function () { on = !on; show(on ? 100 : 0); }, 500);
      show(100);
    });
    show(+wipe.value);
  });
  document.body.setAttribute('data-ready', String(document.querySelectorAll('table').length));
  document.body.setAttribute('data-ab', String(document.querySelectorAll('figure.ab .ab-label').length));
})();
";

fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            _ => o.push(c),
        }
    }
    o
}

/// Inline Markdown of one line: `**bold**`, `` `code` ``, `[text](target)` (a link to a file beside the report).
fn inline(s: &str) -> String {
    let mut out = String::new();
    let mut rest = s;
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix('`') {
            if let Some(end) = r.find('`') {
                let _ = write!(out, "<code>{}</code>", escape(&r[..end]));
                rest = &r[end + 1..];
                continue;
            }
        }
        if let Some(r) = rest.strip_prefix("**") {
            if let Some(end) = r.find("**") {
                let _ = write!(out, "<strong>{}</strong>", inline(&r[..end]));
                rest = &r[end + 2..];
                continue;
            }
        }
        if let Some(r) = rest.strip_prefix('[') {
            if let Some((text, after)) = r.split_once("](") {
                if let Some(end) = after.find(')') {
                    let target = &after[..end];
                    // Only files beside the report: a link never leaves the folder.
                    if !target.contains("://") && !target.starts_with("//") {
                        let _ = write!(out, "<a href=\"{}\">{}</a>", escape(target), inline(text));
                    } else {
                        out.push_str(&escape(text));
                    }
                    rest = &after[end + 1..];
                    continue;
                }
            }
        }
        let first = rest.chars().next().map_or(1, char::len_utf8);
        let next = rest[first..].find(['`', '*', '[']).map_or(rest.len(), |i| i + first);
        out.push_str(&escape(&rest[..next]));
        rest = &rest[next..];
    }
    out
}

/// The cells of a pipe-table line.
fn cells(line: &str) -> Vec<String> {
    let t = line.trim().trim_start_matches('|').trim_end_matches('|');
    t.split('|').map(|c| c.trim().to_string()).collect()
}

fn numeric(cell: &str) -> bool {
    let t = cell.trim_end_matches(['%', 'x', '×']).replace(',', "");
    let first = t.split([' ', '/', '(']).next().unwrap_or("");
    !first.is_empty() && first.parse::<f64>().is_ok()
}

/// A figure: the PNG inline as a data URI (the SVG beside it, when the report has one, inline as markup).
fn figure(alt: &str, file: &str, files: &[Attachment]) -> String {
    let find = |name: &str| files.iter().find(|a| a.name == name);
    let svg = file.strip_suffix(".png").map(|s| format!("{s}.svg")).and_then(|s| find(&s).cloned());
    let body = match (svg, find(file)) {
        (Some(svg), _) => String::from_utf8_lossy(&svg.bytes)
            .trim_start_matches("<?xml version=\"1.0\" standalone=\"no\"?>")
            .to_string(),
        (None, Some(png)) if file.ends_with(".png") => format!(
            "<img alt=\"{}\" src=\"data:image/png;base64,{}\">",
            escape(alt),
            base64::engine::general_purpose::STANDARD.encode(&png.bytes)
        ),
        _ => format!("<p>(figure {} not in the report)</p>", escape(file)),
    };
    format!("<figure>{body}<figcaption>{}</figcaption></figure>\n", inline(alt))
}

/// An A/B view: image `a` over image `b`, the same size; a click flickers between them (FLIP's own way to compare),
/// the slider wipes from one to the other.
fn ab_figure(alt: &str, a: &str, b: &str, files: &[Attachment]) -> String {
    let uri = |name: &str| {
        files
            .iter()
            .find(|f| f.name == name && name.ends_with(".png"))
            .map(|f| format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&f.bytes)))
    };
    let (Some(ua), Some(ub)) = (uri(a), uri(b)) else {
        return format!("<p>(A/B view {} against {} not in the report)</p>\n", escape(a), escape(b));
    };
    format!(
        "<figure class=\"ab\"><div class=\"ab-view\" tabindex=\"0\" title=\"click: flicker\">\
         <img class=\"ab-b\" alt=\"{b}\" src=\"{ub}\"><img class=\"ab-a\" alt=\"{a}\" src=\"{ua}\">\
         <span class=\"ab-label\"></span></div>\
         <input class=\"ab-wipe\" type=\"range\" min=\"0\" max=\"100\" value=\"50\" aria-label=\"wipe {a} against {b}\">\
         <figcaption>{}</figcaption></figure>\n",
        inline(alt),
        a = escape(&label(a)),
        b = escape(&label(b)),
    )
}

/// What an A/B image is called on the page: its file name after `ab_`, without `.png` (`ab_fat_20.png`: `fat_20`).
fn label(file: &str) -> String {
    let stem = file.strip_suffix(".png").unwrap_or(file);
    stem.rsplit_once("ab_").map_or(stem, |(_, s)| s).to_string()
}

/// The report page from its Markdown and its attachments.
#[must_use]
pub fn to_html(markdown: &str, files: &[Attachment]) -> String {
    let title = markdown.lines().find_map(|l| l.strip_prefix("# ")).unwrap_or("gbuf report");
    let mut o = String::with_capacity(markdown.len() * 2);
    let _ = write!(
        o,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        escape(title)
    );
    let lines: Vec<&str> = markdown.lines().collect();
    let mut i = 0;
    let mut para: Vec<&str> = Vec::new();
    let flush = |para: &mut Vec<&str>, o: &mut String| {
        if !para.is_empty() {
            let _ = writeln!(o, "<p>{}</p>", para.iter().map(|l| inline(l)).collect::<Vec<_>>().join(" "));
            para.clear();
        }
    };
    let mut tables = 0;
    while i < lines.len() {
        let line = lines[i];
        let t = line.trim();
        if t.is_empty() {
            flush(&mut para, &mut o);
            i += 1;
        } else if let Some(h) = ["### ", "## ", "# "].iter().position(|p| t.starts_with(p)) {
            flush(&mut para, &mut o);
            let level = 3 - h;
            let text = &t[level + 1..];
            let _ = writeln!(o, "<h{level}>{}</h{level}>", inline(text));
            i += 1;
        } else if t.starts_with("```") {
            flush(&mut para, &mut o);
            let mut j = i + 1;
            let mut code = String::new();
            while j < lines.len() && !lines[j].trim().starts_with("```") {
                code.push_str(&escape(lines[j]));
                code.push('\n');
                j += 1;
            }
            let _ = writeln!(o, "<pre>{code}</pre>");
            i = j + 1;
        } else if t.starts_with('|') {
            flush(&mut para, &mut o);
            let mut j = i;
            while j < lines.len() && lines[j].trim().starts_with('|') {
                j += 1;
            }
            let rows: Vec<Vec<String>> = lines[i..j].iter().filter(|l| !l.contains("---")).map(|l| cells(l)).collect();
            tables += 1;
            let _ = writeln!(
                o,
                "<input class=\"filter\" type=\"search\" placeholder=\"filter the table\" aria-label=\"filter table {tables}\">\n<div class=\"table\"><table>"
            );
            if let Some((head, body)) = rows.split_first() {
                o.push_str("<thead><tr>");
                for c in head {
                    let _ = write!(o, "<th>{}</th>", inline(c));
                }
                o.push_str("</tr></thead>\n<tbody>\n");
                for r in body {
                    o.push_str("<tr>");
                    for c in r {
                        let class = if numeric(c) { " class=\"num\"" } else { "" };
                        let _ = write!(o, "<td{class}>{}</td>", inline(c));
                    }
                    o.push_str("</tr>\n");
                }
                o.push_str("</tbody>");
            }
            o.push_str("</table></div>\n");
            i = j;
        } else if let Some(rest) = t.strip_prefix("![") {
            flush(&mut para, &mut o);
            if let Some((alt, after)) = rest.split_once("](") {
                let target = after.trim_end_matches(')');
                match target.split_once(" \"") {
                    Some((file, b)) => o.push_str(&ab_figure(alt, file, b.trim_end_matches('"'), files)),
                    None => o.push_str(&figure(alt, target, files)),
                }
                // report.md repeats the caption in italics under the image (Markdown viewers hide the alt
                // text); the page shows it once, as the figure's caption.
                let mut j = i + 1;
                while j < lines.len() && lines[j].trim().is_empty() {
                    j += 1;
                }
                if j < lines.len() && lines[j].trim() == format!("*{alt}*") {
                    i = j;
                }
            }
            i += 1;
        } else if t.starts_with("- ") || t.starts_with("* ") {
            flush(&mut para, &mut o);
            o.push_str("<ul>\n");
            while i < lines.len() && (lines[i].trim().starts_with("- ") || lines[i].trim().starts_with("* ")) {
                let _ = writeln!(o, "<li>{}</li>", inline(&lines[i].trim()[2..]));
                i += 1;
            }
            o.push_str("</ul>\n");
        } else {
            para.push(t);
            i += 1;
        }
    }
    flush(&mut para, &mut o);
    let _ = write!(o, "<script>{SCRIPT}</script>\n</body>\n</html>\n");
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_becomes_one_file_with_inline_figures_and_no_outside_reference() {
        let md = "# T\n\nSome **bold** and `code` and [a file](report.csv) and [out](https://x.org).\n\n\
                  | a | b |\n|---|--:|\n| x <y> | 1.5 |\n| z | 10 |\n\n![An image](p.png)\n\n- one\n- two\n";
        let png = Attachment { name: "p.png".into(), bytes: vec![137, 80, 78, 71] };
        let h = to_html(md, &[png]);
        assert!(h.contains("<h1>T</h1>") && h.contains("<strong>bold</strong>") && h.contains("<code>code</code>"));
        assert!(h.contains("<a href=\"report.csv\">a file</a>"), "{h}");
        assert!(!h.contains("https://"), "no outside link or request");
        assert!(h.contains("<td>x &lt;y&gt;</td><td class=\"num\">1.5</td>"), "{h}");
        assert!(h.contains("src=\"data:image/png;base64,iVBORw==\""), "{h}");
        // An A/B pair: one figure with both images, the slider and the label.
        let ab = to_html(
            "![A against B](a.png \"b.png\")\n",
            &[Attachment { name: "a.png".into(), bytes: vec![1] }, Attachment { name: "b.png".into(), bytes: vec![2] }],
        );
        assert!(ab.contains("<figure class=\"ab\">") && ab.contains("class=\"ab-wipe\""), "{ab}");
        assert!(ab.contains("alt=\"a\" src=\"data:image/png;base64,AQ==\"") && ab.contains("base64,Ag=="), "{ab}");
        assert_eq!((label("f1_ab_fat_20.png"), label("ab_reference.png")), ("fat_20".into(), "reference".into()));
        assert!(to_html("![A](a.png \"missing.png\")\n", &[]).contains("not in the report"));
        assert!(h.contains("<li>two</li>"));
        assert!(h.contains("Content-Security-Policy"));
    }

    #[test]
    fn text_of_any_script_and_unclosed_marks_pass_through() {
        for line in ["— ×", "a * b", "[x", "`open", "**open", "é**", "²[", "ü"] {
            let h = inline(line);
            assert!(!h.is_empty(), "{line}");
        }
        assert_eq!(inline("— 3×"), "— 3×");
    }
}
