//! The library's error type: every message carries what a user needs to fix it.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene file that does not parse: `file:line: message`.
    #[error("{}:{line}: {message}", file.display())]
    Parse {
        file: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Parameters that make no sense (caught before any rendering starts).
    #[error("{0}")]
    Invalid(String),
    #[error("{}: cannot encode image: {message}", path.display())]
    Encode { path: PathBuf, message: String },
    /// The caller cancelled the work (a `CancelToken`) before it finished.
    #[error("cancelled")]
    Cancelled,
}

pub type Result<T> = std::result::Result<T, Error>;
