//! Writing legacy `.sto` files exactly as OpenSim's `Storage::print` (§1.1).

use super::Storage;
use crate::error::{Error, Location, Result};
use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

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
///
/// [`push_c_fixed`] appends the same bytes to a buffer.
pub fn format_c_fixed(x: f64, width: usize, prec: usize) -> String {
    let mut out = Vec::with_capacity(width.max(prec + 24));
    push_c_fixed(&mut out, x, width, prec);
    // Only ASCII digits, signs, '.', spaces and nan/inf are written.
    String::from_utf8(out).expect("ASCII")
}

/// Create `path` for writing, empty, as `File::create` does, but replace an
/// existing regular file by a new one (unlink, then create) instead of
/// truncating it in place.
///
/// On ext4, truncating a file to zero and writing it again makes its
/// `close` start the file's writeback (the `auto_da_alloc` safeguard), and
/// the next run's truncation then waits for that writeback: rerunning
/// gait2392's static optimization into the same folder spent most of its
/// excess wall time there. A new file is written back in the background
/// like any other. A symbolic link, a file with other hard links or one
/// the folder does not let us remove is truncated in place as before, so
/// that what the path leads to is still what gets written; a replaced
/// file takes the default permissions of a new one.
pub fn create_output(path: &Path) -> std::io::Result<File> {
    if let Ok(meta) = std::fs::symlink_metadata(path) {
        if meta.file_type().is_file() && single_link(&meta) {
            // Failing to remove it, truncate it in place (File::create).
            let _ = std::fs::remove_file(path);
        }
    }
    File::create(path)
}

#[cfg(unix)]
fn single_link(meta: &std::fs::Metadata) -> bool {
    std::os::unix::fs::MetadataExt::nlink(meta) == 1
}

#[cfg(not(unix))]
fn single_link(_meta: &std::fs::Metadata) -> bool {
    false
}

/// Two-digit pairs "00".."99", for writing decimal digits two at a time.
const DIGIT_PAIRS: &[u8; 200] = b"\
0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// The eight decimal digits of `v` < 10^8, as ASCII, most significant
/// first: both halves, then their digit pairs, then the digits, are split in
/// parallel lanes of one u64 (division by 100 and by 10 as a multiply and
/// shift, exact in this range).
#[inline]
fn eight_digits(v: u32) -> [u8; 8] {
    let v = v as u64;
    let x = (v / 10_000) | ((v % 10_000) << 32);
    let hundreds = ((x * 10_486) >> 20) & 0x0000_007F_0000_007F;
    let y = hundreds | ((x - hundreds * 100) << 16);
    let tens = ((y * 103) >> 10) & 0x000F_000F_000F_000F;
    let z = tens | ((y - tens * 10) << 8);
    (z | 0x3030_3030_3030_3030).to_le_bytes()
}

/// The four decimal digits of `v` < 10^4, as ASCII, most significant
/// first ([`eight_digits`]' lanes, two of them in one u32).
#[inline]
fn four_digits(v: u32) -> [u8; 4] {
    let x = (v / 100) | ((v % 100) << 16);
    let tens = ((x * 103) >> 10) & 0x000F_000F;
    let z = tens | ((x - tens * 10) << 8);
    (z | 0x3030_3030).to_le_bytes()
}

