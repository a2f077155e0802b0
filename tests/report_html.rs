//! `report.html` in a real browser: headless Chromium (Debian's `chromium`) opens the report of the llvmpipe
//! fixture with no console message (no script error, no blocked request: the page's Content-Security-Policy
//! forbids every request, so any attempt would be logged), its script runs to the end (it marks `<body>` with the
//! table count), and a screenshot shows the page rendered (non-blank, the size asked for, figures below the
//! tables). Required in CI (`.ci/run` installs chromium); a noted skip elsewhere.

mod support;

use std::path::Path;
use std::process::Command;

fn chromium(args: &[&str], page: &Path) -> std::process::Output {
    Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--no-first-run",
            "--disable-extensions",
        ])
        .args(args)
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium")
}

#[test]
fn the_report_page_loads_in_chromium_without_a_console_message_and_renders() {
    let dir = tempfile::tempdir().unwrap();
    let dump = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/raster_4x.exr");
    let o = support::gbuf(dir.path(), &["report", dump.to_str().unwrap(), "--runs", "1", "-o", "r", "-q"]);
    assert!(o.status.success(), "{}", support::stderr(&o));
    let page = dir.path().join("r/report.html");
    let html = std::fs::read_to_string(&page).unwrap();
    // One file: every figure inline, nothing that points outside it.
    for outside in ["src=\"http", "href=\"http", "src=\"//", "url(http", "@import"] {
        assert!(!html.contains(outside), "report.html refers outside itself: {outside}");
    }
    let md = std::fs::read_to_string(dir.path().join("r/report.md")).unwrap();
    let figures = md.lines().filter(|l| l.starts_with("![")).count();
    let ab = md.lines().filter(|l| l.starts_with("![A/B: ")).count();
    assert!(
        figures >= 3 && html.matches("<figure>").count() + html.matches("<figure class=\"ab\">").count() == figures,
        "every figure of report.md is inline"
    );
    // One A/B view per layout of the sweep (8 built-ins) and gbuf's shading-rate image, each with its two images
    // and a slider.
    assert_eq!((ab, html.matches("<figure class=\"ab\">").count()), (9, 9));
    assert!(md.contains("ab_shading_rate.png") && md.contains("shading-rate image"), "the SRI beside the A/B views");
    assert!(!html.contains("not in the report"), "no figure is missing");
    // Each caption once, as its figure's caption: not again as a literal `*…*` paragraph.
    assert_eq!(html.matches("<figcaption>").count(), figures, "one caption per figure");
    assert!(!html.contains("<p>*"), "a caption repeated as literal Markdown");
    assert!(html.contains("Lighting:"), "the page names the lighting model");
    // Figure text at least 11 px as shown: every inline SVG fits the page's 1200-px column unscaled (so its
    // font sizes are its displayed sizes), and none is smaller than 11 px.
    let mut svgs = 0;
    for svg in html.split("<svg ").skip(1) {
        svgs += 1;
        let width: f64 = svg.split("width=\"").nth(1).and_then(|w| w.split('"').next()?.parse().ok()).unwrap();
        assert!(width <= 1100.0, "an SVG of {width} px is scaled down on the page");
        let body = &svg[..svg.find("</svg>").unwrap()];
        for size in body.split("font-size=\"").skip(1).filter_map(|f| f.split('"').next()?.parse::<f64>().ok()) {
            assert!(size >= 11.0, "SVG text of {size:.1} px");
        }
    }
    assert!(svgs >= 2, "the scatter plots are inline SVG");
    if !support::tool_has("chromium") {
        return;
    }
    // The script ran to its end: it marks the body with the number of tables it made sortable.
    let o = chromium(&["--dump-dom"], &page);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let dom = String::from_utf8_lossy(&o.stdout);
    let tables = html.matches("<table>").count();
    assert!(tables >= 3 && dom.contains(&format!("data-ready=\"{tables}\"")), "the page's script did not finish");
    assert!(dom.contains("data-ab=\"9\""), "the A/B views were not set up");
    assert!(dom.contains("class=\"ab-label\">fat_20 | reference<"), "the A/B labels are set by the script");
    // No console message (script errors and refused requests are logged there), and a rendered screenshot.
    let shot = dir.path().join("shot.png");
    let o = chromium(
        &["--enable-logging=stderr", "--v=0", "--window-size=1200,3000", &format!("--screenshot={}", shot.display())],
        &page,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let log = String::from_utf8_lossy(&o.stderr);
    let console: Vec<&str> = log.lines().filter(|l| l.contains(":CONSOLE")).collect();
    assert!(console.is_empty(), "console messages: {console:?}");
    let img = image::open(&shot).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (1200, 3000));
    // Rendered: dark text on white in the top part, and coloured figures further down (not one flat colour).
    let band = |y0: u32, y1: u32| {
        let mut dark = 0usize;
        let mut colours = std::collections::HashSet::new();
        for y in y0..y1 {
            for x in 0..img.width() {
                let p = img.get_pixel(x, y).0;
                dark += usize::from(p.iter().all(|&c| c < 100));
                colours.insert(p);
            }
        }
        (dark, colours.len())
    };
    let (dark, _) = band(0, 300);
    assert!(dark > 500, "no text at the top ({dark} dark pixels)");
    let (_, colours) = band(1000, 3000);
    assert!(colours > 200, "no figure rendered below the tables ({colours} colours)");
}
