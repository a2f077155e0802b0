//! One module per subcommand: parse flags into plain data, call the library, print.

pub mod bench;
pub mod budget;
pub mod codecs;
pub mod common;
pub mod compare;
pub mod convert;
pub mod demo;
pub mod edges;
pub mod info;
pub mod layouts;
pub mod merge;
pub mod pack;
pub mod pipelines;
pub mod report;
pub mod resolve;
pub mod roundtrip;
pub mod scene;
pub mod vrs;

static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// `-q/--quiet`: no progress bars.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

/// Was `-q/--quiet` given?
pub fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

/// Are progress bars drawn? Only on a terminal, and not with `-q/--quiet`.
fn progress_shown() -> bool {
    use std::io::IsTerminal as _;
    std::io::stderr().is_terminal() && !quiet()
}

/// The one progress style of every command: a bar of `len` steps on stderr (`{elapsed} [bar] pos/len message`),
/// hidden off a terminal and with `-q`.
pub fn progress_bar(len: u64) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::with_draw_target(Some(len), indicatif::ProgressDrawTarget::stderr());
    if !progress_shown() {
        pb.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    if let Ok(style) = indicatif::ProgressStyle::with_template("{elapsed:>4} [{bar:30}] {pos}/{len} {msg}") {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

/// The same style for a step of unknown length: a spinner with the elapsed time and `msg` (change it with
/// `set_message` as the command moves on; `finish_and_clear` before printing results).
pub fn spinner(msg: impl Into<std::borrow::Cow<'static, str>>) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::with_draw_target(None, indicatif::ProgressDrawTarget::stderr());
    if !progress_shown() {
        pb.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    } else {
        pb.enable_steady_tick(std::time::Duration::from_millis(120));
    }
    if let Ok(style) = indicatif::ProgressStyle::with_template("{elapsed:>4} {spinner} {msg}") {
        pb.set_style(style);
    }
    pb.set_message(msg);
    pb
}

/// Is this error (anywhere in its chain) a closed pipe? Then the reader went away and we exit quietly.
pub fn is_broken_pipe(err: &anyhow::Error) -> bool {
    // serde_json keeps the io error inside its own (`gbuf … --json | head`), so ask it too.
    err.chain().any(|c| {
        c.downcast_ref::<std::io::Error>().is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
            || c.downcast_ref::<serde_json::Error>()
                .is_some_and(|e| e.io_error_kind() == Some(std::io::ErrorKind::BrokenPipe))
    })
}

/// A usage error: flags that do not go together. `gbuf` exits with status 2 for these (1 is bad input).
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// Returns early with a [`UsageError`] (exit status 2).
#[macro_export]
macro_rules! usage {
    ($($t:tt)*) => {
        return Err(anyhow::Error::new($crate::cli::UsageError(format!($($t)*))))
    };
}

/// Is this error a usage error (exit 2)? The CLI's own, and the library's [`gbuf::Error::UnknownName`] (a mistyped
/// layout or codec name).
pub fn is_usage(err: &anyhow::Error) -> bool {
    err.chain().any(|c| {
        c.downcast_ref::<UsageError>().is_some()
            || matches!(c.downcast_ref::<gbuf::Error>(), Some(gbuf::Error::UnknownName(_)))
    })
}
