//! Writes a report folder: `report.md`, `report.html`, `report.csv`, `report.json` and the figures. Every file is written
//! atomically; the folder is created if missing; files that are not ours are left untouched.

use crate::analysis::record::Report;
use crate::base::files::write_bytes_atomic;
use crate::error::{Error, Result};
use crate::report::format::Attachment;
use crate::report::{csv, markdown};
use std::path::{Path, PathBuf};

/// The JSON text of a report. Non-finite numbers become `null` (an infinite PSNR, i.e. an image identical to the
/// reference, shows as `null` with `rmse` 0).
fn to_json(rep: &Report) -> Result<String> {
    serde_json::to_string_pretty(rep).map_err(json_err)
}

fn json_err(e: serde_json::Error) -> Error {
    Error::Internal(format!("cannot serialize the report: {e}"))
}

/// The files every report folder has besides its attachments.
const FOLDER_FILES: [&str; 5] = ["report.csv", "aggregate.csv", "report.json", "report.md", "report.html"];

/// Writes the report folder `dir` and returns the paths written.
pub fn write_folder(dir: &Path, rep: &Report, attachments: &[Attachment]) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    // Refuse before writing anything when a file of the folder is an input (`gbuf merge r/report.json -o r`).
    for name in attachments.iter().map(|a| a.name.as_str()).chain(FOLDER_FILES) {
        crate::base::files::check_not_input(&dir.join(name))?;
    }
    let mut written = Vec::new();
    let mut put = |name: &str, bytes: &[u8]| -> Result<()> {
        if name.contains(['/', '\\']) || name.is_empty() || name.starts_with('.') {
            return Err(Error::Argument(format!("bad report file name {name:?}")));
        }
        let p = dir.join(name);
        write_bytes_atomic(&p, bytes)?;
        written.push(p);
        Ok(())
    };
    for a in attachments {
        put(&a.name, &a.bytes)?;
    }
    let [rows, aggregate, json, md, html] = FOLDER_FILES;
    put(rows, csv::to_csv(&rep.rows).as_bytes())?;
    put(aggregate, csv::aggregate_csv(&rep.aggregate).as_bytes())?;
    put(json, to_json(rep)?.as_bytes())?;
    let text = markdown::to_markdown(rep);
    put(md, text.as_bytes())?;
    // One self-contained page to share: the same text, figures inline (report::html).
    put(html, crate::report::html::to_html(&text, attachments).as_bytes())?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::row::Row;

    fn rep() -> Report {
        let rows = vec![Row {
            layout: "x".into(),
            layout_error: Some(crate::measure::image::ErrorSet {
                psnr_db: f64::INFINITY,
                rmse: 0.0,
                ..Default::default()
            }),
            ..Default::default()
        }];
        crate::analysis::record::test_report("t", 2, 2, rows, vec![])
    }

    #[test]
    fn folder_is_created_and_unrelated_files_survive() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("a/b");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("mine.txt"), "keep").unwrap();
        let att = [Attachment { name: "p.svg".into(), bytes: b"<svg/>".to_vec() }];
        let w = write_folder(&dir, &rep(), &att).unwrap();
        assert_eq!(w.len(), 6);
        assert_eq!(std::fs::read_to_string(dir.join("mine.txt")).unwrap(), "keep");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
        assert_eq!(json["rows"][0]["layout"], "x");
        assert_eq!(json["rows"][0]["layout_error"]["rmse"], 0.0);
        assert!(json["rows"][0]["layout_error"]["psnr_db"].is_null(), "an infinite PSNR is null");
        assert!(json["frames"][0]["needs"]["absent"].as_array().unwrap().len() == 12);
        let back: Report = serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
        assert_eq!(back.rows[0].layout, "x", "report.json reads back (what `gbuf merge` does)");
        let names: Vec<String> =
            std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        assert_eq!(names.len(), 7, "no temporary files left: {names:?}");
        assert!(write_folder(&dir, &rep(), &[Attachment { name: "../x".into(), bytes: vec![] }]).is_err());
    }
}
