//! One module per subcommand: parse flags into plain data, call the library, print.

pub mod budget;
pub mod codecs;
pub mod common;
pub mod demo;
pub mod edges;
pub mod info;
pub mod layouts;
pub mod merge;
pub mod report;
pub mod resolve;
pub mod roundtrip;
pub mod scene;

/// Is this error (anywhere in its chain) a closed pipe? Then the reader went away and we exit quietly.
pub fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe))
}
