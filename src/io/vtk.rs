//! ParaView output: VTK XML image data (`.vti`, cell data, raw appended binary) and `.pvd` time
//! series, written by a small writer of our own.
//!
//! Fields are written as cell data over the interior cells; staggered velocities are averaged to
//! cell centres. Files are written to a temporary name and renamed, so a failed write never
//! leaves a truncated file in place of a good one.

use super::io_error;
use crate::grid::{Field, Grid, VectorField, ops::velocity_at_cell};
use crate::{Error, Real, Result};
use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// One `.vti` snapshot being assembled: add arrays, then [`VtiWriter::write`].
pub struct VtiWriter<'g, T: Real> {
    grid: &'g Grid<T>,
    arrays: Vec<(String, usize, Vec<f64>)>,
    /// The first array refused (a field of another grid), reported by [`VtiWriter::write`].
    refused: Option<Error>,
}

impl<'g, T: Real> VtiWriter<'g, T> {
    /// An empty snapshot of `grid`.
    pub fn new(grid: &'g Grid<T>) -> Self {
        VtiWriter { grid, arrays: Vec::new(), refused: None }
    }

    /// Whether a field of `len` values may be added as `name`; if not, the refusal is kept for
    /// [`write`](Self::write).
    fn accepts(&mut self, name: &str, len: usize) -> bool {
        if len == self.grid.len() {
            return true;
        }
        self.refused.get_or_insert_with(|| {
            Error::invalid(
                "VtiWriter field",
                format!("`{name}` with {len} values"),
                "a field of the writer's grid",
            )
        });
        false
    }

    /// Adds a cell-centred scalar field. A field of another grid is left out, and
    /// [`write`](Self::write) then fails.
    pub fn scalar(&mut self, name: &str, f: &Field<T>) -> &mut Self {
        if !self.accepts(name, f.data.len()) {
            return self;
        }
        let g = self.grid;
        let data = g.cells().map(|(i, j, k)| f.data[g.idx_u(i, j, k)].f64()).collect();
        self.arrays.push((name.to_string(), 1, data));
        self
    }

    /// Adds a staggered vector field, averaged to cell centres (ghosts must be filled). A field
    /// of another grid is left out, and [`write`](Self::write) then fails.
    pub fn vector(&mut self, name: &str, v: &VectorField<T>) -> &mut Self {
        if !v.c.iter().all(|c| self.accepts(name, c.data.len())) {
            return self;
        }
        let g = self.grid;
        let mut data = Vec::with_capacity(3 * g.cell_count());
        for (i, j, k) in g.cells() {
            let c = velocity_at_cell(g, v, g.idx_u(i, j, k));
            data.extend(c.iter().map(|x| x.f64()));
        }
        self.arrays.push((name.to_string(), 3, data));
        self
    }

    /// Adds a cell-centred scalar computed per cell by `f(i, j, k)`.
    pub fn scalar_fn(&mut self, name: &str, f: impl Fn(usize, usize, usize) -> f64) -> &mut Self {
        let data = self.grid.cells().map(|(i, j, k)| f(i, j, k)).collect();
        self.arrays.push((name.to_string(), 1, data));
        self
    }

