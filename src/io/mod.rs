//! Input and output: ParaView snapshots and checkpoints.
//!
//! - [`vtk`]: ParaView snapshots (`.vti`, raw appended binary) and `.pvd` time series;
//! - [`checkpoint`]: a binary container of named arrays for bit-for-bit restarts, written
//!   atomically.
//!
//! Every function that touches the file system creates missing parent directories and maps an
//! operating-system failure to [`crate::Error::Io`] with the path involved. Figures (SVG) and
//! CSV tables are validation tooling, not part of the library: they live in the workspace's
//! `eulermembrane-cases` crate (`cases/`) with the examples.

pub mod checkpoint;
pub mod vtk;

use crate::Error;
use std::path::Path;

/// An [`Error::Io`] naming `path`, with `message`.
pub(crate) fn io_error(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::Io { path: path.display().to_string(), message: message.to_string() }
}
