//! Safe outputs under faults (issue 16, part 4): a `gbuf report` killed while it writes leaves no partial file under
//! a final name; a full disk and a read-only directory give clear errors naming the path; an output that names an
//! input is refused and the input is left as it was.
//!
//! The full disk and the read-only directory are real: a 64 KiB tmpfs and a read-only tmpfs mounted in a private
//! mount namespace (`unshare -rm`, or plain `mount` when running as root). When neither can be had, the test fails:
//! it does not skip.

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

/// The names a report folder's files have: ours, or a temporary file of `base::files::write_atomic`.
fn is_temporary(name: &str) -> bool {
    name.starts_with(".gbuf-tmp-")
}

/// Panics unless every file under a final name in `dir` is whole: JSON parses, CSV parses with one field count,
/// PNG decodes, SVG and Markdown end as our writers end them. Returns how many final files there are.
fn assert_whole_files(dir: &Path, context: &str) -> usize {
    let mut n = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if is_temporary(&name) {
            continue;
        }
        n += 1;
        let bytes = std::fs::read(&p).unwrap();
        let whole = match p.extension().and_then(|e| e.to_str()).unwrap_or("") {
            "json" => serde_json::from_slice::<serde_json::Value>(&bytes).is_ok(),
            "csv" => {
                let mut r = csv::Reader::from_reader(bytes.as_slice());
                let width = r.headers().map(|h| h.len()).unwrap_or(0);
                bytes.ends_with(b"\n") && width > 0 && r.records().all(|rec| rec.is_ok_and(|rec| rec.len() == width))
            }
            "png" => image::load_from_memory(&bytes).is_ok(),
            "exr" => gbuf::io::exr::read_raw_bytes(&bytes, &p, &Default::default()).is_ok(),
            "svg" => String::from_utf8_lossy(&bytes).trim_end().ends_with("</svg>"),
            "md" => bytes.ends_with(b"\n"),
            "html" => bytes.ends_with(b"</html>\n"),
            "toml" => std::str::from_utf8(&bytes).is_ok_and(|t| t.parse::<toml::Table>().is_ok() && t.ends_with('\n')),
            // Shader code ends with gbuf_unpack's closing brace.
            "glsl" | "hlsl" | "wgsl" => bytes.ends_with(b"return s;\n}\n"),
            other => panic!("{context}: unexpected file {name} (.{other}) in the report folder"),
        };
        assert!(whole, "{context}: {name} is partial ({} bytes)", bytes.len());
    }
    n
}

#[test]
fn a_report_killed_while_writing_leaves_no_partial_file_under_a_final_name() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture("room_4x.exr");
    // A whole run first: how many files a report folder has.
    let full = dir.path().join("full");
    let o = support::gbuf(dir.path(), &["report", input.to_str().unwrap(), "--runs", "1", "-o", "full"]);
    assert!(o.status.success(), "{}", support::stderr(&o));
    let total = assert_whole_files(&full, "complete run");
    assert!(total >= 10, "{total} files");
    // Then runs killed (SIGKILL, no chance to clean up) as soon as the k-th file appears: the kill lands among the
    // writes, whichever file is being written at that moment.
    let mut killed_while_writing = 0;
    for k in [1, 2, total / 3, total / 2, total - 2] {
        let out = dir.path().join(format!("killed{k}"));
        let mut child = support::gbuf_command()
            .current_dir(dir.path())
            .args(["report", input.to_str().unwrap(), "--runs", "1", "-o"])
            .arg(&out)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let start = Instant::now();
        let mut seen = 0;
        while start.elapsed() < Duration::from_secs(120) {
            seen = std::fs::read_dir(&out).map(|d| d.count()).unwrap_or(0);
            if seen >= k || child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        let finished_before = child.try_wait().unwrap().is_some();
        let _ = child.kill();
        child.wait().unwrap();
        let finals = assert_whole_files(&out, &format!("killed after {seen} files"));
        if !finished_before && finals < total {
            killed_while_writing += 1;
        }
    }
    assert!(killed_while_writing >= 3, "only {killed_while_writing} kills landed while the folder was being written");
}