/// Write `v` as exactly `out.len()` decimal digits (leading zeros; `v`
/// must be below 10^len).
#[inline(always)]
fn put_digits(out: &mut [u8], mut v: u64) {
    // Up to 8 digits and the usual 16 without loops: the last digits of
    // one lane conversion, copied with a fixed length per case.
    match out.len() {
        1 => {
            out[0] = b'0' + v as u8;
            return;
        }
        2 => {
            out.copy_from_slice(&four_digits(v as u32)[2..]);
            return;
        }
        3 => {
            out.copy_from_slice(&four_digits(v as u32)[1..]);
            return;
        }
        4 => {
            out.copy_from_slice(&four_digits(v as u32));
            return;
        }
        5 => {
            out.copy_from_slice(&eight_digits(v as u32)[3..]);
            return;
        }
        6 => {
            out.copy_from_slice(&eight_digits(v as u32)[2..]);
            return;
        }
        7 => {
            out.copy_from_slice(&eight_digits(v as u32)[1..]);
            return;
        }
        8 => {
            out.copy_from_slice(&eight_digits(v as u32));
            return;
        }
        16 => {
            out[..8].copy_from_slice(&eight_digits((v / 100_000_000) as u32));
            out[8..].copy_from_slice(&eight_digits((v % 100_000_000) as u32));
            return;
        }
        _ => {}
    }
    let mut i = out.len();
    while i >= 8 {
        out[i - 8..i].copy_from_slice(&eight_digits((v % 100_000_000) as u32));
        v /= 100_000_000;
        i -= 8;
    }
    while i >= 2 {
        let pair = (v % 100) as usize * 2;
        v /= 100;
        out[i - 2] = DIGIT_PAIRS[pair];
        out[i - 1] = DIGIT_PAIRS[pair + 1];
        i -= 2;
    }
    if i == 1 {
        out[0] = b'0' + (v % 10) as u8;
    }
}

/// Number of decimal digits of `v` (1 for 0).
#[inline]
fn decimal_len(v: u64) -> usize {
    let mut n = 1;
    let mut p = 10u64;
    while n < 20 && v >= p {
        n += 1;
        p = p.wrapping_mul(10);
    }
    n
}

/// 5^k for k <= 27 (5^27 < 2^63).
const POW5: [u64; 28] = {
    let mut t = [1u64; 28];
    let mut k = 1;
    while k < 28 {
        t[k] = t[k - 1] * 5;
        k += 1;
    }
    t
};

/// 10^k for k <= 19.
const POW10: [u64; 20] = {
    let mut t = [1u64; 20];
    let mut k = 1;
    while k < 20 {
        t[k] = t[k - 1] * 10;
        k += 1;
    }
    t
};

/// `r / 2^s` (a fraction: r < 2^s, s <= 120) times 10^k, k <= 19: the
/// integer part and the remainder as (r', s'), exactly.
#[inline]
fn fraction_times_pow10(r: u128, s: u32, k: u32) -> (u64, u128, u32) {
    // r · 10^k / 2^s = r · 5^k / 2^(s-k)
    let prod = r * POW5[k as usize] as u128;
    if s >= k {
        let sh = s - k;
        ((prod >> sh) as u64, prod & ((1u128 << sh) - 1), sh)
    } else {
        ((prod << (k - s)) as u64, 0, 0)
    }
}

/// Most decimals of the integer fast path: m · 5^p < 2^128 for every
/// 53-bit m needs p <= 32.
const FAST_MAX_PREC: usize = 32;