    /// The file contents.
    pub fn to_bytes(&self) -> Vec<u8> {
        let g = self.grid;
        let [nx, ny, nz] = g.n();
        let o = g.lower();
        let h = g.h();
        let mut xml = String::new();
        xml += "<?xml version=\"1.0\"?>\n";
        xml += "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
        xml += &format!(
            "  <ImageData WholeExtent=\"0 {nx} 0 {ny} 0 {nz}\" Origin=\"{} {} {}\" Spacing=\"{} {} {}\">\n",
            o[0], o[1], o[2], h[0], h[1], h[2]
        );
        xml += &format!("    <Piece Extent=\"0 {nx} 0 {ny} 0 {nz}\">\n      <CellData>\n");
        let mut offset = 0usize;
        for (name, comps, data) in &self.arrays {
            xml += &format!(
                "        <DataArray type=\"Float64\" Name=\"{}\" NumberOfComponents=\"{comps}\" format=\"appended\" offset=\"{offset}\"/>\n",
                escape(name)
            );
            offset += 8 + 8 * data.len();
        }
        xml += "      </CellData>\n    </Piece>\n  </ImageData>\n  <AppendedData encoding=\"raw\">\n_";
        let mut bytes = xml.into_bytes();
        for (_, _, data) in &self.arrays {
            bytes.extend_from_slice(&((8 * data.len()) as u64).to_le_bytes());
            for x in data {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
        bytes.extend_from_slice(b"\n  </AppendedData>\n</VTKFile>\n");
        bytes
    }

    /// Writes the snapshot to `path` (parent folders created).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if a field of another grid was added (nothing is written);
    /// [`Error::Io`] naming `path`.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        if let Some(e) = &self.refused {
            return Err(e.clone());
        }
        write_atomic(path.as_ref(), &self.to_bytes())
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that
/// `path` holds either its old contents or the new ones, never a partial file.
///
/// The temporary file gets a fresh name (`.<file name>.<process id>.<counter>.tmp`, created
/// exclusively), is flushed to disk before the rename, and is removed again if anything fails
/// (a full disk, a folder without write permission, `path` being a folder).
///
/// # Errors
/// [`Error::Io`] naming `path`, with the operating-system message.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |f| f.write_all(bytes))
}

/// [`write_atomic`] with the contents written by `write` into the temporary file.
pub(crate) fn write_atomic_with(path: &Path, write: impl FnOnce(&mut File) -> io::Result<()>) -> Result<()> {
    let name = path.file_name().ok_or_else(|| io_error(path, "not a path to a file"))?;
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    if let Some(dir) = dir {
        std::fs::create_dir_all(dir).map_err(|e| io_error(dir, e))?;
    }
    if path.is_dir() {
        return Err(io_error(path, "is a directory"));
    }
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".{}.{}.tmp", std::process::id(), COUNTER.fetch_add(1, Ordering::Relaxed)));
    let tmp = dir.map_or_else(|| PathBuf::from(&tmp_name), |d| d.join(&tmp_name));
    let result = (|| {
        let mut f = File::options().write(true).create_new(true).open(&tmp)?;
        write(&mut f)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        // The temporary file may not exist (creation failed); nothing else to undo.
        let _ = std::fs::remove_file(&tmp);
        return Err(io_error(path, e));
    }
    // Make the rename itself durable. Best effort: the new file is in place either way, and
    // some file systems refuse to sync a folder.
    #[cfg(unix)]
    if let Ok(d) = File::open(dir.unwrap_or(Path::new("."))) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// A ParaView `.pvd` collection: a time series of snapshot files.
#[derive(Debug, Clone, Default)]
pub struct PvdSeries {
    entries: Vec<(f64, String)>,
}

impl PvdSeries {
    /// An empty series.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of snapshots.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether the series has no snapshot.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Adds a snapshot file (path relative to the `.pvd` file) at `time`.
    pub fn push(&mut self, time: f64, file: impl Into<String>) {
        self.entries.push((time, file.into()));
    }

    /// Writes the collection to `path`.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        let mut s = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\">\n  <Collection>\n",
        );
        for (t, f) in &self.entries {
            s += &format!("    <DataSet timestep=\"{t}\" part=\"0\" file=\"{}\"/>\n", escape(f));
        }
        s += "  </Collection>\n</VTKFile>\n";
        write_atomic(path.as_ref(), s.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vti_layout_and_appended_sizes() {
        let g = Grid::<f64>::periodic([4, 5, 6], [0.0; 3], [1.0; 3]).unwrap();
        let phi = Field::from_cell_fn(&g, |x| x[0]);
        let mut v = VectorField::from_fn(&g, |x| [x[1], 0.0, 1.0]);
        v.fill_ghosts(&g);
        let mut w = VtiWriter::new(&g);
        w.scalar("phi", &phi).vector("velocity", &v);
        let b = w.to_bytes();
        let text = String::from_utf8_lossy(&b);
        assert!(text.contains("WholeExtent=\"0 4 0 5 0 6\""));
        assert!(text.contains("offset=\"968\""), "second array after 8 + 8*120 bytes");
        let marker = b"encoding=\"raw\">\n_";
        let start = b.windows(marker.len()).position(|w| w == marker).unwrap() + marker.len();
        let n0 = u64::from_le_bytes(b[start..start + 8].try_into().unwrap());
        assert_eq!(n0, 8 * 120);
        let first = f64::from_le_bytes(b[start + 8..start + 16].try_into().unwrap());
        assert!((first - 0.125).abs() < 1e-15);
        let n1 = u64::from_le_bytes(b[start + 968..start + 976].try_into().unwrap());
        assert_eq!(n1, 8 * 360);
    }

    #[test]
    fn failed_writes_report_the_path_and_keep_the_old_file() {
        let dir = std::env::temp_dir().join(format!("em_vtk_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("a.pvd");
        let mut s = PvdSeries::new();
        s.push(0.0, "a_0.vti");
        s.write(&good).unwrap();
        // A path whose parent is a file cannot be created.
        let bad = good.join("b.pvd");
        let e = s.write(&bad).unwrap_err();
        assert!(e.to_string().contains("b.pvd") || e.to_string().contains("a.pvd"), "{e}");
        assert!(std::fs::read_to_string(&good).unwrap().contains("a_0.vti"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_short_write_keeps_the_old_file_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("em_atomic_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("state.bin");
        write_atomic(&path, b"old contents").unwrap();
        // The disk fills up after 5 bytes of the new contents.
        let e = write_atomic_with(&path, |f| {
            f.write_all(&b"new contents"[..5])?;
            Err(io::Error::new(io::ErrorKind::StorageFull, "no space left on device (injected)"))
        })
        .unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("state.bin") && msg.contains("no space left"), "{msg}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old contents");
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, ["state.bin"], "a temporary file was left behind");
        // A folder in place of the file is refused, and left alone.
        let sub = dir.join("sub");
        std::fs::create_dir(&sub).unwrap();
        assert!(write_atomic(&sub, b"x").is_err());
        assert!(sub.is_dir());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
