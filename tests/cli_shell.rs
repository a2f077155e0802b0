//! The command line in a terminal and in scripts: help wrapped to the terminal's width with the loader flags under
//! their own heading, completions and a man page, `--threads`, `--quiet`.

mod support;

use std::process::Command;

fn gbuf(args: &[&str], env: &[(&str, &str)]) -> std::process::Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_gbuf"));
    c.current_dir(env!("CARGO_MANIFEST_DIR")).args(args);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap()
}

#[test]
fn help_fits_an_80_column_terminal_and_groups_the_loader_flags() {
    for cmd in ["resolve", "report", "info", "compare", "budget"] {
        let o = gbuf(&[cmd, "--help"], &[("COLUMNS", "80")]);
        assert!(o.status.success());
        let text = String::from_utf8(o.stdout).unwrap();
        let long: Vec<&str> = text.lines().filter(|l| l.chars().count() > 80).collect();
        assert!(long.is_empty(), "{cmd}: lines over 80 columns: {long:?}");
        if cmd != "compare" {
            let (own, input) = (text.find("\nOptions:").unwrap(), text.find("\nInput:").expect("an Input heading"));
            assert!(text[input..].contains("--max-memory"), "{cmd}: the loader flags under Input");
            assert!(!text[own..input].contains("--max-memory"), "{cmd}");
        }
    }
    // `-h` is the short form: the naming conventions and limits only under `--help`, and it says so.
    for cmd in ["resolve", "report", "info", "budget"] {
        let short = String::from_utf8(gbuf(&[cmd, "-h"], &[("COLUMNS", "80")]).stdout).unwrap();
        let long = String::from_utf8(gbuf(&[cmd, "--help"], &[("COLUMNS", "80")]).stdout).unwrap();
        assert!(
            short.contains("--fold") && !short.contains("--max-memory") && !short.contains("--reversed-z"),
            "{cmd}"
        );
        assert!(short.contains("see more with '--help'") && long.contains("--reversed-z"), "{cmd}");
        assert!(short.lines().count() < long.lines().count(), "{cmd}");
    }
    let top = String::from_utf8(gbuf(&["--help"], &[]).stdout).unwrap();
    assert!(top.contains("Exit status: 0 success") && top.contains("4 file error"), "{top}");
}

#[test]
fn completions_and_the_man_page_name_every_command() {
    for shell in ["bash", "zsh", "fish"] {
        let o = gbuf(&["completions", shell], &[]);
        assert!(o.status.success(), "{shell}");
        let text = String::from_utf8(o.stdout).unwrap();
        for cmd in ["resolve", "compare", "budget", "layouts"] {
            assert!(text.contains(cmd), "{shell} completion lacks {cmd}");
        }
    }
    let o = gbuf(&["man"], &[]);
    assert!(o.status.success());
    let man = String::from_utf8(o.stdout).unwrap();
    assert!(man.starts_with(".ie") || man.contains(".TH gbuf 1"), "{}", &man[..200.min(man.len())]);
    assert!(man.contains("compare") && man.contains("Exit status"), "the man page lists the commands and exit codes");
}

#[test]
fn threads_and_quiet_are_global_flags() {
    let one = gbuf(&["--threads", "1", "roundtrip", "fixtures/raster_4x.exr", "--layout", "minimal-8", "--json"], &[]);
    let two = gbuf(&["roundtrip", "fixtures/raster_4x.exr", "--layout", "minimal-8", "--json", "--threads", "2"], &[]);
    assert!(one.status.success() && two.status.success(), "{}", support::stderr(&one));
    let strip = |o: &std::process::Output| {
        let mut v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        strip_times(&mut v);
        v
    };
    assert_eq!(strip(&one), strip(&two), "the numbers do not depend on the thread count");
    let o = gbuf(&["--threads", "0", "layouts"], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", support::stderr(&o));
    let o = gbuf(&["-q", "layouts"], &[]);
    assert!(o.status.success() && o.stderr.is_empty());
}

/// Removes every `*_ms` / `*_s` timing from a JSON value.
fn strip_times(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.retain(|k, _| !(k.ends_with("_ms") || k.ends_with("_s") || k.contains("time")));
            m.values_mut().for_each(strip_times);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(strip_times),
        _ => {}
    }
}

/// `--layout` in a command's help names only a layout the command applies; the input's layout is `--input-layout`
/// everywhere, and the old spelling on `info` still works with a note.
#[test]
fn help_shows_layout_only_where_a_layout_is_applied() {
    let applies = ["pack", "resolve", "roundtrip", "pipelines"];
    for cmd in ["info", "edges", "budget", "report", "convert", "compare", "pack", "resolve", "roundtrip", "pipelines"]
    {
        let o = gbuf(&[cmd, "--help"], &[]);
        let help = String::from_utf8_lossy(&o.stdout).to_string();
        let named = help.contains("--layout ") || help.contains("--layout\n") || help.contains("`--layout`");
        assert_eq!(named, applies.contains(&cmd), "gbuf {cmd} --help:\n{help}");
        if cmd != "compare" {
            assert!(help.contains("--input-layout"), "gbuf {cmd} --help reads packed targets");
        }
    }
    let o = gbuf(&["info", "fixtures/engine_4x", "--layout", "fixtures/engine_4x/engine.toml"], &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("old spelling of `--input-layout`"));
}
