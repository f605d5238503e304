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
/// `x` to `prec` decimals, exactly and rounded half to even on the exact
/// binary value, for the common case |x| < 2^53 with at most 120 fractional
/// bits; None otherwise (then std's exact formatting is used). Much faster
/// than std's Dragon fallback for long precisions (OpenSim setups often ask
/// for 20 decimals).
fn fixed_exact_fast(x: f64, prec: usize) -> Option<String> {
    let bits = x.to_bits();
    let negative = bits >> 63 == 1;
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let mantissa = bits & ((1u64 << 52) - 1);
    if biased == 0 || biased == 0x7ff || prec > 40 {
        return None; // zero, subnormal, inf/nan, or unusual precision
    }
    let m = (mantissa | (1u64 << 52)) as u128;
    let e = biased - 1075; // x = m · 2^e
    if e >= 0 || -e > 120 {
        return None;
    }
    let shift = (-e) as u32;
    let mask = (1u128 << shift) - 1;
    let mut int_part = m >> shift;
    let mut f = m & mask;
    let mut digits: Vec<u8> = Vec::with_capacity(prec);
    for _ in 0..prec {
        f *= 10;
        digits.push((f >> shift) as u8);
        f &= mask;
    }
    let half = 1u128 << (shift - 1);
    let last_odd = match digits.last() {
        Some(d) => d % 2 == 1,
        None => int_part % 2 == 1,
    };
    if f > half || (f == half && last_odd) {
        let mut i = digits.len();
        loop {
            if i == 0 {
                int_part += 1;
                break;
            }
            i -= 1;
            if digits[i] == 9 {
                digits[i] = 0;
            } else {
                digits[i] += 1;
                break;
            }
        }
    }
    let mut out = String::with_capacity(prec + 24);
    if negative {
        out.push('-');
    }
    out.push_str(&int_part.to_string());
    if prec > 0 {
        out.push('.');
        out.extend(digits.iter().map(|d| (b'0' + d) as char));
    }
    Some(out)
}

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
        // negative values that round to zero, as glibc does. The fast path
        // computes the same digits with integer arithmetic.
        fixed_exact_fast(x, prec).unwrap_or_else(|| format!("{x:.prec$}"))
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

    /// [`Self::create`] with two header lines in front of the description
    /// that say what wrote the file: `statopt_version=` and `statopt_setup=`
    /// (key=value lines: OpenSim's Storage skips them, its TimeSeriesTable
    /// keeps them as metadata).
    pub fn create_for_setup(
        setup: &Path,
        path: &Path,
        name: &str,
        description: &str,
        labels: &[String],
        precision: usize,
        in_degrees: bool,
    ) -> Result<StoWriter> {
        let setup = std::path::absolute(setup).unwrap_or_else(|_| setup.to_path_buf());
        let head = format!(
            "statopt_version={}\nstatopt_setup={}\n{description}",
            env!("CARGO_PKG_VERSION"),
            setup.display()
        );
        Self::create(path, name, &head, labels, precision, in_degrees)
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

    /// Reopen a table this writer wrote, keep its first `keep` rows (all of
    /// them complete) and go on writing after them: for `--resume`. The
    /// label line must hold `n_labels` labels after `time`.
    pub fn resume(
        path: &Path,
        n_labels: usize,
        precision: usize,
        keep: usize,
    ) -> Result<StoWriter> {
        let at = || Location::file(path);
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let text = String::from_utf8_lossy(&bytes);
        let n_rows_offset = text
            .find("\nnRows=")
            .map(|i| (i + "\nnRows=".len()) as u64)
            .ok_or_else(|| Error::input(at(), "cannot resume: no nRows= line"))?;
        let end = text
            .find("\nendheader\n")
            .map(|i| i + "\nendheader\n".len())
            .ok_or_else(|| Error::input(at(), "cannot resume: no endheader line"))?;
        let labels_end = text[end..]
            .find('\n')
            .map(|i| end + i + 1)
            .ok_or_else(|| Error::input(at(), "cannot resume: no column labels"))?;
        let found = text[end..labels_end].trim_end().split('\t').count();
        if found != n_labels + 1 {
            return Err(Error::input(
                at(),
                format!(
                    "cannot resume: the table has {found} columns, this run writes {}",
                    n_labels + 1
                ),
            ));
        }
        let mut offset = labels_end;
        for k in 0..keep {
            offset = text[offset..]
                .find('\n')
                .map(|i| offset + i + 1)
                .ok_or_else(|| {
                    Error::input(at(), format!("cannot resume: only {k} complete rows"))
                })?;
        }
        let io = |e| Error::io(path, e);
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .map_err(io)?;
        file.set_len(offset as u64).map_err(io)?;
        file.seek(SeekFrom::Start(n_rows_offset)).map_err(io)?;
        file.write_all(format!("{keep:<NROWS_WIDTH$}").as_bytes())
            .map_err(io)?;
        file.seek(SeekFrom::End(0)).map_err(io)?;
        Ok(StoWriter {
            file,
            path: path.to_path_buf(),
            n_labels,
            precision,
            n_rows: keep,
            n_rows_offset,
            line: String::new(),
        })
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

#[cfg(test)]
mod fast_format_tests {
    use super::fixed_exact_fast;

    /// The fast path equals std's exact formatting digit for digit.
    #[test]
    fn fast_fixed_formatting_equals_std() {
        let mut state = 0x9E3779B97F4A7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut checked = 0;
        for _ in 0..400_000 {
            let r = next();
            // random magnitudes from 1e-12 to 1e12, random signs, and exact binary ties
            let x = match r % 4 {
                0 => f64::from_bits(r >> 2) % 1e12,
                1 => {
                    ((r >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
                        * 10f64.powi((r % 25) as i32 - 12)
                }
                2 => ((r >> 20) % 100_000) as f64 / 8.0 - 5000.0,
                _ => ((r >> 30) % 1000) as f64 * 0.001 - 0.5,
            };
            if !x.is_finite() {
                continue;
            }
            for prec in [0usize, 1, 2, 3, 8, 12, 16, 20] {
                if let Some(fast) = fixed_exact_fast(x, prec) {
                    assert_eq!(fast, format!("{x:.prec$}"), "x = {x:e}, prec {prec}");
                    checked += 1;
                }
            }
        }
        assert!(
            checked > 1_000_000,
            "only {checked} values took the fast path"
        );
    }
}

/// Number of complete data rows of a table a [`StoWriter`] wrote (lines
/// after the label line that end in a newline); 0 when there is no file.
pub fn complete_rows(path: &Path) -> Result<usize> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(Error::io(path, e)),
    };
    let text = String::from_utf8_lossy(&bytes);
    let Some(end) = text
        .find("\nendheader\n")
        .map(|i| i + "\nendheader\n".len())
    else {
        return Ok(0);
    };
    let Some(labels_end) = text[end..].find('\n').map(|i| end + i + 1) else {
        return Ok(0);
    };
    Ok(text[labels_end..].matches('\n').count())
}
