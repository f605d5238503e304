//! Writing legacy `.sto` files exactly as OpenSim's `Storage::print` (§1.1).

use super::Storage;
use crate::error::{Error, Location, Result};
use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// OpenSim's default output precision (`IO::GetPrecision()`, AnalyzeTool
/// `output_precision` default).
pub const DEFAULT_PRECISION: usize = 8;

/// Width reserved for the row count after `nRows=`; the number is followed
/// by spaces up to this width so it can be rewritten in place. OpenSim's
/// legacy reader trims the line and its `TimeSeriesTable` reader trims the
/// value, so both accept the padding.
const NROWS_WIDTH: usize = 12;

/// Format `x` as C `printf("%W.Pf", x)` does with glibc: fixed point,
/// `prec` decimals, right-aligned in `width` characters; `-0.000…` for
/// negative values that round to zero (and for -0.0), `nan`/`-nan`, `inf`/`-inf`.
pub fn format_c_fixed(x: f64, width: usize, prec: usize) -> String {
    let body = if x.is_nan() {
        if x.is_sign_negative() {
            "-nan".to_string()
        } else {
            "nan".to_string()
        }
    } else if x.is_infinite() {
        if x < 0.0 {
            "-inf".to_string()
        } else {
            "inf".to_string()
        }
    } else {
        // Rust's fixed-precision formatting is exact with round-half-even on
        // the exact binary value, as glibc's printf; it prints the sign of
        // negative values that round to zero, as glibc does.
        format!("{x:.prec$}")
    };
    format!("{body:>width$}")
}

/// A legacy `.sto` file being written row by row.
///
/// After every [`write_row`](Self::write_row) the file on disk is a complete,
/// valid storage holding every row written so far: the row is written with a
/// single `write` call and then the fixed-width `nRows=` field is rewritten
/// in place.
pub struct StoWriter {
    file: File,
    path: PathBuf,
    n_labels: usize,
    precision: usize,
    n_rows: usize,
    /// Byte offset of the digits after `nRows=`.
    n_rows_offset: u64,
    line: String,
}

impl StoWriter {
    /// Create (truncate) `path` and write the header: name line, `version=1`,
    /// `nRows=`, `nColumns=` (labels + 1 for time), `inDegrees=`, the
    /// description verbatim (a newline added if missing; nothing if empty),
    /// `endheader` and the label line `time\t<labels…>`.
    /// Numbers are written as C `%{8+precision}.{precision}f`.
    pub fn create(
        path: &Path,
        name: &str,
        description: &str,
        labels: &[String],
        precision: usize,
        in_degrees: bool,
    ) -> Result<StoWriter> {
        let at = || Location::file(path);
        if name.contains(['\n', '\r']) {
            return Err(Error::input(
                at(),
                format!("storage name {name:?} must be a single line"),
            ));
        }
        for l in labels {
            if l.is_empty() || l.contains(char::is_whitespace) {
                return Err(Error::input(
                    at(),
                    format!("column label {l:?} is empty or contains white space; OpenSim's reader splits labels on spaces and tabs"),
                ));
            }
        }
        if description
            .lines()
            .any(|l| l.trim_matches([' ', '\t']) == "endheader")
        {
            return Err(Error::input(
                at(),
                "the description must not contain an 'endheader' line",
            ));
        }
        let mut head = String::new();
        head.push_str(name);
        head.push_str("\nversion=1\nnRows=");
        let n_rows_offset = head.len() as u64;
        head.push_str(&format!("{:<NROWS_WIDTH$}", 0));
        head.push_str(&format!("\nnColumns={}\n", labels.len() + 1));
        head.push_str(if in_degrees {
            "inDegrees=yes\n"
        } else {
            "inDegrees=no\n"
        });
        if !description.is_empty() {
            head.push_str(description);
            if !description.ends_with('\n') {
                head.push('\n');
            }
        }
        head.push_str("endheader\ntime");
        for l in labels {
            head.push('\t');
            head.push_str(l);
        }
        head.push('\n');
        let mut file = File::create(path).map_err(|e| Error::io(path, e))?;
        file.write_all(head.as_bytes())
            .map_err(|e| Error::io(path, e))?;
        Ok(StoWriter {
            file,
            path: path.to_path_buf(),
            n_labels: labels.len(),
            precision,
            n_rows: 0,
            n_rows_offset,
            line: String::new(),
        })
    }

    /// Append one row (time, then one value per label) and update `nRows=`.
    /// A wrong number of values is an internal error (the caller built the row).
    pub fn write_row(&mut self, t: f64, values: &[f64]) -> Result<()> {
        if values.len() != self.n_labels {
            return Err(Error::internal(format!(
                "writing {}: row has {} values but the file has {} columns",
                self.path.display(),
                values.len(),
                self.n_labels
            )));
        }
        let (w, p) = (8 + self.precision, self.precision);
        self.line.clear();
        self.line.push_str(&format_c_fixed(t, w, p));
        for &v in values {
            self.line.push('\t');
            self.line.push_str(&format_c_fixed(v, w, p));
        }
        self.line.push('\n');
        let io = |e| Error::io(&self.path, e);
        self.file.write_all(self.line.as_bytes()).map_err(io)?;
        self.n_rows += 1;
        let count = format!("{:<NROWS_WIDTH$}", self.n_rows);
        if count.len() > NROWS_WIDTH {
            return Err(Error::internal(format!(
                "writing {}: more than {} rows",
                self.path.display(),
                "9".repeat(NROWS_WIDTH)
            )));
        }
        self.file
            .seek(SeekFrom::Start(self.n_rows_offset))
            .map_err(io)?;
        self.file.write_all(count.as_bytes()).map_err(io)?;
        self.file.seek(SeekFrom::End(0)).map_err(io)?;
        Ok(())
    }

    /// Number of rows written so far.
    pub fn rows_written(&self) -> usize {
        self.n_rows
    }

    /// Flush to disk and close.
    pub fn finish(mut self) -> Result<()> {
        self.file.flush().map_err(|e| Error::io(&self.path, e))?;
        self.file.sync_all().map_err(|e| Error::io(&self.path, e))
    }
}

/// Write a whole [`Storage`] in the legacy format with `precision` decimals.
///
/// The description is made of the storage's metadata: `key=value` lines
/// first, then the free text stored under `header`.
pub fn write(path: &Path, st: &Storage, precision: usize) -> Result<()> {
    let mut description = String::new();
    for (k, v) in &st.metadata {
        if k != "header" {
            description.push_str(&format!("{k}={v}\n"));
        }
    }
    if let Some(h) = st.meta("header") {
        description.push_str(h);
    }
    let mut w = StoWriter::create(
        path,
        &st.name,
        &description,
        &st.labels,
        precision,
        st.in_degrees,
    )?;
    for (t, row) in st.time.iter().zip(&st.rows) {
        w.write_row(*t, row)?;
    }
    w.finish()
}