/// Runs `gbuf args…` with `mnt` a fresh tmpfs mounted with `options`, in a private mount namespace; copies what is
/// left in the mount to `copy` and returns (exit status, stderr).
fn gbuf_on_tmpfs(options: &str, args: &[&str], work: &Path) -> (i32, String, PathBuf) {
    let mnt = work.join("mnt");
    let copy = work.join("copy");
    std::fs::create_dir_all(&mnt).unwrap();
    std::fs::create_dir_all(&copy).unwrap();
    let quoted: Vec<String> = args.iter().map(|a| format!("'{a}'")).collect();
    let script = format!(
        "mount -t tmpfs -o {options} tmpfs '{mnt}' || exit 97\n\
         cd '{mnt}' && '{gbuf}' {args} >/dev/null 2>'{work}/stderr'; echo $? >'{work}/rc'\n\
         cp -a '{mnt}/.' '{copy}/'\n\
         cd / && umount '{mnt}' 2>/dev/null; exit 0",
        mnt = mnt.display(),
        work = work.display(),
        copy = copy.display(),
        gbuf = env!("CARGO_BIN_EXE_gbuf"),
        args = quoted.join(" "),
    );
    // A private namespace first (no root needed where user namespaces are allowed), then plain root.
    let ran = [vec!["unshare", "-rm", "sh", "-c"], vec!["sh", "-c"]].into_iter().any(|prefix| {
        let _ = std::fs::remove_file(work.join("rc"));
        let status = Command::new(prefix[0]).args(&prefix[1..]).arg(&script).status();
        status.is_ok_and(|s| s.success()) && work.join("rc").is_file()
    });
    assert!(ran, "cannot mount a tmpfs here (neither `unshare -rm` nor root `mount`): this test needs one");
    let rc: i32 = std::fs::read_to_string(work.join("rc")).unwrap().trim().parse().unwrap();
    (rc, std::fs::read_to_string(work.join("stderr")).unwrap(), copy)
}

#[test]
fn a_full_disk_gives_a_clear_error_and_leaves_only_whole_files() {
    let work = tempfile::tempdir().unwrap();
    let input = fixture("room_4x.exr");
    // The report folder is ~500 KB: a 64 KiB disk fills up part way.
    let (rc, err, copy) =
        gbuf_on_tmpfs("size=64k", &["report", input.to_str().unwrap(), "--runs", "1", "-o", "out"], work.path());
    assert_eq!(rc, 1, "{err}");
    assert!(err.contains("No space left on device") && err.contains("out/"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let out = copy.join("out");
    assert_whole_files(&out, "full disk");
    let leftovers: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| is_temporary(n))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left behind: {leftovers:?}");

    // One big file: the canonical dump of a scene.
    let work = tempfile::tempdir().unwrap();
    let (rc, err, copy) = gbuf_on_tmpfs(
        "size=64k",
        &["scene", "room", "-o", "room.exr", "--width", "320", "--height", "180"],
        work.path(),
    );
    assert_eq!(rc, 1, "{err}");
    assert!(err.contains("No space left on device") && err.contains("room.exr"), "{err}");
    assert!(!copy.join("room.exr").exists(), "a partial room.exr was left");
}

#[test]
fn a_read_only_directory_gives_a_clear_error() {
    let work = tempfile::tempdir().unwrap();
    let input = fixture("room_4x.exr");
    let (rc, err, _) = gbuf_on_tmpfs("ro", &["report", input.to_str().unwrap(), "-o", "out"], work.path());
    assert_eq!(rc, 1, "{err}");
    assert!(err.contains("Read-only file system") && err.contains("out"), "{err}");
    let (rc, err, _) = gbuf_on_tmpfs(
        "ro",
        &["resolve", input.to_str().unwrap(), "--png", "lit.png", "--json"],
        &work.path().join("resolve"),
    );
    assert_eq!(rc, 1, "{err}");
    assert!(err.contains("Read-only file system") && err.contains("lit.png"), "{err}");
}

#[test]
fn an_output_naming_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    for f in ["room_4x.exr", "room_4x.json"] {
        std::fs::copy(fixture(f), dir.path().join(f)).unwrap();
    }
    let before = std::fs::read(dir.path().join("room_4x.exr")).unwrap();
    let sidecar = std::fs::read(dir.path().join("room_4x.json")).unwrap();
    let refused = |args: &[&str], path: &str| {
        let o = support::gbuf(dir.path(), args);
        let err = support::stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(path) && err.contains("is an input of this run"), "{args:?}: {err}");
    };
    refused(&["resolve", "room_4x.exr", "--png", "room_4x.exr"], "room_4x.exr");
    refused(&["resolve", "room_4x.exr", "--heatmap", "./room_4x.json"], "room_4x.json");
    refused(&["budget", "room_4x.exr", "--max-bytes", "12", "-o", "room_4x.exr"], "room_4x.exr");
    assert_eq!(std::fs::read(dir.path().join("room_4x.exr")).unwrap(), before);
    assert_eq!(std::fs::read(dir.path().join("room_4x.json")).unwrap(), sidecar);
    // A report's own report.json merged back into its folder: refused before any file of the folder is replaced.
    let o = support::gbuf(dir.path(), &["report", "room_4x.exr", "--runs", "1", "-o", "r"]);
    assert!(o.status.success(), "{}", support::stderr(&o));
    let csv_before = std::fs::read(dir.path().join("r/report.csv")).unwrap();
    std::thread::sleep(Duration::from_millis(20));
    refused(&["merge", "r/report.json", "-o", "r"], "report.json");
    assert_eq!(std::fs::read(dir.path().join("r/report.csv")).unwrap(), csv_before);
}