/// Append `x` to `prec` decimals, right-aligned in `width`, exactly and
/// rounded half to even on the exact binary value (as glibc's `%W.Pf`),
/// with integer arithmetic: for finite x with |x| < 2^64 and prec <= 32,
/// except |x| in about [2^-68·2^-prec, 2^-68) and fields over 96 bytes
/// (returns false, appends nothing).
///
/// x = m·2^e; the integer part is m >> -e, the fraction f / 2^s. Its
/// digits are floor(f · 10^k / 2^s) = (f · 5^k) >> (s − k), in one or two
/// steps of at most 19 digits so that every product stays below
/// 2^53 · 5^32 < 2^128; the last remainder rounds.
fn push_fixed_fast(out: &mut Vec<u8>, x: f64, width: usize, prec: usize) -> bool {
    if prec > FAST_MAX_PREC {
        return false;
    }
    let bits = x.to_bits();
    let negative = bits >> 63 == 1;
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let low = bits & ((1u64 << 52) - 1);
    if biased == 0x7ff {
        return false;
    }
    let (m, e) = if biased == 0 {
        (low, -1074)
    } else {
        (low | (1u64 << 52), biased - 1075)
    };
    let p = prec as u32;
    let (mut int_part, f, s) = if e >= 0 {
        if e > 11 {
            return false; // |x| >= 2^64
        }
        (m << e, 0u64, 0u32)
    } else {
        let s = (-e) as u32;
        if s > 120 {
            // x < 2^53 · 2^-s; times 10^p that is below 2^53 · 5^p · 2^(p-s)
            // < 2^(128+p-s) <= 1/2 when s >= p + 129: every digit 0, no tie.
            if s < p + 129 {
                return false;
            }
            (0, 0, 0)
        } else if s >= 64 {
            (0, m, s)
        } else {
            (m >> s, m & ((1u64 << s) - 1), s)
        }
    };
    let (k1, k2, d1, d2) = if (1..=ONE_STEP_MAX_PREC).contains(&p) {
        // One step: f / 2^s · 10^p = f · 5^p / 2^(s−p), and f · 5^p <
        // 2^53 · 5^23 < 2^107: the digits and the rounding remainder at
        // once.
        let prod = f as u128 * POW5[p as usize] as u128;
        let (mut q, rem, sh) = if s >= p {
            let sh = s - p;
            (prod >> sh, prod & ((1u128 << sh) - 1), sh)
        } else {
            (prod << (p - s), 0, 0)
        };
        if sh > 0 {
            let half = 1u128 << (sh - 1);
            if rem > half || (rem == half && q & 1 == 1) {
                q += 1;
                if q == (POW5[p as usize] as u128) << p {
                    q = 0;
                    int_part += 1;
                }
            }
        }
        if p <= 19 {
            (p, 0, q as u64, 0)
        } else {
            // q < 10^23: the first p − 16 digits are (q >> 16) / 5^16
            // (below 2^61), the last 16 the rest.
            let hi = ((q >> 16) as u64) / POW5[16];
            let lo = (q as u64).wrapping_sub(hi.wrapping_mul(POW10[16]));
            (p - 16, 16, hi, lo)
        }
    } else {
        fraction_two_steps(f, s, p, &mut int_part)
    };
    let int_len = decimal_len(int_part);
    let len = usize::from(negative) + int_len + if p > 0 { 1 + prec } else { 0 };
    // Right-aligned in `width`: spaces, then the body, built in a local
    // buffer and appended at once.
    const CAP: usize = 96;
    let total = len.max(width);
    if total > CAP {
        return false;
    }
    let mut buf = [b' '; CAP];
    let mut i = CAP - len;
    if negative {
        buf[i] = b'-';
        i += 1;
    }
    put_digits(&mut buf[i..i + int_len], int_part);
    i += int_len;
    if p > 0 {
        buf[i] = b'.';
        i += 1;
        put_digits(&mut buf[i..i + k1 as usize], d1);
        i += k1 as usize;
        put_digits(&mut buf[i..i + k2 as usize], d2);
    }
    out.extend_from_slice(&buf[CAP - total..]);
    true
}

/// Most decimals [`push_fixed_fast`] writes in one step (one product below
/// 2^128 and a quotient below 2^61 · 10^16).
const ONE_STEP_MAX_PREC: u32 = 23;

