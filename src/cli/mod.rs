//! One module per subcommand: parse flags into plain data, call the library, print.

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

static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// `-q/--quiet`: no progress bars.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

/// Was `-q/--quiet` given?
pub fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
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

/// Is this error a usage error (exit 2)?
pub fn is_usage(err: &anyhow::Error) -> bool {
    err.chain().any(|c| c.downcast_ref::<UsageError>().is_some())
}
