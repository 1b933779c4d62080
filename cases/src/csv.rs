//! CSV tables of `f64`: time series and profiles out, reference curves in.
//!
//! Numbers are written in their shortest form that reads back to the same `f64` bit for bit
//! (plain decimal for `1e-4 <= |x| < 1e15`, exponent form otherwise, `NaN`, `inf`, `-inf` for the
//! non-finite values), so a table written by [`CsvWriter`] and read by [`read_columns`] is an
//! exact round trip. Files are comma-separated with one header line of column names; lines that
//! are blank or start with `#` are skipped on reading.
//!
//! [`read_xy`] reads the other kind of file met in validation work: two columns without header,
//! e.g. a curve digitised from a published figure (`0.0297, 0.0106` per line).

use crate::files::{create_parent_dirs, io_error};
use eulermembrane::{Error, Result};
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Formats `x` in its shortest round-trip form (see the [module docs](self)).
///
/// ```
/// use eulermembrane_cases::csv::format_f64;
/// assert_eq!(format_f64(0.25), "0.25");
/// assert_eq!(format_f64(1.5e-7), "1.5e-7");
/// assert_eq!(format_f64(f64::NAN), "NaN");
/// let x = 0.1 + 0.2;
/// assert_eq!(format_f64(x).parse::<f64>().unwrap(), x);
/// ```
pub fn format_f64(x: f64) -> String {
    let mut s = String::new();
    push_f64(&mut s, x);
    s
}

fn push_f64(out: &mut String, x: f64) {
    let a = x.abs();
    // Writing to a String cannot fail.
    if x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&a) {
        let _ = write!(out, "{x}");
    } else {
        let _ = write!(out, "{x:e}");
    }
}

/// Writes a CSV table row by row: a header line of column names, then one line of `f64` per
/// [`row`](CsvWriter::row) call.
///
/// Output is buffered; call [`finish`](CsvWriter::finish) (or [`flush`](CsvWriter::flush)) to
/// see write errors. Dropping the writer flushes too, but silently.
///
/// ```
/// use eulermembrane_cases::csv::{CsvWriter, read_columns};
/// # fn main() -> eulermembrane::Result<()> {
/// let path = std::env::temp_dir().join("eulermembrane_doc_csvwriter/series.csv");
/// let mut csv = CsvWriter::create(&path, &["t", "taylor_d"])?;
/// for step in 0..3 {
///     let t = 0.1 * step as f64;
///     csv.row(&[t, 0.5 * t])?;
/// }
/// csv.finish()?;
/// let table = read_columns(&path)?;
/// assert_eq!(table.column("taylor_d").unwrap().len(), 3);
/// # Ok(())
/// # }
/// ```
#[derive(Debug)]
pub struct CsvWriter {
    path: PathBuf,
    out: BufWriter<File>,
    columns: usize,
    line: String,
}

impl CsvWriter {
    /// Creates (or truncates) the file at `path`, with its parent directories, and writes the
    /// header line.
    ///
    /// Errors: [`Error::InvalidParameter`] if `header` is empty or a name contains a comma, a
    /// quote or a line break; [`Error::Io`] if the file cannot be created or written.
    ///
    /// ```
    /// use eulermembrane_cases::csv::CsvWriter;
    /// # fn main() -> eulermembrane::Result<()> {
    /// let path = std::env::temp_dir().join("eulermembrane_doc_csv_create/a.csv");
    /// let csv = CsvWriter::create(&path, &["x", "y"])?;
    /// assert_eq!(csv.columns(), 2);
    /// # Ok(())
    /// # }
    /// ```
    pub fn create(path: impl AsRef<Path>, header: &[&str]) -> Result<Self> {
        let path = path.as_ref();
        if header.is_empty() {
            return Err(Error::invalid("header", "[]", "at least one column name"));
        }
        if let Some(bad) = header.iter().find(|h| h.contains([',', '"', '\n', '\r'])) {
            return Err(Error::invalid(
                "header",
                format!("{bad:?}"),
                "column names without commas, quotes or line breaks",
            ));
        }
        create_parent_dirs(path)?;
        let file = File::create(path).map_err(|e| io_error(path, e))?;
        let mut writer = CsvWriter {
            path: path.to_path_buf(),
            out: BufWriter::new(file),
            columns: header.len(),
            line: String::new(),
        };
        writer.line = header.join(",");
        writer.line.push('\n');
        writer.write_line()?;
        Ok(writer)
    }

