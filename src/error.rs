//! One error type for the whole crate.
//!
//! Every error that comes from a file names the file; parse errors also name
//! the element or line where reading stopped. Algorithms return
//! [`Error::InvalidInput`] or [`Error::Numerical`] with a sentence saying what
//! was wrong, never a panic.

use std::path::PathBuf;

/// Errors returned by deformlab.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The operating system refused to read or write a file.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file was read but its content is malformed. `location` is e.g.
    /// `line 12`, `vertex 40`, `header`.
    #[error("{}: {location}: {message}", path.display())]
    Parse {
        path: PathBuf,
        location: String,
        message: String,
    },
    /// Input values (not from a file) violate a precondition. Shown as the
    /// sentence alone: the kind is for programs (`matches!`), not users.
    #[error("{0}")]
    InvalidInput(String),
    /// A numerical method failed (singular system, no convergence, failed
    /// residual check). Shown as the sentence alone.
    #[error("{0}")]
    Numerical(String),
}

/// Crate-wide result alias.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// A parse error in `path` at `location`.
    pub fn parse(
        path: impl Into<PathBuf>,
        location: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Error::Parse {
            path: path.into(),
            location: location.into(),
            message: message.into(),
        }
    }

    /// An invalid-input error.
    pub fn invalid(message: impl Into<String>) -> Self {
        Error::InvalidInput(message.into())
    }

    /// A numerical failure.
    pub fn numerical(message: impl Into<String>) -> Self {
        Error::Numerical(message.into())
    }
}
