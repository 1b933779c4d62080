//! The file-system plumbing of [`crate::plot`] and [`crate::csv`]: every failure is an
//! [`Error::Io`] naming the path, and missing parent directories are created.

use eulermembrane::{Error, Result};
use std::path::Path;

/// An [`Error::Io`] naming `path`, with `message`.
pub(crate) fn io_error(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::Io { path: path.display().to_string(), message: message.to_string() }
}

/// Creates the parent directories of `path` if they do not exist.
pub(crate) fn create_parent_dirs(path: &Path) -> Result<()> {
    match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => {
            std::fs::create_dir_all(parent).map_err(|e| io_error(parent, e))
        }
        _ => Ok(()),
    }
}

/// Writes `contents` to `path`, creating the parent directories first.
pub(crate) fn write_file(path: &Path, contents: &str) -> Result<()> {
    create_parent_dirs(path)?;
    std::fs::write(path, contents).map_err(|e| io_error(path, e))
}