/// The `p` fraction digits of f / 2^s in (at most) two groups of k1 and k2
/// digits, rounded half to even (a carry out of the fraction goes to
/// `int_part`): (k1, k2, first group, second group).
fn fraction_two_steps(f: u64, s: u32, p: u32, int_part: &mut u64) -> (u32, u32, u64, u64) {
    // Fraction digits in (at most) two groups, then the rounding remainder.
    // The second step multiplies a remainder below 2^(s-k1) <= 2^(120-k1)
    // by 5^k2: below 2^128 while 2.33·k2 <= 8 + k1, so a first group of 16
    // (written as two blocks of eight) serves up to 26 decimals.
    let (k1, k2) = if p <= 19 {
        (p, 0)
    } else if p <= 26 {
        (16, p - 16)
    } else {
        (p / 2, p - p / 2)
    };
    let (mut d1, rem, sh) = fraction_times_pow10(f as u128, s, k1);
    let (mut d2, rem, sh) = if k2 > 0 {
        fraction_times_pow10(rem, sh, k2)
    } else {
        (0, rem, sh)
    };
    if sh > 0 {
        let half = 1u128 << (sh - 1);
        let last_odd = if k2 > 0 {
            d2 & 1 == 1
        } else if k1 > 0 {
            d1 & 1 == 1
        } else {
            *int_part & 1 == 1
        };
        if rem > half || (rem == half && last_odd) {
            // Add one unit in the last place, carrying leftwards.
            if k2 > 0 {
                d2 += 1;
                if d2 == POW10[k2 as usize] {
                    d2 = 0;
                    d1 += 1;
                }
            } else {
                d1 += 1;
            }
            if k1 > 0 && d1 == POW10[k1 as usize] {
                d1 = 0;
                *int_part += 1;
            } else if k1 == 0 {
                *int_part += 1;
            }
        }
    }
    (k1, k2, d1, d2)
}

/// Append `x` as C `printf("%W.Pf", x)` with glibc (see [`format_c_fixed`]).
pub fn push_c_fixed(out: &mut Vec<u8>, x: f64, width: usize, prec: usize) {
    if !push_fixed_fast(out, x, width, prec) {
        let body: std::borrow::Cow<str> = if x.is_nan() {
            if x.is_sign_negative() {
                "-nan".into()
            } else {
                "nan".into()
            }
        } else if x.is_infinite() {
            if x < 0.0 {
                "-inf".into()
            } else {
                "inf".into()
            }
        } else {
            format!("{x:.prec$}").into()
        };
        let pad = width.saturating_sub(body.len());
        out.resize(out.len() + pad, b' ');
        out.extend_from_slice(body.as_bytes());
    }
}