    /// Appends one row. `values` must hold one number per header column.
    ///
    /// Errors: [`Error::InvalidParameter`] on a wrong number of values; [`Error::Io`] on a
    /// write failure.
    ///
    /// ```
    /// use eulermembrane_cases::csv::CsvWriter;
    /// # fn main() -> eulermembrane::Result<()> {
    /// let path = std::env::temp_dir().join("eulermembrane_doc_csv_row/a.csv");
    /// let mut csv = CsvWriter::create(&path, &["x", "y"])?;
    /// csv.row(&[1.0, 2.0])?;
    /// assert!(csv.row(&[1.0]).is_err());
    /// # Ok(())
    /// # }
    /// ```
    pub fn row(&mut self, values: &[f64]) -> Result<()> {
        if values.len() != self.columns {
            return Err(Error::invalid(
                "row",
                format!("{} values for {} columns", values.len(), self.columns),
                "one value per header column",
            ));
        }
        self.line.clear();
        for (k, &v) in values.iter().enumerate() {
            if k > 0 {
                self.line.push(',');
            }
            push_f64(&mut self.line, v);
        }
        self.line.push('\n');
        self.write_line()
    }

    /// Number of columns (the length of the header).
    ///
    /// ```
    /// use eulermembrane_cases::csv::CsvWriter;
    /// # fn main() -> eulermembrane::Result<()> {
    /// let path = std::env::temp_dir().join("eulermembrane_doc_csv_columns/a.csv");
    /// assert_eq!(CsvWriter::create(&path, &["t", "a", "b"])?.columns(), 3);
    /// # Ok(())
    /// # }
    /// ```
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// The path written to.
    ///
    /// ```
    /// use eulermembrane_cases::csv::CsvWriter;
    /// # fn main() -> eulermembrane::Result<()> {
    /// let path = std::env::temp_dir().join("eulermembrane_doc_csv_path/a.csv");
    /// assert_eq!(CsvWriter::create(&path, &["t"])?.path(), path.as_path());
    /// # Ok(())
    /// # }
    /// ```
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes buffered rows to the file, so that a running simulation's table can be read
    /// while it grows.
    ///
    /// ```
    /// use eulermembrane_cases::csv::CsvWriter;
    /// # fn main() -> eulermembrane::Result<()> {
    /// let path = std::env::temp_dir().join("eulermembrane_doc_csv_flush/a.csv");
    /// let mut csv = CsvWriter::create(&path, &["t"])?;
    /// csv.row(&[0.5])?;
    /// csv.flush()?;
    /// assert_eq!(std::fs::read_to_string(&path).unwrap(), "t\n0.5\n");
    /// # Ok(())
    /// # }
    /// ```
    pub fn flush(&mut self) -> Result<()> {
        self.out.flush().map_err(|e| io_error(&self.path, e))
    }

    /// Flushes and closes the file.
    ///
    /// ```
    /// use eulermembrane_cases::csv::CsvWriter;
    /// # fn main() -> eulermembrane::Result<()> {
    /// let path = std::env::temp_dir().join("eulermembrane_doc_csv_finish/a.csv");
    /// let mut csv = CsvWriter::create(&path, &["t"])?;
    /// csv.row(&[1.0])?;
    /// csv.finish()?;
    /// # Ok(())
    /// # }
    /// ```
    pub fn finish(mut self) -> Result<()> {
        self.flush()
    }

    fn write_line(&mut self) -> Result<()> {
        self.out.write_all(self.line.as_bytes()).map_err(|e| io_error(&self.path, e))
    }
}

/// Writes named columns of equal length as a CSV table in one call.
///
/// Errors: [`Error::InvalidParameter`] if `columns` is empty, the lengths differ or a name is
/// not a plain CSV field; [`Error::Io`] on a file failure.
///
/// ```
/// use eulermembrane_cases::csv::{read_columns, write_columns};
/// # fn main() -> eulermembrane::Result<()> {
/// let path = std::env::temp_dir().join("eulermembrane_doc_write_columns/profile.csv");
/// let y = [0.0, 0.5, 1.0];
/// let u = [0.0, 0.25, 1.0];
/// write_columns(&path, &[("y", &y), ("u", &u)])?;
/// assert_eq!(read_columns(&path)?.column("u"), Some(&u[..]));
/// # Ok(())
/// # }
/// ```
pub fn write_columns(path: impl AsRef<Path>, columns: &[(&str, &[f64])]) -> Result<()> {
    let Some(&(first_name, first)) = columns.first() else {
        return Err(Error::invalid("columns", "[]", "at least one (name, values) column"));
    };
    if let Some(&(name, values)) = columns.iter().find(|(_, v)| v.len() != first.len()) {
        return Err(Error::invalid(
            "columns",
            format!("`{name}` has {} values but `{first_name}` has {}", values.len(), first.len()),
            "columns of equal length",
        ));
    }
    let names: Vec<&str> = columns.iter().map(|(n, _)| *n).collect();
    let mut csv = CsvWriter::create(path, &names)?;
    let mut row = vec![0.0; columns.len()];
    for i in 0..first.len() {
        for (r, (_, values)) in row.iter_mut().zip(columns) {
            *r = values[i];
        }
        csv.row(&row)?;
    }
    csv.finish()
}

