//! Input and output: figures and tables that a person reads or plots again.
//!
//! - [`plot`]: a small, dependency-free SVG plotting builder ([`plot::Figure`]) for the line
//!   plots, marker plots and contour plots that the examples write next to their CSV output, and
//!   marching squares ([`plot::contour_segments`]) to draw an interface from a sampled field;
//! - [`csv`]: time series and profiles written with full precision ([`csv::CsvWriter`],
//!   [`csv::write_columns`]), read back ([`csv::read_columns`]), and published reference curves
//!   read from two-column files ([`csv::read_xy`]);
//! - [`vtk`]: ParaView snapshots (`.vti`, raw appended binary) and `.pvd` time series;
//! - [`checkpoint`]: a binary container of named arrays for bit-for-bit restarts, written
//!   atomically.
//!
//! Every function that touches the file system creates missing parent directories and maps an
//! operating-system failure to [`crate::Error::Io`] with the path involved.

pub mod checkpoint;
pub mod csv;
pub mod plot;
pub mod vtk;

use crate::{Error, Result};
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