/// Write `bytes` at `offset` and leave the file position at the end of the
/// file (where the next row goes): one `pwrite` on Unix.
#[cfg(unix)]
fn write_at(file: &mut File, bytes: &[u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::write_all_at(file, bytes, offset)
}

#[cfg(not(unix))]
fn write_at(file: &mut File, bytes: &[u8], offset: u64) -> std::io::Result<()> {
    file.seek(SeekFrom::Start(offset))?;
    file.write_all(bytes)?;
    file.seek(SeekFrom::End(0)).map(|_| ())
}

/// A legacy `.sto` file being written row by row.
///
/// After every [`write_row`](Self::write_row) the file on disk is a complete,
/// valid storage holding every row written so far: the row is written with a
/// single `write` call and then the fixed-width `nRows=` field is rewritten
/// in place. With [`batch_rows`](Self::batch_rows) rows are written in
/// batches instead; the file on disk is then a complete, valid storage of
/// every row up to the last batch.
pub struct StoWriter {
    /// The file (None: a run kept in memory only, `super::results`).
    file: Option<File>,
    /// The table as typed values, when a capture keeps the run's outputs
    /// (`super::results`): its header and each row as the file prints it,
    /// built as the rows are formatted; at [`Self::finish`] it becomes the
    /// output the run's own consumers read instead of the file.
    kept: Option<super::results::KeptTable>,
    /// What the capture may still keep (`kept` is dropped when it runs out).
    budget: Option<super::results::Budget>,
    path: PathBuf,
    n_labels: usize,
    precision: usize,
    /// Rows given to [`Self::write_row`] (on disk or in `line`).
    n_rows: usize,
    /// Byte offset of the digits after `nRows=`.
    n_rows_offset: u64,
    /// Formatted rows not on disk yet (reused).
    line: Vec<u8>,
    batch: Option<Batch>,
}

/// When a batching [`StoWriter`] writes its rows (see [`StoWriter::batch_rows`]).
#[derive(Debug, Clone, Copy)]
struct Batch {
    rows: usize,
    max_age: Duration,
    last_write: Instant,
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
        let file = if super::results::writes_file(path) {
            let mut file = create_output(path).map_err(|e| Error::io(path, e))?;
            file.write_all(head.as_bytes())
                .map_err(|e| Error::io(path, e))?;
            Some(file)
        } else {
            None
        };
        let mut budget = super::results::budget(path);
        let kept = match budget
            .as_ref()
            .map(|_| super::results::KeptTable::new(path, head.as_bytes(), precision))
        {
            Some(Ok(k)) => Some(k),
            // A header the reader refuses: the file says so to its readers.
            Some(Err(e)) if file.is_none() => return Err(e),
            _ => {
                budget = None;
                None
            }
        };
        Ok(StoWriter {
            file,
            kept,
            budget,
            path: path.to_path_buf(),
            n_labels: labels.len(),
            precision,
            n_rows: 0,
            n_rows_offset,
            line: Vec::new(),
            batch: None,
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
        if decimal_len(self.n_rows as u64 + 1) > NROWS_WIDTH {
            return Err(Error::internal(format!(
                "writing {}: more than {} rows",
                self.path.display(),
                "9".repeat(NROWS_WIDTH)
            )));
        }
        let (w, p) = (8 + self.precision, self.precision);
        push_c_fixed(&mut self.line, t, w, p);
        for &v in values {
            self.line.push(b'\t');
            push_c_fixed(&mut self.line, v, w, p);
        }
        self.line.push(b'\n');
        self.n_rows += 1;
        if let (Some(kept), Some(budget)) = (&mut self.kept, &self.budget) {
            if budget.take(super::results::KeptTable::row_size(values.len())) {
                kept.push(t, values);
            } else if self.file.is_some() {
                // Past the capture's limit: the file is the table's.
                budget.give(kept.size() as usize);
                self.kept = None;
                self.budget = None;
            } else {
                return Err(Error::internal(format!(
                    "{}: a table kept in memory only ran out of its budget",
                    self.path.display()
                )));
            }
        }
        let due = match &self.batch {
            None => true,
            Some(b) => self.n_rows % b.rows == 0 || b.last_write.elapsed() >= b.max_age,
        };
        if due {
            self.write_pending()?;
        }
        Ok(())
    }

    /// Write rows in batches: every `rows`-th row writes the rows not yet
    /// on disk in one `write` call (and updates `nRows=`), and so does the
    /// first row at least `max_age` after the last write. Cheaper than a
    /// write per row; a killed process loses the rows of the open batch.
    /// Batches end at multiples of `rows` (counted from the file's first
    /// row), so tables written frame by frame with the same `rows` stay in
    /// step. [`Self::finish`] (or dropping the writer) writes the rest.
    pub fn batch_rows(&mut self, rows: usize, max_age: Duration) {
        // Room for a batch of rows whose numbers fill their width (the
        // buffer is reused: it no longer grows by copies into fresh
        // memory while the first batch is formatted); at most 4 MiB.
        let row = (self.n_labels + 1) * (8 + self.precision + 1);
        self.line.reserve(
            (rows.max(1) * row)
                .min(4 << 20)
                .saturating_sub(self.line.len()),
        );
        self.batch = Some(Batch {
            rows: rows.max(1),
            max_age,
            last_write: Instant::now(),
        });
    }

    /// Write the rows not yet on disk, then `nRows=`.
    fn write_pending(&mut self) -> Result<()> {
        if let Some(b) = &mut self.batch {
            b.last_write = Instant::now();
        }
        if self.line.is_empty() {
            return Ok(());
        }
        let count = self.n_rows_field();
        let Some(file) = &mut self.file else {
            self.line.clear();
            return Ok(());
        };
        let io = |e| Error::io(&self.path, e);
        let written = file.write_all(&self.line);
        self.line.clear();
        written.map_err(io)?;
        write_at(file, &count, self.n_rows_offset).map_err(io)
    }

    /// `nRows=`'s field: the count left-aligned, padded with spaces.
    fn n_rows_field(&self) -> [u8; NROWS_WIDTH] {
        let mut count = [b' '; NROWS_WIDTH];
        put_digits(
            &mut count[..decimal_len(self.n_rows as u64)],
            self.n_rows as u64,
        );
        count
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
        let bytes = super::source::read_bytes(path)?;
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
        // The kept rows are this run's output too (read from the earlier
        // run's file, as `--resume` reads it).
        let mut budget = super::results::budget(path);
        let mut kept = None;
        if let Some(b) = &budget {
            let mut head = bytes[..offset].to_vec();
            let at = n_rows_offset as usize;
            head[at..at + NROWS_WIDTH].copy_from_slice(format!("{keep:<NROWS_WIDTH$}").as_bytes());
            let first_line = bytes[..labels_end].iter().filter(|&&c| c == b'\n').count() + 1;
            let table = super::read::read_text(path, &head)?;
            let k = super::results::KeptTable::resumed(table, first_line, precision);
            if b.take(k.size() as usize) {
                kept = Some(k);
            } else {
                budget = None;
            }
        }
        Ok(StoWriter {
            file: Some(file),
            kept,
            budget,
            path: path.to_path_buf(),
            n_labels,
            precision,
            n_rows: keep,
            n_rows_offset,
            line: Vec::new(),
            batch: None,
        })
    }

    /// Number of rows written so far (with [`Self::batch_rows`], some of
    /// them may not be on disk yet).
    pub fn rows_written(&self) -> usize {
        self.n_rows
    }

    /// Write the pending rows and close the file, as OpenSim closes its
    /// tables: the bytes are in the file (a process killed after this loses
    /// nothing), the operating system puts them on the disk when it will.
    pub fn finish(mut self) -> Result<()> {
        self.write_pending()?;
        if let Some(file) = &mut self.file {
            file.flush().map_err(|e| Error::io(&self.path, e))?;
        }
        if let Some(kept) = self.kept.take() {
            super::results::keep(
                &self.path,
                super::results::Output::Table(std::sync::Arc::new(kept)),
            );
        }
        Ok(())
    }
}

impl Drop for StoWriter {
    /// A writer dropped without [`StoWriter::finish`] (a run stopped by an
    /// error) still writes its pending rows, as a row-by-row writer would
    /// have; errors cannot be reported here.
    fn drop(&mut self) {
        let _ = self.write_pending();
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
    use super::{format_c_fixed, push_c_fixed};

    /// The formatting this module had before the integer fast path was
    /// rewritten (std's exact formatting behind a digit-by-digit fast path),
    /// kept verbatim as the reference the new code must equal byte for byte.
    mod before {
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
    }

    fn check(x: f64, prec: usize) {
        for width in [0, 8 + prec, 100] {
            let want = before::format_c_fixed(x, width, prec);
            // std's exact formatting is the definition of the digits.
            if x.is_finite() {
                assert_eq!(want.trim_start(), format!("{x:.prec$}"));
            }
            let mut got = b"#".to_vec();
            push_c_fixed(&mut got, x, width, prec);
            assert_eq!(
                &got[1..],
                want.as_bytes(),
                "x = {x:e} (bits {:#018x}), width {width}, prec {prec}",
                x.to_bits()
            );
            assert_eq!(format_c_fixed(x, width, prec), want);
        }
    }

    /// The lane arithmetic of `four_digits`, and `put_digits` at every
    /// length up to 20, for every value below 10^4 (and 10^4 · k + 9999).
    #[test]
    fn four_digits_and_put_digits_of_every_value() {
        for v in 0..10_000u32 {
            let d = super::four_digits(v);
            let back = d
                .iter()
                .fold(0u32, |acc, &c| acc * 10 + u32::from(c.wrapping_sub(b'0')));
            assert!(d.iter().all(u8::is_ascii_digit) && back == v, "{v}: {d:?}");
        }
        for len in 0..=20usize {
            for v in (0..10_000u64).chain([123_456_789, u64::MAX / 7, u64::MAX]) {
                let v = if len < 20 {
                    v % 10u64.pow(len as u32)
                } else {
                    v
                };
                let mut got = vec![b'#'; len];
                super::put_digits(&mut got, v);
                let want = if len == 0 {
                    String::new()
                } else {
                    format!("{v:0len$}")
                };
                assert_eq!(got, want.as_bytes(), "len {len}, v {v}");
            }
        }
    }

    /// The lane arithmetic of `eight_digits`, for every value below 10^8.
    #[test]
    fn eight_digits_of_every_value() {
        for v in 0..100_000_000u32 {
            let d = super::eight_digits(v);
            let back = d
                .iter()
                .fold(0u32, |acc, &c| acc * 10 + u32::from(c.wrapping_sub(b'0')));
            assert!(d.iter().all(u8::is_ascii_digit) && back == v, "{v}: {d:?}");
        }
    }

    /// Powers of two over the whole exponent range, both sides of the fast
    /// path's limits (2^-68, 2^-120, 2^64), subnormals, zeros, non-finite
    /// values and decimal ties, at every precision 0..=40.
    #[test]
    fn fixed_formatting_of_special_values_equals_before() {
        let mut xs = vec![
            0.0,
            -0.0,
            f64::NAN,
            -f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::from_bits(1),
            -f64::from_bits(1),
            f64::from_bits((1 << 52) - 1),
            f64::MAX,
            f64::MIN,
            18446744073709549568.0, // largest double below 2^64
            18446744073709551616.0, // 2^64
            9007199254740991.5,
            4503599627370495.5,
            0.5,
            1.5,
            2.5,
            -0.5,
            0.125,
            0.375,
            0.05,
            0.15,
            0.25,
            0.35,
            9.5,
            99.5,
            999.9999999999999,
            1e-20,
            5e-21,
            4.9999999999999995e-21,
            5.000000000000001e-21,
        ];
        for k in 0..1100 {
            let p = 2f64.powi(-k);
            xs.extend([p, -3.0 * p, 2f64.powi(k.min(1023)), 0.999 * p, 1.001 * p]);
        }
        for x in xs {
            for prec in 0..=40 {
                check(x, prec);
            }
        }
    }

    /// Random doubles of every kind: random bit patterns (subnormals, huge,
    /// NaN), random magnitudes from 1e-25 to 1e25, exact binary ties,
    /// values next to decimal ties, and neighbours of round numbers.
    #[test]
    fn fixed_formatting_of_random_values_equals_before() {
        let mut state = 0x243F6A8885A308D3u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut checked = 0;
        for i in 0..300_000u64 {
            let r = next();
            let sign = if r >> 63 == 1 { -1.0 } else { 1.0 };
            let x = match i % 8 {
                0 => f64::from_bits(r),
                1 => f64::from_bits((r & !(0x7ff << 52)) | (((r >> 52) % 160 + 923) << 52)),
                2 => {
                    ((r >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
                        * 10f64.powi((r % 50) as i32 - 25)
                }
                3 => sign * ((r >> 20) % 1_000_000) as f64 / (1u64 << (r % 60)) as f64,
                4 => {
                    let k = ((r >> 8) % 100_000) as f64;
                    sign * (k + 0.5) / 10f64.powi((r % 25) as i32)
                }
                5 => f64::from_bits((r >> 12) | ((r & 1) << 63)),
                6 => {
                    let base = ((r >> 16) % 2000) as f64 * 0.001 - 1.0;
                    f64::from_bits(base.to_bits().wrapping_add(r % 7).wrapping_sub(3))
                }
                _ => sign * (r >> 1) as f64 * 1e-3,
            };
            for prec in [(r >> 40) as usize % 41, 20, 8] {
                check(x, prec);
                checked += 1;
            }
        }
        assert_eq!(checked, 900_000);
    }
}

/// Number of complete data rows of a table a [`StoWriter`] wrote (lines
/// after the label line that end in a newline); 0 when there is no file.
pub fn complete_rows(path: &Path) -> Result<usize> {
    if !path.exists() {
        return Ok(0);
    }
    let bytes = super::source::read_bytes(path)?;
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
