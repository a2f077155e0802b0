//! One typed error for the whole library. Every variant says what went wrong and where.

use std::path::PathBuf;

/// Result alias used across the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in gbuf. Variants name the file (when there is one) and the problem.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing a file failed at the OS level.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The exr crate refused the file.
    #[error("{path}: not a readable OpenEXR file: {source}")]
    Exr {
        /// The file.
        path: PathBuf,
        /// The exr crate's error (it carries no path, so we add it).
        #[source]
        source: exr::error::Error,
    },
    /// A channel needed for an attribute is not in the file.
    #[error("{path}: missing channel {name}; channels found: {found}")]
    MissingChannel {
        /// The file.
        path: PathBuf,
        /// The channel (or attribute) that could not be found.
        name: String,
        /// Comma-separated list of the channels the file does have.
        found: String,
    },
    /// Two things that must have the same size do not.
    #[error("{path}: size mismatch: {what}")]
    SizeMismatch {
        /// The file.
        path: PathBuf,
        /// What did not match.
        what: String,
    },
    /// A channel has a sample type we cannot use for that attribute.
    #[error("{path}: channel {channel}: unsupported sample type {found}")]
    UnsupportedSampleType {
        /// The file.
        path: PathBuf,
        /// The channel.
        channel: String,
        /// The sample type found.
        found: String,
    },
    /// A file declares more data than the configured memory limit allows.
    #[error("{path}: declares {bytes} bytes of samples, over the limit of {limit} bytes ({why}; raise it with --max-memory MIB)")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Bytes the file would need.
        bytes: u64,
        /// The limit in force.
        limit: u64,
        /// Where the limit comes from (`ReadLimits::describe` of the io stage).
        why: String,
    },
    /// The file is structurally valid but holds something we do not support (deep data, subsampling, ...).
    #[error("{path}: unsupported: {what}")]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is unsupported.
        what: String,
    },
    /// The file's contents are malformed.
    #[error("{path}: invalid: {what}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// A JSON/TOML document (sidecar, layout file) does not parse or does not fit.
    #[error("{path}: {what}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        what: String,
    },
    /// An output would replace a file this run read as input.
    #[error("{path}: is an input of this run; refusing to overwrite it (choose another output path)")]
    WouldOverwriteInput {
        /// The input file.
        path: PathBuf,
    },
    /// A parameter given by the caller is out of range or inconsistent (no file involved).
    #[error("invalid argument: {0}")]
    Argument(String),
    /// A name given by the caller names nothing (a mistyped layout or codec name): the message lists the names or
    /// suggests the closest. The command line treats it as a usage error (exit 2).
    #[error("{0}")]
    UnknownName(String),
    /// Inputs that are each valid but do not fit together (a mask of another size than the G-buffer, data packed with
    /// another layout, a detector or resolve given a G-buffer without the planes it reads).
    #[error("{0}")]
    Mismatch(String),
    /// The inputs give no result that can be right (no covered sample, no light, a black reference): the job stops
    /// instead of reporting a number that means nothing.
    #[error("no meaningful result: {0}")]
    Implausible(String),
    /// A step that cannot fail on valid data failed (serialising a report, drawing a plot, emitting a shader):
    /// a gbuf bug.
    #[error("internal error (a gbuf bug: please report): {0}")]
    Internal(String),
    /// A step of a job over several frames failed on one of them.
    #[error("{frame}: {step}")]
    InFrame {
        /// The frame (its path or name).
        frame: String,
        /// What was being done.
        step: &'static str,
        /// Why it failed.
        #[source]
        source: Box<Error>,
    },
}

impl Error {
    /// Shorthand for [`Error::Io`].
    #[must_use]
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), source }
    }
    /// Shorthand for [`Error::Invalid`].
    #[must_use]
    pub fn invalid(path: impl Into<PathBuf>, what: impl Into<String>) -> Self {
        Error::Invalid { path: path.into(), what: what.into() }
    }
}