/// A table read by [`read_columns`]: column names and the values of each column.
///
/// ```
/// use eulermembrane_cases::csv::Table;
/// let table = Table { names: vec!["t".into()], columns: vec![vec![0.0, 0.1]] };
/// assert_eq!(table.column("t"), Some(&[0.0, 0.1][..]));
/// assert_eq!(table.rows(), 2);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// Column names, from the header line.
    pub names: Vec<String>,
    /// One vector of values per column, in header order.
    pub columns: Vec<Vec<f64>>,
}

impl Table {
    /// The values of the column called `name`, if there is one.
    ///
    /// ```
    /// use eulermembrane_cases::csv::Table;
    /// let names = vec!["x".to_string(), "y".to_string()];
    /// let table = Table { names, columns: vec![vec![1.0], vec![2.0]] };
    /// assert_eq!(table.column("y"), Some(&[2.0][..]));
    /// assert_eq!(table.column("z"), None);
    /// ```
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        let k = self.names.iter().position(|n| n == name)?;
        self.columns.get(k).map(Vec::as_slice)
    }

    /// Number of rows (0 for a table without columns).
    ///
    /// ```
    /// use eulermembrane_cases::csv::Table;
    /// assert_eq!(Table::default().rows(), 0);
    /// ```
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }
}

/// Reads a comma-separated table with a header line, as written by [`CsvWriter`].
///
/// Blank lines and lines starting with `#` are skipped; the first other line is the header.
/// Errors: [`Error::Io`] naming the path (and the line, for a malformed row: a field that is not
/// a number, or a row whose length differs from the header's).
///
/// ```
/// use eulermembrane_cases::csv::read_columns;
/// # fn main() -> eulermembrane::Result<()> {
/// let path = std::env::temp_dir().join("eulermembrane_doc_read_columns.csv");
/// std::fs::write(&path, "# a comment\nt,e\n0,1.5\n1,2.5\n").unwrap();
/// let table = read_columns(&path)?;
/// assert_eq!(table.names, ["t", "e"]);
/// assert_eq!(table.column("e"), Some(&[1.5, 2.5][..]));
/// # Ok(())
/// # }
/// ```
pub fn read_columns(path: impl AsRef<Path>) -> Result<Table> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| io_error(path, e))?;
    let mut table = Table::default();
    let mut fields = Vec::new();
    for (number, line) in data_lines(&text) {
        if table.names.is_empty() {
            table.names = line.split(',').map(|s| s.trim().to_string()).collect();
            table.columns = vec![Vec::new(); table.names.len()];
            continue;
        }
        parse_fields(path, number, line, &mut fields)?;
        if fields.len() != table.names.len() {
            return Err(line_error(
                path,
                number,
                format!("{} fields, but the header has {}", fields.len(), table.names.len()),
            ));
        }
        for (column, &v) in table.columns.iter_mut().zip(&fields) {
            column.push(v);
        }
    }
    Ok(table)
}

/// Reads `x, y` pairs from a two-column comma-separated file without header, such as a curve
/// digitised from a published figure.
///
/// Blank lines and lines starting with `#` are skipped. Errors: [`Error::Io`] naming the path,
/// and the line number for a line that is not two numbers.
///
/// ```
/// use eulermembrane_cases::csv::read_xy;
/// # fn main() -> eulermembrane::Result<()> {
/// let path = std::env::temp_dir().join("eulermembrane_doc_read_xy.csv");
/// std::fs::write(&path, "# t, D\n0.03, 0.0106\n\n0.075, 0.032\n").unwrap();
/// assert_eq!(read_xy(&path)?, vec![(0.03, 0.0106), (0.075, 0.032)]);
/// # Ok(())
/// # }
/// ```
pub fn read_xy(path: impl AsRef<Path>) -> Result<Vec<(f64, f64)>> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| io_error(path, e))?;
    let mut points = Vec::new();
    let mut fields = Vec::new();
    for (number, line) in data_lines(&text) {
        parse_fields(path, number, line, &mut fields)?;
        match fields[..] {
            [x, y] => points.push((x, y)),
            _ => {
                return Err(line_error(
                    path,
                    number,
                    format!("expected 2 comma-separated numbers, found {}", fields.len()),
                ));
            }
        }
    }
    Ok(points)
}

/// The lines that hold data, with their 1-based line numbers: trimmed, not blank, not `#`.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(k, line)| (k + 1, line.trim()))
        .filter(|(_, line)| !line.is_empty() && !line.starts_with('#'))
}

fn parse_fields(path: &Path, number: usize, line: &str, fields: &mut Vec<f64>) -> Result<()> {
    fields.clear();
    for field in line.split(',') {
        let field = field.trim();
        let v = field
            .parse::<f64>()
            .map_err(|_| line_error(path, number, format!("expected a number, found `{field}`")))?;
        fields.push(v);
    }
    Ok(())
}

fn line_error(path: &Path, number: usize, what: String) -> Error {
    io_error(path, format!("line {number}: {what}"))
}
